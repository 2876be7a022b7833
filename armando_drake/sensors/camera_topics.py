"""A camera's topics, as Gazebo's camera bridge publishes them: ``<topic>/image_raw``
(``sensor_msgs/msg/Image``, ``rgb8``) and ``<topic>/camera_info``
(``sensor_msgs/msg/CameraInfo``), each frame stamped with the time it was taken, read a
thousandth of a period after it."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from armando_drake.messages.definitions import header, image_message
from armando_drake.messages.publications import Topic
from armando_drake.sensors.camera import read_color
from armando_drake.sensors.image_view import PUBLISH_OFFSET_FRACTION


@dataclass(frozen=True)
class CameraStream:
    """One camera published as ``<topic>/image_raw`` and ``<topic>/camera_info``."""

    name: str  # the camera's name in the world
    topic: str  # topic namespace, e.g. "/camera"
    frame_id: str  # header.frame_id of its messages (the camera link)
    width: int  # [px]
    height: int  # [px]
    fx: float  # [px] focal lengths
    fy: float  # [px]
    cx: float  # [px] principal point
    cy: float  # [px]
    rate: float  # [Hz] the camera's frame rate

    def camera_info(self, stamp: float) -> dict[str, Any]:
        """sensor_msgs/CameraInfo: a pinhole without distortion."""
        return {
            "header": header(stamp, self.frame_id),
            "height": self.height,
            "width": self.width,
            "distortion_model": "plumb_bob",
            "d": [0.0] * 5,
            "k": [self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0],
            "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            "p": [self.fx, 0.0, self.cx, 0.0, 0.0, self.fy, self.cy, 0.0, 0.0, 0.0, 1.0, 0.0],
            "binning_x": 0,
            "binning_y": 0,
            "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False},
        }

    def frame_stamp(self, image, time: float) -> float | None:
        """The time the frame ``image`` (an ImageRgba8U read at ``time``) was taken; None
        before anything was rendered."""
        if image.width() != self.width or image.height() != self.height:
            return None
        period = 1.0 / self.rate
        return math.floor(time / period + 1e-6) * period

    def image(self, image, time: float):
        """(image_raw message, stamp, None) of a frame, or None."""
        stamp = self.frame_stamp(image, time)
        if stamp is None:
            return None
        rgb = np.ascontiguousarray(image.data[:, :, :3])
        return image_message(stamp, self.frame_id, rgb), stamp, None

    def info(self, image, time: float):
        """(camera_info message, stamp, None) of a frame, or None."""
        stamp = self.frame_stamp(image, time)
        return None if stamp is None else (self.camera_info(stamp), stamp, None)


def camera_stream(name: str, camera) -> CameraStream:
    """The stream of a :class:`~armando_drake.sensors.camera.AddedCamera`, intrinsics from Drake."""
    intrinsics = camera.sensor.default_color_render_camera().core().intrinsics()
    info = camera.info
    return CameraStream(
        name=name,
        topic="/" + (info.topic or info.name).strip("/"),
        frame_id=info.link,
        width=intrinsics.width(),
        height=intrinsics.height(),
        fx=intrinsics.focal_x(),
        fy=intrinsics.focal_y(),
        cx=intrinsics.center_x(),
        cy=intrinsics.center_y(),
        rate=info.frame_rate,
    )


def camera_topics(name: str, camera) -> list[Topic]:
    """The two topics of an AddedCamera, read from its ``color_image`` (the world's
    cameras are not under a robot's namespace)."""
    stream = camera_stream(name, camera)
    base = stream.topic.strip("/")
    period = 1.0 / stream.rate
    offset = PUBLISH_OFFSET_FRACTION * period
    common = dict(
        port=camera.color_image,
        rate=stream.rate,
        offset=offset,
        frame_id=stream.frame_id,
        on_attach=lambda: read_color(camera, stream.rate, offset),
    )
    return [
        Topic(f"{base}/image_raw", "sensor_msgs/msg/Image", read=stream.image,
              qos="sensor_data", **common),
        Topic(f"{base}/camera_info", "sensor_msgs/msg/CameraInfo", read=stream.info, **common),
    ]  # fmt: skip
