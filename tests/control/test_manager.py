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
    ParameterError,
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
    ControllerManager,
    ManagedController,
)
from armando_drake.control.messages import (
    Float64MultiArray,
    JointTrajectory,
    Publication,
)
from armando_drake.description.loader import load_robot
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario

RATE = 50  # [Hz]


def bare_world(controllers=("position",)):
    """Armando on a plant with the manager: a broadcaster and a position controller."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=0.001, discrete_contact_approximation="lagged"), builder
    )
    robot = load_robot(plant)
    hardware = AddHardwareInterface(plant, robot, kp=8.0, kd=0.4)
    plant.Finalize()
    FinishHardwareInterface(plant, robot, hardware)
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
    builder.Connect(view.GetOutputPort("joint_states"), sink.get_input_port())
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


def test_two_controllers_of_the_same_name_are_refused():
    with pytest.raises(ValueError, match=r"controllers \['arm'\] are given more than once"):
        bare_world(controllers=("position", "position"))


# ----------------------------------------------------------------------------------------
# The registry


def test_registry_knows_the_shipped_types_and_answers_by_message():
    assert registered_types() == (
        "joint_state_broadcaster/JointStateBroadcaster",
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
    )
    assert types_accepting(Float64MultiArray, "velocity") == (
        "forward_command_controller/ForwardCommandController",
        "velocity_controllers/JointGroupVelocityController",
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
    joints: list[str] = dataclasses.field(default_factory=list)
    # Factor applied to every commanded position [1].
    scale: float = 1.0

    def check(self, raw):
        if not self.scale > 0:
            raise ParameterError("scale", f"scale={self.scale!r} must be > 0")


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
    assert str(error.value) == f"{path}: toy.ros__parameters.scale: scale=-2.0 must be > 0"
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
    assert list(world.controllers) == ["fwd"]
    assert world.sequencer_target == "fwd"
    world.close()


# ----------------------------------------------------------------------------------------
# The update rate


def test_scenario_overrides_the_update_rate_of_the_yaml():
    scenario = load_scenario(
        "position",
        "logging: {console_rate: 0}\ncontrollers: {update_rate: 500}\nsimulation: {duration: 0.1}",
    )
    world = MakeWorld(scenario, quiet=True)
    assert world.update_rate == 500
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.1)
    log = world.logger.GetLog(world.logger.GetMyContextFromRoot(simulator.get_context()))
    np.testing.assert_allclose(np.diff(log.sample_times()), 0.002, atol=1e-12)
    world.close()


@pytest.mark.parametrize("rate", [-5, 2.5])
def test_a_bad_update_rate_override_is_named(rate):
    scenario = load_scenario("position", "logging: {console_rate: 0}")
    scenario.controllers.update_rate = rate
    with pytest.raises(ScenarioError) as error:
        MakeWorld(scenario, quiet=True, source="position.yaml")
    assert str(error.value) == (
        f"position.yaml: controllers: update_rate={rate!r} must be a positive integer [Hz]"
    )
