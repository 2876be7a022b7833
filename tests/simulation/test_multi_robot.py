"""Several robots in one world (a scenario's robots:): two Armandos facing each other
(diagrams/dual_armando.yaml), Armando mounted on fra2mo (diagrams/fra2mo_armando.yaml),
and the one-line errors of a robots: list."""

import io
import json

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.outputs.logger import read_joint_states
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.run import run
from armando_drake.simulation.scenario import ScenarioError, load_scenario

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
    for entry in scenario.robots:
        section = robots[entry.name]
        assert section["namespace"] == f"/{entry.name}"
        assert section["model_instance"] == f"{entry.name}::armando"
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
    for entry in scenario.robots:
        states = read_joint_states(out / entry.name / "joint_states.csv")
        assert states.joint_names == ["j0", "j1", "j2", "j3"]
        assert states.times[0] == 0.0 and abs(states.times[-1] - summary["sim_time"]) < 1e-9
        assert np.all(np.diff(states.times) > 0)
        rate = (len(states.times) - 1) / states.times[-1]
        assert abs(rate - 100.0) < 1.0, rate  # Armando's controllers' update rate
        last = np.array(entry.sequencer.targets[-1])
        assert np.abs(states.position[-1] - last).max() <= TOLERANCE
        assert (out / entry.name / "commands.csv").is_file()


def test_the_effective_scenario_of_two_robots_loads_back(dual):
    """scenario.yaml keeps the robots: list (each with the gains that ran) and loads."""
    out, _, _, _ = dual
    again = load_scenario(out / "scenario.yaml")
    assert [entry.name for entry in again.robots] == ["left", "right"]
    assert again.robots[0].actuators.kp == 8.0  # Armando's servos


def test_two_robots_have_their_own_ports_and_model_instances():
    """Two robots of one URDF: two model instances; every port under its namespace."""
    world = MakeWorld(load_scenario("dual_armando", QUIET), quiet=True)
    names = [world.plant.GetModelInstanceName(p.robot.model_instance) for p in world.robots]
    assert names == ["left::armando", "right::armando"]
    outputs = {
        world.diagram.get_output_port(i).get_name()
        for i in range(world.diagram.num_output_ports())
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
    arm, base = (world.robot_topics(name).robot for name in ("armando", "fra2mo"))
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
    targets = world.robot_topics("armando").sequencer.config.targets
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
            "robots.1.namespace='/b' is another robot's too",
        ),
        (
            "robots: [{name: a, parent: 'zz::base_link'}]",
            "robots.0.parent='zz::base_link': no robot 'zz' is listed before 'a'",
        ),
        (
            "robots: [{name: a}, {name: b, parent: 'a::nolink'}]",
            "robots.1.parent='a::nolink': robot 'a' has no link 'nolink' (links: base_link,",
        ),
        ("robots: [{name: '1a'}]", "robots.0.name='1a': give a name"),
    ],
)
def test_a_wrong_robots_list_is_one_line_naming_the_key(override, reason):
    with pytest.raises(ScenarioError) as error:
        MakeWorld(load_scenario("dual_armando", override), quiet=True, source="dual.yaml")
    message = str(error.value)
    assert "\n" not in message and reason in message, message
