"""The command line of the world (``python -m armando_drake.world``): its options,
the scenario they make, the run and its report. :mod:`armando_drake.world` is the
thin entry module over :func:`run_command`."""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import sys
import time
from pathlib import Path

from armando_drake.control.controllers import controller_kinds, controller_type_for
from armando_drake.control.sequencer import (
    CONTROLLER_KIND,
    MODE_NAMES,
    JointTrajectoryTargets,
    PositionTargets,
    Sinusoid,
)
from armando_drake.outputs.folder_lock import output_folder_lock
from armando_drake.outputs.headlines import chapter_lines
from armando_drake.outputs.recording import RecordingError, check_recording_path
from armando_drake.outputs.view import serve_until_interrupted
from armando_drake.simulation.run import format_table, run
from armando_drake.simulation.scenario import (
    apply_scenario_arguments,
    load_scenario,
    note_option,
    only_robot,
    resolve_scenario_path,
    sources_of,
)
from armando_drake.simulation.validation import check_scenario
from armando_drake.tools.cli import (
    UserError,
    add_host_argument,
    add_scenario_arguments,
    add_viewer_arguments,
    check_host,
    command_parser,
    keeps_serving,
    start_meshcat,
    user_errors,
    wait_seconds,
)

# What each --controller mode feeds its controller.
_FEEDS = {
    "position": "the target sequence",
    "trajectory": "the same targets as one JointTrajectory",
    "sinusoid": "a sinusoid",
}


def _controller_modes() -> dict[str, str]:
    """What ``--controller`` chooses from: each mode of the command sequencer whose kind of
    controller the registry has, with the type of that kind (``none``: only the joint
    state broadcaster)."""

    kinds = controller_kinds()
    modes = {
        mode: controller_type_for(CONTROLLER_KIND[config])
        for config, mode in MODE_NAMES.items()
        if CONTROLLER_KIND[config] in kinds
    }
    return modes | {"none": ""}


def world_parser(doc: str) -> argparse.ArgumentParser:
    """The parser of ``python -m armando_drake.world`` (``doc``: its help text)."""
    parser = command_parser("armando_drake.world", doc)
    add_scenario_arguments(parser)
    modes = _controller_modes()
    drives = [
        f"{mode}: the first {type_name} of the controller YAML with {_FEEDS.get(mode, mode)}"
        for mode, type_name in modes.items()
        if type_name
    ]
    parser.add_argument(
        "--controller",
        choices=list(modes),
        help=f"what drives the arm: {'; '.join(drives)}; none: nothing but the joint state "
        "broadcaster (default: as the scenario says)",
    )
    parser.add_argument(
        "--param-file",
        action="append",
        default=[],
        metavar="FILE",
        help="a controller parameter file (ROS 2 or ROS 1 YAML) to read instead of the "
        "robot's own; repeatable, read in order with later values winning, as spawner "
        "--param-file (default: as the scenario says)",
    )
    parser.add_argument(
        "--duration",
        type=float,
        metavar="SECONDS",
        help="simulated time [s] (default: one pass of the sequence)",
    )
    parser.add_argument(
        "--realtime-rate",
        type=float,
        metavar="R",
        help="target simulated/wall time ratio; 0 = as fast as possible (default: the "
        "scenario's simulator_config.target_realtime_rate: 1, except the navigation "
        "scenarios fra2mo_goals, fra2mo_obstacles, fra2mo_explore, fra2mo_amcl and "
        "fra2mo_aruco, which run unpaced (0); 1 with --ros2 or --foxglove)",
    )
    parser.add_argument("--no-meshcat", action="store_true", help="run without the viewer")
    add_viewer_arguments(parser)
    _add_camera_options(parser)
    _add_output_options(parser)
    _add_ros2_options(parser)
    add_host_argument(parser)
    return parser


