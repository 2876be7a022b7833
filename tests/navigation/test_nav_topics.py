"""The navigation's topics as Nav2 publishes them (/map, /plan, goal frames, map -> odom),
over DDS and in the MCAP recording, and RViz's /goal_pose over DDS: one shared run."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.messages.definitions import pose_stamped_message
from armando_drake.navigation.topics import planar
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "ros2"))
pytest.importorskip("cyclonedds")

GOAL_POSE = (0.7, -0.6, -1.0)  # [m, m, rad] free, between the pillars
GOALS = ["north_east", "north_west", "south_west", "south_east"]


def _stamp(header) -> float:
    return header["stamp"]["sec"] + 1e-9 * header["stamp"]["nanosec"]


@pytest.fixture(scope="module")
def goal_pose_run(tmp_path_factory):
    """fra2mo on its way to its first goal; at 2 s a /goal_pose from another DDS participant
    preempts it; run until that is reached (at most 20 s)."""
    from ros2_support import new_domain_id

    from armando_drake.ros2.dds import DdsNode

    domain_id = new_domain_id()
    path = tmp_path_factory.mktemp("nav") / "run.mcap"
    overrides = [
        "logging: {console_rate: 0}",
        "visualization: {enable_meshcat_creation: false}",
        f"ros2: {{enabled: true, domain_id: {domain_id}}}",
    ]
    world = MakeWorld(merge_overrides(load_scenario("fra2mo_goals"), overrides), quiet=True,
                      record=path)  # fmt: skip
    bridge = world.diagram.GetSubsystemByName("ros2_bridge")
    node = DdsNode(domain_id=domain_id)
    live = {"/plan": [], "/tf": []}
    node.subscribe("/plan", "nav_msgs/msg/Path", live["/plan"].append)
    node.subscribe("/tf", "tf2_msgs/msg/TFMessage", live["/tf"].append)
    node.advertise("/goal_pose", "geometry_msgs/msg/PoseStamped")
    writer = node.writer("/goal_pose")
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(0)
    simulator.Initialize()
    deadline = time.monotonic() + 10
    while writer.get_publication_matched_status().current_count == 0:
        assert time.monotonic() < deadline, "the world's /goal_pose subscription was not found"
        time.sleep(0.02)
    simulator.AdvanceTo(2.0)
    message = pose_stamped_message(2.0, "map", planar(*GOAL_POSE))
    node.publish("/goal_pose", "geometry_msgs/msg/PoseStamped", message)
    deadline = time.monotonic() + 5
    while not bridge.received.get("/goal_pose") and time.monotonic() < deadline:
        time.sleep(0.005)
    navigator = world.robot().navigation.navigator
    context = simulator.get_context()
    nav_context = navigator.GetMyContextFromRoot(context)
    while context.get_time() < 20.0:
        simulator.AdvanceTo(context.get_time() + 1.0)
        results = navigator.summary(nav_context)["goals"]
        if results[-1]["name"] == "goal_pose" and results[-1]["reason"] != "not reached":
            break
    summary = navigator.summary(nav_context)
    # Latched topics reach a subscriber that joins late.
    latched = {"/tf_static": [], "/map": []}
    node.subscribe("/tf_static", "tf2_msgs/msg/TFMessage", latched["/tf_static"].append, "latched")
    node.subscribe("/map", "nav_msgs/msg/OccupancyGrid", latched["/map"].append, "latched")
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not all(latched.values()):
        time.sleep(0.02)
    time.sleep(0.3)
    world.close(context)
    node.close()
    return world, summary, live, latched, _read_bag(path)


def _read_bag(path: Path) -> dict[str, list]:
    """Messages per topic, read with rosbags (not the writer's library)."""
    from rosbags.highlevel import AnyReader

    topics: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for connection, _, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append(message)
        topics["__types__"] = {c.topic: c.msgtype for c in reader.connections}
    return topics


def test_goal_pose_over_dds_preempts_and_is_reached(goal_pose_run):
    _, summary, _, _, _ = goal_pose_run
    first, last = summary["goals"][0], summary["goals"][-1]
    assert [g["name"] for g in summary["goals"]] == ["north_east", "goal_pose"]
    assert first["reason"] == "canceled"
    assert last["reached"], last
    assert last["goal"] == pytest.approx(list(GOAL_POSE))
    assert last["position_error"] <= summary["xy_goal_tolerance"]
    assert last["yaw_error"] <= summary["yaw_goal_tolerance"]


def test_plan_over_dds_ends_at_each_goal(goal_pose_run):
    _, _, live, _, _ = goal_pose_run
    plans = live["/plan"]
    assert len(plans) >= 2  # replanned at 1 Hz
    assert all(p["header"]["frame_id"] == "map" for p in plans)
    ends = [(p["poses"][-1]["pose"]["position"]["x"], p["poses"][-1]["pose"]["position"]["y"])
            for p in plans]  # fmt: skip
    assert ends[0] == pytest.approx((1.5, 1.3))  # north_east
    assert ends[-1] == pytest.approx(GOAL_POSE[:2])
    assert _stamp(plans[0]["header"]) == pytest.approx(1.0)  # the first goal at start_delay
    for plan in plans:  # a cell apart (the last: the goal itself)
        xy = np.array([[q["pose"]["position"]["x"], q["pose"]["position"]["y"]]
                       for q in plan["poses"]])  # fmt: skip
        assert np.linalg.norm(np.diff(xy, axis=0), axis=1).max() <= 2 * 0.05  # the goal ends it


def test_goal_frames_and_map_are_latched(goal_pose_run):
    world, _, live, latched, _ = goal_pose_run
    frames = {t["child_frame_id"]: t for t in latched["/tf_static"][-1]["transforms"]}
    for name in [*GOALS, "goal_pose"]:
        assert frames[name]["header"]["frame_id"] == "map"
    translation = frames["goal_pose"]["transform"]["translation"]
    assert (translation["x"], translation["y"]) == pytest.approx(GOAL_POSE[:2])
    q = frames["south_west"]["transform"]["rotation"]
    assert 2 * math.atan2(q["z"], q["w"]) == pytest.approx(-1.5708)
    assert "laser_frame" in frames  # the robot's fixed joints are still there
    grid = latched["/map"][-1]
    info = grid["info"]
    navigation_grid = world.robot().navigation.grid
    assert (info["width"], info["height"]) == (navigation_grid.width, navigation_grid.height)
    assert len(grid["data"]) == info["width"] * info["height"]
    assert info["resolution"] == pytest.approx(navigation_grid.resolution)
    assert np.array_equal(np.array(grid["data"]), navigation_grid.data.ravel())
    # map -> odom on /tf: the identity with the ground truth.
    map_odom = [t for m in live["/tf"] for t in m["transforms"] if t["header"]["frame_id"] == "map"]
    assert map_odom and map_odom[-1]["child_frame_id"] == "odom"
    assert map_odom[-1]["transform"]["translation"]["x"] == 0.0


def test_mcap_has_map_plan_goal_frames_and_map_to_odom(goal_pose_run):
    world, _, live, _, bag = goal_pose_run
    types = bag["__types__"]
    assert types["/map"] == "nav_msgs/msg/OccupancyGrid"
    assert types["/plan"] == "nav_msgs/msg/Path"
    assert types["/tf_static"] == "tf2_msgs/msg/TFMessage"
    (grid,) = bag["/map"]
    assert grid.info.width * grid.info.height == len(grid.data)
    assert grid.header.frame_id == "map"
    assert len(bag["/plan"]) == len(live["/plan"])
    last = bag["/plan"][-1].poses[-1].pose.position
    assert (last.x, last.y) == pytest.approx(GOAL_POSE[:2])
    static = {t.child_frame_id for m in bag["/tf_static"] for t in m.transforms}
    assert {*GOALS, "goal_pose"} <= static
    map_odom = [t for m in bag["/tf"] for t in m.transforms if t.header.frame_id == "map"]
    odom = [t for m in bag["/tf"] for t in m.transforms if t.child_frame_id == "base_footprint"]
    assert len(map_odom) == len(odom) > 100  # with each odometry
