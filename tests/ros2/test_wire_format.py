"""The bytes our DDS writer sends are ROS 2's CDR, as rosbags serialises it.

A reader in another process takes the raw serialised samples off the loopback
(Cyclone's ``ddspy_take``, before any decoding) and prints them; each must equal,
byte for byte including the encapsulation header, what rosbags (an independent
ROS 2 CDR implementation) makes of the same message.
"""

import json
import subprocess
import textwrap
import time

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from ros2_support import new_domain_id, python, subprocess_env

from armando_drake.messages import definitions as messages
from armando_drake.messages.types import (
    Float64MultiArray,
    JointState,
    JointTrajectory,
    JointTrajectoryPoint,
)

pytest.importorskip("cyclonedds")
rosbags_typesys = pytest.importorskip("rosbags.typesys")

X_PC = RigidTransform(RollPitchYaw(0.3, -0.2, 1.1), [0.01, -0.02, 0.1234])
SAMPLES = {
    "/joint_states": (
        "sensor_msgs/msg/JointState",
        messages.joint_state_message(
            JointState(
                stamp=12.345678901,
                name=("j0", "j1", "joint_2"),
                position=(0.1, -0.2, 1.5),
                velocity=(0.0, 1e-3, -2.0),
                effort=(0.5, 0.25, -0.125),
            )
        ),
    ),
    "/position_controller/commands": (
        "std_msgs/msg/Float64MultiArray",
        messages.float64_multi_array_message(Float64MultiArray(data=(1.2, -1.0, 1.2, 0.6))),
    ),
    "/trajectory_controller/joint_trajectory": (
        "trajectory_msgs/msg/JointTrajectory",
        messages.joint_trajectory_message(
            JointTrajectory(
                stamp=0.0,
                joint_names=("j0", "j1"),
                points=(
                    JointTrajectoryPoint(positions=(0.5, -0.5), time_from_start=1.5),
                    JointTrajectoryPoint(
                        positions=(1.0, -1.0), velocities=(0.0, 0.0), time_from_start=3.0
                    ),
                ),
            )
        ),
    ),
    "/tf": (
        "tf2_msgs/msg/TFMessage",
        {
            "transforms": [
                messages.transform_stamped(7.25, "base_link", "link1", X_PC),
                messages.transform_stamped(7.25, "link1", "link_2", X_PC.inverse()),
            ]
        },
    ),
}

READER = textwrap.dedent(
    """
    import json, sys, time
    from cyclonedds.core import SampleState, ViewState, InstanceState
    from cyclonedds._clayer import ddspy_take
    from cyclonedds.domain import Domain, DomainParticipant
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from armando_drake.ros2.dds import QOS, cyclonedds_config
    from armando_drake.ros2.idl import idl_type

    domain_id, topics = int(sys.argv[1]), json.loads(sys.argv[2])
    domain = Domain(domain_id, cyclonedds_config())
    participant = DomainParticipant(domain_id)
    readers = {
        topic: DataReader(participant, Topic(participant, "rt" + topic, idl_type(type_name)),
                          qos=QOS["default"])
        for topic, type_name in topics.items()
    }
    print("ready", flush=True)
    payloads, deadline = {}, time.monotonic() + 30
    mask = SampleState.Any | ViewState.Any | InstanceState.Any
    while len(payloads) < len(readers) and time.monotonic() < deadline:
        for topic, reader in readers.items():
            for data, info in ddspy_take(reader._ref, mask, 1):
                if info.valid_data:
                    payloads[topic] = bytes(data).hex()
        time.sleep(0.01)
    print(json.dumps(payloads), flush=True)
    """
)


def _rosbags_message(typestore, type_name: str, value):
    """The rosbags message of a message dictionary, built field by field from its classes."""
    kwargs = {
        name: _rosbags_field(typestore, detail, value[name])
        for name, detail in typestore.fielddefs[type_name][1]
    }
    return typestore.types[type_name](**kwargs)


def _rosbags_field(typestore, detail, value):
    from rosbags.interfaces import Nodetype

    kind = detail[0]
    if kind == Nodetype.BASE:
        return value
    if kind == Nodetype.NAME:
        return _rosbags_message(typestore, detail[1], value)
    element = detail[1][0]
    if element[0] == Nodetype.BASE and element[1][0] != "string":
        return np.array(value, dtype={"float64": np.float64, "uint8": np.uint8}[element[1][0]])
    return [_rosbags_field(typestore, element, item) for item in value]


def test_payloads_on_the_wire_equal_rosbags_cdr():
    domain_id = new_domain_id()
    from armando_drake.ros2.dds import DdsNode

    topics = {topic: type_name for topic, (type_name, _) in SAMPLES.items()}
    reader = subprocess.Popen(
        [python(), "-c", READER, str(domain_id), json.dumps(topics)],
        stdout=subprocess.PIPE,
        text=True,
        env=subprocess_env(),
    )
    node = DdsNode(domain_id=domain_id)
    try:
        assert reader.stdout.readline().strip() == "ready"
        deadline = time.monotonic() + 30
        while reader.poll() is None and time.monotonic() < deadline:
            for topic, (type_name, message) in SAMPLES.items():
                node.publish(topic, type_name, message)
            time.sleep(0.05)
        received = json.loads(reader.stdout.read())
    finally:
        reader.kill()
        node.close()

    typestore = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_JAZZY)
    assert set(received) == set(SAMPLES)
    for topic, (type_name, message) in SAMPLES.items():
        expected = bytes(
            typestore.serialize_cdr(_rosbags_message(typestore, type_name, message), type_name)
        )
        wire = bytes.fromhex(received[topic])
        assert wire[:4] == b"\x00\x01\x00\x00", f"{topic}: header {wire[:4].hex()}"
        assert wire == expected, f"{topic}: {wire.hex()} != {expected.hex()}"


# Messages of packages outside ROS 2 Jazzy's core set, with their fields as the
# package's .msg files list them (Universal Robots' cartesian_control_msgs, ros2_control's
# control_msgs).
NOT_IN_JAZZY = {
    "control_msgs/msg/MultiDOFCommand": ["dof_names", "values", "values_dot"],
    "control_msgs/msg/SpeedScalingFactor": ["factor"],
    "cartesian_control_msgs/msg/CartesianPosture": [
        "posture_joint_names", "posture_joint_values"
    ],
    "cartesian_control_msgs/msg/CartesianTrajectoryPoint": [
        "time_from_start", "pose", "twist", "acceleration", "jerk", "posture"
    ],
    "cartesian_control_msgs/msg/CartesianTrajectory": ["header", "points", "controlled_frame"],
}  # fmt: skip
ALL_TYPES = sorted(messages.MESSAGE_TYPES)


@pytest.mark.parametrize("type_name", sorted(NOT_IN_JAZZY))
def test_messages_outside_jazzy_have_their_package_fields(type_name):
    assert [name for _, name in messages.fields(type_name)] == NOT_IN_JAZZY[type_name]


@pytest.mark.parametrize("type_name", [t for t in ALL_TYPES if t not in NOT_IN_JAZZY])
def test_every_message_type_is_named_and_defined_as_ros2_does(type_name):
    """The DDS type name and the .msg fields of every type agree with rosbags' Jazzy store."""
    from armando_drake.ros2.idl import idl_type

    typestore = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_JAZZY)
    ours = [name for _, name in messages.fields(type_name)]
    assert ours == [name for name, _ in typestore.fielddefs[type_name][1]]
    package, _, name = type_name.split("/")
    assert idl_type(type_name).__idl_typename__ == f"{package}::msg::dds_::{name}_"
