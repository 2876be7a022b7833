"""Running a scenario: the arm controller node of the bring-up, start to finish.

:func:`run` builds the world of a scenario with :func:`~armando_drake.simulation.builder.MakeWorld`,
simulates it with Drake's ``Simulator`` set up by ``ApplySimulatorConfig``
(paced to real time or as fast as possible, with a progress bar on a
terminal when faster than real time), survives Ctrl-C, and reports per
command step the target, the reached position, the final error, the largest
error after settling and the settling time (within :data:`SETTLE_TOLERANCE`).
The table is computed in memory from the rows the joint-state logger records,
with or without an output folder.
With an output folder it writes ``joint_states.csv`` (the logger),
``commands.csv`` (every command published) and ``summary.json`` (which also names the
version of armando-drake that ran, and its git commit from a checkout).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import signal
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator

from armando_drake.control.sequencer import Sinusoid, mode_of, wave_of
from armando_drake.control.stack import effective_actuators
from armando_drake.kinematics.arm import tool_frame
from armando_drake.outputs.logger import rounded
from armando_drake.outputs.navigation import (
    goal_rejections,
    navigation_summary,
    write_navigation_map,
    write_navigation_plot,
)
from armando_drake.outputs.plots import write_plots
from armando_drake.outputs.replay import REPLAY_FILE, RecordingMeshcat, publish_replay, write_replay
from armando_drake.outputs.task_space import TASK_SPACE_CSV, TaskSpaceTracker, write_task_space_csv
from armando_drake.outputs.view import wait_for_browser as wait
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import (
    RobotEntry,
    Scenario,
    ScenarioRobot,
    default_duration,
    dump_scenario,
    scenario_robots,
    sources_of,
)
from armando_drake.tools.cli import STOP_SIGNALS, meshcat_urls
from armando_drake.tools.files import writing
from armando_drake.tools.version import provenance
from armando_drake.vision.outputs import write_vision_outputs

SCENARIO_FILE = "scenario.yaml"  # the effective scenario, in the output folder
SETTLE_TOLERANCE = 0.01  # [rad] "reached" band of the step table
TRACKING_SKIP = 1.0  # [s] the sinusoid's tracking error counts from start_delay + this


@dataclass
class StepResult:
    """One command step of the run."""

    start: float  # [s] when the step's command began
    end: float  # [s] when the next step began (or the run ended)
    target: list[float]  # [rad] per joint
    reached: list[float]  # [rad] measured at the end of the step
    final_error: float  # [rad] largest |reached - target| over the joints, at the step's end
    # [rad] largest |q - target| over the joints and the samples after settling;
    # None if it never settled.
    largest_error_after_settling: float | None
    # [s] from start until within SETTLE_TOLERANCE for good; None if never.
    settling_time: float | None


def step_summary(step: StepResult) -> dict[str, Any]:
    """A step of the table as summary.json has it."""
    return {
        "target": step.target,
        "reached": step.reached,
        "final_error": step.final_error,
        "largest_error_after_settling": step.largest_error_after_settling,
        "settling_time": step.settling_time,
        "start": step.start,
    }


@dataclass
class RunResult:
    """What a run did."""

    scenario: str
    controller: str  # what drove the robot: controller_mode(), or vision | dds
    sim_time: float  # [s]
    wall_time: float  # [s]
    realtime_factor: float
    interrupted: bool
    joint_names: list[str]
    steps: list[StepResult] = field(default_factory=list)
    tracking_error: float | None = None  # [rad] sinusoid: max |q - wave| after 1 s
    # task: max_position_error, rms_position_error [m], max_orientation_error [rad]
    task_space: dict[str, Any] | None = None
    output_dir: str | None = None
    # What drove the arm: the controller the sequencer, the task, the jog or the camera's
    # detections drove, by its name in the YAML; with DDS, the command topics used.
    driven: str = ""
    # Vision: frames, detections, final_pointing_error [rad], marker_position_error [m]
    vision: dict[str, Any] | None = None
    # A mobile base: distance travelled [m], final pose, odometry drift (outputs/base.py)
    base: dict[str, Any] | None = None
    # Navigation: per goal reached, errors [m, rad], time [s], path length [m]; collisions
    navigation: dict[str, Any] | None = None
    # Perception: the last point cloud's planes and clusters (PerceptionResult.summary)
    perception: dict[str, Any] | None = None
    # A world of several robots: per robot name, its namespace, joints, driven controller,
    # step table (or tracking error), largest final error [rad], base and end effector
    # (robot_summary).
    robots: dict[str, Any] | None = None
    # Runtime inputs dropped (not finite, out of range, malformed), by topic.
    rejected_messages: dict[str, int] = field(default_factory=dict)
    # The cameras, by name: renderer, antialiasing, size, rate (AddedCamera.summary).
    # Absent from summary.json when the world has none.
    cameras: dict[str, Any] = field(default_factory=dict)
    # Settings for interactive runs that were on (e.g. camera.max_rate), by key: the
    # figures are not the scenario's own. Absent from summary.json when none was.
    interactive: dict[str, Any] = field(default_factory=dict)
    # Their step tables, by robot name (not in summary.json: robots has them).
    robot_steps: dict[str, list[StepResult]] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """The ``summary.json`` contract; ``armando_drake`` names the code that produced
        the run (version, and the git commit when run from a checkout)."""
        return {  # the top-level joints, steps, base: the first robot's of several
            "armando_drake": provenance(),
            "scenario": self.scenario,
            "controller": self.controller,
            "driven_controller": self.driven,
            "sim_time": self.sim_time,
            "wall_time": self.wall_time,
            "realtime_factor": self.realtime_factor,
            "interrupted": self.interrupted,
            "joint_names": self.joint_names,
            "tracking_error": self.tracking_error,
            "task_space": self.task_space,
            "steps": [step_summary(step) for step in self.steps],
            "vision": self.vision,
            "base": self.base,
            "navigation": self.navigation,
            "perception": self.perception,
            "rejected_messages": self.rejected_messages,
            **({"robots": self.robots} if self.robots is not None else {}),
            **({"cameras": self.cameras} if self.cameras else {}),
            **({"interactive": self.interactive} if self.interactive else {}),
        }

    def headline(self) -> str:
        """One line naming what ran and how fast, e.g. ``position.yaml with the
        trajectory controller: 15.00 s simulated in 2.10 s (7.14x real time)``."""
        name = Path(self.scenario).name if self.scenario else "the scenario"
        if self.robots:  # several robots: what drove each
            driven = (f"{n} {r['driven_controller'] or 'undriven'}" for n, r in self.robots.items())
            what = f"{name} with {len(self.robots)} robots ({', '.join(driven)})"
        elif self.controller == "task":
            what = f"{name} with a task-space motion"
        elif self.controller == "learned_ik":
            what = f"{name} with target poses through the learned IK"
        elif self.controller == "jog" and self.driven:
            what = f"{name} jogged from the viewer"
        elif self.controller == "jog":
            what = f"{name} with no viewer to jog from (the arm held its home posture)"
        elif self.controller == "twist_jog" and self.driven:
            what = f"{name} driven from the viewer's keys"
        elif self.controller == "twist_jog":
            what = f"{name} with no viewer to drive from (the base stood still)"
        elif self.controller == "vision":
            what = f"{name} with the camera's detections driving the arm"
        elif self.controller == "dds":
            what = f"{name} with DDS commands driving the arm"
        elif self.controller == "twist":
            what = f"{name} with a cmd_vel sequence"
        elif self.controller == "navigation":
            nav = self.navigation or {}
            mapping = nav.get("mapping")
            if mapping:  # the goals are frontiers: the exploration's own outcome
                left = mapping.get("frontiers_left")
                state = "done" if mapping.get("done") else "not done"
                what = f"{name} exploring, {state}, {left} frontiers left"
            else:
                reached, goals = nav.get("reached", 0), len(nav.get("goals", []))
                what = f"{name} navigating to goals, {reached}/{goals} reached"
        elif self.controller == "none":
            what = f"{name} with no controller driving the arm"
        elif self.controller == "sinusoid":
            what = f"{name} with a sinusoid on the position controller"
        else:
            what = f"{name} with the {self.controller} controller"
        if self.driven and not self.robots:
            what += f" ({self.driven})"
        return (
            f"{what}: {self.sim_time:.2f} s simulated in {self.wall_time:.2f} s "
            f"({self.realtime_factor:.2f}x real time)"
            + (" [interrupted]" if self.interrupted else "")
        )


def write_scenario(scenario: Scenario, path: Path) -> None:
    """Writes ``scenario`` as YAML that :func:`~armando_drake.simulation.scenario.load_scenario`
    reads back to an equal scenario."""
    with writing(path):
        path.write_text(
            "# The effective scenario of this run: the file with every override applied.\n"
            + dump_scenario(scenario)
        )


def controller_mode(scenario: Scenario) -> str:
    """position | trajectory | sinusoid | task | learned_ik | jog | twist | navigation |
    twist_jog | none: what drives the robot; those of several robots joined by ", " (each
    once)."""
    robots = scenario_robots(scenario).values()
    return ", ".join(dict.fromkeys(robot_mode(robot) for robot in robots))


def robot_mode(robot: ScenarioRobot) -> str:
    """What drives one robot (see :func:`controller_mode`)."""
    if robot.entry.sequencer is not None:
        return mode_of(robot.entry.sequencer)
    if robot.section("task") is not None:
        return "task"
    if robot.section("learned_ik") is not None:
        return "learned_ik"
    if robot.entry.twist is not None:
        return "twist"
    if robot.section("navigation") is not None:
        return "navigation"
    jog = robot.section("jog")
    if robot.section("twist_jog") is not None and jog is None:
        return "twist_jog"
    return "none" if jog is None else "jog"


@dataclass
class _Step:
    """What :class:`StepTable` keeps of one step while the rows stream in."""

    start: float  # [s]
    target: np.ndarray  # [rad]
    reached: np.ndarray | None = None  # [rad] the latest sample
    final_error: float = math.nan  # [rad] the latest sample's error
    exceeded: bool = False  # a sample was outside the band
    pending: bool = False  # the latest sample was outside the band
    settled_at: float | None = None  # [s] the first sample after the latest one outside
    largest_after: float = -math.inf  # [rad] largest error since the latest one outside


class StepTable:
    """The step table of a target sequence, computed from rows as they stream in.

    Step k starts at ``start_delay + k period`` with target ``targets[k mod n]``
    (after the last target, the steps go on only if ``cyclic``; the last step
    lasts to the end of the run). A row belongs to the step in force at its
    time. Feed it the logger's rows in time order with :meth:`add` (it is a
    :meth:`~armando_drake.outputs.logger.JointStateLogger.add_listener`
    listener); memory stays one small record per step, however long the run.
    """

    def __init__(
        self,
        *,
        targets,
        period: float,
        cyclic: bool,
        start_delay: float = 0.0,
        columns=None,
        tolerance: float = SETTLE_TOLERANCE,
    ):
        self._targets = np.asarray(targets, dtype=float)
        self._period = float(period)
        self._cyclic = cyclic
        self._start_delay = float(start_delay)
        self._columns = None if columns is None else np.asarray(columns, dtype=int)
        self._tolerance = tolerance
        self._steps: dict[int, _Step] = {}

    def _index(self, times: np.ndarray) -> np.ndarray:
        k = np.floor((times - self._start_delay) / self._period + 1e-9).astype(int)
        if not self._cyclic:
            k = np.minimum(k, len(self._targets) - 1)
        return k

    def add(self, times: np.ndarray, positions: np.ndarray) -> None:
        """Takes rows: ``times`` [s] (m,), ``positions`` [rad] (m, columns); with
        ``columns``, those columns of ``positions`` are the sequence's joints."""
        times = np.asarray(times, dtype=float)
        q = np.asarray(positions, dtype=float)
        if self._columns is not None:
            q = q[:, self._columns]
        keep = times >= self._start_delay - 1e-9
        times, q, index = times[keep], q[keep], self._index(times[keep])
        for k in np.unique(index).tolist():
            rows = index == k
            step = self._steps.get(k)
            if step is None:
                start = self._start_delay + k * self._period
                step = self._steps[k] = _Step(start, self._targets[k % len(self._targets)])
            self._update(step, times[rows], q[rows])

    def _update(self, step: _Step, t: np.ndarray, q: np.ndarray) -> None:
        error = np.abs(q - step.target).max(axis=1)
        outside = np.nonzero(error > self._tolerance)[0]
        if len(outside):
            step.exceeded = True
            last = outside[-1]
            step.pending = last + 1 == len(t)
            step.settled_at = None if step.pending else float(t[last + 1])
            step.largest_after = -math.inf if step.pending else float(error[last + 1 :].max())
        else:
            if step.pending:
                step.settled_at = float(t[0])
                step.pending = False
            step.largest_after = max(step.largest_after, float(error.max()))
        step.reached = q[-1]
        step.final_error = float(error[-1])

    def results(self, end_time: float) -> list[StepResult]:
        """One :class:`StepResult` per step that has rows, the last ending at ``end_time``."""
        # A step that begins when the run ends never ran.
        keys = [k for k in sorted(self._steps) if self._steps[k].start < end_time - 1e-9]
        keys = keys or sorted(self._steps)[:1]
        results = []
        for position, k in enumerate(keys):
            step = self._steps[k]
            settled = step.final_error <= self._tolerance
            if not settled:
                settling = None
            elif not step.exceeded:
                settling = 0.0
            else:
                settling = step.settled_at - step.start
            following = keys[position + 1] if position + 1 < len(keys) else None
            end = end_time if following is None else self._steps[following].start
            results.append(
                StepResult(
                    start=step.start,
                    end=float(end),
                    target=step.target.tolist(),
                    reached=step.reached.tolist(),
                    final_error=step.final_error,
                    largest_error_after_settling=step.largest_after if settled else None,
                    settling_time=settling,
                )
            )
        return results


