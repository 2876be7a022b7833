"""Recording a run as a ROS 2 bag (MCAP, CDR): the ``ros2 bag record`` step.

:class:`RosbagRecorder` is a Drake system that writes the world's topics to
one ``.mcap`` file with ROS 2 message schemas (``ros2msg``) and CDR-encoded
messages, the storage format of rosbag2 since Iron, so ``ros2 bag info``,
``ros2 bag play`` and Foxglove open it as they would a recording of the real
robot. Topics (for the default controller names):

==================================== ====================================
topic                                message type
==================================== ====================================
``/joint_states``                    ``sensor_msgs/msg/JointState``
``/position_controller/commands``    ``std_msgs/msg/Float64MultiArray``
``/trajectory_controller/joint_trajectory`` ``trajectory_msgs/msg/JointTrajectory``
``/camera/image_raw``                ``sensor_msgs/msg/Image`` (``rgb8``)
``/camera/camera_info``              ``sensor_msgs/msg/CameraInfo``
==================================== ====================================

Times are simulation time: each message's log time and header stamp are the
simulation time at which it was sampled or published (a run starts at
1970-01-01 00:00:00 on a player's clock). :func:`AddRosbagRecorder` adds the
recorder to a world being built and connects it to the joint state
broadcaster, the command sequencer (the commands actually sent to the
controller it drives) and the cameras.

The file is written with ``mcap-ros2-support`` (the MCAP project's ROS 2
writer). Its message definitions are those of :mod:`armando_drake.ros2.messages`
(ROS 2 Humble and later; these messages have not changed).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem
from pydrake.systems.sensors import ImageRgba8U

from armando_drake.control.messages import JointState, PublicationValue
from armando_drake.ros2.messages import (  # the message definitions, shared with the bridge
    cartesian_trajectory_message,
    float64_multi_array_message,
    header,
    image_message,
    joint_state_message,
    joint_trajectory_message,
    message_definition,
)


class RecordingError(ValueError):
    """A recording that cannot be written; the message names the path."""


@dataclass(frozen=True)
class CameraStream:
    """One camera recorded as ``<topic>/image_raw`` and ``<topic>/camera_info``."""

    name: str  # the camera's name in the world (its input port is "<name>.color_image")
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


def check_recording_path(path: str | os.PathLike) -> Path:
    """``path`` if an MCAP file can be created there; RecordingError naming it otherwise."""
    path = Path(path)
    if path.suffix != ".mcap":
        raise RecordingError(f"--record {path}: the file name must end in .mcap")
    folder = path.parent
    if not folder.is_dir():
        raise RecordingError(f"--record {path}: folder {folder} does not exist")
    if path.is_dir():
        raise RecordingError(f"--record {path}: is a folder")
    existed = path.exists()
    try:
        with open(path, "ab"):  # the real test: can this process create or append to it?
            pass
    except OSError as error:
        raise RecordingError(f"--record {path}: cannot write there: {error.strerror}") from None
    if not existed:
        path.unlink()
    return path


class RosbagRecorder(LeafSystem):
    """Writes joint states, commands and camera images to an MCAP file (ROS 2, CDR).

    .. pydrake_system::

        name: RosbagRecorder
        input_ports:
        - joint_states
        - commands
        - joint_trajectory
        - cartesian_trajectory
        - <camera>.color_image (one per camera)

    - ``joint_states``: a :class:`~armando_drake.control.messages.JointState`; a
      sample is recorded on ``joint_states_topic`` whenever its stamp is new,
      with that stamp (the same samples, at the same times, as the
      joint-state logger's CSV);
    - ``commands`` / ``joint_trajectory``: a
      :class:`~armando_drake.control.messages.Publication` of Float64MultiArray /
      JointTrajectory; the latest message is recorded on ``commands_topic`` /
      ``trajectory_topic`` whenever the publication's count grows, stamped
      with its publication time. Unconnected: nothing recorded. Publications
      closer together than 1/``update_rate`` keep only the latest;
    - ``cartesian_trajectory``: a Publication of CartesianTrajectory (the task's
      reference), recorded the same way on ``cartesian_topic``
      (``cartesian_control_msgs/msg/CartesianTrajectory``);
    - ``<camera>.color_image``: an ImageRgba8U held at the camera's rate;
      each frame is recorded as ``<topic>/image_raw`` (rgb8) plus
      ``<topic>/camera_info``, stamped with the time the frame was taken.

    A periodic publish event at ``update_rate`` [Hz] from t = 0 handles the
    first three; per camera, a periodic publish event at the camera's rate,
    a thousandth of a period after each frame is taken, records the frame.
    Call :meth:`close` when the run ends (it writes the MCAP summary);
    closing twice is harmless.
    """

    def __init__(
        self,
        *,
        path: str | os.PathLike,
        update_rate: float,
        joint_states_topic: str = "/joint_states",
        commands_topic: str = "/position_controller/commands",
        trajectory_topic: str = "/trajectory_controller/joint_trajectory",
        cartesian_topic: str = "/operational_space_controller/cartesian_trajectory",
        cameras: Sequence[CameraStream] = (),
    ):
        super().__init__()
        from mcap_ros2.writer import Writer

        if not (math.isfinite(update_rate) and update_rate > 0):
            raise ValueError(f"update_rate={update_rate!r} must be positive [Hz]")
        self._path = check_recording_path(path)
        self._topics = {
            "joint_states": joint_states_topic,
            "commands": commands_topic,
            "joint_trajectory": trajectory_topic,
            "cartesian_trajectory": cartesian_topic,
        }
        try:
            self._file: IO[bytes] | None = open(self._path, "wb")
        except OSError as error:
            raise RecordingError(f"--record {path}: cannot write: {error.strerror}") from None
        self._writer = Writer(self._file)
        self._schemas: dict[str, Any] = {}
        self._counts: dict[str, int] = {}  # messages written, by topic
        self._last_stamp: float | None = None
        self._last_publication = {"commands": 0, "joint_trajectory": 0, "cartesian_trajectory": 0}

        self._joint_states = self.DeclareAbstractInputPort(
            "joint_states", AbstractValue.Make(JointState())
        )
        self._publications = {
            name: self.DeclareAbstractInputPort(name, PublicationValue())
            for name in ("commands", "joint_trajectory", "cartesian_trajectory")
        }
        self.DeclarePeriodicPublishEvent(1.0 / update_rate, 0.0, self._PublishTopics)
        from armando_drake.sensors.image_view import PUBLISH_OFFSET_FRACTION

        self._cameras = list(cameras)
        for camera in self._cameras:
            port = self.DeclareAbstractInputPort(
                f"{camera.name}.color_image", AbstractValue.Make(ImageRgba8U())
            )
            period = 1.0 / camera.rate
            self.DeclarePeriodicPublishEvent(
                period,
                PUBLISH_OFFSET_FRACTION * period,
                lambda context, camera=camera, port=port: self._PublishFrame(context, camera, port),
            )

    @property
    def path(self) -> Path:
        return self._path

    @property
    def message_counts(self) -> dict[str, int]:
        """Messages written so far, by topic."""
        return dict(self._counts)

    def close(self) -> None:
        """Finishes the MCAP file (summary and index). Safe to call more than once."""
        if self._file is None:
            return
        self._writer.finish()
        self._file.close()
        self._file = None

    def _Write(self, topic: str, type_name: str, message: dict[str, Any], stamp: float) -> None:
        if self._file is None:
            raise RuntimeError(f"RosbagRecorder for {self._path} was closed before the run ended")
        schema = self._schemas.get(type_name)
        if schema is None:
            schema = self._writer.register_msgdef(type_name, message_definition(type_name))
            self._schemas[type_name] = schema
        sequence = self._counts.get(topic, 0)
        time_ns = max(0, round(stamp * 1e9))
        self._writer.write_message(
            topic=topic,
            schema=schema,
            message=message,
            log_time=time_ns,
            publish_time=time_ns,
            sequence=sequence,
        )
        self._counts[topic] = sequence + 1

    def _PublishTopics(self, context: Context) -> None:
        sample = self._joint_states.Eval(context) if self._joint_states.HasValue(context) else None
        if sample is not None and sample.name and sample.stamp != self._last_stamp:
            self._Write(
                self._topics["joint_states"],
                "sensor_msgs/msg/JointState",
                joint_state_message(sample),
                sample.stamp,
            )
            self._last_stamp = sample.stamp
        for name, port in self._publications.items():
            if not port.HasValue(context):
                continue
            publication = port.Eval(context)
            if publication.count <= self._last_publication[name]:
                continue
            self._last_publication[name] = publication.count
            if name == "commands":
                type_name = "std_msgs/msg/Float64MultiArray"
                message = float64_multi_array_message(publication.message)
            elif name == "cartesian_trajectory":
                type_name = "cartesian_control_msgs/msg/CartesianTrajectory"
                message = cartesian_trajectory_message(publication.message)
            else:
                type_name = "trajectory_msgs/msg/JointTrajectory"
                message = joint_trajectory_message(publication.message)
            self._Write(self._topics[name], type_name, message, publication.stamp)

    def _PublishFrame(self, context: Context, camera: CameraStream, port) -> None:
        image = port.Eval(context)
        if image.width() != camera.width or image.height() != camera.height:
            return  # nothing rendered yet
        period = 1.0 / camera.rate
        stamp = math.floor(context.get_time() / period + 1e-6) * period
        rgb = np.ascontiguousarray(image.data[:, :, :3])
        self._Write(
            f"{camera.topic}/image_raw",
            "sensor_msgs/msg/Image",
            image_message(stamp, camera.frame_id, rgb),
            stamp,
        )
        self._Write(
            f"{camera.topic}/camera_info",
            "sensor_msgs/msg/CameraInfo",
            camera.camera_info(stamp),
            stamp,
        )


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


def AddRosbagRecorder(builder, world, path: str | os.PathLike) -> RosbagRecorder:
    """Adds a :class:`RosbagRecorder` writing ``path`` to a world being built.

    Connects the broadcaster's joint states, the sequencer's command topic
    (named after the controller it drives) and every camera; the world
    closes the file when it closes.
    """
    target = world.sequencer_target or "position_controller"
    task = world.task
    trajectory_owner = world.sequencer_target or "trajectory_controller"
    if task is not None and task.topic == "joint_trajectory" and world.sequencer is None:
        trajectory_owner = task.controller
    cameras = [camera_stream(name, camera) for name, camera in world.cameras.items()]
    recorder = builder.AddSystem(
        RosbagRecorder(
            path=path,
            update_rate=world.update_rate,
            commands_topic=f"/{target}/commands",
            trajectory_topic=f"/{trajectory_owner}/joint_trajectory",
            cartesian_topic=f"/{task.controller if task else 'operational_space_controller'}"
            "/cartesian_trajectory",
            cameras=cameras,
        )
    )
    recorder.set_name("rosbag_recorder")
    world.closers.append(recorder.close)
    if world.broadcaster is not None:
        builder.Connect(
            world.broadcaster.GetOutputPort("joint_states"),
            recorder.GetInputPort("joint_states"),
        )
    if world.sequencer is not None:
        for port in ("commands", "joint_trajectory"):
            builder.Connect(world.sequencer.GetOutputPort(port), recorder.GetInputPort(port))
    if task is not None and not builder.IsConnectedOrExported(recorder.GetInputPort(task.topic)):
        builder.Connect(task.source.get_output_port(), recorder.GetInputPort(task.topic))
    for stream in cameras:
        builder.Connect(
            world.cameras[stream.name].color_image,
            recorder.GetInputPort(f"{stream.name}.color_image"),
        )
    return recorder
