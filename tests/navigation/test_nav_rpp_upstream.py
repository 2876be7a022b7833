"""Regulated Pure Pursuit, case for case with Nav2 (jazzy).

Ported from navigation2's (jazzy, f4108e5b1c2bce804a1aa0c7be6673a8eb4a1501)
nav2_regulated_pure_pursuit_controller/test/test_regulated_pp.cpp
(basicAPI's speed limits, findVelocitySignChange, circleSegmentIntersection,
projectCarrotPastGoal, lookaheadAPI, rotateTests, applyConstraints, testDynamicParameter's
values read from a file, the TransformGlobalPlanTest cases) with its path_utils
(test/path_utils/path_utils.cpp and its own test_path_utils.cpp); ParameterHandler's
corrections; and the numbers read in its source
(regulation_functions.hpp's cost regulation and approach slowing, rotateToHeading's clamping
order).
"""

import math
import sys

import numpy as np
import pytest

from armando_drake.navigation.costmap import Costmap
from armando_drake.navigation.follower import (
    ControllerParameters,
    RppParameters,
    angle_to_path,
    carrot,
    circle_segment_intersection,
    controller_parameters,
    lookahead_distance,
    regulate,
    rotate_to_heading,
    rpp_command,
    speed_limited,
    transform_global_plan,
    velocity_sign_change,
)

DT = 1.0 / 20.0  # control_duration_ at the default controller_frequency


# -- path_utils.cpp


def _append(path, rotation, forward):
    x, y, yaw = path[-1]
    path.append((x + forward * math.cos(yaw), y + forward * math.sin(yaw), yaw + rotation))


def straight(path, length, spacing):
    for _ in range(int(math.floor(length / spacing))):
        _append(path, 0.0, spacing)


def arc(path, radius, radians, spacing):
    n = int(math.floor(radius * abs(radians) / spacing))
    if n == 0:
        return
    step = radians / n
    for _ in range(n):
        _append(path, step, 2 * radius * math.sin(abs(step) / 2))


def generate_poses(spacing, *segments, start=(0.0, 0.0, 0.0)):
    """path_utils' generate_path: the poses (x, y, yaw) from ``start``."""
    path = [tuple(start)]
    for segment, *args in segments:
        segment(path, *args, spacing)
    return np.array(path)


def generate_path(spacing, *segments, start=(0.0, 0.0, 0.0)):
    return generate_poses(spacing, *segments, start=start)[:, :2]


def quaternion(yaw):
    """tf2's rotation of a yaw, as toMsg gives it from the transform's matrix (w >= 0)."""
    half = math.atan2(math.sin(yaw), math.cos(yaw)) / 2
    sign = 1.0 if math.cos(half) >= 0 else -1.0
    return (0.0, 0.0, sign * math.sin(half), sign * math.cos(half))


def costmap(width, resolution, around=(0.0, 0.0)):
    """A free costmap ``width`` metres wide (Costmap2DROS's width is in metres) centred on
    ``around``."""
    cells = int(round(width / resolution))
    origin = (around[0] - width / 2, around[1] - width / 2, 0.0)
    return Costmap(np.zeros((cells, cells), dtype=np.uint8), resolution, origin)


# -- the cases


def test_findVelocitySignChange():
    path = np.array([[1.0, 1.0], [2.0, 2.0], [-1.0, -1.0]])
    assert velocity_sign_change(path) == math.sqrt(8.0)
    path[2] = (3.0, 3.0)
    assert velocity_sign_change(path) == sys.float_info.max


