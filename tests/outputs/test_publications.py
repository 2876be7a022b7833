"""The publication table: a publisher registered in it as the world is built is recorded
in the MCAP file, published on DDS and served to Foxglove, with no edit of the recorder or
the bridge; its message type (sensor_msgs/Imu, which no module of the package speaks)
comes from the rosbags type store."""

import json
import os
import random
import threading
import time

import pytest
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, EventStatus, LeafSystem

from armando_drake.control.stack import (
    ActuatorConfig,
    AddControllerManager,
    AddHardware,
    ConnectControlStack,
    ControllersConfig,
    LoadControllerConfig,
)
from armando_drake.description.loader import load_robot
from armando_drake.messages.definitions import header, message_definition
from armando_drake.messages.publications import (
    PUBLISH,
    SUBSCRIBE,
    PublicationRegistry,
    Publications,
    Topic,
    published,
)
from armando_drake.messages.types import PublicationValue
from armando_drake.outputs.recording import AddRosbagRecorder
from armando_drake.ros2.bridge import AddRos2Bridge, BridgeRobot
from armando_drake.ros2.config import Ros2Config

IMU_RATE = 50.0  # [Hz]
GRAVITY = 9.81  # [m/s^2]


class ImuSensor(LeafSystem):
    """A test-only sensor: a reading (stamp, z acceleration) on its ``imu`` port, a
    Publication at IMU_RATE."""

    def __init__(self):
        super().__init__()
        self._state = self.DeclareAbstractState(PublicationValue())
        self.DeclareStateOutputPort("imu", self._state)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / IMU_RATE, 0.0, self._Update)

    def _Update(self, context, state) -> EventStatus:
        publication = context.get_abstract_state(self._state).get_value()
        stamp = context.get_time()
        reading = (stamp, GRAVITY + 0.001 * publication.count)
        state.get_mutable_abstract_state(self._state).set_value(
            publication.publish(reading, stamp=stamp)
        )
        return EventStatus.Succeeded()


def imu_message(reading) -> dict:
    """sensor_msgs/Imu of a reading: the z acceleration, nothing else measured."""
    stamp, az = reading
    vector = {"x": 0.0, "y": 0.0, "z": 0.0}
    return {
        "header": header(stamp, "imu_link"),
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        "orientation_covariance": [-1.0] + [0.0] * 8,  # no orientation, as REP 145 says
        "angular_velocity": vector,
        "angular_velocity_covariance": [0.0] * 9,
        "linear_acceleration": {**vector, "z": az},
        "linear_acceleration_covariance": [0.0] * 9,
    }


def armando_world(builder, publications: PublicationRegistry):
    """Armando with its joint state broadcaster and position controller, as MakeWorld
    adds them, their topics registered in ``publications``; its ControlStack."""
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.001), builder)
    robot = load_robot(plant)
    controllers = ControllersConfig(activate=["joint_state_broadcaster", "position_controller"])
    yaml = LoadControllerConfig(controllers, robot)
    hardware = AddHardware(plant, scene_graph, robot, ActuatorConfig(), yaml)
    stack = AddControllerManager(
        builder,
        controllers,
        plant=plant,
        robot=robot,
        hardware=hardware,
        controller_config=yaml,
        update_rate=yaml.update_rate,
        publications=publications,
    )
    return stack


def AddImu(builder, publications: PublicationRegistry) -> ImuSensor:
    """The test IMU's AddX: adds the sensor and registers its topic, one record, as
    every AddX of the world registers its own."""
    imu = builder.AddSystem(ImuSensor())
    publications.add(
        Topic("imu/data", "sensor_msgs/msg/Imu", port=imu.GetOutputPort("imu"),
              read=published(imu_message), rate=IMU_RATE, frame_id="imu_link")
    )  # fmt: skip
    return imu


def with_imu(builder) -> tuple[object, Publications]:
    """Armando and the test IMU: (its ControlStack, the world's table)."""
    publications = PublicationRegistry()
    stack = armando_world(builder, publications)
    AddImu(builder, publications)
    return stack, publications.table()


