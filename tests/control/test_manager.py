"""The controller manager in a bare DiagramBuilder (a plant and the manager, no MakeWorld),
the registry with a toy controller type, and the update-rate override."""

import dataclasses
import logging

import numpy as np
import pytest
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import VectorLogSink

from armando_drake.control.config import ControllerConfigError, load_controller_config
from armando_drake.control.controllers import (
    Controller,
    ControllerJoints,
    ControllerMemory,
    Rejected,
    lookup,
    register,
    registered_types,
    types_accepting,
    unregister,
)
from armando_drake.control.controllers.broadcaster import JointStateBroadcaster
from armando_drake.control.controllers.forward_command import JointGroupPositionController
from armando_drake.control.hardware import (
    AddHardwareInterface,
    ConnectHardwareInterface,
    FinishHardwareInterface,
)
from armando_drake.control.manager import (
    AddJointStateVector,
    AddStreamDesiredState,
    ControllerManager,
    ManagedController,
)
from armando_drake.control.sequencer import Sinusoid, SinusoidSequencer
from armando_drake.description.loader import load_robot
from armando_drake.messages.types import (
    Float64MultiArray,
    JointTrajectory,
    Publication,
)
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ONE_ROBOT, ScenarioError, load_scenario
from armando_drake.tools.schema import param

RATE = 50  # [Hz]


