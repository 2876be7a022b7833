"""Each subsystem alone, in a bare DiagramBuilder with a plant and its own config section,
without MakeWorld: what it adds, what it returns, and what that does, in numbers."""

import logging
from pathlib import Path

import numpy as np
import pytest
from pydrake.geometry import Meshcat, Role
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.visualization import VisualizationConfig

from armando_drake.control.sequencer import AddSequencer, PositionTargets
from armando_drake.control.stack import (
    ActuatorConfig,
    AddControllerManager,
    AddHardware,
    ConnectControlStack,
    ControllersConfig,
    ExportFreeControllerPorts,
    LoadControllerConfig,
)
from armando_drake.control.topics import RegisterSentCommands
from armando_drake.description.loader import load_robot
from armando_drake.kinematics.motion import TaskSpaceMotion
from armando_drake.messages.publications import PublicationRegistry
from armando_drake.messages.types import Float64MultiArray, Publication
from armando_drake.outputs.config import LoggingConfig
from armando_drake.outputs.logger import AddJointStateLogger, read_joint_states
from armando_drake.outputs.recording import AddRosbagRecorder
from armando_drake.outputs.replay import AddVisualization
from armando_drake.perception.add import AddPerception
from armando_drake.perception.config import PerceptionConfig
from armando_drake.ros2.bridge import AddRos2Bridge, BridgeRobot
from armando_drake.ros2.config import Ros2Config
from armando_drake.sensors.cameras import AddCameras
from armando_drake.sensors.config import CameraSettings
from armando_drake.sensors.objects import AddGround
from armando_drake.task.reference import AddTask
from armando_drake.teleop.config import JogConfig
from armando_drake.teleop.jog import AddJog
from armando_drake.tools.errors import ScenarioError
from armando_drake.vision.add import AddDetectors
from armando_drake.vision.config import ArucoDetectorConfig, VisionConfig

POSITION = ["joint_state_broadcaster", "position_controller"]
TARGET = [0.6, -0.4, 0.5, 0.3]  # [rad] Armando's j0..j3, inside their limits


def armando(
    builder, activate=POSITION, *, sequencer=None, ground=True, start=None, publications=None
):
    """Armando's plant, hardware interface and controller manager, as MakeWorld adds them
    (the description's own controller YAML; its topics registered in ``publications``);
    (plant, scene_graph, stack)."""
    config = MultibodyPlantConfig(time_step=0.001, discrete_contact_approximation="lagged")
    plant, scene_graph = AddMultibodyPlant(config, builder)
    robot = load_robot(plant)
    if ground:
        AddGround(plant, scene_graph)
    controllers = ControllersConfig(activate=list(activate))
    yaml = LoadControllerConfig(controllers, robot)
    starts = [(start, "", "task.start_positions")] if start is not None else []
    hardware = AddHardware(
        plant, scene_graph, robot, ActuatorConfig(), yaml, start_positions=starts
    )
    stack = AddControllerManager(
        builder,
        controllers,
        plant=plant,
        robot=robot,
        hardware=hardware,
        controller_config=yaml,
        update_rate=yaml.update_rate,
        sequencer=sequencer,
        publications=publications,
    )
    return plant, scene_graph, stack


def positions(stack, context) -> np.ndarray:
    plant = stack.plant
    q = plant.GetPositions(plant.GetMyContextFromRoot(context), stack.robot.model_instance)
    return q[stack.hardware.position_index]


def test_the_control_stack_alone_moves_the_arm_to_a_published_target():
    builder = DiagramBuilder()
    _, _, stack = armando(builder)
    assert list(stack.controllers) == ["position_controller"]
    assert stack.broadcaster_name == "joint_state_broadcaster"
    feedforward = ConnectControlStack(builder, stack, gravity_feedforward=True)
    assert feedforward is not None
    ExportFreeControllerPorts(builder, stack)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_context()
    diagram.GetInputPort("position_controller.commands").FixValue(
        context, Publication(1, Float64MultiArray(data=tuple(TARGET)), 0.0)
    )
    simulator.AdvanceTo(3.0)
    assert np.abs(positions(stack, context) - TARGET).max() < 0.01
    status = diagram.GetOutputPort("position_controller.status").Eval(context)
    assert status.accepted == 1 and status.rejected == 0


