"""The dynamic look-at controllers (the seed's 2.c): on the iiwa (effort interface) with a
flange camera, the camera follows its linear path within 2 mm while pointing at the ArUco
marker within 0.05 rad, through joint-space and operational-space inverse dynamics. The
path error is measured here from the plant's true camera pose, independently of the
controller."""

import re

import numpy as np
import pytest
from conftest import REPO
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.systems.analysis import Simulator

from armando_drake.control.config import ControllerConfigError, parse_controller_config
from armando_drake.control.controllers.look_at_dynamic import look_at_rotation
from armando_drake.kinematics.motion import TaskSpaceMotion, make_time_law
from armando_drake.kinematics.paths import LinearPath
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario
from armando_drake.vision.metrics import camera_pose, pointing_error, true_marker_position

pytest.importorskip("cv2")


@pytest.mark.parametrize(
    "controller", ["joint_space_look_at_controller", "operational_space_look_at_controller"]
)
def test_camera_tracks_its_linear_path_within_2_mm_while_pointing_within_0_05_rad(
    monkeypatch, controller
):
    monkeypatch.chdir(REPO)  # the scenario names models/ relative to it
    scenario = load_scenario(
        "vision_dynamic",
        "logging: {console_rate: 0}\ncamera: {live_view: false}\n"
        f"controllers: {{activate: [joint_state_broadcaster, {controller}]}}",
    )
    world = MakeWorld(scenario, quiet=True)
    try:
        simulator = Simulator(world.diagram)
        context = simulator.get_context()
        p_WM = true_marker_position(scenario)
        start = pointing_error(world.robot(), context, "flange_camera", p_WM)
        assert start >= 0.2, start  # [rad] the marker well off the optical axis at first
        params = world.robot().stack.config.controllers[controller].params
        time_law = make_time_law(
            TaskSpaceMotion(
                offset=params.offset,
                profile=params.profile,
                duration=params.duration,
                acceleration_time=params.acceleration_time,
            )
        )
        path_errors, pointing = [], []
        for t in np.arange(0.01, 3.0 + 1e-9, 0.01):
            simulator.AdvanceTo(t)
            detail = world.status(context, controller).detail
            path = LinearPath(start=detail["path_start"], goal=detail["path_goal"])
            s = time_law(np.array([min(t - detail["path_start_time"], time_law.duration)]))
            p_d = path(s.s, s.s_dot, s.s_ddot).position[0]
            p_C = camera_pose(world.robot(), context, "flange_camera").translation()
            path_errors.append(np.linalg.norm(p_C - p_d))
            pointing.append((t, pointing_error(world.robot(), context, "flange_camera", p_WM)))
        pointing = np.array(pointing)
        # The path starts where the camera was when the marker was first seen (1 ms).
        assert detail["path_start_time"] <= 0.002
        assert np.linalg.norm(np.subtract(detail["path_goal"], detail["path_start"])) > 0.2
        assert max(path_errors) <= 0.002, max(path_errors)
        # Pointing within 0.05 rad once the first 0.5 s have turned the camera, to the end.
        assert pointing[pointing[:, 0] >= 0.5, 1].max() <= 0.05, pointing[pointing[:, 0] >= 0.5]
        assert (
            world.robot().detectors.aruco.detections == world.robot().detectors.aruco.frames == 90
        )
        # The controller's own figure (every tick) is at least what 10 ms samples saw.
        assert max(path_errors) - 1e-9 <= detail["max_path_error"] <= 0.002
        assert world.status(context, controller).state == "executing"
    finally:
        world.close()


def test_look_at_rotation_turns_the_axis_onto_the_direction():
    rng = np.random.default_rng(3)
    for _ in range(20):
        axis, direction = rng.normal(size=3), rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        direction /= np.linalg.norm(direction)
        e = look_at_rotation(axis, direction)
        angle = np.linalg.norm(e)
        R = RotationMatrix(AngleAxis(angle, e / angle))
        assert np.allclose(R.matrix() @ axis, direction, atol=1e-9)
        assert abs(e @ axis) < 1e-9  # the smallest rotation: no turn about the axis
    assert not np.any(look_at_rotation(np.array([0, 0, 1.0]), np.array([0, 0, 1.0])))


@pytest.mark.parametrize(
    "parameters, message",
    [
        ({"offset": [0.1, 0.2]}, "offset=[0.1, 0.2] must be 3 numbers"),
        ({"profile": "sine"}, "profile='sine' must be one of"),
        ({"duration": -1.0}, "duration"),
    ],
    ids=["offset", "profile", "duration"],
)
def test_bad_path_parameters_are_a_parameter_error(parameters, message):
    data = {
        "controller_manager": {
            "ros__parameters": {
                "update_rate": 1000,
                "look": {"type": "vision_controllers/OperationalSpaceLookAtController"},
            }
        },
        "look": {"ros__parameters": {"joints": ["a", "b"], **parameters}},
    }
    with pytest.raises(ControllerConfigError, match=re.escape(message)) as raised:
        parse_controller_config(data, source="look.yaml")
    assert "\n" not in str(raised.value)


