"""The live jog in a running world: sliders, the Cartesian jog's differential IK, the
gamepad (synthetic states fed to the jog system), home, limits and their notes."""

import subprocess
import sys

import numpy as np
import pytest
from jog_worlds import Pad, jog_world
from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario
from armando_drake.teleop.config import GamepadMapping
from armando_drake.teleop.jog import CartesianJog, followable_rotations

HOME = np.array([0.0, 0.4, 0.9, 0.7])  # diagrams/jog.yaml
MAPPING = GamepadMapping()
DEADMAN = MAPPING.deadman_button


def test_the_arm_starts_at_home_and_holds_it():
    run = jog_world()
    try:
        np.testing.assert_allclose(run.q(), HOME, atol=1e-9)
        run.advance(1.0)
        assert np.abs(run.q() - HOME).max() < 0.01
        assert run.jog.sliders == ["j0", "j1", "j2", "j3"]
        # Armando's 4 joints follow the position and the pitch, about the gripper's x.
        assert run.jog.rotations == ["x"]
        assert "jog +x (W)" in run.meshcat.GetButtonNames()
        assert "jog +rot x (U)" in run.meshcat.GetButtonNames()
        assert "jog +rot y (I)" not in run.meshcat.GetButtonNames()
    finally:
        run.close()


def test_a_slider_set_on_the_server_moves_its_joint_there():
    run = jog_world()
    try:
        run.meshcat.SetSliderValue("j1", 0.75)
        run.advance(2.0)
        q = run.q()
        assert abs(q[1] - 0.75) < 0.01, q
        assert np.abs(np.delete(q - HOME, 1)).max() < 0.01  # the others hold
        np.testing.assert_allclose(run.jog.command(run.context), [0.0, 0.75, 0.9, 0.7])
    finally:
        run.close()


def test_followable_rotations_come_from_the_jacobian():
    run = jog_world()
    try:
        arm, jog = run.jog.cartesian.arm, run.jog.cartesian
        assert followable_rotations(arm, jog.columns, jog.lower, jog.upper) == [0]
        # Without j3 (the wrist pitch) the gripper cannot turn with its position held.
        assert followable_rotations(arm, jog.columns[:3], jog.lower[:3], jog.upper[:3]) == []
    finally:
        run.close()


def test_a_six_joint_arm_follows_every_rotation(iiwa_package):
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    from armando_drake.description.loader import load_robot

    plant, _ = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.001)
    robot = load_robot(plant, str(iiwa_package))
    plant.Finalize()
    joints = [f"iiwa_joint_{k}" for k in range(1, 8)]
    limits = [plant.GetJointByName(j) for j in joints]
    jog = CartesianJog(
        plant=plant,
        model_instance=robot.model_instance,
        end_effector="iiwa_link_7",
        joints=joints,
        lower=[j.position_lower_limits()[0] for j in limits],
        upper=[j.position_upper_limits()[0] for j in limits],
        velocity=[j.velocity_upper_limits()[0] for j in limits],
        time_step=1 / 30,
    )
    assert jog.rotations == [0, 1, 2]


@pytest.mark.parametrize("axis", range(3))
@pytest.mark.parametrize("sign", [1, -1])
def test_the_cartesian_step_goes_along_the_commanded_axis(axis, sign):
    run = jog_world()
    try:
        jog = run.jog.cartesian
        X = jog.pose(HOME)
        step = np.zeros(3)
        step[axis] = sign * 0.005
        q, reached = jog.solve(HOME, RigidTransform(X.rotation(), X.translation() + step))
        assert reached
        X_new = jog.pose(q)
        moved = X_new.translation() - X.translation()
        assert moved @ step / (np.linalg.norm(moved) * 0.005) > 0.999
        assert np.linalg.norm(moved) == pytest.approx(0.005, rel=0.1)
        # The followed rotation (about the gripper's x) is held.
        R = X.rotation().inverse().multiply(X_new.rotation()).ToAngleAxis()
        assert abs((R.axis() * R.angle())[0]) < 0.005
    finally:
        run.close()


