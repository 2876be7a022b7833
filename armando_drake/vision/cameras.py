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
from dataclasses import dataclass

from armando_drake.sensors.camera import CameraError, CameraSensorInfo
from armando_drake.tools.schema import Refusal, check_config, param


@dataclass
class ScenarioCamera:
    """One camera of the scenario, attached to a link of the robot."""

    # The camera's name: the diagram's ports <name>.color_image / .depth_image.
    name: str = ""
    # The robot link it is attached to; in a world of several robots, ROBOT::link is a
    # link of the robot named ROBOT (a bare link is the first robot's).
    link: str = ""
    # [m] position of the sensor frame in the link frame.
    xyz: list[float] = param([0.0, 0.0, 0.0], unit="m", length=3, coordinate=True)
    # [rad] roll pitch yaw of the sensor frame in the link frame; as in Gazebo the
    # camera looks along the sensor frame's +x, +y to the left of the image, +z up.
    rpy: list[float] = param([0.0, 0.0, 0.0], unit="rad", length=3)
    width: int = param(640, unit="px", gt=0)  # [px] image width
    height: int = param(480, unit="px", gt=0)  # [px] image height
    # [rad] horizontal field of view, in (0, pi)
    horizontal_fov: float = param(1.047, unit="rad", gt=0, lt=math.pi)
    near: float = param(0.05, unit="m", gt=0)  # [m] near clipping plane (and depth range start)
    far: float = param(10.0, unit="m", gt=0)  # [m] far clipping plane (and depth range end)
    update_rate: float = param(30.0, unit="Hz", gt=0)  # [Hz] frame rate (> 0)
    # Gazebo sensor type: "camera" (colour) or "rgbd_camera" (colour + depth).
    type: str = param("camera", choices=("camera", "rgbd_camera"))

    def check(self) -> None:
        """A name, a link, and a far plane beyond the near one."""
        if not self.name:
            raise Refusal("name", "='': a camera needs a name")
        if not self.link:
            raise Refusal("link", "='': a camera needs the link it is attached to")
        if not self.far > self.near:
            raise Refusal("far", f"={self.far!r} must be greater than near={self.near!r}")

    def sensor_info(self, origin: str = "") -> CameraSensorInfo:
        """The checked camera as a :class:`CameraSensorInfo`; :class:`CameraError`
        naming the camera and the bad value otherwise. ``origin`` is where the scenario's
        cameras came from (its file, or the ``--set`` override): the messages, and those
        about the info later (a link that does not exist), start with it."""
        within = f"{origin}: cameras" if origin else "cameras"
        where = f"{within}: {self.name or '(unnamed)'!r}"
        check_config(self, origin=lambda _key: where, error=CameraError)
        robot, _, link = self.link.rpartition("::")
        return CameraSensorInfo(
            name=self.name,
            sensor_name=self.name,
            type=self.type,
            link=link,
            robot=robot,
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
