"""Mapping and exploration (diagrams/fra2mo_explore.yaml): slam_toolbox's and explore_lite's
parameters, the scan matcher and the frontiers on small grids, and one shared run of fra2mo
exploring its arena with a drive plugin whose wheel radius is 3 % off (the odometry drifts)."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.navigation import reference
from armando_drake.navigation.config import NavigationConfig
from armando_drake.navigation.costmap import CostmapParameters, make_costmap
from armando_drake.navigation.explore import ExploreParameters, explore_parameters, frontiers
from armando_drake.navigation.maps import OccupancyMap, load_map, save_map
from armando_drake.navigation.slam import (
    SUB,
    SlamParameters,
    insert_scan,
    likelihood,
    map_accuracy,
    match,
    occupancy,
    slam_parameters,
)
from armando_drake.outputs.navigation import navigation_summary
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import Refusal

QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]
DRIFT = "robot: {xacro_args: {drive_wheel_radius_scale: '1.03'}}"


@pytest.fixture(scope="module")
def explored(tmp_path_factory):
    """fra2mo exploring its arena until no frontier is left (about 33 s simulated)."""
    scenario = merge_overrides(load_scenario("fra2mo_explore"), [*QUIET, DRIFT])
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    navigation = world.robot().navigation
    explorer_context = navigation.navigator.GetMyContextFromRoot(simulator.get_context())
    for end in np.arange(25.0, scenario.simulation.duration + 0.5, 1.0):
        simulator.AdvanceTo(min(end, scenario.simulation.duration))
        if navigation.navigator.exploration(explorer_context)["done"]:
            break
    summary = navigation_summary(world, simulator.get_context())
    folder = tmp_path_factory.mktemp("explored")
    built, _ = navigation.final_map(simulator.get_context())
    save_map(built, folder / "map")
    return (world, simulator), summary, folder


def test_the_arena_is_explored_until_no_frontier_is_left_without_collision(explored):
    _, summary, _ = explored
    mapping = summary["mapping"]
    assert mapping["done"] and mapping["frontiers_left"] == 0
    assert mapping["done_at"] < 40.0
    assert summary["collisions"] == 0
    assert mapping["explored_area"] > 23.0  # the arena's free space is 23.7 m^2


def test_the_saved_map_matches_the_worlds_occupancy(explored):
    (world, _), _, folder = explored
    saved = load_map(folder / "map.yaml")
    assert saved.resolution == 0.05
    truth = world.robot().navigation.truth
    accuracy = map_accuracy(saved, truth, (0.0, 0.0), 0.2)
    assert accuracy["precision"] >= 0.9
    assert accuracy["recall"] >= 0.9
    # All the free space the robot can reach is known as free; its whole room too.
    assert accuracy["coverage"] >= 0.99
    assert accuracy["free_known"] >= 0.98


def test_scan_matching_corrects_the_odometrys_drift(explored):
    _, summary, _ = explored
    mapping = summary["mapping"]
    # The wheel radius 3 % off: the odometry is off by decimetres at the end (its heading by
    # 3 % of the net turn), the scan-matched pose by a few centimetres.
    assert mapping["odometry_position_error"] > 0.15
    assert mapping["slam_position_error"] < 0.04
    assert mapping["slam_yaw_error"] < 0.015
    assert mapping["odometry_position_error"] > 5 * mapping["slam_position_error"]
    # The localization's errors over time are SLAM's, named so.
    localization = summary["localization"]
    assert localization["method"] == "slam"
    assert localization["errors"] and localization["final_position_error"] < 0.04


def _room_scan(pose, n=360):
    """A scan of a 4 m x 3 m room (walls at x = +-1.95, y = +-1.45) from ``pose``."""
    angles = -math.pi + 2 * math.pi / n * np.arange(n)
    heading = pose[2] + angles
    c, s = np.cos(heading), np.sin(heading)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, 1.95 - pose[0], -1.95 - pose[0]) / c
        ty = np.where(s > 0, 1.45 - pose[1], -1.45 - pose[1]) / s

    class Scan:
        angle_min, angle_increment, range_min, range_max = -math.pi, 2 * math.pi / n, 0.1, 10.0
        ranges = np.minimum(np.abs(tx), np.abs(ty))

    return Scan


def test_the_correlative_matcher_finds_the_pose_the_odometry_missed():
    grid = OccupancyMap(np.full((80, 100), -1, dtype=np.int8), 0.05, (-2.5, -2.0, 0.0))
    params = SlamParameters()
    logodds = np.zeros(grid.data.shape, dtype=np.float32)
    hits = np.zeros((SUB * 80, SUB * 100), dtype=np.int32)
    for _ in range(3):
        scan = _room_scan((0.0, 0.0, 0.0))
        logodds = insert_scan(logodds, grid, (0.0, 0.0, 0.0), (0, 0, 0), scan, 12, hits=hits)
    built = occupancy(logodds, grid)
    assert (built.data == 100).sum() > 200 and (built.data == 0).sum() > 2000
    truth = (0.3, -0.2, 0.15)
    field = likelihood(logodds, grid, params.correlation_search_space_smear_deviation, hits)
    predicted = (0.42, -0.29, 0.08)  # 0.15 m and 0.07 rad off
    pose, response = match(field, grid, predicted, (0, 0, 0), _room_scan(truth), params)
    assert math.hypot(pose[0] - truth[0], pose[1] - truth[1]) < 0.015
    assert abs(pose[2] - truth[2]) < 0.01
    assert response > 0.5


def test_frontiers_are_free_cells_next_to_unknown_ones_clustered_and_sized():
    data = np.full((60, 60), -1, dtype=np.int8)
    data[10:50, 10:30] = 0  # a known free room, open on its east side (x = 1.5 m)
    data[10:50, 9] = data[9, 9:31] = data[50, 9:31] = 100
    grid = OccupancyMap(data, 0.05, (0.0, 0.0, 0.0))
    costmap = make_costmap(grid, CostmapParameters(robot_radius=0.1, inflation_radius=0.3))
    found = frontiers(grid, costmap, (0.5, 1.5), ExploreParameters(min_frontier_size=0.6))
    assert len(found) == 1
    assert found[0].size == pytest.approx(40 * 0.05)
    assert found[0].goal[0] == pytest.approx(1.475, abs=0.3) and 1.0 < found[0].goal[1] < 2.0
    assert found[0].distance == pytest.approx(1.0 - 0.025, abs=0.03)
    # Shorter than min_frontier_size: none.
    assert frontiers(grid, costmap, (0.5, 1.5), ExploreParameters(min_frontier_size=2.5)) == []
    # Its goal blacklisted: none either.
    assert frontiers(grid, costmap, (0.5, 1.5), ExploreParameters(), [found[0].goal]) == []


def test_the_courses_slam_and_explore_parameters_load_and_those_ignored_are_named(
    fra2mo_package, caplog
):
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        slam = slam_parameters(fra2mo_package / "config" / "slam.yaml")
        explore = explore_parameters(fra2mo_package / "config" / "explore.yaml")
    assert (slam.resolution, slam.map_update_interval, slam.max_laser_range) == (0.05, 2.0, 12.0)
    assert (slam.minimum_travel_distance, slam.correlation_search_space_dimension) == (0.01, 0.5)
    assert slam.use_scan_matching and slam.coarse_search_angle_offset == 0.349
    assert "slam.ros__parameters.do_loop_closing: no loop closure" in caplog.text
    assert "slam.ros__parameters.ceres_linear_solver: no pose graph, no solver" in caplog.text
    assert "slam.ros__parameters.scan_buffer_size: matched against the whole map" in caplog.text
    assert (explore.planner_frequency, explore.progress_timeout) == (2.0, 15.0)
    assert (explore.potential_scale, explore.gain_scale, explore.min_frontier_size) == (
        5.0,
        1.0,
        0.6,
    )
    assert "explore_node.ros__parameters.orientation_scale: unused by explore_lite" in caplog.text


def test_a_bad_value_is_one_line_naming_the_file_and_the_key(tmp_path):
    slam = tmp_path / "slam.yaml"
    slam.write_text("slam_toolbox:\n  ros__parameters:\n    resolution: -0.05\n")
    with pytest.raises(ConfigError) as error:
        slam_parameters(slam)
    message = str(error.value)
    assert "\n" not in message
    assert str(slam) in message and "slam_toolbox.ros__parameters.resolution" in message
    explore = tmp_path / "explore.yaml"
    explore.write_text("explore_node:\n  ros__parameters:\n    planner_frequency: fast\n")
    with pytest.raises(
        ConfigError, match=r"explore_node.ros__parameters.planner_frequency='fast' must be a"
    ):
        explore_parameters(explore)
    slam.write_text("slam_toolbox:\n  ros__parameters:\n    mode: localization\n")
    with pytest.raises(ConfigError, match=r"mode='localization' is not one of 'mapping': only"):
        slam_parameters(slam)


@pytest.mark.parametrize(
    ("node", "text", "message"),
    [
        ("slam_toolbox", "resolution: -0.05", "resolution=-0.05 must be positive [m]"),
        ("slam_toolbox", "throttle_scans: 0", "throttle_scans=0 must be positive"),
        ("slam_toolbox", "minimum_travel_distance: -1", "minimum_travel_distance=-1.0 must be"),
        ("slam_toolbox", "use_scan_matching: 1", "use_scan_matching=1 must be true or false"),
        ("explore_node", "planner_frequency: 0", "planner_frequency=0.0 must be positive [Hz]"),
        ("explore_node", "min_frontier_size: -0.5", "min_frontier_size=-0.5 must be zero or"),
    ],
)
def test_a_bad_slam_or_explore_value_is_one_error_naming_file_and_key(
    tmp_path, node, text, message
):
    """slam_toolbox's and explore_lite's parameters are declared with their rules and
    checked by the schema's checker: one line, ``<file>: <node>.ros__parameters.<key>=...``."""
    path = tmp_path / f"{node}.yaml"
    path.write_text(f"{node}:\n  ros__parameters:\n    {text}\n")
    read = slam_parameters if node == "slam_toolbox" else explore_parameters
    with pytest.raises(ConfigError) as error:
        read(path)
    assert str(error.value).startswith(f"{path}: {node}.ros__parameters.{message}"), error.value
    assert "\n" not in str(error.value)


