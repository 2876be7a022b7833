"""The perception's topics in the run's MCAP recording (``--record``): the camera's point
cloud ``<camera topic>/points`` (``sensor_msgs/msg/PointCloud2``, in the camera's optical
frame) and the clusters ``/perception/clusters`` (``visualization_msgs/msg/MarkerArray``),
as depth_image_proc and a segmentation node publish them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem

from armando_drake.messages.definitions import header, ros_time
from armando_drake.messages.publications import Send, Topic
from armando_drake.perception.pipeline import NO_RESULT
from armando_drake.perception.systems import CLUSTER_COLOURS
from armando_drake.sensors.camera import read_color

# PointCloud2 layout of /camera/points: x, y, z as float32 and rgb packed as in
# PCL (0x00RRGGBB in the bytes of a float32), 16 bytes a point, little-endian.
POINT_FIELDS = [
    {"name": "x", "offset": 0, "datatype": 7, "count": 1},
    {"name": "y", "offset": 4, "datatype": 7, "count": 1},
    {"name": "z", "offset": 8, "datatype": 7, "count": 1},
    {"name": "rgb", "offset": 12, "datatype": 7, "count": 1},
]
MARKER_CUBE, MARKER_SPHERE, MARKER_DELETEALL = 1, 2, 3
CENTROID_MARKER_SIZE = 0.01  # [m] diameter of the sphere marking a cluster's centroid


def point_cloud2_message(
    cloud, stamp: float, frame_id: str, width: int = 0, height: int = 0
) -> dict[str, Any]:
    """sensor_msgs/PointCloud2 of a Drake ``PointCloud`` (xyz and, if it has them, rgb).

    With ``width`` x ``height`` equal to its size the cloud is organised (one
    point per pixel, NaN where the depth is out of range, as ROS's
    depth_image_proc publishes it); otherwise it is one row.
    """
    count = cloud.size()
    if width * height != count or count == 0:
        width, height = count, 1
    points = np.zeros(count, dtype=[("xyz", "<f4", 3), ("rgb", "<u4")])
    points["xyz"] = cloud.xyzs().T
    if cloud.has_rgbs():
        rgb = cloud.rgbs().astype(np.uint32)
        points["rgb"] = (rgb[0] << 16) | (rgb[1] << 8) | rgb[2]
    return {
        "header": header(stamp, frame_id),
        "height": height,
        "width": width,
        "fields": POINT_FIELDS,
        "is_bigendian": False,
        "point_step": 16,
        "row_step": 16 * width,
        "data": points.tobytes(),
        "is_dense": bool(np.isfinite(cloud.xyzs()).all()),
    }


def marker_array_message(result, stamp: float, frame_id: str) -> dict[str, Any]:
    """visualization_msgs/MarkerArray of a perception result: DELETEALL, then per
    cluster k a CUBE (namespace ``boxes``, its axis-aligned box) and a SPHERE
    (namespace ``centroids``, at its centroid), both with id k and its colour."""

    def marker(ns: str, marker_id: int, kind: int, action: int, centre, scale, colour):
        return {
            "header": header(stamp, frame_id),
            "ns": ns,
            "id": marker_id,
            "type": kind,
            "action": action,
            "pose": {
                "position": dict(zip("xyz", (float(v) for v in centre), strict=True)),
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
            },
            "scale": dict(zip("xyz", (float(v) for v in scale), strict=True)),
            "color": dict(zip("rgba", (float(v) for v in colour), strict=True)),
            "lifetime": ros_time(0.0),
            "frame_locked": False,
            "points": [],
            "colors": [],
            "texture_resource": "",
            "texture": {"header": header(0.0), "format": "", "data": b""},
            "uv_coordinates": [],
            "text": "",
            "mesh_resource": "",
            "mesh_file": {"filename": "", "data": b""},
            "mesh_use_embedded_materials": False,
        }

    markers = [marker("", 0, MARKER_CUBE, MARKER_DELETEALL, (0, 0, 0), (0, 0, 0), (0, 0, 0, 0))]
    for k, cluster in enumerate(result.clusters):
        colour = (*CLUSTER_COLOURS[k % len(CLUSTER_COLOURS)], 0.5)
        centre = (cluster.lower + cluster.upper) / 2
        size = np.maximum(cluster.upper - cluster.lower, 1e-3)
        markers.append(marker("boxes", k, MARKER_CUBE, 0, centre, size, colour))
        markers.append(
            marker(
                "centroids",
                k,
                MARKER_SPHERE,
                0,
                cluster.centroid,
                [CENTROID_MARKER_SIZE] * 3,
                (*colour[:3], 1.0),
            )
        )
    return {"markers": markers}


class PerceptionRecorder(LeafSystem):
    """Sends a camera's point cloud and the perception results through ``send`` (the
    recorder's write).

    Ports:
      - input ``points`` (PointCloud, the camera frame): recorded on
        ``points_topic`` as sensor_msgs/PointCloud2 every ``1 / points_rate``
        seconds (0 = never), stamped with the camera frame's time;
      - input ``result`` (PerceptionResult): each new result recorded on
        ``clusters_topic`` as visualization_msgs/MarkerArray, stamped with
        its frame's time (read every ``1 / clusters_rate`` seconds).

    Both publish events start at ``offset``, after the pipeline's update.
    """

    def __init__(
        self,
        *,
        send: Send,
        camera_rate: float,
        points_rate: float,
        clusters_rate: float,
        offset: float,
        image_size: tuple[int, int],
        points_frame_id: str,
        clusters_frame_id: str,
        points_topic: str = "/camera/points",
        clusters_topic: str = "/perception/clusters",
    ):
        super().__init__()
        from pydrake.perception import PointCloud  # loaded with a perception only

        self._send = send
        self._camera_rate = camera_rate
        self._size = image_size
        self._frames = (points_frame_id, clusters_frame_id)
        self._topics = (points_topic, clusters_topic)
        self._last_time = None
        self._points = self.DeclareAbstractInputPort("points", AbstractValue.Make(PointCloud()))
        self._result = self.DeclareAbstractInputPort("result", AbstractValue.Make(NO_RESULT))
        if points_rate > 0:
            self.DeclarePeriodicPublishEvent(1.0 / points_rate, offset, self._PublishPoints)
        self.DeclarePeriodicPublishEvent(1.0 / clusters_rate, offset, self._PublishClusters)

    def _PublishPoints(self, context: Context) -> None:
        stamp = math.floor(context.get_time() * self._camera_rate + 1e-6) / self._camera_rate
        width, height = self._size
        message = point_cloud2_message(
            self._points.Eval(context), stamp, self._frames[0], width, height
        )
        self._send(self._topics[0], "sensor_msgs/msg/PointCloud2", message, stamp)

    def _PublishClusters(self, context: Context) -> None:
        result = self._result.Eval(context)
        if not result.computed or result.time == self._last_time:
            return
        self._last_time = result.time
        message = marker_array_message(result, result.time, self._frames[1])
        self._send(self._topics[1], "visualization_msgs/msg/MarkerArray", message, result.time)


@dataclass(frozen=True, eq=False)
class PerceptionSource:
    """The :class:`PerceptionRecorder` of a world's perception (an AddedPerception), on
    its camera (an AddedCamera): a :class:`~armando_drake.messages.publications.TopicSource`."""

    perception: Any
    camera: Any

    @property
    def optical_frame(self) -> str:
        return f"{self.camera.info.link}_optical"

    @property
    def points_topic(self) -> str:
        info = self.camera.info
        return "/" + (info.topic or info.name).strip("/") + "/points"

    def table(self) -> list[Topic]:
        """Its topics (recorded, not live), the cloud's when it is recorded."""
        config = self.perception.config
        clusters_frame = "world" if config.frame == "world" else self.optical_frame
        found = [
            Topic("/perception/clusters", "visualization_msgs/msg/MarkerArray", source=self,
                  rate=config.rate, frame_id=clusters_frame, live=False),
        ]  # fmt: skip
        if config.points_record_rate > 0:
            found.insert(0, Topic(self.points_topic, "sensor_msgs/msg/PointCloud2", source=self,
                                  rate=config.points_record_rate, frame_id=self.optical_frame,
                                  live=False))  # fmt: skip
        return found

    def attach(self, builder, send: Send, consumer: str) -> PerceptionRecorder:
        """Sends the cloud (in the camera's optical frame ``<link>_optical``: z forward, x
        right, y down) and the clusters (in ``world`` or that optical frame)."""
        perception, info = self.perception, self.camera.info
        system = builder.AddNamedSystem(
            f"perception_{consumer}",
            PerceptionRecorder(
                send=send,
                camera_rate=info.frame_rate,
                points_rate=perception.config.points_record_rate,
                clusters_rate=perception.config.rate,
                offset=2 * perception.offset,
                image_size=(info.width, info.height),
                points_frame_id=self.optical_frame,
                clusters_frame_id=(
                    "world" if perception.config.frame == "world" else self.optical_frame
                ),
                points_topic=self.points_topic,
            ),
        )
        builder.Connect(perception.points_in_camera, system.GetInputPort("points"))
        builder.Connect(perception.result, system.GetInputPort("result"))
        if perception.config.points_record_rate > 0:  # the cloud's colour, at its rate
            read_color(self.camera, perception.config.points_record_rate, 2 * perception.offset)
        return system
