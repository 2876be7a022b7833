"""Command interfaces position, velocity and effort: from the description to the joint."""

import textwrap

import pytest
from conftest import make_mini_package
from pydrake.systems.analysis import Simulator

from armando_drake.messages.types import Float64MultiArray
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario

# A single arm spinning about a vertical axis: gravity exerts no torque on it at any angle.
SPIN_INERTIA = 0.002  # [kg m^2] izz of the arm about the joint axis (the URDF's, at its origin)
SPIN_EFFORT_LIMIT = 0.2  # [N m]
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
    <limit effort="{SPIN_EFFORT_LIMIT}" velocity="20"/>
  </joint>
  <ros2_control name="SpinnerSystem" type="system">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <joint name="spin">
      <command_interface name="INTERFACE"/>
      <state_interface name="position"/><state_interface name="velocity"/>
    </joint>
  </ros2_control>
</robot>
"""
SPINNER_CONTROLLERS = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    spin_controller: {type: TYPE}
spin_controller:
  ros__parameters:
    joints: [spin]
"""
TYPES = {
    "effort": "effort_controllers/JointGroupEffortController",
    "velocity": "velocity_controllers/JointGroupVelocityController",
}


def spinner_world(tmp_path, interface: str, extra: str = ""):
    urdf = tmp_path / "spinner.urdf"
    urdf.write_text(SPINNER.replace("INTERFACE", interface))
    controllers = tmp_path / "spinner_controllers.yaml"
    controllers.write_text(SPINNER_CONTROLLERS.replace("TYPE", TYPES[interface]))
    scenario = load_scenario(
        "position",
        f"robot: {{description: {urdf}, base_xyz: [0, 0, 0]}}\nsequencer: null\n"
        "logging: {console_rate: 0}\n"
        f"controllers: {{config: {controllers}, activate: "
        "[joint_state_broadcaster, spin_controller]}\n" + extra,
    )
    return MakeWorld(scenario, quiet=True)


def velocity_of(world, context) -> float:
    plant = world.plant
    return plant.GetVelocities(
        plant.GetMyContextFromRoot(context), world.robot().robot.model_instance
    )[0]


def test_constant_effort_gives_the_acceleration_tau_over_inertia(tmp_path):
    world = spinner_world(tmp_path, "effort")
    assert [joint.command_interface for joint in world.robot().stack.hardware.joints] == ["effort"]
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    torque = 0.05  # [N m], within the limit
    world.publish(context, "spin_controller", Float64MultiArray(data=(torque,)))
    simulator.AdvanceTo(0.1)
    v1 = velocity_of(world, context)
    simulator.AdvanceTo(0.3)
    v2 = velocity_of(world, context)
    acceleration = (v2 - v1) / 0.2
    assert acceleration == pytest.approx(torque / SPIN_INERTIA, rel=1e-3)  # 25 rad/s^2
    effort = world.diagram.GetOutputPort("joint_states").Eval(context).effort
    assert effort == pytest.approx((torque,), abs=1e-12)
    world.close()


def test_effort_is_clamped_to_the_urdf_limit(tmp_path):
    world = spinner_world(tmp_path, "effort")
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    world.publish(context, "spin_controller", Float64MultiArray(data=(-5.0,)))
    simulator.AdvanceTo(0.1)
    v1 = velocity_of(world, context)
    simulator.AdvanceTo(0.2)
    acceleration = (velocity_of(world, context) - v1) / 0.1
    assert acceleration == pytest.approx(-SPIN_EFFORT_LIMIT / SPIN_INERTIA, rel=1e-3)  # -100
    status = world.status(context, "spin_controller")
    assert status.detail["warning"] == (
        "command -5.0 for joint 'spin' is outside its limits [-0.2, 0.2]; clamped to -0.2"
    )
    effort = world.diagram.GetOutputPort("joint_states").Eval(context).effort
    assert effort == pytest.approx((-SPIN_EFFORT_LIMIT,), abs=1e-12)
    world.close()


@pytest.mark.parametrize("kv", [0.05, 1.0])
def test_velocity_command_reaches_the_commanded_speed(tmp_path, kv):
    world = spinner_world(tmp_path, "velocity", f"actuators: {{kv: {kv}}}")
    (joint,) = world.robot().stack.hardware.joints
    assert joint.command_interface == "velocity"
    actuator = world.plant.get_joint_actuator(
        world.plant.GetJointActuatorIndices(world.robot().robot.model_instance)[0]
    )
    gains = actuator.get_controller_gains()
    assert (gains.p, gains.d) == (0.0, kv)
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    command = 3.0  # [rad/s]
    world.publish(context, "spin_controller", Float64MultiArray(data=(command,)))
    # Speeding up at the effort limit (100 rad/s^2, 30 ms), then the time constant
    # I / kv (40 ms at kv = 0.05, 2 ms at kv = 1): within 2 % after 10 of them.
    simulator.AdvanceTo(command * SPIN_INERTIA / SPIN_EFFORT_LIMIT + 10 * SPIN_INERTIA / kv)
    assert velocity_of(world, context) == pytest.approx(command, rel=0.02)
    simulator.AdvanceTo(1.0)
    assert velocity_of(world, context) == pytest.approx(command, rel=1e-4)
    world.close()