class TrackingError:
    """The largest |q - wave(t)| over the joints of the rows at or after ``after`` [s]."""

    def __init__(self, wave, *, after: float, columns=None):
        self._wave = wave
        self._after = after
        self._columns = None if columns is None else np.asarray(columns, dtype=int)
        self.largest: float | None = None  # [rad], None before a row counts

    def add(self, times: np.ndarray, positions: np.ndarray) -> None:
        keep = np.asarray(times) >= self._after - 1e-9
        if not keep.any():
            return
        q = np.asarray(positions)[keep]
        if self._columns is not None:
            q = q[:, self._columns]
        error = float(np.abs(q - self._wave(np.asarray(times)[keep])).max())
        self.largest = error if self.largest is None else max(self.largest, error)


def format_table(joint_names: list[str], steps: list[StepResult]) -> str:
    """The end-of-run table, one line per step: final error, largest error after
    settling and settling time as in summary.json."""
    width = 7 * len(joint_names)
    lines = [
        f"{'step':>4}  {'t [s]':>6}  {'target [rad]':<{width}}  {'reached [rad]':<{width}}"
        f"  {'final error':>11}  {'after settling':>14}  {'settling [s]':>12}"
    ]
    for k, step in enumerate(steps):
        target = " ".join(f"{rounded(v):6.3f}" for v in step.target)
        reached = " ".join(f"{rounded(v):6.3f}" for v in step.reached)
        settle = "-" if step.settling_time is None else f"{step.settling_time:.3f}"
        after = step.largest_error_after_settling
        after_text = "-" if after is None else f"{after:.4f}"
        lines.append(
            f"{k:>4}  {step.start:6.2f}  {target:<{width}}  {reached:<{width}}"
            f"  {step.final_error:11.4f}  {after_text:>14}  {settle:>12}"
        )
    return "\n".join(lines)


