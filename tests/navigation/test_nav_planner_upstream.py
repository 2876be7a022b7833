"""NavFn and nav2_util's path length, case for case with Nav2 (jazzy).

Ported from navigation2's (jazzy, f4108e5b1c2bce804a1aa0c7be6673a8eb4a1501)
nav2_navfn_planner/test/test_dynamic_parameters.cpp (its values read from a Nav2 file: the
parameters are set at configure time here), nav2_system_tests/src/planning/
test_planner_plugins.cpp's NavFn cases (testSmallPathValidityAndOrientation and
...AndNoOrientation on a free 5 m x 5 m costmap of 0.1 m, Costmap2DROS's default) and
nav2_util/test/test_geometry_utils.cpp
(calculate_path_length, as :func:`~armando_drake.navigation.planner.path_length` of the
path from a start index).
"""

import math

import numpy as np
import pytest

from armando_drake.navigation.costmap import Costmap
from armando_drake.navigation.planner import (
    PlannerParameters,
    final_orientation,
    path_length,
    plan,
    planner_parameters,
)
from armando_drake.navigation.reference import DIFFERENCES


def test_NavfnTest_testDynamicParameter(tmp_path):
    path = tmp_path / "nav2.yaml"
    path.write_text(
        "planner_server:\n  ros__parameters:\n    planner_plugins: [test]\n    test:\n"
        "      plugin: nav2_navfn_planner::NavfnPlanner\n      tolerance: 1.0\n"
        "      use_astar: true\n      allow_unknown: true\n"
        "      use_final_approach_orientation: true\n"
    )
    params = planner_parameters(path, "test")
    assert params.tolerance == 1.0
    assert params.use_astar is True
    assert params.allow_unknown is True
    assert params.use_final_approach_orientation is True


def test_GeometryUtils_calculate_path_length():
    straight_line = np.array([[2.0 * i, 0.0] for i in range(10)], dtype=np.float32)
    assert path_length(straight_line) == pytest.approx((10 - 1) * 2.0, abs=1e-5)
    assert path_length(straight_line[len(straight_line) :]) == pytest.approx(0.0, abs=1e-5)
    pi = np.float32(3.14159265358979)
    angles = np.arange(360) * (pi / np.float32(180.0))
    circle = np.stack([2.0 * np.cos(angles), 2.0 * np.sin(angles)], axis=1).astype(np.float32)
    assert path_length(circle) == pytest.approx(2 * math.pi * 2.0, abs=1e-1)


LENGTHS = {  # test_planner_plugins.cpp's NavFn<case> and NavFn<case>N
    "EqualStartGoal": 0.0,
    "VerySmallPath": 0.00001,
    "BelowCostmapResolution": 0.09,
    "JustAboveCostmapResolution": 0.102,
    "AboveCostmapResolution": 1.5,
}


def _small_plan(length: float, use_final_approach_orientation: bool):
    costmap = Costmap(np.zeros((50, 50), dtype=np.uint8), 0.1, (0.0, 0.0, 0.0))
    params = PlannerParameters(use_final_approach_orientation=use_final_approach_orientation)
    start, goal = (0.5, 0.5), (0.5, 0.5 + length)
    path = plan(costmap, start, goal, params)
    return path, final_orientation(path, math.pi / 2, -math.pi, params)


@pytest.mark.parametrize("case", LENGTHS)
def test_testSmallPathValidityAndOrientation(case):
    path, yaw = _small_plan(LENGTHS[case], False)
    assert len(path) > 0
    assert yaw == pytest.approx(-math.pi, abs=0.01)


@pytest.mark.parametrize("case", LENGTHS)
def test_testSmallPathValidityAndNoOrientation(case):
    path, yaw = _small_plan(LENGTHS[case], True)
    assert len(path) > 0
    if case == "AboveCostmapResolution":
        # The documented difference (reference.DIFFERENCES, GridBased.plugin): the plan
        # runs on cell centres, 0.05 m beside NavFn's straight line x = 0.5 from (0.5, 0.5)
        # to (0.5, 2.0), so its last segment, (0.55, 1.95) -> (0.5, 2.0), faces 3 pi / 4,
        # where NavFn's faces pi / 2, the direction from its first pose to its last.
        assert path[-2].tolist() == pytest.approx([0.55, 1.95])
        assert yaw == pytest.approx(3 * math.pi / 4)
        assert DIFFERENCES[("GridBased", "plugin")].count("use_final_approach_orientation")
        return
    if len(path) == 1:
        assert yaw == pytest.approx(math.pi / 2, abs=0.01)
    else:
        dx, dy = path[-1] - path[0]
        assert yaw == pytest.approx(math.atan2(dy, dx), abs=0.01)


def test_equal_start_and_goal_is_a_one_pose_plan():
    # navfn_planner.cpp createPlan: start (x, y) == goal (x, y): one pose, the start's
    path, yaw = _small_plan(0.0, True)
    assert path.tolist() == [[0.5, 0.5]]
    assert yaw == math.pi / 2
