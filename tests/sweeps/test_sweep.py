"""Sweeps of the Armando world: determinism against single runs, failures, resume, Ray.

Every run is a real ``python -m armando_drake.world`` process; the runs are
3.5 s of the position scenario (the second target comes at 3 s, so the gains
show in the errors) and take about 2.5 s of wall time each.
"""

import json
import os
import subprocess
import sys

import pyarrow.parquet as pq
import pytest
from conftest import skip_or_fail

from armando_drake.sweeps import sweep as sweep_command
from armando_drake.sweeps.axes import make_variants, parse_grid
from armando_drake.sweeps.engines import LocalPool, RayEngine
from armando_drake.sweeps.sweep import Sweep, run_sweep
from armando_drake.sweeps.table import read_table

DURATION = "3.5"  # [s] simulated per run
GRID = ("actuators.kp=[4, 16]", "actuators.kd=[0.1, 0.4]")
# The same four variants written out by hand, as a user would for single runs.
SINGLE_RUN_OVERRIDES = [
    "actuators: {kp: 4, kd: 0.1}",
    "actuators: {kp: 4, kd: 0.4}",
    "actuators: {kp: 16, kd: 0.1}",
    "actuators: {kp: 16, kd: 0.4}",
]
TIMING = {"wall_time", "host", "summary.wall_time", "summary.realtime_factor"}


def grid_sweep() -> Sweep:
    return Sweep(
        scenario="position",
        variants=make_variants([parse_grid(text) for text in GRID]),
        world_args=["--duration", DURATION],
    )


def numbers(value, prefix="summary"):
    """Every number of a summary.json, by dotted path (written here, not imported)."""
    if isinstance(value, dict):
        return {
            k: v for key, item in value.items() for k, v in numbers(item, f"{prefix}.{key}").items()
        }
    if isinstance(value, list):
        return {
            k: v for i, item in enumerate(value) for k, v in numbers(item, f"{prefix}.{i}").items()
        }
    return {prefix: value} if value is None or isinstance(value, int | float) else {}


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    """The 2 x 2 grid on the local pool with 2 workers: (outcome, output folder)."""
    output = tmp_path_factory.mktemp("local") / "sweep"
    with LocalPool(workers=2) as engine:
        outcome = run_sweep(grid_sweep(), output, engine, progress=False)
    return outcome, output


@pytest.fixture(scope="module")
def single_runs(tmp_path_factory):
    """summary.json of each variant run on its own, two at a time."""
    root = tmp_path_factory.mktemp("single")
    summaries = []
    for pair in (SINGLE_RUN_OVERRIDES[:2], SINGLE_RUN_OVERRIDES[2:]):
        processes = []
        for override in pair:
            output = root / str(len(summaries) + len(processes))
            command = [sys.executable, "-m", "armando_drake.world", "--set", override]
            command += ["--duration", DURATION, "--no-meshcat", "--realtime-rate", "0"]
            command += ["--no-replay", "--output", str(output), "--quiet"]
            processes.append((subprocess.Popen(command, stdout=subprocess.DEVNULL), output))
        for process, output in processes:
            assert process.wait(timeout=300) == 0
            summaries.append(json.loads((output / "summary.json").read_text()))
    return summaries


def test_grid_rows_equal_single_runs_exactly(local_sweep, single_runs):
    outcome, output = local_sweep
    table = outcome.table
    assert (outcome.ran, outcome.skipped, outcome.failed) == (4, 0, 0)
    assert len(table.rows) == 4
    assert [(r["actuators.kp"], r["actuators.kd"]) for r in table.rows] == [
        (4, 0.1),
        (4, 0.4),
        (16, 0.1),
        (16, 0.4),
    ]
    for record, summary in zip(table.rows, single_runs, strict=True):
        assert record["status"] == "ok" and record["exit_code"] == 0 and record["error"] == ""
        assert record["wall_time"] > 0
        expected = {k: v for k, v in numbers(summary).items() if k not in TIMING}
        got = {k: v for k, v in record.items() if k.startswith("summary.") and k not in TIMING}
        assert got == expected
        steps = summary["steps"]
        assert record["max_error"] == max(step["final_error"] for step in steps)
    # The gains matter: four different errors at the end of the cut second step.
    assert len({r["summary.steps.1.final_error"] for r in table.rows}) == 4
    # The same rows in the Parquet file and the CSV file.
    parquet = read_table(output).to_pylist()
    assert [r["summary.steps.1.reached.2"] for r in parquet] == [
        r["summary.steps.1.reached.2"] for r in table.rows
    ]
    header = (output / "results.csv").read_text().splitlines()[0].split(",")
    assert header[:4] == ["variant", "actuators.kp", "actuators.kd", "status"]
    assert len((output / "results.csv").read_text().splitlines()) == 5
    # Each variant ran in its own folder with the world's own outputs.
    for index in range(4):
        folder = output / "variants" / f"{index:04d}"
        assert (folder / "summary.json").is_file() and (folder / "joint_states.csv").is_file()