def armando_plant():
    """(builder, plant, robot, hardware): Armando on a 1 ms plant with its PD actuators."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=0.001, discrete_contact_approximation="lagged"), builder
    )
    robot = load_robot(plant)
    hardware = AddHardwareInterface(plant, robot, kp=8.0, kd=0.4)
    plant.Finalize()
    FinishHardwareInterface(plant, robot, hardware)
    return builder, plant, robot, hardware


def bare_world(controllers=("position",)):
    """Armando on a plant with the manager: a broadcaster and a position controller."""
    builder, plant, robot, hardware = armando_plant()
    names = hardware.joint_names
    joints = ControllerJoints.make(
        names,
        lower=[j.lower for j in hardware.joints],
        upper=[j.upper for j in hardware.joints],
        initial_positions=[j.initial_position for j in hardware.joints],
    )
    broadcaster = JointStateBroadcaster(name="joint_state_broadcaster", joints=joints)
    managed = [
        ManagedController("arm", JointGroupPositionController(name="arm", joints=joints))
        for _ in controllers
    ]
    manager = builder.AddSystem(
        ControllerManager(
            hardware=hardware, update_rate=RATE, broadcaster=broadcaster, controllers=managed
        )
    )
    instance = robot.model_instance
    builder.Connect(plant.get_state_output_port(instance), manager.GetInputPort("state"))
    builder.Connect(plant.get_net_actuation_output_port(instance), manager.GetInputPort("effort"))
    ConnectHardwareInterface(
        builder,
        plant,
        robot,
        hardware,
        desired_state=manager.GetOutputPort("desired_state"),
        effort=None,
        gravity_feedforward=True,
    )
    view = AddJointStateVector(builder, plant, hardware, instance, names)
    sink = builder.AddSystem(VectorLogSink(3 * len(names), 1.0 / RATE))
    builder.Connect(view, sink.get_input_port())
    builder.ExportInput(manager.GetInputPort("arm.commands"), "arm.commands")
    diagram = builder.Build()
    return diagram, plant, robot, manager, sink


def test_manager_runs_a_position_controller_on_a_plant():
    diagram, plant, robot, manager, _ = bare_world()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    target = (0.4, -0.6, 0.8, 0.2)
    diagram.GetInputPort("arm.commands").FixValue(
        context, Publication().publish(Float64MultiArray(data=target))
    )
    simulator.AdvanceTo(3.0)
    q = plant.GetPositions(plant.GetMyContextFromRoot(context), robot.model_instance)
    np.testing.assert_allclose(q, target, atol=1e-4)  # gravity fed forward: no sag
    status = manager.GetOutputPort("arm.status").Eval(manager.GetMyContextFromRoot(context))
    assert (status.state, status.accepted, status.rejected) == ("active", 1, 0)


def test_broadcaster_message_and_its_vector_view_are_the_plant_state():
    diagram, plant, robot, manager, sink = bare_world()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    diagram.GetInputPort("arm.commands").FixValue(
        context, Publication().publish(Float64MultiArray(data=(1.0, -1.0, 1.0, 0.5)))
    )
    simulator.AdvanceTo(0.06)  # mid-motion, at a 50 Hz tick
    plant_context = plant.GetMyContextFromRoot(context)
    instance = robot.model_instance
    q = plant.GetPositions(plant_context, instance)
    v = plant.GetVelocities(plant_context, instance)
    effort = plant.get_net_actuation_output_port(instance).Eval(plant_context)
    assert np.abs(v).max() > 0.1 and np.abs(effort).max() > 0.01  # moving, loaded
    message = manager.GetOutputPort("joint_states").Eval(manager.GetMyContextFromRoot(context))
    assert message.stamp == pytest.approx(0.06, abs=1e-12)
    assert message.name == ("j0", "j1", "j2", "j3")
    np.testing.assert_allclose(message.position, q, atol=1e-15)
    np.testing.assert_allclose(message.velocity, v, atol=1e-15)
    np.testing.assert_allclose(message.effort, effort, atol=1e-15)
    # The logger's C++ view: the same numbers as [q; v; effort], one sample per tick.
    log = sink.GetLog(sink.GetMyContextFromRoot(context))
    np.testing.assert_allclose(log.sample_times(), [0.0, 0.02, 0.04, 0.06], atol=1e-12)
    np.testing.assert_allclose(log.data()[:, -1], np.concatenate([q, v, effort]), atol=1e-15)


def test_broadcaster_without_effort_publishes_empty_effort():
    joints = ControllerJoints.make(("a",))
    from armando_drake.control.hardware import HardwareInterface, HardwareJoint

    hardware = HardwareInterface("bare", "test", [HardwareJoint("a", -1, 1, 1, 0)], [0], [1], 2)
    manager = ControllerManager(
        hardware=hardware,
        update_rate=100,
        broadcaster=JointStateBroadcaster(name="b", joints=joints),
    )
    context = manager.CreateDefaultContext()
    manager.GetInputPort("state").FixValue(context, [0.5, 0.25])
    context.SetTime(0.01)
    message = manager.GetOutputPort("joint_states").Eval(context)
    assert (message.stamp, message.position, message.velocity, message.effort) == (
        pytest.approx(0.01),
        (0.5,),
        (0.25,),
        (),
    )


def sinusoid_world(config: Sinusoid, *, stream: bool):
    """Armando on a plant, its position controller driven by a SinusoidSequencer: through
    the manager as messages, or as a C++ stream (``stream``)."""
    builder, plant, robot, hardware = armando_plant()
    names = list(reversed(hardware.joint_names))  # not the hardware order
    rows = hardware.find(names)
    joints = ControllerJoints.make(
        names,
        lower=[hardware.joints[i].lower for i in rows],
        upper=[hardware.joints[i].upper for i in rows],
        initial_positions=[hardware.joints[i].initial_position for i in rows],
    )
    logic = JointGroupPositionController(name="arm", joints=joints)
    manager = builder.AddSystem(
        ControllerManager(
            hardware=hardware,
            update_rate=RATE,
            controllers=[ManagedController("arm", logic, stream=stream)],
        )
    )
    instance = robot.model_instance
    builder.Connect(plant.get_state_output_port(instance), manager.GetInputPort("state"))
    sequencer = builder.AddSystem(
        SinusoidSequencer(
            config=config,
            joint_names=names,
            controller_rate=RATE,
            initial_positions=joints.initial_positions,
            controller_ticks=stream,
        )
    )
    builder.Connect(sequencer.GetOutputPort("commands"), manager.GetInputPort("arm.commands"))
    desired = manager.GetOutputPort("desired_state")
    if stream:
        builder.Connect(
            sequencer.GetOutputPort("tick_count"), manager.GetInputPort("arm.command_count")
        )
        desired = AddStreamDesiredState(
            builder, hardware, names, sequencer.GetOutputPort("tick_command")
        )
    ConnectHardwareInterface(
        builder,
        plant,
        robot,
        hardware,
        desired_state=desired,
        effort=None,
        gravity_feedforward=True,
    )
    builder.ExportOutput(desired, "desired_state")
    view = AddJointStateVector(builder, plant, hardware, instance, hardware.joint_names)
    sink = builder.AddSystem(VectorLogSink(3 * len(names), 1.0 / RATE))
    builder.Connect(view, sink.get_input_port())
    return builder.Build(), manager, sink


@pytest.mark.parametrize(
    "config",
    [
        Sinusoid(frequency=0.5, amplitude=[0.3, 0.2, 0.1, 0.4]),
        Sinusoid(frequency=0.5, rate=37.0, start_delay=0.013),  # off the manager's ticks
    ],
    ids=["at-the-update-rate", "slower-and-delayed"],
)
def test_a_stream_drives_the_plant_as_the_manager_would_to_the_bit(config):
    """A stream controller is not updated by the manager, yet the plant sees the same
    desired state at every step (so the same motion and efforts, to the bit) and the
    controller reports the same status at any time."""
    runs = []
    for stream in (False, True):
        diagram, manager, sink = sinusoid_world(config, stream=stream)
        simulator = Simulator(diagram)
        context = simulator.get_mutable_context()
        trace = []
        for t in np.arange(0.0, 0.8, 0.0037):
            simulator.AdvanceTo(t)
            status = manager.GetOutputPort("arm.status").Eval(manager.GetMyContextFromRoot(context))
            trace.append((status, diagram.GetOutputPort("desired_state").Eval(context).tolist()))
        runs.append((trace, sink.FindLog(context).data().copy()))
    (messages, logged), (streamed, logged_stream) = runs
    assert streamed == messages
    np.testing.assert_array_equal(logged_stream, logged)
    assert messages[-1][0].state == "active" and messages[-1][0].accepted > 10


@pytest.mark.parametrize("stream", [False, True])
def test_a_manager_of_streams_only_has_no_update(stream):
    _, manager, _ = sinusoid_world(Sinusoid(), stream=stream)
    simulator = Simulator(manager)
    simulator.AdvanceTo(0.1)
    # Without events the simulator goes to 0.1 s in one step; with the update, in 5.
    assert simulator.get_num_steps_taken() == (1 if stream else 5)


def test_a_controller_that_takes_no_stream_is_refused_one():
    diagram, plant, robot, manager, _ = bare_world()
    hardware = manager._hardware
    joints = ControllerJoints.make(hardware.joint_names)
    logic = lookup("velocity_controllers/JointGroupVelocityController")(name="v", joints=joints)
    with pytest.raises(ValueError, match="'v' .*takes no command stream"):
        ControllerManager(
            hardware=hardware, update_rate=RATE, controllers=[ManagedController("v", logic, True)]
        )


def test_two_controllers_of_the_same_name_are_refused():
    with pytest.raises(ValueError, match=r"controllers \['arm'\] are given more than once"):
        bare_world(controllers=("position", "position"))


# ----------------------------------------------------------------------------------------
# The registry


def test_registry_knows_the_shipped_types_and_answers_by_message():
    assert registered_types() == (
        "joint_state_broadcaster/JointStateBroadcaster",
        "diff_drive_controller/DiffDriveController",
        "forward_command_controller/ForwardCommandController",
        "position_controllers/JointGroupPositionController",
        "velocity_controllers/JointGroupVelocityController",
        "effort_controllers/JointGroupEffortController",
        "joint_trajectory_controller/JointTrajectoryController",
        "vision_controllers/LookAtPointController",
        "vision_controllers/ImprovedLookAtPointController",
        "task_space_controllers/JointSpaceInverseDynamics",
        "task_space_controllers/OperationalSpaceInverseDynamics",
        "vision_controllers/JointSpaceLookAtController",
        "vision_controllers/OperationalSpaceLookAtController",
        "forward_command_controller/MultiInterfaceForwardCommandController",
        "pid_controller/PidController",
    )
    assert types_accepting(Float64MultiArray, "velocity") == (
        "forward_command_controller/ForwardCommandController",
        "velocity_controllers/JointGroupVelocityController",
        "forward_command_controller/MultiInterfaceForwardCommandController",
    )
    assert types_accepting(JointTrajectory) == (
        "joint_trajectory_controller/JointTrajectoryController",
        "task_space_controllers/JointSpaceInverseDynamics",
    )
    assert types_accepting(JointTrajectory, "position") == (
        "joint_trajectory_controller/JointTrajectoryController",
    )
    with pytest.raises(KeyError, match="unknown controller type 'x/Y'; supported: joint_state"):
        lookup("x/Y")


TOY_TYPE = "toy_controllers/ScaledPositionController"


@dataclasses.dataclass
class ScaledParameters:
    """The toy's parameters."""

    # The joints commanded, in command order.
    joints: list[str] = param([], nonempty=True, unique=True)
    # Factor applied to every commanded position [1].
    scale: float = param(1.0, unit="-", gt=0)


