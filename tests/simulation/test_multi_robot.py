"""Several robots in one world (a scenario's robots:): two Armandos facing each other
(diagrams/dual_armando.yaml), the two meeting at one point (diagrams/dual_armando_meet.yaml),
Armando mounted on fra2mo (diagrams/fra2mo_armando.yaml), and the one-line errors of a
robots: list."""

import dataclasses as dc
import io
import json

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame
from pydrake.systems.analysis import Simulator

from armando_drake.description.loader import AddRobot
from armando_drake.kinematics.arm import ArmModel
from armando_drake.kinematics.inverse_kinematics import solve_ik
from armando_drake.outputs.logger import read_joint_states
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.run import run
from armando_drake.simulation.scenario import load_scenario
from armando_drake.tools.errors import ConfigError

QUIET = "logging: {console_rate: 0}\nsimulator_config: {target_realtime_rate: 0}"
TOLERANCE = 0.01  # [rad] the targets reached


@pytest.fixture(scope="module")
def dual(tmp_path_factory):
    """One run of dual_armando.yaml with an output folder: (its folder, its summary,
    its result)."""
    out = tmp_path_factory.mktemp("dual")
    scenario = load_scenario("dual_armando", QUIET)
    result = run(
        scenario,
        scenario_name="dual_armando.yaml",
        output_dir=out,
        quiet=True,
        stream=io.StringIO(),
        replay=False,
        plots=False,
    )
    return out, json.loads((out / "summary.json").read_text()), result, scenario


def test_each_armando_follows_its_own_targets(dual):
    """Each arm reaches each of its own targets within 0.01 rad, and its section of
    summary.json lists its own targets (the two sequences differ)."""
    _, summary, _, scenario = dual
    robots = summary["robots"]
    assert list(robots) == ["left", "right"]
    for name, entry in scenario.robots.items():
        section = robots[name]
        assert section["namespace"] == f"/{name}"
        assert section["model_instance"] == f"{name}::armando"
        assert [step["target"] for step in section["steps"]] == entry.sequencer.targets
        assert section["max_final_error"] <= TOLERANCE, section["max_final_error"]
        for step in section["steps"]:
            assert step["final_error"] <= TOLERANCE, step
            assert step["settling_time"] is not None and step["settling_time"] < 1.0, step
    assert robots["left"]["steps"][1]["target"] != robots["right"]["steps"][1]["target"]


def test_each_armando_logs_its_own_joint_states_to_the_end(dual):
    """<output>/left/joint_states.csv and <output>/right/joint_states.csv: a row per
    controller tick from 0 to the end, each ending at its own last target."""
    out, summary, _, scenario = dual
    assert not (out / "joint_states.csv").exists()
    for name, entry in scenario.robots.items():
        states = read_joint_states(out / name / "joint_states.csv")
        assert states.joint_names == ["j0", "j1", "j2", "j3"]
        assert states.times[0] == 0.0 and abs(states.times[-1] - summary["sim_time"]) < 1e-9
        assert np.all(np.diff(states.times) > 0)
        rate = (len(states.times) - 1) / states.times[-1]
        assert abs(rate - 100.0) < 1.0, rate  # Armando's controllers' update rate
        last = np.array(entry.sequencer.targets[-1])
        assert np.abs(states.position[-1] - last).max() <= TOLERANCE
        assert (out / name / "commands.csv").is_file()


def test_the_effective_scenario_of_two_robots_loads_back(dual):
    """scenario.yaml keeps the robots: list (each with the gains that ran) and loads."""
    out, _, _, _ = dual
    again = load_scenario(out / "scenario.yaml")
    assert list(again.robots) == ["left", "right"]
    assert again.robots["left"].actuators.kp == 8.0  # Armando's servos


def test_two_robots_have_their_own_ports_and_model_instances():
    """Two robots of one URDF: two model instances; every port under its namespace."""
    world = MakeWorld(load_scenario("dual_armando", QUIET), quiet=True)
    plant = world.plant
    names = [plant.GetModelInstanceName(p.robot.model_instance) for p in world.robots.values()]
    assert names == ["left::armando", "right::armando"]
    outputs = {
        world.diagram.get_output_port(i).get_name() for i in range(world.diagram.num_output_ports())
    }
    for space in ("left", "right"):
        for port in ("joint_states", "desired_state", "position_controller.status"):
            assert f"{space}/{port}" in outputs
    assert "joint_states" not in outputs
    world.close()


