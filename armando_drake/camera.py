"""Camera sensors described in the URDF (Gazebo ``<sensor type="camera">`` blocks).

Placeholder until the camera work lands: parses nothing yet.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET


def parse_camera_sensors(root: ET.Element, source: str = "") -> list:
    """The camera sensor blocks of an expanded URDF."""
    return []