def _add_camera_options(parser) -> None:
    """--camera, --camera-view, --save-frames, --save-rate, --renderer, --camera-max-rate."""
    parser.add_argument(
        "--camera",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="turn the URDF's camera sensors into Drake RgbdSensors (with Meshcat on, "
        "their live view is served on --host; default: as the scenario says)",
    )
    parser.add_argument(
        "--camera-view",
        action="store_true",
        help="serve the camera's live view on --host (127.0.0.1) even with --no-meshcat (with "
        "Meshcat on it is served anyway; implies --camera)",
    )
    parser.add_argument(
        "--save-frames",
        metavar="DIR",
        help="save camera frames: colour PNG and depth 16-bit PNG in millimetres (implies "
        "--camera)",
    )
    parser.add_argument(
        "--save-rate",
        type=float,
        metavar="HZ",
        help="rate at which --save-frames writes frames [Hz]; 0 = the camera's rate "
        "(default: as the scenario says, 0)",
    )
    parser.add_argument(
        "--renderer",
        choices=("auto", "gl", "vtk"),
        help="camera renderer: gl = Drake's OpenGL engine (on DISPLAY or a private Xvfb), "
        "vtk = VTK through EGL (no display needed), auto = gl when possible, else vtk "
        "(default: as the scenario says, auto)",
    )
    parser.add_argument(
        "--camera-max-rate",
        type=float,
        metavar="HZ",
        help="for interactive runs: every camera renders at most at HZ instead of its own "
        "rate (its detectors follow; the log and summary.json say so); 0 = the cameras' "
        "own rates (default: as the scenario says, 0)",
    )


def _add_output_options(parser) -> None:
    """--output, --no-replay, --record."""
    parser.add_argument(
        "--output", metavar="DIR", help="write joint_states.csv, commands.csv, summary.json"
    )
    parser.add_argument(
        "--no-replay",
        action="store_true",
        help="with --output, do not write replay.html (saves the recording's cost)",
    )
    parser.add_argument(
        "--record",
        metavar="FILE.mcap",
        help="record the run's topics as a ROS 2 bag (MCAP) for ros2 bag and Foxglove",
    )


def _add_ros2_options(parser) -> None:
    """--ros2, --foxglove, --quiet."""
    parser.add_argument(
        "--ros2",
        action="store_true",
        help="put the running world on DDS as a ROS 2 robot (loopback only unless the "
        "scenario's ros2.network_interface names one); paced at real time unless "
        "--realtime-rate is given",
    )
    parser.add_argument(
        "--foxglove",
        nargs="?",
        type=int,
        const=8765,
        metavar="PORT",
        help="serve the same topics to Foxglove over WebSocket on 127.0.0.1:PORT (default 8765)",
    )
    parser.add_argument(
        "--quiet", action="store_true", help="print only errors and the final table"
    )


def _apply_controller(scenario, mode: str) -> None:
    """Points the scenario's only robot at the controller a --controller choice names
    (an error naming the option for a scenario of several robots).

    position / trajectory keep the scenario's targets, period, cyclic and
    start delay (the seed targets when it has none); sinusoid keeps a
    sinusoid the scenario has, else runs the seed's wave (Sinusoid's
    defaults).
    """

    # The YAML's joint state broadcaster, whatever its name (ROS 1: JointStateController).
    broadcasters = [f"type:{controller_type_for('broadcaster')}"]
    entry = only_robot(scenario, "--controller")
    if mode == "none":
        entry.controllers.activate = broadcasters
        entry.sequencer = None
        return
    current = entry.sequencer
    if mode == "sinusoid":
        entry.sequencer = current if isinstance(current, Sinusoid) else Sinusoid()
    else:
        kind = PositionTargets if mode == "position" else JointTrajectoryTargets
        if isinstance(current, (PositionTargets, JointTrajectoryTargets)):
            entry.sequencer = kind(
                targets=current.targets,
                period=current.period,
                cyclic=current.cyclic,
                start_delay=current.start_delay,
            )
        else:
            entry.sequencer = kind()
    # The first controller of the type of the sequencer's kind in the controller YAML.
    wanted = controller_type_for(CONTROLLER_KIND[type(entry.sequencer)])
    entry.controllers.activate = broadcasters + [f"type:{wanted}"]


