"""The scenario's ``vision:`` block: which detectors run on which camera.

::

    vision:
      blob: {camera: camera}                       # SimpleBlobDetector, the seed's parameters
      aruco: {camera: flange_camera, dictionary: DICT_ARUCO_ORIGINAL, marker_id: 201,
              side_length: 0.1}

(No ``from __future__ import annotations``: ``yaml_load_typed`` needs real types.)
"""

from dataclasses import dataclass

from armando_drake.tools.schema import param


@dataclass
class BlobDetectorConfig:
    """``cv2.SimpleBlobDetector`` on a camera's colour image (the seed's parameters)."""

    camera: str = "camera"  # the camera's name (a cameras: entry or the description's)
    # [grey level] first binarisation threshold
    min_threshold: float = param(1.0, unit="grey level")
    # [grey level] last binarisation threshold
    max_threshold: float = param(250.0, unit="grey level")
    threshold_step: float = param(1.0, unit="grey level")  # [grey level] between thresholds
    min_area: float = param(100.0, unit="px^2")  # [px^2] smallest blob kept
    # [-] 4 pi area / perimeter^2 of a blob kept, in [0, 1]
    min_circularity: float = param(0.8, unit="-")
    # Run OpenCV once per distinct binary image (thresholds between the same two grey
    # levels of the frame give the same one) and repeat its centres: the same keypoints
    # as SimpleBlobDetector over every threshold, much cheaper on a rendered frame.
    # false = SimpleBlobDetector as it is (for comparison).
    skip_repeated_thresholds: bool = True
    # [m] the true diameter of the blob's object (a disc): > 0 makes the largest
    # keypoint a target point for the look-at-point controllers (its ray, at the
    # distance where that diameter has the keypoint's size); 0 = no target. (Its range
    # is checked with the other blob targets, when the detectors are added.)
    target_diameter: float = param(0.0, unit="m")
    # Print the keypoints on the console once a second (not when logging.console_rate is 0).
    print_keypoints: bool = True


@dataclass
class ArucoDetectorConfig:
    """ArUco detection and pose estimation (``solvePnP``) on a camera's colour image."""

    camera: str = "camera"  # the camera's name
    dictionary: str = "DICT_ARUCO_ORIGINAL"  # OpenCV's predefined dictionary (DICT_*)
    marker_id: int = param(201, unit="-")  # the id of the marker whose pose is estimated
    side_length: float = param(0.1, unit="m")  # [m] side of the marker's black square
    # [m] with a navigation: the robot is sent this far in front of the marker, facing
    # it, once it has seen it `approach_after` times (vision/marker_goal.py); 0 = not
    # (the marker's pose on the map is still estimated).
    approach_distance: float = param(0.0, unit="m", ge=0)
    approach_after: int = param(10, unit="-", ge=1)  # detections before the goal is sent


@dataclass
class VisionConfig:
    """The detectors of the scenario; absent = none."""

    blob: BlobDetectorConfig | None = None  # the blob detector, absent = none
    aruco: ArucoDetectorConfig | None = None  # the ArUco detector, absent = none
    # [rad] where the robot's joints start (hardware joint order); empty = their
    # initial positions. (A vision scenario starts the arm looking away from the marker.)
    start_positions: list[float] = param([], unit="rad")
    # In a world of several robots (robots:), the name of the one it acts on; "" = the
    # first listed.
    robot: str = ""
