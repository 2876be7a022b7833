"""SIGTERM and SIGHUP (a closed terminal) stop a run as Ctrl-C does: the logs and the
summary are written, the exit code is 130, one "interrupted" line; also while the plots
are written after the run."""

import json
import signal
import subprocess
import sys
import time

import pytest

TIME_LIMIT = 120  # [s]


def start(*args) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--quiet", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_for(condition) -> None:
    deadline = time.monotonic() + TIME_LIMIT
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


@pytest.mark.parametrize("stop", [signal.SIGHUP, signal.SIGTERM], ids=["SIGHUP", "SIGTERM"])
def test_a_stop_signal_during_the_run_keeps_the_logs_and_the_summary(tmp_path, stop):
    process = start("--realtime-rate", "1", "--duration", "30", "--output", str(tmp_path))
    log = tmp_path / "joint_states.csv"
    wait_for(lambda: log.is_file() and len(log.read_text().splitlines()) > 100)
    process.send_signal(stop)
    _, stderr = process.communicate(timeout=TIME_LIMIT)
    assert process.returncode == 130, stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] is True and 1.0 <= summary["sim_time"] < 30
    rows = log.read_text().splitlines()
    ticks = int(summary["sim_time"] * 100 + 1e-9) + 1  # 100 Hz from 0 to where it stopped
    assert len(rows) - 1 == ticks  # every tick, whole


def test_sigterm_while_the_plots_are_written_exits_130_with_the_summary_kept(tmp_path):
    process = start("--realtime-rate", "0", "--duration", "20", "--output", str(tmp_path))
    summary = tmp_path / "summary.json"
    wait_for(lambda: any(tmp_path.glob("*.png")))  # the plots are being written
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=TIME_LIMIT)
    if process.returncode == 0:
        pytest.skip("the plots and the replay were done before the signal came")
    assert process.returncode == 130, stderr  # not killed by the signal (-15)
    assert stderr.strip().splitlines()[-1].startswith("interrupted"), stderr
    assert json.loads(summary.read_text())["sim_time"] == pytest.approx(20.0)
