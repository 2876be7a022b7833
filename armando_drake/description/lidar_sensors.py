"""Planar lidars as a robot description gives them: the ``<gazebo reference="LINK">
<sensor type="gpu_lidar|lidar|ray|gpu_ray">`` blocks of a URDF, read into
:class:`LidarInfo`, which :mod:`armando_drake.sensors.lidar` simulates.

Both of Gazebo's forms are read: Gazebo Sim's ``<lidar>`` and Gazebo classic's
``<ray>``, each with ``<scan><horizontal>`` (``samples``, ``resolution``,
``min_angle``, ``max_angle``), ``<range>`` (``min``, ``max``, ``resolution``) and
``<noise>``; the sensor's ``<update_rate>``, ``<pose>`` and ``<topic>``, and its frame
(``<gz_frame_id>``, ``<ignition_frame_id>``, ``<frame_id>`` or the link). SDFormat's
defaults fill what a block leaves out. A ``<vertical>`` scan of more than one sample
(a 3D lidar) is read as its horizontal plane only, with a warning.
"""

from __future__ import annotations

import logging
import math
import xml.etree.ElementTree as ET
import zlib
from dataclasses import dataclass

from pydrake.math import RigidTransform

from armando_drake.description.urdf import SensorBlock
from armando_drake.tools.errors import UserInputError

_log = logging.getLogger("armando_drake.world")

# Gazebo sensor types of a ray-casting range finder (Gazebo Sim, then classic).
LIDAR_SENSOR_TYPES = ("gpu_lidar", "lidar", "gpu_ray", "ray")
# The rate used where the description says 0 ("every physics step").
DEFAULT_UPDATE_RATE = 10.0  # [Hz]
# SDFormat's lidar.sdf defaults.
DEFAULT_SAMPLES = 640
DEFAULT_RANGE_MIN = 0.0  # [m]


class LidarError(UserInputError, ValueError):
    """A lidar block that cannot be used; the message names the file and the value."""


@dataclass(frozen=True)
class LidarNoise:
    """Gaussian noise added to every range: ``mean + stddev * N(0, 1)``."""

    mean: float = 0.0  # [m]
    stddev: float = 0.0  # [m]


@dataclass(frozen=True)
class LidarInfo:
    """One planar lidar of the description."""

    name: str  # the <sensor name>
    type: str  # gpu_lidar | lidar | gpu_ray | ray
    link: str  # the link it is mounted on
    X_LS: RigidTransform  # the sensor frame S (beams in its x-y plane) in the link
    samples: int  # <horizontal><samples>
    resolution: float  # <horizontal><resolution>: beams = samples * resolution
    angle_min: float  # [rad] <min_angle>
    angle_max: float  # [rad] <max_angle>
    range_min: float  # [m]
    range_max: float  # [m]
    range_resolution: float  # [m] as written (ranges are not quantised)
    update_rate: float  # [Hz]
    topic: str  # where Gazebo would publish the scan
    frame_id: str  # the scan's frame_id
    noise: LidarNoise | None = None
    vertical_samples: int = 1  # >1: a 3D lidar, of which the horizontal plane is simulated
    source: str = ""

    @property
    def beams(self) -> int:
        """How many ranges one scan has (Gazebo's range count: samples x resolution)."""
        return max(1, round(self.samples * self.resolution))

    @property
    def angle_increment(self) -> float:
        """[rad] between neighbouring beams (0 for a single beam)."""
        return (self.angle_max - self.angle_min) / (self.beams - 1) if self.beams > 1 else 0.0

    @property
    def seed(self) -> int:
        """The noise seed: a checksum of the sensor's name (the same every run)."""
        return zlib.crc32(self.name.encode())

    def describe(self) -> str:
        span = math.degrees(self.angle_max - self.angle_min)
        noise = f", noise {self.noise.stddev:g} m" if self.noise else ""
        return (
            f"{self.beams} beams over {span:.1f} deg, {self.range_min:g}..{self.range_max:g} m "
            f"at {self.update_rate:g} Hz{noise}"
        )


def _ray_element(sensor: ET.Element) -> ET.Element | None:
    for tag in ("lidar", "ray"):
        element = sensor.find(tag)
        if element is not None:
            return element
    return None