def test_run_outputs_give_the_torques_and_the_path_error(monkeypatch, tmp_path):
    import csv
    import json

    from armando_drake.simulation.run import run

    monkeypatch.chdir(REPO)
    scenario = load_scenario(
        "vision_dynamic",
        "logging: {console_rate: 0}\ncamera: {live_view: false}\nsimulation: {duration: 0.5}",
    )
    run(scenario, scenario_name="vision_dynamic.yaml", output_dir=tmp_path, quiet=True,
        replay=False, plots=False)  # fmt: skip
    vision = json.loads((tmp_path / "summary.json").read_text())["vision"]
    assert 0 < vision["max_path_error"] <= 0.002
    assert vision["detections"] == vision["frames"] == 15
    with (tmp_path / "vision.csv").open() as stream:
        rows = list(csv.reader(stream))
    assert rows[0][4:] == [f"iiwa_joint_{k}_effort_command" for k in range(1, 8)]
    assert len(rows) == 16 and any(abs(float(x)) > 1.0 for x in rows[-1][4:])  # [N m]


@pytest.mark.parametrize("kind", ["joint_space", "operational_space"])
def test_logic_holds_until_the_marker_then_follows_it_and_rejects_bad_poses(kind):
    """The logic alone on Armando's plant (4 joints: the general case, no iiwa needed)."""
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import MultibodyPlant

    from armando_drake.control.controllers import ControllerJoints
    from armando_drake.control.controllers.look_at_dynamic import (
        JointSpaceLookAtController,
        OperationalSpaceLookAtController,
    )
    from armando_drake.description.loader import load_robot
    from armando_drake.messages.types import MarkerPose

    plant = MultibodyPlant(0.0)
    robot = load_robot(plant)
    for info in robot.joints:  # a torque actuator per joint, as on the effort interface
        plant.AddJointActuator(f"{info.name}_motor", plant.GetJointByName(info.name), info.effort)
    plant.Finalize()
    cls = JointSpaceLookAtController if kind == "joint_space" else OperationalSpaceLookAtController
    joints = ControllerJoints.make(["j0", "j1", "j2", "j3"])
    params = cls.parameters(joints=list(joints.names), offset=[0.02, 0.0, 0.0], duration=1.0,
                            acceleration_time=0.3)  # fmt: skip
    logic = cls(name="look", joints=joints, params=params)
    logic.connect_plant(plant, robot.model_instance)
    q = np.array([0.0, 0.0, 0.0, 2.3])

    def measure(desired):
        return q, np.zeros(4)

    memory = logic.update(0.0, None, logic.initial_memory(), measure)
    assert memory.status.state == "holding" and np.all(np.isfinite(memory.effort))
    memory = logic.update(0.001, "not a pose", memory, measure)
    assert memory.status.rejected == 1 and memory.status.state == "holding"
    X_LC = RigidTransform(RollPitchYaw([-np.pi / 2, -np.pi / 2, 0.0]), [0.0, 0.0, 0.06])
    pose = MarkerPose(stamp=0.002, frame_id="c", pose=RigidTransform([0.05, 0.0, 0.3]),
                      link="crawer_base", X_LC=X_LC)  # fmt: skip
    memory = logic.update(0.002, pose, memory, measure)
    detail = memory.status.detail
    assert memory.status.state == "executing" and memory.status.accepted == 1
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, robot.model_instance, q)
    X_WC = plant.GetBodyByName("crawer_base").EvalPoseInWorld(context) @ X_LC
    assert np.allclose(detail["path_start"], X_WC.translation(), atol=1e-12)
    assert np.allclose(np.subtract(detail["path_goal"], detail["path_start"]), [0.02, 0, 0])
    assert np.allclose(detail["target"], X_WC @ np.array([0.05, 0.0, 0.3]), atol=1e-12)
    assert detail["path_start_time"] == 0.002
    bad = MarkerPose(stamp=0.003, frame_id="c", pose=RigidTransform([0, 0, 0.3]), link="nope")
    memory = logic.update(0.003, bad, memory, measure)
    assert memory.status.rejected == 2 and "link 'nope'" in memory.status.last_error
    memory = logic.update(0.004, None, memory, measure)  # between frames: the estimate holds
    assert memory.status.state == "executing" and np.all(np.isfinite(memory.effort))
    assert np.allclose(memory.internal.target, detail["target"])