def test_the_slam_and_explore_parameters_are_in_the_reference():
    """The generated parameter reference lists them with their units, ranges, meanings."""
    page = reference.render()
    assert "| `resolution` | honoured | [m] the map's cell size (positive) |" in page
    assert "| `planner_frequency` | honoured | [Hz] how often the frontiers" in page


def test_exploration_needs_slam_and_no_goals():
    config = NavigationConfig(params_file="nav.yaml", explore=True)
    with pytest.raises(Refusal, match="explore"):
        config.check()
    config.localization = "slam"
    with pytest.raises(Refusal, match="slam_params_file"):
        config.check()
    config.slam_params_file = config.explore_params_file = "x.yaml"
    config.check()


def test_the_summary_has_the_mapping_section_and_the_figure_is_written(explored, tmp_path):
    from armando_drake.outputs.navigation import write_navigation_outputs

    (world, simulator), summary, _ = explored
    write_navigation_outputs(tmp_path, world, summary, simulator.get_context())
    assert (tmp_path / "map.pgm").is_file() and (tmp_path / "navigation.png").stat().st_size
    assert summary["mapping"]["scans_used"] > 100
    # Each frontier goal in the summary: replaced on the way, the last one explored.
    reasons = [goal["reason"] for goal in summary["goals"]]
    assert len(reasons) == summary["mapping"]["frontier_goals"]
    assert set(reasons) <= {"superseded", "reached", "explored", "no plan", "progress timeout"}
    # The last one explored, or reached just before the search found no frontier left
    # (the scans placed with the odometry at their stamp: the drifting run reaches it).
    assert reasons[-1] in ("explored", "reached")