@pytest.mark.parametrize(
    ("p1", "p2", "r", "expected"),
    [
        ((0.0, 0.0), (2.0, 0.0), 1.0, (1.0, 0.0)),
        ((0.0, 0.0), (-2.0, 0.0), 1.0, (-1.0, 0.0)),
        ((0.0, 0.0), (0.0, 2.0), 1.0, (0.0, 1.0)),
        ((0.0, 0.0), (0.0, -2.0), 1.0, (0.0, -1.0)),
        ((4.0, 0.0), (-1.0, 0.0), 2.0, (2.0, 0.0)),  # the segment enters the circle
        ((0.0, 4.0), (0.0, -0.5), 2.0, (0.0, 2.0)),  # the segment enters the circle
        ((2.0, 0.0), (0.0, 0.0), 2.0, (2.0, 0.0)),
        ((0.0, 0.0), (0.0, 2.0), 2.0, (0.0, 2.0)),
        ((0.0, 0.0), (6.0, 8.0), 5.0, (3.0, 4.0)),
        ((0.0, 0.0), (-6.0, -8.0), 5.0, (-3.0, -4.0)),
        ((0.0, 0.0), (-6.0, 8.0), 5.0, (-3.0, 4.0)),
        ((0.0, 0.0), (6.0, -8.0), 5.0, (3.0, -4.0)),
    ],
)
def test_circleSegmentIntersection(p1, p2, r, expected):
    actual = circle_segment_intersection(p1, p2, r)
    assert actual == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert math.hypot(*actual) == pytest.approx(r, rel=1e-12)


def _at(degrees):
    return (10 * math.cos(math.radians(degrees)), 10 * math.sin(math.radians(degrees)))


@pytest.mark.parametrize(
    ("path", "expected"),
    [
        ([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]], (10.0, 0.0)),
        ([[2.0, 0.0], [3.0, 0.0]], (10.0, 0.0)),
        ([[2.0, 2.0], [3.0, 3.0]], _at(45)),
        ([[0.0, 2.0], [0.0, 3.0]], _at(90)),
        ([[-2.0, 2.0], [-3.0, 3.0]], _at(135)),
        ([[-2.0, 0.0], [-3.0, 0.0]], (-10.0, 0.0)),
        ([[-2.0, -2.0], [-3.0, -3.0]], _at(-135)),
        ([[0.0, -2.0], [0.0, -3.0]], _at(-90)),
        ([[2.0, -2.0], [3.0, -3.0]], _at(-45)),
    ],
)
def test_projectCarrotPastGoal(path, expected):
    eps = float(np.finfo(np.float32).eps)
    point = carrot(np.array(path), 10.0, True, after_goal=True)
    assert point == pytest.approx(expected, abs=eps)


def test_lookaheadAPI():
    p = RppParameters()
    assert lookahead_distance(p, 0.0) == 0.6
    assert lookahead_distance(p, 10.0) == 0.6  # not a function of speed
    p.use_velocity_scaled_lookahead_dist = True
    assert lookahead_distance(p, 10.0) == 0.9
    assert lookahead_distance(p, 0.35) == pytest.approx(0.525, abs=1e-4)
    assert lookahead_distance(p, 0.0) == 0.3
    path = np.array([[float(i), 0.0] for i in range(10)])
    assert carrot(path, 1.0, True)[0] == 1.0  # an exact hit
    assert carrot(path, 3.8, True)[0] == pytest.approx(3.8)  # interpolated


def test_rotateTests():
    p = RppParameters()
    assert abs(angle_to_path((0.0, 0.0))) <= p.rotate_to_heading_min_angle  # no rotation
    assert abs(angle_to_path((0.5, 0.25))) <= p.rotate_to_heading_min_angle
    assert abs(angle_to_path((0.5, 1.0))) > p.rotate_to_heading_min_angle
    assert rotate_to_heading(0.4, 1.75, p, DT) == 1.6  # the slow-down limit
    assert rotate_to_heading(-0.4, -1.75, p, DT) == -1.6
    assert rotate_to_heading(0.4, 0.0, p, DT) == pytest.approx(0.16, abs=0.01)
    assert rotate_to_heading(0.4, 1.0, p, DT) == pytest.approx(1.16, abs=0.01)
    assert rotate_to_heading(-0.4, 1.0, p, DT) == pytest.approx(0.84, abs=0.01)


def test_rotate_to_heading_clamps_to_the_acceleration_window_then_to_the_stopping_rate():
    """rotateToHeading: at 1.8 rad/s and 0.1 rad from the heading the command is first kept
    within max_angular_accel of the turn rate (1.8 - 3.2 / 20 = 1.64), then cut to the
    stopping rate sqrt(2 x 3.2 x 0.1) = 0.8 rad/s."""
    p = RppParameters()
    assert rotate_to_heading(0.1, 1.8, p, DT) == pytest.approx(math.sqrt(2 * 3.2 * 0.1))
    assert rotate_to_heading(0.1, 1.8, p, DT) == pytest.approx(0.8)
    assert rotate_to_heading(-0.1, -1.8, p, DT) == pytest.approx(-0.8)
    # below the stopping rate the acceleration window holds: 0 + 3.2 / 20
    assert rotate_to_heading(1.0, 0.0, p, DT) == pytest.approx(0.16)