def run_command(argv: list[str] | None, doc: str) -> int:
    """``python -m armando_drake.world``: the scenario with the command line's options
    applied, run, and reported; the exit code (130 when interrupted)."""
    started = time.time()  # the files of --output written since then are this run's
    args = world_parser(doc).parse_args(argv)
    logging.basicConfig(
        level=logging.WARNING if args.quiet else logging.INFO,
        format="%(message)s",
        stream=sys.stdout,
    )
    with user_errors():
        path = resolve_scenario_path(args.scenario)
        scenario = scenario_from_arguments(load_scenario(path), args)
        host = check_host(args.host)
        wait = wait_seconds(args)
        if args.record:
            _check_record(args.record)
        if args.output:
            _check_output(args.output)
        if args.save_frames:
            _check_output(args.save_frames, "--save-frames")
        meshcat = None
        if not args.no_meshcat:
            meshcat = start_meshcat(host)
        # One run per output folder: a second run given the same one is refused.
        with output_folder_lock(args.output) if args.output else contextlib.nullcontext():
            result = run(
                scenario,
                scenario_name=str(path),
                output_dir=args.output,
                meshcat=meshcat,
                quiet=args.quiet,
                replay=not args.no_replay,
                record=args.record,
                wait_for_browser=0.0 if meshcat is None else wait,
                host=host,
            )
        _report(result, args, started)
        if meshcat is not None and not result.interrupted and keeps_serving(args):
            serve_until_interrupted(meshcat)
    return 130 if result.interrupted else 0


def scenario_from_arguments(scenario, args):
    """``scenario`` with the command line's options applied and checked (the scenario's
    schema, :func:`~armando_drake.simulation.validation.check_scenario`), each option
    noted as the origin of the keys it sets: ``--controller`` first, so that ``--set``
    edits the sequencer it chose, then ``--set``, ``--description``, ``--package-path``;
    ``--controller none`` last (nothing drives the arm, whatever ``--set`` said of the
    sequencer)."""
    if args.controller not in (None, "none"):
        _apply_controller(scenario, args.controller)
        note_option(scenario, ("sequencer", "controllers.activate"), "--controller")
    scenario = apply_scenario_arguments(scenario, args)
    if args.controller == "none":
        if any(origin.startswith("--set") for origin in _sequencer_origins(scenario)):
            logging.getLogger("armando_drake.world").warning(
                "--controller none: the sequencer that --set describes is not run"
            )
        _apply_controller(scenario, "none")
        note_option(scenario, ("sequencer", "controllers.activate"), "--controller none")
    if args.param_file:
        only_robot(scenario, "--param-file").controllers.config = list(args.param_file)
        note_option(scenario, ("controllers.config",), "--param-file")
    _apply_run_options(scenario, args)
    _apply_camera_options(scenario, args)
    # The options' values checked by the scenario's schema, as a file's or a --set's
    # (before Meshcat starts): the error names the option that set the key.
    check_scenario(scenario)
    return scenario


def _apply_run_options(scenario, args) -> None:
    """--duration, --realtime-rate, --ros2, --foxglove."""
    if args.duration is not None:
        # 0 s is one pass of the sequence in the scenario; on the command line, no time.
        scenario.simulation.duration = args.duration if args.duration != 0 else 1e-9
        note_option(scenario, ("simulation.duration",), f"--duration {args.duration}")
    if args.realtime_rate is not None:
        scenario.simulator_config.target_realtime_rate = args.realtime_rate
        option = f"--realtime-rate {args.realtime_rate}"
        note_option(scenario, ("simulator_config.target_realtime_rate",), option)
    if args.ros2 or args.foxglove is not None:
        scenario.ros2.enabled = scenario.ros2.enabled or args.ros2
        if args.foxglove is not None:
            scenario.ros2.foxglove, scenario.ros2.foxglove_port = True, args.foxglove
            note_option(scenario, ("ros2.foxglove_port",), f"--foxglove {args.foxglove}")
        if args.realtime_rate is None:
            scenario.simulator_config.target_realtime_rate = 1.0


