"""NavFn's parameters and nav2_util's path length, case for case with Nav2 (jazzy).

Ported from navigation2's (jazzy, f4108e5b1c2bce804a1aa0c7be6673a8eb4a1501)
nav2_navfn_planner/test/test_dynamic_parameters.cpp (its values read from a Nav2 file: the
parameters are set at configure time here) and nav2_util/test/test_geometry_utils.cpp
(calculate_path_length, as :func:`~armando_drake.navigation.planner.path_length` of the
path from a start index).
"""

import math

import numpy as np
import pytest

from armando_drake.navigation.planner import path_length, planner_parameters


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