def test_applyConstraints():
    p = RppParameters(approach_velocity_scaling_dist=0.6)
    no_approach = generate_path(0.1, (straight, 1.6))
    assert regulate(p, 0.0, 0.5, 0, no_approach, 0.2) == 0.25  # the min set speed
    assert regulate(p, 1.0, 0.7407, 0, no_approach, 0.2) == pytest.approx(0.5, abs=0.01)
    assert regulate(p, 1.0, 1000.0, 0, no_approach, 0.2) == pytest.approx(0.25, abs=0.01)
    approach = generate_path(0.1, (straight, 0.0))
    assert regulate(p, 1.0, 0.0, 0, approach, 0.2) == pytest.approx(0.05, abs=0.01)


def test_cost_regulation_takes_the_distance_from_log_253_over_the_cost():
    """costConstraint: d = (k r - ln(cost) + ln(253)) / k; cost 100, r 0.2 m, k 3:
    d = 0.5094 m, under cost_scaling_dist 0.6: v = 0.5 x 0.5094 / 0.6."""
    p = RppParameters(use_regulated_linear_velocity_scaling=False)
    p.regulated_linear_scaling_min_speed = 0.0
    path = generate_path(0.1, (straight, 2.0))
    distance = 0.2 + math.log(253 / 100) / 3.0
    assert regulate(p, 0.5, 0.0, 100, path, 0.2) == pytest.approx(0.5 * distance / 0.6)
    assert regulate(p, 0.5, 0.0, 253, path, 0.2) == pytest.approx(0.5 * 0.2 / 0.6)  # inscribed
    assert regulate(p, 0.5, 0.0, 0, path, 0.2) == 0.5  # free: no regulation


def test_approach_slowing_takes_the_straight_line_distance_to_the_paths_end():
    """approachVelocityScalingFactor: a U-shaped path 0.5 m long (under
    approach_velocity_scaling_dist 0.6) whose end is 0.1 m from the robot slows 0.5 m/s by
    the straight-line 0.1 / 0.6, not below min_approach_linear_velocity 0.05."""
    p = RppParameters()
    path = np.array([[0.0, 0.0], [0.2, 0.0], [0.2, 0.1], [0.0, 0.1]])
    assert regulate(p, 0.5, 0.0, 0, path, 0.2) == pytest.approx(0.5 * 0.1 / 0.6)
    p.min_approach_linear_velocity = 0.1
    assert regulate(p, 0.5, 0.0, 0, path, 0.2) == pytest.approx(0.1)  # the floor
    # the path's length (from its first pose) decides when: 0.7 m long, no slowing
    longer = np.array([[0.0, 0.0], [0.3, 0.0], [0.3, 0.1], [0.0, 0.1]])
    assert regulate(p, 0.5, 0.0, 0, longer, 0.2) == 0.5


def test_speed_limit():
    p = RppParameters(desired_linear_vel=0.5)
    assert speed_limited(p, 0.0, True).desired_linear_vel == 0.5  # NO_SPEED_LIMIT
    assert speed_limited(p, 50.0, True).desired_linear_vel == 0.25
    assert speed_limited(p, 0.3, False).desired_linear_vel == 0.3


def test_no_pruning_on_large_costmap():
    plan = generate_path(0.1, (arc, 1.0, 2 * math.pi))
    index, local = transform_global_plan(plan, 0, (-0.1, 0.0, 0.0), 5.0, costmap(100, 0.1))
    assert (index, len(local)) == (0, len(plan))


