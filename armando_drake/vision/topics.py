"""The detectors' results in the run's MCAP recording (``--record``), as the seed's
ROS nodes publish them:

=================================  ====================================================
``/image_converter/output_video``  ``sensor_msgs/msg/Image`` (``rgb8``): the annotated
                                   image (keypoints, or the marker's outline and axes)
``/aruco_single/pose``             ``geometry_msgs/msg/PoseStamped``: ``cam_T_marker``,
                                   in the camera frame, one per detection
``/aruco_single/pose_world``       ``geometry_msgs/msg/PoseStamped``: the marker in the
                                   world
``/tf``                            ``map -> aruco_frame``: the marker on a navigation's
                                   map (with a navigation; ``map -> <namespace>/aruco_frame``
                                   for a robot with a namespace), live and recorded
=================================  ====================================================

The camera's own ``image_raw`` and ``camera_info`` (its intrinsics) are recorded by the
recorder for every camera, the scenario's included.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus, LeafSystem
from pydrake.systems.sensors import ImageRgba8U

from armando_drake.messages.definitions import (
    image_message,
    pose_stamped_message,
    transform_stamped,
)
from armando_drake.messages.publications import Send, Topic
from armando_drake.messages.types import PublicationValue
from armando_drake.vision.detectors import FRAME_DELAY

ANNOTATED_TOPIC = "/image_converter/output_video"
POSE_TOPIC = "/aruco_single/pose"
WORLD_POSE_TOPIC = "/aruco_single/pose_world"
MAP_FRAME, MARKER_FRAME = "map", "aruco_frame"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"


class VisionRecorder(LeafSystem):
    """Sends a detector's outputs through ``send`` (the recorder's write).

    .. pydrake_system::

        name: VisionRecorder
        input_ports:
        - annotated_image
        - cam_T_marker
        - marker_in_world

    Publishes at the camera rate, just after the detector's update; a pose is
    written only when a new one was published (``count`` grew).
    """

    def __init__(self, *, send: Send, frame_rate: float, camera: str):
        super().__init__()
        self._send, self._camera = send, camera
        self._image = self.DeclareAbstractInputPort(
            "annotated_image", AbstractValue.Make(ImageRgba8U())
        )
        self._poses = {
            POSE_TOPIC: self.DeclareAbstractInputPort("cam_T_marker", PublicationValue()),
            WORLD_POSE_TOPIC: self.DeclareAbstractInputPort("marker_in_world", PublicationValue()),
        }
        self._written = {topic: 0 for topic in self._poses}
        self.DeclarePeriodicPublishEvent(1.0 / frame_rate, 2 * FRAME_DELAY, self._Publish)

    def _Publish(self, context) -> EventStatus:
        stamp = context.get_time()
        if self._image.HasValue(context):
            rgb = np.ascontiguousarray(self._image.Eval(context).data[:, :, :3])
            self._send(
                ANNOTATED_TOPIC,
                "sensor_msgs/msg/Image",
                image_message(stamp, self._camera, rgb),
                stamp,
            )
        for topic, port in self._poses.items():
            if not port.HasValue(context):
                continue
            publication = port.Eval(context)
            if publication.count > self._written[topic]:
                self._written[topic] = publication.count
                pose = publication.message
                self._send(
                    topic,
                    "geometry_msgs/msg/PoseStamped",
                    pose_stamped_message(pose.stamp, pose.frame_id, pose.pose),
                    pose.stamp,
                )
        return EventStatus.Succeeded()


class MarkerFrame(LeafSystem):
    """Sends ``map -> <prefix>aruco_frame`` on /tf each time the marker goal publishes a
    new estimate of the marker on the map (input ``marker_in_map``, a Publication of
    MarkerPose), at the camera rate."""

    def __init__(self, *, send: Send, frame_rate: float, prefix: str = ""):
        super().__init__()
        self._send, self._child = send, f"{prefix}{MARKER_FRAME}"
        self._marker = self.DeclareAbstractInputPort("marker_in_map", PublicationValue())
        self._count = 0
        self.DeclarePeriodicPublishEvent(1.0 / frame_rate, 3 * FRAME_DELAY, self._Publish)

    def _Publish(self, context) -> EventStatus:
        if self._marker.HasValue(context):
            marker = self._marker.Eval(context)
            if marker.count > self._count:
                self._count = marker.count
                pose = marker.message.pose
                frame = transform_stamped(marker.stamp, MAP_FRAME, self._child, pose)
                self._send("/tf", TF_MESSAGE, {"transforms": [frame]}, marker.stamp)
        return EventStatus.Succeeded()


@dataclass(frozen=True, eq=False)
class VisionSource:
    """The :class:`VisionRecorder` of each detector of ``detectors`` (AddedDetectors) on
    ``cameras`` (AddedCamera by name): a
    :class:`~armando_drake.messages.publications.TopicSource`."""

    detectors: Any
    cameras: dict

    def _detectors(self) -> list[tuple[Any, str]]:
        detectors = self.detectors
        return [
            (detector, camera)
            for detector, camera in (
                (detectors.blob, detectors.blob_camera),
                (detectors.aruco, detectors.aruco_camera),
            )
            if detector is not None
        ]

    def table(self) -> list[Topic]:
        """Its topics (recorded, not live): each detector's annotated image, the ArUco
        detector's poses."""
        found = []
        for detector, camera in self._detectors():
            rate = self.cameras[camera].info.frame_rate
            found.append(Topic(ANNOTATED_TOPIC, "sensor_msgs/msg/Image", source=self,
                               rate=rate, frame_id=camera, live=False))  # fmt: skip
            if detector is self.detectors.aruco:
                found += [
                    Topic(topic, "geometry_msgs/msg/PoseStamped", source=self, rate=rate,
                          live=False)
                    for topic in (POSE_TOPIC, WORLD_POSE_TOPIC)
                ]  # fmt: skip
        return found

    def attach(self, builder, send: Send, consumer: str) -> list[VisionRecorder]:
        added = []
        for detector, camera in self._detectors():
            system = builder.AddNamedSystem(
                f"vision_{consumer}_{camera}",
                VisionRecorder(
                    send=send, frame_rate=self.cameras[camera].info.frame_rate, camera=camera
                ),
            )
            builder.Connect(
                detector.GetOutputPort("annotated_image"), system.GetInputPort("annotated_image")
            )
            if detector is self.detectors.aruco:
                for port in ("cam_T_marker", "marker_in_world"):
                    builder.Connect(detector.GetOutputPort(port), system.GetInputPort(port))
            added.append(system)
        return added


@dataclass(frozen=True, eq=False)
class MarkerFrameSource:
    """The :class:`MarkerFrame` of a ``marker_goal`` (the MarkerGoal of the detectors of
    a robot with a navigation) at the camera's ``rate``; ``space``: that robot's
    namespace: a :class:`~armando_drake.messages.publications.TopicSource`."""

    marker_goal: Any
    rate: float
    space: str = ""

    def table(self) -> list[Topic]:
        """``map -> aruco_frame`` on /tf (recorded and live)."""
        return [Topic("/tf", TF_MESSAGE, source=self, rate=self.rate)]

    def attach(self, builder, send: Send, consumer: str) -> MarkerFrame:
        prefix = f"{self.space}/" if self.space else ""
        frame = builder.AddNamedSystem(
            f"{prefix}marker_frame_{consumer}",
            MarkerFrame(send=send, frame_rate=self.rate, prefix=prefix),
        )
        port = self.marker_goal.GetOutputPort("marker_in_map")
        builder.Connect(port, frame.GetInputPort("marker_in_map"))
        return frame
