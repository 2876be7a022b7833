"""URDF velocity limits capped on every command interface, as Gazebo's physics does."""

import numpy as np
import pytest
from conftest import make_mini_package
from pydrake.systems.analysis import Simulator

from armando_drake.messages.types import Float64MultiArray
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

LIMIT = 0.7  # [rad/s] the joints' URDF velocity limit
CONTROLLERS = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    CONTROLLER: {type: TYPE}
CONTROLLER:
  ros__parameters:
    joints: [q1, q2]
"""
TYPES = {
    "position": "position_controllers/JointGroupPositionController",
    "velocity": "velocity_controllers/JointGroupVelocityController",
    "effort": "effort_controllers/JointGroupEffortController",
}


def limited_world(tmp_path, interface: str, controller: str):
    block = f"""
<ros2_control name="MiniSystem" type="system">
  <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
  <joint name="q1"><command_interface name="{interface}"/><state_interface name="position"/></joint>
  <joint name="q2"><command_interface name="{interface}"/><state_interface name="position"/></joint>
</ros2_control>
"""
    package = make_mini_package(tmp_path, block)
    controllers = tmp_path / "controllers.yaml"
    controllers.write_text(
        CONTROLLERS.replace("CONTROLLER", controller).replace("TYPE", TYPES[interface])
    )
    urdf = package / "urdf" / "mini.urdf.xacro"
    urdf.write_text(urdf.read_text().replace('velocity="3"', f'velocity="{LIMIT}"'))
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}}}\nsequencer: null\nlogging: {{console_rate: 0}}\n"
        f"controllers: {{config: {controllers}, "
        f"activate: [joint_state_broadcaster, {controller}]}}\n"
        "actuators: {velocity_limits: true}",
    )
    return MakeWorld(scenario, quiet=True)


def peak_speed(world, command, seconds: float) -> tuple[float, np.ndarray]:
    """The largest |joint velocity| [rad/s] of the joint states sampled every 2 ms while
    ``command`` is held, and the final positions."""
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    world.publish(context, *command)
    peak = 0.0
    for t in np.arange(0.002, seconds, 0.002):
        simulator.AdvanceTo(t)
        state = world.diagram.GetOutputPort("joint_states").Eval(context)
        peak = max(peak, max(abs(v) for v in state.velocity))
    return peak, world.joint_positions(context)


@pytest.mark.parametrize(
    "interface, controller, data",
    [
        ("position", "position_controller", (1.5, 0.0)),
        ("velocity", "velocity_controller", (5.0, -5.0)),
        ("effort", "effort_controller", (0.5, 0.0)),
    ],
)
def test_a_step_command_never_drives_a_joint_above_its_velocity_limit(
    tmp_path, interface, controller, data
):
    world = limited_world(tmp_path, interface, controller)
    try:
        peak, q = peak_speed(world, (controller, Float64MultiArray(data=data)), 2.0)
    finally:
        world.close()
    assert peak <= 1.01 * LIMIT, f"{interface}: {peak} rad/s against {LIMIT}"
    assert peak >= 0.95 * LIMIT  # the joint does run at its limit
    if interface == "position":
        # 2 s at up to 0.7 rad/s cover at most 1.4 rad: q1 is still on its way to 1.5.
        assert 1.0 < q[0] < 1.41
        assert q[1] == pytest.approx(0.0, abs=0.01)


@pytest.mark.parametrize("data", [(1.5, -1.0), (0.2, -1.5), (0.3, -1.0), (-1.5, 0.3)])
def test_joints_stepped_together_never_run_above_their_limits_by_more_than_1_percent(
    tmp_path, data
):
    # Both joints stepped at once: the shoulder's start drags the light tip (derived kp
    # 0.09 N m/rad, its mass matrix coupling to the shoulder as large as its own
    # inertia) within a step; the cap sees that coupling and holds every joint.
    world = limited_world(tmp_path, "position", "position_controller")
    try:
        simulator = Simulator(world.diagram)
        context = simulator.get_mutable_context()
        world.publish(context, "position_controller", Float64MultiArray(data=data))
        peaks = np.zeros(2)
        for t in np.arange(0.001, 0.6, 0.001):
            simulator.AdvanceTo(t)
            state = world.diagram.GetOutputPort("joint_states").Eval(context)
            peaks = np.maximum(peaks, np.abs(state.velocity))
    finally:
        world.close()
    assert np.all(peaks <= 1.01 * LIMIT), f"{data}: {peaks} rad/s against {LIMIT}"
    assert np.max(peaks) >= 0.95 * LIMIT  # a joint does run at its limit
