"""The obstacle layer on the lidar's scans, replanning around what the map does not have,
and the recoveries before a blocked goal is aborted (one shared run of
diagrams/fra2mo_obstacles.yaml), and the layer's marking and clearing on a synthetic scan."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.messages.scans import LaserScan
from armando_drake.navigation.behaviors import behavior_parameters
from armando_drake.navigation.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from armando_drake.navigation.costmap import Costmap, costmap_parameters
from armando_drake.navigation.inflation_layer import inflate
from armando_drake.navigation.obstacle_layer import ObservationSource, observe
from armando_drake.navigation.planner import PlanningError, plan, planner_parameters
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides
from armando_drake.tools.errors import ConfigError

CONFIG = Path(__file__).parents[2] / "models" / "fra2mo_description" / "config"
QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]
CRATE = (-0.72, -0.43, 0.2)  # the crate's centre (x, y) and half side [m]
BASE_RADIUS = 0.11  # [m] fra2mo's base cylinder (its wheels are within it)


IN_CRATE = (-0.72, -0.28)  # the goal inside the crate, 0.05 m in from its north face [m]


def _crate_clearance(x: float, y: float) -> float:
    cx, cy, h = CRATE
    return math.hypot(max(abs(x - cx) - h, 0.0), max(abs(y - cy) - h, 0.0))


def test_a_scan_clears_along_its_beams_and_marks_their_ends():
    costmap = Costmap(np.zeros((40, 40), np.uint8), 0.05, (-1.0, -1.0, 0.0))
    layer = np.full((40, 40), NO_INFORMATION, np.uint8)
    scan = LaserScan(
        angle_min=0.0,
        angle_increment=math.pi / 2,
        range_min=0.1,
        range_max=10.0,
        ranges=np.array([0.6, np.inf, 3.0, 0.2]),  # +x hit, +y nothing, -x too far, -y near
    )
    source = ObservationSource(clearing=True, obstacle_max_range=2.5, raytrace_max_range=3.0)
    out = observe(layer, costmap, (0.0, 0.0, 0.0), 0.2, scan, source)
    assert out[costmap.world_to_cell(0.6, 0.0)] == LETHAL_OBSTACLE
    assert out[costmap.world_to_cell(0.3, 0.0)] == FREE_SPACE  # cleared up to the hit
    assert out[costmap.world_to_cell(0.0, 0.5)] == NO_INFORMATION  # inf: not valid
    assert out[costmap.world_to_cell(-0.9, 0.0)] == FREE_SPACE  # 3.0 m: cleared, not marked
    assert (out == LETHAL_OBSTACLE).sum() == 2  # +x and -y (0.2 m >= obstacle_min_range)
    # Above max_obstacle_height nothing is marked.
    high = observe(layer, costmap, (0.0, 0.0, 0.0), 2.5, scan, source)
    assert (high == LETHAL_OBSTACLE).sum() == 0


def test_the_obstacle_layer_and_local_costmap_parameters_load():
    path = CONFIG / "navigation_obstacles.yaml"
    global_ = costmap_parameters(path)
    local = costmap_parameters(path, "local_costmap")
    scan = global_.obstacle_layer.sources[0]
    assert (scan.topic, scan.data_type, scan.clearing, scan.marking) == (
        "/scan",
        "LaserScan",
        True,
        True,
    )
    assert (scan.obstacle_max_range, scan.raytrace_max_range) == (2.5, 3.0)
    assert local.rolling_window and (local.width, local.height) == (3.0, 3.0)
    assert local.update_frequency == 10.0 and not local.static_layer
    behaviors = behavior_parameters(path)
    assert set(behaviors.plugins) == {"spin", "backup", "wait"}


def test_bad_obstacle_layer_values_name_the_file_and_key(tmp_path):
    path = tmp_path / "nav.yaml"
    path.write_text(
        "global_costmap:\n  global_costmap:\n    ros__parameters:\n"
        "      plugins: [obstacle_layer]\n      obstacle_layer:\n"
        "        plugin: nav2_costmap_2d::ObstacleLayer\n        observation_sources: scan\n"
        "        scan: {data_type: LaserScan, obstacle_max_range: -1.0}\n"
    )
    with pytest.raises(ConfigError, match=r"nav.yaml: .*obstacle_layer.scan.obstacle_max_range"):
        costmap_parameters(path)


def test_the_goal_in_the_crate_is_blocked_by_its_north_face_alone():
    # The designed abort does not depend on which other faces the scans marked, nor on a
    # cost's last unit: with only the north face lethal (the one seen from north_west), the
    # goal's cell and every cell within NavFn's tolerance are inscribed.
    goal = load_scenario("fra2mo_obstacles").navigation.goals[1]
    assert (goal.name, goal.x, goal.y) == ("in_crate", *IN_CRATE)
    path = CONFIG / "navigation_obstacles.yaml"
    params, planner = costmap_parameters(path), planner_parameters(path)
    cx, cy, h = CRATE
    costs = np.zeros((124, 126), np.uint8)  # the arena map's grid
    costmap = Costmap(costs, 0.05, (-3.15, -3.1, 0.0))
    for x in np.arange(cx - h, cx + h + 1e-9, 0.01):
        costs[costmap.world_to_cell(x, cy + h)] = LETHAL_OBSTACLE
    costmap = Costmap(inflate(costs, 0.05, params), 0.05, (-3.15, -3.1, 0.0))
    row, col = costmap.world_to_cell(*IN_CRATE)
    radius = 3  # cells: beyond the 0.1 m tolerance
    rows, cols = np.mgrid[row - radius : row + radius + 1, col - radius : col + radius + 1]
    centres = costmap.cell_to_world(rows.ravel(), cols.ravel())
    within = np.hypot(*(centres - IN_CRATE).T) <= planner.tolerance
    assert (costmap.costs[rows.ravel()[within], cols.ravel()[within]] >= 253).all()
    with pytest.raises(PlanningError, match="in an obstacle"):
        plan(costmap, (-1.7, 0.5), IN_CRATE, planner)


@pytest.fixture(scope="module")
def run():
    """fra2mo_obstacles until both goals have a result: the crate's clearance each 0.1 s."""
    scenario = merge_overrides(load_scenario("fra2mo_obstacles"), QUIET)
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    plant = world.plant
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    navigator = world.robot().navigation.navigator
    clearance, t, seen = math.inf, 0.0, None
    while t < scenario.simulation.duration:
        t += 0.1
        simulator.AdvanceTo(t)
        p = plant.EvalBodyPoseInWorld(plant.GetMyContextFromRoot(simulator.get_context()), body)
        clearance = min(clearance, _crate_clearance(*p.translation()[:2]))
        context = navigator.GetMyContextFromRoot(simulator.get_context())
        state = navigator.nav_state(context)
        if not state.results and state.costmaps:  # on the way to north_west
            seen = state.costmaps[0]
        if len(state.results) == 2:
            break
    return {
        "summary": navigator.summary(context),
        "state": navigator.nav_state(context),
        "clearance": clearance,
        "end": t,
        "navigator": navigator,
        "seen": seen,
    }


