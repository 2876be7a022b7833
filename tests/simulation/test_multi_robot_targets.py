"""In a world of several robots, each section names the robot it acts on and each robot
has its own sensors: a task-space motion on the second of two Armandos moves only that
one; two fra2mos each scan with their own lidar on /<namespace>/scan and broadcast their
odometry as <namespace>/odom -> <namespace>/base_footprint on /tf; a scenario camera on
the second Armando's link renders from there."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario
from armando_drake.tools.errors import ConfigError

PLANT = """plant_config:
  time_step: 0.001
  discrete_contact_approximation: lagged
  use_sampled_output_ports: false
logging: {console_rate: 0}
simulator_config: {target_realtime_rate: 0}
"""

ARMANDO = """  - name: {name}
    robot:
      description: ""
      xacro_args: {{use_camera: "false"}}
      base_xyz: [{x}, 0.0, 0.0313]
      base_rpy: [0.0, 0.0, {yaw}]
    actuators: {{gravity_feedforward: true}}
    controllers:
      activate: [joint_state_broadcaster, {controller}]
"""

OFFSET = np.array([0.03, 0.05, 0.04])  # [m] the task's
START = [0.3, 0.4, 0.9, 0.7]  # [rad] the right arm's start (the task's start_positions)
RIGHT_YAW = 3.1416  # [rad]


def _two_armandos(tmp_path, extra: str):
    """Two Armandos (left at x = -0.25 m holding its position controller, right at 0.25 m
    turned half a turn, on its trajectory controller) and ``extra`` keys."""
    robots = ARMANDO.format(name="left", x=-0.25, yaw=0.0, controller="position_controller")
    robots += ARMANDO.format(
        name="right", x=0.25, yaw=RIGHT_YAW, controller="trajectory_controller"
    )
    path = tmp_path / "two.yaml"
    path.write_text(f"robots:\n{robots}{extra}{PLANT}")
    return load_scenario(path)


def _tool(world, context, name: str) -> np.ndarray:
    """The position [m] of robot ``name``'s crawer_base in the world."""
    plant = world.robot().plant
    part = world.robots[name]
    frame = plant.GetFrameByName("crawer_base", part.robot.model_instance)
    plant_context = plant.GetMyContextFromRoot(context)
    return frame.CalcPoseInWorld(plant_context).translation()


