"""Goals in their frame at their stamp, as Nav2 transforms a PoseStamped through TF: a goal in
base_link stamped 0.5 s ago, sent while the base drives, is the base's pose then (the pose
buffer's), not now; a goal_pose in a frame the world does not know is refused with its name
and counted in summary.json's rejected_messages."""

from __future__ import annotations

import math

import numpy as np
import pytest

from armando_drake.messages.types import Publication
from armando_drake.navigation.config import NavigationGoal
from armando_drake.navigation.navigator import FramedGoal
from armando_drake.navigation.pose_buffer import compose
from armando_drake.outputs.base import COLUMNS
from armando_drake.outputs.navigation import goal_rejections
from armando_drake.simulation.commander import BasicNavigator, TaskResult
from armando_drake.simulation.scenario import load_scenario, merge_overrides

QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]
AHEAD = (0.4, 0.0, math.pi / 2)  # in base_link: 0.4 m ahead, a quarter turn left
LAG = 0.5  # [s] the goal's stamp before the time it is sent


def _stamped(stamp: float, frame_id: str) -> dict:
    sec = math.floor(stamp)
    return {"header": {"frame_id": frame_id,
                       "stamp": {"sec": sec, "nanosec": round((stamp - sec) * 1e9)}},
            "pose": {"position": {"x": AHEAD[0], "y": AHEAD[1], "z": 0.0},
                     "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(AHEAD[2] / 2),
                                     "w": math.cos(AHEAD[2] / 2)}}}  # fmt: skip


def _truth_at(log: np.ndarray, t: float) -> tuple[float, float, float]:
    """The ground truth's (x, y, yaw) at ``t`` from the base log (interpolated)."""
    time, x, y, yaw = (log[:, COLUMNS.index(k)] for k in ("time", "x", "y", "yaw"))
    heading = float(np.interp(t, time, np.unwrap(yaw)))
    return float(np.interp(t, time, x)), float(np.interp(t, time, y)), heading


@pytest.fixture(scope="module")
def run():
    navigator = BasicNavigator(merge_overrides(load_scenario("fra2mo_goals"), QUIET))
    navigator.waitUntilNav2Active()
    assert navigator.goToPose((-1.7, 0.5, math.pi))
    navigator.spin(3.0)
    out = {"sent_at": navigator.time}
    out["sent"] = navigator.goToPose(_stamped(navigator.time - LAG, "base_link"))
    log = navigator.world.robot().base_log.array()
    out["then"] = _truth_at(log, out["sent_at"] - LAG)
    out["now"] = _truth_at(log, out["sent_at"])
    out["goal"] = navigator.summary()["goals"]  # the first goal canceled so far
    end = navigator.time + 30.0
    while not navigator.isTaskComplete() and navigator.time < end:
        navigator.spin(0.1)
    out["result"] = navigator.getResult()
    out["summary"] = navigator.summary()
    # A goal_pose message in a frame the world does not know, as the bridge delivers it.
    context = navigator.navigator.GetMyMutableContextFromRoot(
        navigator.simulator.get_mutable_context()
    )
    message = FramedGoal(NavigationGoal(name="goal_pose", x=0.1, y=0.0), "camera_optical", 0.0)
    port = navigator.navigator.GetInputPort("goal_pose")
    port.FixValue(context, Publication().publish(message, navigator.time))
    goals_before = len(navigator.summary()["goals"])
    navigator.spin(0.5)
    out["unknown_goals"] = len(navigator.summary()["goals"]) - goals_before
    out["rejected"] = goal_rejections(navigator.world, navigator.context)
    navigator.close()
    return out


def test_a_goal_in_base_link_is_taken_at_the_pose_of_its_stamp(run):
    assert run["sent"] is True
    expected = compose(run["then"], AHEAD)
    at_send = compose(run["now"], AHEAD)
    assert math.dist(expected[:2], at_send[:2]) > 0.05  # the base moved meanwhile
    result = run["summary"]["goals"][-1]
    assert result["goal"][:2] == pytest.approx(expected[:2], abs=2e-3)
    assert math.remainder(result["goal"][2] - expected[2], 2 * math.pi) == pytest.approx(
        0.0, abs=2e-3
    )
    assert run["result"] == TaskResult.SUCCEEDED
    assert result["reached"] and result["position_error"] <= run["summary"]["xy_goal_tolerance"]


def test_a_goal_pose_in_an_unknown_frame_is_refused_and_counted(run):
    assert run["unknown_goals"] == 0  # nothing sent, the navigator runs on
    assert run["rejected"] == {"/goal_pose": 1}