def test_transform_start_selection():
    plan = generate_path(0.1, (arc, 2.0, 2 * math.pi))
    pose = (0.0, 4.0, 0.0)  # on the other side of the circle
    _, local = transform_global_plan(plan, 0, pose, 10.0, costmap(100, 0.1, pose[:2]))
    assert abs(len(local) - len(plan) // 2) <= 1
    assert local[0] == pytest.approx((0.0, 0.0), abs=0.5)


def test_all_poses_outside_of_costmap():
    plan = generate_path(0.1, (arc, 2.0, 2 * math.pi))
    pose = (1000.0, 1000.0, 0.0)
    grid = costmap(10, 0.1, pose[:2])
    _, local = transform_global_plan(plan, 0, pose, 10.0, grid)
    assert len(local) == 0  # Nav2 throws: the controller fails
    params = ControllerParameters()
    command = rpp_command(params, grid, local, pose, (0.0, 0.0), (0.0, 0.0, 0.0),
                          rotating_to_goal=False, inscribed_radius=0.2)  # fmt: skip
    assert command.collision and (command.linear, command.angular) == (0.0, 0.0)


def test_good_circle_shortcut():
    plan = generate_path(0.1, (arc, 2.0, 2 * math.pi))
    _, local = transform_global_plan(plan, 0, (-0.1, 0.0, 0.0), 15.0, costmap(100, 0.1))
    assert abs(len(local) - 1) <= 1
    assert local[0] == pytest.approx((0.0, 0.0), abs=0.5)


def test_costmap_pruning():
    """A 100 m straight plan (a pose a metre) on a 20 m costmap: the 10 poses within its
    half-width kept, not all 101."""
    plan = generate_path(1.0, (straight, 100.0))
    _, local = transform_global_plan(plan, 0, (-0.1, 0.0, 0.0), 10.0, costmap(20, 0.5))
    assert abs(len(local) - 10) <= 1
    assert local[0] == pytest.approx((0.0, 0.0), abs=0.5)


def test_prune_after_leaving_costmap():
    plan = generate_path(1.0, (straight, 100.0), (arc, 1.0, math.pi), (straight, 100.0))
    _, local = transform_global_plan(plan, 0, (-0.1, 0.0, 0.0), 10.0, costmap(20, 0.5))
    assert abs(len(local) - 10) <= 1
    assert local[0] == pytest.approx((0.0, 0.0), abs=0.5)


# -- test_regulated_pp.cpp: basicAPI, testDynamicParameter; ParameterHandler


def test_basicAPI_speed_limit():
    # test_regulated_pp.cpp TEST(RegulatedPurePursuitTest, basicAPI): setSpeedLimit
    p = RppParameters()
    base_speed = p.desired_linear_vel
    assert speed_limited(p, 0.51, False).desired_linear_vel == 0.51
    assert speed_limited(p, 0.0, False).desired_linear_vel == base_speed  # NO_SPEED_LIMIT
    assert speed_limited(p, 30, True).desired_linear_vel == base_speed * 0.3
    assert speed_limited(p, 0.0, True).desired_linear_vel == base_speed


RPP_FILE = (
    "controller_server:\n  ros__parameters:\n    FollowPath:\n      plugin: "
    "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController\n"
)


def _rpp(tmp_path, body: str, costmap: str = "") -> RppParameters:
    path = tmp_path / "nav2.yaml"
    path.write_text(RPP_FILE + body + costmap)
    return controller_parameters(path).rpp


def test_testDynamicParameter_values_are_read(tmp_path):
    values = {
        "desired_linear_vel": 1.0, "lookahead_dist": 7.0, "max_lookahead_dist": 7.0,
        "min_lookahead_dist": 6.0, "lookahead_time": 1.8, "rotate_to_heading_angular_vel": 18.0,
        "min_approach_linear_velocity": 1.0, "max_allowed_time_to_collision_up_to_carrot": 2.0,
        "cost_scaling_dist": 2.0, "cost_scaling_gain": 4.0,
        "regulated_linear_scaling_min_radius": 10.0, "max_angular_accel": 3.0,
        "rotate_to_heading_min_angle": 0.7, "regulated_linear_scaling_min_speed": 4.0,
        "use_velocity_scaled_lookahead_dist": False,
        "use_regulated_linear_velocity_scaling": False,
        "use_cost_regulated_linear_velocity_scaling": False,
        "inflation_cost_scaling_factor": 1.0, "allow_reversing": False,
        "use_rotate_to_heading": False, "stateful": False,
    }  # fmt: skip
    body = "".join(f"      {k}: {str(v).lower()}\n" for k, v in values.items())
    rpp = _rpp(tmp_path, body + "      transform_tolerance: 30.0\n")
    for key, value in values.items():
        assert getattr(rpp, key) == value, key


def test_a_nonpositive_inflation_cost_scaling_factor_disables_cost_regulation(tmp_path, caplog):
    # parameter_handler.cpp: "it should be >0. Disabling cost regulated linear velocity
    # scaling." (testDynamicParameter's -1.0 is refused at run time)
    rpp = _rpp(tmp_path, "      inflation_cost_scaling_factor: -1.0\n")
    assert rpp.use_cost_regulated_linear_velocity_scaling is False
    assert "inflation_cost_scaling_factor" in caplog.text
    assert _rpp(tmp_path, "").use_cost_regulated_linear_velocity_scaling is True


def test_max_robot_pose_search_dist_defaults_to_half_the_local_costmap(tmp_path):
    # parameter_handler.cpp: its default is costmap_size_x / 2; negative: every pose
    assert _rpp(tmp_path, "").max_robot_pose_search_dist == 2.5  # a 5 m local costmap
    local = "local_costmap:\n  local_costmap:\n    ros__parameters:\n      width: 3\n"
    assert _rpp(tmp_path, "", local).max_robot_pose_search_dist == 1.5
    rpp = _rpp(tmp_path, "      max_robot_pose_search_dist: -1.0\n", local)
    assert rpp.max_robot_pose_search_dist == sys.float_info.max


# -- path_utils/test_path_utils.cpp


def test_path_utils_generate_straight():
    path = generate_poses(1.0, (straight, 2.0))
    assert len(path) == 3
    assert tuple(path[0, :2]) == (0.0, 0.0)
    assert path[1, :2] == pytest.approx((1.0, 0.0), abs=0.1)
    assert path[2, :2] == pytest.approx((2.0, 0.0), abs=0.1)


def test_path_utils_half_turn():
    # from (1, -1) turned the other way (orientation z 1, w 0), a right turn around of 2 m
    path = generate_poses(0.1, (arc, 2.0, -math.pi), start=(1.0, -1.0, math.pi))
    expected_length = math.pi * 2.0
    assert abs(len(path) - (1 + int(expected_length / 0.1))) <= 10
    assert path[-1, :2] == pytest.approx((1.0, 3.0), abs=0.2)
    assert quaternion(path[-1, 2]) == pytest.approx((0.0, 0.0, 0.0, 1.0), abs=0.1)


def test_path_utils_generate_all():
    path = generate_poses(
        0.1,
        (straight, 1.0),
        (arc, 1.0, math.pi / 2), (arc, 1.0, -math.pi / 2),  # LeftTurn, RightTurn
        (arc, 1.0, math.pi), (arc, 1.0, -math.pi),  # LeftTurnAround, RightTurnAround
        (arc, 1.0, 2 * math.pi), (arc, 1.0, -2 * math.pi),  # LeftCircle, RightCircle
        (arc, 1.0, 2 * math.pi),  # Arc(1.0, 2 pi): another circle
    )  # fmt: skip
    expected_length = 1.0 + 2.0 * (math.pi / 2 + math.pi / 2) + 2.0 * math.pi + 3.0 * 2 * math.pi
    assert abs(len(path) - (1 + int(expected_length / 0.1))) <= 50
    assert path[-1, :2] == pytest.approx((3.0, 6.0), abs=0.5)
    assert quaternion(path[-1, 2]) == pytest.approx((0.0, 0.0, 0.0, 1.0), abs=0.1)


def test_controller_server_default_plugins_have_their_default_types(tmp_path):
    # controller_server.cpp: the default ids goal_checker, progress_checker and FollowPath
    # are declared with SimpleGoalChecker, SimpleProgressChecker and DWBLocalPlanner
    path = tmp_path / "nav2.yaml"
    path.write_text("controller_server:\n  ros__parameters:\n    controller_frequency: 20.0\n")
    params = controller_parameters(path)
    assert params.stopped_goal_checker is False
    assert params.plugin == "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