class Progress:
    """A tqdm progress bar on stderr for runs faster than real time: simulated time,
    real-time factor and time left; silent when stderr is not a terminal."""

    def __init__(self, duration: float, stream: TextIO | None = None):
        self._duration = duration
        self._stream = stream if stream is not None else sys.stderr
        self._bar = None
        self._start = time.monotonic()
        if not self._stream.isatty():
            return
        from tqdm import tqdm

        self._bar = tqdm(
            total=duration,
            unit="s",
            unit_scale=False,
            file=self._stream,
            leave=False,
            dynamic_ncols=True,
            # tqdm puts ", " in front of the postfix itself.
            bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} s simulated "
            "[{elapsed}<{remaining}{postfix}]",
        )

    @contextlib.contextmanager
    def printing_above(self) -> Iterator[None]:
        """Within it, what is printed to standard output (the console log once a
        second) goes above the bar, which is cleared and redrawn around it."""
        if self._bar is None:
            yield
            return
        with contextlib.redirect_stdout(_AboveBar(sys.stdout, self._bar)):
            yield

    def restart(self) -> None:
        """The wall clock starts now (after a wait for a browser)."""
        self._start = time.monotonic()
        if self._bar is not None:
            self._bar.reset(total=self._duration)

    def update(self, sim_time: float) -> None:
        if self._bar is None:
            return
        wall = time.monotonic() - self._start
        rate = sim_time / wall if wall > 0 else math.inf
        self._bar.set_postfix_str(f"{rate:.1f}x real time", refresh=False)
        self._bar.update(sim_time - self._bar.n)

    def finish(self) -> None:
        if self._bar is not None:
            self._bar.close()