def test_velocity_joint_refuses_a_proportional_gain(tmp_path):
    with pytest.raises(ValueError, match=r"velocity joint spin: kp=2.0 must be 0"):
        spinner_world(tmp_path, "velocity", "actuators: {gains: {spin: [2.0, 0.1]}}")


def test_position_controller_on_an_effort_joint_is_refused(tmp_path):
    urdf = tmp_path / "spinner.urdf"
    urdf.write_text(SPINNER.replace("INTERFACE", "effort"))
    controllers = tmp_path / "c.yaml"
    controllers.write_text(
        SPINNER_CONTROLLERS.replace("TYPE", "position_controllers/JointGroupPositionController")
    )
    scenario = load_scenario(
        "position",
        f"robot: {{description: {urdf}}}\nsequencer: null\nlogging: {{console_rate: 0}}\n"
        f"controllers: {{config: {controllers}, activate: [spin_controller]}}",
    )
    with pytest.raises(ScenarioError) as error:
        MakeWorld(scenario, quiet=True)
    # Named after the override that activated it.
    assert str(error.value).startswith("override 'robot: {description: ")
    assert str(error.value).endswith(
        ": controller 'spin_controller' commands the position interface of joint 'spin', "
        "which the hardware interface 'SpinnerSystem' drives through effort"
    )


# ----------------------------------------------------------------------------------------
# Where the interfaces come from

ROS2_CONTROL = """
<ros2_control name="MiniSystem" type="system">
  <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
  <joint name="q1">
    <command_interface name="velocity"/>
    <state_interface name="position"/>
  </joint>
  <joint name="q2">
    <command_interface name="effort"/><command_interface name="position"/>
    <state_interface name="position"/>
  </joint>
</ros2_control>
"""
TRANSMISSIONS = """
<transmission name="t1">
  <type>transmission_interface/SimpleTransmission</type>
  <joint name="q1">
    <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>
  </joint>
  <actuator name="m1"><mechanicalReduction>1</mechanicalReduction></actuator>
</transmission>
<transmission name="t2">
  <type>transmission_interface/SimpleTransmission</type>
  <joint name="q2"><hardwareInterface>VelocityJointInterface</hardwareInterface></joint>
  <actuator name="m2">
    <hardwareInterface>hardware_interface/VelocityJointInterface</hardwareInterface>
  </actuator>
</transmission>
"""


def mini_hardware(tmp_path, extra: str):
    package = make_mini_package(tmp_path, extra)
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}}}\nsequencer: null\nlogging: {{console_rate: 0}}\n"
        "controllers: {activate: [joint_state_broadcaster]}",
    )
    world = MakeWorld(scenario, quiet=True)
    plant = world.plant
    gains = []
    for index in plant.GetJointActuatorIndices(world.robot().robot.model_instance):
        actuator = plant.get_joint_actuator(index)
        if actuator.has_controller():
            gains.append((actuator.get_controller_gains().p, actuator.get_controller_gains().d))
        else:
            gains.append(None)
    interfaces = {
        joint.name: joint.command_interface for joint in world.robot().stack.hardware.joints
    }
    source = world.robot().stack.hardware.source
    world.close()
    return source, interfaces, gains


def test_interfaces_from_ros2_control_command_interface_names(tmp_path):
    source, interfaces, gains = mini_hardware(tmp_path, ROS2_CONTROL)
    # q2 declares effort and position: position wins (Drake's PD actuator).
    assert (source, interfaces) == ("ros2_control", {"q1": "velocity", "q2": "position"})
    # kv = 1 (the scenario's default); q2's derived: its link's 1e-4 kg m^2 about its axis
    # at wn = 30 rad/s, no gravity torque (its centre of mass on the axis):
    # kp = M wn^2 = 0.09 N m/rad, kd = 2 sqrt(kp M) = 0.006 N m s/rad.
    assert gains[0] == (0.0, 1.0)
    assert gains[1] == (pytest.approx(0.09), pytest.approx(0.006))


def test_interfaces_from_ros1_transmissions(tmp_path):
    source, interfaces, gains = mini_hardware(tmp_path, TRANSMISSIONS)
    assert (source, interfaces) == ("transmission", {"q1": "effort", "q2": "velocity"})
    assert gains == [None, (0.0, 1.0)]  # effort: no PD controller


# ----------------------------------------------------------------------------------------
# A mixed robot: the arm joint on effort, the "gripper" joint on position

