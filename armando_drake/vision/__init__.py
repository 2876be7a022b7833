"""Vision: cameras on any link from the scenario, the ArUco marker object,
OpenCV detectors as Drake systems (blob, ArUco pose) and what the look-at-point
controllers read from them."""