class _AboveBar(io.TextIOBase):
    """A text stream that writes to ``stream`` with the progress ``bar`` cleared first."""

    def __init__(self, stream: TextIO, bar):
        self._stream, self._bar = stream, bar

    def write(self, text: str) -> int:
        with self._bar.external_write_mode(file=self._bar.fp):
            self._stream.write(text)
            self._stream.flush()
        return len(text)

    def flush(self) -> None:
        self._stream.flush()

    def isatty(self) -> bool:
        return self._stream.isatty()


class _Interrupts:
    """Ctrl-C (SIGINT), SIGTERM and SIGHUP during a run: the first raises KeyboardInterrupt
    (the simulation stops, and a terminated run still writes its logs); any later
    one is only counted, so it cannot cut the logs in half, and :meth:`raise_pending`
    raises it once they are written."""

    def __init__(self):
        self.received = 0  # signals received
        self.raised = 0  # of them raised as KeyboardInterrupt
        self.raising = True  # whether the next one raises

    def _handler(self, signum, frame):
        self.received += 1
        if self.raising:
            self.raising = False
            self.raised += 1
            raise KeyboardInterrupt

    @contextlib.contextmanager
    def installed(self):
        try:
            previous = {s: signal.signal(s, self._handler) for s in STOP_SIGNALS}
        except ValueError:  # not the main thread
            yield self
            return
        try:
            yield self
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)

    def raise_pending(self, what: str) -> None:
        if self.received > self.raised:
            raise KeyboardInterrupt(what)


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
    plots: bool = True,
    wait_for_browser: float = 0.0,
    host: str = "127.0.0.1",
) -> RunResult:
    """Builds and simulates ``scenario``; returns (and, with ``output_dir``, writes) results.

    With ``output_dir`` it also writes, with ``plots``, the plots
    (:mod:`armando_drake.outputs.plots`) and, with ``replay``, ``replay.html``
    (:mod:`armando_drake.outputs.replay`; without ``meshcat`` a private Meshcat
    records it). ``record``: an
    ``.mcap`` file for the ROS 2 recording (:mod:`armando_drake.outputs.recording`).
    With ``meshcat`` and ``replay``, the run is published there as an animation at the
    end; ``wait_for_browser`` [s]: how long to wait for a browser on ``meshcat``
    before the clock starts (0: not at all). ``host``: the address the camera's live
    view listens on (``--host``, checked: :func:`~armando_drake.tools.cli.check_host`).
    """
    duration = scenario.simulation.duration
    if duration <= 0:
        duration = default_duration(scenario)
    log_dir = None
    if output_dir is not None:
        log_dir = Path(output_dir)
        log_dir.mkdir(parents=True, exist_ok=True)
    # The replay: into the live Meshcat when there is one (kept after the run), else,
    # for replay.html, into a private one.
    replay_meshcat = meshcat
    if replay_meshcat is None and output_dir is not None and replay:
        replay_meshcat = RecordingMeshcat()
    world = MakeWorld(
        scenario,
        meshcat=replay_meshcat,
        output_dir=log_dir,
        quiet=quiet,
        source=scenario_name,
        write_commands=output_dir is not None,
        record=record,
        host=host,
    )
    if log_dir is not None:  # what ran: the scenario after every override, gains derived
        write_scenario(_effective(scenario, world), log_dir / SCENARIO_FILE)
    # The step tables (or the sinusoid's tracking errors) from the loggers' rows.
    tables = {name: _table_of(r, r.logger) for name, r in world.robots.items()}
    table = tables[world.robot().name]
    tracker = _task_tracker_of(world)
    simulator = Simulator(world.diagram)
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    realtime_rate = scenario.simulator_config.target_realtime_rate
    progress = None if (0 < realtime_rate <= 1 or quiet) else Progress(duration)
    _announce(world, meshcat, stream)
    signals = _Interrupts()
    with signals.installed(), progress.printing_above() if progress else contextlib.nullcontext():
        interrupted, wall_time = _simulate(
            simulator,
            duration,
            signals,
            progress,
            meshcat,
            wait_for_browser,
            stream,
            _interrupted_message(log_dir, record),
        )
        if progress:
            progress.finish()
        sim_time = simulator.get_context().get_time()
        # The logs and the summary are written whole, whatever signal comes.
        world.close(simulator.get_context())  # the logger's last rows reach the table too
        result = _result(scenario, world, simulator, table, tracker, log_dir, scenario_name)
        entries = scenario.robots
        _add_robot_sections(result, world, tables, simulator.get_context(), entries)
        result.scenario, result.sim_time, result.wall_time = scenario_name, sim_time, wall_time
        result.realtime_factor = sim_time / wall_time if wall_time > 0 else math.inf
        result.interrupted = interrupted
        result.output_dir = None if output_dir is None else str(output_dir)
        if log_dir is not None:
            with writing(log_dir / "summary.json"):
                (log_dir / "summary.json").write_text(json.dumps(result.summary(), indent=2) + "\n")
            if result.navigation is not None:  # what the run made: kept with its logs
                write_navigation_map(log_dir, world, simulator.get_context())
    # A Ctrl-C that came while they were written stops the plots and the replay.
    signals.raise_pending(f"the logs are complete in {log_dir}" if log_dir else "")
    if log_dir is not None and plots:
        for folder in {log_dir / robot.folder for robot in world.robots.values()}:
            write_plots(folder)
    if log_dir is not None and result.navigation is not None:
        write_navigation_plot(log_dir, world, result.navigation, simulator.get_context())
    if replay and replay_meshcat is not None and world.replay_sampler is not None:
        _publish_replay(replay_meshcat, world, simulator, log_dir)
    return result


