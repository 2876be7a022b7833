"""The hardware interface from <ros2_control>: limits, initial values, effort limits."""

import numpy as np
import pytest
from conftest import make_mini_package
from pydrake.systems.analysis import Simulator

from armando_drake.messages.types import Float64MultiArray
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

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
    q1, q2 = world.robot().stack.hardware.joints
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


def armando_world(kp: float, feedforward: bool, more: str = ""):
    scenario = load_scenario(
        "position",
        "sequencer: null\nlogging: {console_rate: 0}\n"
        f"actuators: {{kp: {kp}, kd: {kp / 20}, gravity_feedforward: {str(feedforward).lower()}}}"
        f"\n{more}",
    )
    return MakeWorld(scenario, quiet=True)


@pytest.mark.parametrize("kp", [2.0, 8.0])
def test_gravity_feedforward_removes_the_steady_state_error_whatever_the_gains(kp):
    # j1 and j2 bent: gravity loads them. Without feed-forward the PD actuators sag by
    # about tau_g / kp (0.17 rad at kp = 2, 0.04 rad at kp = 8); with it they do not.
    target = np.array([0.0, 1.0, 0.8, 0.0])
    errors = {}
    for feedforward in (True, False):
        world = armando_world(kp, feedforward)
        simulator = Simulator(world.diagram)
        context = simulator.get_mutable_context()
        world.publish(context, "position_controller", Float64MultiArray(data=tuple(target)))
        simulator.AdvanceTo(4.0)
        errors[feedforward] = np.abs(world.joint_positions(context) - target).max()
        world.close()
    assert errors[True] < 1e-4, errors
    assert errors[False] > 0.3 / kp, errors


def test_gravity_feedforward_cancels_gravity_at_the_command():
    world = armando_world(8.0, True)
    plant = world.plant
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    target = (0.3, -0.9, 1.1, 0.5)
    world.publish(context, "position_controller", Float64MultiArray(data=target))
    # Handled at the 10 ms tick; the joints (velocity limit 6.18 rad/s) are there by 0.5 s.
    simulator.AdvanceTo(0.5)
    port = world.robot().gravity_feedforward
    feedforward = port.Eval(port.get_system().GetMyContextFromRoot(context))
    # The generalized gravity forces at q = target, computed directly on the plant.
    plant_context = plant.CreateDefaultContext()
    plant.SetPositions(plant_context, world.robot().robot.model_instance, np.array(target))
    expected = -plant.CalcGravityGeneralizedForces(plant_context)
    np.testing.assert_allclose(feedforward, expected, atol=1e-12)
    assert np.abs(expected).max() > 0.01  # a real load, not zeros
    # It reaches the plant's actuation input (the arm's only actuation here).
    actuation = plant.get_actuation_input_port(world.robot().robot.model_instance)
    np.testing.assert_allclose(
        actuation.Eval(plant.GetMyContextFromRoot(context)), expected, atol=1e-12
    )
    world.close()


class EffortProbe:
    """A world driven to a bent pose by its position controller, with the effort its
    broadcaster reports and the torque the plant's net actuation port solves."""

    def __init__(self, more: str = ""):
        self.world = armando_world(8.0, True, more)
        plant = self.world.plant
        self.simulator = Simulator(self.world.diagram)
        self.context = self.simulator.get_mutable_context()
        self._plant_context = plant.GetMyContextFromRoot(self.context)
        self._applied = plant.get_net_actuation_output_port(self.world.robot().robot.model_instance)
        self.h = plant.time_step()

    def command(self) -> None:
        target = Float64MultiArray(data=(0.3, -0.9, 1.1, 0.5))
        self.world.publish(self.context, "position_controller", target)

    def reported(self) -> np.ndarray:
        joint_states = self.world.diagram.GetOutputPort("joint_states").Eval(self.context)
        return np.array(joint_states.effort)

    def solved(self) -> np.ndarray:
        """The torque of the step from now on, solved from the current state."""
        return np.array(self._applied.Eval(self._plant_context))

    def last_step_at(self, m: int) -> np.ndarray:
        """Advances to plant step ``m`` (t = m h, as Drake times the plant's steps);
        returns the torque the step [t - h, t] applied. Steps at least two apart: an
        ``AdvanceTo`` to the present time runs the updates pending at it."""
        self.simulator.AdvanceTo((m - 1) * self.h)
        applied = self.solved()
        self.simulator.AdvanceTo(m * self.h)
        return applied


def test_effort_state_is_the_torque_applied_over_the_last_plant_step():
    # The broadcaster and the logger read the effort a servo reports: what its actuator
    # applied over the plant step that just ended, not a step solved ahead from the
    # current state (which costs one more contact solve whenever a command arrives).
    probe = EffortProbe()
    steps = round(1.0 / (probe.world.robot().stack.update_rate * probe.h))  # plant steps per update
    probe.simulator.Initialize()
    np.testing.assert_array_equal(probe.reported(), np.zeros(4))  # no step taken yet
    probe.command()
    # Mid-motion, at each of 60 controller updates (where the broadcaster publishes) and
    # at a plant step between each and the next: the report is the torque the step
    # [t - h, t] applied, solved from the state and command at t - h.
    assert steps >= 4
    ahead = []  # how far the plant's port, which solves the next step, is from the report
    for update in range(5, 65):
        for m in (update * steps, update * steps + steps // 2):
            expected = probe.last_step_at(m)
            np.testing.assert_array_equal(probe.reported(), expected, err_msg=f"at t = {m} h")
            assert np.abs(expected).max() > 0.01  # the arm is being driven
            ahead.append(np.abs(probe.solved() - expected).max())
    # Mid-motion the step ahead applies a different torque.
    assert max(ahead[:10]) > 1e-4
    probe.world.close()


@pytest.mark.parametrize("rate", [100, 300, 250])
def test_effort_state_holds_the_last_steps_torque_whatever_the_update_rate(rate):
    # 300 Hz on a 1 ms plant: no plant step ends at the updates (a warned setup); 250 Hz:
    # every fourth step. The report is the last step's torque in every case.
    probe = EffortProbe(f"controllers: {{update_rate: {rate}}}")
    probe.command()
    for m in (35, 38, 200, 403):
        expected = probe.last_step_at(m)
        np.testing.assert_array_equal(probe.reported(), expected)
        assert np.abs(expected).max() > 0.01
    probe.world.close()
