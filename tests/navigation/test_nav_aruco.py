"""Vision-based navigation (diagrams/fra2mo_aruco.yaml): the ArUco marker on the map from
fra2mo's base camera, and the robot 1 m in front of it, facing it: one shared run."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RollPitchYaw
from pydrake.systems.analysis import Simulator

from armando_drake.outputs.navigation import navigation_summary
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides
from armando_drake.vision.marker_goal import front_goal

pytest.importorskip("cv2")
QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]


@pytest.fixture(scope="module")
def aruco_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("aruco") / "run.mcap"
    scenario = merge_overrides(load_scenario("fra2mo_aruco"), QUIET)
    world = MakeWorld(scenario, quiet=True, record=path)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    context = simulator.get_context()
    while context.get_time() < 20.0:
        simulator.AdvanceTo(context.get_time() + 1.0)
        summary = navigation_summary(world, context)
        if summary["goals"][-1]["name"] == "aruco_front" and summary["goals"][-1]["reached"]:
            break
    world.close(context)
    (marker,) = [o for o in scenario.objects if o.name == "aruco_marker"]
    X_WM = marker.X_WO() @ marker.shape.X_OM()  # the marker frame (OpenCV's) in the world
    return summary, X_WM, path


def test_the_markers_pose_on_the_map_is_within_5_cm_and_5_degrees(aruco_run):
    summary, X_WM, _ = aruco_run
    aruco = summary["aruco"]
    assert aruco["detections"] >= 10 and aruco["frame"] == "aruco_frame"
    error = np.linalg.norm(np.array(aruco["position"]) - X_WM.translation())
    assert error < 0.05, error
    R = RollPitchYaw(aruco["rpy"]).ToRotationMatrix()
    angle = R.InvertAndCompose(X_WM.rotation()).ToAngleAxis().angle()
    assert angle < math.radians(5.0), math.degrees(angle)


def test_the_robot_ends_1_m_in_front_of_the_marker_facing_it(aruco_run):
    summary, X_WM, _ = aruco_run
    names = [g["name"] for g in summary["goals"]]
    assert names == ["search", "aruco_front"]
    assert summary["goals"][0]["reached"]  # the search goal, from where the marker is seen
    final = summary["goals"][-1]
    assert final["reached"], final
    x, y, yaw = front_goal(X_WM, 1.0)  # the true pose 1 m in front of it
    assert (x, y) == pytest.approx((-1.495, 0.0), abs=1e-3)
    assert abs(math.remainder(yaw - math.pi, 2 * math.pi)) < 1e-3  # facing -x
    assert math.hypot(final["pose"][0] - x, final["pose"][1] - y) <= summary["xy_goal_tolerance"]
    assert abs(math.remainder(final["pose"][2] - yaw, 2 * math.pi)) <= summary["yaw_goal_tolerance"]
    assert summary["collisions"] == 0


def test_aruco_frame_on_tf_in_the_recording(aruco_run):
    from rosbags.highlevel import AnyReader

    summary, _, path = aruco_run
    frames = []
    with AnyReader([Path(path)]) as reader:
        for connection, _, raw in reader.messages():
            if connection.topic == "/tf":
                message = reader.deserialize(raw, connection.msgtype)
                frames += [t for t in message.transforms if t.child_frame_id == "aruco_frame"]
    assert len(frames) == summary["aruco"]["detections"]
    last = frames[-1]
    assert last.header.frame_id == "map"
    p = last.transform.translation
    assert [p.x, p.y, p.z] == pytest.approx(summary["aruco"]["position"])
