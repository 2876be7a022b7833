"""Descriptions other than our own: the course's STL package, the course's KUKA iiwa (world
link, ROS 1 transmissions) and a xacro arm with a gripper."""

import json
import logging
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from conftest import make_mini_package

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario


def run(module: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=300
    )


def test_display_loads_the_course_package(course_package):
    result = run("armando_drake.display", "--description", str(course_package), "--loop-once")
    assert result.returncode == 0, result.stderr
    assert "Joints: j0 [-2.57, 2.57], j1 [-3.14, 3.14], j2 [-3.14, 3.14], j3 [-3.14, 3.14]" in (
        result.stdout
    )


def test_world_drives_the_course_package_to_the_seed_targets(course_package, tmp_path):
    # The package's placeholder velocity limits (0.1 rad/s) would keep the arm from the
    # targets (see the test below): this one is about the import, so it lifts the cap.
    result = run(
        "armando_drake.world",
        "--no-meshcat",
        "--realtime-rate",
        "0",
        "--description",
        str(course_package),
        "--set",
        "actuators: {velocity_limits: false}",
        "--output",
        str(tmp_path),
        "--quiet",
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert len(summary["steps"]) == 5
    assert max(step["final_error"] for step in summary["steps"]) <= 0.01
    # The importer said what it repaired.
    assert "link 'base_link': inertia" in result.stderr + result.stdout


def test_the_course_packages_velocity_limits_are_said_to_make_its_targets_late(
    course_package, caplog
):
    scenario = load_scenario(
        "position",
        f"robot: {{description: {course_package}}}\nlogging: {{console_rate: 0}}",
    )
    with caplog.at_level(logging.WARNING, logger="armando_drake.world"):
        MakeWorld(scenario, quiet=True).close()
    lines = [r.getMessage() for r in caplog.records if "velocity limit" in r.getMessage()]
    assert len(lines) == 1, lines
    # j0 from 1.2 to -1.2 rad at 0.1 rad/s: 24 s against the seed's 3 s.
    expected = "joint j0 (velocity limit 0.1 rad/s) needs 24 s to move 2.4 rad to target 2"
    assert expected in lines[0]
    assert "3 s are given" in lines[0]


GRIPPER = """
<link name="finger">
  <visual><geometry><box size="0.01 0.02 0.04"/></geometry></visual>
  <collision><geometry><box size="0.01 0.02 0.04"/></geometry></collision>
  <inertial><mass value="0.02"/>
    <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>
</link>
<joint name="finger_joint" type="prismatic">
  <parent link="lower"/><child link="finger"/><origin xyz="0 0 0.12"/><axis xyz="1 0 0"/>
  <limit lower="0" upper="0.03" effort="20" velocity="0.1"/>
</joint>
<xacro:include filename="$(find mini_description)/urdf/mini.ros2_control.xacro"/>
<xacro:mini_ros2_control name="MiniArm" initial_q1="$(arg initial_q1)"/>
"""

ROS2_CONTROL_MACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="mini_ros2_control" params="name initial_q1">
    <ros2_control name="${name}" type="system">
      <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
      <xacro:macro name="joint_interfaces" params="joint initial">
        <joint name="${joint}">
          <command_interface name="position"/>
          <state_interface name="position"><param name="initial_value">${initial}</param>
          </state_interface>
          <state_interface name="velocity"/>
        </joint>
      </xacro:macro>
      <xacro:joint_interfaces joint="q1" initial="${initial_q1}"/>
      <xacro:joint_interfaces joint="q2" initial="0.0"/>
      <xacro:joint_interfaces joint="finger_joint" initial="0.0"/>
    </ros2_control>
  </xacro:macro>
</robot>
"""

CONTROLLERS = """
/**:
  controller_manager:
    ros__parameters:
      update_rate: 200
      joint_state_broadcaster:
        type: joint_state_broadcaster/JointStateBroadcaster
      arm_controller:
        type: forward_command_controller/ForwardCommandController
/**/arm_controller:
  ros__parameters:
    joints: [q1, q2, finger_joint]
    interface_name: position
"""


def test_xacro_arm_with_gripper_ros2_control_macro_and_namespaced_yaml(tmp_path):
    package = make_mini_package(tmp_path, GRIPPER)
    top = package / "urdf" / "mini.urdf.xacro"
    top.write_text(
        top.read_text().replace(
            '<xacro:arg name="prefix" default=""/>',
            '<xacro:arg name="prefix" default=""/>\n  <xacro:arg name="initial_q1" default="0.2"/>',
        )
    )
    (package / "urdf" / "mini.ros2_control.xacro").write_text(ROS2_CONTROL_MACRO)
    (package / "config").mkdir()
    (package / "config" / "mini_controllers.yaml").write_text(textwrap.dedent(CONTROLLERS))
    scenario = tmp_path / "mini.yaml"
    scenario.write_text(
        textwrap.dedent(
            f"""
            robot:
              description: package://mini_description/urdf/mini.urdf.xacro
              package_paths: [{tmp_path}]
              xacro_args: {{initial_q1: "0.3"}}
            controllers:
              activate: [joint_state_broadcaster, arm_controller]
            sequencer: !PositionTargets
              targets: [[0.3, 0.0, 0.0], [0.8, -0.6, 0.02], [-0.5, 0.9, 0.01]]
              period: 2.0
            """
        )
    )
    out = tmp_path / "out"
    result = run(
        "armando_drake.world",
        "--scenario",
        str(scenario),
        "--no-meshcat",
        "--realtime-rate",
        "0",
        "--output",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    assert "loaded controller 'arm_controller' of type " in result.stdout
    assert "at 200 Hz" in result.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["joint_names"] == ["q1", "q2", "finger_joint"]
    errors = [step["final_error"] for step in summary["steps"]]
    assert len(errors) == 3 and max(errors) <= 0.01, errors
    rows = (out / "joint_states.csv").read_text().splitlines()
    assert rows[0].startswith("time,q1_position,q1_velocity,q1_effort,q2_position")
    assert abs(len(rows) - 1 - 6.0 * 200) <= 1
    first = [float(v) for v in rows[1].split(",")]
    assert first[1] == pytest.approx(0.3)  # initial_value from the xacro:arg


IIWA_JOINTS = [f"iiwa_joint_{i}" for i in range(1, 8)]
# [rad] seed-style targets for the 7 joints: out, back, a mixed pose, home.
IIWA_TARGETS = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1.2, -1.0, 1.2, -1.0, 0.6, 1.0, 0.5],
    [-1.2, 1.0, -1.2, 1.0, -0.6, -1.0, -0.5],
    [0.6, 0.5, -0.6, -1.5, 1.0, 0.5, 1.0],
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
]
# [N m/rad], [N m s/rad]: stiff enough for a 30 kg arm (Armando's default is 8, 0.4).
IIWA_GAINS = "actuators: {kp: 2000.0, kd: 50.0}"


def test_display_loads_the_iiwa_with_its_world_link(iiwa_package):
    result = run("armando_drake.display", "--description", str(iiwa_package), "--loop-once")
    assert result.returncode == 0, result.stderr
    assert "Showing 'iiwa14'" in result.stdout
    (line,) = [line for line in result.stdout.splitlines() if line.startswith("Joints: ")]
    assert line.count("iiwa_joint_") == 7
    assert "iiwa_joint_1 [-2.97, 2.97]" in line and "iiwa_joint_7 [-3.05, 3.05]" in line
    assert "Welded to the world: iiwa_link_0 (fixed to the world link by 'world_iiwa_joint')" in (
        result.stdout
    )


def _iiwa_world(iiwa_package, tmp_path, controller: str, *sets: str) -> subprocess.CompletedProcess:
    result = run(
        "armando_drake.world", "--description", str(iiwa_package), "--controller", controller,
        "--no-meshcat", "--realtime-rate", "0", "--quiet", "--no-replay",
        "--output", str(tmp_path), *[arg for s in sets for arg in ("--set", s)],
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return result


def test_iiwa_falls_without_a_controller(iiwa_package, tmp_path):
    _iiwa_world(iiwa_package, tmp_path, "none", "simulation: {duration: 2.0}")
    from armando_drake.outputs.logger import read_joint_states

    states = read_joint_states(tmp_path / "joint_states.csv", IIWA_JOINTS)
    times, q = states.times, states.position
    assert times[-1] == pytest.approx(2.0)
    moved = np.abs(q[-1] - q[0])
    assert moved.max() > 0.1, f"the joints moved only {moved} rad in 2 s"


def test_iiwa_position_controller_reaches_the_seed_style_targets(iiwa_package, tmp_path):
    _iiwa_world(
        iiwa_package,
        tmp_path,
        "position",
        f"sequencer: {{targets: {IIWA_TARGETS}, period: 3.0}}",
        IIWA_GAINS,
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["joint_names"] == IIWA_JOINTS
    errors = [step["final_error"] for step in summary["steps"]]
    assert len(errors) == 5 and max(errors) <= 0.01, errors


@pytest.mark.parametrize(
    "argument, interface",
    [("PositionJointInterface", "position"), ("EffortJointInterface", "effort")],
)
def test_iiwa_transmission_hardware_interface_per_joint(iiwa_package, argument, interface):
    from pydrake.multibody.plant import MultibodyPlant

    from armando_drake.description.loader import load_robot

    plant = MultibodyPlant(0.001)
    robot = load_robot(plant, iiwa_package, xacro_args={"hardware_interface": argument})
    assert robot.base_link == "iiwa_link_0"
    assert robot.welds[0].joint == "world_iiwa_joint"
    assert robot.actuation_source == "transmission"
    assert robot.command_interfaces == {joint: [interface] for joint in IIWA_JOINTS}
    assert robot.transmissions[0].hardware_interfaces == {
        "iiwa_joint_1": [f"hardware_interface/{argument}"]
    }
    assert [j.damping for j in robot.joints] == [0.5] * 7
