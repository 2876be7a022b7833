"""Benchmark suite and performance budget: ``python -m armando_drake.bench``.

Measures, in one invocation so that every ratio compares runs made under the
same machine load:

1. pipeline overhead: real-time factor of the position, trajectory and
   sinusoid scenarios (no viewer, no camera, console logging off, the CSV
   logger on) against the bare plant (same model, actuators, plant config and
   time step) driven by a ``TrajectorySource`` through the same targets,
   5 runs of each per repetition (each run is about a second); and each
   world's plant inputs replayed on the bare plant, which splits its cost into
   the physics of its motion and what the pipeline adds;
2. the same job in MuJoCo: the largest time step of {1, 2, 5, 10, 20} ms that
   keeps every final error within 0.01 rad, for the Drake pipeline and for
   MuJoCo (the URDF our loader expands, position actuators of the same gains),
   and each one's real-time factor at that step;
3. the camera: frames per second at 640 x 480, colour and colour + depth, and
   the world's real-time factor with the camera on at its 30 Hz;
4. start-up: wall time of ``python -m armando_drake.world --no-meshcat
   --duration 0`` from launch to exit, with an empty mesh cache and a full one;
5. memory: resident memory at the start and after one simulated hour of the
   cyclic position scenario with the CSV logger at 100 Hz and the replay
   (fresh process), and the size of its replay.html;
6. perception: frames per second of the point cloud pipeline of
   ``diagrams/perception.yaml`` on its 640 x 480 depth frame (rendering
   excluded), and that scenario's real-time factor with the camera at 30 Hz,
   without and with the pipeline at 10 Hz;
7. task-space torque control on the iiwa (``../shared`` beside the repository):
   real-time factor of ``task_os`` (operational-space inverse dynamics) and
   ``task_js`` (joint-space) with the controller manager at 1 kHz, and the
   Python cost of one operational-space controller update (the law with M, C,
   g, J, J-dot v from the plant) in microseconds;
8. sweep: throughput of ``python -m armando_drake.sweep`` (world runs per
   minute) on the local pool with 1 and 2 workers, and on a local Ray instance
   of 2 CPUs;
9. vision: real-time factor of ``diagrams/vision_blob.yaml`` (a 640 x 480
   camera at 30 Hz) with no detector, with the seed's blob detector on every
   frame, with OpenCV's SimpleBlobDetector as it is and with ArUco + solvePnP,
   and each detector's cost per frame in milliseconds;
10. lidar: wall time of one scan of a 640-beam, 360 deg lidar (fra2mo's) in a room
    of boxes and cylinders, in milliseconds.
11. mobile: real-time factor of ``diagrams/fra2mo.yaml`` (fra2mo on its wheels in its
    arena of walls, crates and pillars, its DiffDrive plugin driven by a cmd_vel
    sequence, its lidar scanning at 10 Hz, the base log on), target >= 2; and of
    ``diagrams/fra2mo_goals.yaml`` (four navigation goals: NavFn and Regulated Pure
    Pursuit at 20 Hz), target >= 1; and of ``diagrams/fra2mo_amcl.yaml`` (the same goals
    localized by AMCL on the saved map: the lidar at 10 Hz, the costmap, the particle
    count of the Nav2 YAML, the controller at its rate), target >= 1.
12. learned IK: milliseconds per pose of the learned inverse kinematics network
    (``models/learned_ik/armando_ik_network.onnx`` in ONNX Runtime), alone (budget
    0.2 ms) and with 3 Gauss-Newton steps, and of Drake's InverseKinematics.

Each figure is the median of ``--repeat`` repetitions, with min and max. The
table is printed as markdown and written with the raw samples to a JSON file.
``--quick`` shortens every measurement to a smoke run of a few seconds.

Examples:
  python -m armando_drake.bench
  python -m armando_drake.bench --quick --json /tmp/bench.json
  python -m armando_drake.bench --only pipeline,mujoco --repeat 5
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import datetime
import io
import json
import logging
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from armando_drake import MODELS_DIR
from armando_drake.control.hardware import AddHardwareInterface, FinishHardwareInterface
from armando_drake.control.sequencer import SEED_TARGETS
from armando_drake.control.stack import ARMANDO_GAINS
from armando_drake.description.lidar_sensors import LidarInfo
from armando_drake.description.loader import load_robot
from armando_drake.kinematics.inverse_kinematics import solve_ik
from armando_drake.learning.network import IkModel, refine
from armando_drake.outputs.plots import write_plots
from armando_drake.outputs.replay import RecordingMeshcat, publish_replay, write_replay
from armando_drake.sensors.camera import choose_renderer
from armando_drake.sensors.lidar import LIDAR_RENDERER, LidarScanner
from armando_drake.sensors.objects import AddGround, AddSceneObjects, Box, Cylinder, SceneObject
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.run import run
from armando_drake.simulation.scenario import ONE_ROBOT, load_scenario, merge_overrides
from armando_drake.sweeps.axes import make_variants, parse_grid
from armando_drake.sweeps.engines import LocalPool, RayEngine
from armando_drake.sweeps.errors import SweepError
from armando_drake.sweeps.sweep import Sweep, run_sweep
from armando_drake.tools.cli import command_parser
from armando_drake.tools.version import provenance

SECTIONS = (
    "pipeline",
    "mujoco",
    "camera",
    "startup",
    "memory",
    "perception",
    "task",
    "sweep",
    "vision",
    "lidar",
    "mobile",
    "learned_ik",
)
SCENARIOS = ("position", "trajectory", "sinusoid")
# [rad] j0..j3: the seed targets (diagrams/position.yaml's), 3 s apart.
TARGETS = [list(target) for target in SEED_TARGETS]
TARGET_PERIOD = 3.0  # [s] between targets
TIME_STEPS = (0.001, 0.002, 0.005, 0.010, 0.020)  # [s] candidates of the step search
FINAL_ERROR_TOLERANCE = 0.01  # [rad] every joint at the end of every target
NO_CONSOLE = "logging: {console_rate: 0}"
# The replays feed the bare plant's PD inputs at the controller ticks; the velocity cap
# reshapes those inputs at every plant step, so the worlds they replay run without it (its
# cost stays in the pipeline rows, which run the scenarios as they are).
UNCAPPED = "actuators: {velocity_limits: false}"
RTF = "x real time"  # unit of a real-time factor: simulated over wall-clock seconds


@dataclasses.dataclass
class Row:
    """One line of the table."""

    section: str  # one of SECTIONS
    name: str  # what is measured
    unit: str  # e.g. "x real time", "frames/s", "s", "MB"
    samples: list[float]  # one per repetition
    target: str = ""  # e.g. ">= 0.9"; "" = no budget for this row
    met: bool | None = None  # whether the median meets the target; None without one

    @property
    def median(self) -> float:
        return float(statistics.median(self.samples))

    @property
    def min(self) -> float:
        return float(min(self.samples))

    @property
    def max(self) -> float:
        return float(max(self.samples))

    def check(self, op: str, bound: float) -> Row:
        """Sets the target ``op bound`` (op: ">=" or "<=") and whether the median meets it."""
        self.target = f"{op} {bound:g}"
        self.met = self.median >= bound if op == ">=" else self.median <= bound
        return self

    def as_dict(self) -> dict:
        return {
            "section": self.section,
            "name": self.name,
            "unit": self.unit,
            "median": self.median,
            "min": self.min,
            "max": self.max,
            "samples": list(self.samples),
            "target": self.target,
            "met": self.met,
        }


@dataclasses.dataclass
class Report:
    """All rows and notes of one invocation."""

    quick: bool
    repeat: int
    rows: list[Row] = dataclasses.field(default_factory=list)
    notes: list[str] = dataclasses.field(default_factory=list)
    started: str = ""  # ISO date and time of the start
    seconds: float = 0.0  # [s] wall time of the whole invocation

    def add(self, row: Row) -> Row:
        self.rows.append(row)
        return row

    def as_dict(self) -> dict:
        return {
            "started": self.started,
            "seconds": self.seconds,
            "quick": self.quick,
            "repeat": self.repeat,
            "machine": machine(),
            "armando_drake": provenance(),  # the code measured: version, git commit
            "rows": [row.as_dict() for row in self.rows],
            "notes": list(self.notes),
        }

    def markdown(self) -> str:
        lines = [
            "| Benchmark | Median | Min | Max | Unit | Target | Met |",
            "| --- | ---: | ---: | ---: | --- | --- | --- |",
        ]
        for row in self.rows:
            met = "" if row.met is None else ("yes" if row.met else "**no**")
            lines.append(
                f"| {row.name} | {_number(row.median)} | {_number(row.min)} | "
                f"{_number(row.max)} | {row.unit} | {row.target} | {met} |"
            )
        if self.notes:
            lines.append("")
            lines.extend(f"- {note}" for note in self.notes)
        return "\n".join(lines)


def _number(value: float) -> str:
    if abs(value) >= 100:
        return f"{value:.0f}"
    if abs(value) >= 10:
        return f"{value:.1f}"
    return f"{value:.3g}" if abs(value) < 1 else f"{value:.2f}"


def machine() -> dict:
    """What the figures were measured on."""
    from importlib import metadata

    info = {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": _cpu_model(),
        "cpus": os.cpu_count(),
        "load_average": list(os.getloadavg()),
        "drake": metadata.version("drake"),
    }
    with contextlib.suppress(ImportError):
        import mujoco

        info["mujoco"] = mujoco.__version__
    return info


def _cpu_model() -> str:
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor()


# --- 7. task-space torque control --------------------------------------------


def _iiwa_task_overrides() -> tuple[str, ...]:
    """The task scenarios' repository-relative controller file made absolute (their iiwa,
    models/iiwa_description, is found as a package wherever the benchmark runs)."""

    return (
        f"controllers: {{config: '{MODELS_DIR / 'task_controllers' / 'iiwa_controllers.yaml'}'}}",
    )


def task_controller_cost(ticks: int) -> float:
    """[us] the mean wall time of one update of the operational-space controller's logic
    on the iiwa, in the middle of its task (the law, M, C, g, J, J-dot v, the
    reference's evaluation), over ``ticks`` updates."""

    scenario = load_scenario("task_os", NO_CONSOLE)
    for override in _iiwa_task_overrides():
        scenario = load_scenario_override(scenario, override)
    world = MakeWorld(scenario, quiet=True)
    from pydrake.systems.analysis import Simulator

    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(1.0)  # mid-motion: a reference is being followed
    manager = world.robot().stack.manager
    logic = manager.controllers[0].logic
    context = manager.GetMyContextFromRoot(simulator.get_context())
    memory = context.get_abstract_state(0).get_value().memories[0]
    x = manager.GetInputPort("state").Eval(context)
    q, v = x[:7].copy(), x[7:].copy()
    begin = time.perf_counter()
    for k in range(ticks):
        logic.update(1.0 + k * 1e-6, None, memory, lambda desired: (q, v))
    seconds = time.perf_counter() - begin
    world.close()
    return seconds / ticks * 1e6


def bench_task(report: Report, duration: float, ticks: int) -> None:
    overrides = _iiwa_task_overrides()
    rtf = {"task_os": [], "task_js": []}
    cost = []
    for _ in range(report.repeat):
        for name in rtf:
            rtf[name].append(pipeline_rtf(name, duration, overrides))
        cost.append(task_controller_cost(ticks))
    report.add(
        Row("task", f"iiwa operational-space ID at 1 kHz, {duration:g} s", RTF, rtf["task_os"])
    ).check(">=", 2.0)
    report.add(Row("task", f"iiwa joint-space ID at 1 kHz, {duration:g} s", RTF, rtf["task_js"]))
    report.add(Row("task", "operational-space controller update", "us/tick", cost))
    report.notes.append(
        "Task: the iiwa's task scenarios with the CSV logger on, not paced; the update row "
        f"is the mean of {ticks} calls of the controller's logic mid-motion (pure Python: "
        "the manager's event dispatch and the plant step come on top)."
    )


def bench_mobile(report: Report, duration: float, navigation: float, exploration: float) -> None:
    """fra2mo (diagrams/fra2mo.yaml): a floating base on its wheels in contact with the
    floor (2 ms steps) in its arena, its DiffDrive plugin at 100 Hz, its lidar (640 beams,
    360 deg) at 10 Hz, a cmd_vel sequence, the base log; then driving to the goals of
    diagrams/fra2mo_goals.yaml for ``navigation`` seconds, then localized by AMCL
    (:func:`bench_amcl`); exploring the arena for
    ``exploration`` seconds (:func:`bench_exploration`)."""
    rtf = [pipeline_rtf("fra2mo", duration) for _ in range(report.repeat)]
    report.add(Row("mobile", f"fra2mo driving a cmd_vel sequence, {duration:g} s", RTF, rtf)).check(
        ">=", 2.0
    )
    rtf = [pipeline_rtf("fra2mo_goals", navigation) for _ in range(report.repeat)]
    what = f"fra2mo navigating to four goals, {navigation:g} s"
    report.add(Row("mobile", what, RTF, rtf)).check(">=", 1.0)
    bench_amcl(report, navigation)
    report.notes.append(
        "Mobile: diagrams/fra2mo.yaml (straight, turn, straight in the arena of "
        "models/fra2mo_description/worlds/arena.sdf, the lidar at 10 Hz) with the CSV "
        "loggers and base.csv on, not paced; the wheels' and caster's contact with the floor "
        "is most of the cost, the lidar's ring of four 1-pixel-high depth renders about 5 ms "
        "a scan."
    )
    bench_exploration(report, exploration)


def bench_amcl(report: Report, duration: float) -> None:
    """fra2mo to the four goals localized by AMCL on the saved map (diagrams/fra2mo_amcl.yaml:
    the lidar at 10 Hz, the costmap, the particle count of the Nav2 YAML's amcl section, the
    controller at its controller_frequency) for ``duration`` seconds."""
    results = [run_scenario("fra2mo_amcl", duration) for _ in range(report.repeat)]
    what = f"fra2mo_goals with AMCL (lidar 10 Hz, costmap, YAML particles), {duration:g} s"
    report.add(Row("mobile", what, RTF, [r.realtime_factor for r in results])).check(">=", 1.0)
    navigation = results[-1].navigation or {}
    localization = navigation.get("localization") or {}
    settled = localization.get("max_position_error_settled")
    report.notes.append(
        "AMCL: diagrams/fra2mo_amcl.yaml, not paced; "
        f"{navigation.get('reached')} goals reached, AMCL's largest position error once settled "
        + (f"{settled:.3f} m." if settled is not None else "not measured (too short a run).")
    )


def bench_exploration(report: Report, duration: float) -> None:
    """fra2mo mapping its arena by exploration (diagrams/fra2mo_explore.yaml: the SlamMapper
    matching each scan, the Explorer's frontiers and plans on the map being built) for
    ``duration`` seconds: the whole arena is explored in about 33 s."""
    results = [run_scenario("fra2mo_explore", duration) for _ in range(report.repeat)]
    what = f"fra2mo exploring its arena (SLAM + frontiers), {duration:g} s"
    report.add(Row("mobile", what, RTF, [r.realtime_factor for r in results])).check(">=", 1.0)
    wall = [r.wall_time for r in results]
    report.add(Row("mobile", "fra2mo's exploration: wall time", "s", wall))
    mapping = (results[-1].navigation or {}).get("mapping") or {}
    report.notes.append(
        "Exploration: diagrams/fra2mo_explore.yaml, not paced; at the end "
        + (f"done at {mapping.get('done_at')} s, " if mapping.get("done") else "not done, ")
        + f"{mapping.get('frontiers_left')} frontiers left, map precision "
        f"{mapping.get('precision', 0):.3f}, recall {mapping.get('recall', 0):.3f}, coverage "
        f"{mapping.get('coverage', 0):.3f}."
    )


# --- 1. pipeline overhead ---------------------------------------------------


def pipeline_rtf(name: str, duration: float, overrides: tuple[str, ...] = ()) -> float:
    """Real-time factor of ``python -m armando_drake.world --scenario name`` without a viewer.

    Console logging off, the CSV logger on (a temporary folder), not paced.
    """
    result = run_scenario(name, duration, overrides)
    return result.realtime_factor


def run_scenario(name: str, duration: float, overrides: tuple[str, ...] = ()):
    """The :class:`~armando_drake.simulation.run.RunResult` of a scenario run as fast as it goes."""

    scenario = load_scenario(name, NO_CONSOLE)
    for override in overrides:
        scenario = load_scenario_override(scenario, override)
    scenario.simulation.duration = duration
    scenario.simulator_config.target_realtime_rate = 0.0
    # The CSV logs on, in a temporary folder (the run writes no CSV without a folder);
    # no plots, no replay.
    with tempfile.TemporaryDirectory(prefix="armando_drake_bench_") as folder:
        return run(
            scenario,
            scenario_name=name,
            quiet=True,
            stream=io.StringIO(),
            output_dir=folder,
            replay=False,
            plots=False,
        )


def load_scenario_override(scenario, override: str):

    return merge_overrides(scenario, override)


def add_bare_plant(builder, scenario_name: str, time_step: float | None = None):
    """(plant, robot, hardware): the scenario's model on its ground, with its plant config
    (``time_step`` [s] instead of its own when given) and PD actuators, finalized; no
    controllers, sequencer or logger. What the pipeline rows compare the worlds with."""
    from pydrake.multibody.plant import AddMultibodyPlant, ApplyMultibodyPlantConfig

    scenario = load_scenario(scenario_name)
    config = scenario.plant_config
    if time_step is not None:
        config.time_step = time_step
    plant, scene_graph = AddMultibodyPlant(config, builder)
    ApplyMultibodyPlantConfig(config, plant)
    robot = load_robot(plant)
    AddGround(plant, scene_graph)
    actuators = scenario.robots[
        ONE_ROBOT
    ].actuators  # the built-in Armando: its servos' gains unless given
    kp = actuators.kp if actuators.kp is not None else ARMANDO_GAINS[0]
    kd = actuators.kd if actuators.kd is not None else ARMANDO_GAINS[1]
    hardware = AddHardwareInterface(plant, robot, kp=kp, kd=kd)
    plant.Finalize()
    FinishHardwareInterface(plant, robot, hardware)
    return plant, robot, hardware


def bare_plant_rtf(duration: float, time_step: float = 0.001) -> float:
    """Real-time factor of the plant alone, its PD actuators fed by a TrajectorySource.

    The same model, actuators, ground and plant config as the world; the
    targets are held for ``TARGET_PERIOD`` each (zero desired velocity).
    """
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    builder = DiagramBuilder()
    plant, robot, hardware = add_bare_plant(builder, "position", time_step)
    n = len(hardware.joints)
    columns = [np.concatenate([target, np.zeros(n)]) for target in TARGETS]
    times = [k * TARGET_PERIOD for k in range(len(TARGETS))]
    times.append(len(TARGETS) * TARGET_PERIOD)
    columns.append(columns[-1])
    trajectory = PiecewisePolynomial.ZeroOrderHold(times, np.stack(columns, axis=1))
    source = builder.AddSystem(TrajectorySource(trajectory))
    builder.Connect(
        source.get_output_port(), plant.get_desired_state_input_port(robot.model_instance)
    )
    return diagram_rtf(builder.Build(), duration)


def diagram_rtf(diagram, duration: float) -> float:
    """Real-time factor of ``diagram`` simulated for ``duration`` [s] as fast as it goes
    (its simulator's initialization included)."""
    from pydrake.systems.analysis import Simulator

    simulator = Simulator(diagram)
    start = time.perf_counter()
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return duration / (time.perf_counter() - start)


@dataclasses.dataclass(frozen=True)
class PlantInputs:
    """What a world feeds its plant, sampled at its controller ticks (where it changes)."""

    scenario: str  # the scenario's name
    times: list[float]  # [s] the ticks
    desired: np.ndarray  # [rad, rad/s] desired state [q_d; v_d] at each tick (2n x ticks)
    feedforward: np.ndarray | None  # [N m] gravity feed-forward (n x ticks); None without


def recorded_plant_inputs(name: str, duration: float) -> PlantInputs:
    """The plant inputs of scenario ``name`` (without the velocity cap, :data:`UNCAPPED`)
    over ``duration`` [s]: its desired state and gravity feed-forward, read half a tick after
    each controller tick (they change only at the ticks, where the controllers and the
    sequencer's streams write)."""
    from pydrake.systems.analysis import Simulator

    world = MakeWorld(load_scenario(name, f"{NO_CONSOLE}\n{UNCAPPED}"), quiet=True)
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    port = world.diagram.GetOutputPort("desired_state")
    feedforward = world.robot().gravity_feedforward
    period = 1.0 / world.robot().stack.update_rate
    times, samples, torques = [], [], []
    for k in range(int(round(duration / period)) + 1):
        simulator.AdvanceTo(k * period + period / 2)
        times.append(k * period)
        samples.append(np.array(port.Eval(context)))
        if feedforward is not None:
            owner = feedforward.get_system().GetMyContextFromRoot(context)
            torques.append(np.array(feedforward.Eval(owner)))
    world.close(context)
    return PlantInputs(
        name,
        times,
        np.stack(samples, axis=1),
        np.stack(torques, axis=1) if torques else None,
    )


def replay_diagram(inputs: PlantInputs):
    """(diagram, plant): the bare plant (the scenario's model, actuators, ground and plant
    config) whose desired state and actuation inputs replay ``inputs`` from C++
    ``TrajectorySource``s (zero-order holds): the world's motion without its controllers,
    sequencer or logger."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    builder = DiagramBuilder()
    plant, robot, _ = add_bare_plant(builder, inputs.scenario)
    inputs_and_ports = [(inputs.desired, plant.get_desired_state_input_port(robot.model_instance))]
    if inputs.feedforward is not None:
        inputs_and_ports.append(
            (inputs.feedforward, plant.get_actuation_input_port(robot.model_instance))
        )
    for values, port in inputs_and_ports:
        source = builder.AddSystem(
            TrajectorySource(PiecewisePolynomial.ZeroOrderHold(inputs.times, values))
        )
        builder.Connect(source.get_output_port(), port)
    return builder.Build(), plant


def replay_rtf(inputs: PlantInputs, duration: float) -> float:
    """Real-time factor of :func:`replay_diagram` of ``inputs`` over ``duration`` [s]."""
    return diagram_rtf(replay_diagram(inputs)[0], duration)


def bench_pipeline(report: Report, duration: float, runs_per_repeat: int = 1) -> None:
    runs = report.repeat * runs_per_repeat
    # Each world's plant inputs, recorded once (a little longer than the runs, so the last
    # tick's hold covers their end).
    inputs = {name: recorded_plant_inputs(name, duration + 0.5) for name in SCENARIOS}
    bare, pipelines = [], {name: [] for name in SCENARIOS}
    replays = {name: [] for name in SCENARIOS}
    for _ in range(runs):
        # Interleaved, so that a change of machine load hits every column alike.
        bare.append(bare_plant_rtf(duration))
        for name in SCENARIOS:
            pipelines[name].append(pipeline_rtf(name, duration))
            replays[name].append(replay_rtf(inputs[name], duration))
    report.add(Row("pipeline", f"bare plant + TrajectorySource, {duration:g} s", RTF, bare))
    for name in SCENARIOS:
        report.add(Row("pipeline", f"{name} scenario, {duration:g} s", RTF, pipelines[name]))
    for name in SCENARIOS:
        # Each run against the bare plant run just before it.
        ratios = [p / b for p, b in zip(pipelines[name], bare, strict=True)]
        report.add(Row("pipeline", f"{name} / bare plant", "ratio", ratios).check(">=", 0.9))
    fastest = max(pipelines["position"]) / max(bare)
    report.add(Row("pipeline", "position / bare plant, fastest runs", "ratio", [fastest]))
    # What the physics of each motion costs, and what the pipeline costs on top of it.
    for name in SCENARIOS:
        report.add(
            Row("pipeline", f"{name} plant inputs replayed, {duration:g} s", RTF, replays[name])
        )
    for name in SCENARIOS[1:]:
        ratios = [r / h for r, h in zip(replays[name], replays["position"], strict=True)]
        report.add(Row("pipeline", f"{name} replay / position replay", "ratio", ratios))
    for name in SCENARIOS:
        ratios = [p / r for p, r in zip(pipelines[name], replays[name], strict=True)]
        report.add(Row("pipeline", f"{name} / its replay", "ratio", ratios))
    report.notes.append(
        f"Pipeline: {runs} runs of each configuration, interleaved; a ratio row is the "
        "median (min, max) of each scenario run over the bare-plant run just before it. "
        "On a shared machine single runs vary by +-20 %; 'fastest runs' compares the "
        "least disturbed run of each."
    )
    report.notes.append(
        "Replays: the bare plant whose desired state and actuation inputs play back what the "
        "scenario's world fed its plant (desired state and gravity feed-forward, read at its "
        "controller ticks) from two C++ TrajectorySources: the world's motion without its "
        "controllers, sequencer or logger. The position replay holds the bare plant's targets "
        "through the same two sources, so 'X replay / position replay' is what the motion "
        "alone costs the physics (an arm that moves costs the discrete solver more than one "
        "that holds still): the ceiling of 'X / bare plant' whatever the pipeline costs. "
        "'X / its replay' is what the controllers, sequencer and logger cost on top."
    )


# --- 2. the same job in MuJoCo ------------------------------------------------


def mujoco_xml(urdf: str) -> str:
    """The expanded URDF as MuJoCo's URDF importer reads it.

    Drops ``ros2_control``, ``gazebo`` and ``transmission`` elements and keeps
    every link a body of its own (no static fusion) with its visual geometry.
    """
    root = ET.fromstring(urdf)
    for tag in ("ros2_control", "gazebo", "transmission"):
        for element in root.findall(tag):
            root.remove(element)
    extension = ET.SubElement(root, "mujoco")
    ET.SubElement(extension, "compiler", discardvisual="false", fusestatic="false")
    return ET.tostring(root, encoding="unicode")


def _welded_groups(root: ET.Element) -> tuple[dict[str, str], list[tuple[str, str]]]:
    """(link -> the root link of its welded group, [(parent, child) of each moving joint])."""
    parent_of = {}
    moving = []
    for joint in root.findall("joint"):
        parent = joint.find("parent").get("link")
        child = joint.find("child").get("link")
        parent_of[child] = (parent, joint.get("type"))
        if joint.get("type") != "fixed":
            moving.append((parent, child))

    def group(link: str) -> str:
        while link in parent_of and parent_of[link][1] == "fixed":
            link = parent_of[link][0]
        return link

    return {link.get("name"): group(link.get("name")) for link in root.findall("link")}, moving


def mujoco_model(urdf: str, hardware, *, kp: float, kd: float, time_step: float, gravcomp: bool):
    """A compiled MuJoCo model of the arm with the world's actuators and contact filter.

    Position actuators with ``kp``, ``kv = kd`` and the effort limit as force
    range; the implicitfast integrator; a ground plane at z = 0; links across
    a moving joint (with their welded links) never collide, as in our importer;
    with ``gravcomp``, gravity compensation through the actuators (the
    world's gravity feed-forward).
    """
    import mujoco

    text = mujoco_xml(urdf)
    spec = mujoco.MjSpec.from_string(text)
    spec.option.timestep = time_step
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    if gravcomp:
        for body in spec.bodies[1:]:
            body.gravcomp = 1.0
    for joint in hardware.joints:
        spec.joint(joint.name).actgravcomp = gravcomp
        actuator = spec.add_actuator(
            name=joint.name, target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT
        )
        actuator.set_to_position(kp=kp, kv=kd)
        if np.isfinite(joint.effort):
            actuator.forcelimited = True
            actuator.forcerange = [-joint.effort, joint.effort]
    group, moving = _welded_groups(ET.fromstring(urdf))
    for parent, child in moving:
        for a in [link for link, g in group.items() if g == group[parent]]:
            for b in [link for link, g in group.items() if g == group[child]]:
                spec.add_exclude(bodyname1=a, bodyname2=b)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.0, 1.0, 0.1])
    model = spec.compile()
    for joint in hardware.joints:
        model.joint(joint.name).qpos0[:] = joint.initial_position
    return model


def mujoco_job(model, hardware, period: float) -> tuple[float, list[float]]:
    """(real-time factor, final error of each target [rad]) of the target sequence."""
    import mujoco

    data = mujoco.MjData(model)
    joints = [model.joint(joint.name) for joint in hardware.joints]
    address = [int(joint.qposadr[0]) for joint in joints]
    steps = int(round(period / model.opt.timestep))
    errors = []
    start = time.perf_counter()
    for target in TARGETS:
        data.ctrl[:] = target
        mujoco.mj_step(model, data, steps)
        q = data.qpos[address]
        error = np.abs(q - target).max() if np.all(np.isfinite(q)) else np.inf
        errors.append(float(error))
    wall = time.perf_counter() - start
    return len(TARGETS) * steps * model.opt.timestep / wall, errors


def drake_job(time_step: float, period: float) -> tuple[float, list[float]]:
    """(real-time factor, final error of each target [rad]) of the position scenario."""
    overrides = [
        f"plant_config: {{time_step: {time_step!r}}}",
        f"sequencer: {{period: {period!r}}}",
    ]
    if time_step > 0.01:  # the controllers at the plant's rate, no faster (100 Hz at most)
        overrides.append(f"controllers: {{update_rate: {round(1 / time_step)}}}")
    result = run_scenario("position", len(TARGETS) * period, tuple(overrides))
    errors = [step.final_error for step in result.steps]
    if len(errors) != len(TARGETS):
        errors.append(np.inf)
    return result.realtime_factor, errors


def _largest_step(job) -> tuple[float | None, dict[float, list[float]]]:
    """The largest time step whose every final error is within tolerance, and all errors."""
    errors = {}
    best = None
    for time_step in TIME_STEPS:
        _, errors[time_step] = job(time_step)
        if max(errors[time_step]) <= FINAL_ERROR_TOLERANCE:
            best = time_step
    return best, errors


def bench_mujoco(report: Report, period: float) -> None:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        report.notes.append(
            "MuJoCo comparison skipped: mujoco is not installed (pip install -e '.[bench]')."
        )
        return

    scenario = load_scenario("position", NO_CONSOLE)
    world = MakeWorld(scenario, quiet=True)
    world.close()
    actuators = scenario.robots[ONE_ROBOT].actuators

    def mujoco_at(time_step: float) -> tuple[float, list[float]]:
        model = mujoco_model(
            world.robot().robot.urdf,
            world.robot().stack.hardware,
            kp=world.robot().stack.hardware.joints[0].kp,
            kd=world.robot().stack.hardware.joints[0].kd,
            time_step=time_step,
            gravcomp=actuators.gravity_feedforward,
        )
        return mujoco_job(model, world.robot().stack.hardware, period)

    with _quiet_mujoco():
        drake_step, drake_errors = _largest_step(lambda h: drake_job(h, period))
        mujoco_step, mujoco_errors = _largest_step(mujoco_at)
    for label, errors in (("Drake", drake_errors), ("MuJoCo", mujoco_errors)):
        worst = ", ".join(
            f"{1000 * h:g} ms: {max(e):.3g}"
            if np.isfinite(max(e))
            else f"{1000 * h:g} ms: diverged"
            for h, e in errors.items()
        )
        report.notes.append(f"{label}, worst final error per time step [rad]: {worst}.")
    if drake_step is None or mujoco_step is None:
        report.notes.append(
            "MuJoCo comparison: no time step kept every final error within "
            f"{FINAL_ERROR_TOLERANCE} rad (Drake: {drake_step}, MuJoCo: {mujoco_step})."
        )
        return
    drake_rtf, mujoco_rtf, mujoco_1ms = [], [], []
    for _ in range(report.repeat):
        drake_rtf.append(drake_job(drake_step, period)[0])
        mujoco_rtf.append(mujoco_at(mujoco_step)[0])
        mujoco_1ms.append(mujoco_at(TIME_STEPS[0])[0])
    job = f"{len(TARGETS)} targets x {period:g} s"
    report.add(Row("mujoco", "Drake pipeline: largest step", "ms", [1000 * drake_step]))
    report.add(Row("mujoco", "MuJoCo: largest step", "ms", [1000 * mujoco_step]))
    report.add(Row("mujoco", f"Drake pipeline at {1000 * drake_step:g} ms, {job}", RTF, drake_rtf))
    report.add(Row("mujoco", f"MuJoCo at {1000 * mujoco_step:g} ms, {job}", RTF, mujoco_rtf))
    report.add(Row("mujoco", f"MuJoCo at 1 ms, {job}", RTF, mujoco_1ms))
    ratios = [d / m for d, m in zip(drake_rtf, mujoco_rtf, strict=True)]
    row = report.add(Row("mujoco", "Drake pipeline / MuJoCo", "ratio", ratios).check(">=", 1.0))
    if not row.met:
        report.notes.append(
            "Drake pipeline / MuJoCo: MuJoCo runs each 3 s target as one C call "
            "(mj_step with nstep, no controller in the loop) and its implicitfast step of this "
            "4-joint arm costs a few microseconds; our pipeline pays Drake's discrete step "
            "(contact solver with the PD gains implicit, 'lagged' approximation; compare the "
            "bare plant at 1 ms with MuJoCo at 1 ms) plus our Python systems at 100 Hz, "
            "which at 20 ms are most of the cost. Drake's implicit PD keeps 20 ms stable where "
            "MuJoCo's explicit position gain diverges above 5 ms, which is not enough to "
            "close the gap."
        )


@contextlib.contextmanager
def _quiet_mujoco():
    """Keeps MuJoCo's instability warnings (a diverging time step) off the console."""
    import mujoco

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


# --- 3. camera ------------------------------------------------------------------


def camera_fps(frames: int, *, depth: bool, renderer: str = "auto") -> tuple[float, str]:
    """(frames rendered per wall-clock second, camera description) of the camera scene's
    camera (diagrams/camera.yaml: the arm, the blue disc, the box)."""

    scenario = load_scenario(
        "camera",
        f"camera: {{depth: {str(depth).lower()}, live_view: false, renderer: {renderer}}}\n"
        f"{NO_CONSOLE}",
    )
    world = MakeWorld(scenario, quiet=True)
    try:
        if not world.robot().cameras:
            raise RuntimeError("the built-in description has no camera")
        name, camera = next(iter(world.robot().cameras.items()))
        context = world.diagram.CreateDefaultContext()
        sensor_context = camera.sensor.GetMyContextFromRoot(context)
        ports = [camera.sensor.GetOutputPort("color_image")]
        if depth:
            ports.append(camera.sensor.GetOutputPort("depth_image_32f"))
        for port in ports:  # the first frame builds the render pipeline
            port.Eval(sensor_context)
        start = time.perf_counter()
        for i in range(frames):
            context.SetTime((i + 1) * 1e-3)  # a new time: the images are rendered again
            for port in ports:
                port.Eval(sensor_context)
        fps = frames / (time.perf_counter() - start)
        info = camera.info
        return fps, f"{name} {info.width} x {info.height} at {info.frame_rate:g} Hz"
    finally:
        world.close()


def camera_world_rtf(duration: float, renderer: str = "auto", *, read: bool = False) -> float:
    """Real-time factor of the camera scenario (the camera at its 30 Hz, no live view),
    as fast as it goes: as the scenario is (nothing reads the images, none is rendered),
    or with ``read`` every frame read (colour and depth saved, as the frame saver does)."""
    overrides = [f"camera: {{live_view: false, renderer: {renderer}}}"]
    if read:
        folder = tempfile.mkdtemp(prefix="bench-frames-")
        overrides.append(f"camera: {{save_frames: {folder}}}")
    try:
        return pipeline_rtf("camera", duration, tuple(overrides))
    finally:
        if read:
            shutil.rmtree(folder, ignore_errors=True)


def renderers_to_bench(quick: bool) -> list[str]:
    """The renderers whose camera rows a run has: the one a world gets here first
    (``"gl"`` where an X display or Xvfb is there, else ``"vtk"``), then VTK through EGL
    too when that is not it (not in a ``--quick`` run, beyond the camera section)."""
    fastest = choose_renderer("auto")
    return [fastest] if fastest == "vtk" or quick else [fastest, "vtk"]


ENGINES = {"gl": "RenderEngineGl", "vtk": "RenderEngineVtk"}


def bench_camera(report: Report, frames: int, duration: float) -> None:

    fastest = choose_renderer("auto")  # "gl" where an X display or Xvfb is there
    renderers = ["vtk"] if fastest == "vtk" else ["gl", "vtk"]
    rows = {}
    what = ""
    for _ in range(report.repeat):
        for renderer in renderers:
            fps, what = camera_fps(frames, depth=False, renderer=renderer)
            rows.setdefault((renderer, "colour"), []).append(fps)
            both = camera_fps(frames, depth=True, renderer=renderer)[0]
            rows.setdefault((renderer, "both"), []).append(both)
            rows.setdefault((renderer, "world"), []).append(camera_world_rtf(duration, renderer))
            if not report.quick:
                rtf = camera_world_rtf(duration, renderer, read=True)
                rows.setdefault((renderer, "read"), []).append(rtf)
        rows.setdefault(("none", "world"), []).append(
            pipeline_rtf("camera", duration, ("camera: {enabled: false}",))
        )
    names = ENGINES
    for renderer in renderers:
        engine = names[renderer]
        report.add(Row("camera", f"colour render, {engine}", "frames/s", rows[renderer, "colour"]))
        report.add(
            Row("camera", f"colour + depth render, {engine}", "frames/s", rows[renderer, "both"])
        )
    report.add(
        Row("camera", f"camera scenario, no camera, {duration:g} s", RTF, rows["none", "world"])
    )
    for renderer in renderers:
        row = Row(
            "camera",
            f"camera scenario + camera, {names[renderer]}, {duration:g} s",
            RTF,
            rows[renderer, "world"],
        )
        report.add(row.check(">=", 1.0) if renderer == fastest else row)
        if (renderer, "read") in rows:
            label = f"camera scenario, every frame saved, {names[renderer]}, {duration:g} s"
            report.add(Row("camera", label, RTF, rows[renderer, "read"]))
    report.notes.append(
        f"Camera: {what} in the scene of diagrams/camera.yaml, on the CPU (no GPU). "
        "The world uses RenderEngineGl (OpenGL, on DISPLAY or a private Xvfb) when it can, "
        "else RenderEngineVtk (EGL); the target applies to the renderer a world gets here. "
        "A camera renders only the frames a system reads: in the camera scenario nothing "
        "reads them ('+ camera' renders none); 'every frame saved' reads colour and depth "
        "at 30 Hz (the frame saver) from the camera on the moving arm: every frame differs, "
        "the worst case of a camera. "
        "The world rows include the first frame, which builds the render pipeline."
    )


# --- 4. start-up --------------------------------------------------------------------


START_COMMAND = ("-m", "armando_drake.world", "--no-meshcat", "--duration", "0", "--quiet")


def startup_seconds(cache_dir: Path) -> float:
    """Wall time [s] of ``python -m armando_drake.world --no-meshcat --duration 0``."""
    environment = dict(os.environ, XDG_CACHE_HOME=str(cache_dir))
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, *START_COMMAND],
        env=environment,
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    return time.perf_counter() - start


def bench_startup(report: Report) -> None:
    cold, warm = [], []
    for _ in range(report.repeat):
        with tempfile.TemporaryDirectory(prefix="armando_bench_cache_") as cache:
            cold.append(startup_seconds(Path(cache)))
            warm.append(startup_seconds(Path(cache)))
    command = "python " + " ".join(START_COMMAND)
    report.add(Row("startup", "start-up, empty cache", "s", cold).check("<=", 1.5))
    report.add(Row("startup", "start-up, warm cache", "s", warm).check("<=", 1.5))
    report.notes.append(
        f"Start-up: `{command}` from launch to exit; 'empty cache' runs with a new "
        "XDG_CACHE_HOME, 'warm cache' again with the same one (the OS file cache is warm "
        "in both)."
    )


# --- 5. memory ----------------------------------------------------------------------


def rss_mb(field: str = "VmRSS") -> float:
    """Resident memory of this process [MB] (VmRSS; VmHWM: its peak so far)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(f"{field}:"):
            return int(line.split()[1]) / 1024.0
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def memory_soak(horizon: float) -> dict:
    """Runs the cyclic position scenario for ``horizon`` simulated seconds; RSS samples.

    As ``python -m armando_drake.world --no-meshcat --output DIR`` does: the CSV
    logger writes joint_states.csv at the controller rate (100 Hz) to a temporary
    folder and the replay is sampled into a private Meshcat, then written as
    replay.html after the run, then the plots of the whole run are drawn; console
    logging off; as fast as it goes.
    """
    from pydrake.systems.analysis import Simulator

    logging.disable(logging.WARNING)
    scenario = load_scenario("position", f"sequencer: {{cyclic: true}}\n{NO_CONSOLE}")
    with tempfile.TemporaryDirectory(prefix="armando_bench_soak_") as folder:
        meshcat = RecordingMeshcat()
        world = MakeWorld(scenario, output_dir=folder, quiet=True, meshcat=meshcat)
        simulator = Simulator(world.diagram)
        simulator.Initialize()
        samples = [(0.0, rss_mb())]
        start = time.perf_counter()
        chunks = 20
        for k in range(1, chunks + 1):
            simulator.AdvanceTo(horizon * k / chunks)
            samples.append((horizon * k / chunks, rss_mb()))
        wall = time.perf_counter() - start
        world.close()
        csv_bytes = (Path(folder) / "joint_states.csv").stat().st_size
        replay_start = time.perf_counter()
        frames = publish_replay(
            meshcat, world.diagram, world.plant, world.replay_sampler, simulator.get_context()
        )
        replay = write_replay(meshcat, Path(folder) / "replay.html")
        replay_wall = time.perf_counter() - replay_start
        replay_bytes = replay.stat().st_size
        after_replay = rss_mb()
        peak_before_plots = rss_mb("VmHWM")
        plots_start = time.perf_counter()
        write_plots(folder)
        plots_wall = time.perf_counter() - plots_start
        peak = rss_mb("VmHWM")
    return {
        "horizon": horizon,
        "wall": wall,
        "samples": samples,
        "csv_bytes": csv_bytes,
        "replay_bytes": replay_bytes,
        "replay_frames": frames,
        "replay_wall": replay_wall,
        "rss_after_replay": after_replay,
        "peak_before_plots": peak_before_plots,
        "plots_wall": plots_wall,
        "peak": peak,
    }


def bench_memory(report: Report, horizon: float) -> None:
    output = subprocess.run(
        [sys.executable, "-m", "armando_drake.bench", "--memory-child", repr(horizon)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    soak = json.loads(output.strip().splitlines()[-1])
    samples = soak["samples"]
    start, end = samples[0][1], soak["rss_after_replay"]
    label = f"{horizon / 3600:g} h" if horizon >= 3600 else f"{horizon:g} s"
    hours = horizon / 3600.0
    report.add(Row("memory", "resident memory at the start", "MB", [start]))
    report.add(
        Row("memory", f"resident memory after {label} simulated and replay.html", "MB", [end])
    )
    report.add(
        Row("memory", f"growth over {label}, replay on", "MB", [end - start]).check(
            "<=", 20.0 * max(hours, 1.0)
        )
    )
    report.add(
        Row(
            "memory", f"replay.html after {label} simulated", "MB", [soak["replay_bytes"] / 1e6]
        ).check("<=", 50.0)
    )
    if "peak" in soak:
        report.add(
            Row(
                "memory",
                f"peak resident memory, plots of the {label} drawn after the run",
                "MB",
                [soak["peak"]],
            )
        )
    report.notes.append(
        f"Memory: one fresh process, cyclic position scenario as `--no-meshcat --output` "
        f"runs it: joint_states.csv at 100 Hz ({soak['csv_bytes'] / 1e6:.1f} MB written) and "
        f"the replay ({soak['replay_frames']} frames, drawn and written in "
        f"{soak['replay_wall']:.1f} s after the run), {label} simulated in "
        f"{soak['wall']:.0f} s; RSS [MB] at 0, 25, 50, 75, 100 % of the run: "
        + ", ".join(f"{samples[i][1]:.1f}" for i in (0, 5, 10, 15, 20))
        + f", after writing replay.html {end:.1f}; peak before the plots "
        f"{soak.get('peak_before_plots', float('nan')):.1f}, with the plots (drawn in "
        f"{soak.get('plots_wall', float('nan')):.1f} s) {soak.get('peak', float('nan')):.1f}."
    )


# --- 6. perception -----------------------------------------------------


def perception_fps(frames: int) -> tuple[float, float, dict[str, float], str]:
    """(frames per wall-clock second, per CPU second of this process, median ms per
    stage, what) of the perception scenario's pipeline on its camera's 640 x 480 depth
    frame: Drake's depth-to-cloud conversion in the world frame, then every step. The
    frame is rendered once; each repetition converts it again (its input set anew)."""
    from pydrake.perception import PointCloud
    from pydrake.systems.analysis import Simulator

    world = MakeWorld(load_scenario("perception", NO_CONSOLE), quiet=True)
    try:
        added = world.robot().perception
        simulator = Simulator(world.diagram)
        simulator.AdvanceTo(0.05)
        context = simulator.get_context()
        converter = added.points_in_world.get_system()
        depth = world.diagram.GetOutputPort(f"{added.camera}.depth_image").Eval(context)
        color = world.diagram.GetOutputPort(f"{added.camera}.color_image").Eval(context)
        X_WC = added.camera_pose.Eval(added.camera_pose.get_system().GetMyContextFromRoot(context))
        converter_context = converter.CreateDefaultContext()
        converter.GetInputPort("color_image").FixValue(converter_context, color)
        converter.GetInputPort("camera_pose").FixValue(converter_context, X_WC)
        pipeline = added.pipeline.pipeline
        stages: dict[str, list[float]] = {"depth to point cloud": []}
        start, cpu_start = time.perf_counter(), time.process_time()
        for _ in range(frames):
            begin = time.perf_counter()
            converter.GetInputPort("depth_image").FixValue(converter_context, depth)
            cloud = PointCloud(converter.get_output_port().Eval(converter_context))
            stages["depth to point cloud"].append(time.perf_counter() - begin)
            result = pipeline.run(cloud, viewpoint=X_WC.translation(), frame="world")
            for stage in result.stages[1:]:
                stages.setdefault(stage.name, []).append(stage.seconds)
        fps = frames / (time.perf_counter() - start)
        cpu_fps = frames / (time.process_time() - cpu_start)
        medians = {name: 1e3 * statistics.median(values) for name, values in stages.items()}
        what = f"{depth.width()} x {depth.height()}, {len(result.clusters)} clusters"
        return fps, cpu_fps, medians, what
    finally:
        world.close()


def perception_world_rtf(
    duration: float, override: str = "", renderer: str = "auto"
) -> tuple[float, float]:
    """(simulated per wall-clock second, simulated per CPU second of this process) of
    the perception scenario run as fast as it goes, no viewer, from the first step
    (which renders the first frame) to the end, its cameras rendered by ``renderer``;
    building the world is not counted."""
    from pydrake.systems.analysis import Simulator

    text = f"{NO_CONSOLE}\ncamera: {{renderer: {renderer}}}\n{override}"
    world = MakeWorld(load_scenario("perception", text), quiet=True)
    try:
        simulator = Simulator(world.diagram)
        simulator.set_target_realtime_rate(0.0)
        start, cpu_start = time.perf_counter(), time.process_time()
        simulator.AdvanceTo(duration)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
        return duration / wall, duration / cpu
    finally:
        world.close()


def bench_perception(report: Report, frames: int, duration: float) -> None:
    renderers = renderers_to_bench(report.quick)
    fps, cpu_fps = [], []
    worlds: dict[str, list[float]] = {}
    stages: dict[str, list[float]] = {}
    what = ""
    for _ in range(report.repeat):
        rate, cpu_rate, medians, what = perception_fps(max(frames, 10))
        fps.append(rate)
        cpu_fps.append(cpu_rate)
        for name, value in medians.items():
            stages.setdefault(name, []).append(value)
        for renderer in renderers:
            for key, override in (("with", ""), ("without", "perception: null")):
                wall, cpu = perception_world_rtf(duration, override, renderer)
                worlds.setdefault(f"{key}, {renderer}", []).append(wall)
                worlds.setdefault(f"{key}, {renderer}, cpu", []).append(cpu)
    report.add(
        Row("perception", "perception pipeline, 640 x 480 depth frames", "frames/s", fps).check(
            ">=", 15.0
        )
    )
    report.add(
        Row("perception", "perception pipeline, per CPU second of the process", "frames/s", cpu_fps)
    )
    for renderer in renderers:
        engine = ENGINES[renderer]
        label = f"perception scenario, no pipeline, {engine}, {duration:g} s"
        report.add(Row("perception", label, RTF, worlds[f"without, {renderer}"]))
        label = f"perception scenario, camera 30 Hz, pipeline 10 Hz, {engine}, {duration:g} s"
        row = Row("perception", label, RTF, worlds[f"with, {renderer}"])
        report.add(row.check(">=", 1.0) if renderer == renderers[0] else row)
        label = f"perception scenario, pipeline 10 Hz, {engine}, per CPU second of the process"
        report.add(Row("perception", label, RTF, worlds[f"with, {renderer}, cpu"]))
    steps = ", ".join(f"{name}: {statistics.median(v):.1f}" for name, v in stages.items())
    report.notes.append(
        f"Perception: diagrams/perception.yaml ({what}); the pipeline row converts the "
        f"rendered depth frame and runs every step (rendering excluded); median ms per "
        f"stage: {steps}. The scenario rows run the world with the camera at 30 Hz, "
        "without and with the pipeline at 10 Hz (no viewer), by the renderer named (the "
        "pipeline reads colour and depth at 10 Hz: 10 frames a second; without it, "
        "none). Its arm and objects hold still: the camera renders its colour once and "
        "holds it while no pose changes, and the pipeline reuses its result for the same "
        "cloud (docs/design/performance.md). 'Per CPU second' divides by "
        "the process's CPU time instead of the wall time: what the frame rate would be "
        "with the CPU to itself, on a machine shared with other jobs."
    )


def vision_world_rtf(
    duration: float, override: str, renderer: str = "auto", scenario: str = "vision_blob"
) -> tuple[float, float, float, int]:
    """(simulated per wall-clock second, per CPU second of this process, detector
    seconds per frame, frames) of diagrams/``scenario``.yaml with ``override``, as fast
    as it goes, no viewer, its cameras rendered by ``renderer``; building the world is
    not counted. (vision, #15)"""
    from pydrake.systems.analysis import Simulator

    text = f"{NO_CONSOLE}\ncamera: {{live_view: false, renderer: {renderer}}}\n{override}"
    world = MakeWorld(load_scenario(scenario, text), quiet=True)
    try:
        simulator = Simulator(world.diagram)
        simulator.set_target_realtime_rate(0.0)
        start, cpu_start = time.perf_counter(), time.process_time()
        simulator.AdvanceTo(duration)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
        detectors = world.robot().detectors
        detector = None if detectors is None else (detectors.blob or detectors.aruco)
        per_frame = detector.seconds / max(1, detector.frames) if detector else 0.0
        return duration / wall, duration / cpu, per_frame, detector.frames if detector else 0
    finally:
        world.close()


# (row label, override of the scenario, the scenario) of the vision section.
VISION_CASES = (
    ("no detector", "vision: null", "vision_blob"),
    ("blob detector, the seed's 249 thresholds", "", "vision_blob"),
    (
        "blob detector, 249 thresholds, SimpleBlobDetector as it is",
        "vision: {blob: {skip_repeated_thresholds: false}}",
        "vision_blob",
    ),
    (
        "ArUco detector + solvePnP",
        "objects: [{name: marker, shape: !ArucoMarker {}, xyz: [0.45, 0.0, 0.0025]}]\n"
        "vision: {blob: null, aruco: {camera: top_camera}}",
        "vision_blob",
    ),
    # The camera on the arm's flange turns to the marker: every frame differs.
    ("camera on the moving arm, ArUco + solvePnP (vision_look_at)", "", "vision_look_at"),
)


def bench_vision(report: Report, duration: float) -> None:
    """The blob scenario (640 x 480 at 30 Hz, detection on every frame)."""
    renderers = renderers_to_bench(report.quick)
    results: dict[tuple[str, str], dict[str, list[float]]] = {}
    for _ in range(report.repeat):
        for renderer in renderers:
            for label, override, scenario in VISION_CASES:
                wall, cpu, per_frame, _frames = vision_world_rtf(
                    duration, override, renderer, scenario
                )
                entry = results.setdefault((label, renderer), {"wall": [], "cpu": [], "ms": []})
                entry["wall"].append(wall)
                entry["cpu"].append(cpu)
                entry["ms"].append(per_frame * 1000.0)
    for renderer in renderers:
        engine, first = ENGINES[renderer], renderer == renderers[0]
        for label, _, _ in VISION_CASES:
            entry = results[label, renderer]
            name = f"vision scenario, {label}, {engine}, {duration:g} s"
            row = Row("vision", name, RTF, entry["wall"])
            report.add(row.check(">=", 1.0) if "seed" in label and first else row)
            if "seed" in label or "moving" in label:
                name = f"{label}, {engine}, per CPU second of the process"
                report.add(Row("vision", name, RTF, entry["cpu"]))
            if label != "no detector" and first:
                report.add(Row("vision", f"{label}: cost per frame", "ms", entry["ms"]))
    report.notes.append(
        "Vision: diagrams/vision_blob.yaml (a 640 x 480 camera at 30 Hz looking down at the "
        "blue disc), by the renderer named (RenderEngineGl first when a display can be had, "
        "then RenderEngineVtk too), run as fast as it goes, no "
        "viewer; the detector reads every frame (30 frames a second; none without a "
        "detector). Nothing in its view moves: the camera renders once and holds that "
        "frame while no pose changes, and a detector returns its last result for a frame "
        "equal to the last one (on either renderer); 'cost per frame' (those frames "
        "included) is the OpenCV time of "
        "the detector (wall clock, annotated image included). The seed's row runs OpenCV once per "
        "distinct binary image (armando_drake/vision/blobs.py, the same keypoints); 'as it "
        "is' runs SimpleBlobDetector over all 249 thresholds. The moving arm's row is "
        "diagrams/vision_look_at.yaml: the iiwa's flange camera turns to the ArUco marker "
        "and every frame differs, so every frame is rendered and detected (no target: the "
        "issue's rows are the still views above)."
    )


# --- 8. sweep ------------------------------------------------------------------------


def bench_sweep(report: Report) -> None:
    """World runs per minute of a sweep: local pool with 1 and 2 workers, Ray on 2 CPUs.

    The same variants each time (the position scenario, kp over a grid, no
    console output), each run a fresh world process; the three engines are
    interleaved per repetition. Ray's start-up is not timed (a cluster is
    started once and serves many sweeps).
    """
    import shutil

    count, duration = (2, 0.1) if report.quick else (8, 2.0)
    sweep = Sweep(
        scenario="position",
        variants=make_variants([parse_grid(f"actuators.kp=linspace(2, 16, {count})")]),
        common_overrides=[NO_CONSOLE],
        world_args=["--duration", repr(duration)],
    )

    def runs_per_minute(engine) -> float:
        with tempfile.TemporaryDirectory(prefix="armando_bench_sweep_") as folder:
            start = time.perf_counter()
            outcome = run_sweep(sweep, folder, engine, progress=False)
            seconds = time.perf_counter() - start
        if outcome.failed:
            raise RuntimeError(f"sweep benchmark: {outcome.failed} of {count} runs failed")
        return 60.0 * count / seconds

    load = [os.getloadavg()[0]]
    ray_engine, ray_folder = None, tempfile.mkdtemp(prefix="armando_bench_ray_")
    if report.quick:  # a local Ray cluster's start-up alone takes about 30 s here
        report.notes.append("Sweep: no Ray row in a --quick run.")
    else:
        try:
            ray_engine = RayEngine("local", workers=2, temp_dir=ray_folder)
        except SweepError as error:
            report.notes.append(f"Sweep: no Ray row ({error}).")
    one, two, ray = [], [], []
    try:
        for _ in range(report.repeat):
            one.append(runs_per_minute(LocalPool(workers=1)))
            two.append(runs_per_minute(LocalPool(workers=2)))
            if ray_engine is not None:
                ray.append(runs_per_minute(ray_engine))
            load.append(os.getloadavg()[0])
    finally:
        if ray_engine is not None:
            ray_engine.close()
        shutil.rmtree(ray_folder, ignore_errors=True)
    report.add(Row("sweep", "sweep, local pool, 1 worker", "runs/min", one))
    report.add(Row("sweep", "sweep, local pool, 2 workers", "runs/min", two))
    ratios = [b / a for a, b in zip(one, two, strict=True)]
    report.add(Row("sweep", "sweep, 2 workers / 1 worker", "ratio", ratios).check(">=", 1.8))
    if ray:
        report.add(Row("sweep", "sweep, Ray on 2 CPUs", "runs/min", ray))
        ratios = [r / b for r, b in zip(ray, two, strict=True)]
        report.add(
            Row("sweep", "sweep, Ray / local pool, 2 workers", "ratio", ratios).check(">=", 0.9)
        )
    report.notes.append(
        f"Sweep: {count} variants of the position scenario (kp from 2 to 16), {duration:g} s "
        "simulated each, every run a fresh `python -m armando_drake.world` process (start-up "
        f"included); {os.cpu_count()} CPUs, 1-minute load average "
        + ", ".join(f"{x:.2f}" for x in load)
        + " (before, then after each repetition). The 2-worker target needs 2 idle CPUs."
    )


# --- 10. lidar ----------------------------------------------------------------------

LIDAR_BUDGET_MS = 10.0  # [ms] per scan: 10 % of real time at 10 Hz


def lidar_scan_ms(scans: int) -> float:
    """[ms] wall time of one scan of fra2mo's lidar (640 beams over 360 deg, 0.1..10 m)
    in a 10 m x 10 m room of four walls and 20 boxes and cylinders, rendered by the
    lidar's ring of depth cameras (RenderEngineVtk through EGL)."""
    from pydrake.geometry import MakeRenderEngineVtk, RenderEngineVtkParams
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    rng = np.random.default_rng(0)
    objects = [
        SceneObject(name=f"wall{i}", shape=Box(size=size), xyz=xyz)
        for i, (size, xyz) in enumerate(
            [
                ([0.1, 10, 2], [5, 0, 1]),
                ([0.1, 10, 2], [-5, 0, 1]),
                ([10, 0.1, 2], [0, 5, 1]),
                ([10, 0.1, 2], [0, -5, 1]),
            ]
        )
    ]
    for i in range(20):
        x, y = rng.uniform(-4.5, 4.5, 2)
        shape = Box(size=[0.4, 0.6, 1.0]) if i % 2 else Cylinder(radius=0.25, length=1.0)
        objects.append(SceneObject(name=f"thing{i}", shape=shape, xyz=[x, y, 0.5]))
    AddSceneObjects(plant, objects)
    plant.Finalize()
    info = LidarInfo(
        name="lidar",
        type="gpu_lidar",
        link="world",
        X_LS=RigidTransform([0.0, 0.0, 0.3]),
        samples=640,
        resolution=1.0,
        angle_min=-3.14,
        angle_max=3.14,
        range_min=0.1,
        range_max=10.0,
        range_resolution=0.01,
        update_rate=10.0,
        topic="lidar",
        frame_id="lidar",
    )
    scene_graph.AddRenderer(LIDAR_RENDERER, MakeRenderEngineVtk(RenderEngineVtkParams()))
    scanner = builder.AddSystem(
        LidarScanner(info, body_frame_id=scene_graph.world_frame_id(), X_BS=info.X_LS)
    )
    builder.Connect(scene_graph.get_query_output_port(), scanner.get_query_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    query = scanner.get_query_input_port().Eval(scanner.GetMyContextFromRoot(context))
    scanner.scan_ranges(query)  # the first scan builds the render pipeline
    start = time.perf_counter()
    for count in range(scans):
        scanner.scan_ranges(query, count)
    return (time.perf_counter() - start) / scans * 1e3


def bench_lidar(report: Report, scans: int) -> None:
    samples = [lidar_scan_ms(scans) for _ in range(report.repeat)]
    report.add(
        Row("lidar", "lidar scan, 640 beams over 360 deg", "ms", samples).check(
            "<=", LIDAR_BUDGET_MS
        )
    )
    report.notes.append(
        "Lidar: one scan rendered by a ring of four 1-pixel-high depth cameras "
        "(RenderEngineVtk) in a room of 24 boxes and cylinders; a numpy ray caster on the "
        "scene's triangles took about 4 times as long on the race field's meshes."
    )


# --- 12. learned IK -------------------------------------------------------------------

LEARNED_IK_NETWORK = MODELS_DIR / "learned_ik" / "armando_ik_network.onnx"
LEARNED_IK_BUDGET = 0.2  # [ms] one pose through the network


def bench_learned_ik(report: Report, poses: int) -> None:
    """Milliseconds per pose of the learned IK (models/learned_ik/armando_ik_network.onnx,
    ONNX Runtime on one thread), one pose at a time as a node answers targets: the
    network alone, and with 3 Gauss-Newton steps on the plant; and Drake's
    InverseKinematics on the same poses (a tenth of them)."""
    model = IkModel(LEARNED_IK_NETWORK)
    arm = model.make_arm()
    rng = np.random.default_rng(0)
    q = rng.uniform(
        np.maximum(arm.lower, -2.5), np.minimum(arm.upper, 2.5), (poses, arm.num_joints)
    )
    targets = []
    for row in q:
        arm.set_state(row)
        targets.append(arm.pose())
    network, refined, drake = [], [], []
    for _ in range(report.repeat):
        start = time.perf_counter()
        answers = [model.predict(X) for X in targets]
        network.append((time.perf_counter() - start) / poses * 1e3)
        start = time.perf_counter()
        for answer, X in zip(answers, targets, strict=True):
            refine(arm, answer, X, 3)
        refined.append(network[-1] + (time.perf_counter() - start) / poses * 1e3)
        count = max(1, poses // 10)
        start = time.perf_counter()
        for X in targets[:count]:
            solve_ik(arm, X, orientation="constraint")
        drake.append((time.perf_counter() - start) / count * 1e3)
    report.add(
        Row("learned_ik", "learned IK, network per pose", "ms", network).check(
            "<=", LEARNED_IK_BUDGET
        )
    )
    report.add(Row("learned_ik", "learned IK, network + 3 Gauss-Newton steps", "ms", refined))
    report.add(Row("learned_ik", "Drake InverseKinematics per pose", "ms", drake))
    report.notes.append(
        f"Learned IK: {poses} random poses of Armando, one at a time through "
        f"{LEARNED_IK_NETWORK.name} (ONNX Runtime, one thread); the refinement's steps run "
        "on the plant in Python; Drake's IK (solve_ik, the whole pose as a constraint) on "
        "a tenth of them."
    )


# --- the suite ----------------------------------------------------------------------


@dataclasses.dataclass
class Settings:
    """How long each measurement runs."""

    pipeline_seconds: float  # [s] simulated per pipeline run
    pipeline_runs: int  # runs of each pipeline configuration per repetition
    target_period: float  # [s] per target in the time-step search
    camera_frames: int  # frames per render measurement
    camera_seconds: float  # [s] simulated with the camera
    memory_seconds: float  # [s] simulated in the memory soak
    task_seconds: float = 3.0  # [s] simulated per task-space run (the motion is 2.5 s)
    task_ticks: int = 2000  # controller updates timed
    mobile_seconds: float = 11.14  # [s] simulated of fra2mo's sequence (all of it)
    learned_ik_poses: int = 2000  # poses the learned IK answers, one at a time
    navigation_seconds: float = 34.0  # [s] simulated of fra2mo's goals (all four)
    exploration_seconds: float = 34.0  # [s] simulated of fra2mo exploring its arena (all of it)

    @staticmethod
    def of(quick: bool) -> Settings:
        if quick:
            return Settings(1.0, 1, 1.0, 5, 0.5, 5.0, 0.5, 100, 1.0, 100, 2.0, 2.0)
        return Settings(10.0, 5, TARGET_PERIOD, 60, 5.0, 3600.0)


def run_suite(
    *, quick: bool, repeat: int, sections=SECTIONS, stream=sys.stdout, settings=None
) -> Report:
    """Runs the chosen sections and returns the report."""
    settings = settings or Settings.of(quick)
    report = Report(quick=quick, repeat=repeat)
    report.started = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    begin = time.perf_counter()
    steps = {
        "pipeline": lambda: bench_pipeline(
            report, settings.pipeline_seconds, settings.pipeline_runs
        ),
        "mujoco": lambda: bench_mujoco(report, settings.target_period),
        "camera": lambda: bench_camera(report, settings.camera_frames, settings.camera_seconds),
        "startup": lambda: bench_startup(report),
        "memory": lambda: bench_memory(report, settings.memory_seconds),
        "perception": lambda: bench_perception(
            report, settings.camera_frames, settings.camera_seconds
        ),
        "task": lambda: bench_task(report, settings.task_seconds, settings.task_ticks),
        "sweep": lambda: bench_sweep(report),
        "vision": lambda: bench_vision(report, settings.camera_seconds),
        "lidar": lambda: bench_lidar(report, settings.camera_frames),
        "mobile": lambda: bench_mobile(
            report,
            settings.mobile_seconds,
            settings.navigation_seconds,
            settings.exploration_seconds,
        ),
        "learned_ik": lambda: bench_learned_ik(report, settings.learned_ik_poses),
    }
    for section in sections:
        print(f"[bench] {section} ...", file=sys.stderr, flush=True)
        section_start = time.perf_counter()
        steps[section]()
        print(
            f"[bench] {section}: {time.perf_counter() - section_start:.1f} s",
            file=sys.stderr,
            flush=True,
        )
    report.seconds = time.perf_counter() - begin
    return report


def _sections(text: str) -> list[str]:
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in SECTIONS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"--only {text!r}: choose from {', '.join(SECTIONS)} (comma separated)"
        )
    return names


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("armando_drake.bench", __doc__)
    parser.add_argument("--quick", action="store_true", help="a smoke run of a few seconds")
    parser.add_argument(
        "--json", metavar="FILE", default="bench.json", help="output (default: bench.json)"
    )
    parser.add_argument(
        "--repeat", type=int, metavar="N", help="repetitions per figure (default: 3; quick: 1)"
    )
    parser.add_argument(
        "--only", type=_sections, default=list(SECTIONS), help="sections, comma separated"
    )
    parser.add_argument("--memory-child", type=float, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    if args.memory_child is not None:
        print(json.dumps(memory_soak(args.memory_child)))
        return 0
    repeat = args.repeat if args.repeat is not None else (1 if args.quick else 3)
    if repeat < 1:
        parser.error(f"--repeat {repeat} must be at least 1")
    report = run_suite(quick=args.quick, repeat=repeat, sections=args.only)
    print(report.markdown())
    path = Path(args.json)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(report.as_dict(), indent=2) + "\n")
    print(f"\n{len(report.rows)} rows in {report.seconds:.0f} s; raw numbers: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
