"""The navigation drawn live in Meshcat (outputs/navigation_view.py): the map's occupied
cells, the costmap's inflated ones, the plan the navigator follows and the goals."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator

from armando_drake.outputs.navigation_view import NAV_PATH, PLAN_HEIGHT, cell_centres
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario


@pytest.fixture(scope="module")
def drawn():
    meshcat = Meshcat()
    scenario = load_scenario("fra2mo_goals", "logging: {console_rate: 0}")
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(3.0)  # the first goal planned (after the start delay) and driven to
    view = world.diagram.GetSubsystemByName("navigation_view")
    navigator = world.diagram.GetSubsystemByName(world.robot().navigation.navigator.get_name())
    nav = navigator.GetOutputPort("nav_state").Eval(
        navigator.GetMyContextFromRoot(simulator.get_context())
    )
    yield meshcat, view, world, nav
    world.close(simulator.get_context())


def _positions(meshcat: Meshcat, path: str) -> np.ndarray:
    """The (n, 3) vertices of the Meshcat object at ``path`` (a line or a point cloud)."""
    packed = msgpack.unpackb(meshcat._GetPackedObject(path), raw=False, strict_map_key=False)
    array = packed["object"]["geometries"][0]["data"]["attributes"]["position"]["array"]
    return np.frombuffer(array.data, dtype=np.float32).reshape(-1, 3)


def test_the_plan_drawn_is_the_navigators(drawn):
    meshcat, view, _, nav = drawn
    assert nav.path is not None and len(nav.path) > 10
    line = _positions(meshcat, f"{NAV_PATH}/plan/{len(view.plans) - 1}")  # the latest
    assert view.plan_points == len(nav.path) == len(line)
    assert np.abs(line[:, :2] - nav.path).max() < 1e-6
    assert np.allclose(line[:, 2], PLAN_HEIGHT)


def _visible(meshcat: Meshcat, path: str) -> bool:
    packed = msgpack.unpackb(meshcat._GetPackedProperty(path, "visible"), raw=False)
    return packed["value"]


def test_each_plan_is_kept_and_a_replay_shows_the_one_current_then(drawn):
    """Every plan stays drawn (plan/<k>), the latest shown; a replay's frame at time t
    (the forced publish publish_replay makes) shows the plan current at t only."""
    meshcat, view, world, nav = drawn
    assert len(view.plans) >= 2 and view.plans == sorted(view.plans), view.plans
    assert view.plans[-1] == pytest.approx(nav.planned_at)
    latest = len(view.plans) - 1
    assert [_visible(meshcat, f"{NAV_PATH}/plan/{k}") for k in range(latest)] == [False] * latest
    context = world.diagram.CreateDefaultContext()
    own = view.GetMyContextFromRoot(context)
    for k, made in enumerate(view.plans):
        context.SetTime(made + 0.01)
        view.ForcedPublish(own)
        shown = [_visible(meshcat, f"{NAV_PATH}/plan/{j}") for j in range(len(view.plans))]
        assert shown == [j == k for j in range(len(view.plans))], (k, shown)


def test_the_map_and_the_costmap_are_drawn_cell_by_cell(drawn):
    meshcat, view, world, _ = drawn
    grid = world.robot().navigation.grid
    occupied = np.asarray(grid.data) >= 65
    points = _positions(meshcat, f"{NAV_PATH}/map")
    assert view.map_cells == occupied.sum() == len(points) > 100
    expected = cell_centres(occupied, grid.resolution, grid.origin).T
    assert np.abs(np.sort(points[:, 0]) - np.sort(expected[:, 0])).max() < 1e-5
    costs = np.asarray(world.robot().navigation.costmap.costs)
    inflated = ((costs > 0) & (costs < 254)).sum()
    assert view.costmap_cells == inflated == len(_positions(meshcat, f"{NAV_PATH}/costmap"))


def test_every_goal_is_drawn_where_it_is(drawn):
    meshcat, view, _, nav = drawn
    assert view.goals_drawn == [goal.name for goal in nav.goals] and len(nav.goals) == 4
    for goal in nav.goals:
        assert meshcat.HasPath(f"{NAV_PATH}/goals/{goal.name}/position")
        heading = _positions(meshcat, f"{NAV_PATH}/goals/{goal.name}/heading")
        direction = heading[1, :2] - heading[0, :2]
        assert np.arctan2(direction[1], direction[0]) == pytest.approx(
            np.arctan2(np.sin(goal.yaw), np.cos(goal.yaw)), abs=1e-5
        )


def test_cell_centres_follow_a_turned_origin():
    mask = np.zeros((2, 3), bool)
    mask[1, 2] = True  # row 1, column 2: local (2.5, 1.5) cells
    xy = cell_centres(mask, 0.1, (1.0, 2.0, np.pi / 2))
    assert xy[:, 0] == pytest.approx([1.0 - 0.15, 2.0 + 0.25])


def test_the_costmap_drawn_follows_the_obstacle_layer():
    """fra2mo_obstacles: a crate the map lacks, once the lidar sees it, is drawn inflated in
    the costmap (cells around it that the static costmap left free)."""
    meshcat = Meshcat()
    scenario = load_scenario("fra2mo_obstacles", "logging: {console_rate: 0}")
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True)
    view = world.diagram.GetSubsystemByName("navigation_view")
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.5)
    before = _positions(meshcat, f"{NAV_PATH}/costmap")
    simulator.AdvanceTo(6.0)
    after = _positions(meshcat, f"{NAV_PATH}/costmap")
    world.close(simulator.get_context())
    crate = np.array([-0.72, -0.43])  # the crate's centre (diagrams/fra2mo_obstacles.yaml)

    def near(points):
        return int((np.linalg.norm(points[:, :2] - crate, axis=1) < 0.5).sum())

    assert near(after) > near(before) + 20  # the pillar to the south-west inflates some
    assert view.costmap_cells == len(after)


def test_the_map_being_built_is_drawn_as_the_mapper_publishes_it():
    """fra2mo_explore: the view draws the mapper's published map (its ``map`` output), more
    of it as the exploration goes, cell for cell; the view reads only its own ports, so a
    Simulator's initialization and periodic events run (they hand it its own context)."""
    meshcat = Meshcat()
    scenario = load_scenario("fra2mo_explore", "logging: {console_rate: 0}")
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True)
    view = world.diagram.GetSubsystemByName("navigation_view")
    mapper = world.robot().navigation.mapper
    simulator = Simulator(world.diagram)
    counts = []
    for t in (1.5, 4.5):
        simulator.AdvanceTo(t)
        published = mapper.GetOutputPort("map").Eval(
            mapper.GetMyContextFromRoot(simulator.get_context())
        )
        occupied = np.asarray(published.data) >= 65
        points = _positions(meshcat, f"{NAV_PATH}/map")
        expected = cell_centres(occupied, published.resolution, published.origin).T
        assert view.map_cells == occupied.sum() == len(points)
        assert np.abs(np.sort(points[:, 1]) - np.sort(expected[:, 1])).max() < 1e-5
        counts.append(len(points))
    world.close(simulator.get_context())
    assert counts[0] > 20 and counts[1] > counts[0] + 20  # the walls seen as it explores


