"""The hardware interface from <ros2_control>: limits, initial values, effort limits."""

import numpy as np
import pytest
from conftest import make_mini_package
from pydrake.systems.analysis import Simulator

from armando_drake.builder import MakeWorld
from armando_drake.messages import Float64MultiArray
from armando_drake.scenario import load_scenario

BLOCK = """
<ros2_control name="MiniSystem" type="system">
  <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
  <joint name="q1">
    <command_interface name="position">
      <param name="min">-1.2</param><param name="max">3.0</param>
    </command_interface>
    <state_interface name="position"><param name="initial_value">-1.9</param></state_interface>
  </joint>
  <joint name="q2">
    <command_interface name="position"/>
    <state_interface name="position"/>
  </joint>
</ros2_control>
"""


@pytest.fixture
def world(tmp_path):
    package = make_mini_package(tmp_path, BLOCK)
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}}}\nsequencer: null\nlogging: {{console_rate: 0}}\n"
        "controllers: {activate: [joint_state_broadcaster, position_controller]}",
    )
    world = MakeWorld(scenario, quiet=True)
    yield world
    world.close()


def test_interface_limits_merge_with_the_urdf_and_initial_values_are_clamped(world):
    q1, q2 = world.hardware.joints
    # URDF q1 limits [-2, 2]; the interface's min -1.2 is tighter, its max 3.0 is not.
    assert (q1.lower, q1.upper) == (-1.2, 2.0)
    assert (q2.lower, q2.upper) == (-2.5, 2.5)
    # initial_value -1.9 clamped into [-1.2, 2]; absent initial_value: 0.
    assert (q1.initial_position, q2.initial_position) == (-1.2, 0.0)
    assert q1.effort == 10.0  # the URDF effort limit
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    np.testing.assert_allclose(world.joint_positions(context), [-1.2, 0.0])
    # A command below the interface min is clamped to it.
    world.publish(context, "position_controller", Float64MultiArray(data=(-1.8, 0.4)))
    simulator.AdvanceTo(2.0)
    np.testing.assert_allclose(world.joint_positions(context), [-1.2, 0.4], atol=0.01)
    status = world.status(context, "position_controller")
    assert "outside its limits" in str(status.detail)


def test_actuator_torque_respects_the_urdf_effort_limit(tmp_path):
    package = make_mini_package(tmp_path)
    urdf = package / "urdf" / "mini.urdf.xacro"
    urdf.write_text(urdf.read_text().replace('effort="10"', 'effort="0.05"'))
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}}}\nsequencer: null\nlogging: {{console_rate: 0}}\n"
        "actuators: {gravity_feedforward: false}",
    )
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    world.publish(context, "position_controller", Float64MultiArray(data=(1.5, 0.0)))
    simulator.AdvanceTo(1.0)
    state = world.diagram.GetOutputPort("joint_states").Eval(context)
    assert max(abs(e) for e in state.effort) <= 0.05 + 1e-9
    # 0.05 N m cannot lift the 0.1 kg links: q1 stays far from its target.
    assert abs(world.joint_positions(context)[0] - 1.5) > 0.5
    world.close()