def test_an_unknown_controller_to_activate_is_one_line_naming_it():
    with pytest.raises(ScenarioError, match=r"activate names 'nope', which .* does not define"):
        armando(DiagramBuilder(), ["joint_state_broadcaster", "nope"])


def test_the_sequencer_alone_drives_its_controller_through_the_targets():
    builder = DiagramBuilder()
    config = PositionTargets(targets=[TARGET, [0.0, 0.0, 0.0, 0.0]], period=2.0)
    _, _, stack = armando(builder, sequencer=config)
    published = []
    sequencer, target = AddSequencer(
        builder, config, stack, commands_log=lambda joints: lambda *row: published.append(row)
    )
    assert target == "position_controller"
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    simulator = Simulator(builder.Build())
    context = simulator.get_context()
    simulator.AdvanceTo(1.9)
    assert np.abs(positions(stack, context) - TARGET).max() < 0.01
    simulator.AdvanceTo(3.9)
    assert np.abs(positions(stack, context)).max() < 0.01
    assert len(published) == 2  # one command per target


def test_the_logger_alone_writes_a_row_per_controller_tick(tmp_path):
    builder = DiagramBuilder()
    _, _, stack = armando(builder)
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    logger = AddJointStateLogger(builder, LoggingConfig(console_rate=0), stack, output_dir=tmp_path)
    simulator = Simulator(builder.Build())
    context = simulator.get_context()
    simulator.AdvanceTo(1.0)
    logger.flush(logger.GetMyContextFromRoot(context))
    logger.close()
    states = read_joint_states(tmp_path / "joint_states.csv")
    assert len(states.times) == 101  # 100 Hz from 0 to 1 s
    assert states.times[-1] == pytest.approx(1.0)
    # The arm holds its initial pose: the logged positions are the plant's.
    assert np.abs(states.position[-1] - positions(stack, context)).max() < 1e-3


def test_no_broadcaster_no_logger():
    builder = DiagramBuilder()
    _, _, stack = armando(builder, ["position_controller"])
    assert AddJointStateLogger(builder, LoggingConfig(), stack) is None


def test_the_task_alone_publishes_its_joint_trajectory_once():
    builder = DiagramBuilder()
    start = [0.0, 0.6, 0.6, 0.3]  # [rad] away from the upright singular pose
    _, _, stack = armando(
        builder, ["joint_state_broadcaster", "trajectory_controller"], start=start
    )
    motion = TaskSpaceMotion(offset=[0.0, 0.0, -0.02], duration=1.0, acceleration_time=0.2)
    task = AddTask(builder, motion, stack)
    assert task.controller == "trajectory_controller" and task.topic == "joint_trajectory"
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    ExportFreeControllerPorts(builder, stack)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_context()
    path = task.trajectory.reference(np.array([0.0, motion.duration]))[:, 4:7]
    assert path[1] - path[0] == pytest.approx([0.0, 0.0, -0.02], abs=1e-9)
    simulator.AdvanceTo(1.5)
    status = diagram.GetOutputPort("trajectory_controller.status").Eval(context)
    assert status.accepted == 1
    task.arm.set_state(positions(stack, context))
    reached = np.array(task.arm.pose().translation())
    assert np.abs(reached - path[1]).max() < 1e-3  # the end of the path, within 1 mm


def test_the_task_needs_a_controller_that_takes_it():
    builder = DiagramBuilder()
    _, _, stack = armando(builder)  # a position controller only
    with pytest.raises(ScenarioError, match="task needs an active controller"):
        AddTask(builder, TaskSpaceMotion(offset=[0.0, 0.0, -0.02]), stack)