@pytest.fixture(scope="module")
def mounted():
    """Armando on fra2mo driven along its short path, sampled every 0.25 s: (times, the
    arm's base_link poses, fra2mo's base_link poses, the arm's positions at each target's
    end, the world)."""
    world = MakeWorld(load_scenario("fra2mo_armando", QUIET), quiet=True)
    plant = world.plant
    arm, base = (world.robot(name).robot for name in ("armando", "fra2mo"))
    arm_frame = plant.GetFrameByName("base_link", arm.model_instance)
    base_frame = plant.GetFrameByName("base_link", base.model_instance)
    simulator = Simulator(world.diagram)
    context = simulator.get_context()
    plant_context = plant.GetMyContextFromRoot(context)
    times, arm_poses, base_poses, reached = [], [], [], []
    for t in np.arange(0.0, 4.5 + 1e-9, 0.25):
        simulator.AdvanceTo(t)
        times.append(t)
        arm_poses.append(arm_frame.CalcPoseInWorld(plant_context))
        base_poses.append(base_frame.CalcPoseInWorld(plant_context))
        if abs(t - 1.5) < 1e-9 or abs(t - 3.0) < 1e-9 or abs(t - 4.5) < 1e-9:
            reached.append(world.joint_positions(context, "armando"))
    world.close(context)
    return times, arm_poses, base_poses, reached, world


def test_the_mounted_arm_reaches_its_targets_while_the_base_drives(mounted):
    """Each of the arm's targets within 0.01 rad at the end of its 1.5 s, while fra2mo
    drives 0.3 m straight and turns."""
    _, _, base_poses, reached, world = mounted
    targets = world.robot("armando").sequencer.config.targets
    assert len(reached) == len(targets) == 3
    for target, q in zip(targets, reached, strict=True):
        assert np.abs(q - np.array(target)).max() <= TOLERANCE, (target, q)
    travelled = np.linalg.norm(base_poses[-1].translation()[:2] - base_poses[0].translation()[:2])
    assert travelled > 0.35, travelled


def test_the_mounted_arm_rides_with_fra2mo(mounted):
    """The arm's base_link stays where it is welded on fra2mo's base_link (0.1613 m above
    it, within 1 um and 1e-6 rad) while both move through the world."""
    _, arm_poses, base_poses, _, _ = mounted
    for X_WA, X_WB in zip(arm_poses, base_poses, strict=True):
        X_BA = X_WB.inverse() @ X_WA
        assert np.abs(X_BA.translation() - [0.0, 0.0, 0.1613]).max() < 1e-6
        assert np.abs(X_BA.rotation().matrix() - np.eye(3)).max() < 1e-6
    moved = np.linalg.norm(arm_poses[-1].translation() - arm_poses[0].translation())
    assert moved > 0.35, moved


@pytest.mark.parametrize(
    ("override", "reason"),
    [
        ("sequencer: !PositionTargets {}", "sequencer: a key of the one robot, beside robots:"),
        ("actuators: {kp: 3.0}", "actuators: a key of the one robot, beside robots:"),
        ("robots: [{name: a}, {name: a}]", "robots.1.name='a' is listed twice"),
        (
            "robots: [{name: a, namespace: /b}, {name: b}]",
            "robots.b.namespace='/b' is another robot's too",
        ),
        (
            "robots: [{name: a, parent: 'zz::base_link'}]",
            "robots.a.parent='zz::base_link': no robot 'zz' is listed before 'a'",
        ),
        (
            "robots: [{name: a}, {name: b, parent: 'a::nolink'}]",
            "robots.b.parent='a::nolink': robot 'a' has no link 'nolink' (links: base_link,",
        ),
        ("robots: [{name: '1a'}]", "robots.0.name='1a': give a name"),
        ("robots: [{name: a, actuators: {kp: -1}}]", "robots.a.actuators.kp=-1.0 must be positive"),
        (
            "robots: [{name: a, controllers: {activate: [joint_state_broadcaster, "
            "position_controller]}, sequencer: !PositionTargets {targets: [[1, 2]]}}]",
            "robots.0 (a): target 0 has 2 values, expected 4 (j0, j1, j2, j3)",
        ),
    ],
)
def test_a_wrong_robots_list_is_one_line_naming_the_key(override, reason):
    with pytest.raises(ConfigError) as error:  # a ScenarioError, a SequencerError
        MakeWorld(load_scenario("dual_armando", override), quiet=True, source="dual.yaml")
    message = str(error.value)
    assert "\n" not in message and reason in message, message