def _announce(world, meshcat, stream) -> None:
    """Prints where the run is watched: Meshcat, the cameras' live view."""
    if meshcat is not None:
        print(f"Meshcat: {meshcat_urls(meshcat)}", file=stream, flush=True)
    if world.image_view_url:
        urls = getattr(world.image_view, "urls", world.image_view_url)
        print(f"Camera view: {urls}", file=stream, flush=True)


def _interrupted_message(log_dir, record) -> str:
    """What a Ctrl-C during the simulation prints: what is still written, if anything."""
    writing = ["the logs and the summary"] if log_dir is not None else []
    writing += ["the recording"] if record is not None else []
    return "interrupted: writing " + " and ".join(writing) if writing else "interrupted"


def _simulate(
    simulator, duration, signals, progress, meshcat, wait_for_browser, stream, interrupted_message
):
    """Runs ``simulator`` to ``duration`` [s] in slices (the progress line), after waiting
    up to ``wait_for_browser`` [s] for a browser on ``meshcat``; (interrupted, wall time
    [s] since the clock started). A Ctrl-C prints ``interrupted_message``."""
    interrupted = False
    wall_start = time.monotonic()
    try:
        # The messages in the order things happen: the wait and the browser connecting,
        # then the start (the scene reaches the page, the t = 0 state is printed).
        waits = meshcat is not None and wait_for_browser > 0
        connected = wait(meshcat, wait_for_browser, stream) if waits else False
        simulator.Initialize()
        if waits:
            if connected:
                time.sleep(0.5)  # the page loads the scene Initialize sent
            simulator.ResetStatistics()  # the pacing to real time starts now
            wall_start = time.monotonic()
            if progress:
                progress.restart()
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
        signals.raising = False  # from here on a Ctrl-C waits for the logs
        if signals.raised:  # raised, but caught by a library that went on
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        interrupted = True
        print(f"\n{interrupted_message}", file=stream, flush=True)
    return interrupted, time.monotonic() - wall_start