def test_the_jog_alone_publishes_on_the_free_position_controller(caplog):
    builder = DiagramBuilder()
    _, _, stack = armando(builder)
    with caplog.at_level(logging.WARNING, logger="armando_drake.world"):
        assert AddJog(builder, JogConfig(cartesian=False), stack, meshcat=None) is None
    assert "no Meshcat" in caplog.text
    meshcat = Meshcat()
    jog = AddJog(builder, JogConfig(cartesian=False), stack, meshcat=meshcat)
    assert jog.controller == "position_controller"
    assert builder.IsConnectedOrExported(stack.command_input("position_controller"))
    jog.delete_controls()


def test_the_cameras_alone_render_at_their_size(tmp_path):
    builder = DiagramBuilder()
    plant, scene_graph, stack = armando(builder)
    settings = CameraSettings(enabled=True, depth=True, renderer="vtk")
    cameras, view = AddCameras(
        builder, settings, plant=plant, scene_graph=scene_graph, robots={"robot": stack.robot}
    )
    assert view is None  # no live view asked for, no Meshcat
    assert cameras, "Armando's description mounts a camera"
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    for name, camera in cameras.items():
        image = diagram.GetOutputPort(f"{name}.color_image").Eval(context)
        assert (image.width(), image.height()) == (camera.info.width, camera.info.height)
        depth = diagram.GetOutputPort(f"{name}.depth_image").Eval(context)
        finite = np.isfinite(depth.data)
        assert finite.any()  # it sees the ground slab at least


def test_the_ground_alone_is_a_collision_slab_the_cameras_see_and_meshcat_does_not():
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.001), builder)
    AddGround(plant, scene_graph)
    plant.Finalize()
    inspector = scene_graph.model_inspector()
    roles = {
        role: [
            g for g in inspector.GetAllGeometryIds(role) if inspector.GetName(g).endswith("ground")
        ]
        for role in (Role.kProximity, Role.kPerception, Role.kIllustration)
    }
    assert len(roles[Role.kProximity]) == 1 and len(roles[Role.kPerception]) == 1
    assert roles[Role.kIllustration] == []
    (collision,) = roles[Role.kProximity]
    box = inspector.GetShape(collision)
    assert (box.width(), box.depth(), box.height()) == (2.0, 2.0, 0.05)
    X_WG = inspector.GetPoseInFrame(collision)
    assert X_WG.translation()[2] == pytest.approx(-0.025)  # top face at z = 0


def test_the_visualization_alone_samples_the_state_for_the_replay():
    builder = DiagramBuilder()
    plant, scene_graph, stack = armando(builder)
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    sampler = AddVisualization(
        builder,
        VisualizationConfig(),
        plant=plant,
        scene_graph=scene_graph,
        meshcat=Meshcat(),
        robot_instances=[stack.robot.model_instance],
        ground=True,
    )
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.5)
    times, states = sampler.frames()
    assert times[0] == 0.0 and times[-1] == pytest.approx(0.5, abs=sampler.interval)
    assert states.shape == (len(times), plant.num_multibody_states())


def test_the_stack_registers_its_joint_states_and_command_inputs():
    builder = DiagramBuilder()
    publications = PublicationRegistry()
    _, _, stack = armando(builder, publications=publications)
    assert stack.update_rate == 100 and stack.broadcaster is stack.manager
    table = publications.table()
    (joint_states,) = table.published(recorded=True)
    assert joint_states.name == "joint_states" and joint_states.rate == stack.update_rate
    assert joint_states.port is stack.manager.GetOutputPort("joint_states")
    assert [t.key for t in table.subscribed()] == ["position_controller.commands"]


def _armando_with_camera(builder):
    """Armando with its description's camera (VTK, depth on), as AddCameras adds it."""
    plant, scene_graph, stack = armando(builder)
    settings = CameraSettings(enabled=True, depth=True, renderer="vtk")
    cameras, _ = AddCameras(
        builder, settings, plant=plant, scene_graph=scene_graph, robots={"robot": stack.robot}
    )
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    return plant, stack, cameras