# The meeting of diagrams/dual_armando_meet.yaml: the tool point between the fingers,
# 4.8 mm beyond their tips (they end 0.0592 m along crawer_base's z), and the shared point.
TOOL_POINT = np.array([0.0, 0.015, 0.064])  # [m] in crawer_base
MEETING_POINT = np.array([0.0, 0.0, 0.30])  # [m] in the world, midway between the bases
MEETING_TIME = 4.0  # [s] the trajectories' second point


def _meeting_targets(robot_config) -> list[list[float]]:
    """Each arm's joint targets by the project's IK: the tool point 5 cm short of the
    meeting point, then on it, approaching level toward the other arm (its base's +x)."""
    plant = MultibodyPlant(0.0)
    robot = AddRobot(plant, dc.replace(robot_config, base_xyz=[0, 0, 0], base_rpy=[0, 0, 0]))
    crawer = plant.GetFrameByName("crawer_base", robot.model_instance)
    tool = plant.AddFrame(FixedOffsetFrame("tool", crawer, RigidTransform(TOOL_POINT)))
    plant.Finalize()
    arm = ArmModel(plant=plant, end_effector_frame=tool, model_instance=robot.model_instance)
    X_WB = RigidTransform(RollPitchYaw(robot_config.base_rpy), robot_config.base_xyz)
    # Level, toward +x of the base: the gripper's approach (z at q = 0) pitched a quarter
    # turn by j1..j3 (about x), then yawed a quarter turn by j0.
    R0 = tool.CalcPoseInWorld(plant.CreateDefaultContext()).rotation()
    R_BT = RotationMatrix.MakeZRotation(np.pi / 2) @ RotationMatrix.MakeXRotation(np.pi / 2) @ R0
    targets = []
    for back in (0.05, 0.0):
        p_W = MEETING_POINT - back * X_WB.rotation().matrix()[:, 0]
        p_B = X_WB.inverse() @ p_W
        result = solve_ik(arm, RigidTransform(R_BT, p_B), orientation="cost")
        assert result.success and result.position_error < 1e-9, result.message
        targets.append(list(result.q))
    return targets


def test_the_meeting_targets_are_the_ik_of_the_shared_point():
    """The joint targets written in dual_armando_meet.yaml are the project's IK of the
    shared point for each arm, within 1e-4 rad."""
    scenario = load_scenario("dual_armando_meet")
    for name, entry in scenario.robots.items():
        expected = _meeting_targets(entry.robot)
        assert np.abs(np.array(entry.sequencer.targets) - expected).max() < 1e-4, name


@pytest.fixture(scope="module")
def meeting():
    """dual_armando_meet.yaml sampled every 0.05 s: (times, the two tool points [m],
    the smallest signed distance between a left and a right geometry [m]) per sample."""
    world = MakeWorld(load_scenario("dual_armando_meet", QUIET), quiet=True)
    plant, scene_graph = world.plant, world.scene_graph
    simulator = Simulator(world.diagram)
    context = simulator.get_context()
    plant_context = plant.GetMyContextFromRoot(context)
    graph_context = scene_graph.GetMyContextFromRoot(context)
    instances = {name: robot.robot.model_instance for name, robot in world.robots.items()}
    tools = {name: plant.GetFrameByName("crawer_base", i) for name, i in instances.items()}
    geometries = {
        name: {
            g
            for body in plant.GetBodyIndices(instance)
            for g in plant.GetCollisionGeometriesForBody(plant.get_body(body))
        }
        for name, instance in instances.items()
    }
    times, points, clearances = [], [], []
    for t in np.arange(0.0, 5.0 + 1e-9, 0.05):
        simulator.AdvanceTo(t)
        times.append(t)
        points.append({n: f.CalcPoseInWorld(plant_context) @ TOOL_POINT for n, f in tools.items()})
        query = scene_graph.get_query_output_port().Eval(graph_context)
        pairs = query.ComputeSignedDistancePairwiseClosestPoints(0.2)
        between = [
            pair.distance
            for pair in pairs
            if {pair.id_A, pair.id_B} & geometries["left"]
            and {pair.id_A, pair.id_B} & geometries["right"]
        ]
        clearances.append(min(between, default=np.inf))
    world.close(context)
    return np.array(times), points, np.array(clearances)


