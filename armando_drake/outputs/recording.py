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
recorder to a world being built and records every topic of the world's publication
table (:mod:`armando_drake.outputs.publications`) that is ``recorded``: the joint state
broadcaster's, the command sequencer's (the commands actually sent to the controller it
drives), the cameras', and any other a subsystem registers there.

The file's metadata record ``armando_drake`` (:data:`METADATA_NAME`) names the
version of armando-drake that wrote it, and its git commit from a checkout.
The file is written with ``mcap-ros2-support`` (the MCAP project's ROS 2
writer). Its message definitions are those of :mod:`armando_drake.messages.definitions`
(the rosbags type store of ROS 2 Humble; these messages have not changed since).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

from armando_drake.messages.definitions import message_definition  # shared with the bridge
from armando_drake.messages.publications import Publications, Topic
from armando_drake.outputs.publications import (
    AttachTopics,
    TopicPublisher,
    recorded_name,
)
from armando_drake.tools.files import OutputFile
from armando_drake.tools.version import provenance

# The MCAP metadata record naming the code that wrote the file: version, and git commit
# when run from a checkout (:func:`~armando_drake.tools.version.provenance`).
METADATA_NAME = "armando_drake"


class RecordingError(ValueError):
    """A recording that cannot be written; the message names the path."""


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


class RosbagRecorder(TopicPublisher):
    """Writes the world's recorded topics to an MCAP file (ROS 2, CDR).

    .. pydrake_system::

        name: RosbagRecorder
        input_ports:
        - <k>:<topic> (one per recorded topic read from a port)

    Each topic of ``topics`` (:class:`~armando_drake.messages.publications.Topic`) that is
    read from a port is an input, read at the topic's rate; each new message is written
    on the topic's absolute name (``/joint_states``, ``/left/joint_states``), log time
    its stamp: joint states whenever their stamp is new (the same samples, at the same
    times, as the joint-state logger's CSV), a command whenever the publication's count
    grows, a camera frame a thousandth of a period after it is taken. The topics sent by
    a source (a mobile base, a navigation, the detectors) come through :meth:`write`.
    Call :meth:`close` when the run ends (it writes the MCAP summary); closing twice is
    harmless.
    """

    def __init__(self, *, path: str | os.PathLike, topics: Sequence[Topic] = ()):
        from mcap_ros2.writer import Writer

        super().__init__(topics, self._Write, name=recorded_name)
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


def AddRosbagRecorder(builder, path: str | os.PathLike, table: Publications) -> RosbagRecorder:
    """Adds a :class:`RosbagRecorder` writing ``path`` to a world being built.

    Records every ``recorded`` topic of ``table``, the world's publication table (the
    topics of the robots of a world of several under their namespace:
    ``/left/joint_states``, ``/left/position_controller/commands``); the world closes the
    file (``close``) when it closes.
    """
    recorded = table.published(recorded=True)
    recorder = builder.AddNamedSystem("rosbag_recorder", RosbagRecorder(path=path, topics=recorded))
    AttachTopics(builder, recorder, recorded, recorder.write, consumer="recorder")
    return recorder