def test_perception_alone_makes_world_points_of_the_cameras_depth():
    builder = DiagramBuilder()
    _, _, cameras = _armando_with_camera(builder)
    added = AddPerception(builder, PerceptionConfig(rate=10.0), cameras=cameras)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.15)
    cloud = added.points_in_world.Eval(
        added.points_in_world.get_system().GetMyContextFromRoot(simulator.get_context())
    )
    xyz = cloud.xyzs()[:, np.isfinite(cloud.xyzs()).all(axis=0)]
    assert xyz.shape[1] > 1000
    # The camera sees the ground slab: points at z = 0 within the slab's 2 m x 2 m.
    on_ground = np.abs(xyz[2]) < 2e-3
    assert on_ground.sum() > 100
    assert np.abs(xyz[:2, on_ground]).max() <= 1.0 + 1e-3


def test_perception_needs_a_camera_named_in_its_config():
    builder = DiagramBuilder()
    _, _, cameras = _armando_with_camera(builder)
    with pytest.raises(ScenarioError, match=r"camera='nope' is not a camera of the world"):
        AddPerception(builder, PerceptionConfig(camera="nope"), cameras=cameras)


def test_the_detectors_alone_watch_their_camera_and_feed_no_controller_without_a_target():
    pytest.importorskip("cv2", reason="the vision extra (opencv-python-headless)")
    builder = DiagramBuilder()
    _, stack, cameras = _armando_with_camera(builder)
    name = next(iter(cameras))
    with pytest.raises(ScenarioError, match=r"vision.aruco.camera='nope' is not a camera"):
        AddDetectors(
            builder, VisionConfig(aruco=ArucoDetectorConfig(camera="nope")), stack, cameras=cameras
        )
    added = AddDetectors(
        builder, VisionConfig(aruco=ArucoDetectorConfig(camera=name)), stack, cameras=cameras
    )
    assert added.aruco_camera == name and added.driven == []  # no look-at controller
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.2)
    published = diagram.GetOutputPort(f"{name}.cam_T_marker").Eval(simulator.get_context())
    assert added.aruco.frames >= 6 and published.count == 0  # frames seen, no marker in view


def read_bag(path: Path) -> dict[str, list]:
    """The messages of each topic, read back with rosbags (not the writer's library)."""
    from rosbags.highlevel import AnyReader  # a test dependency

    topics: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for connection, log_time, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append((log_time, message))
    return topics


def test_the_recorder_alone_writes_the_joint_states_and_the_commands(tmp_path):
    builder = DiagramBuilder()
    config = PositionTargets(targets=[TARGET], period=1.0)
    publications = PublicationRegistry()
    _, _, stack = armando(builder, sequencer=config, publications=publications)
    sequencer, target = AddSequencer(builder, config, stack)
    RegisterSentCommands(publications, stack, sequencer=sequencer, target=target)
    ConnectControlStack(builder, stack, gravity_feedforward=True)
    recorder = AddRosbagRecorder(builder, tmp_path / "run.mcap", publications.table())
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.5)
    recorder.close()
    bag = read_bag(tmp_path / "run.mcap")
    assert len(bag["/joint_states"]) == 51  # 100 Hz from 0 to 0.5 s
    ((_, command),) = bag["/position_controller/commands"]
    assert list(command.data) == pytest.approx(TARGET)


def test_the_bridge_alone_subscribes_the_free_command_inputs():
    pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds)")
    builder = DiagramBuilder()
    publications = PublicationRegistry()
    _, _, stack = armando(builder, publications=publications)
    table, robots = publications.table(), [BridgeRobot(stack)]
    assert AddRos2Bridge(builder, Ros2Config(), table, robots) is None  # off: nothing added
    bridge = AddRos2Bridge(builder, Ros2Config(enabled=True, domain_id=71), table, robots)
    try:
        assert [c.port for c in bridge.commands] == ["position_controller.commands"]
        assert builder.IsConnectedOrExported(stack.command_input("position_controller"))
    finally:
        bridge.close()