def _publish_replay(replay_meshcat, world, simulator, log_dir) -> None:
    """The run as an animation in Meshcat (the live page keeps it) and in replay.html."""
    publish_replay(
        replay_meshcat,
        world.diagram,
        world.plant,
        world.replay_sampler,
        simulator.get_context(),
    )
    if log_dir is not None:
        write_replay(replay_meshcat, log_dir / REPLAY_FILE)


def _result(scenario, world, simulator, table, tracker, log_dir, name: str = "") -> RunResult:
    """The run's result, with the step table, the task-space errors (task_space.csv in
    ``log_dir``) and the vision outputs (their plot titled with the scenario's ``name``);
    the caller fills in names and times."""
    sim_time = simulator.get_context().get_time()

    watcher = world.robot_with("detectors")  # the robot the vision acts on
    vision_driven = watcher.detectors.driven if watcher.detectors is not None else []
    mode = "vision" if vision_driven else controller_mode(scenario)
    dds_topics = _dds_command_topics(world)
    if mode == "none" and dds_topics:
        mode = "dds"
    result = RunResult(
        scenario="",
        controller=mode,
        sim_time=sim_time,
        wall_time=0.0,
        realtime_factor=0.0,
        interrupted=False,
        joint_names=world.robot().stack.hardware.joint_names,
        driven=world.robot().sequencer_target
        or world.robot().twist_target
        or (world.robot().task.controller if world.robot().task else "")
        or (world.robot().jog.controller if world.robot().jog else "")
        or ", ".join(vision_driven)
        or ", ".join(dds_topics),
    )
    if scenario.camera.max_rate > 0:
        result.interactive["camera.max_rate"] = scenario.camera.max_rate
    for robot in world.robots.values():
        result.cameras |= {name: camera.summary() for name, camera in robot.cameras.items()}
    if isinstance(table, StepTable):
        result.steps = table.results(sim_time)
    elif isinstance(table, TrackingError):
        result.tracking_error = table.largest
    if tracker is not None:
        errors = tracker.errors()
        result.task_space = errors.summary()
        if log_dir is not None:
            write_task_space_csv(errors, log_dir / TASK_SPACE_CSV)
        if world.meshcat is not None and len(errors.times):
            from pydrake.geometry import Rgba

            world.meshcat.SetLine(
                "task/end_effector_trace", errors.actual.T, 2.0, Rgba(1.0, 0.3, 0.1, 1.0)
            )
    base = world.robot_with("base_log").base_log
    if base is not None:
        result.base = base.summary()
    result.navigation = navigation_summary(world, simulator.get_context())
    if world.robot_with("perception").perception is not None:
        port = world.diagram.GetOutputPort("perception.result")
        result.perception = port.Eval(simulator.get_context()).summary()
    if world.ros2_bridge is not None:
        result.rejected_messages = world.ros2_bridge.rejections.counts
    for topic, n in goal_rejections(world, simulator.get_context()).items():
        result.rejected_messages[topic] = result.rejected_messages.get(topic, 0) + n
    if watcher.detectors is not None:
        result.vision = write_vision_outputs(
            watcher,
            world.diagram,
            simulator.get_context(),
            scenario,
            log_dir,
            Path(name).stem if name else "",
        )
    return result


