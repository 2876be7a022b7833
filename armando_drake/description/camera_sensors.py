"""Camera sensors as a robot description gives them: the ``<gazebo><sensor
type="camera">`` blocks (and ``depth``, ``rgbd_camera``, ...) of a URDF, read into
:class:`CameraSensorInfo`, which :mod:`armando_drake.sensors.camera` turns into
Drake ``RgbdSensor``s. SDFormat's defaults fill what a block leaves out."""

from __future__ import annotations

import logging
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

from armando_drake.tools.errors import UserInputError
from armando_drake.tools.schema import Refusal, check_config, param

_logger = logging.getLogger("armando_drake.sensors.camera")

# Gazebo sensor types that produce a camera image.
CAMERA_SENSOR_TYPES = ("camera", "depth", "depth_camera", "rgbd_camera", "rgbd")
# SDFormat's defaults (camera.sdf, sensor.sdf).
DEFAULT_HORIZONTAL_FOV = 1.047  # [rad]
DEFAULT_WIDTH = 320  # [px]
DEFAULT_HEIGHT = 240  # [px]
DEFAULT_NEAR = 0.1  # [m]
DEFAULT_FAR = 100.0  # [m]
# The frame rate used where the description says 0 ("every physics step").
DEFAULT_FRAME_RATE = 30.0  # [Hz]
# Camera renderers: "auto" picks "gl" when it can (see choose_renderer), else "vtk".
RENDERERS = ("auto", "gl", "vtk")
# The farthest depth Drake's 16-bit depth image can represent.
MAX_DEPTH_RANGE = 65.5  # [m]

# Gazebo camera convention (x forward, y left, z up) -> Drake camera frame
# (z forward, x right, y down); columns are C's axes expressed in S.
R_SC = RotationMatrix(np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))


class CameraError(UserInputError, ValueError):
    """A camera sensor block that cannot be used; the message names file and value."""


@dataclass
class CameraNoise:
    """Gazebo's ``<noise>`` on the colour image."""

    type: str = "gaussian"  # only "gaussian" is supported
    mean: float = 0.0  # [colour fraction, 0..1] added to every channel
    stddev: float = 0.0  # [colour fraction, 0..1] standard deviation


@dataclass
class CameraSensorInfo:
    """One camera sensor block of the description, its rules declared beside its fields
    (checked by :func:`~armando_drake.tools.schema.check_config`, named in messages by
    their tags: :data:`SENSOR_TAGS`)."""

    name: str  # camera name: the <topic> (slashes -> "_") if given, else the sensor name
    sensor_name: str  # the <sensor name="..."> attribute
    type: str  # Gazebo sensor type: camera | depth | depth_camera | rgbd_camera | rgbd
    link: str  # the <gazebo reference="..."> link the camera is attached to
    topic: str = ""  # the <topic> as written ("" if none)
    # [rad] the horizontal field of view
    horizontal_fov: float = param(DEFAULT_HORIZONTAL_FOV, unit="rad", gt=0, lt=math.pi)
    width: int = param(DEFAULT_WIDTH, unit="px", gt=0)  # [px]
    height: int = param(DEFAULT_HEIGHT, unit="px", gt=0)  # [px]
    # [m] near clipping plane (and depth range start)
    near: float = param(DEFAULT_NEAR, unit="m", gt=0)
    far: float = param(DEFAULT_FAR, unit="m")  # [m] far clipping plane (and depth range end)
    # [Hz] as written; 0 = SDFormat's "every step"
    update_rate: float = param(0.0, unit="Hz", ge=0)
    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # [m] sensor in link
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # [rad] sensor in link
    noise: CameraNoise | None = None  # colour noise, None = noise-free
    source: str = ""  # the file the block came from (for messages)
    # In a world of several robots, the robot whose link it is on ("" = the one given).
    robot: str = ""

    def check(self) -> None:
        """A far plane beyond the near one."""
        if not self.far > self.near:
            raise Refusal("far", f"={self.far!r} must be greater than near={self.near!r}")

    @property
    def frame_rate(self) -> float:
        """[Hz] the rate images are produced at in Drake."""
        return self.update_rate if self.update_rate > 0 else DEFAULT_FRAME_RATE

    @property
    def focal_length(self) -> float:
        """[px] fx = fy from the horizontal field of view (square pixels)."""
        return self.width / (2.0 * math.tan(self.horizontal_fov / 2.0))

    @property
    def has_depth(self) -> bool:
        """Whether Gazebo would publish a depth image for this sensor type."""
        return self.type != "camera"

    def X_LS(self) -> RigidTransform:
        """Pose of the Gazebo sensor frame S in the link frame L."""
        return RigidTransform(RollPitchYaw(self.rpy), self.xyz)

    def X_LC(self) -> RigidTransform:
        """Pose of Drake's camera frame C (z forward, x right, y down) in the link frame."""
        return self.X_LS() @ RigidTransform(R_SC)


# --------------------------------------------------------------------------
# Parsing
# --------------------------------------------------------------------------


def sensor_origin(source: str, sensor: str) -> str:
    return f"{source or '<urdf>'}: camera sensor {sensor!r}"


def _number(element: ET.Element | None, path: str, default, kind, where: str):
    """The number at ``path`` below ``element`` (default if absent)."""
    if element is None:
        return default
    text = element.findtext(path)
    if text is None or text.strip() == "":
        return default
    try:
        value = float(text)
    except ValueError:
        raise CameraError(f"{where}: <{path}>={text.strip()!r} is not a number") from None
    if kind is int:
        if not value.is_integer():
            raise CameraError(f"{where}: <{path}>={text.strip()!r} is not a whole number")
        return int(value)
    return value


