"""BasicNavigator (nav2_simple_commander's interface) driving fra2mo: one shared script."""

from __future__ import annotations

import math

import numpy as np
import pytest

from armando_drake.outputs.base import COLUMNS
from armando_drake.simulation.commander import BasicNavigator, TaskResult
from armando_drake.simulation.scenario import load_scenario, merge_overrides

QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]
POSE = (0.7, -0.6, -1.0)
WAYPOINTS = [(0.2, -0.3, 3.1416), (-0.4, 0.3, 1.5708)]
FAR = (-1.7, 0.5, 3.1416)
NAN, INF = math.nan, math.inf
HOSTILE = [
    (NAN, 0.0, 0.0), (0.0, NAN, 0.0), (0.0, 0.0, NAN), (INF, 0.0, 0.0), (0.0, 0.0, INF),
    (0.0, 0.0, -INF), (1e308, 0.0, 0.0), ("x", 0.0, 0.0), (0.0, 0.0),
    {"pose": {"position": {"x": 0.2, "y": NAN, "z": 0.0},
              "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
    {"pose": {"position": {"x": 0.2, "y": 0.0, "z": 0.0},
              "orientation": {"x": 0.0, "y": 0.0, "z": NAN, "w": 1.0}}},
]  # fmt: skip


def _drive(navigator: BasicNavigator, limit: float) -> list:
    feedback = []
    end = navigator.time + limit
    while not navigator.isTaskComplete() and navigator.time < end:
        feedback.append(navigator.getFeedback())
    return feedback


@pytest.fixture(scope="module")
def script():
    navigator = BasicNavigator(merge_overrides(load_scenario("fra2mo_goals"), QUIET))
    navigator.waitUntilNav2Active()
    out = {"idle": navigator.getResult()}
    assert navigator.goToPose(POSE)
    out["pose_feedback"] = _drive(navigator, 20.0)
    out["pose_result"] = navigator.getResult()
    assert navigator.followWaypoints(WAYPOINTS)
    out["waypoint_feedback"] = _drive(navigator, 30.0)
    out["waypoints_result"] = navigator.getResult()
    out["missed"] = navigator.missed_waypoints
    assert navigator.goToPose(FAR)
    navigator.spin(3.0)
    out["moving"] = navigator.world.robot().base_log.array()[-1].copy()
    navigator.cancelTask()
    out["cancel_complete"] = navigator.isTaskComplete()
    navigator.spin(1.0)
    out["stopped"] = navigator.world.robot().base_log.array()[-1].copy()
    out["cancel_result"] = navigator.getResult()
    out["in_obstacle"] = navigator.goToPose((1.6, 0.0, 0.0))  # crate_1
    out["rejected"] = navigator.rejected
    out["hostile"] = [(pose, navigator.goToPose(pose), navigator.rejected) for pose in HOSTILE]
    out["complete_after_hostile"] = navigator.isTaskComplete()  # no "math domain error"
    out["summary"] = navigator.summary()
    # A PoseStamped in base_link: 0.4 m ahead of the robot, a quarter turn left.
    out["start"] = navigator._state().last_pose
    ahead = {"header": {"frame_id": "base_link"},
             "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.0},
                      "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(math.pi / 4),
                                      "w": math.cos(math.pi / 4)}}}  # fmt: skip
    out["ahead_sent"] = navigator.goToPose(ahead)
    _drive(navigator, 20.0)
    out["ahead_result"] = navigator.getResult()
    out["ahead"] = navigator.summary()["goals"][-1]
    unknown = dict(ahead, header={"frame_id": "camera_optical"})
    out["unknown_sent"] = navigator.goToPose(unknown)
    out["unknown_reason"] = navigator.rejected
    navigator.close()
    return out


