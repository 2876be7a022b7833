"""Running a scenario: the arm controller node of the bring-up, start to finish.

:func:`run` builds the world of a scenario with :func:`~armando_drake.simulation.builder.MakeWorld`,
simulates it (paced to real time or as fast as possible, with a progress line
when not paced), survives Ctrl-C, and reports per command step the target,
the reached position, the largest joint error and the time to settle within
0.01 rad. With an output folder it writes ``joint_states.csv`` (the logger),
``commands.csv`` (every command published) and ``summary.json``.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from armando_drake.simulation.scenario import Scenario

SETTLE_TOLERANCE = 0.01  # [rad] "reached" band of the step table


@dataclass
class StepResult:
    """One command step of the run."""

    start: float  # [s] when the step's command began
    end: float  # [s] when the next step began (or the run ended)
    target: list[float]  # [rad] per joint
    reached: list[float]  # [rad] measured at the end of the step
    max_abs_error: float  # [rad] largest |reached - target| over the joints
    settle_time: float | None  # [s] from start until within 0.01 rad for good, None if never


@dataclass
class RunResult:
    """What a run did."""

    scenario: str
    controller: str
    sim_time: float  # [s]
    wall_time: float  # [s]
    realtime_factor: float
    interrupted: bool
    joint_names: list[str]
    steps: list[StepResult] = field(default_factory=list)
    tracking_error: float | None = None  # [rad] sinusoid: max |q - reference| after 1 s
    # task: max_position_error, rms_position_error [m], max_orientation_error [rad]
    task_space: dict[str, Any] | None = None
    output_dir: str | None = None

    def summary(self) -> dict[str, Any]:
        """The ``summary.json`` contract."""
        return {
            "scenario": self.scenario,
            "controller": self.controller,
            "sim_time": self.sim_time,
            "wall_time": self.wall_time,
            "realtime_factor": self.realtime_factor,
            "interrupted": self.interrupted,
            "joint_names": self.joint_names,
            "tracking_error": self.tracking_error,
            "task_space": self.task_space,
            "steps": [
                {
                    "target": step.target,
                    "reached": step.reached,
                    "max_abs_error": step.max_abs_error,
                    "settle_time": step.settle_time,
                    "start": step.start,
                }
                for step in self.steps
            ],
        }


def controller_mode(scenario: Scenario) -> str:
    """position | trajectory | sinusoid | none: what drives the arm."""
    if scenario.sequencer is None:
        return "none"
    return scenario.sequencer.mode


def default_duration(scenario: Scenario) -> float:
    """[s] one pass of the command sequence (2 s without one)."""
    config = scenario.sequencer
    if config is None:
        return 2.0
    if config.mode == "sinusoid":
        return config.start_delay + 1.0 / config.frequency
    return config.start_delay + len(config.targets) * config.period


def read_joint_states(path: Path, joint_names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(times [s], positions [rad] per joint) from a joint_states.csv."""
    with open(path, newline="", encoding="utf-8") as file:
        rows = list(csv.reader(file))
    if len(rows) < 2:
        return np.zeros(0), np.zeros((0, len(joint_names)))
    header = rows[0]
    columns = [header.index(f"{name}_position") for name in joint_names]
    data = []
    for row in rows[1:]:
        if len(row) == len(header):  # a row cut by a kill is skipped
            data.append([float(row[0])] + [float(row[c]) for c in columns])
    array = np.array(data) if data else np.zeros((0, len(joint_names) + 1))
    return array[:, 0], array[:, 1:]


def step_table(
    times: np.ndarray,
    positions: np.ndarray,
    steps: list[tuple[float, list[float]]],
    end_time: float,
) -> list[StepResult]:
    """Per step: the position reached just before the next step, its error, settle time."""
    results = []
    for k, (start, target) in enumerate(steps):
        end = steps[k + 1][0] if k + 1 < len(steps) else end_time
        last = k + 1 == len(steps)
        inside = (times >= start - 1e-9) & ((times <= end + 1e-9) if last else (times < end - 1e-9))
        if not inside.any():
            continue
        window_t = times[inside]
        window_q = positions[inside]
        reached = window_q[-1]
        error = np.abs(window_q - np.asarray(target)).max(axis=1)
        outside = np.nonzero(error > SETTLE_TOLERANCE)[0]
        if error[-1] > SETTLE_TOLERANCE:
            settle = None
        elif len(outside) == 0:
            settle = 0.0
        else:
            settle = float(window_t[outside[-1] + 1] - start)
        results.append(
            StepResult(
                start=float(start),
                end=float(end),
                target=[float(v) for v in target],
                reached=[float(v) for v in reached],
                max_abs_error=float(error[-1]),
                settle_time=settle,
            )
        )
    return results


