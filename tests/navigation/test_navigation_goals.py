"""fra2mo driving to goals as Nav2 does (diagrams/fra2mo_goals.yaml): one shared run."""

from __future__ import annotations

import heapq
import logging
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from scipy import ndimage

from armando_drake.navigation.follower import controller_parameters
from armando_drake.navigation.maps import OCCUPIED, load_map, save_map
from armando_drake.navigation.planner import PlanningError
from armando_drake.navigation.world_map import world_map
from armando_drake.outputs.base import COLUMNS
from armando_drake.outputs.navigation import navigation_summary
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides

QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]


def _scenario(*overrides: str):
    return merge_overrides(load_scenario("fra2mo_goals"), [*QUIET, *overrides])


@pytest.fixture(scope="module")
def goals_run():
    scenario = _scenario()
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    context = simulator.get_context()
    for end in np.arange(20.0, scenario.simulation.duration + 0.5, 1.0):  # until all are done
        simulator.AdvanceTo(min(end, scenario.simulation.duration))
        summary = navigation_summary(world, context)
        if all(goal["reason"] != "not reached" for goal in summary["goals"]):
            break
    return world, summary, world.robot().base_log.array()


def _shortest(free: np.ndarray, start, goal) -> float:
    """[cells] the shortest 8-connected path between two free cells (plain Dijkstra)."""
    h, w = free.shape
    dist = np.full(free.shape, np.inf)
    dist[start] = 0.0
    queue = [(0.0, start)]
    moves = [(dr, dc, math.hypot(dr, dc)) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
    while queue:
        d, (r, c) = heapq.heappop(queue)
        if (r, c) == goal:
            return d
        if d > dist[r, c]:
            continue
        for dr, dc, step in moves:
            rr, cc = r + dr, c + dc
            if 0 <= rr < h and 0 <= cc < w and free[rr, cc] and d + step < dist[rr, cc]:
                dist[rr, cc] = d + step
                heapq.heappush(queue, (d + step, (rr, cc)))
    return math.inf


def test_every_goal_is_reached_within_the_goal_checkers_tolerances(goals_run):
    world, summary, rows = goals_run
    names = [g["name"] for g in summary["goals"]]
    assert names == ["north_east", "north_west", "south_west", "south_east"]  # the order
    assert summary["reached"] == 4
    goals = {g.name: g for g in world.robot().navigation.navigator.goals}
    time = rows[:, COLUMNS.index("time")]
    for result in summary["goals"]:
        assert result["reached"], result
        assert result["position_error"] <= summary["xy_goal_tolerance"]
        assert result["yaw_error"] <= summary["yaw_goal_tolerance"]
        assert 0 < result["time"] < 15.0
        # The base logger's ground truth agrees, when the goal was taken.
        k = int(np.argmin(np.abs(time - result["reached_at"])))
        goal = goals[result["name"]]
        x, y = rows[k, COLUMNS.index("x")], rows[k, COLUMNS.index("y")]
        assert math.hypot(x - goal.x, y - goal.y) <= summary["xy_goal_tolerance"] + 0.01


def test_no_collision_with_the_worlds_obstacles(goals_run):
    _, summary, rows = goals_run
    assert summary["collisions"] == 0
    assert summary["collision_bodies"] == []
    assert len(rows) > 1000  # the contacts were sampled all along


def test_each_driven_path_is_at_most_1_25_times_the_shortest_collision_free_one(goals_run):
    world, summary, rows = goals_run
    grid = world.robot().navigation.grid
    radius = 0.2  # the robot's, in the Nav2 YAML
    cells = math.ceil(radius / grid.resolution)
    rr, cc = np.mgrid[-cells : cells + 1, -cells : cells + 1]
    disk = np.hypot(rr, cc) * grid.resolution <= radius
    free = ~ndimage.binary_dilation(grid.data == OCCUPIED, structure=disk)

    def cell(x, y):
        return (
            math.floor((y - grid.origin[1]) / grid.resolution),
            math.floor((x - grid.origin[0]) / grid.resolution),
        )

    start = rows[0, COLUMNS.index("x")], rows[0, COLUMNS.index("y")]
    goals = {g.name: g for g in world.robot().navigation.navigator.goals}
    ratios = []
    for result in summary["goals"]:
        goal = goals[result["name"]]
        shortest = _shortest(free, cell(*start), cell(goal.x, goal.y)) * grid.resolution
        ratios.append(result["path_length"] / shortest)
        start = result["pose"][:2]
    assert max(ratios) <= 1.25, ratios
    assert min(ratios) > 0.8, ratios  # the path is a real one, not a jump


def test_the_worlds_map_is_its_geometry_cut_at_the_lidars_height(goals_run, tmp_path):
    world, _, _ = goals_run
    grid = world.robot().navigation.grid
    res = grid.resolution

    def occupied(x, y):
        r = math.floor((y - grid.origin[1]) / res)
        c = math.floor((x - grid.origin[0]) / res)
        return grid.data[r, c] == OCCUPIED

    # pillar_1 (radius 0.1 m) at (0, 1.2): its centre occupied, 0.2 m off free.
    assert occupied(0.0, 1.2) and occupied(0.07, 1.2)
    assert not occupied(0.2, 1.2) and not occupied(0.0, 1.4)
    # crate_1 (0.3 m x 0.3 m) at (1.6, 0); the walls at |x|, |y| = 2.5..2.6 m.
    assert occupied(1.72, 0.12) and not occupied(1.85, 0.0)
    assert occupied(2.55, 0.0) and occupied(0.0, -2.55) and not occupied(2.3, 0.0)
    assert not occupied(0.0, 0.0)  # the robot's own geometry is not an obstacle
    # The same map again, and saved as map_server's files that load back unchanged.
    again = world_map(
        world.plant,
        world.scene_graph,
        height=0.215,
        resolution=res,
        exclude=[world.robot().robot.model_instance],
    )
    assert np.array_equal(again.data, grid.data)
    loaded = load_map(save_map(grid, tmp_path / "map"))
    assert np.array_equal(loaded.data, grid.data)
    assert loaded.origin == pytest.approx(grid.origin, abs=1e-3)


def test_a_goal_inside_an_obstacle_is_refused_naming_it():
    scenario = _scenario(
        "navigation: {goals: [{name: into_the_pillar, x: 0.0, y: 1.2, yaw: 0.0}], order: []}"
    )
    with pytest.raises(PlanningError) as error:
        MakeWorld(scenario, quiet=True)
    message = str(error.value)
    assert "into_the_pillar" in message and "obstacle" in message
    assert "\n" not in message


def test_the_courses_navigation_yaml_loads_with_its_parameters(fra2mo_package, caplog):
    path = fra2mo_package / "config" / "navigation.yaml"
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        params = controller_parameters(path)
    assert params.controller_frequency == 5.0
    assert params.failure_tolerance == 2.0
    assert (params.xy_goal_tolerance, params.yaw_goal_tolerance) == (0.1, 0.2)
    assert params.goal_stateful
    assert (params.required_movement_radius, params.movement_time_allowance) == (0.5, 10.0)
    rpp = params.rpp
    assert (rpp.desired_linear_vel, rpp.lookahead_dist) == (0.4, 0.6)
    assert (rpp.min_lookahead_dist, rpp.max_lookahead_dist, rpp.lookahead_time) == (0.4, 0.9, 2.0)
    assert rpp.use_velocity_scaled_lookahead_dist and rpp.use_rotate_to_heading
    assert not rpp.use_cost_regulated_linear_velocity_scaling
    assert (rpp.regulated_linear_scaling_min_radius, rpp.regulated_linear_scaling_min_speed) == (
        0.7,
        0.2,
    )
    assert (rpp.rotate_to_heading_min_angle, rpp.rotate_to_heading_angular_vel) == (0.785, 1.8)
    assert rpp.max_angular_accel == 5.0
    assert params.expected_planner_frequency == 1.0
    # The one parameter not applied is named.
    key = "controller_server.ros__parameters.FollowPath.transform_tolerance"
    assert params.ignored == [f"{path}: {key}"]
    assert "FollowPath.transform_tolerance: not applied here" in caplog.text
