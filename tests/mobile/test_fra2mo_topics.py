"""fra2mo's topics: /odom, /tf (odom -> base_footprint), /cmd_vel and /scan in the MCAP
recording, read back with rosbags; over DDS, a Twist on /cmd_vel drives the base."""

import math
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mobile_world import scenario
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "ros2"))

TWIST = "twist: {start_delay: 0.2, steps: [{linear: 0.2, angular: 0.0, duration: 1.0}]}"


def _read_bag(path: Path) -> dict[str, list]:
    """(log time [ns], message) per topic, read with rosbags (not the writer's library)."""
    from rosbags.highlevel import AnyReader

    topics: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for connection, log_time, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append((log_time, message))
        topics["__types__"] = {c.topic: c.msgtype for c in reader.connections}
    return topics


def _stamp(message) -> float:
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def test_mcap_has_odom_tf_cmd_vel_and_scan(tmp_path):
    """1.4 s of fra2mo driving 0.2 m/s straight: /scan at 10 Hz with 640 ranges (the crate
    1.45 m ahead at the start); /odom at the drive's 50 Hz, its last pose that of base.csv's
    odometry; /tf odom -> base_footprint with the same pose; /cmd_vel the sequence's twist."""
    path = tmp_path / "run.mcap"
    world = MakeWorld(scenario(TWIST), quiet=True, record=path)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(1.4)
    world.close(simulator.get_context())
    bag = _read_bag(path)
    types = bag["__types__"]
    assert types["/odom"] == "nav_msgs/msg/Odometry"
    assert types["/scan"] == "sensor_msgs/msg/LaserScan"
    assert types["/cmd_vel"] == "geometry_msgs/msg/Twist"
    assert types["/tf"] == "tf2_msgs/msg/TFMessage"
    scans = [message for _, message in bag["/scan"]]
    assert len(scans) == 14  # 0, 0.1, ..., 1.3 s (the 1.4 s one is taken as the next step begins)
    assert all(len(scan.ranges) == 640 for scan in scans)
    first = scans[0]
    assert first.header.frame_id == "laser_frame" and first.range_max == pytest.approx(10.0)
    ahead = int(np.argmin(np.abs(first.angle_min + first.angle_increment * np.arange(640))))
    assert abs(first.ranges[ahead] - 1.45) < 0.01, first.ranges[ahead]
    # The last scan sees the crate nearer by what the base drove.
    odom = [message for _, message in bag["/odom"]]
    assert 60 <= len(odom) <= 71  # 50 Hz
    last = odom[-1]
    assert (last.header.frame_id, last.child_frame_id) == ("odom", "base_footprint")
    logged = world.robot().base_log.array()
    assert last.pose.pose.position.x == pytest.approx(logged[-1, 8], abs=1e-9)
    assert 0.15 < last.pose.pose.position.x < 0.25  # ~1 s at 0.2 m/s
    moving = min(odom, key=lambda message: abs(_stamp(message) - 1.0))  # the step ends at 1.2 s
    assert abs(moving.twist.twist.linear.x - 0.2) < 0.01
    assert abs(last.twist.twist.linear.x) < 0.01  # stopped
    x_final = last.pose.pose.position.x
    assert abs(scans[-1].ranges[ahead] - (1.45 - x_final)) < 0.02
    base_tf = [
        (t, tf)
        for t, message in bag["/tf"]
        for tf in message.transforms
        if tf.child_frame_id == "base_footprint"
    ]
    assert len(base_tf) == len(odom) and base_tf[-1][1].header.frame_id == "odom"
    assert base_tf[-1][1].transform.translation.x == pytest.approx(x_final)
    twists = [message for _, message in bag["/cmd_vel"]]
    assert 20 <= len(twists) <= 25  # 20 Hz from 0.2 s
    assert twists[0].linear.x == pytest.approx(0.2) and twists[-1].linear.x == 0.0
    assert all(_stamp(scan) == pytest.approx(0.1 * k) for k, scan in enumerate(scans))


def test_cmd_vel_over_dds_drives_the_base():
    """With --ros2 and no twist sequence, /cmd_vel is subscribed (geometry_msgs/Twist, as
    the course's bridge takes it): a Twist of 0.2 m/s from another participant drives
    fra2mo forward; /odom and /scan come back over DDS."""
    pytest.importorskip("cyclonedds")
    from ros2_support import new_domain_id

    from armando_drake.messages.definitions import twist_message
    from armando_drake.messages.types import Twist
    from armando_drake.ros2.dds import DdsNode

    domain_id = new_domain_id()
    loaded = scenario("twist: null", f"ros2: {{enabled: true, domain_id: {domain_id}}}")
    world = MakeWorld(loaded, quiet=True)
    bridge = world.diagram.GetSubsystemByName("ros2_bridge")
    assert [(c.topic, c.type_name) for c in bridge.commands] == [
        ("/cmd_vel", "geometry_msgs/msg/Twist")
    ]
    node = DdsNode(domain_id=domain_id)
    received = {"/odom": [], "/scan": []}
    node.subscribe("/odom", "nav_msgs/msg/Odometry", received["/odom"].append)
    node.subscribe("/scan", "sensor_msgs/msg/LaserScan", received["/scan"].append)
    node.advertise("/cmd_vel", "geometry_msgs/msg/Twist")
    writer = node.writer("/cmd_vel")
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(0)
    simulator.Initialize()
    deadline = time.monotonic() + 10
    while writer.get_publication_matched_status().current_count == 0:
        assert time.monotonic() < deadline, "the world's /cmd_vel subscription was not found"
        time.sleep(0.02)
    simulator.AdvanceTo(0.3)  # resting
    x0 = world.robot().base_log.array()[-1, 1]
    twist = twist_message(Twist(linear=(0.2, 0.0, 0.0)))
    for _ in range(10):  # 1 s of simulated time, the Twist sent at each 0.1 s (timeout 0.5 s)
        count = sum(bridge.received.values())
        node.publish("/cmd_vel", "geometry_msgs/msg/Twist", twist)
        deadline = time.monotonic() + 5
        while sum(bridge.received.values()) == count and time.monotonic() < deadline:
            time.sleep(0.005)
        simulator.AdvanceTo(simulator.get_context().get_time() + 0.1)
    rows = world.robot().base_log.array()
    moved = rows[-1, 1] - x0
    speed = rows[-1, 11]
    world.close(simulator.get_context())
    assert 0.12 < moved < 0.22, moved  # ~0.9 s at 0.2 m/s, after accelerating
    assert abs(speed - 0.2) < 0.01, speed
    deadline = time.monotonic() + 2
    while not (received["/odom"] and received["/scan"]) and time.monotonic() < deadline:
        time.sleep(0.02)
    node.close()
    assert received["/odom"] and len(received["/scan"][-1]["ranges"]) == 640
    assert math.isfinite(received["/odom"][-1]["pose"]["pose"]["position"]["x"])