def test_the_crate_not_on_the_map_is_seen_in_the_costmap(run):
    navigator = run["navigator"]
    cx, cy, h = CRATE
    static = navigator.costmap  # the saved map's: no crate
    assert static.costs[static.world_to_cell(cx - h, cy)] < 253
    costmap = run["seen"]  # the global costmap with its obstacle layer, at north_west
    # The faces the robot drove past are lethal within one cell of their centres ...
    faces = 0
    for x, y in ((cx - h, cy), (cx + h, cy), (cx, cy - h), (cx, cy + h)):
        row, col = costmap.world_to_cell(x, y)
        faces += (costmap.costs[row - 1 : row + 2, col - 1 : col + 2] == LETHAL_OBSTACLE).any()
    assert faces >= 3
    # ... and every lethal cell the scans added near it (but the arena's own obstacles,
    # on the saved map a cell or two off) is within one cell of its sides.
    walls = costmap.cell_to_world(*np.nonzero(static.costs == LETHAL_OBSTACLE))
    rows, cols = np.nonzero(costmap.costs == LETHAL_OBSTACLE)
    near = [
        _crate_clearance(x, y)
        for x, y in costmap.cell_to_world(rows, cols)
        if _crate_clearance(x, y) < 0.5 and np.hypot(*(walls - (x, y)).T).min() > 0.15
    ]
    assert near and max(near) <= costmap.resolution * 1.5


def test_the_plan_blocked_by_the_crate_is_replanned_and_the_goal_reached(run):
    first = run["summary"]["goals"][0]
    assert first["name"] == "north_west" and first["status"] == "succeeded"
    assert first["position_error"] < 0.1
    # Its first plan passed within the costmap's robot_radius (0.2 m) of the crate, across
    # it, beyond the obstacle range when planned ...
    plan = run["state"].results[0].first_plan
    assert min(_crate_clearance(x, y) for x, y in plan) < 0.2
    assert min(_crate_clearance(x, y) for x, y in plan) == 0.0
    # ... replanned once it was seen, and driven around it without touching it.
    assert first["blocked_replans"] >= 1
    assert run["clearance"] > BASE_RADIUS + 0.05


def test_a_goal_inside_the_crate_runs_the_recoveries_then_is_aborted(run):
    goal = run["summary"]["goals"][1]
    assert goal["name"] == "in_crate" and goal["status"] == "aborted"
    assert goal["reason"] == "no plan"
    kinds = [r["behavior"] for r in goal["recoveries"]]
    assert kinds == ["clear_costmaps", "Spin", "Wait", "BackUp", "clear_costmaps", "Spin"]
    wait = goal["recoveries"][2]
    assert wait["end"] - wait["start"] == pytest.approx(5.0, abs=0.06)
    assert run["end"] < 50.0  # ended within the run, not hanging


def test_unknown_behaviour_plugins_are_refused(tmp_path):
    path = tmp_path / "nav.yaml"
    path.write_text(
        "behavior_server:\n  ros__parameters:\n    behavior_plugins: [spin]\n"
        "    spin: {plugin: nav2_behaviors::Spinn}\n"
    )
    with pytest.raises(ConfigError, match=r"nav.yaml: .*spin.plugin: unknown behaviour"):
        behavior_parameters(path)