def _number(element: ET.Element | None, path: str, default: float, where: str) -> float:
    text = element.findtext(path) if element is not None else None
    if text is None or not text.strip():
        return default
    try:
        value = float(text)
    except ValueError:
        raise LidarError(f"{where}: <{path}>={text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise LidarError(f"{where}: <{path}>={text.strip()!r} is not finite")
    return value


def _noise(ray: ET.Element | None, sensor: ET.Element, where: str) -> LidarNoise | None:
    noise = ray.find("noise") if ray is not None else None
    noise = noise if noise is not None else sensor.find("noise")
    if noise is None:
        return None
    kind = (noise.get("type") or noise.findtext("type") or "gaussian").strip()
    if kind == "none":
        return None
    if kind not in ("gaussian", "gaussian_quantized"):
        raise LidarError(f"{where}: <noise type={kind!r}> is not supported (use 'gaussian')")
    stddev = _number(noise, "stddev", 0.0, where)
    if stddev < 0:
        raise LidarError(f"{where}: <noise><stddev>={stddev!r} must be >= 0")
    return LidarNoise(mean=_number(noise, "mean", 0.0, where), stddev=stddev)


def _topic(sensor: ET.Element, name: str) -> str:
    """The topic as Gazebo Sim (<topic>) or a classic ROS plugin (<topicName>, a
    ``~/out:=`` remapping) names it; else ``<name>/scan``."""
    topic = (sensor.findtext("topic") or "").strip()
    for plugin in sensor.findall("plugin"):
        topic = topic or (plugin.findtext("topicName") or "").strip()
        for remap in plugin.iter("remapping"):
            left, _, right = (remap.text or "").partition(":=")
            if left.strip() in ("~/out", "out") and right.strip():
                topic = topic or right.strip()
    return topic or f"{name}/scan"


def _frame_id(sensor: ET.Element, link: str) -> str:
    for tag in ("gz_frame_id", "ignition_frame_id", "frame_id", "frameName"):
        for element in [sensor, *sensor.findall("plugin")]:
            text = (element.findtext(tag) or "").strip()
            if text:
                return text.split("::")[-1]  # Gazebo's scoped model::link::frame
    return link


def parse_lidar(block: SensorBlock) -> LidarInfo:
    """The lidar of one sensor block (its type one of :data:`LIDAR_SENSOR_TYPES`)."""
    where = block.where()
    sensor = block.element
    if not block.link:
        raise LidarError(f'{where}: the <gazebo> block has no reference="LINK"')
    ray = _ray_element(sensor)
    horizontal = ray.find("scan/horizontal") if ray is not None else None
    samples = _number(horizontal, "samples", DEFAULT_SAMPLES, where)
    resolution = _number(horizontal, "resolution", 1.0, where)
    angle_min = _number(horizontal, "min_angle", 0.0, where)
    angle_max = _number(horizontal, "max_angle", 0.0, where)
    range_min = _number(ray, "range/min", DEFAULT_RANGE_MIN, where)
    range_max = _number(ray, "range/max", 0.0, where)
    vertical = _number(ray, "scan/vertical/samples", 1, where) if ray is not None else 1
    if samples < 1 or not float(samples).is_integer():
        raise LidarError(f"{where}: <horizontal><samples>={samples:g} must be a whole number >= 1")
    if resolution <= 0:
        raise LidarError(f"{where}: <horizontal><resolution>={resolution:g} must be > 0")
    if angle_max < angle_min or angle_max - angle_min > 2 * math.pi + 1e-6:
        raise LidarError(
            f"{where}: <min_angle>={angle_min:g} <max_angle>={angle_max:g}: need min <= max, "
            "at most 2 pi apart"
        )
    if range_min < 0 or range_max <= range_min:
        raise LidarError(
            f"{where}: <range><min>={range_min:g} <max>={range_max:g}: need 0 <= min < max"
        )
    rate = block.update_rate
    if rate < 0 or not math.isfinite(rate):
        raise LidarError(f"{where}: <update_rate>={rate!r} must be >= 0")
    if vertical > 1:
        _log.warning(
            "%s: a 3D lidar (%d vertical samples): only its horizontal plane is simulated",
            where,
            vertical,
        )
    return LidarInfo(
        name=block.name,
        type=block.type,
        link=block.link,
        X_LS=block.X_LS,
        samples=int(samples),
        resolution=resolution,
        angle_min=angle_min,
        angle_max=angle_max,
        range_min=range_min,
        range_max=range_max,
        range_resolution=_number(ray, "range/resolution", 0.0, where),
        update_rate=rate if rate > 0 else DEFAULT_UPDATE_RATE,
        topic=_topic(sensor, block.name),
        frame_id=_frame_id(sensor, block.link),
        noise=_noise(ray, sensor, where),
        vertical_samples=int(vertical),
        source=block.source,
    )