def test_the_table_lists_the_world_topics_and_subscriptions():
    builder = DiagramBuilder()
    _, table = with_imu(builder)
    assert [(t.name, t.type_name, t.direction) for t in table.topics] == [
        ("joint_states", "sensor_msgs/msg/JointState", PUBLISH),
        ("position_controller/commands", "std_msgs/msg/Float64MultiArray", SUBSCRIBE),
        ("imu/data", "sensor_msgs/msg/Imu", PUBLISH),
    ]
    assert message_definition("sensor_msgs/msg/Imu").startswith("std_msgs/Header header\n")
    with pytest.raises(ValueError, match="'imu/data'.*needs a port and read, or a source"):
        Topic("imu/data", "sensor_msgs/msg/Imu")


def test_a_publisher_added_to_the_table_is_recorded(tmp_path):
    from rosbags.highlevel import AnyReader  # a test dependency

    builder = DiagramBuilder()
    stack, table = with_imu(builder)
    recorder = AddRosbagRecorder(builder, tmp_path / "run.mcap", table)
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.5)
    recorder.close()
    messages = []
    with AnyReader([tmp_path / "run.mcap"]) as reader:
        for connection, log_time, raw in reader.messages():
            if connection.topic == "/imu/data":
                assert connection.msgtype == "sensor_msgs/msg/Imu"
                messages.append((log_time, reader.deserialize(raw, connection.msgtype)))
    assert len(messages) == 25  # 50 Hz, from 0 to 0.48 s
    for k, (log_time, message) in enumerate(messages):
        assert log_time == round(k / IMU_RATE * 1e9)
        assert message.header.frame_id == "imu_link"
        assert message.linear_acceleration.z == pytest.approx(GRAVITY + 0.001 * k)
    assert recorder.message_counts["/joint_states"] == 51  # the world's own, as before


def test_a_publisher_added_to_the_table_is_on_dds_and_in_foxglove():
    pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds)")
    pytest.importorskip("foxglove", reason="the ros2 extra (foxglove-sdk)")
    websockets_client = pytest.importorskip("websockets.sync.client")
    from armando_drake.ros2.dds import DdsNode

    domain_id = random.Random(os.getpid() * 7919 + time.monotonic_ns()).randint(100, 230)
    builder = DiagramBuilder()
    stack, table = with_imu(builder)
    config = Ros2Config(enabled=True, domain_id=domain_id, foxglove=True, foxglove_port=0)
    bridge = AddRos2Bridge(builder, config, table, [BridgeRobot(stack)])
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    node = DdsNode(domain_id=domain_id)
    received: list[dict] = []
    node.subscribe("/imu/data", "sensor_msgs/msg/Imu", received.append)
    _, server = bridge.sinks
    channels: dict[str, dict] = {}
    advertised = threading.Event()

    def client():
        with websockets_client.connect(
            server.url, subprotocols=["foxglove.sdk.v1"], open_timeout=10
        ) as socket:
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline and "/imu/data" not in channels:
                frame = socket.recv(timeout=5)
                if isinstance(frame, str):
                    message = json.loads(frame)
                    if message["op"] == "advertise":
                        channels.update({c["topic"]: c for c in message["channels"]})
            advertised.set()

    thread = threading.Thread(target=client, daemon=True)
    thread.start()
    simulator = Simulator(builder.Build())
    simulator.set_target_realtime_rate(0)
    simulator.Initialize()
    deadline = time.monotonic() + 10
    while len(received) < 10 and time.monotonic() < deadline:
        simulator.AdvanceTo(simulator.get_context().get_time() + 0.1)
        time.sleep(0.01)
    assert advertised.wait(20)
    bridge.close()
    node.close()
    assert len(received) >= 10
    assert received[-1]["header"]["frame_id"] == "imu_link"
    assert received[-1]["linear_acceleration"]["z"] > GRAVITY
    channel = channels["/imu/data"]
    assert (channel["schemaName"], channel["schemaEncoding"]) == ("sensor_msgs/msg/Imu", "ros2msg")
    assert channel["schema"] == message_definition("sensor_msgs/msg/Imu")
