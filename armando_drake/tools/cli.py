"""What the command-line entry points share: argument helpers and error reporting."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterable, Iterator


class UserError(Exception):
    """A mistake in the user's input, reported as one line without a traceback."""


def command_parser(module: str, doc: str) -> argparse.ArgumentParser:
    """The argument parser of ``python -m <module>``: the first paragraph of the module's
    ``doc`` as description, the rest (usage notes, examples) as epilog, verbatim."""
    description, _, epilog = doc.partition("\n\n")
    return argparse.ArgumentParser(
        prog=f"python -m {module}",
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


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


def add_viewer_arguments(parser) -> None:
    """``--wait SECONDS`` / ``--no-wait`` before the run and ``--exit-when-done`` /
    ``--keep-serving`` after it, for a run with Meshcat."""
    from armando_drake.outputs.view import WAIT_TIMEOUT

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
    from armando_drake.outputs.view import WAIT_TIMEOUT

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


def apply_scenario_arguments(scenario, args):
    """The scenario with ``--set``, ``--description`` and ``--package-path`` applied."""
    from armando_drake.simulation.scenario import merge_overrides

    scenario = merge_overrides(scenario, args.set)
    if args.description is not None:
        scenario.robot.description = args.description
    scenario.robot.package_paths += args.package_path
    return scenario


@contextlib.contextmanager
def user_errors() -> Iterator[None]:
    """Turns the project's input errors into ``error: ...`` on stderr and exit 2."""
    from armando_drake.description.loader import DescriptionError
    from armando_drake.description.ros2_control import Ros2ControlError

    errors: tuple[type[BaseException], ...] = (UserError, DescriptionError, Ros2ControlError)
    for module, name in (
        ("armando_drake.control.config", "ControllerConfigError"),
        ("armando_drake.sensors.camera", "CameraError"),
        ("armando_drake.control.sequencer", "SequencerError"),
        ("armando_drake.simulation.scenario", "ScenarioError"),
    ):
        with contextlib.suppress(ImportError, AttributeError):
            errors += (getattr(__import__(module, fromlist=[name]), name),)
    try:
        yield
    except errors as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)
