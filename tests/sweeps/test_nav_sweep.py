"""A sweep of Nav2 parameters (nav.KEY axes) on fra2mo_goals: the navigation metrics of
each variant equal those of the same run made on its own; the table and figure written.

Each run is 9 s of fra2mo_goals (the first goal is reached at 5.5 s to 7.7 s), about 4 s of
wall time.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from armando_drake.sweeps import sweep as sweep_command
from armando_drake.sweeps.table import read_table

DURATION = "9"  # [s] simulated per run
KEY = "controller_server.FollowPath.desired_linear_vel"
SPEEDS = (0.4, 0.6)
CONFIGURATIONS = Path(__file__).parents[2] / "diagrams/sweeps/nav2_configurations.args"


def expected_metrics(summary: dict) -> dict:
    """The navigation metrics of a summary.json, written out here (not imported)."""
    nav = summary["navigation"]
    goals = nav["goals"]
    times = [g["time"] for g in goals if g["reached"]]
    return {
        "nav_reached": nav["reached"],
        "nav_time": sum(times) if times else None,
        "nav_path_length": sum(g["path_length"] for g in goals),
        "nav_position_error": sum(g["position_error"] for g in goals) / len(goals),
        "nav_yaw_error": sum(g["yaw_error"] for g in goals) / len(goals),
        "nav_collisions": nav["collisions"],
    }


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """(the sweep's folder, summary.json of each speed run on its own)."""
    root = tmp_path_factory.mktemp("navsweep")
    processes = []
    for speed in SPEEDS:
        output = root / f"single_{speed}"
        command = [sys.executable, "-m", "armando_drake.world", "--scenario", "fra2mo_goals"]
        command += ["--set", f"navigation: {{params_overrides: {{{KEY}: {speed}}}}}"]
        command += ["--duration", DURATION, "--no-meshcat", "--realtime-rate", "0"]
        command += ["--no-replay", "--output", str(output), "--quiet"]
        processes.append((subprocess.Popen(command, stdout=subprocess.DEVNULL), output))
    for process, _ in processes:
        assert process.wait(timeout=300) == 0
    singles = [json.loads((output / "summary.json").read_text()) for _, output in processes]
    sweep = root / "sweep"
    argv = ["--scenario", "fra2mo_goals", "--grid", f"nav.{KEY}={list(SPEEDS)}"]
    argv += ["--duration", DURATION, "--output", str(sweep), "--workers", "2", "--quiet"]
    assert sweep_command.main([*argv, "--plot", "--metric", "nav_time"]) == 0
    return sweep, singles


def test_nav_sweep_rows_equal_the_single_runs(runs):
    sweep, singles = runs
    rows = read_table(sweep).to_pylist()
    assert [r[f"nav.{KEY}"] for r in rows] == list(SPEEDS)
    for record, summary in zip(rows, singles, strict=True):
        assert record["status"] == "ok"
        expected = expected_metrics(summary)
        assert {k: record[k] for k in expected} == expected
        assert record["nav_reached"] == 1 and record["nav_collisions"] == 0
    # The speed matters: the faster variant reaches its first goal sooner.
    assert rows[1]["nav_time"] < rows[0]["nav_time"] - 1.0
    assert (sweep / "nav_time.png").stat().st_size > 10_000
    header = (sweep / "results.csv").read_text().splitlines()[0].split(",")
    assert header[:2] == ["variant", f"nav.{KEY}"]


def test_the_configurations_file_parses_to_four_variants(capsys):
    assert sweep_command.main([f"@{CONFIGURATIONS}", "--dry-run"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 4 and all("--scenario" in line for line in lines)
    assert "inflation_radius: 0.35" in lines[1] and "map_resolution: 0.025" in lines[2]