MIXED = """
<ros2_control name="MixedSystem" type="system">
  <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
  <joint name="q1">
    <command_interface name="effort"/>
    <state_interface name="position"><param name="initial_value">0.3</param></state_interface>
  </joint>
  <joint name="q2"><command_interface name="position"/><state_interface name="position"/></joint>
</ros2_control>
"""
MIXED_CONTROLLERS = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    arm_controller: {type: effort_controllers/JointGroupEffortController}
    gripper_controller: {type: position_controllers/JointGroupPositionController}
arm_controller:
  ros__parameters: {joints: [q1]}
gripper_controller:
  ros__parameters: {joints: [q2]}
"""


def test_mixed_effort_arm_and_position_gripper(tmp_path):
    package = make_mini_package(tmp_path, MIXED)
    controllers = tmp_path / "mixed.yaml"
    controllers.write_text(textwrap.dedent(MIXED_CONTROLLERS))
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}}}\nsequencer: null\nlogging: {{console_rate: 0}}\n"
        f"controllers: {{config: {controllers}, activate: "
        "[joint_state_broadcaster, arm_controller, gripper_controller]}",
    )
    world = MakeWorld(scenario, quiet=True)
    plant, instance = world.plant, world.robot().robot.model_instance
    assert world.robot().stack.hardware.interfaces() == ["effort", "position"]
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    # The torque that holds q1 against gravity at q1 = 0.3 (its initial value), q2 = 0.5,
    # from the plant. (Each mini link has its centre of mass on its own joint axis, so
    # gravity loads q1 only.)
    target = 0.5
    static = plant.CreateDefaultContext()
    plant.SetPositions(static, instance, [0.3, target])
    gravity = -plant.CalcGravityGeneralizedForces(static)
    hold = float(gravity[0])
    assert abs(hold) > 0.01
    world.publish(context, "arm_controller", Float64MultiArray(data=(hold,)))
    world.publish(context, "gripper_controller", Float64MultiArray(data=(target,)))
    simulator.AdvanceTo(3.0)
    q = world.joint_positions(context)
    # The arm joint gets exactly its command (no feed-forward, no PD) ...
    actuation = plant.get_net_actuation_output_port(instance).Eval(
        plant.GetMyContextFromRoot(context)
    )
    assert actuation[0] == pytest.approx(hold, abs=1e-12)
    # ... the gravity feed-forward goes to the position joint only ...
    feedforward = world.robot().gravity_feedforward
    torques = feedforward.Eval(feedforward.get_system().GetMyContextFromRoot(context))
    assert torques.tolist() == [0.0, pytest.approx(gravity[1], abs=1e-12)]
    # ... and the gripper joint reaches its position, while the arm joint, balanced on
    # top (unstable) and pushed by the gripper's reaction torque, is free: it tips over
    # to its limit, which a PD-held joint would not.
    assert abs(q[1] - target) < 1e-3, q
    assert q[0] == pytest.approx(-2.0, abs=1e-3), q
    world.close()


def test_mixed_feedforward_uses_the_measured_position_of_the_effort_joint(tmp_path):
    package = make_mini_package(tmp_path, MIXED)
    # Centres of mass 0.1 m up each link: gravity on q2 depends on where q1 is.
    parts = package / "urdf" / "parts.xacro"
    parts.write_text(
        parts.read_text().replace("<inertial>", '<inertial>\n        <origin xyz="0 0 0.1"/>')
    )
    controllers = tmp_path / "mixed.yaml"
    controllers.write_text(textwrap.dedent(MIXED_CONTROLLERS))
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}}}\nsequencer: null\nlogging: {{console_rate: 0}}\n"
        f"controllers: {{config: {controllers}, activate: "
        "[joint_state_broadcaster, arm_controller, gripper_controller]}",
    )
    world = MakeWorld(scenario, quiet=True)
    plant, instance = world.plant, world.robot().robot.model_instance
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    target = 0.5
    world.publish(context, "gripper_controller", Float64MultiArray(data=(target,)))
    simulator.AdvanceTo(0.3)  # q1 (no torque) is falling
    q1 = world.joint_positions(context)[0]
    assert abs(q1 - 0.3) > 0.1, q1

    def gravity_at(q):
        static = plant.CreateDefaultContext()
        plant.SetPositions(static, instance, q)
        return -plant.CalcGravityGeneralizedForces(static)

    port = world.robot().gravity_feedforward
    torques = port.Eval(port.get_system().GetMyContextFromRoot(context))
    expected = gravity_at([q1, target])[1]
    assert torques.tolist() == [0.0, pytest.approx(expected, abs=1e-12)]
    # At q1's initial position the torque would be another one.
    assert abs(expected - gravity_at([0.3, target])[1]) > 0.01
    world.close()
