"""Other robots' public Nav2 parameter files (tests/navigation/fixtures/, each naming its
source) load as Nav2 reads them: the plugins not implemented here named once with what
runs instead, and fra2mo reaches a goal on TurtleBot3 Burger's parameters."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.navigation.behaviors import behavior_parameters
from armando_drake.navigation.costmap import costmap_parameters
from armando_drake.navigation.follower import controller_parameters
from armando_drake.navigation.planner import planner_parameters
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides
from armando_drake.tools.errors import ConfigError

FIXTURES = Path(__file__).parent / "fixtures"
QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]


def _load(path: Path):
    return (
        costmap_parameters(path),
        costmap_parameters(path, "local_costmap"),
        planner_parameters(path),
        controller_parameters(path),
        behavior_parameters(path),
    )


def test_nav2s_default_parameters_load_with_mppi_and_the_voxel_layer_substituted(caplog):
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        global_, local, planner, controller, behaviors = _load(FIXTURES / "nav2_params.yaml")
    text = caplog.text
    assert text.count("nav2_mppi_controller::MPPIController is not implemented here") == 1
    assert "Regulated Pure Pursuit follows instead (desired_linear_vel=0.5 from vx_max" in text
    assert (
        "local_costmap.local_costmap.ros__parameters.voxel_layer.plugin: "
        "nav2_costmap_2d::VoxelLayer is not implemented here; the obstacle layer runs instead"
        in text
    )
    assert controller.rpp.desired_linear_vel == 0.5
    assert (controller.xy_goal_tolerance, controller.yaw_goal_tolerance) == (0.25, 0.25)
    assert global_.obstacle_layer.sources[0].topic.endswith("scan")
    assert global_.inflation_radius == 0.7 and global_.cost_scaling_factor == 3.0
    assert local.rolling_window and (local.width, local.height) == (3.0, 3.0)
    assert local.obstacle_layer.sources[0].max_obstacle_height == 2.0
    assert planner.tolerance == 0.5 and not planner.use_astar
    assert {"spin", "backup", "wait"} <= set(behaviors.plugins)


def test_turtlebot3_burger_loads_with_dwb_substituted(caplog):
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        global_, local, _, controller, behaviors = _load(FIXTURES / "turtlebot3_burger.yaml")
    assert caplog.text.count("dwb_core::DWBLocalPlanner is not implemented here") == 1
    rpp = controller.rpp  # DWB's max_vel_x, max_vel_theta, acc_lim_theta
    assert (rpp.desired_linear_vel, rpp.rotate_to_heading_angular_vel) == (0.3, 1.0)
    assert rpp.max_angular_accel == 3.2
    assert (controller.xy_goal_tolerance, controller.yaw_goal_tolerance) == (0.25, 0.25)
    assert global_.robot_radius == 0.1 and global_.static_layer
    assert local.obstacle_layer is not None and len(local.obstacle_layer.sources) >= 1
    assert set(behaviors.plugins) >= {"spin", "backup", "wait"}


@pytest.mark.parametrize(
    ("path", "section", "text", "message"),
    [
        ("planner_server.ros__parameters.GridBased.plugin", "planner",
         "nav2_navfn_planner::NavfnPlaner", "unknown planner 'nav2_navfn_planner::NavfnPlaner'"),
        ("controller_server.ros__parameters.FollowPath.plugin", "controller",
         "dwb_core::DWBLocalPlaner", "unknown controller 'dwb_core::DWBLocalPlaner'"),
        ("global_costmap.global_costmap.ros__parameters.inflation_layer.inflation_radius",
         "global", "-0.55", "inflation_layer.inflation_radius=-0.55 must be zero or positive"),
        ("planner_server.ros__parameters.GridBased.tolerance", "planner", "-0.5",
         "GridBased.tolerance=-0.5 must be zero or positive"),
        ("controller_server.ros__parameters.goal_checker.xy_goal_tolerance", "controller",
         "-0.1", "goal_checker.xy_goal_tolerance=-0.1 must be zero or positive"),
        ("global_costmap.global_costmap.ros__parameters.static_layer.plugin", "global",
         "nav2_costmap_2d::StaticLayr", "unknown costmap layer 'nav2_costmap_2d::StaticLayr'"),
    ],
)  # fmt: skip
def test_typos_and_bad_values_name_the_file_and_key(tmp_path, path, section, text, message):
    import yaml

    doc = yaml.safe_load((FIXTURES / "turtlebot3_burger.yaml").read_text())
    node = doc
    *parents, key = path.split(".")
    for name in parents:
        node = node[name]
    node[key] = yaml.safe_load(text)
    bad = tmp_path / "burger.yaml"
    bad.write_text(yaml.safe_dump(doc))
    loaders = {
        "planner": planner_parameters,
        "controller": controller_parameters,
        "global": costmap_parameters,
    }
    with pytest.raises(ConfigError) as error:
        loaders[section](bad)
    assert str(bad) in str(error.value) and message in str(error.value)
    assert "\n" not in str(error.value)


def test_fra2mo_reaches_a_goal_on_turtlebot3_burgers_parameters():
    scenario = merge_overrides(
        load_scenario("fra2mo_goals"),
        [
            *QUIET,
            f"navigation: {{params_file: {FIXTURES / 'turtlebot3_burger.yaml'}, "
            "goals: [{name: north_east, x: 1.5, y: 1.3, yaw: 1.5708}], order: []}",
        ],
    )
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    navigator = world.robot().navigation.navigator
    context = navigator.GetMyContextFromRoot(simulator.get_context())
    t = 0.0
    while t < 20.0 and not navigator.nav_state(context).results:
        t += 0.5
        simulator.AdvanceTo(t)
    goal = navigator.summary(context)["goals"][0]
    assert goal["status"] == "succeeded", goal
    # Burger's goal checker: 0.25 m (xy_goal_tolerance), 0.25 rad.
    assert goal["position_error"] < 0.25 and goal["yaw_error"] < 0.25
    assert math.isfinite(goal["time"]) and goal["time"] < 15.0
