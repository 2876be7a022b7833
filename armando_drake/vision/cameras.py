"""Cameras on any link of the robot, from the scenario instead of the description.

A scenario's ``cameras:`` list gives the same fields as a ``<gazebo><sensor
type="camera">`` block, so a flange camera needs no edit of the robot's xacro::

    cameras:
    - name: flange_camera           # ports <name>.color_image, topics /<name>/...
      link: iiwa_link_7             # the link it is attached to
      xyz: [0.0, 0.0, 0.05]         # [m] sensor frame in the link
      rpy: [0.0, -1.5708, 0.0]      # [rad] (Gazebo: the camera looks along its +x)
      width: 640                    # [px]
      height: 480                   # [px]
      horizontal_fov: 1.047         # [rad]
      near: 0.05                    # [m]
      far: 10.0                     # [m]
      update_rate: 30.0             # [Hz]

Each entry becomes a :class:`~armando_drake.sensors.camera.CameraSensorInfo`, so
it is added, rendered and shown exactly like a camera of the description. (No
``from __future__ import annotations``: ``yaml_load_typed`` needs real types.)
"""

import math
from dataclasses import dataclass, field

from armando_drake.sensors.camera import CameraError, CameraSensorInfo


@dataclass
class ScenarioCamera:
    """One camera of the scenario, attached to a link of the robot."""

    # The camera's name: the diagram's ports <name>.color_image / .depth_image.
    name: str = ""
    # The robot link it is attached to.
    link: str = ""
    # [m] position of the sensor frame in the link frame.
    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    # [rad] roll pitch yaw of the sensor frame in the link frame; as in Gazebo the
    # camera looks along the sensor frame's +x, +y to the left of the image, +z up.
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    width: int = 640  # [px] image width
    height: int = 480  # [px] image height
    horizontal_fov: float = 1.047  # [rad] horizontal field of view, in (0, pi)
    near: float = 0.05  # [m] near clipping plane (and depth range start)
    far: float = 10.0  # [m] far clipping plane (and depth range end)
    update_rate: float = 30.0  # [Hz] frame rate (> 0)
    # Gazebo sensor type: "camera" (colour) or "rgbd_camera" (colour + depth).
    type: str = "camera"

    def sensor_info(self, origin: str = "") -> CameraSensorInfo:
        """The checked camera as a :class:`CameraSensorInfo`; :class:`CameraError`
        naming the camera and the bad value otherwise. ``origin`` is where the scenario's
        cameras came from (its file, or the ``--set`` override): the messages, and those
        about the info later (a link that does not exist), start with it."""
        within = f"{origin}: cameras" if origin else "cameras"
        where = f"{within}: {self.name or '(unnamed)'!r}"
        if not self.name:
            raise CameraError(f"{where}: a camera needs a name")
        if not self.link:
            raise CameraError(f"{where}: link={self.link!r} must name a link of the robot")
        if self.width <= 0 or self.height <= 0:
            raise CameraError(f"{where}: width={self.width!r}, height={self.height!r} must be > 0")
        if not 0.0 < self.horizontal_fov < math.pi:
            raise CameraError(f"{where}: horizontal_fov={self.horizontal_fov!r} must be in (0, pi)")
        if not (self.near > 0 and math.isfinite(self.near)):
            raise CameraError(f"{where}: near={self.near!r} must be positive")
        if not (self.far > self.near and math.isfinite(self.far)):
            raise CameraError(f"{where}: far={self.far!r} must be finite and > near={self.near!r}")
        if not (self.update_rate > 0 and math.isfinite(self.update_rate)):
            raise CameraError(f"{where}: update_rate={self.update_rate!r} must be positive")
        if self.type not in ("camera", "rgbd_camera"):
            raise CameraError(f"{where}: type={self.type!r} must be 'camera' or 'rgbd_camera'")
        for label, values in (("xyz", self.xyz), ("rpy", self.rpy)):
            if len(values) != 3 or not all(math.isfinite(v) for v in values):
                raise CameraError(f"{where}: {label}={values!r} must be 3 finite numbers")
        return CameraSensorInfo(
            name=self.name,
            sensor_name=self.name,
            type=self.type,
            link=self.link,
            horizontal_fov=self.horizontal_fov,
            width=self.width,
            height=self.height,
            near=self.near,
            far=self.far,
            update_rate=self.update_rate,
            xyz=list(self.xyz),
            rpy=list(self.rpy),
            source=within,
        )