def _dds_command_topics(world) -> list[str]:
    """The command topics on which DDS messages came (relative names), in the bridge's
    order; none without the bridge."""
    if world.ros2_bridge is None:
        return []
    return [topic for topic, count in world.ros2_bridge.received.items() if count > 0]


def _task_tracker_of(world):
    """A listener on the world's joint-state logger that follows the end effector of the
    scenario's task (:class:`~armando_drake.outputs.task_space.TaskSpaceTracker`);
    None without a task."""
    robot = world.robot_with("task")
    if robot.task is None or robot.logger is None:
        return None

    tracker = TaskSpaceTracker(robot.task, list(robot.logger.joint_names))
    robot.logger.add_listener(tracker.add)
    return tracker


def _effective(scenario: Scenario, world) -> Scenario:
    """The scenario as it ran, in the form it was given: each robot's gains that the
    robot's own rules gave written out, and the controllers its controller file chose
    activated (the one robot of the top-level keys dumped as those keys)."""
    robots = dict(scenario.robots)
    for name, robot in world.robots.items():
        entry = robots[name]
        robots[name] = dataclasses.replace(
            entry,
            actuators=effective_actuators(entry.actuators, robot.stack.hardware),
            controllers=dataclasses.replace(entry.controllers, activate=robot.choice.activate),
        )
    effective = dataclasses.replace(scenario, robots=robots)
    effective.__dict__["_sources"] = sources_of(scenario)
    return effective


