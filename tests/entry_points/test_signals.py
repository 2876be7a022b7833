"""Ctrl-C at any moment: during start-up the command exits 130 quietly; a second Ctrl-C
while the logs are written keeps them whole and prints no traceback."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

FAST = ["--no-meshcat", "--realtime-rate", "0", "--quiet"]
NOISE = ("Traceback", "Could not initialize pydrake", "Fatal Python error", "Failure at")


def start(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", *FAST, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_for(condition, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def loading_drake(process: subprocess.Popen) -> bool:
    """Whether the process has begun to load Drake's library (its imports are under way)."""
    try:
        return "libdrake" in Path(f"/proc/{process.pid}/maps").read_text()
    except OSError:
        return process.poll() is not None


@pytest.mark.parametrize("delay", [0.0, 0.05, 0.2, 0.5, 0.7, 0.8, 1.0])
def test_ctrl_c_during_start_up_exits_130_quietly(tmp_path, delay):
    """SIGINT while pydrake is imported and the world is built (delays after Drake's
    library is mapped): exit 130, no traceback, no stack dump of pydrake's start-up."""
    if not Path("/proc/self/maps").is_file():
        pytest.skip("needs /proc to see when Drake is loaded")
    process = start("--duration", "30", "--output", str(tmp_path))
    wait_for(lambda: loading_drake(process))
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    for noise in NOISE:
        assert noise not in stderr + stdout, stderr
    assert len(stderr.splitlines()) <= 1, stderr  # at most "interrupted"


def test_some_ctrl_c_lands_before_the_simulation(tmp_path):
    """The start-up test's earliest delay does interrupt the start-up: no logs yet."""
    process = start("--duration", "30", "--output", str(tmp_path))
    wait_for(lambda: loading_drake(process))
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert not (tmp_path / "joint_states.csv").exists()


@pytest.mark.parametrize("second", [0.0, 0.02, 0.1, 0.4])
def test_a_second_ctrl_c_while_the_logs_are_written_keeps_them(tmp_path, second):
    process = start("--duration", "60", "--output", str(tmp_path))
    log = tmp_path / "joint_states.csv"
    wait_for(lambda: log.is_file() and log.stat().st_size > 20_000)
    process.send_signal(signal.SIGINT)
    time.sleep(second)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    for noise in NOISE:
        assert noise not in stderr + stdout, stderr
    # The logs are whole: every row complete, up to the time the summary gives.
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] is True
    lines = log.read_text().splitlines()
    assert len(lines) > 100
    assert all(len(line.split(",")) == 13 for line in lines[1:]), lines[-1]
    last = float(lines[-1].split(",")[0])
    assert last == pytest.approx(summary["sim_time"], abs=0.011)
    assert (tmp_path / "commands.csv").read_text().splitlines()[1:]
    assert (tmp_path / "scenario.yaml").is_file()


@pytest.mark.parametrize("output", [False, True])
def test_ctrl_c_during_the_run_says_what_it_still_writes(tmp_path, output):
    """Without --output nothing is written: the run says "interrupted", not that it writes
    logs and a summary."""
    args = ["--no-meshcat", "--realtime-rate", "0", "--duration", "3000"]
    args += ["--output", str(tmp_path)] if output else []
    process = subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    for line in process.stdout:  # the simulation is under way at its second console block
        if line.startswith("[t=1.000 s]"):
            break
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    for noise in NOISE:
        assert noise not in stderr + stdout, stderr
    said = [line for line in stdout.splitlines() if line.startswith("interrupted")]
    if output:
        assert said == ["interrupted: writing the logs and the summary"], stdout
        assert (tmp_path / "summary.json").is_file()
    else:
        assert said == ["interrupted"], stdout


SWALLOWED = """
import os, signal, time
from armando_drake.tools.cli import user_errors
with user_errors():
    try:  # as trimesh's imports do: catch BaseException, go on
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)
    except BaseException:
        pass
    print("went on")
print("finished")
"""


def test_a_ctrl_c_a_library_swallows_still_stops_the_command():
    """A KeyboardInterrupt caught by a library during start-up (trimesh's imports catch
    BaseException) still ends the command with 130 before it goes any further."""
    process = subprocess.run(
        [sys.executable, "-c", SWALLOWED], capture_output=True, text=True, timeout=120
    )
    assert process.returncode == 130, process.stderr
    assert "went on" in process.stdout  # the library did go on ...
    assert "finished" not in process.stdout  # ... but the command stopped there
    assert process.stderr.strip() == "interrupted"
