"""The viewer keeps a mobile robot and its task in view (outputs/follow.py, outputs/view.py):
the first view frames the arena with the robot and its goals, then the camera follows the
base; from the camera Meshcat is given and the base's pose, the base never leaves the
view."""

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator

from armando_drake.outputs.follow import BUTTON, TIME_CONSTANT, in_view
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

QUIET = "logging: {console_rate: 0}"


def test_in_view_is_the_cameras_frustum():
    camera, target = [0.0, -5.0, 0.0], [0.0, 0.0, 0.0]  # looking along +y, 30 deg tall
    assert in_view([0.0, 0.0, 0.0], camera, target)
    edge = 5.0 * np.tan(np.radians(15.0))
    assert in_view([0.0, 0.0, 0.99 * edge], camera, target)
    assert not in_view([0.0, 0.0, 1.01 * edge], camera, target)
    assert in_view([1.5 * edge, 0.0, 0.0], camera, target, aspect=16 / 9)
    assert not in_view([1.5 * edge, 0.0, 0.0], camera, target)
    assert not in_view([0.0, -6.0, 0.0], camera, target)  # behind the camera


def test_fra2mo_and_its_goals_stay_in_view_while_the_camera_follows():
    meshcat = Meshcat()
    scenario = load_scenario("fra2mo_goals", QUIET)
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True)
    follow = world.diagram.GetSubsystemByName("follow_camera")
    assert BUTTON in meshcat.GetButtonNames()
    plant, base = world.plant, world.robot().mobile.base_link
    body = plant.GetBodyByName(base, world.robot().robot.model_instance)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    first = follow.camera.copy(), follow.target.copy()
    nav_goals = (
        world.robot()
        .navigation.navigator.nav_state(
            world.robot().navigation.navigator.GetMyContextFromRoot(simulator.get_context())
        )
        .goals
    )
    assert len(nav_goals) == 4
    for goal in nav_goals:  # the arena framed: every goal in the first view
        assert in_view([goal.x, goal.y, 0.0], *first), goal
    seen, lag = [], []
    for t in np.arange(0.5, 20.01, 0.5):
        simulator.AdvanceTo(t)
        context = plant.GetMyContextFromRoot(simulator.get_context())
        position = plant.EvalBodyPoseInWorld(context, body).translation()
        seen.append(in_view(position, follow.camera, follow.target))
        lag.append(np.linalg.norm(follow.target[:2] - position[:2]))
    assert all(seen), seen
    assert follow.moves > 150  # 10 Hz for 20 s
    # Smooth, and close: the target trails the base by its lag at fra2mo's 0.26 m/s at most.
    assert max(lag[4:]) < 0.26 * TIME_CONSTANT * 2 + 0.05, lag
    offset = follow.camera - follow.target
    assert np.allclose(offset, first[0] - first[1])  # the view's direction and distance kept
    world.close(simulator.get_context())
