"""The look-at-point controllers: the interaction matrix against finite differences, and
the iiwa with a flange camera turning to the ArUco marker (both kinematic versions)."""

import numpy as np
import pytest
from conftest import REPO
from pydrake.systems.analysis import Simulator

from armando_drake.control.config import ControllerConfigError, parse_controller_config
from armando_drake.control.controllers.look_at import interaction_matrix
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario
from armando_drake.vision.metrics import pointing_error, true_marker_position


def test_interaction_matrix_predicts_how_the_unit_vector_moves():
    rng = np.random.default_rng(7)
    p = np.array([0.1, -0.2, 0.6])  # [m] a still point in the camera frame
    twist = rng.normal(size=6)  # [w; v] of the camera, in its own frame
    dt = 1e-6

    def s_after(t):
        w, v = twist[:3], twist[3:]
        # The point as seen from the camera that moved for t: p - t (v + w x p) (first order).
        moved = p - t * (v + np.cross(w, p))
        return moved / np.linalg.norm(moved)

    numeric = (s_after(dt) - s_after(-dt)) / (2 * dt)
    assert np.allclose(interaction_matrix(p) @ twist, numeric, atol=1e-6)


def test_rest_positions_of_the_wrong_length_are_a_parameter_error():
    data = {
        "controller_manager": {
            "ros__parameters": {
                "update_rate": 100,
                "look": {"type": "vision_controllers/ImprovedLookAtPointController"},
            }
        },
        "look": {"ros__parameters": {"joints": ["a", "b"], "rest_positions": [0.0]}},
    }
    with pytest.raises(ControllerConfigError, match=r"rest_positions=\[0.0\] must have one value"):
        parse_controller_config(data, source="look.yaml")


@pytest.mark.parametrize(
    "controller, marker, off",
    [
        ("improved_look_at_point_controller", [0.55, 0.0], 0.4),
        ("look_at_point_controller", [0.55, 0.0], 0.4),
        ("improved_look_at_point_controller", [0.64, 0.12], 0.2),  # moved by --set
    ],
    ids=["improved", "pose_offset", "improved_marker_moved"],
)
def test_iiwa_looks_at_the_marker_within_5_seconds(monkeypatch, controller, marker, off):
    monkeypatch.chdir(REPO)  # the scenario names models/ relative to it
    scenario = load_scenario(
        "vision_look_at",
        "logging: {console_rate: 0}\ncamera: {live_view: false}\n"
        f"controllers: {{activate: [joint_state_broadcaster, {controller}]}}\n"
        f"objects: [{{name: marker, shape: !ArucoMarker {{}}, xyz: [{marker[0]}, {marker[1]}, "
        "0.0025]}]",
    )
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    context = simulator.get_context()
    p_WM = true_marker_position(scenario)
    start = pointing_error(world.robot(), context, "flange_camera", p_WM)
    assert start >= off, start  # [rad] at the start
    simulator.AdvanceTo(5.0)
    final = pointing_error(world.robot(), context, "flange_camera", p_WM)
    assert final < 0.02, (start, final)
    assert world.robot().detectors.aruco.detections >= 140  # found in (nearly) every frame
    assert world.status(context, controller).state == "executing"
    world.close()


def _armando_logic(controller_class):
    """A look-at controller's logic on Armando's plant (no world: the logic alone)."""
    from pydrake.multibody.plant import MultibodyPlant

    from armando_drake.control.controllers import ControllerJoints
    from armando_drake.description.loader import load_robot

    plant = MultibodyPlant(0.0)
    robot = load_robot(plant)
    plant.Finalize()
    joints = ControllerJoints.make(["j0", "j1", "j2", "j3"], velocity=[1.0] * 4)
    logic = controller_class(
        name="look", joints=joints, params=controller_class.parameters(joints=list(joints.names))
    )
    logic.connect_plant(plant, robot.model_instance)
    return logic


@pytest.mark.parametrize("kind", ["improved", "pose_offset"])
def test_commands_turn_the_camera_towards_the_marker_and_stop_when_it_is_lost(kind):
    from pydrake.math import RigidTransform

    from armando_drake.control.controllers.look_at import (
        ImprovedLookAtPointController,
        LookAtPointController,
    )
    from armando_drake.messages.types import MarkerPose

    cls = ImprovedLookAtPointController if kind == "improved" else LookAtPointController
    logic = _armando_logic(cls)
    p = np.array([0.15, -0.1, 0.5])  # [m] the marker, off the optical axis
    message = MarkerPose(stamp=1.0, frame_id="c", pose=RigidTransform(p), link="wrist")
    q = np.array([0.1, -0.4, 0.8, 0.3])
    memory = logic.update(1.0, message, logic.initial_memory(), lambda desired: (q, q * 0))
    qdot = memory.desired[4:]
    assert memory.status.state == "executing" and np.abs(qdot).max() > 0.01
    # The camera's motion under qdot turns s towards (0, 0, 1): s . s_d grows.
    J = logic.camera_jacobian(q, "wrist", RigidTransform())
    s_dot = interaction_matrix(p) @ J @ qdot
    assert s_dot @ np.array([0.0, 0.0, 1.0]) > 0.0
    assert np.abs(qdot).max() <= 1.0 + 1e-12  # the velocity limits
    # No marker pose for longer than the timeout: the joints are commanded to stop.
    held = logic.update(1.1, None, memory, lambda desired: (q, q * 0))
    assert held is memory  # within the timeout the command holds
    stopped = logic.update(1.0 + logic.params.timeout + 0.01, None, memory, lambda d: (q, q * 0))
    assert stopped.status.state == "holding" and not np.any(stopped.desired[4:])
