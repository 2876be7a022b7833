"""run(): the step table computed in memory from the logger's rows, and its columns."""

import io
import json

import numpy as np
import pytest

from armando_drake.simulation.run import (
    SETTLE_TOLERANCE,
    RunResult,
    StepTable,
    TrackingError,
    _interrupted_message,
    run,
)
from armando_drake.simulation.scenario import load_scenario

FAST = "logging: {console_rate: 0}\nsimulator_config: {target_realtime_rate: 0}\n"


def test_step_columns_hold_final_error_largest_error_after_settling_and_settling_time():
    # One joint, two 1 s steps sampled at 10 Hz (the last one lasts to 2 s): step 0
    # (target 1) enters the band at 0.4 s, leaves it at 0.6 s, is back for good at
    # 0.7 s and ends 0.002 off; step 1 (target 0) never gets within the band.
    times = np.round(np.arange(0.0, 2.01, 0.1), 10)
    q = np.array(
        [0.0, 0.5, 0.9, 0.95, 0.995, 0.996, 0.98, 0.994, 0.997, 0.998]
        + [0.9, 0.7, 0.5, 0.4, 0.3, 0.2, 0.1, 0.05, 0.03, 0.025, 0.02]
    ).reshape(-1, 1)
    table = StepTable(targets=[[1.0], [0.0]], period=1.0, cyclic=False)
    table.add(times, q)
    first, second = table.results(end_time=2.0)
    assert (first.start, first.end, second.start, second.end) == (0.0, 1.0, 1.0, 2.0)
    assert first.reached == [0.998] and first.final_error == pytest.approx(0.002)
    assert first.settling_time == pytest.approx(0.7)  # the first sample after 0.6 s
    # The largest error after settling: 0.006 at 0.7 s, not the 0.02 at 0.6 s.
    assert first.largest_error_after_settling == pytest.approx(0.006)
    assert second.final_error == pytest.approx(0.02)
    assert second.final_error > SETTLE_TOLERANCE
    assert second.settling_time is None and second.largest_error_after_settling is None