def test_failing_variant_is_recorded_resumed_and_plotted(tmp_path, capsys):
    output = tmp_path / "sweep"
    common = ["--grid", "actuators.kd=[0.4]", "--duration", "0.5", "--output", str(output)]
    common += ["--workers", "2", "--quiet", "--plot", "--metric", "max_error"]
    assert sweep_command.main(["--grid", "actuators.kp=[4, fast]", *common]) == 0
    printed = capsys.readouterr().out
    assert "2 of 2 variants: 1 ok, 1 failed (2 run now" in printed
    rows = read_table(output).to_pylist()
    assert [r["actuators.kp"] for r in rows] == ["4", "fast"]  # a mixed column is text
    assert rows[0]["status"] == "ok" and rows[0]["summary.sim_time"] == pytest.approx(0.5)
    assert rows[1]["status"] == "failed" and rows[1]["exit_code"] == 2
    assert rows[1]["error"].startswith("error: ") and "fast" in rows[1]["error"]
    assert rows[1]["summary.sim_time"] is None
    assert (output / "max_error.png").stat().st_size > 10_000
    # The same folder again without --resume is refused.
    with pytest.raises(SystemExit) as exit_code:
        sweep_command.main(["--grid", "actuators.kp=[4, fast]", *common])
    assert exit_code.value.code == 2
    assert "already holds a sweep" in capsys.readouterr().err
    # --resume with one more value runs only that one; the failure is kept.
    assert sweep_command.main(["--grid", "actuators.kp=[4, fast, 8]", "--resume", *common]) == 0
    assert "3 of 3 variants: 2 ok, 1 failed (1 run now" in capsys.readouterr().out
    # --retry-failed runs the failed one again, and it fails the same way.
    again = ["--grid", "actuators.kp=[4, fast, 8]", "--resume", "--retry-failed", *common]
    assert sweep_command.main(again) == 0
    assert "(1 run now" in capsys.readouterr().out
    assert read_table(output).to_pylist()[1]["error"] == rows[1]["error"]
    # A resume whose variants differ from the stored ones is refused.
    with pytest.raises(SystemExit):
        sweep_command.main(["--grid", "actuators.kp=[5]", "--resume", *common])
    assert "is of another sweep" in capsys.readouterr().err
    stored = json.loads((output / "sweep.json").read_text())["variants"]
    assert [v["values"]["actuators.kp"] for v in stored] == [4, "fast", 8]  # left as it was


def test_dry_run_prints_the_world_commands(capsys):
    code = sweep_command.main(
        ["--grid", "actuators.kp=[2, 4]", "--set", "logging: {console_rate: 0}", "--dry-run"]
    )
    assert code == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2
    assert lines[1].startswith("-m armando_drake.world --scenario position")
    assert "--set logging: {console_rate: 0} --set actuators: {kp: 4}" in lines[1]
    assert "--output out/sweep/variants/0001" in lines[1]


@pytest.fixture(scope="module")
def ray_instance(tmp_path_factory):
    """A local Ray instance of 2 CPUs started here, its files in the test's tmp folder."""
    try:
        import ray
    except ImportError:
        skip_or_fail("ray is not installed (pip install -e '.[test]')")
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        log_to_driver=False,
        _temp_dir=str(tmp_path_factory.mktemp("ray")),
    )
    yield ray
    ray.shutdown()


def test_ray_gives_the_same_table(ray_instance, local_sweep, tmp_path):
    local, _ = local_sweep
    engine = RayEngine()  # the instance started by the fixture, 2 CPUs
    assert engine.workers == 2
    assert "1 node, 2 CPUs" in engine.describe()
    outcome = run_sweep(grid_sweep(), tmp_path / "sweep", engine, progress=False)
    engine.close()
    assert ray_instance.is_initialized()  # not ours to shut down
    assert (outcome.ran, outcome.failed) == (4, 0)
    assert outcome.table.columns == local.table.columns
    for ours, theirs in zip(outcome.table.rows, local.table.rows, strict=True):
        assert {k: v for k, v in ours.items() if k not in TIMING} == {
            k: v for k, v in theirs.items() if k not in TIMING
        }


def test_ray_makes_the_same_data_set(ray_instance, tmp_path):
    from armando_drake.sweeps.dataset import IkSettings, RobotSpec, make_ik_dataset
    from armando_drake.sweeps.engines import InProcess

    ik = IkSettings(enabled=True)
    with RayEngine() as engine:
        on_ray = make_ik_dataset(RobotSpec(), 12, 5, tmp_path / "ray.parquet", engine, ik=ik)
    here = make_ik_dataset(RobotSpec(), 12, 5, tmp_path / "here.parquet", InProcess(), ik=ik)
    ray_table, local_table = pq.read_table(on_ray), pq.read_table(here)
    assert ray_table.num_rows == 12
    assert ray_table.equals(local_table)


def test_sigterm_stops_the_runs_and_leaves_them_to_resume(tmp_path):
    import signal
    import time

    output = tmp_path / "sweep"
    command = [sys.executable, "-m", "armando_drake.sweep", "--grid", "actuators.kp=[4, 8]"]
    command += ["--duration", "600", "--workers", "2", "--output", str(output), "--quiet"]
    sweep = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    logs = [output / "variants" / f"{i:04d}" / "joint_states.csv" for i in range(2)]
    deadline = time.monotonic() + 120

    def simulating(log):  # rows are written once a simulated second
        return log.is_file() and len(log.read_text().splitlines()) > 2

    while not all(simulating(log) for log in logs) and time.monotonic() < deadline:
        time.sleep(0.2)  # both worlds are simulating their 600 s (about a minute each)
    sweep.send_signal(signal.SIGTERM)
    stdout, _ = sweep.communicate(timeout=60)
    assert sweep.returncode == 130
    assert "0 of 2 variants" in stdout and "[interrupted]" in stdout
    for index in range(2):
        folder = output / "variants" / f"{index:04d}"
        assert not (folder / "result.json").exists()  # not done: resume runs it again
        summary = json.loads((folder / "summary.json").read_text())
        assert summary["interrupted"] is True and 0 < summary["sim_time"] < 600
    assert read_table(output).num_rows == 0
