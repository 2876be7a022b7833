"""`python -m armando_drake.world` run as a user would: output contract, Ctrl-C, bad input."""

import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import skip_or_fail
from PIL import Image

FAST = ["--no-meshcat", "--realtime-rate", "0"]


def world(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.world", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def rows(path) -> list[list[str]]:
    with open(path, newline="") as file:
        return list(csv.reader(file))


@pytest.mark.parametrize("controller", ["position", "trajectory"])
def test_every_step_ends_within_0_01_rad(tmp_path, controller):
    result = world(*FAST, "--controller", controller, "--output", str(tmp_path))
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["controller"] == controller
    assert summary["scenario"].endswith("position.yaml")
    assert summary["driven_controller"] == f"{controller}_controller"
    # The headline names what ran: the file and the controller that --controller chose.
    assert f"position.yaml with the {controller} controller ({controller}_controller)" in (
        result.stdout
    )
    assert len(summary["steps"]) == 5
    for step in summary["steps"]:
        assert step["final_error"] <= 0.01, step
        assert step["settling_time"] is not None and step["settling_time"] < 3.0
        # Largest error after settling: within the band by definition, and not below the
        # final error (the final sample is one of those after settling).
        assert step["final_error"] <= step["largest_error_after_settling"] <= 0.01, step
    assert summary["sim_time"] == pytest.approx(15.0)
    assert summary["realtime_factor"] > 0
    # The table is printed, one line per step, under columns named for what they hold.
    assert re.search(r"^\s+4\s+12\.00\s", result.stdout, re.M), result.stdout
    assert re.search(r"final error\s+after settling\s+settling \[s\]$", result.stdout, re.M)
    # One CSV row per controller tick from 0 to 15 s, and commands.csv.
    log = rows(tmp_path / "joint_states.csv")
    assert log[0][:4] == ["time", "j0_position", "j0_velocity", "j0_effort"]
    assert len(log) - 1 == 15.0 * 100 + 1  # 0, 0.01, ..., 15.0 s
    commands = rows(tmp_path / "commands.csv")
    assert commands[0] == ["time", "j0", "j1", "j2", "j3"]
    assert [float(v) for v in commands[2][1:]] == [1.2, -1.0, 1.2, 0.6]


def test_sinusoid_tracks_its_reference(tmp_path):
    result = world(*FAST, "--controller", "sinusoid", "--duration", "10", "--output", str(tmp_path))
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["tracking_error"] is not None
    assert summary["tracking_error"] <= 0.05
    # Check the reference independently of the summary: amplitude pi/2 at 0.05 Hz.
    log = np.array([[float(v) for v in row] for row in rows(tmp_path / "joint_states.csv")[1:]])
    assert len(log) == 10.0 * 100 + 1  # one row per controller tick, 0 to 10 s
    t, q0 = log[:, 0], log[:, 1]
    after = t >= 1.0
    reference = (np.pi / 2) * np.sin(2 * np.pi * 0.05 * t[after])
    assert np.abs(q0[after] - reference).max() <= 0.05
    assert q0.max() > 1.5  # it really swings to pi/2 at t = 5 s


def test_a_tagged_override_switches_the_sequencer(tmp_path):
    result = world(
        *FAST,
        "--quiet",
        "--set",
        "sequencer: !Sinusoid {frequency: 0.1}",
        "--duration",
        "5",
        "--output",
        str(tmp_path),
        "--no-replay",
    )
    assert result.returncode == 0, result.stderr
    assert "position.yaml with a sinusoid on the position controller" in result.stdout
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["controller"] == "sinusoid" and summary["steps"] == []
    log = np.array([[float(v) for v in row] for row in rows(tmp_path / "joint_states.csv")[1:]])
    t, q1 = log[:, 0], log[:, 4]
    # The seed wave at 0.1 Hz: j1 reaches about pi/2 at t = 2.5 s.
    assert np.abs(q1[t >= 1.0] - (np.pi / 2) * np.sin(2 * np.pi * 0.1 * t[t >= 1.0])).max() < 0.1
    assert q1.max() > 1.45


def test_console_lines_follow_the_seed_node_format():
    result = world(*FAST, "--duration", "2")
    assert result.returncode == 0, result.stderr
    headers = re.findall(r"^\[t=(\d+\.\d{3}) s\] Joint positions:$", result.stdout, re.M)
    assert headers[:3] == ["0.000", "1.000", "2.000"]
    joints = re.findall(r"^Joint (j\d): (-?\d+\.\d{3})$", result.stdout, re.M)
    assert [name for name, _ in joints[:4]] == ["j0", "j1", "j2", "j3"]
    assert "loaded controller 'position_controller'" in result.stdout
    assert "activated controller 'position_controller'" in result.stdout


def test_sigint_keeps_every_row_and_writes_the_summary(tmp_path):
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "armando_drake.world",
            "--no-meshcat",
            "--realtime-rate",
            "1",
            "--output",
            str(tmp_path),
            "--quiet",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    log = tmp_path / "joint_states.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if log.is_file() and len(log.read_text().splitlines()) > 150:
            break
        time.sleep(0.2)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    lines = log.read_text().splitlines()
    assert len(lines) > 150
    times = [float(line.split(",")[0]) for line in lines[1:]]
    assert all(len(line.split(",")) == 13 for line in lines[1:])
    np.testing.assert_allclose(np.diff(times), 0.01, atol=1e-6)  # no tick missing
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] is True
    assert summary["sim_time"] == pytest.approx(times[-1], abs=0.02)
    assert "interrupted" in stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["--set", "robot: {descripton: x}"], "--set 'robot: {descripton: x}': "),
        (["--scenario", "nope"], "nope: scenario file not found"),
        (["--set", "sequencer: {targets: [[0, 0, 0]]}"], "target 0 has 3 values, expected 4"),
        (["--set", "sequencer: {targets: [[0, 3.5, 0, 0]]}"], "target 0: j1=3.5 is above"),
        (["--set", "sequencer: {period: 0}"], "period=0.0 must be positive"),
        (
            ["--set", "sequencer: !Sinusoid {perod: 3}"],
            "--set 'sequencer: !Sinusoid {perod: 3}': The fields ['perod'] were unknown",
        ),
        (
            ["--set", "sequencer: !Sine {frequency: 1}"],
            "sequencer: unknown tag !Sine (choose !PositionTargets, !JointTrajectoryTargets, "
            "!Sinusoid)",
        ),
        (
            ["--duration", "-1"],
            "--duration -1.0: simulation.duration=-1.0 must be zero or positive [s]",
        ),
    ],
    ids=["unknown-key", "no-file", "length", "limit", "period", "variant-key", "tag", "duration"],
)
def test_bad_input_is_one_line_without_traceback(args, message):
    result = world(*FAST, *args)
    assert result.returncode == 2, result.stdout + result.stderr
    assert "Traceback" not in result.stderr
    assert message in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_unknown_key_in_a_scenario_file_names_the_file(tmp_path):
    scenario = tmp_path / "mine.yaml"
    scenario.write_text("simulation: {duraton: 3}\n")
    result = world(*FAST, "--scenario", str(scenario))
    assert result.returncode == 2
    assert f"error: {scenario}: " in result.stderr and "duraton" in result.stderr