def _apply_camera_options(scenario, args) -> None:
    """--camera, --camera-view, --save-frames, --save-rate, --renderer, --camera-max-rate."""
    if args.camera is not None:
        scenario.camera.enabled = args.camera
    if args.camera_view:
        scenario.camera.enabled = scenario.camera.live_view = True
    if args.save_frames:
        scenario.camera.enabled = True
        scenario.camera.save_frames = args.save_frames
    if args.save_rate is not None:
        scenario.camera.save_rate = args.save_rate
        note_option(scenario, ("camera.save_rate",), f"--save-rate {args.save_rate}")
    if args.renderer is not None:
        scenario.camera.renderer = args.renderer
    if args.camera_max_rate is not None:
        scenario.camera.max_rate = args.camera_max_rate
        note_option(scenario, ("camera.max_rate",), f"--camera-max-rate {args.camera_max_rate}")


def _report(result, args, started: float) -> None:
    """The run's headline, step table, tracking errors and the files it wrote."""
    print(f"\n{result.headline()}")
    for name, steps in result.robot_steps.items():  # a world of several robots
        section = result.robots[name]
        print(f"{name} ({section['namespace']}):")
        print(format_table(section["joint_names"], steps))
    if result.steps and not result.robot_steps:
        print(format_table(result.joint_names, result.steps))
    if result.tracking_error is not None:
        print(f"sinusoid tracking error after 1 s: {result.tracking_error:.4f} rad")
    if result.task_space and result.task_space["max_position_error"] is not None:
        errors = result.task_space
        print(
            f"task space: max position error {errors['max_position_error'] * 1e3:.3f} mm "
            f"(RMS {errors['rms_position_error'] * 1e3:.3f} mm), max orientation error "
            f"{errors['max_orientation_error']:.4f} rad"
        )
    if result.vision:
        print(_vision_line(result.vision))
    for line in chapter_lines(result.summary()):  # the chapter's own figures
        print(line)
    if args.output:
        _print_outputs(args.output, started)
    if args.record:
        print(f"recording: {args.record}")


def _vision_line(vision: dict) -> str:
    """summary.json's ``vision`` in one line."""
    parts = [f"{vision['detections']} detections in {vision['frames']} frames"]
    if vision.get("final_pointing_error") is not None:
        parts.append(f"final pointing error {vision['final_pointing_error']:.4f} rad")
    if vision.get("marker_position_error") is not None:
        error = math.sqrt(sum(e * e for e in vision["marker_position_error"]))
        parts.append(f"marker position error {error * 1e3:.2f} mm")
    if vision.get("max_path_error") is not None:
        parts.append(f"largest path error {vision['max_path_error'] * 1e3:.3f} mm")
    return "vision: " + ", ".join(parts)


def _print_outputs(output: str, since: float) -> None:
    """The files the run wrote to ``output`` (modified after ``since``, a ``time.time()``),
    by kind: what it wrote, not what it might have."""
    written = sorted(
        p.name for p in Path(output).iterdir() if p.is_file() and p.stat().st_mtime >= since
    )
    kinds = (
        ("logs", (".csv", ".json", ".yaml")),
        ("plots", (".png",)),
        ("replay", (".html",)),
    )
    for label, suffixes in kinds:
        names = [name for name in written if name.endswith(suffixes)]
        if label == "replay":
            for name in names:
                print(f"replay: {output}/{name}")
        elif names:
            print(f"{label}: {output}/{names[0]}" + "".join(f", {n}" for n in names[1:]))


def _sequencer_origins(scenario) -> list[str]:
    """Where the sequencer's values came from (files, --set texts, options)."""

    sources = sources_of(scenario)
    return [o for k, o in sources.keys.items() if k == "sequencer" or k.startswith("sequencer.")]


def _check_record(record: str) -> None:

    try:
        check_recording_path(record)
    except RecordingError as error:
        raise UserError(str(error)) from None


def _check_output(output: str, option: str = "--output") -> None:
    """``output`` is a folder (made if missing) where files can be written."""
    path = Path(output)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write_test"
        probe.write_text("")
        probe.unlink()
    except OSError as error:
        raise UserError(f"{option} {output}: cannot write there: {error.strerror}") from None
