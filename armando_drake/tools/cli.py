"""What the command-line entry points share: argument helpers and error reporting."""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import traceback
from collections.abc import Iterable, Iterator
from typing import NoReturn


class UserError(Exception):
    """A mistake in the user's input, reported as one line without a traceback."""


# Whether an unexpected error prints its traceback (``--debug``, or ARMANDO_DRAKE_DEBUG=1).
_debug = bool(os.environ.get("ARMANDO_DRAKE_DEBUG"))


class _DebugAction(argparse.Action):
    def __call__(self, parser, namespace, values, option_string=None):
        global _debug
        _debug = True
        setattr(namespace, self.dest, True)


def command_parser(module: str, doc: str) -> argparse.ArgumentParser:
    """The argument parser of ``python -m <module>``: the first paragraph of the module's
    ``doc`` as description, the rest (usage notes, examples) as epilog, verbatim; with
    ``--debug`` (see :func:`user_errors`)."""
    description, _, epilog = doc.partition("\n\n")
    parser = argparse.ArgumentParser(
        prog=f"python -m {module}",
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--debug",
        action=_DebugAction,
        nargs=0,
        default=False,
        help="print the traceback of an unexpected error (input errors stay one line)",
    )
    return parser


def parse_xacro_args(items: Iterable[str]) -> dict[str, str]:
    """``["name:=value", ...]`` as a mapping; errors name the bad item."""
    result = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name:
            raise UserError(f"--xacro-arg {item!r} is not of the form name:=value")
        result[name] = value
    return result


def add_scenario_arguments(parser) -> None:
    """``--scenario FILE`` and repeatable ``--set YAML``, as every scenario command takes them."""
    parser.add_argument(
        "--scenario",
        default="position",
        metavar="FILE",
        help="scenario YAML: a path, or a name in diagrams/ (default: position)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="YAML",
        help='YAML merged over the scenario, e.g. "simulation: {duration: 5}" (repeatable)',
    )
    add_description_arguments(parser, default="the scenario's, i.e. the built-in Armando")


def add_host_argument(parser) -> None:
    """``--host ADDRESS``: where Meshcat listens; this machine only by default."""
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        metavar="ADDRESS",
        help="address Meshcat listens on (default 127.0.0.1: this machine only; 0.0.0.0 "
        "opens it to every network interface)",
    )


def start_meshcat(host: str):
    """A Meshcat server listening on ``host`` (see :func:`add_host_argument`)."""
    import logging

    from pydrake.geometry import Meshcat, MeshcatParams

    if host not in ("127.0.0.1", "localhost", "::1"):
        logging.getLogger("armando_drake").warning(
            "--host %s: Meshcat is reachable from other machines", host
        )
    # Drake logs "Meshcat listening for connections at URL"; the run prints the URL once.
    drake_logger = logging.getLogger("drake")
    level = drake_logger.level
    drake_logger.setLevel(logging.WARNING)
    try:
        return Meshcat(MeshcatParams(host=host))
    finally:
        drake_logger.setLevel(level)


def interactive() -> bool:
    """Whether a person is at the terminal: standard input and output are both terminals."""
    return sys.stdin.isatty() and sys.stdout.isatty()


WAIT_TIMEOUT = 60.0  # [s] how long a run on a terminal waits for a browser by default


def add_viewer_arguments(parser) -> None:
    """``--wait SECONDS`` / ``--no-wait`` before the run and ``--exit-when-done`` /
    ``--keep-serving`` after it, for a run with Meshcat."""
    parser.add_argument(
        "--wait",
        type=float,
        metavar="SECONDS",
        help="with Meshcat, wait up to SECONDS for a browser to open the page before the "
        f"clock starts (default: {WAIT_TIMEOUT:g} on a terminal, 0 otherwise)",
    )
    parser.add_argument(
        "--no-wait", action="store_true", help="start at once (the same as --wait 0)"
    )
    serve = parser.add_mutually_exclusive_group()
    serve.add_argument(
        "--exit-when-done",
        dest="keep_serving",
        action="store_false",
        default=None,
        help="exit when the run ends (default when not on a terminal)",
    )
    serve.add_argument(
        "--keep-serving",
        dest="keep_serving",
        action="store_true",
        help="after the run, keep Meshcat serving the run as a replay until Ctrl-C "
        "(default on a terminal)",
    )


def wait_seconds(args) -> float:
    """[s] how long to wait for a browser, from ``--wait`` / ``--no-wait``."""
    if args.no_wait:
        return 0.0
    if args.wait is not None:
        if not args.wait >= 0:
            raise UserError(f"--wait {args.wait} must not be negative [s]")
        return args.wait
    return WAIT_TIMEOUT if interactive() else 0.0


def keeps_serving(args) -> bool:
    """Whether Meshcat stays up after the run (``--keep-serving`` / ``--exit-when-done``)."""
    return interactive() if args.keep_serving is None else args.keep_serving


