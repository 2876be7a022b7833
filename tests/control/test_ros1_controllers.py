"""ROS 1 (ros_control) controller YAML: the same controllers and interfaces as ROS 2,
the effort PID position controller, and types that fail only when activated."""

import json
import logging
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from conftest import make_mini_package
from pydrake.systems.analysis import Simulator

from armando_drake.control.config import (
    ROS1_UPDATE_RATE,
    ControllerConfigError,
    load_controller_config,
)
from armando_drake.control.controllers import ControllerJoints, load_parameters, lookup
from armando_drake.control.controllers.broadcaster import JointStateBroadcaster
from armando_drake.control.controllers.forward_command import JointGroupPositionController
from armando_drake.control.controllers.joint_trajectory import JointTrajectoryController
from armando_drake.control.controllers.ros1 import JointPositionPidController
from armando_drake.control.sequencer import SEED_TARGETS, seed_targets_for, seed_wave_for
from armando_drake.messages.types import Float64, Float64MultiArray, JointTrajectory
from armando_drake.outputs.logger import read_joint_states
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario

# The course's first-year layout: one namespace, one entry per controller, its
# parameters beside its type; gazebo_ros_control's gains in the same file.
ARMANDO_ROS1 = """\
armando:
  joint_state_controller:
    type: joint_state_controller/JointStateController
    publish_rate: 50
  j0_position_controller:
    type: position_controllers/JointPositionController
    joint: j0
  j1_effort_controller:
    type: effort_controllers/JointPositionController
    joint: j1
    pid: {p: 100.0, i: 0.01, d: 10.0}
  arm_controller:
    type: position_controllers/JointGroupPositionController
    joints: [j0, j1, j2, j3]
  trajectory_controller:
    type: position_controllers/JointTrajectoryController
    joints: [j0, j1, j2, j3]
    constraints:
      goal_time: 0.6
      stopped_velocity_tolerance: 0.05
      j0: {trajectory: 0.5, goal: 0.02}
    state_publish_rate: 25
  gripper_controller:
    type: position_controllers/GripperActionController
    joint: gripper
gazebo_ros_control:
  pid_gains:
    j0: {p: 100.0, i: 0.01, d: 10.0}
"""


