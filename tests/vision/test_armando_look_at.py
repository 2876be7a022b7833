"""Armando with a camera on its last link looks at the disc (pan and tilt only): the blob
detector's largest keypoint as the look-at target, the improved look-at-point controller
on Armando's position servos, the pointing error against the disc's true top face."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario
from armando_drake.vision.detectors import BlobTarget, Keypoint
from armando_drake.vision.metrics import pointing_error, true_disc_position

pytest.importorskip("cv2")

QUIET = "logging: {console_rate: 0}\ncamera: {live_view: false}\n"
DISC = "objects: [{name: blue_disc, shape: !Cylinder {radius: 0.05, length: 0.01}, "
DISC += "xyz: [%g, %g, 0.005], color: [0.05, 0.15, 0.9, 1.0], collision: false}]"


@pytest.mark.parametrize(
    "disc, pan",
    [(None, 1.0), ((-0.1, -0.25), -1.0)],  # the scenario's, to the right; moved to the left
    ids=["scenario", "disc_moved"],
)
def test_armando_looks_at_the_disc_within_0_05_rad(disc, pan):
    override = QUIET + ("" if disc is None else DISC % disc)
    scenario = load_scenario("vision_armando", override)
    world = MakeWorld(scenario, quiet=True)
    try:
        simulator = Simulator(world.diagram)
        context = simulator.get_context()
        p_WD = true_disc_position(scenario)
        plant_context = world.plant.GetMyContextFromRoot(context)
        q0 = world.plant.GetPositions(plant_context, world.robot().robot.model_instance).copy()
        start = pointing_error(world.robot(), context, "wrist_camera", p_WD)
        assert start >= 0.25, start  # [rad] the disc well off the optical axis
        simulator.AdvanceTo(3.0)
        final = pointing_error(world.robot(), context, "wrist_camera", p_WD)
        assert final < 0.05, (start, final)
        q = world.plant.GetPositions(plant_context, world.robot().robot.model_instance)
        # It panned (j0) towards the disc's side; the detector found the disc on every frame.
        assert pan * (q[0] - q0[0]) > 0.2, q - q0
        blob = world.robot().detectors.blob
        assert blob.detections == blob.frames >= 90
        assert world.status(context, "improved_look_at_point_controller").state == "executing"
        published = world.diagram.GetOutputPort("wrist_camera.cam_T_target").Eval(context)
        assert published.count == blob.detections
    finally:
        world.close()


def test_blob_target_point_is_at_the_distance_of_the_known_diameter():
    K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])
    target = BlobTarget(K=K, diameter=0.1, camera="c", link="l", X_LC=RigidTransform())
    # A 0.1 m disc 0.5 m away on the optical axis, and 0.1 m to the right at 0.4 m.
    assert np.allclose(target.point(Keypoint(320.0, 240.0, 100.0)), [0.0, 0.0, 0.5])
    assert np.allclose(target.point(Keypoint(445.0, 240.0, 125.0)), [0.1, 0.0, 0.4])


@pytest.mark.parametrize(
    "override, message",
    [
        (
            "vision: {blob: {camera: wrist_camera, target_diameter: -0.1}}",
            "vision.blob.target_diameter=-0.1 must be >= 0 [m]",
        ),
        (
            "vision: {blob: {camera: wrist_camera, target_diameter: 0.1}, "
            "aruco: {camera: wrist_camera}}",
            "both give the look-at-point controllers a target",
        ),
        (
            "vision: {blob: {camera: wrist_camera}, start_positions: [0.0, 0.1, 0.2, 0.3]}",
            "vision.start_positions: joint 'j0' takes position commands",
        ),
    ],
    ids=["negative_diameter", "two_targets", "start_positions_on_position_joints"],
)
def test_bad_blob_target_is_a_one_line_error(override, message):
    with pytest.raises(ScenarioError) as raised:
        MakeWorld(load_scenario("vision_armando", QUIET + override), quiet=True)
    text = str(raised.value)
    assert message in text and "\n" not in text, text


def test_world_cli_names_the_vision_controller_and_lists_what_it_wrote(tmp_path):
    """The headline names what drove the arm (the look-at controller fed by the camera),
    the vision figures are printed, and the file list is what the run wrote."""
    import json
    import subprocess
    import sys

    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--scenario", "vision_armando"]
        + ["--no-meshcat", "--realtime-rate", "0", "--duration", "1", "--quiet"]
        + ["--no-replay", "--output", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert any(
        line.startswith(
            "vision_armando.yaml with the camera's detections driving the arm "
            "(improved_look_at_point_controller):"
        )
        for line in lines
    ), result.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["controller"] == "vision"
    assert summary["driven_controller"] == "improved_look_at_point_controller"
    vision = summary["vision"]
    assert f"vision: {vision['detections']} detections in {vision['frames']} frames" in (
        result.stdout
    )
    assert vision["frames"] == 30 and vision["detections"] == 30
    logs = next(line for line in lines if line.startswith("logs: "))
    assert "vision.csv" in logs and "keypoints.csv" in logs and "commands.csv" not in logs
    assert not (out / "commands.csv").exists()
    assert not any(line.startswith("replay: ") for line in lines)
