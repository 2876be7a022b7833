"""Costmaps (static + inflation layers, Nav2 parameters) and NavFn's global planner."""

from __future__ import annotations

import heapq
import logging
import math

import numpy as np
import pytest

from armando_drake.navigation.costmap import (
    CostmapParameters,
    costmap_parameters,
    make_costmap,
)
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.planner import (
    PlannerParameters,
    PlanningError,
    final_orientation,
    path_length,
    plan,
    planner_parameters,
    smooth_approach_to_goal,
)
from armando_drake.tools.errors import ConfigError

RES = 0.05


def _wall_map() -> OccupancyMap:
    """6 m x 4 m free, a wall at x = 3 m from y = 0 to 3 m (a 1 m gap above), borders."""
    data = np.zeros((80, 120), dtype=np.int8)
    data[:, 59:61] = 100
    data[60:, 59:61] = 0
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyMap(data=data, resolution=RES, origin=(0.0, 0.0, 0.0))


def test_inflation_costs_equal_upstreams_formula():
    data = np.zeros((41, 41), dtype=np.int8)
    data[20, 20] = 100
    # A footprint whose inscribed radius is 0.2 m (a robot_radius is Nav2's padded 16-gon:
    # 0.2059 m for 0.2 m, test_nav_costmap_upstream.py)
    square = [[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]]
    params = CostmapParameters(footprint=square, footprint_padding=0.0, inflation_radius=0.75,
                               cost_scaling_factor=2.0)  # fmt: skip
    assert params.inscribed_radius == 0.2
    costs = make_costmap(OccupancyMap(data, RES, (0.0, 0.0, 0.0)), params).costs
    assert costs[20, 20] == 254
    for cells in range(1, 20):
        d = cells * RES
        if d <= 0.2 + 1e-9:
            expected = 253
        elif cells > math.ceil(0.75 / RES):
            expected = 0
        else:
            expected = int(252 * math.exp(-2.0 * (d - 0.2)))
        assert costs[20, 20 + cells] == expected, cells
    # figures: 0.25 m -> 228, 0.5 m -> 138, 0.75 m -> 83, 0.8 m (beyond 15 cells) -> 0
    assert [int(costs[20, 20 + c]) for c in (5, 10, 15, 16)] == [228, 138, 83, 0]
    # a diagonal distance: sqrt(3^2 + 4^2) = 5 cells = 0.25 m
    assert costs[23, 24] == 228


def test_unknown_space_and_negative_radius(tmp_path):
    data = np.full((5, 5), -1, dtype=np.int8)
    grid = OccupancyMap(data, RES, (0.0, 0.0, 0.0))
    assert (make_costmap(grid, CostmapParameters(track_unknown_space=True)).costs == 255).all()
    assert (make_costmap(grid, CostmapParameters(track_unknown_space=False)).costs == 0).all()
    path = tmp_path / "nav.yaml"
    path.write_text(
        "global_costmap:\n  global_costmap:\n    ros__parameters:\n"
        "      plugins: [inflation_layer]\n      inflation_layer:\n"
        "        plugin: nav2_costmap_2d::InflationLayer\n        inflation_radius: -0.5\n"
    )
    with pytest.raises(
        ConfigError, match=r"inflation_layer.inflation_radius=-0.5 must be zero or positive"
    ):
        costmap_parameters(path)
    path.write_text(path.read_text().replace("nav2_costmap_2d::InflationLayer", "my::Layer"))
    with pytest.raises(ConfigError) as error:
        costmap_parameters(path)
    assert str(path) in str(error.value) and "inflation_layer.plugin: unknown" in str(error.value)


def test_course_navigation_yaml_parses(fra2mo_package, caplog):
    path = fra2mo_package / "config" / "navigation.yaml"
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        params = costmap_parameters(path)
    assert params.robot_radius == 0.2 and params.resolution == 0.05
    assert params.inflation_radius == 0.75 and params.cost_scaling_factor == 2.0
    assert params.track_unknown_space and params.static_layer and params.inflation_layer
    scan = params.obstacle_layer.sources[0]  # the course's lidar topic
    assert (scan.topic, scan.data_type, scan.obstacle_max_range) == ("/lidar", "LaserScan", 2.5)
    local = costmap_parameters(path, "local_costmap")
    assert (local.inflation_radius, local.cost_scaling_factor) == (0.09, 1.0)
    assert planner_parameters(path) == PlannerParameters(0.2, False, True)


def test_unknown_costmap_parameter_is_warned(tmp_path, caplog):
    path = tmp_path / "nav.yaml"
    path.write_text(
        "global_costmap:\n  global_costmap:\n    ros__parameters:\n"
        "      robot_radius: 0.3\n      wheel_colour: red\n      plugins: [static_layer]\n"
        "      static_layer:\n        plugin: nav2_costmap_2d::StaticLayer\n"
    )
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        params = costmap_parameters(path)
    assert params.ignored == [f"{path}: global_costmap.global_costmap.ros__parameters.wheel_colour"]
    assert "wheel_colour: not used" in caplog.text and not params.inflation_layer