@pytest.fixture(scope="module")
def task_on_right(tmp_path_factory):
    """2 s of a 1.5 s linear task-space motion of the right arm: (its tool point and both
    arms' joints at 0 and at the end)."""
    task = (
        "task:\n  robot: right\n  path: linear\n  offset: [0.03, 0.05, 0.04]\n"
        "  duration: 1.5\n  acceleration_time: 0.4\n  end_effector: crawer_base\n"
        f"  start_positions: {START}\n"
        "simulation: {duration: 2.0}\n"
    )
    world = MakeWorld(_two_armandos(tmp_path_factory.mktemp("task"), task), quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    context = simulator.get_context()
    before = {
        n: (_tool(world, context, n), world.joint_positions(context, n)) for n in ("left", "right")
    }
    simulator.AdvanceTo(2.0)
    after = {
        n: (_tool(world, context, n), world.joint_positions(context, n)) for n in ("left", "right")
    }
    yield world, before, after
    world.close(context)


def test_a_task_on_the_second_robot_moves_it_along_its_path(task_on_right):
    """The right arm starts at the task's start positions and its tool point ends 1 mm
    within the offset (the task's frame is the world's, as the arm model's base)."""
    world, before, after = task_on_right
    assert np.allclose(before["right"][1], START, atol=1e-9)
    moved = after["right"][0] - before["right"][0]
    assert np.linalg.norm(moved - OFFSET) < 1e-3, moved
    robots = world.robots
    assert robots["right"].task is not None and robots["left"].task is None


def test_a_task_on_the_second_robot_has_its_commands_in_the_table(task_on_right):
    """The trajectory the right arm's task sends is a row of the world's publication table,
    under the right robot's namespace (recorded, not published live), as any robot's."""
    world, _, _ = task_on_right
    task = world.robots["right"].task
    rows = [
        t
        for t in world.publications.topics
        if t.topic.endswith(task.topic) and t.direction == "publish"
    ]
    assert [(t.namespace, t.topic, t.recorded, t.live) for t in rows] == [
        ("right", f"{task.controller}/{task.topic}", True, False)
    ], rows


def test_a_task_on_the_second_robot_leaves_the_first_alone(task_on_right):
    """The left arm holds its zero start (no task start positions) within 1 mrad."""
    _, before, after = task_on_right
    assert np.allclose(before["left"][1], 0.0, atol=1e-9)
    assert np.abs(after["left"][1]).max() < 1e-3, after["left"][1]
    assert np.linalg.norm(after["left"][0] - before["left"][0]) < 1e-3


def test_a_section_naming_no_robot_is_one_line(tmp_path):
    with pytest.raises(ConfigError) as error:
        MakeWorld(_two_armandos(tmp_path, "task: {robot: middle}\n"), quiet=True)
    message = str(error.value)
    assert "\n" not in message, message
    assert "task.robot='middle': no such robot (listed: left, right)" in message, message


FRA2MO = """  - name: {name}
    robot:
      description: package://fra2mo_description/urdf/fra2mo.urdf.xacro
      base_xyz: [0.0, {y}, 0.1]
      base: auto
    controllers:
      activate: [joint_state_broadcaster]
"""
WALL = 1.0  # [m] the wall's face ahead of both (x), each lidar 1.0 m from it at the start


@pytest.fixture(scope="module")
def two_fra2mos(tmp_path_factory):
    """1 s recorded of two fra2mos side by side facing a wall, b driving 0.2 m/s towards
    it from 0.2 s: the bag's messages per topic."""
    from rosbags.highlevel import AnyReader

    folder = tmp_path_factory.mktemp("fra2mos")
    robots = FRA2MO.format(name="a", y=-0.5) + FRA2MO.format(name="b", y=0.5)
    robots += "    twist: {start_delay: 0.2, steps: [{linear: 0.2, angular: 0.0, duration: 1.0}]}\n"
    wall = "objects:\n  - {name: wall, shape: !Box {size: [0.1, 3.0, 1.0]}, "
    wall += f"xyz: [{WALL + 0.05}, 0.0, 0.5]}}\n"
    path = folder / "fra2mos.yaml"
    path.write_text(f"robots:\n{robots}{wall}{PLANT}")
    bag = folder / "fra2mos.mcap"
    world = MakeWorld(load_scenario(path), quiet=True, record=bag)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(1.0)
    world.close(simulator.get_context())
    topics: dict[str, list] = {}
    with AnyReader([bag]) as reader:
        for connection, _, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append(message)
    return topics


def _stamp(message) -> float:
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def test_each_fra2mo_scans_with_its_own_lidar(two_fra2mos):
    """/a/scan and /b/scan at 10 Hz, each in its own frame; a's range straight ahead stays
    1 m, b's shrinks by what b drove (its odometry nearest the scan's stamp) within 1 cm."""
    bag = two_fra2mos
    assert "/scan" not in bag
    for name in ("a", "b"):
        scans = bag[f"/{name}/scan"]
        assert len(scans) == 10 and scans[0].header.frame_id == f"{name}/laser_frame"
    first = bag["/a/scan"][0]
    ahead = int(np.argmin(np.abs(first.angle_min + first.angle_increment * np.arange(640))))
    assert all(abs(scan.ranges[ahead] - WALL) < 0.005 for scan in bag["/a/scan"])
    odom = bag["/b/odom"]
    for scan in bag["/b/scan"]:
        at = min(odom, key=lambda message: abs(_stamp(message) - _stamp(scan)))
        driven = at.pose.pose.position.x
        assert abs(scan.ranges[ahead] - (WALL - driven)) < 0.01, (scan.ranges[ahead], driven)
    assert bag["/b/scan"][-1].ranges[ahead] < WALL - 0.1


def test_each_fra2mos_odometry_frames_are_under_its_namespace(two_fra2mos):
    """/tf holds a/odom -> a/base_footprint and b/odom -> b/base_footprint (b's at b's
    /b/odom pose); each /<name>/odom message names the same frames."""
    bag = two_fra2mos
    pairs = {}
    for message in bag["/tf"]:
        for transform in message.transforms:
            pairs[(transform.header.frame_id, transform.child_frame_id)] = transform
    assert {("a/odom", "a/base_footprint"), ("b/odom", "b/base_footprint")} <= set(pairs)
    assert not any(frame == "odom" for frame, _ in pairs)
    last = bag["/b/odom"][-1]
    assert (last.header.frame_id, last.child_frame_id) == ("b/odom", "b/base_footprint")
    moved = pairs[("b/odom", "b/base_footprint")].transform.translation.x
    assert moved == pytest.approx(last.pose.pose.position.x, abs=1e-9) and moved > 0.1
    assert abs(pairs[("a/odom", "a/base_footprint")].transform.translation.x) < 1e-3


def test_a_camera_on_the_second_robots_link_renders_from_there(tmp_path):
    """Two scenario cameras of one pose, 0.12 m along +y of a base_link looking that way:
    on right::base_link (turned half a turn: it looks along the world's -y) it sees the
    wall whose face is at y = -1 m, 0.88 m away; on the bare base_link (the first
    robot's, left) it looks along +y at nothing. Each sensor is on its robot's body."""
    camera = "{{name: {name}, link: '{link}', xyz: [0.0, 0.12, 0.05], rpy: [0.0, 0.0, 1.5708], "
    camera += "width: 32, height: 24, far: 5.0, type: rgbd_camera}}"
    extra = "cameras:\n"
    extra += f"  - {camera.format(name='on_right', link='right::base_link')}\n"
    extra += f"  - {camera.format(name='on_left', link='base_link')}\n"
    extra += "objects:\n  - {name: wall, shape: !Box {size: [3.0, 0.1, 1.0]}, "
    extra += "xyz: [0.0, -1.05, 0.5]}\nsimulation: {duration: 0.1}\n"
    world = MakeWorld(_two_armandos(tmp_path, extra), quiet=True)
    context = world.diagram.CreateDefaultContext()
    depth = {
        name: world.diagram.GetOutputPort(f"{name}.depth_image").Eval(context).data[..., 0]
        for name in ("on_right", "on_left")
    }
    centre = depth["on_right"][12, 16]
    assert abs(centre - 0.88) < 0.005, centre
    ahead = depth["on_left"][12, 16]  # the ground only in its lower rows
    assert not np.isfinite(ahead) or ahead >= 5.0, ahead
    plant = world.robot().plant
    for name, part in (("on_right", world.robots["right"]), ("on_left", world.robots["left"])):
        body = plant.GetBodyByName("base_link", part.robot.model_instance)
        sensor = part.cameras[name].sensor
        assert sensor.default_parent_frame_id() == plant.GetBodyFrameIdOrThrow(body.index())
    world.close(context)


def test_a_camera_on_an_unknown_robot_is_one_line(tmp_path):
    extra = "cameras: [{name: c, link: 'middle::base_link'}]\n"
    with pytest.raises(ConfigError) as error:
        MakeWorld(_two_armandos(tmp_path, extra), quiet=True)
    message = str(error.value)
    assert "\n" not in message, message
    assert "link 'middle::base_link': no robot 'middle' (robots: left, right)" in message, message


def test_each_robots_description_camera_is_added(tmp_path):
    """Two Armandos with their camera stands (use_camera) and camera: {enabled: true}:
    each robot's camera is <robot>_<camera> on /<robot>/<topic>, on its own robot's link,
    and is that robot's (world.robots[name].cameras)."""
    scenario = _two_armandos(tmp_path, "camera: {enabled: true, depth: false}\n")
    for entry in scenario.robots.values():
        entry.robot.xacro_args["use_camera"] = "true"
    world = MakeWorld(scenario, quiet=True)
    (first,) = world.robots["left"].cameras.values()
    (second,) = world.robots["right"].cameras.values()
    described = world.robot().robot.cameras[0]  # the description's own camera block
    topic = (described.topic or described.name).strip("/")
    assert (first.info.name, first.info.topic) == (f"left_{described.name}", f"/left/{topic}")
    assert (second.info.name, second.info.topic) == (f"right_{described.name}", f"/right/{topic}")
    plant = world.robot().plant
    for camera, part in ((first, world.robots["left"]), (second, world.robots["right"])):
        body = plant.GetBodyByName(camera.info.link, part.robot.model_instance)
        assert camera.sensor.default_parent_frame_id() == plant.GetBodyFrameIdOrThrow(body.index())
    world.close(world.diagram.CreateDefaultContext())


# [m, rad] the right arm's crawer_base in the world at j = [0.4, 0.5, 0.8, 0.3]
RIGHT_TARGET = [0.162058286, 0.200449878, 0.243495052, 1.6, 0.0, -2.741585307]


def test_the_learned_ik_on_the_second_robot_reaches_its_world_target(tmp_path):
    """learned_ik: {robot: right}: the right arm's gripper reaches the world target within
    1 mm in 2 s (the network's answer in the right arm's base frame); the left arm is
    not commanded."""
    pytest.importorskip("onnxruntime")
    extra = (
        "learned_ik:\n  robot: right\n  network: models/learned_ik/armando_ik_network.onnx\n"
        f"  targets: [{RIGHT_TARGET}]\n  period: 2.0\nsimulation: {{duration: 2.0}}\n"
    )
    robots = ARMANDO.format(name="left", x=-0.25, yaw=0.0, controller="position_controller")
    robots += ARMANDO.format(name="right", x=0.25, yaw=RIGHT_YAW, controller="position_controller")
    path = tmp_path / "learned.yaml"
    path.write_text(f"robots:\n{robots}{extra}{PLANT}")
    world = MakeWorld(load_scenario(path), quiet=True)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(2.0)
    context = simulator.get_context()
    error = np.linalg.norm(_tool(world, context, "right") - RIGHT_TARGET[:3])
    assert error < 1e-3, error
    assert np.abs(world.joint_positions(context, "left")).max() < 1e-3
    assert world.robots["right"].learned_ik is not None
    world.close(context)


def test_a_navigation_on_the_second_fra2mo_drives_it_and_publishes_under_its_namespace(tmp_path):
    """navigation: {robot: b}: b drives to a goal 0.8 m ahead (within the goal checker's
    0.1 m) while a stays; the map and plan are on /b/map and /b/plan, map -> b/odom and
    map -> b/ahead on /tf, the goal listened for on b/goal_pose; Meshcat draws the plan
    under /drake/navigation/b; summary's navigation is b's."""
    from pydrake.geometry import Meshcat
    from rosbags.highlevel import AnyReader

    robots = FRA2MO.format(name="a", y=-0.6) + FRA2MO.format(name="b", y=0.6)
    navigation = (
        "navigation:\n  robot: b\n"
        "  params_file: package://fra2mo_description/config/navigation.yaml\n"
        "  map: ''\n  start_delay: 0.3\n  localization: ground_truth\n"
        "  goals: [{name: ahead, x: 0.8, y: 0.6, yaw: 0.0}]\n"
    )
    walls = "objects:\n"  # a 4 m x 4 m pen: the map of the world's true occupancy
    for k, (x, y, sx, sy) in enumerate(
        [(2, 0, 0.1, 4), (-2, 0, 0.1, 4), (0, 2, 4, 0.1), (0, -2, 4, 0.1)]
    ):
        box = f"!Box {{size: [{sx}, {sy}, 0.5]}}"
        walls += f"  - {{name: wall{k}, shape: {box}, xyz: [{x}, {y}, 0.25]}}\n"
    path = tmp_path / "nav_b.yaml"
    path.write_text(f"robots:\n{robots}{navigation}{walls}{PLANT}")
    bag = tmp_path / "nav_b.mcap"
    meshcat = Meshcat()
    world = MakeWorld(load_scenario(path), quiet=True, record=bag, meshcat=meshcat)
    assert world.robots["a"].navigation is None and world.robots["b"].navigation is not None
    names = {topic.name for topic in world.publications.published(recorded=True)}
    assert {"/b/map", "/b/plan"} <= names and not {"/map", "/plan"} & names, names
    subscribed = {topic.name for topic in world.publications.subscribed()}
    assert "b/goal_pose" in subscribed, subscribed
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(8.0)
    context = simulator.get_context()
    plant = world.plant
    pose = {
        name: plant.EvalBodyPoseInWorld(
            plant.GetMyContextFromRoot(context),
            plant.GetBodyByName("base_footprint", world.robots[name].robot.model_instance),
        ).translation()
        for name in ("a", "b")
    }
    assert np.hypot(pose["b"][0] - 0.8, pose["b"][1] - 0.6) < 0.1, pose["b"]
    assert np.hypot(pose["a"][0], pose["a"][1] + 0.6) < 0.01, pose["a"]
    assert meshcat.HasPath("/drake/navigation/b/plan")
    assert not meshcat.HasPath("/drake/navigation/plan")
    world.close(context)
    frames = set()
    with AnyReader([bag]) as reader:
        topics = {connection.topic for connection in reader.connections}
        for connection, _, raw in reader.messages():
            if connection.topic in ("/tf", "/tf_static"):
                message = reader.deserialize(raw, connection.msgtype)
                frames |= {(t.header.frame_id, t.child_frame_id) for t in message.transforms}
    assert {"/b/map", "/b/plan"} <= topics and "/map" not in topics, topics
    assert {("map", "b/odom"), ("map", "b/ahead")} <= frames, frames
