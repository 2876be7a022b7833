"""What a run makes is kept first: an exploration's map (``map.yaml`` + ``map.pgm``) is
written with the logs, before the plots and the replay, on Ctrl-C, on a second Ctrl-C
while the outputs are written, on Ctrl-C during the plots and on SIGTERM; ``base.csv``
is streamed, so a run killed outright (SIGKILL) keeps its path up to about a second
before the kill."""

import json
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from armando_drake.navigation.maps import load_map
from armando_drake.outputs.base import read_base_csv

TIME_LIMIT = 40.0  # [s] for each run
NOISE = ("Traceback", "Fatal Python error", "Failure at")


def start(folder: Path, *args: str) -> subprocess.Popen:
    command = [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--output"]
    return subprocess.Popen(
        [*command, str(folder), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def explore(folder: Path, *args: str) -> subprocess.Popen:
    return start(folder, "--scenario", "fra2mo_explore", "--quiet", *args)


def last_time(path: Path) -> float:
    """[s] the time of base.csv's last row (-1 without one)."""
    try:
        rows = read_base_csv(path)
    except OSError:
        return -1.0
    return float(rows[-1, 0]) if len(rows) else -1.0


def wait_for(condition, deadline: float) -> None:
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def assert_map_kept(folder: Path, process: subprocess.Popen, deadline: float) -> None:
    stdout, stderr = process.communicate(timeout=max(1.0, deadline - time.monotonic()))
    assert process.returncode == 130, stderr
    for noise in NOISE:
        assert noise not in stdout + stderr, stderr
    assert "\ninterrupted" in f"\n{stdout}\n{stderr}", (stdout, stderr)
    grid = load_map(folder / "map.yaml")  # loads back
    assert grid.resolution == pytest.approx(0.05)
    assert (grid.data == 0).sum() > 1000  # free cells the lidar saw
    assert (grid.data == 100).sum() > 50  # and walls
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["navigation"]["map"]["size"] == [grid.width, grid.height]


@pytest.mark.parametrize(
    "signals",
    [[signal.SIGINT], [signal.SIGINT, signal.SIGINT], [signal.SIGTERM]],
    ids=["SIGINT", "SIGINT-twice", "SIGTERM"],
)
def test_a_stopped_exploration_keeps_its_map(tmp_path, signals):
    deadline = time.monotonic() + TIME_LIMIT
    process = explore(tmp_path, "--realtime-rate", "1")
    try:
        wait_for(lambda: last_time(tmp_path / "base.csv") >= 2.5, deadline)
        for k, stop in enumerate(signals):
            time.sleep(0.05 * k)  # the second while the logs and the map are written
            process.send_signal(stop)
        assert_map_kept(tmp_path, process, deadline)
        assert json.loads((tmp_path / "summary.json").read_text())["interrupted"] is True
        if len(signals) > 1:  # the second Ctrl-C skips the plots and the replay only
            assert not (tmp_path / "replay.html").exists()
    finally:
        process.kill()


def test_ctrl_c_during_the_plots_keeps_the_map(tmp_path):
    """The run is done, its plots are being written: Ctrl-C stops them, the map is there."""
    deadline = time.monotonic() + TIME_LIMIT
    process = explore(tmp_path, "--realtime-rate", "0", "--duration", "4")
    try:
        wait_for(lambda: any(tmp_path.glob("*.png")) or process.poll() is not None, deadline)
        process.send_signal(signal.SIGINT)
        if process.wait(timeout=TIME_LIMIT) == 0:
            pytest.skip("the plots and the replay were done before the signal came")
        assert_map_kept(tmp_path, process, deadline)
        summary = json.loads((tmp_path / "summary.json").read_text())
        assert summary["interrupted"] is False and summary["sim_time"] == pytest.approx(4.0)
    finally:
        process.kill()


def test_sigkill_keeps_base_csv_up_to_about_a_second_before(tmp_path):
    """base.csv's last row after SIGKILL is within about a second of the time the run had
    simulated: its rows reach the file at least every half second of wall time."""
    deadline = time.monotonic() + TIME_LIMIT
    process = start(tmp_path, "--scenario", "fra2mo", "--realtime-rate", "1")
    printed: list[tuple[float, float]] = []  # (wall time read, simulated time printed)

    def read_console():  # "[t=2.000 s]" once a simulated second, as it is reached
        for line in process.stdout:
            if line.startswith("[t="):
                printed.append((time.monotonic(), float(line[3:].split()[0])))

    reader = threading.Thread(target=read_console, daemon=True)
    reader.start()
    try:
        path = tmp_path / "base.csv"
        wait_for(lambda: last_time(path) >= 0, deadline)
        first_row = time.monotonic()  # the clock started about here
        wait_for(lambda: len(printed) >= 5, deadline)
        time.sleep(0.7)  # between two console lines, and two of base.csv's writes
        killed = time.monotonic()
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        process.kill()
    reader.join(timeout=5)
    # How far the simulation was behind the wall clock when it last printed (a loaded
    # machine may not keep real time), to take from the time elapsed at the kill.
    wall, simulated = printed[-1]
    lag = max(0.0, (wall - first_row) - simulated)
    reached = killed - first_row - lag  # [s] simulated, about, when killed
    rows = read_base_csv(path)
    assert rows[-1, 0] >= reached - 1.0, (rows[-1, 0], reached)
    assert len(set(rows[:, 0])) == len(rows)  # each row once, in time order
    assert (rows[1:, 0] > rows[:-1, 0]).all()
