"""The course's KUKA iiwa with ``hardware_interface:=EffortJointInterface``: every joint
torque-controlled, driven by ROS 1 effort controllers (iiwa_stack's layout)."""

import json
import subprocess
import sys

import numpy as np
from pydrake.systems.analysis import Simulator

from armando_drake.control.sequencer import seed_targets_for
from armando_drake.messages.types import Float64, Float64MultiArray
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

JOINTS = [f"iiwa_joint_{k}" for k in range(1, 8)]
PIDS = [f"EffortJointInterface_J{k}_controller" for k in range(1, 8)]
# [N m/rad, N m/(rad s), N m s/rad, N m] p, i, d, i_clamp per joint, tuned here: about
# 25-150 rad/s for each joint's inertia (from ~3 kg m^2 at joint 2 down to ~0.002 kg m^2
# at joint 7, where d dt / I must stay well below 1 at the 1 kHz loop), an integral
# time p / i of 0.5 s against gravity, the integral bounded by i_clamp (antiwindup).
GAINS = [
    (1500, 3000, 50, 300),
    (2000, 4000, 60, 300),
    (300, 600, 15, 100),
    (800, 1600, 30, 200),
    (80, 160, 4, 50),
    (50, 100, 3, 50),
    (50, 100, 0.8, 5),
]


def ros1_controllers() -> str:
    """iiwa_stack's ROS 1 layout: a PID position controller per joint on effort, and a
    group effort controller."""
    lines = [
        "iiwa:",
        "  joint_state_controller:",
        "    type: joint_state_controller/JointStateController",
        "    publish_rate: 50",
        "  effort_group:",
        "    type: effort_controllers/JointGroupEffortController",
        f"    joints: [{', '.join(JOINTS)}]",
    ]
    lines += [
        "  EffortJointInterface_trajectory_controller:",
        "    type: effort_controllers/JointTrajectoryController",
        f"    joints: [{', '.join(JOINTS)}]",
        "    constraints: {goal_time: 0.5, stopped_velocity_tolerance: 0.05}",
        "    state_publish_rate: 25",
        "    gains:",
    ]
    for joint, (p, i, d, clamp) in zip(JOINTS, GAINS, strict=True):
        lines.append(
            f"      {joint}: {{p: {p}, i: {i}, d: {d}, i_clamp: {clamp}, antiwindup: true}}"
        )
    for name, joint, (p, i, d, clamp) in zip(PIDS, JOINTS, GAINS, strict=True):
        lines += [
            f"  {name}:",
            "    type: effort_controllers/JointPositionController",
            f"    joint: {joint}",
            f"    pid: {{p: {p}, i: {i}, d: {d}, i_clamp: {clamp}, antiwindup: true}}",
        ]
    return "\n".join(lines) + "\n"


def iiwa_world(iiwa_package, tmp_path, activate: list[str], extra: str = ""):
    controllers = tmp_path / "iiwa_control.yaml"
    controllers.write_text(ros1_controllers())
    scenario = load_scenario(
        "position",
        f"robot: {{description: {iiwa_package}, base_xyz: [0, 0, 0], "
        "xacro_args: {hardware_interface: EffortJointInterface}}\n"
        "sequencer: null\nlogging: {console_rate: 0}\n"
        f"controllers: {{config: {controllers}, activate: [{', '.join(activate)}]}}\n" + extra,
    )
    return MakeWorld(scenario, quiet=True)


def test_every_iiwa_joint_takes_torques_that_reach_the_plant_exactly(iiwa_package, tmp_path):
    # The torques pass unchanged only while no joint is at its velocity limit, which
    # these reach within the 50 ms (with the cap, iiwa_joint_1's 40 N m is taken down to
    # 18.9 N m): this test is about the pass-through, so it lifts the cap.
    world = iiwa_world(
        iiwa_package,
        tmp_path,
        ["joint_state_controller", "effort_group"],
        "actuators: {velocity_limits: false}\n",
    )
    assert world.robot().stack.hardware.source == "transmission"
    assert world.robot().stack.hardware.joint_names == JOINTS
    assert world.robot().stack.hardware.interfaces() == ["effort"] * 7
    plant, instance = world.plant, world.robot().robot.model_instance
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(instance)]
    assert [a.has_controller() for a in actuators] == [False] * 7  # no PD: torque only
    assert [a.effort_limit() for a in actuators] == [300.0] * 7  # the URDF's max_effort
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    torques = (40.0, -30.0, 20.0, -10.0, 5.0, -2.5, 1.25)  # [N m]
    world.publish(context, "effort_group", Float64MultiArray(data=torques))
    simulator.AdvanceTo(0.05)
    plant_context = plant.GetMyContextFromRoot(context)
    # No gravity feed-forward on effort joints: the command is the actuation, bit for bit.
    assert plant.get_actuation_input_port(instance).Eval(plant_context).tolist() == list(torques)
    assert plant.get_net_actuation_output_port(instance).Eval(plant_context).tolist() == list(
        torques
    )
    assert world.diagram.GetOutputPort("joint_states").Eval(context).effort == torques
    world.close()


def test_iiwa_pid_effort_controllers_reach_seed_style_targets(iiwa_package, tmp_path):
    world = iiwa_world(iiwa_package, tmp_path, ["joint_state_controller", *PIDS])
    assert world.robot().stack.update_rate == 1000  # a ROS 1 file: gazebo_ros_control's 1 ms loop
    hardware = world.robot().stack.hardware
    targets = seed_targets_for(
        [j.lower for j in hardware.joints], [j.upper for j in hardware.joints]
    )
    assert targets[1] == [1.2, -1.0, 1.2, 0.6, 1.2, -1.0, 1.2]  # room enough: the seed
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    errors = []
    for k, target in enumerate(targets[1:4]):  # out, back, a mixed pose: 3 s each
        for name, value in zip(PIDS, target, strict=True):
            world.publish(context, name, Float64(value))
        simulator.AdvanceTo(3.0 * (k + 1))
        errors.append(np.abs(world.joint_positions(context) - target).max())
    assert max(errors) <= 0.01, errors
    assert [world.status(context, name).accepted for name in PIDS] == [3] * 7
    world.close()


def test_iiwa_effort_trajectory_controller_runs_the_seed_from_the_command_line(
    iiwa_package, tmp_path
):
    # iiwa_stack's ROS 1 trajectory controller on effort, chosen by --controller trajectory.
    controllers = tmp_path / "iiwa_control.yaml"
    controllers.write_text(ros1_controllers())
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--description", str(iiwa_package),
         "--controller", "trajectory", "--no-meshcat", "--realtime-rate", "0", "--quiet",
         "--no-replay", "--output", str(out),
         "--set", "robot: {xacro_args: {hardware_interface: EffortJointInterface}}",
         "--set", f"controllers: {{config: {controllers}}}"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["joint_names"] == JOINTS
    targets = [step["target"] for step in summary["steps"]]
    assert targets[1] == [1.2, -1.0, 1.2, 0.6, 1.2, -1.0, 1.2]  # the seed, sized to 7 joints
    errors = [
        max(abs(r - t) for r, t in zip(step["reached"], step["target"], strict=True))
        for step in summary["steps"]
    ]
    assert len(errors) == 5 and max(errors) <= 0.01, errors
