"""Two robots on DDS: each one's joint states, robot description and command topics under
its namespace (/left/..., /right/...), one /clock, tf frames named <namespace>/<link>."""

import time

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from ros2_support import new_domain_id

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

pytest.importorskip("cyclonedds")

# Two Armandos facing each other, nothing driving them but DDS.
ARM = "xacro_args: {use_camera: 'false'}"
ROBOTS = (
    "robots:\n"
    f"  - {{name: left, robot: {{{ARM}, base_xyz: [-0.25, 0, 0.0313]}},\n"
    "     controllers: {activate: [joint_state_broadcaster, position_controller]}}\n"
    f"  - {{name: right, robot: {{{ARM}, base_xyz: [0.25, 0, 0.0313], base_rpy: [0, 0, 3.1416]}},\n"
    "     controllers: {activate: [joint_state_broadcaster, position_controller]}}\n"
)


def test_each_robot_is_driven_and_heard_on_its_own_topics():
    """A Float64MultiArray on /right/position_controller/commands moves the right arm only;
    /left/joint_states and /right/joint_states each carry their robot's joints; /clock is
    published once per tick; /tf names the right arm's links right/<link>."""
    from armando_drake.messages.definitions import float64_multi_array_message
    from armando_drake.messages.types import Float64MultiArray
    from armando_drake.ros2.dds import DdsNode

    domain_id = new_domain_id()
    overrides = f"ros2: {{enabled: true, domain_id: {domain_id}}}\nlogging: {{console_rate: 0}}\n"
    world = MakeWorld(load_scenario("dual_armando", overrides + ROBOTS), quiet=True)
    node = DdsNode(domain_id=domain_id)
    received: dict[str, list] = {}
    for topic, type_name in (
        ("/left/joint_states", "sensor_msgs/msg/JointState"),
        ("/right/joint_states", "sensor_msgs/msg/JointState"),
        ("/clock", "rosgraph_msgs/msg/Clock"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
    ):
        node.subscribe(topic, type_name, received.setdefault(topic, []).append)
    topic, type_name = "/right/position_controller/commands", "std_msgs/msg/Float64MultiArray"
    node.advertise(topic, type_name)
    writer = node.writer(topic)
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(0)
    simulator.Initialize()
    deadline = time.monotonic() + 10
    while writer.get_publication_matched_status().current_count == 0:
        assert time.monotonic() < deadline, "the world's subscription was not found"
        time.sleep(0.02)
    target = [0.5, -0.3, 0.4, 0.2]
    node.publish(topic, type_name, float64_multi_array_message(Float64MultiArray(data=target)))
    right_bridge = world.diagram.GetSubsystemByName("right/ros2_bridge")
    deadline = time.monotonic() + 10
    while right_bridge.received["position_controller/commands"] == 0:
        assert time.monotonic() < deadline, "the command did not arrive"
        time.sleep(0.01)
    simulator.AdvanceTo(1.5)
    context = simulator.get_context()
    right, left = world.joint_positions(context, "right"), world.joint_positions(context, "left")
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and len(received["/right/joint_states"]) < 140:
        time.sleep(0.05)
    world.close(context)
    node.close()
    assert np.abs(right - target).max() <= 0.01, right
    assert np.abs(left).max() <= 0.01, left  # the left arm held its start
    for space in ("left", "right"):
        states = received[f"/{space}/joint_states"]
        assert len(states) >= 140 and list(states[-1]["name"]) == ["j0", "j1", "j2", "j3"]
    assert abs(received["/right/joint_states"][-1]["position"][0] - 0.5) < 0.01
    # One /clock per tick (the first robot's bridge), not one per robot.
    stamps = [m["clock"]["sec"] * 10**9 + m["clock"]["nanosec"] for m in received["/clock"]]
    assert len(stamps) == len(set(stamps)) >= 140
    frames = {t["child_frame_id"] for m in received["/tf"] for t in m["transforms"]}
    moving = ["base_turn_rot", "dyn2_r", "dyn3_r", "dyn4_r"]  # the children of j0..j3
    assert frames == {f"{space}/{link}" for space in ("left", "right") for link in moving}