def add_description_arguments(parser, default: str) -> None:
    """``--description PATH`` and repeatable ``--package-path DIR``."""
    parser.add_argument(
        "--description",
        metavar="PATH",
        help="robot description: .urdf/.xacro file, package directory or package://pkg/file "
        f"(default: {default})",
    )
    parser.add_argument(
        "--package-path",
        action="append",
        default=[],
        metavar="DIR",
        help="a folder to search for ROS packages before ROS_PACKAGE_PATH (repeatable)",
    )


def note_option(scenario, keys: Iterable[str], option: str) -> None:
    """Records that the command-line ``option`` set the scenario's dotted ``keys``, for
    the messages of :mod:`armando_drake.simulation.validation`."""
    from armando_drake.simulation.scenario import sources_of

    for key in keys:
        sources_of(scenario).note(key, option)


def apply_scenario_arguments(scenario, args):
    """The scenario with ``--set``, ``--description`` and ``--package-path`` applied."""
    from armando_drake.simulation.scenario import merge_overrides

    scenario = merge_overrides(scenario, args.set)
    if args.description is not None:
        scenario.robot.description = args.description
        note_option(scenario, ("robot.description",), "--description")
    scenario.robot.package_paths += args.package_path
    return scenario


def _input_errors() -> tuple[type[BaseException], ...]:
    """The exception types that mean a mistake in the user's input."""
    errors: tuple[type[BaseException], ...] = (UserError,)
    for module, name in (
        ("armando_drake.description.loader", "DescriptionError"),
        ("armando_drake.description.ros2_control", "Ros2ControlError"),
        ("armando_drake.control.config", "ControllerConfigError"),
        ("armando_drake.sensors.camera", "CameraError"),
        ("armando_drake.sensors.objects", "SceneObjectError"),
        ("armando_drake.control.sequencer", "SequencerError"),
        ("armando_drake.simulation.scenario", "ScenarioError"),
    ):
        with contextlib.suppress(ImportError, AttributeError):
            errors += (getattr(__import__(module, fromlist=[name]), name),)
    return errors


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _unexpected(error: BaseException) -> str:
    """One line for an error that is not an input error: Drake's ``Failure at
    <file>:<line> in <function>(): condition '...' failed.`` keeps only its condition."""
    text = _one_line(error)
    if text.startswith("Failure at "):
        condition = text.partition(": ")[2] or text
        return f"Drake refused an input ({condition})"
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


@contextlib.contextmanager
def _held_interrupts() -> Iterator[None]:
    """Ctrl-C waits until the block is done, then raises KeyboardInterrupt."""
    held = []
    try:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if held:
        raise KeyboardInterrupt


def _exit_interrupted(message: str) -> NoReturn:
    """Prints ``message`` and exits 130 at once. pydrake runs part of its start-up through
    pybind11's exec, which marks a KeyboardInterrupt raised there as unhandled: Python
    would then end the process by SIGINT (exit -2) whatever it exits with. What a run
    keeps (logs, summary) is written before a KeyboardInterrupt gets here. A further
    Ctrl-C from here on is ignored."""
    with contextlib.suppress(ValueError):  # not the main thread
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    print(message, file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


@contextlib.contextmanager
def user_errors() -> Iterator[None]:
    """What a command does on an error, whatever its origin.

    - an input error (:class:`UserError`, a description, controller YAML, scenario,
      camera, object or sequencer error): ``error: ...`` on stderr, one line, exit 2;
    - Ctrl-C (SIGINT), also one that breaks an import half way (``ImportError:
      initialization failed``): ``interrupted`` on stderr, exit 130;
    - anything else: ``error: <type>: <message> (run with --debug for the
      traceback)``, one line, exit 1; with ``--debug`` the traceback first.
    """
    interrupted = []
    previous = None

    def on_sigint(signum, frame):
        interrupted.append(signum)
        if len(interrupted) == 1:  # the first stops the command; later ones only count
            raise KeyboardInterrupt

    try:
        # pydrake's C++ start-up, cut by a Ctrl-C, logs a stack dump: it is let finish.
        with _held_interrupts():
            import pydrake  # noqa: F401
        with contextlib.suppress(ValueError):  # not the main thread: leave SIGINT alone
            previous = signal.signal(signal.SIGINT, on_sigint)
        yield
    except KeyboardInterrupt as interrupt:
        _exit_interrupted(f"interrupted: {interrupt}" if str(interrupt) else "interrupted")
    except SystemExit:
        raise
    except Exception as error:
        if interrupted:  # Ctrl-C inside an extension's import surfaces as ImportError
            _exit_interrupted("interrupted")
        if isinstance(error, _input_errors()):
            print(f"error: {_one_line(error)}", file=sys.stderr)
            sys.exit(2)
        if _debug:
            traceback.print_exc()
            print(f"error: {_unexpected(error)}", file=sys.stderr)
        else:
            print(
                f"error: {_unexpected(error)} (run with --debug for the traceback)",
                file=sys.stderr,
            )
        sys.exit(1)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
