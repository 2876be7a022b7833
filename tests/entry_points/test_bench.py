"""The benchmark suite's smoke run: shape of its output, not the speed."""

import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import skip_or_fail

from armando_drake.benchmarks import suite as bench
from armando_drake.tools.version import provenance

HAS_MUJOCO = importlib.util.find_spec("mujoco") is not None


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """(stdout, JSON report) of ``python -m armando_drake.bench --quick``."""
    path = tmp_path_factory.mktemp("bench") / "out" / "bench.json"
    done = subprocess.run(
        [sys.executable, "-m", "armando_drake.bench", "--quick", "--json", str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout, json.loads(path.read_text())


def test_the_report_names_the_code_it_measured(quick_run):
    _, report = quick_run
    assert report["armando_drake"] == provenance()


def test_quick_run_writes_every_row_with_positive_numbers(quick_run):
    _, report = quick_run
    assert report["quick"] is True
    assert report["repeat"] == 1
    assert report["machine"]["cpus"] >= 1
    names = [row["name"] for row in report["rows"]]
    expected = [
        "bare plant + TrajectorySource, 1 s",
        "position scenario, 1 s",
        "trajectory scenario, 1 s",
        "sinusoid scenario, 1 s",
        "position / bare plant",
        "trajectory / bare plant",
        "sinusoid / bare plant",
        "position / bare plant, fastest runs",
        "position plant inputs replayed, 1 s",
        "trajectory plant inputs replayed, 1 s",
        "sinusoid plant inputs replayed, 1 s",
        "trajectory replay / position replay",
        "sinusoid replay / position replay",
        "position / its replay",
        "trajectory / its replay",
        "sinusoid / its replay",
        "colour render, RenderEngineVtk",
        "colour + depth render, RenderEngineVtk",
        "camera scenario, no camera, 0.5 s",
        "camera scenario + camera, RenderEngineVtk, 0.5 s",
        "start-up, empty cache",
        "start-up, warm cache",
        "resident memory at the start",
        "resident memory after 5 s simulated and replay.html",
        "replay.html after 5 s simulated",
        "peak resident memory, plots of the 5 s drawn after the run",
    ]
    if shutil.which("Xvfb") or os.environ.get("CI"):  # CI installs Xvfb: the GL rows too
        expected += [
            "colour render, RenderEngineGl",
            "colour + depth render, RenderEngineGl",
            "camera scenario + camera, RenderEngineGl, 0.5 s",
        ]
    expected += [  # the iiwa of models/iiwa_description
        "iiwa operational-space ID at 1 kHz, 0.5 s",
        "iiwa joint-space ID at 1 kHz, 0.5 s",
        "operational-space controller update",
    ]
    for name in expected:
        assert name in names
    assert HAS_MUJOCO, "mujoco is not installed (pip install -e '.[test]')"
    assert "Drake pipeline / MuJoCo" in names
    assert "Drake pipeline: largest step" in names
    for row in report["rows"]:
        assert set(row) >= {"section", "name", "unit", "median", "min", "max", "samples"}
        assert row["section"] in bench.SECTIONS
        assert len(row["samples"]) == 1
        assert row["min"] <= row["median"] <= row["max"]
        if row["name"].startswith("growth"):
            assert math.isfinite(row["median"])  # memory may shrink
        else:
            assert row["median"] > 0 and math.isfinite(row["median"]), row
    budget = {row["name"]: row for row in report["rows"] if row["target"]}
    assert budget["position / bare plant"]["target"] == ">= 0.9"
    assert budget["start-up, warm cache"]["target"] == "<= 1.5"
    camera_budget = [name for name in budget if name.startswith("camera scenario + camera")]
    assert len(camera_budget) == 1 and budget[camera_budget[0]]["target"] == ">= 1"
    assert budget["growth over 5 s, replay on"]["target"] == "<= 20"
    assert budget["replay.html after 5 s simulated"]["target"] == "<= 50"
    assert budget["iiwa operational-space ID at 1 kHz, 0.5 s"]["target"] == ">= 2"
    assert all(isinstance(row["met"], bool) for row in budget.values())


def test_quick_run_prints_the_markdown_table(quick_run):
    stdout, report = quick_run
    lines = stdout.splitlines()
    assert lines[0] == "| Benchmark | Median | Min | Max | Unit | Target | Met |"
    table = [line for line in lines if line.startswith("| ")]
    assert len(table) == 2 + len(report["rows"])
    assert any(line.startswith("| start-up, warm cache | ") for line in table)


def test_row_target_and_statistics():
    row = bench.Row("pipeline", "x", "ratio", [0.8, 1.0, 0.95]).check(">=", 0.9)
    assert (row.median, row.min, row.max, row.met, row.target) == (0.95, 0.8, 1.0, True, ">= 0.9")
    assert bench.Row("startup", "y", "s", [2.0, 1.6, 1.7]).check("<=", 1.5).met is False


def test_bad_arguments_are_refused(capsys):
    with pytest.raises(SystemExit):
        bench.main(["--only", "pipeline,gpu"])
    assert "--only 'pipeline,gpu': choose from pipeline, mujoco" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        bench.main(["--repeat", "0"])
    assert "--repeat 0 must be at least 1" in capsys.readouterr().err


def test_mujoco_xml_drops_ros_elements_and_keeps_every_link():
    urdf = """<robot name="r">
      <link name="a"/><link name="b"/><link name="c"/>
      <joint name="fix" type="fixed"><parent link="a"/><child link="b"/></joint>
      <joint name="j" type="revolute"><parent link="b"/><child link="c"/>
        <axis xyz="0 0 1"/><limit effort="1.5" lower="-1" upper="1" velocity="1"/></joint>
      <ros2_control name="s" type="system"/><gazebo reference="c"/>
    </robot>"""
    root = ET.fromstring(bench.mujoco_xml(urdf))
    assert root.find("ros2_control") is None and root.find("gazebo") is None
    compiler = root.find("mujoco/compiler")
    assert compiler.get("fusestatic") == "false" and compiler.get("discardvisual") == "false"
    group, moving = bench._welded_groups(root)
    assert group == {"a": "a", "b": "a", "c": "c"}
    assert moving == [("b", "c")]


def test_mujoco_model_reaches_the_targets_like_the_world():
    if not HAS_MUJOCO:
        skip_or_fail("mujoco is not installed (pip install -e '.[test]')")
    from armando_drake.simulation.builder import MakeWorld
    from armando_drake.simulation.scenario import load_scenario

    world = MakeWorld(load_scenario("position", bench.NO_CONSOLE), quiet=True)
    world.close()
    model = bench.mujoco_model(
        world.robot().robot.urdf,
        world.robot().stack.hardware,
        kp=8.0,
        kd=0.4,
        time_step=0.002,
        gravcomp=True,
    )
    assert model.nu == 4
    assert list(model.actuator_forcerange[0]) == [-1.5, 1.5]
    rtf, errors = bench.mujoco_job(model, world.robot().stack.hardware, period=bench.TARGET_PERIOD)
    assert rtf > 0
    assert len(errors) == len(bench.TARGETS)
    assert max(errors) < bench.FINAL_ERROR_TOLERANCE


@pytest.mark.parametrize("name", ["trajectory", "sinusoid"])
def test_a_replay_moves_the_arm_as_its_world_does(name):
    """The pipeline rows' replays split a world's cost into physics and pipeline: the bare
    plant fed the world's recorded plant inputs must follow the world's own motion."""
    from pydrake.systems.analysis import Simulator

    from armando_drake.simulation.builder import MakeWorld
    from armando_drake.simulation.scenario import load_scenario

    duration = 4.0  # the trajectory's first segment runs from 0 to 3 s
    inputs = bench.recorded_plant_inputs(name, duration + 0.5)
    assert inputs.feedforward is not None  # the scenarios feed gravity forward
    assert inputs.desired.shape == (8, len(inputs.times))
    # The desired state moves (a replay of a held arm would compare nothing).
    assert np.ptp(inputs.desired[:4, : int(duration * 100)], axis=1).max() > 0.1

    diagram, plant = bench.replay_diagram(inputs)
    replay = Simulator(diagram)
    replay.AdvanceTo(duration)
    world = MakeWorld(load_scenario(name, f"{bench.NO_CONSOLE}\n{bench.UNCAPPED}"), quiet=True)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(duration)
    x_world = world.plant.GetPositionsAndVelocities(
        world.plant.GetMyContextFromRoot(simulator.get_context())
    )
    x_replay = plant.GetPositionsAndVelocities(plant.GetMyContextFromRoot(replay.get_context()))
    world.close(simulator.get_context())
    assert np.abs(x_world[:4]).max() > 0.05  # the arm has left its start
    # The same plant fed the same inputs at the same steps: the same state, bit for bit.
    np.testing.assert_array_equal(x_replay, x_world)