def write(tmp_path, text: str, name: str = "armando_ros1.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_ros1_file_maps_onto_the_ros2_controllers_and_interfaces(tmp_path, caplog):
    path = write(tmp_path, ARMANDO_ROS1)
    with caplog.at_level(logging.WARNING, logger="armando_drake.control.config"):
        config = load_controller_config(path)
    assert config.ros == 1 and config.update_rate == ROS1_UPDATE_RATE == 1000
    c = config.controllers
    assert list(c) == [
        "joint_state_controller",
        "j0_position_controller",
        "j1_effort_controller",
        "arm_controller",
        "trajectory_controller",
        "gripper_controller",
    ]
    # name: (ROS 2 counterpart, interface, message, joints, topic)
    expected = {
        "joint_state_controller": (JointStateBroadcaster, None, None, [], None),
        "j0_position_controller": (
            JointGroupPositionController, "position", Float64, ["j0"],
            "/armando/j0_position_controller/command",
        ),
        "j1_effort_controller": (
            JointPositionPidController, "effort", Float64, ["j1"],
            "/armando/j1_effort_controller/command",
        ),
        "arm_controller": (
            JointGroupPositionController, "position", Float64MultiArray, ["j0", "j1", "j2", "j3"],
            "/armando/arm_controller/command",
        ),
        "trajectory_controller": (
            JointTrajectoryController, "position", JointTrajectory, ["j0", "j1", "j2", "j3"],
            "/armando/trajectory_controller/command",
        ),
    }  # fmt: skip
    for name, (base, interface, message, joints, topic) in expected.items():
        entry = c[name]
        assert issubclass(entry.controller_class, base), name
        assert entry.controller_class.ros == 1
        assert (entry.interface_name, entry.joints, entry.ros_topic) == (interface, joints, topic)
        if message is not None:
            assert entry.controller_class.message is message
    assert c["joint_state_controller"].params.publish_rate == 50.0
    pid = c["j1_effort_controller"].params.pid
    assert (pid.p, pid.i, pid.d, pid.i_min, pid.i_max) == (100.0, 0.01, 10.0, 0.0, 0.0)
    trajectory = c["trajectory_controller"].params
    assert trajectory.goal_time == 0.6 and trajectory.stopped_velocity_tolerance == 0.05
    assert trajectory.goal_tolerance == {"j0": 0.02}
    assert trajectory.trajectory_tolerance == {"j0": 0.5}
    assert trajectory.command_interfaces == ["position"]
    assert trajectory.allow_nonzero_velocity_at_trajectory_end  # ROS 1 does not check it
    # The gripper's type is not simulated: one warning, and the file loads.
    assert not c["gripper_controller"].supported
    messages = [r.getMessage() for r in caplog.records]
    assert (
        f"{path}: armando/gripper_controller.type: controller type "
        "'position_controllers/GripperActionController' is not supported; "
        "'gripper_controller' fails if activated"
    ) in messages
    # The others: ROS 1 parameters the simulation does not need, each named once.
    others = [m for m in messages if "gripper_controller" not in m]
    assert others and all("not simulated: ignored" in m for m in others), others
    assert config.pid_gains == {"j0": (100.0, 0.01, 10.0)}  # gazebo_ros_control's
    # The same type string means the ROS 2 controller in a ROS 2 file.
    assert lookup("position_controllers/JointGroupPositionController").topic == "commands"


def actuator_gains(world) -> dict[str, tuple[float, float]]:
    plant = world.plant
    result = {}
    for index in plant.GetJointActuatorIndices(world.robot().robot.model_instance):
        actuator = plant.get_joint_actuator(index)
        gains = actuator.get_controller_gains()
        result[actuator.joint().name()] = (gains.p, gains.d)
    return result


@pytest.mark.parametrize(
    "override, j0",
    [("", (100.0, 10.0)), ("actuators: {gains: {j0: [20.0, 1.0]}}", (20.0, 1.0))],
    ids=["from-the-yaml", "scenario-wins"],
)
def test_gazebo_ros_control_pid_gains_are_the_position_actuator_gains(tmp_path, override, j0):
    path = write(tmp_path, ARMANDO_ROS1)
    scenario = load_scenario(
        "position",
        "sequencer: null\nlogging: {console_rate: 0}\n"
        f"controllers: {{config: {path}, activate: [joint_state_controller]}}\n" + override,
    )
    world = MakeWorld(scenario, quiet=True)
    # p and d of pid_gains/j0; the other joints keep the scenario's kp 8, kd 0.4.
    assert actuator_gains(world) == {
        "j0": j0, "j1": (8.0, 0.4), "j2": (8.0, 0.4), "j3": (8.0, 0.4),
    }  # fmt: skip
    world.close()


@pytest.mark.parametrize(
    "controller, key, message",
    [
        (
            "js:\n  type: joint_state_controller/JointStateController\n",
            "js.publish_rate",
            "Parameter 'publish_rate' not set",
        ),
        (
            "js:\n  type: joint_state_controller/JointStateController\n  publish_rate: 0\n",
            "js.publish_rate",
            "publish_rate=0.0 must be positive [Hz]",
        ),
        (
            "pid:\n  type: effort_controllers/JointPositionController\n  joint: j1\n"
            "  pid: {i: 1.0}\n",
            "pid.pid.p",
            "No p gain specified for pid",
        ),
        (
            "pid:\n  type: effort_controllers/JointPositionController\n  pid: {p: 1.0}\n",
            "pid.joint",
            "No joint given; expected a joint name",
        ),
        (
            "pid:\n  type: effort_controllers/JointPositionController\n  joint: j1\n"
            "  pid: {p: .inf}\n",
            "pid.pid.p",
            "pid.p=inf is not a finite number",
        ),
        (
            "traj:\n  type: effort_controllers/JointTrajectoryController\n  joints: [j0, j1]\n"
            "  gains: {j0: {p: 100.0, d: 1.0}}\n",
            "traj.gains.j1.p",
            "No p gain specified for pid",
        ),
        (
            "js: {type: joint_state_controller/JointStateController, publish_rate: 50}\n"
            "gazebo_ros_control:\n  pid_gains:\n    j0: {i: 1.0}\n",
            "gazebo_ros_control/pid_gains/j0.p",
            "No p gain specified for pid",
        ),
    ],
    ids=["publish-rate-missing", "publish-rate-zero", "p-missing", "joint-missing",
         "p-not-finite", "trajectory-gains-missing",
         "gazebo-p-missing"],
)  # fmt: skip
def test_bad_ros1_parameters_name_file_and_key(tmp_path, controller, key, message):
    path = write(tmp_path, controller)
    with pytest.raises(ControllerConfigError) as error:
        load_controller_config(path)
    assert str(error.value) == f"{path}: {key}: {message}"


def pid_controller(raw: dict, effort_limit: float = 1e4) -> JointPositionPidController:
    params = load_parameters(JointPositionPidController, {"joint": "j", **raw})
    joints = ControllerJoints.make(["j"], lower=[-1.0], upper=[1.0], effort=[effort_limit])
    controller = JointPositionPidController(name="pid", joints=joints, params=params)
    controller.configure(update_rate=1000)  # the 1 ms steps below
    return controller


def measured(q: float):
    return lambda desired: (np.array([q]), np.array([0.0]))


def test_pid_computes_control_toolbox_numbers():
    p, i, d = 100.0, 1000.0, 10.0
    pid = pid_controller({"pid": {"p": p, "i": i, "d": d, "i_clamp": 5.0}})
    memory = pid.initial_memory()
    assert memory.busy  # it runs at every update, command or not
    # First update: the target is the measured position (upstream's starting()): no effort.
    memory = pid.update(0.0, None, memory, measured(0.2))
    assert memory.effort.tolist() == [0.0]
    # A step to 0.5 measured at 0.2: p e + i (e dt) + d (e - 0) / dt, dt = 1 ms.
    memory = pid.update(0.001, Float64(0.5), memory, measured(0.2))
    e1 = 0.3
    assert memory.effort[0] == pytest.approx(p * e1 + i * e1 * 0.001 + d * e1 / 0.001)  # 3030.3
    memory = pid.update(0.002, None, memory, measured(0.25))
    e2 = 0.25
    integral = (e1 + e2) * 0.001
    assert memory.effort[0] == pytest.approx(p * e2 + i * integral + d * (e2 - e1) / 0.001)
    # The integral term stays within i_clamp [N m].
    for k in range(3, 30):
        memory = pid.update(k * 0.001, None, memory, measured(0.25))
    assert memory.effort[0] == pytest.approx(p * e2 + 5.0)
    assert memory.status.accepted == 1


def test_pid_without_i_clamp_has_no_integral_action_as_upstream():
    pid = pid_controller({"pid": {"p": 2.0, "i": 50.0}})
    memory = pid.update(0.0, Float64(0.1), pid.initial_memory(), measured(0.0))
    for k in range(1, 100):
        memory = pid.update(k * 0.001, None, memory, measured(0.0))
    assert memory.effort[0] == pytest.approx(2.0 * 0.1)  # p e only: i_clamp defaults to 0


def test_pid_clamps_target_and_effort_and_drops_non_finite_commands():
    pid = pid_controller({"pid": {"p": 100.0}}, effort_limit=30.0)
    memory = pid.update(0.0, Float64(2.0), pid.initial_memory(), measured(0.0))
    assert memory.internal.target == 1.0  # the upper limit
    assert memory.status.detail["warning"] == (
        "command 2.0 for joint 'j' is outside its limits [-1.0, 1.0]; clamped to 1.0"
    )
    assert memory.effort.tolist() == [30.0]  # 100 N m/rad x 1 rad, at the 30 N m limit
    memory = pid.update(0.001, Float64(float("nan")), memory, measured(0.0))
    assert memory.status.rejected == 1 and memory.internal.target == 1.0
    assert memory.status.last_error == "Non-finite value received. Dropping message"


# A single arm spinning about a vertical axis (no gravity torque), on the effort interface.
SPIN_INERTIA = 0.002  # [kg m^2]
SPINNER = f"""<?xml version="1.0"?>
<robot name="spinner">
  <link name="base"/>
  <link name="arm">
    <inertial>
      <mass value="0.5"/>
      <inertia ixx="0.0002" iyy="0.0019" izz="{SPIN_INERTIA}" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <visual><geometry><box size="0.2 0.05 0.02"/></geometry></visual>
  </link>
  <joint name="spin" type="continuous">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
    <limit effort="0.5" velocity="20"/>
  </joint>
  <transmission name="spin_transmission">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="spin">
      <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>
    </joint>
    <actuator name="spin_motor"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
</robot>
"""
SPINNER_ROS1 = """\
spinner:
  joint_state_controller:
    type: joint_state_controller/JointStateController
    publish_rate: 50
  spin_controller:
    type: effort_controllers/JointPositionController
    joint: spin
    pid: {p: 2.0, i: 20.0, d: 0.1, i_clamp: 0.05, antiwindup: true}
"""


def test_effort_pid_tracks_a_step_within_a_hundredth_of_a_radian(tmp_path):
    urdf = tmp_path / "spinner.urdf"
    urdf.write_text(SPINNER)
    controllers = write(tmp_path, SPINNER_ROS1, "spinner_controllers.yaml")
    scenario = load_scenario(
        "position",
        f"robot: {{description: {urdf}, base_xyz: [0, 0, 0]}}\nsequencer: null\n"
        "logging: {console_rate: 0}\n"
        f"controllers: {{config: {controllers}, activate: "
        "[joint_state_controller, spin_controller]}\n",
    )
    world = MakeWorld(scenario, quiet=True)
    assert (
        world.robot().stack.update_rate == 1000
        and world.robot().stack.hardware.interfaces() == ["effort"]
    )
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    plant_context = world.plant.GetMyContextFromRoot(context)
    simulator.AdvanceTo(0.5)  # held where it started
    assert world.joint_positions(context)[0] == pytest.approx(0.0, abs=1e-9)
    step = 1.0  # [rad]
    world.publish(context, "spin_controller", Float64(step))
    simulator.AdvanceTo(0.502)
    # The derivative kick saturates the 0.5 N m effort limit, as Gazebo's limit would.
    net = world.plant.get_net_actuation_output_port(world.robot().robot.model_instance)
    assert net.Eval(plant_context)[0] == pytest.approx(0.5)
    errors = []
    for t in np.arange(1.5, 3.0, 0.05):  # from 1 s after the step
        simulator.AdvanceTo(t)
        errors.append(abs(world.joint_positions(context)[0] - step))
    assert max(errors) <= 0.01, max(errors)
    assert world.status(context, "spin_controller").accepted == 1
    world.close()


def run_world(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--realtime-rate", "0",
         "--quiet", "--no-replay", *args],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def step_errors(summary: dict) -> list[float]:
    return [
        max(abs(r - t) for r, t in zip(step["reached"], step["target"], strict=True))
        for step in summary["steps"]
    ]


@pytest.mark.parametrize("controller", ["position", "trajectory"])
def test_armando_with_a_ros1_file_reaches_the_seed_targets(tmp_path, controller):
    path = write(tmp_path, ARMANDO_ROS1)
    out = tmp_path / "out"
    result = run_world(
        "--controller", controller, "--output", str(out),
        "--set", f"controllers: {{config: {path}}}",
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert [step["target"] for step in summary["steps"]] == [list(t) for t in SEED_TARGETS]
    assert max(step_errors(summary)) <= 0.01, step_errors(summary)
    # joint_state_controller's publish_rate: 50 Hz rows, the controllers at 1000 Hz.
    rows = (out / "joint_states.csv").read_text().splitlines()[1:]
    times = [float(row.split(",")[0]) for row in rows]
    assert np.diff(times) == pytest.approx(np.full(len(times) - 1, 0.02))


GRIPPER_ROS2 = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    position_controller: {type: position_controllers/JointGroupPositionController}
    gripper_controller: {type: position_controllers/GripperActionController}
position_controller:
  ros__parameters:
    joints: [q1, q2]
gripper_controller:
  ros__parameters:
    joint: q2
    goal_tolerance: 0.01
"""


def test_an_unsupported_type_in_the_package_config_fails_only_when_activated(tmp_path):
    package = make_mini_package(tmp_path)
    (package / "config").mkdir()
    config = package / "config" / "mini_controllers.yaml"  # found by the package search
    config.write_text(GRIPPER_ROS2)
    key = "controller_manager.ros__parameters.gripper_controller.type"
    result = run_world("--description", str(package), "--controller", "none",
                       "--duration", "0.5")  # fmt: skip
    assert result.returncode == 0, result.stderr
    warning = (
        f"{config}: {key}: controller type 'position_controllers/GripperActionController' "
        "is not supported; 'gripper_controller' fails if activated"
    )
    assert result.stdout.count(warning) == 1, result.stdout
    result = run_world("--description", str(package), "--controller", "position")
    assert result.returncode == 0, result.stderr
    result = run_world(
        "--description", str(package), "--duration", "0.5", "--set", "sequencer: null",
        "--set", "controllers: {activate: [joint_state_broadcaster, gripper_controller]}",
    )  # fmt: skip
    assert result.returncode != 0
    (line,) = result.stderr.strip().splitlines()
    assert line.endswith(
        f"controllers.activate: 'gripper_controller': {config}: {key}: unknown controller "
        "type 'position_controllers/GripperActionController'; supported: "
        "joint_state_broadcaster/JointStateBroadcaster, "
        "diff_drive_controller/DiffDriveController, "
        "forward_command_controller/ForwardCommandController, "
        "position_controllers/JointGroupPositionController, "
        "velocity_controllers/JointGroupVelocityController, "
        "effort_controllers/JointGroupEffortController, "
        "joint_trajectory_controller/JointTrajectoryController, "
        "vision_controllers/LookAtPointController, "
        "vision_controllers/ImprovedLookAtPointController, "
        "task_space_controllers/JointSpaceInverseDynamics, "
        "task_space_controllers/OperationalSpaceInverseDynamics, "
        "vision_controllers/JointSpaceLookAtController, "
        "vision_controllers/OperationalSpaceLookAtController, "
        "forward_command_controller/MultiInterfaceForwardCommandController, "
        "pid_controller/PidController"
    ), line


def test_activating_an_unsupported_ros1_controller_names_file_key_and_type(tmp_path):
    path = write(tmp_path, ARMANDO_ROS1)
    override = (
        "sequencer: null\nlogging: {console_rate: 0}\n"
        f"controllers: {{config: {path}, activate: [gripper_controller]}}"
    )
    scenario = load_scenario("position", override)
    with pytest.raises(ScenarioError) as error:
        MakeWorld(scenario, quiet=True, source="position.yaml")
    assert str(error.value).startswith(  # the override that activated it, the YAML's file
        f"override {override!r}: controllers.activate: 'gripper_controller': {path}: "
        "armando/gripper_controller.type: unknown controller type "
        "'position_controllers/GripperActionController'; supported: "
        "joint_state_controller/JointStateController, "
    )


def test_seed_targets_sized_to_the_joint_limits():
    armando = seed_targets_for([-2.57, -3.14, -3.14, -3.14], [2.57, 3.14, 3.14, 3.14])
    assert armando == [list(t) for t in SEED_TARGETS]  # room enough: the seed itself
    # A 7-joint arm with room: columns 0 1 2 3 0 1 2.
    seven = seed_targets_for([-2.9] * 7, [2.9] * 7)
    assert seven[1] == [1.2, -1.0, 1.2, 0.6, 1.2, -1.0, 1.2]
    # A joint with 0.05 of room above home and none below; one whose range excludes 0.
    short = seed_targets_for([0.0, 0.5], [0.05, 1.5])
    assert [t[0] for t in short] == pytest.approx([0.0, 0.04, 0.0, 0.02, 0.0])
    assert [t[1] for t in short] == pytest.approx([0.5, 0.5, 0.5 + 0.8 / 1.2, 0.5, 0.5])


# A third, prismatic joint of 5 cm on the mini robot's tip.
SLIDER = """\
<joint name="slide" type="prismatic">
  <parent link="tip"/><child link="slider"/><axis xyz="1 0 0"/>
  <limit lower="0" upper="0.05" effort="20" velocity="1"/>
</joint>
<link name="slider">
  <inertial>
    <mass value="0.05"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/>
  </inertial>
  <visual><geometry><box size="0.02 0.02 0.02"/></geometry></visual>
</link>
"""


@pytest.mark.parametrize("controller", ["position", "trajectory"])
def test_controller_flag_on_another_robot_sizes_the_seed_targets(tmp_path, controller):
    package = make_mini_package(tmp_path, textwrap.dedent(SLIDER))
    out = tmp_path / "out"
    result = run_world("--description", str(package), "--controller", controller,
                       "--output", str(out))  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["joint_names"] == ["q1", "q2", "slide"]
    targets = [step["target"] for step in summary["steps"]]
    # q1 [-2, 2] and q2 [-2.5, 2.5] take the seed's j0 and j1 columns as they are; the
    # 5 cm slide its j2 column within 80 % of its range above home (none below).
    assert np.array(targets) == pytest.approx(
        np.array([[0, 0, 0], [1.2, -1.0, 0.04], [-1.2, 1.0, 0], [0.6, 0, 0], [0, 0, 0]])
    )
    assert max(step_errors(summary)) <= 0.01, step_errors(summary)


SPINNER_TRAJECTORY_ROS1 = """\
spinner:
  joint_state_controller:
    type: joint_state_controller/JointStateController
    publish_rate: 100
  spin_trajectory_controller:
    type: effort_controllers/JointTrajectoryController
    joints: [spin]
    gains:
      spin: {p: 2.0, i: 20.0, d: 0.1, i_clamp: 0.05, antiwindup: true}
"""


def test_effort_trajectory_controller_follows_the_seed_through_its_pid(tmp_path):
    urdf = tmp_path / "spinner.urdf"
    urdf.write_text(SPINNER)
    controllers = write(tmp_path, SPINNER_TRAJECTORY_ROS1, "spinner_controllers.yaml")
    out = tmp_path / "out"
    result = run_world(
        "--description", str(urdf), "--controller", "trajectory", "--output", str(out),
        "--set", f"controllers: {{config: {controllers}}}",
        "--set", "robot: {base_xyz: [0, 0, 0]}",
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((out / "summary.json").read_text())
    # The continuous joint takes the seed's j0 column as it is.
    assert [step["target"] for step in summary["steps"]] == [[t[0]] for t in SEED_TARGETS]
    # At the moment each point is due, through the PID: within 0.01 rad.
    assert max(step_errors(summary)) <= 0.01, step_errors(summary)
    rows = (out / "joint_states.csv").read_text().splitlines()
    effort = np.array([float(row.split(",")[3]) for row in rows[1:]])  # [N m]
    # The PID's torques move the light arm (I = 0.002 kg m^2): a few mN m, within the limit.
    assert 1e-3 < np.abs(effort).max() <= 0.5


def test_sinusoid_flag_on_another_robot_sizes_the_seed_wave(tmp_path):
    package = make_mini_package(tmp_path, textwrap.dedent(SLIDER))
    out = tmp_path / "out"
    result = run_world("--description", str(package), "--controller", "sinusoid",
                       "--duration", "5", "--output", str(out))  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    amplitude, phase, offset = seed_wave_for([-2.0, -2.5, 0.0], [2.0, 2.5, 0.05])
    # pi/2 where the range allows (q1, q2, about home); the 5 cm slide swings 2 cm about
    # 2.5 cm, 5 mm from either limit; phases: the seed's j0 j1 j2.
    assert amplitude == pytest.approx([np.pi / 2, np.pi / 2, 0.02])
    assert offset == pytest.approx([0.0, 0.0, 0.025])
    assert phase == [0.0, 0.0, np.pi]
    states = read_joint_states(out / "joint_states.csv", ["q1", "q2", "slide"])
    times, q = states.times, states.position
    late = times >= 1.0
    wave = np.array(offset) + np.array(amplitude) * np.sin(
        2 * np.pi * 0.05 * times[late, None] + np.array(phase)
    )
    # Within the position PD's lag (Armando's own sinusoid tracks within about 0.03 rad).
    error = np.abs(q[late] - wave).max(axis=0)
    assert error[0] <= 0.05 and error[1] <= 0.05 and error[2] <= 0.005, error


def test_ros1_parameters_a_controller_does_not_read_are_ignored(tmp_path, caplog):
    path = write(
        tmp_path,
        "traj:\n  type: effort_controllers/JointTrajectoryController\n  joints: [j0]\n"
        "  command_interfaces: [position]\n  gains: {j0: {p: 1.0}, j9: {p: 1.0}}\n",
    )
    with caplog.at_level(logging.WARNING, logger="armando_drake.control.config"):
        config = load_controller_config(path)
    assert config.controllers["traj"].params.gains["j0"].p == 1.0
    assert [r.getMessage() for r in caplog.records] == [
        f"{path}: traj.{name}: effort_controllers/JointTrajectoryController (ROS 1) does not "
        "declare it; ignored, as ROS ignores it"
        for name in ("command_interfaces", "gains.j9")
    ]