def test_go_to_pose_reaches_it_within_the_goal_tolerances(script):
    assert script["idle"] == TaskResult.UNKNOWN
    assert script["pose_result"] == TaskResult.SUCCEEDED
    result = script["summary"]["goals"][0]
    assert result["name"] == "goal" and result["goal"] == pytest.approx(list(POSE))
    assert result["position_error"] <= script["summary"]["xy_goal_tolerance"]
    assert result["yaw_error"] <= script["summary"]["yaw_goal_tolerance"]
    feedback = [f for f in script["pose_feedback"] if f is not None]
    distances = [f.distance_remaining for f in feedback]
    assert distances[0] == pytest.approx(math.hypot(0.7, 0.6), abs=0.15)  # from (0, 0)
    assert distances[-1] < 0.15
    times = [f.navigation_time for f in feedback]
    assert np.all(np.diff(times) > 0) and times[-1] == pytest.approx(result["time"], abs=0.2)


def test_follow_waypoints_visits_each(script):
    assert script["waypoints_result"] == TaskResult.SUCCEEDED and script["missed"] == []
    goals = script["summary"]["goals"]
    assert [g["name"] for g in goals[1:3]] == ["waypoint_0", "waypoint_1"]
    for result, pose in zip(goals[1:3], WAYPOINTS, strict=True):
        assert result["reached"] and result["goal"] == pytest.approx(list(pose))
        assert result["position_error"] <= script["summary"]["xy_goal_tolerance"]
    waypoints = {f.current_waypoint for f in script["waypoint_feedback"] if f is not None}
    assert waypoints == {0, 1}


def test_cancel_stops_the_base_and_reports_canceled(script):
    linear, angular = COLUMNS.index("linear"), COLUMNS.index("angular")
    assert abs(script["moving"][linear]) > 0.05 or abs(script["moving"][angular]) > 0.1
    assert script["cancel_complete"]
    assert script["cancel_result"] == TaskResult.CANCELED
    assert abs(script["stopped"][linear]) < 0.01 and abs(script["stopped"][angular]) < 0.02
    assert script["summary"]["goals"][3]["reason"] == "canceled"


def test_a_goal_in_an_obstacle_is_rejected(script):
    assert script["in_obstacle"] is False
    assert "goal 'goal' (1.6, 0) is in an obstacle" in script["rejected"]
    assert len(script["summary"]["goals"]) == 4  # not sent


def test_a_goal_with_a_nan_or_inf_is_rejected_with_its_reason(script):
    """NaN, inf, 1e308, no number, a short tuple, a NaN PoseStamped: each goToPose is False
    with the field named; nothing is sent and the navigator runs on."""
    for pose, sent, reason in script["hostile"]:
        assert sent is False, pose
        assert reason, pose
    reasons = [reason for _, _, reason in script["hostile"]]
    assert reasons[0] == "x=nan is not finite"
    assert reasons[4] == "yaw=inf is not finite"
    assert reasons[6].startswith("x=1e+308 is out of range")
    assert reasons[7] == "x='x' is not a number"
    assert "is not (x, y, yaw)" in reasons[8]
    assert reasons[9] == "pose.position.y=nan is not finite"
    assert reasons[10] == "pose.orientation.z=nan is not finite"
    assert script["complete_after_hostile"] is True
    assert len(script["summary"]["goals"]) == 4  # none sent


def test_a_goal_in_base_link_is_reached_at_its_map_pose(script):
    x, y, yaw = script["start"]
    expected = (x + 0.4 * math.cos(yaw), y + 0.4 * math.sin(yaw),
                math.remainder(yaw + math.pi / 2, 2 * math.pi))  # fmt: skip
    assert script["ahead_sent"] is True
    assert script["ahead_result"] == TaskResult.SUCCEEDED
    assert script["ahead"]["goal"] == pytest.approx(list(expected), abs=1e-6)  # at rest
    assert script["ahead"]["position_error"] <= script["summary"]["xy_goal_tolerance"]


def test_a_goal_in_an_unknown_frame_is_rejected_with_its_name(script):
    assert script["unknown_sent"] is False
    assert "goal frame 'camera_optical' is unknown" in script["unknown_reason"]
