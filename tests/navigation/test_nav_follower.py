"""Regulated Pure Pursuit and the controller server's parameters (pure computation)."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from armando_drake.navigation.costmap import Costmap
from armando_drake.navigation.follower import (
    ControllerParameters,
    carrot,
    controller_parameters,
    rpp_command,
    to_robot,
)
from armando_drake.tools.errors import ConfigError

RES = 0.05


def _free(size: float = 10.0) -> Costmap:
    n = int(size / RES)
    return Costmap(np.zeros((n, n), dtype=np.uint8), RES, (-size / 2, -size / 2, 0.0))


def _params(**rpp) -> ControllerParameters:
    params = ControllerParameters(controller_frequency=20.0, xy_goal_tolerance=0.1)
    for key, value in rpp.items():
        setattr(params.rpp, key, value)
    params.rpp.use_cost_regulated_linear_velocity_scaling = False
    return params


def _command(params, path, pose=(0.0, 0.0, 0.0), speed=(0.0, 0.0), costmap=None, goal=None):
    path = np.asarray(path, dtype=float)
    goal = goal or (*path[-1], 0.0)
    return rpp_command(
        params,
        costmap or _free(),
        to_robot(path, pose),
        pose,
        speed,
        goal,
        rotating_to_goal=False,
        inscribed_radius=0.2,
    )


def _line(x0, y0, x1, y1, n=100):
    return np.stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n)], axis=1)


def test_straight_path_at_the_desired_speed_and_the_carrot_on_the_circle():
    params = _params(desired_linear_vel=0.4, use_velocity_scaled_lookahead_dist=False)
    command = _command(params, _line(0, 0, 3, 0))
    assert command.linear == pytest.approx(0.4)
    assert command.angular == pytest.approx(0.0, abs=1e-9)
    # Interpolated: exactly at the lookahead distance on the segment crossing the circle.
    local = _line(0, 0.1, 3, 0.1, n=7)
    point = carrot(local, 0.6, True)
    assert math.hypot(*point) == pytest.approx(0.6)
    assert carrot(local, 0.6, False)[0] == pytest.approx(1.0)  # the first point beyond


def test_a_path_behind_is_turned_to_in_place_within_the_angular_acceleration():
    params = _params(max_angular_accel=5.0, rotate_to_heading_angular_vel=1.8)
    command = _command(params, _line(0, 0, -3, 0.5))
    assert command.linear == 0.0
    assert command.angular == pytest.approx(5.0 / 20.0)  # one step of acceleration
    command = _command(params, _line(0, 0, -3, -0.5), speed=(0.0, -1.7))
    assert command.angular == pytest.approx(-1.8)


def test_tight_curvature_slows_to_radius_over_min_radius():
    params = _params(
        desired_linear_vel=0.4,
        regulated_linear_scaling_min_radius=0.7,
        regulated_linear_scaling_min_speed=0.05,
        use_velocity_scaled_lookahead_dist=False,
        lookahead_dist=0.3,
        approach_velocity_scaling_dist=0.0,
        rotate_to_heading_min_angle=1.5,
    )
    radius = 0.35  # a circle to the left through the robot, heading +x
    t = np.linspace(0, math.pi, 400)
    path = np.stack([radius * np.sin(t), radius - radius * np.cos(t)], axis=1)
    command = _command(params, path)
    assert command.linear == pytest.approx(0.4 * radius / 0.7, rel=0.03)
    assert command.angular == pytest.approx(command.linear / radius, rel=0.03)


def test_approach_slows_on_the_last_metres_not_below_the_minimum():
    params = _params(
        desired_linear_vel=0.4,
        approach_velocity_scaling_dist=0.5,
        min_approach_linear_velocity=0.1,
    )
    assert _command(params, _line(0, 0, 0.4, 0)).linear == pytest.approx(0.4 * 0.4 / 0.5)
    assert _command(params, _line(0, 0, 0.11, 0)).linear == pytest.approx(0.1)


def test_velocity_scaled_lookahead_and_collision_ahead_stops():
    params = _params(lookahead_time=1.5, min_lookahead_dist=0.3, max_lookahead_dist=0.9)
    costmap = _free()
    row, col = costmap.world_to_cell(0.5, 0.0)
    costmap.costs[row - 2 : row + 3, col : col + 2] = 254
    command = _command(params, _line(0, 0, 3, 0), speed=(0.3, 0.0), costmap=costmap)
    assert command.collision and command.linear == 0.0 and command.angular == 0.0
    params.rpp.use_collision_detection = False
    assert not _command(params, _line(0, 0, 3, 0), costmap=costmap).collision


def test_near_the_goal_it_turns_to_the_goals_heading():
    params = _params()
    command = _command(params, _line(0, 0, 0.05, 0), goal=(0.05, 0.0, math.pi / 2))
    assert command.rotating_to_goal and command.linear == 0.0 and command.angular > 0


def test_unknown_keys_are_warned_by_name_and_bad_values_refused(tmp_path, caplog):
    path = tmp_path / "nav2.yaml"
    path.write_text(
        "controller_server:\n  ros__parameters:\n    controller_frequency: 10.0\n"
        "    goal_checker: {plugin: nav2_controller::StoppedGoalChecker, trans_stopped_velocity:"
        " 0.1, xy_goal_tolerance: 0.05}\n"
        "    progress_checker: {plugin: nav2_controller::SimpleProgressChecker}\n"
        "    FollowPath:\n      plugin: "
        "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController\n"
        "      desired_linear_vel: 0.3\n      made_up_gain: 2.0\n"
    )
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        params = controller_parameters(path)
    assert params.controller_frequency == 10.0 and params.rpp.desired_linear_vel == 0.3
    assert params.stopped_goal_checker and params.trans_stopped_velocity == 0.1
    assert params.xy_goal_tolerance == 0.05
    assert "FollowPath.made_up_gain: not used here" in caplog.text
    path.write_text(path.read_text().replace("0.3\n", "fast\n"))
    with pytest.raises(ConfigError, match="FollowPath.desired_linear_vel='fast' must be a number"):
        controller_parameters(path)