def _shortest_free(blocked: np.ndarray, start, goal) -> float:
    """Plain Dijkstra, 8-connected, on the binary grid: the shortest collision-free length."""
    h, w = blocked.shape
    best = {start: 0.0}
    queue = [(0.0, start)]
    while queue:
        d, (r, c) = heapq.heappop(queue)
        if (r, c) == goal:
            return d * RES
        if d > best[(r, c)]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                n = (r + dr, c + dc)
                if (dr or dc) and 0 <= n[0] < h and 0 <= n[1] < w and not blocked[n]:
                    nd = d + math.hypot(dr, dc)
                    if nd < best.get(n, math.inf):
                        best[n] = nd
                        heapq.heappush(queue, (nd, n))
    return math.inf


@pytest.mark.parametrize("use_astar", [False, True])
def test_planner_path_around_a_wall(use_astar):
    params = CostmapParameters(robot_radius=0.2, inflation_radius=0.75, cost_scaling_factor=2.0)
    costmap = make_costmap(_wall_map(), params)
    start, goal = (1.5, 1.0), (4.5, 1.0)
    path = plan(costmap, start, goal, PlannerParameters(0.2, use_astar, True))
    rows, cols = zip(*(costmap.world_to_cell(x, y) for x, y in path), strict=True)
    assert (costmap.costs[list(rows), list(cols)] < 253).all()  # collision-free when inflated
    assert path[0] == pytest.approx(start, abs=RES) and path[-1] == pytest.approx(goal, abs=RES)
    assert path[:, 1].max() > 3.0  # through the gap above the wall
    blocked = costmap.costs >= 253
    shortest = _shortest_free(blocked, costmap.world_to_cell(*start), costmap.world_to_cell(*goal))
    length = path_length(path)
    # figures: shortest 5.73 m on the inflated grid, NavFn 6.66 m (1.16x): it keeps off walls
    assert shortest < length <= 1.25 * shortest, (length, shortest)


def test_goal_inside_obstacle_is_refused():
    costmap = make_costmap(_wall_map(), CostmapParameters(robot_radius=0.2, inflation_radius=0.75))
    with pytest.raises(PlanningError, match=r"goal \(3\.000, 1\.000\) is in an obstacle \(cost 25"):
        plan(costmap, (1.5, 1.0), (3.0, 1.0), PlannerParameters(tolerance=0.2))
    # with a tolerance reaching past the inscribed band, the nearest free cell is the goal
    path = plan(costmap, (1.5, 1.0), (3.0, 1.0), PlannerParameters(tolerance=0.5))
    assert 0.2 < abs(path[-1][0] - 3.0) <= 0.5


def test_navfn_plan_starts_at_the_robot_and_ends_at_the_goal_exactly():
    """NavfnPlanner: the plan from the robot's position (not its cell's centre) to the
    goal's (smoothApproachToGoal), cell centres between."""
    costmap = make_costmap(_wall_map(), CostmapParameters())
    start, goal = (1.013, 1.027), (5.021, 1.238)
    path = plan(costmap, start, goal)
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    inner = path[1:-1]
    centres = (inner - 0.5 * RES) / RES
    assert np.allclose(centres, np.round(centres))  # cell centres between
    assert not np.allclose(path[-2], goal)  # the goal is not given twice


def test_smooth_approach_to_goal():
    """smoothApproachToGoal: the goal replaces the last point when it is nearer the
    point before, or is that point; else it is appended."""
    path = np.array([[0.0, 0.0], [1.0, 0.0]])
    assert smooth_approach_to_goal(path, (0.9, 0.0)).tolist() == [[0.0, 0.0], [0.9, 0.0]]
    assert smooth_approach_to_goal(path, (1.0, 0.0)).tolist() == [[0.0, 0.0], [1.0, 0.0]]
    assert smooth_approach_to_goal(path, (1.1, 0.0)).tolist() == [[0, 0], [1, 0], [1.1, 0]]


def test_use_final_approach_orientation():
    """NavfnPlanner's last pose faces along the last segment (the one before when the
    last two coincide; a one-pose plan: the start's heading), else the goal's."""
    on = PlannerParameters(use_final_approach_orientation=True)
    path = np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 1.0]])
    assert final_orientation(path, 0.3, 2.0, on) == pytest.approx(math.pi / 4)
    assert final_orientation(path[:2], 0.3, 2.0, on) == pytest.approx(math.pi / 4)
    assert final_orientation(path[:1], 0.3, 2.0, on) == 0.3
    assert final_orientation(path, 0.3, 2.0, PlannerParameters()) == 2.0