def test_the_replay_animates_the_plans_in_their_order(drawn, tmp_path):
    """publish_replay of the run so far: in replay.html's animation each plan/<k> is
    hidden at the start, shown from the frame its plan was made, hidden at the next's."""
    import base64
    import re

    from armando_drake.outputs.replay import publish_replay

    meshcat, view, world, _ = drawn
    context = world.diagram.CreateDefaultContext()
    context.SetTime(3.0)
    frames = publish_replay(meshcat, world.diagram, world.plant, world.replay_sampler, context)
    assert frames > 0
    fps = 1.0 / world.replay_sampler.interval
    html = meshcat.StaticHtml()
    (animation,) = [
        command
        for blob in re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
        for command in [msgpack.unpackb(base64.b64decode(blob), raw=False, strict_map_key=False)]
        if command.get("type") == "set_animation"
    ]
    tracks = {a["path"]: a["clip"]["tracks"][0] for a in animation["animations"]}
    sampled = world.replay_sampler.frames()[0]
    for k, made in enumerate(view.plans):
        track = tracks[f"{NAV_PATH}/plan/{k}"]
        assert track["name"] == ".visible"
        keys = [(key["time"], key["value"]) for key in track["keys"]]
        shown_at = min(t for t in sampled if t >= made - 1e-9)  # the first frame after it
        assert keys[0] == (0, False) and (round(shown_at * fps), True) in keys, (k, keys)