def format_table(joint_names: list[str], steps: list[StepResult]) -> str:
    """The end-of-run table, one line per step."""
    width = 7 * len(joint_names)
    lines = [
        f"{'step':>4}  {'t [s]':>6}  {'target [rad]':<{width}}  {'reached [rad]':<{width}}"
        f"  {'max err':>8}  {'settle [s]':>10}"
    ]
    for k, step in enumerate(steps):
        target = " ".join(f"{v:6.3f}" for v in step.target)
        reached = " ".join(f"{v:6.3f}" for v in step.reached)
        settle = "-" if step.settle_time is None else f"{step.settle_time:.3f}"
        lines.append(
            f"{k:>4}  {step.start:6.2f}  {target:<{width}}  {reached:<{width}}"
            f"  {step.max_abs_error:8.4f}  {settle:>10}"
        )
    return "\n".join(lines)


class _Progress:
    """A one-line progress indication on stderr for runs not paced to real time."""

    def __init__(self, duration: float, stream: TextIO = sys.stderr):
        self._duration = duration
        self._stream = stream
        self._tty = stream.isatty()
        self._start = time.monotonic()
        self._last_percent = -1

    def update(self, sim_time: float) -> None:
        percent = int(100 * sim_time / self._duration) if self._duration > 0 else 100
        if not self._tty and percent // 10 == self._last_percent // 10:
            return
        self._last_percent = percent
        wall = time.monotonic() - self._start
        rate = sim_time / wall if wall > 0 else math.inf
        end = "\r" if self._tty else "\n"
        self._stream.write(
            f"[{percent:3d}%] t = {sim_time:7.2f} / {self._duration:.2f} s "
            f"({rate:5.1f}x real time){end}"
        )
        self._stream.flush()

    def finish(self) -> None:
        if self._tty:
            self._stream.write("\n")


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """Treats SIGTERM like Ctrl-C so a terminated run still writes its logs."""

    def handler(signum, frame):
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run(
    scenario: Scenario,
    *,
    scenario_name: str = "",
    output_dir: str | Path | None = None,
    meshcat=None,
    quiet: bool = False,
    stream: TextIO = sys.stdout,
    replay: bool = True,
    record: str | Path | None = None,
) -> RunResult:
    """Builds and simulates ``scenario``; returns (and, with ``output_dir``, writes) results.

    With ``output_dir`` it also writes the plots (:mod:`armando_drake.outputs.plots`)
    and, with ``replay``, ``replay.html`` (:mod:`armando_drake.outputs.replay`;
    without ``meshcat`` a private Meshcat records it). ``record``: an
    ``.mcap`` file for the ROS 2 recording (:mod:`armando_drake.outputs.recording`).
    """
    import tempfile

    from pydrake.systems.analysis import Simulator

    from armando_drake.simulation.builder import MakeWorld

    duration = scenario.simulation.duration
    if duration <= 0:
        duration = default_duration(scenario)
    temporary = None
    if output_dir is None:
        temporary = tempfile.TemporaryDirectory(prefix="armando_drake_")
        log_dir = Path(temporary.name)
    else:
        log_dir = Path(output_dir)
        log_dir.mkdir(parents=True, exist_ok=True)
    replay_meshcat = None
    if output_dir is not None and replay:
        from armando_drake.outputs.replay import RecordingMeshcat, start_replay

        replay_meshcat = meshcat if meshcat is not None else RecordingMeshcat()
    world = MakeWorld(
        scenario,
        meshcat=meshcat if replay_meshcat is None else replay_meshcat,
        output_dir=log_dir,
        quiet=quiet,
        source=scenario_name,
        write_commands=output_dir is not None,
        record=record,
    )
    if replay_meshcat is not None:
        start_replay(replay_meshcat, live=replay_meshcat is meshcat)
    joint_names = world.hardware.joint_names
    simulator = Simulator(world.diagram)
    realtime_rate = scenario.simulation.realtime_rate
    simulator.set_target_realtime_rate(realtime_rate)
    progress = None if (realtime_rate > 0 or quiet) else _Progress(duration)
    if meshcat is not None:
        print(f"Meshcat: {meshcat.web_url()}", file=stream, flush=True)
    if world.image_view_url:
        print(f"Camera view: {world.image_view_url}", file=stream, flush=True)
    interrupted = False
    wall_start = time.monotonic()
    with _sigterm_as_interrupt():
        try:
            simulator.Initialize()
            # Advance in slices of about 1 % (at least 50 ms) for the progress
            # line; slice ends are computed, not accumulated, so the last one
            # is exactly ``duration`` and its final controller tick runs.
            slices = max(1, min(100, math.ceil(duration / 0.05)))
            for k in range(1, slices + 1):
                target = duration if k == slices else duration * k / slices
                if target <= simulator.get_context().get_time():
                    continue
                simulator.AdvanceTo(target)
                if progress:
                    progress.update(target)
        except KeyboardInterrupt:
            interrupted = True
            print("\ninterrupted: writing the logs and the summary", file=stream, flush=True)
    wall_time = time.monotonic() - wall_start
    if progress:
        progress.finish()
    sim_time = simulator.get_context().get_time()
    world.close(simulator.get_context())

    result = RunResult(
        scenario=scenario_name,
        controller=controller_mode(scenario),
        sim_time=sim_time,
        wall_time=wall_time,
        realtime_factor=sim_time / wall_time if wall_time > 0 else math.inf,
        interrupted=interrupted,
        joint_names=joint_names,
        output_dir=None if output_dir is None else str(output_dir),
    )
    csv_path = log_dir / "joint_states.csv"
    if world.sequencer is not None and csv_path.is_file():
        sequencer_joints = world.controller_joints[world.sequencer_target]
        times, positions = read_joint_states(csv_path, sequencer_joints)
        config = world.sequencer.config
        if config.mode == "sinusoid":
            result.tracking_error = _sinusoid_error(world.sequencer, times, positions)
        else:
            steps = [(t, list(config.targets[k])) for t, k in world.sequencer.step_times(sim_time)]
            result.steps = step_table(times, positions, steps, sim_time)
    if world.task is not None and csv_path.is_file():
        from armando_drake.outputs.task_space import (
            TASK_SPACE_CSV,
            task_space_errors,
            write_task_space_csv,
        )

        times, positions = read_joint_states(csv_path, world.task.arm.joint_names)
        errors = task_space_errors(world.task, times, positions, world.task.arm.joint_names)
        result.task_space = errors.summary()
        if output_dir is not None:
            write_task_space_csv(errors, log_dir / TASK_SPACE_CSV)
        if world.meshcat is not None and len(times):
            from pydrake.geometry import Rgba

            world.meshcat.SetLine(
                "task/end_effector_trace", errors.actual.T, 2.0, Rgba(1.0, 0.3, 0.1, 1.0)
            )
    if temporary is not None:
        temporary.cleanup()
    if output_dir is not None:
        (log_dir / "summary.json").write_text(json.dumps(result.summary(), indent=2) + "\n")
        from armando_drake.outputs.plots import write_plots

        write_plots(log_dir)
    if replay_meshcat is not None:
        from armando_drake.outputs.replay import REPLAY_FILE, write_replay

        write_replay(replay_meshcat, log_dir / REPLAY_FILE)
    return result


def _sinusoid_error(sequencer, times: np.ndarray, positions: np.ndarray) -> float | None:
    """[rad] largest |q - reference| after the first second of the sinusoid."""
    from armando_drake.control.sequencer import sinusoid_of

    config = sequencer.config
    wave = sinusoid_of(config, sequencer.joint_names)
    keep = times >= config.start_delay + 1.0
    if not keep.any():
        return None
    t = times[keep][:, None] - config.start_delay
    reference = np.asarray(wave.offset) + np.asarray(wave.amplitude) * np.sin(
        2 * np.pi * wave.frequency * t + np.asarray(wave.phase)
    )
    return float(np.abs(positions[keep] - reference).max())