def _add_robot_sections(result: RunResult, world, tables: dict, context, entries) -> None:
    """``result.robots`` and ``result.robot_steps``: a section per robot with a namespace
    (none for the one robot of the top-level keys, whose run is the top-level fields), at
    the end of the run (the diagram's ``context``; ``entries``: the scenario's robots)."""
    sim_time = context.get_time()
    named = {name: robot for name, robot in world.robots.items() if robot.namespace}
    result.robot_steps = {
        name: tables[name].results(sim_time)
        for name in named
        if isinstance(tables[name], StepTable)
    }
    sections = {
        name: robot_summary(
            robot, tables[name], result.robot_steps.get(name, []), context, entries[name]
        )
        for name, robot in named.items()
    }
    result.robots = sections or None


def robot_summary(
    part, table, steps: list[StepResult], context=None, entry: RobotEntry | None = None
) -> dict[str, Any]:
    """A robot's section of summary.json in a world of several: its namespace, joints,
    driven controller, step table (or sinusoid's tracking error), the largest final error
    of its steps [rad], its base's summary, and (an arm's, at the diagram's ``context``)
    its end effector: the task's, else its tool point (``entry``'s tool_link and
    tool_xyz; :func:`~armando_drake.kinematics.arm.tool_frame` without a link)."""
    return {
        "namespace": part.namespace,
        "model_instance": part.robot.name,
        "joint_names": part.stack.hardware.joint_names,
        "driven_controller": part.sequencer_target
        or part.twist_target
        or (part.task.controller if part.task else "")
        or (part.jog.controller if part.jog else "")
        or (part.learned_ik.controller if part.learned_ik else ""),
        "steps": [step_summary(step) for step in steps],
        "max_final_error": max((step.final_error for step in steps), default=None),
        "tracking_error": table.largest if isinstance(table, TrackingError) else None,
        "base": part.base_log.summary() if part.base_log is not None else None,
        "end_effector": _end_effector(part, context, entry or RobotEntry()),
    }


def _last_joint_bounded(plant, instance) -> bool:
    """Whether the robot's last moving joint has position limits (an arm's; a wheel's
    continuous joint has none)."""
    moving = [plant.get_joint(i) for i in plant.GetJointIndices(instance)]
    moving = [joint for joint in moving if joint.num_velocities() > 0]
    if not moving:
        return False
    last = max(moving, key=lambda joint: joint.velocity_start())
    limits = np.concatenate([last.position_lower_limits(), last.position_upper_limits()])
    return bool(np.all(np.isfinite(limits)))


def _end_effector(part, context, entry: RobotEntry) -> dict[str, Any] | None:
    """An arm's end effector at the diagram's ``context``: its frame's name, the point
    in it and its world position [m]; None for a mobile base (free, or welded on its
    wheels) or without a context."""
    if context is None or part.base_log is not None or not part.stack.hardware.joint_names:
        return None
    plant, instance = part.plant, part.robot.model_instance
    point = np.zeros(3)
    if not (part.task or entry.tool_link) and not _last_joint_bounded(plant, instance):
        return None  # its last joint turns without end: a wheel, not an arm's tool
    if part.task:
        frame = part.task.arm.frame_E
    elif entry.tool_link:
        frame, point = plant.GetFrameByName(entry.tool_link, instance), np.array(entry.tool_xyz)
    else:
        frame = tool_frame(plant, instance)
    X = frame.CalcPoseInWorld(plant.GetMyContextFromRoot(context))
    position = [float(v) for v in X @ point]
    return {"frame": frame.name(), "point": [float(v) for v in point], "position": position}


def _table_of(robot, logger) -> StepTable | TrackingError | None:
    """A listener on a robot's joint-state ``logger`` that computes the step table (or
    the sinusoid's tracking error) of its sequencer (``robot``: its AddedRobot); None
    without either."""
    if robot.sequencer is None or logger is None:
        return None
    logged = list(logger.joint_names)
    joints = robot.stack.controller_joints[robot.sequencer_target]
    if not set(joints) <= set(logged):
        return None
    columns = [logged.index(name) for name in joints]
    config = robot.sequencer.config
    if isinstance(config, Sinusoid):
        table = TrackingError(
            wave_of(config, joints), after=config.start_delay + TRACKING_SKIP, columns=columns
        )
    else:
        table = StepTable(
            targets=config.targets,
            period=config.period,
            cyclic=config.cyclic,
            start_delay=config.start_delay,
            columns=columns,
        )
    logger.add_listener(table.add)
    return table
