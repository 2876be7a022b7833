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
``/camera/points`` (perception on)   ``sensor_msgs/msg/PointCloud2``
``/perception/clusters``             ``visualization_msgs/msg/MarkerArray``
``/odom``, ``/tf`` (mobile base)     ``nav_msgs/msg/Odometry``, ``tf2_msgs/msg/TFMessage``
``/cmd_vel`` (twist sequence)        ``geometry_msgs/msg/Twist``
``/scan`` (a lidar's topic)          ``sensor_msgs/msg/LaserScan``
==================================== ====================================

Times are simulation time: each message's log time and header stamp are the
simulation time at which it was sampled or published (a run starts at
1970-01-01 00:00:00 on a player's clock). :func:`AddRosbagRecorder` adds the
recorder to a world being built and connects it to the joint state
broadcaster, the command sequencer (the commands actually sent to the
controller it drives) and the cameras.

The file's metadata record ``armando_drake`` (:data:`METADATA_NAME`) names the
version of armando-drake that wrote it, and its git commit from a checkout.
The file is written with ``mcap-ros2-support`` (the MCAP project's ROS 2
writer). Its message definitions are those of :mod:`armando_drake.messages.definitions`
(ROS 2 Humble and later; these messages have not changed).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem
from pydrake.systems.sensors import ImageRgba8U

from armando_drake.messages.definitions import (  # the message definitions, shared with the bridge
    cartesian_trajectory_message,
    float64_multi_array_message,
    header,
    image_message,
    joint_state_message,
    joint_trajectory_message,
    message_definition,
    ros_time,
)
from armando_drake.messages.types import JointState, PublicationValue
from armando_drake.outputs.mobile_topics import AddMobileTopics
from armando_drake.outputs.navigation_topics import AddNavigationTopics
from armando_drake.outputs.topics import WorldTopics
from armando_drake.outputs.vision_recording import AddVisionRecorder
from armando_drake.perception.pipeline import NO_RESULT
from armando_drake.perception.systems import CLUSTER_COLOURS
from armando_drake.sensors.image_view import PUBLISH_OFFSET_FRACTION
from armando_drake.tools.files import OutputFile
from armando_drake.tools.version import provenance

# The MCAP metadata record naming the code that wrote the file: version, and git commit
# when run from a checkout (:func:`~armando_drake.tools.version.provenance`).
METADATA_NAME = "armando_drake"


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
    """``path`` if an MCAP file can be created there (its folder is made if missing, as
    ``--output`` makes its own); RecordingError naming it otherwise."""
    path = Path(path)
    if path.suffix != ".mcap":
        raise RecordingError(f"--record {path}: the file name must end in .mcap")
    folder = path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise RecordingError(
            f"--record {path}: cannot make folder {folder}: {error.strerror}"
        ) from None
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


@dataclass
class _Tap:
    """One robot's topics in a :class:`RosbagRecorder`: its inputs and what was written."""

    topics: dict[str, str]  # input name -> topic
    joint_states: Any  # the joint_states input
    publications: dict[str, Any]  # commands, joint_trajectory, ... inputs
    last_stamp: float | None = None  # of the latest joint state written
    last_publication: dict[str, int] = field(default_factory=dict)  # counts written


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

    - ``joint_states``: a :class:`~armando_drake.messages.types.JointState`; a
      sample is recorded on ``joint_states_topic`` whenever its stamp is new,
      with that stamp (the same samples, at the same times, as the
      joint-state logger's CSV);
    - ``commands`` / ``joint_trajectory``: a
      :class:`~armando_drake.messages.types.Publication` of Float64MultiArray /
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
        try:
            self._file: IO[bytes] | None = OutputFile(self._path, "wb")  # type: ignore[assignment]
        except OSError as error:
            raise RecordingError(f"--record {path}: cannot write: {error.strerror}") from None
        self._writer = Writer(self._file)
        # The code that wrote the file, as summary.json names it.
        self._writer.add_metadata(METADATA_NAME, provenance())
        self._schemas: dict[str, Any] = {}
        self._counts: dict[str, int] = {}  # messages written, by topic
        self._taps: list[_Tap] = []  # each robot's topics, the first one's first
        topics = {
            "joint_states": joint_states_topic,
            "commands": commands_topic,
            "joint_trajectory": trajectory_topic,
            "cartesian_trajectory": cartesian_topic,
        }
        self._AddTap("", topics, update_rate)

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

    def write(self, topic: str, type_name: str, message: dict[str, Any], stamp: float) -> None:
        """Writes one message (a dictionary of its fields) stamped ``stamp`` [s]."""
        self._Write(topic, type_name, message, stamp)

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

    def add_robot(
        self, namespace: str, update_rate: float, *, commands_topic: str, trajectory_topic: str
    ) -> None:
        """Records another robot of the world too (before the diagram is built), from its
        inputs ``<namespace>/joint_states``, ``<namespace>/commands`` and
        ``<namespace>/joint_trajectory`` (``namespace`` without its leading ``/``), on
        ``/<namespace>/joint_states``, ``commands_topic`` and ``trajectory_topic``,
        sampled at ``update_rate`` [Hz]."""
        topics = {
            "joint_states": f"/{namespace}/joint_states",
            "commands": commands_topic,
            "joint_trajectory": trajectory_topic,
        }
        self._AddTap(f"{namespace}/", topics, update_rate)

    def _AddTap(self, prefix: str, topics: dict[str, str], update_rate: float) -> None:
        """The inputs of one robot's topics (their names begin with ``prefix``), read by a
        periodic publish event at ``update_rate`` [Hz] from t = 0."""
        names = [n for n in ("commands", "joint_trajectory", "cartesian_trajectory") if n in topics]
        tap = _Tap(
            topics=dict(topics),
            joint_states=self.DeclareAbstractInputPort(
                f"{prefix}joint_states", AbstractValue.Make(JointState())
            ),
            publications={
                name: self.DeclareAbstractInputPort(f"{prefix}{name}", PublicationValue())
                for name in names
            },
        )
        self._taps.append(tap)
        self.DeclarePeriodicPublishEvent(
            1.0 / update_rate, 0.0, lambda context, tap=tap: self._PublishTopics(context, tap)
        )

    def _PublishTopics(self, context: Context, tap: _Tap) -> None:
        port = tap.joint_states
        sample = port.Eval(context) if port.HasValue(context) else None
        if sample is not None and sample.name and sample.stamp != tap.last_stamp:
            self._Write(
                tap.topics["joint_states"],
                "sensor_msgs/msg/JointState",
                joint_state_message(sample),
                sample.stamp,
            )
            tap.last_stamp = sample.stamp
        for name, port in tap.publications.items():
            if not port.HasValue(context):
                continue
            publication = port.Eval(context)
            if publication.count <= tap.last_publication.get(name, 0):
                continue
            tap.last_publication[name] = publication.count
            if name == "commands":
                type_name = "std_msgs/msg/Float64MultiArray"
                message = float64_multi_array_message(publication.message)
            elif name == "cartesian_trajectory":
                type_name = "cartesian_control_msgs/msg/CartesianTrajectory"
                message = cartesian_trajectory_message(publication.message)
            else:
                type_name = "trajectory_msgs/msg/JointTrajectory"
                message = joint_trajectory_message(publication.message)
            self._Write(tap.topics[name], type_name, message, publication.stamp)

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


def AddRosbagRecorder(
    builder, path: str | os.PathLike, topics: WorldTopics, others: Sequence[WorldTopics] = ()
) -> RosbagRecorder:
    """Adds a :class:`RosbagRecorder` writing ``path`` to a world being built.

    Connects the broadcaster's joint states, the sequencer's (or the live jog's)
    command topic (named after the controller it drives), every camera, the point
    clouds and the detections of ``topics``; the world closes the file (``close``)
    when it closes. ``others``: the other robots of a world of several, whose joint
    states, sequencer's commands and base's topics are recorded too; each robot's
    topics are under its namespace (``/left/joint_states``,
    ``/left/position_controller/commands``).
    """
    jog = topics.jog  # the live jog, when no sequencer drives
    jogged = jog.controller if jog is not None and topics.sequencer is None else ""
    target = topics.sequencer_target or jogged or "position_controller"
    task = topics.task
    trajectory_owner = topics.sequencer_target or jogged or "trajectory_controller"
    if task is not None and task.topic == "joint_trajectory" and topics.sequencer is None:
        trajectory_owner = task.controller
    cameras = [camera_stream(name, camera) for name, camera in topics.cameras.items()]
    recorder = builder.AddSystem(
        RosbagRecorder(
            path=path,
            update_rate=topics.update_rate,
            commands_topic=topics.topic(f"{target}/commands"),
            trajectory_topic=topics.topic(f"{trajectory_owner}/joint_trajectory"),
            cartesian_topic=topics.topic(
                f"{task.controller if task else 'operational_space_controller'}"
                "/cartesian_trajectory"
            ),
            cameras=cameras,
            joint_states_topic=topics.topic(topics.joint_states_topic),
        )
    )
    recorder.set_name("rosbag_recorder")
    if topics.broadcaster is not None:
        builder.Connect(
            topics.broadcaster.GetOutputPort("joint_states"),
            recorder.GetInputPort("joint_states"),
        )
    if topics.sequencer is not None:
        for port in ("commands", "joint_trajectory"):
            builder.Connect(topics.sequencer.GetOutputPort(port), recorder.GetInputPort(port))
    if jogged:
        port = "joint_trajectory" if jog.sends_trajectories else "commands"
        builder.Connect(jog.GetOutputPort("commands"), recorder.GetInputPort(port))
    if task is not None and not builder.IsConnectedOrExported(recorder.GetInputPort(task.topic)):
        builder.Connect(task.source.get_output_port(), recorder.GetInputPort(task.topic))
    for stream in cameras:
        builder.Connect(
            topics.cameras[stream.name].color_image,
            recorder.GetInputPort(f"{stream.name}.color_image"),
        )
    if topics.perception is not None:  # point clouds, clusters
        AddPerceptionRecorder(builder, topics, recorder)
    if topics.detectors is not None:  # detections
        AddVisionRecorder(builder, topics, recorder)
    # A mobile base's odometry, /tf, cmd_vel and its lidars' scans.
    AddMobileTopics(builder, topics, recorder.write, name="mobile_recorder")
    for other in others:
        _record_robot(builder, recorder, other)
    # A navigation's /map, /plan, goal frames and map -> odom.
    AddNavigationTopics(builder, topics, recorder.write, name="navigation_recorder")
    return recorder


def _record_robot(builder, recorder: RosbagRecorder, topics: WorldTopics) -> None:
    """Another robot's joint states, its sequencer's commands and its base's topics."""
    space = topics.stack.namespace.strip("/")
    target = topics.sequencer_target
    recorder.add_robot(
        space,
        topics.update_rate,
        commands_topic=topics.topic(f"{target or 'position_controller'}/commands"),
        trajectory_topic=topics.topic(f"{target or 'trajectory_controller'}/joint_trajectory"),
    )
    if topics.broadcaster is not None:
        builder.Connect(
            topics.broadcaster.GetOutputPort("joint_states"),
            recorder.GetInputPort(f"{space}/joint_states"),
        )
    if topics.sequencer is not None:
        for port in ("commands", "joint_trajectory"):
            builder.Connect(
                topics.sequencer.GetOutputPort(port), recorder.GetInputPort(f"{space}/{port}")
            )
    AddMobileTopics(builder, topics, recorder.write, name=f"{space}/mobile_recorder")


# --------------------------------------------------------------------------
# Perception: /camera/points and /perception/clusters
# --------------------------------------------------------------------------

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
    """Records a camera's point cloud and the perception results through a
    :class:`RosbagRecorder`.

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
        recorder: RosbagRecorder,
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
        from pydrake.perception import PointCloud

        self._recorder = recorder
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
        self._recorder.write(self._topics[0], "sensor_msgs/msg/PointCloud2", message, stamp)

    def _PublishClusters(self, context: Context) -> None:
        result = self._result.Eval(context)
        if not result.computed or result.time == self._last_time:
            return
        self._last_time = result.time
        message = marker_array_message(result, result.time, self._frames[1])
        self._recorder.write(
            self._topics[1], "visualization_msgs/msg/MarkerArray", message, result.time
        )


def AddPerceptionRecorder(
    builder, topics: WorldTopics, recorder: RosbagRecorder
) -> PerceptionRecorder:
    """Records ``topics.perception``'s camera cloud (``/camera/points``, in the camera's
    optical frame ``<link>_optical``: z forward, x right, y down) and clusters
    (``/perception/clusters``, in ``world`` or that optical frame)."""
    perception = topics.perception
    camera = topics.cameras[perception.camera]
    info = camera.info
    optical = f"{info.link}_optical"
    topic = "/" + (info.topic or info.name).strip("/")
    system = builder.AddNamedSystem(
        "perception_recorder",
        PerceptionRecorder(
            recorder=recorder,
            camera_rate=info.frame_rate,
            points_rate=perception.config.points_record_rate,
            clusters_rate=perception.config.rate,
            offset=2 * perception.offset,
            image_size=(info.width, info.height),
            points_frame_id=optical,
            clusters_frame_id="world" if perception.config.frame == "world" else optical,
            points_topic=f"{topic}/points",
        ),
    )
    builder.Connect(perception.points_in_camera, system.GetInputPort("points"))
    builder.Connect(perception.result, system.GetInputPort("result"))
    return system