def test_step_table_gives_the_same_result_however_the_rows_are_split():
    rng = np.random.default_rng(7)
    times = np.round(np.arange(0.0, 9.0 + 1e-9, 0.01), 10)
    targets = [[0.0, 0.5], [1.0, -0.5], [0.2, 0.2]]
    reference = np.array([targets[min(int(t // 3.0), 2)] for t in times])
    since_start = times - 3.0 * np.minimum(times // 3.0, 2)  # [s] into the step
    decay = 0.05 * np.exp(-5 * since_start)[:, None]
    q = reference + decay + rng.normal(0, 1e-3, (len(times), 2))
    whole = StepTable(targets=targets, period=3.0, cyclic=False)
    whole.add(times, q)
    pieces = StepTable(targets=targets, period=3.0, cyclic=False)
    for chunk in np.array_split(np.arange(len(times)), 37):
        pieces.add(times[chunk], q[chunk])
    assert pieces.results(9.0) == whole.results(9.0)
    assert [r.settling_time is not None for r in whole.results(9.0)] == [True] * 3


def test_cyclic_steps_and_columns():
    times = np.arange(0, 5) * 1.0
    q = np.array([[9, 0.0], [9, 1.0], [9, 0.0], [9, 1.0], [9, 0.0]])
    table = StepTable(targets=[[0.0], [1.0]], period=1.0, cyclic=True, columns=[1])
    table.add(times, q)
    results = table.results(4.5)
    assert [r.start for r in results] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert [r.target for r in results] == [[0.0], [1.0], [0.0], [1.0], [0.0]]
    assert all(r.final_error == 0.0 for r in results)
    # A run that ends at 4 s never ran the step that begins then (its row at t = 4
    # is the state before the command).
    assert [r.start for r in table.results(4.0)] == [0.0, 1.0, 2.0, 3.0]
    assert table.results(4.0)[-1].end == 4.0


def test_tracking_error_counts_from_its_start():
    def wave(t):
        return np.sin(np.asarray(t)).reshape(-1, 1)

    tracking = TrackingError(wave, after=1.0)
    times = np.array([0.0, 0.5, 1.0, 1.5])
    tracking.add(times[:2], wave(times[:2]) + 5.0)  # before 1 s: not counted
    assert tracking.largest is None
    tracking.add(times[2:], wave(times[2:]) + np.array([[0.01], [-0.03]]))
    assert tracking.largest == pytest.approx(0.03)


@pytest.mark.parametrize("name", ["position", "trajectory"])
def test_a_run_without_output_gives_the_table_of_a_run_with_it(tmp_path, name):
    overrides = FAST + "sequencer: {period: 1.0}\nsimulation: {duration: 5.0}"
    scenario = load_scenario(name, overrides)
    without = run(scenario, scenario_name=name, quiet=True, stream=io.StringIO())
    scenario = load_scenario(name, overrides)
    with_output = run(
        scenario,
        scenario_name=name,
        quiet=True,
        stream=io.StringIO(),
        output_dir=tmp_path,
        replay=False,
    )
    assert len(without.steps) == 5
    assert without.steps == with_output.steps
    assert all(step.final_error <= 0.01 for step in without.steps)
    summary = json.loads((tmp_path / "summary.json").read_text())
    for step, row in zip(without.steps, summary["steps"], strict=True):
        assert row["final_error"] == step.final_error
        assert row["largest_error_after_settling"] == step.largest_error_after_settling
        assert row["settling_time"] == step.settling_time
        assert step.largest_error_after_settling <= SETTLE_TOLERANCE
    assert with_output.headline().startswith(f"{name} with the {name} controller (")


def test_a_sinusoid_run_without_output_gives_its_tracking_error(tmp_path):
    overrides = FAST + "simulation: {duration: 3.0}"
    without = run(load_scenario("sinusoid", overrides), quiet=True, stream=io.StringIO())
    with_output = run(
        load_scenario("sinusoid", overrides),
        quiet=True,
        stream=io.StringIO(),
        output_dir=tmp_path,
        replay=False,
    )
    assert without.tracking_error == with_output.tracking_error
    assert 0 < without.tracking_error <= 0.05
    # commands.csv holds every sample at the controller rate, 0 to 2.99 s (the 3 s
    # sample would be taken by the next step).
    commands = np.loadtxt(tmp_path / "commands.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(commands[:, 0], np.arange(300) / 100.0, atol=1e-9)
    expected = (np.pi / 2) * np.sin(2 * np.pi * 0.05 * commands[:, 0])
    np.testing.assert_allclose(commands[:, 1], expected, atol=1e-9)
    np.testing.assert_allclose(commands[:, 3], -expected, atol=1e-9)  # j2 in antiphase


@pytest.mark.parametrize(
    "controller, driven, expected",
    [
        ("position", "position_controller", "with the position controller (position_controller)"),
        ("task", "joint_space_controller", "with a task-space motion (joint_space_controller)"),
        ("jog", "position_controller", "jogged from the viewer (position_controller)"),
        (
            "vision",
            "improved_look_at_point_controller",
            "with the camera's detections driving the arm (improved_look_at_point_controller)",
        ),
        (
            "dds",
            "position_controller/commands",
            "with DDS commands driving the arm (position_controller/commands)",
        ),
        ("none", "", "with no controller driving the arm"),
    ],
)
def test_the_final_line_names_what_drove_the_arm(controller, driven, expected):
    result = RunResult(
        scenario="diagrams/x.yaml",
        controller=controller,
        sim_time=2.0,
        wall_time=1.0,
        realtime_factor=2.0,
        interrupted=False,
        joint_names=["j0"],
        driven=driven,
    )
    assert result.headline() == f"x.yaml {expected}: 2.00 s simulated in 1.00 s (2.00x real time)"


def test_an_interrupted_run_says_it_writes_only_what_it_writes(tmp_path):
    assert _interrupted_message(None, None) == "interrupted"
    assert _interrupted_message(tmp_path, None) == "interrupted: writing the logs and the summary"
    assert _interrupted_message(None, "run.mcap") == "interrupted: writing the recording"
    assert _interrupted_message(tmp_path, "run.mcap") == (
        "interrupted: writing the logs and the summary and the recording"
    )
