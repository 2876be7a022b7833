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
def test_iiwa_looks_at_the_marker_within_5_seconds(
    iiwa_package, monkeypatch, controller, marker, off
):
    monkeypatch.chdir(REPO)  # the scenario names ../shared and models/ relative to it
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
    start = pointing_error(world, context, "flange_camera", p_WM)
    assert start >= off, start  # [rad] at the start
    simulator.AdvanceTo(5.0)
    final = pointing_error(world, context, "flange_camera", p_WM)
    assert final < 0.02, (start, final)
    assert world.detectors.aruco.detections >= 140  # found in (nearly) every frame
    assert world.status(context, controller).state == "executing"
    world.close()