def test_both_tool_points_reach_the_shared_point_together(meeting):
    """At the meeting time (4 s) the two tool points are within 1 mm of each other and
    each within 1 mm of the shared point (measured: 0.1 mm); they stay there."""
    times, points, _ = meeting
    for k in np.flatnonzero(times >= MEETING_TIME - 1e-9):
        left, right = points[k]["left"], points[k]["right"]
        assert np.linalg.norm(left - right) <= 1e-3, (times[k], left, right)
        for point in (left, right):
            assert np.linalg.norm(point - MEETING_POINT) <= 1e-3, (times[k], point)
    # Together: 0.5 s before, both are still as far (centimetres) from the point.
    before = points[int(np.argmin(np.abs(times - (MEETING_TIME - 0.5))))]
    far = [np.linalg.norm(before[n] - MEETING_POINT) for n in ("left", "right")]
    assert min(far) > 5e-3 and abs(far[0] - far[1]) < 1e-4, far


def test_the_two_arms_never_touch(meeting):
    """The smallest distance between the two arms' collision geometries over the run
    (SceneGraph's signed distance) stays above 5 mm (measured: 9.2 mm at the meeting)."""
    _, _, clearances = meeting
    assert clearances.min() > 5e-3, clearances.min()


def _topics_of_bag(path) -> dict[str, list]:
    """The messages per topic of an MCAP file, read with rosbags (not the writer's
    library), and ``__types__``: each topic's message type."""
    from rosbags.highlevel import AnyReader

    topics: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for connection, _, raw in reader.messages():
            topics.setdefault(connection.topic, []).append(
                reader.deserialize(raw, connection.msgtype)
            )
        topics["__types__"] = {c.topic: c.msgtype for c in reader.connections}
    return topics


def test_the_recording_has_each_robots_topics_under_its_namespace(tmp_path):
    """--record of the two Armandos (1.5 s) and of Armando on fra2mo (1.2 s): each robot's
    joint states and commands on /<namespace>/..., fra2mo's odometry and cmd_vel on
    /fra2mo/odom and /fra2mo/cmd_vel."""
    path = tmp_path / "dual.mcap"
    world = MakeWorld(load_scenario("dual_armando", QUIET), quiet=True, record=path)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(1.5)
    world.close(simulator.get_context())
    bag = _topics_of_bag(path)
    for space in ("left", "right"):
        states = bag[f"/{space}/joint_states"]
        assert len(states) == 151 and list(states[-1].name) == ["j0", "j1", "j2", "j3"]
        commands = bag[f"/{space}/position_controller/commands"]
        assert [list(c.data) for c in commands] == [[0.0, 0.0, 0.0, 0.0]]
    assert "/joint_states" not in bag
    path = tmp_path / "mounted.mcap"
    world = MakeWorld(load_scenario("fra2mo_armando", QUIET), quiet=True, record=path)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(1.2)
    world.close(simulator.get_context())
    bag = _topics_of_bag(path)
    types = bag["__types__"]
    assert types["/fra2mo/odom"] == "nav_msgs/msg/Odometry"
    assert types["/fra2mo/cmd_vel"] == "geometry_msgs/msg/Twist"
    assert list(bag["/fra2mo/joint_states"][-1].name) == ["left_wheel_joint", "right_wheel_joint"]
    assert len(bag["/armando/joint_states"]) == 121
    assert len(bag["/armando/position_controller/commands"]) == 1
    assert abs(bag["/fra2mo/cmd_vel"][-1].linear.x - 0.15) < 1e-9