def test_a_step_past_a_joint_limit_stops_at_the_limit():
    run = jog_world()
    try:
        jog = run.jog.cartesian
        q_start = np.array([0.0, 0.4, 0.9, 3.13])  # j3 0.01 rad under its upper limit
        X = jog.pose(q_start)
        # Turning the gripper about its x by +0.1 rad needs j3 past its limit.
        from pydrake.math import RollPitchYaw, RotationMatrix

        turn = RotationMatrix(RollPitchYaw(0.1, 0.0, 0.0))
        target = RigidTransform(X.rotation().multiply(turn), X.translation())
        q, reached = jog.solve(q_start, target)
        assert not reached
        assert np.all(q <= jog.upper + 1e-9) and np.all(q >= jog.lower - 1e-9)
        assert jog.blocking(q, target) == [3]  # j3, at its upper limit
    finally:
        run.close()


def fed(run) -> Pad:
    pad = Pad()
    run.jog.gamepad_source = pad
    return pad


def test_gamepad_joint_mode_moves_the_joint_at_its_speed_while_the_deadman_is_held():
    run = jog_world()
    pad = fed(run)
    try:
        pad.set(pressed=[MAPPING.joint_mode_button])  # to joint mode
        run.advance(0.1)
        pad.set(axes=(-1.0, 0.0, 0.0, 0.0))  # left stick left, no dead-man: nothing
        run.advance(0.5)
        np.testing.assert_allclose(run.jog.command(run.context), HOME)
        pad.set(axes=(-1.0, 0.0, 0.0, 0.0), pressed=[DEADMAN])  # j0 at +joint_speed
        run.advance(1.0)
        command = run.jog.command(run.context)
        # 0.5 rad/s for 1 s, give or take a 1/30 s tick.
        assert command[0] == pytest.approx(0.5, abs=0.5 / 30 + 1e-9)
        np.testing.assert_allclose(command[1:], HOME[1:])
        pad.set(axes=(-1.0, 0.0, 0.0, 0.0))  # dead-man released: it stops
        run.advance(0.5)
        np.testing.assert_allclose(run.jog.command(run.context), command)
        run.advance(1.5)
        assert abs(run.q()[0] - command[0]) < 0.01
        # The sliders follow the command.
        assert run.meshcat.GetSliderValue("j0") == pytest.approx(command[0], abs=0.001)
    finally:
        run.close()


def test_gamepad_command_past_a_limit_is_clamped_with_a_note_in_the_viewer():
    run = jog_world("jog: {home_positions: [2.4, 0.4, 0.9, 0.7]}")
    pad = fed(run)
    try:
        pad.set(pressed=[MAPPING.joint_mode_button])
        run.advance(0.1)
        pad.set(axes=(-1.0, 0.0, 0.0, 0.0), pressed=[DEADMAN])  # j0 towards +2.57
        run.advance(1.0)
        upper = run.world.robot().stack.hardware.joints[0].upper
        assert run.jog.command(run.context)[0] == pytest.approx(upper)
        (note,) = run.notes()
        assert note == f"note: gamepad: j0 clamped to its upper limit {upper:.3f}"
        assert run.jog.note(run.context) == note
        run.advance(1.0)
        assert abs(run.q()[0] - upper) < 0.01
        pad.set()  # let go; the note goes after note_time (5 s)
        run.advance(5.5)
        assert run.notes() == []
    finally:
        run.close()


def test_gamepad_cartesian_mode_moves_the_end_effector_along_the_stick():
    run = jog_world()
    pad = fed(run)
    try:
        run.advance(0.5)
        start = run.end_effector()
        pad.set(axes=(0.0, -1.0, 0.0, 0.0), pressed=[DEADMAN])  # left stick up: +x
        run.advance(1.0)
        pad.set()
        run.advance(1.0)
        moved = run.end_effector() - start
        assert moved[0] / np.linalg.norm(moved) > 0.95, moved
        # 0.05 m/s for 1 s
        assert np.linalg.norm(moved) == pytest.approx(0.05, rel=0.1)
    finally:
        run.close()


def test_a_cartesian_jog_stopped_by_a_joint_limit_names_the_joint():
    run = jog_world("jog: {home_positions: [0.0, 0.4, 0.9, 3.0]}")
    pad = fed(run)
    try:
        pad.set(axes=(0.0, 0.0, 1.0, 0.0), pressed=[DEADMAN])  # turn about the gripper's x
        run.advance(1.0)
        assert run.notes() == ["note: gamepad: end effector stopped, j3 at its limit"]
        assert run.jog.command(run.context)[3] == pytest.approx(
            run.world.robot().stack.hardware.joints[3].upper
        )
    finally:
        run.close()