class ScaledPositionController(Controller):
    """A toy: writes scale * command to the position interface."""

    parameters = ScaledParameters
    message = Float64MultiArray
    topic = "scaled_commands"
    fixed_interface = "position"

    def update(self, now, message, memory, measure):
        if message is None:
            return memory
        try:
            if len(message.data) != self.n:
                raise Rejected(f"expected {self.n} values, got {len(message.data)}")
        except Rejected as rejection:
            return dataclasses.replace(memory, status=self.reject(memory.status, str(rejection)))
        q_d = np.clip(self.params.scale * np.asarray(message.data), self.lower, self.upper)
        status = self.accept(memory.status, "active", {})
        return ControllerMemory(np.concatenate([q_d, np.zeros(self.n)]), status)


@pytest.fixture
def toy_type():
    register(TOY_TYPE)(ScaledPositionController)
    yield ScaledPositionController
    unregister(TOY_TYPE)


TOY_YAML = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {{type: joint_state_broadcaster/JointStateBroadcaster}}
    toy: {{type: {type}}}
toy:
  ros__parameters:
    joints: [j0, j1, j2, j3]
    scale: {scale}
"""


def test_a_toy_controller_type_registered_here_runs_in_a_world(tmp_path, toy_type, caplog):
    path = tmp_path / "toy.yaml"
    path.write_text(TOY_YAML.format(type=TOY_TYPE, scale=0.5))
    scenario = load_scenario(
        "position",
        f"sequencer: null\nlogging: {{console_rate: 0}}\n"
        f"controllers: {{config: {path}, activate: [joint_state_broadcaster, toy]}}",
    )
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    assert world.diagram.HasInputPort("toy.scaled_commands")
    world.publish(context, "toy", Float64MultiArray(data=(0.8, -1.0, 1.2, 0.4)))
    simulator.AdvanceTo(3.0)
    np.testing.assert_allclose(world.joint_positions(context), [0.4, -0.5, 0.6, 0.2], atol=1e-4)
    with caplog.at_level(logging.ERROR, logger="armando_drake.control.controllers"):
        world.publish(context, "toy", Float64MultiArray(data=(0.1,)))
        simulator.AdvanceTo(3.1)
    assert world.status(context, "toy").last_error == "expected 4 values, got 1"
    assert [r.getMessage() for r in caplog.records] == ["toy: expected 4 values, got 1"]
    world.close()


def test_a_toy_controller_parameter_is_checked_with_its_key(tmp_path, toy_type):
    path = tmp_path / "toy.yaml"
    path.write_text(TOY_YAML.format(type=TOY_TYPE, scale=-2))
    with pytest.raises(ControllerConfigError) as error:
        load_controller_config(path)
    assert str(error.value) == f"{path}: toy.ros__parameters.scale: scale=-2.0 must be positive"
    path.write_text(TOY_YAML.format(type=TOY_TYPE, scale="fast"))
    with pytest.raises(ControllerConfigError, match=r"toy.ros__parameters.scale: .*'fast'"):
        load_controller_config(path)


def test_activate_by_type_finds_a_forward_command_controller_on_position(tmp_path):
    path = tmp_path / "forward.yaml"
    path.write_text(
        "controller_manager:\n  ros__parameters:\n"
        "    fwd: {type: forward_command_controller/ForwardCommandController}\n"
        "fwd:\n  ros__parameters: {joints: [j0, j1, j2, j3], interface_name: position}\n"
    )
    scenario = load_scenario(
        "position",
        "logging: {console_rate: 0}\n"
        f"controllers: {{config: {path}, activate: "
        "['type:position_controllers/JointGroupPositionController']}",
    )
    world = MakeWorld(scenario, quiet=True)
    assert list(world.robot().stack.controllers) == ["fwd"]
    assert world.robot().sequencer_target == "fwd"
    world.close()


# ----------------------------------------------------------------------------------------
# The update rate


def test_scenario_overrides_the_update_rate_of_the_yaml():
    scenario = load_scenario(
        "position",
        "logging: {console_rate: 0}\ncontrollers: {update_rate: 500}\nsimulation: {duration: 0.1}",
    )
    world = MakeWorld(scenario, quiet=True)
    assert world.robot().stack.update_rate == 500
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.1)
    log = world.robot().logger.GetLog(
        world.robot().logger.GetMyContextFromRoot(simulator.get_context())
    )
    np.testing.assert_allclose(np.diff(log.sample_times()), 0.002, atol=1e-12)
    world.close()


@pytest.mark.parametrize("rate", [-5, 2.5])
def test_a_bad_update_rate_override_is_named(rate):
    scenario = load_scenario("position", "logging: {console_rate: 0}")
    scenario.robots[ONE_ROBOT].controllers.update_rate = rate
    with pytest.raises(ScenarioError) as error:
        MakeWorld(scenario, quiet=True, source="position.yaml")
    assert str(error.value) == (
        f"position.yaml: controllers: update_rate={rate!r} must be a positive integer [Hz]"
    )