def _camera_name(topic: str, sensor_name: str) -> str:
    name = topic.strip().strip("/").replace("/", "_")
    return name or sensor_name


def _parse_pose(sensor: ET.Element, where: str) -> tuple[list[float], list[float]]:
    pose = sensor.find("pose")
    if pose is None or not (pose.text or "").strip():
        return [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    relative_to = pose.get("relative_to")
    if relative_to:
        raise CameraError(
            f"{where}: <pose relative_to={relative_to!r}> is not supported; "
            "give the pose in the link frame"
        )
    try:
        values = [float(v) for v in pose.text.split()]
    except ValueError:
        raise CameraError(f"{where}: <pose>={pose.text.strip()!r} is not 6 numbers") from None
    if len(values) != 6:
        raise CameraError(f"{where}: <pose>={pose.text.strip()!r} is not 6 numbers")
    return values[:3], values[3:]


def _parse_noise(camera: ET.Element | None, sensor: ET.Element, where: str) -> CameraNoise | None:
    noise = camera.find("noise") if camera is not None else None
    if noise is None:
        noise = sensor.find("noise")
    if noise is None:
        return None
    kind = (noise.findtext("type") or "gaussian").strip()
    if kind == "none":
        return None
    if kind not in ("gaussian", "gaussian_quantized"):
        raise CameraError(f"{where}: <noise><type>={kind!r} is not supported (use 'gaussian')")
    mean = _number(noise, "mean", 0.0, float, where)
    stddev = _number(noise, "stddev", 0.0, float, where)
    if stddev < 0:
        raise CameraError(f"{where}: <noise><stddev>={stddev!r} must be >= 0")
    return CameraNoise(type="gaussian", mean=mean, stddev=stddev)


def _parse_sensor(sensor: ET.Element, link: str, source: str) -> CameraSensorInfo:
    sensor_name = sensor.get("name", "").strip()
    where = sensor_origin(source, sensor_name or "(unnamed)")
    if not sensor_name:
        raise CameraError(f"{where} on link {link!r}: <sensor> has no name")
    camera = sensor.find("camera")
    topic = (sensor.findtext("topic") or "").strip()
    width = _number(camera, "image/width", DEFAULT_WIDTH, int, where)
    height = _number(camera, "image/height", DEFAULT_HEIGHT, int, where)
    fov = _number(camera, "horizontal_fov", DEFAULT_HORIZONTAL_FOV, float, where)
    near = _number(camera, "clip/near", DEFAULT_NEAR, float, where)
    far = _number(camera, "clip/far", DEFAULT_FAR, float, where)
    rate = _number(sensor, "update_rate", 0.0, float, where)
    xyz, rpy = _parse_pose(sensor, where)
    info = CameraSensorInfo(
        name=_camera_name(topic, sensor_name),
        sensor_name=sensor_name,
        type=sensor.get("type", ""),
        link=link,
        topic=topic,
        horizontal_fov=fov,
        width=width,
        height=height,
        near=near,
        far=far,
        update_rate=rate,
        xyz=xyz,
        rpy=rpy,
        noise=_parse_noise(camera, sensor, where),
        source=str(source),
    )
    _check_sensor(info, where)
    return info


# The description's tag of each field of CameraSensorInfo that has a rule, for messages.
SENSOR_TAGS = {
    "width": "<image><width>",
    "height": "<image><height>",
    "horizontal_fov": "<horizontal_fov>",
    "near": "<clip><near>",
    "far": "<clip><far>",
    "update_rate": "<update_rate>",
}


def _check_sensor(info: CameraSensorInfo, where: str) -> None:
    """:class:`CameraError` ``<where>: <tag>=<value> <problem>`` for the first value of
    ``info`` that its declared rules refuse."""
    try:
        check_config(info, error=CameraError)
    except CameraError as error:
        tag = SENSOR_TAGS.get(error.key, error.key)
        raise CameraError(f"{where}: {tag}{error.text.removeprefix(error.key)}") from None


def parse_camera_sensors(root: ET.Element, source: str = "") -> list[CameraSensorInfo]:
    """The camera sensor blocks of an expanded URDF, in document order.

    Reads ``<gazebo reference="LINK"><sensor type="camera|depth|depth_camera|
    rgbd_camera|rgbd">``; other sensor types (imu, ray, ...) are ignored.
    Raises :class:`CameraError` naming ``source`` and the bad value.
    """
    links = {link.get("name") for link in root.findall("link")}
    cameras: list[CameraSensorInfo] = []
    for gazebo in root.findall("gazebo"):
        for sensor in gazebo.findall("sensor"):
            if sensor.get("type", "").strip() not in CAMERA_SENSOR_TYPES:
                continue
            link = (gazebo.get("reference") or "").strip()
            where = sensor_origin(source, sensor.get("name", "(unnamed)"))
            if not link:
                raise CameraError(f'{where}: the <gazebo> block has no reference="LINK"')
            if link not in links:
                raise CameraError(
                    f"{where}: reference={link!r} is not a link of the URDF "
                    f"(links: {', '.join(sorted(n for n in links if n))})"
                )
            info = _parse_sensor(sensor, link, source)
            if any(other.name == info.name for other in cameras):
                raise CameraError(f"{where}: camera name {info.name!r} is used twice")
            cameras.append(info)
    return cameras


# --------------------------------------------------------------------------
# Drake systems
# --------------------------------------------------------------------------