def test_unreadable_scenario(tmp_path):
    if os.geteuid() == 0:
        scenario = tmp_path / "folder.yaml"
        scenario.mkdir()  # root reads any file; a folder is unreadable as a scenario
    else:
        scenario = tmp_path / "locked.yaml"
        scenario.write_text("{}\n")
        scenario.chmod(0)
    result = world(*FAST, "--scenario", str(scenario))
    assert result.returncode == 2
    assert str(scenario) in result.stderr
    assert "Traceback" not in result.stderr


def test_unknown_controller_choice():
    result = world(*FAST, "--controller", "velocity")
    assert result.returncode == 2
    assert "invalid choice: 'velocity'" in result.stderr


def test_help_documents_every_option_with_examples():
    result = world("--help")
    assert result.returncode == 0
    for option in [
        "--scenario",
        "--set",
        "--controller",
        "--duration",
        "--realtime-rate",
        "--no-meshcat",
        "--output",
        "--quiet",
        "--camera",
        "--save-frames",
        "--renderer",
    ]:
        assert option in result.stdout
    assert "Examples:" in result.stdout


@pytest.mark.parametrize("renderer, engine", [("vtk", "RenderEngineVtk"), ("gl", "RenderEngineGl")])
def test_renderer_choice_renders_the_saved_frames(tmp_path, renderer, engine):
    if renderer == "gl" and shutil.which("Xvfb") is None and not os.environ.get("DISPLAY"):
        skip_or_fail("no X display and no Xvfb (Debian package xvfb) for RenderEngineGl")
    frames = tmp_path / "frames"
    result = world(
        *FAST,
        "--scenario",
        "camera",
        "--duration",
        "0.2",
        "--renderer",
        renderer,
        "--save-frames",
        str(frames),
    )
    assert result.returncode == 0, result.stderr
    assert f"rendered by {engine}" in result.stdout + result.stderr
    colour = sorted(p for p in frames.glob("camera_*.png") if not p.stem.endswith("_depth"))
    assert len(colour) == 6, list(frames.iterdir())  # 0 to 0.2 s at 30 Hz, and the depths
    assert all(p.with_name(f"{p.stem}_depth.png").is_file() for p in colour)
    image = np.asarray(Image.open(colour[-1]).convert("RGB"))
    assert image.shape == (480, 640, 3)
    # The blue disc of diagrams/camera.yaml is in the lower left of the frame.
    blue = (image[:, :, 2] > 150) & (image[:, :, 0] < 80) & (image[:, :, 1] < 80)
    assert blue[240:, :320].sum() > 5000, blue.sum()