def test_home_returns_the_arm_and_stops_when_the_deadman_is_released():
    run = jog_world()
    pad = fed(run)
    try:
        run.meshcat.SetSliderValue("j2", 0.1)
        run.advance(0.2)
        pad.set(pressed=[DEADMAN, MAPPING.home_button])
        run.advance(0.5)
        halfway = run.jog.command(run.context)
        assert 0.1 < halfway[2] < HOME[2]  # 0.5 rad/s: 0.25 rad in 0.5 s
        pad.set()  # released: homing stops
        run.advance(0.5)
        np.testing.assert_allclose(run.jog.command(run.context), halfway)
        pad.set(pressed=[DEADMAN, MAPPING.home_button])
        run.advance(0.1)
        pad.set(pressed=[DEADMAN])  # a press starts it; the dead-man keeps it going
        run.advance(2.0)
        np.testing.assert_allclose(run.jog.command(run.context), HOME)
        assert np.abs(run.q() - HOME).max() < 0.01
    finally:
        run.close()


def test_the_trajectory_controller_takes_the_jog_too():
    run = jog_world("controllers: {activate: [joint_state_broadcaster, trajectory_controller]}")
    try:
        assert run.jog.controller == "trajectory_controller"
        run.meshcat.SetSliderValue("j0", -0.5)
        run.advance(2.0)
        assert abs(run.q()[0] + 0.5) < 0.01
        status = run.world.status(run.context, "trajectory_controller")
        assert status.accepted >= 1 and status.rejected == 0
    finally:
        run.close()


@pytest.mark.parametrize(
    "override, from_override, message",
    [
        ("jog: {rate: 0}", True, "jog.rate=0.0 must be positive"),
        (
            "jog: {controller: arm}",
            True,
            "jog.controller='arm' needs an active controller that takes joint "
            "positions (Float64MultiArray or JointTrajectory) and that nothing else drives; "
            "such controllers: position_controller",
        ),
        (
            "sequencer: !PositionTargets {}",
            False,  # the jog block at fault is the file's
            "jog needs an active controller that takes joint positions "
            "(Float64MultiArray or JointTrajectory) and that nothing else drives; such "
            "controllers: none",
        ),
        (
            "{sequencer: !PositionTargets {}, jog: {controller: position_controller}}",
            True,
            "jog.controller='position_controller': position_controller already "
            "takes its commands from the scenario's sequencer or task",
        ),
        (
            "jog: {home_positions: [0, 0]}",
            True,
            "jog.home_positions=[0.0, 0.0] must have 4 values (j0, j1, j2, j3)",
        ),
        ("jog: {end_effector: hand}", True, "jog: frame 'hand' is not in the plant"),
        (
            "jog: {gamepad_mapping: {joint_signs: [1, 1]}}",
            True,
            "jog.gamepad_mapping.joint_signs=[1.0, 1.0] must have one sign per "
            "entry of joint_axes=[0, 1, 3, 2]",
        ),
    ],
)
def test_a_bad_jog_block_is_one_line_naming_it(override, from_override, message):
    """The message names where the bad value came from: the override, or jog.yaml."""
    with pytest.raises(ScenarioError) as error:
        jog_world(override)
    source = f"--set {override!r}" if from_override else "jog.yaml"
    assert str(error.value).startswith(f"{source}: {message}")


def test_world_cli_runs_the_jog_scenario():
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--scenario", "jog", "--no-meshcat"]
        + ["--duration", "0.3"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    output = result.stdout + result.stderr
    assert "jog: no Meshcat to read" in output
    assert (
        "jog.yaml with no viewer to jog from (the arm held its home posture): 0.30 s simulated"
        in output
    )


def test_the_jog_commands_are_recorded_on_the_controller_topic(tmp_path):
    from rosbags.highlevel import AnyReader

    bag = tmp_path / "jog.mcap"
    scenario = load_scenario("jog", "logging: {console_rate: 0}")
    scenario.simulator_config.target_realtime_rate = 0
    meshcat = Meshcat()
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True, record=bag)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.2)
    meshcat.SetSliderValue("j3", -0.25)
    simulator.AdvanceTo(0.5)
    world.close(simulator.get_context())
    with AnyReader([bag]) as reader:
        messages = [
            reader.deserialize(raw, connection.msgtype)
            for connection, _, raw in reader.messages()
            if connection.topic == "/position_controller/commands"
        ]
    assert messages, "no /position_controller/commands in the bag"
    np.testing.assert_allclose(messages[-1].data, [0.0, 0.4, 0.9, -0.25])
