"""What the command-line entry points share: argument helpers and error reporting."""

from __future__ import annotations

import argparse
import contextlib
import ipaddress
import math
import os
import shlex
import signal
import socket
import sys
import traceback
from collections.abc import Iterable, Iterator
from typing import NoReturn

from armando_drake.tools.errors import UserInputError
from armando_drake.tools.version import version_text

# The signals that stop a command as Ctrl-C does: what a run keeps (logs, the table, the
# summary) is written first, then exit 130.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def stop_signals_held() -> Iterator[None]:
    """The :data:`STOP_SIGNALS` held back (blocked) for the block: one that comes meanwhile
    is delivered when it ends, so a file write and the note of what it wrote are never
    cut apart (Python runs its handlers on the main thread: call it there)."""
    try:
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    except (AttributeError, ValueError, OSError):  # no pthread_sigmask on this platform
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


class UserError(UserInputError):
    """A mistake in the user's input, reported as one line without a traceback."""


# Whether an unexpected error prints its traceback (``--debug``, or ARMANDO_DRAKE_DEBUG=1).
_debug = bool(os.environ.get("ARMANDO_DRAKE_DEBUG"))


class _DebugAction(argparse.Action):
    def __call__(self, parser, namespace, values, option_string=None):
        global _debug
        _debug = True
        setattr(namespace, self.dest, True)


class _VersionAction(argparse.Action):
    """Prints :func:`~armando_drake.tools.version.version_text` on stdout and exits 0; the
    version (and git) is looked up only when the option is given."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_text())
        parser.exit(0)


def add_version_argument(parser: argparse.ArgumentParser) -> None:
    """``--version``: prints the package's version (and the git commit of a checkout), exits."""
    parser.add_argument(
        "--version",
        action=_VersionAction,
        nargs=0,
        help="print the version of armando-drake (and the git commit it runs from) and exit",
    )


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line, as input errors are:
    ``error: <argparse's message> (see --help)`` on stderr, exit code 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"error: {_one_line(message)} (see --help)\n")


def command_parser(module: str, doc: str) -> argparse.ArgumentParser:
    """The argument parser of ``python -m <module>``: the first paragraph of the module's
    ``doc`` as description, the rest (usage notes, examples) as epilog, verbatim; with
    ``--version`` (:func:`add_version_argument`) and ``--debug`` (see :func:`user_errors`).
    A usage error is one line (its subcommands' parsers are of the same kind)."""
    description, _, epilog = doc.partition("\n\n")
    parser = _Parser(
        prog=f"python -m {module}",
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_version_argument(parser)
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


LOOPBACK = "127.0.0.1"


def add_host_argument(parser) -> None:
    """``--host ADDRESS``: where Meshcat and the camera view listen; this machine only by
    default (see :func:`check_host`)."""
    parser.add_argument(
        "--host",
        default=LOOPBACK,
        metavar="ADDRESS",
        help="address Meshcat and the camera view listen on: an IP address of this machine "
        "or localhost (default 127.0.0.1: this machine only; 0.0.0.0 or :: opens them to "
        "every network interface)",
    )


def check_host(host: str) -> str:
    """``--host``'s address, checked before any server starts: an IP address literal (IPv4
    or IPv6) or ``localhost`` (127.0.0.1), that is an address of this machine (a throwaway
    socket binds to it). Names are not looked up: a lookup can hang."""
    where = f"--host {shlex.quote(host)}"
    if host.lower() == "localhost":
        return LOOPBACK
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        raise UserError(
            f"{where}: not an IP address (give one of this machine's addresses, e.g. "
            "127.0.0.1, ::1, 0.0.0.0 for every interface, or localhost; names are not "
            "looked up)"
        ) from None
    if address.is_multicast or address == ipaddress.IPv4Address("255.255.255.255"):
        raise UserError(f"{where}: a multicast or broadcast address cannot be listened on")
    family = socket.AF_INET6 if address.version == 6 else socket.AF_INET
    try:
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((str(address), 0))
    except OSError as error:
        reason = error.strerror or str(error)
        raise UserError(f"{where}: not an address of this machine ({reason})") from None
    return str(address)


def is_open(host: str) -> bool:
    """Whether a server on ``host`` is reachable from other machines."""
    try:
        return not ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host.lower() != "localhost"


def _http(host: str, port: int, path: str) -> str:
    return f"http://[{host}]:{port}{path}" if ":" in host else f"http://{host}:{port}{path}"


def server_url(host: str, port: int, path: str = "/") -> str:
    """The URL of a server listening on ``host``:``port``. A wildcard address (0.0.0.0,
    ::) is no address to browse to: the machine's host name stands for it."""
    if host in ("0.0.0.0", "::"):
        return _http(socket.gethostname(), port, path)
    return _http(host, port, path)


def server_urls(host: str, port: int, path: str = "/") -> str:
    """What the log prints for a server on ``host``:``port``: :func:`server_url`, and for a
    wildcard address the loopback URL that works on this machine too."""
    url = server_url(host, port, path)
    if host in ("0.0.0.0", "::"):
        local = _http(LOOPBACK if host == "0.0.0.0" else "::1", port, path)
        return f"{url} (on this machine: {local})"
    return url


def warn_if_open(host: str, what: str) -> None:
    """Logs that ``what`` listens on ``host``, reachable from other machines."""
    import logging

    if is_open(host):
        logging.getLogger("armando_drake").warning(
            "--host %s: %s is reachable from other machines", host, what
        )


def start_meshcat(host: str):
    """A Meshcat server listening on ``host``, checked (:func:`check_host`); its
    ``web_url()`` is the URL that works (:func:`server_url`), ``urls()`` the log's line."""
    import logging

    from pydrake.geometry import Meshcat, MeshcatParams

    host = check_host(host)

    class ServedMeshcat(Meshcat):
        def web_url(self) -> str:
            return server_url(host, self.port(), "")

        def urls(self) -> str:
            return server_urls(host, self.port(), "")

    warn_if_open(host, "Meshcat")
    # Drake logs "Meshcat listening for connections at URL"; the run prints the URL once.
    drake_logger = logging.getLogger("drake")
    level = drake_logger.level
    drake_logger.setLevel(logging.WARNING)
    try:
        meshcat = ServedMeshcat(MeshcatParams(host=host))
    finally:
        drake_logger.setLevel(level)
    meshcat.host = host
    return meshcat


def meshcat_urls(meshcat) -> str:
    """The log's line for ``meshcat``: :func:`start_meshcat`'s, or Drake's URL."""
    urls = getattr(meshcat, "urls", None)
    return urls() if urls is not None else meshcat.web_url()


def interactive() -> bool:
    """Whether a person is at the terminal: standard input and output are both terminals."""
    return sys.stdin.isatty() and sys.stdout.isatty()


WAIT_TIMEOUT = 60.0  # [s] how long a run on a terminal waits for a browser by default
WAIT_MAX = 3600.0  # [s] the longest --wait


def _wait(text: str) -> float:
    """``--wait``'s value: finite, 0 to :data:`WAIT_MAX` seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (math.isfinite(value) and 0 <= value <= WAIT_MAX):
        raise argparse.ArgumentTypeError(
            f"{text} must be a number of seconds from 0 to {WAIT_MAX:g}"
        )
    return value


def package_folder(text: str) -> str:
    """``--package-path``'s value: an existing folder."""
    path = os.path.expanduser(text)
    if not os.path.exists(path):
        raise argparse.ArgumentTypeError(f"{text}: no such folder")
    if not os.path.isdir(path):
        raise argparse.ArgumentTypeError(f"{text}: not a folder")
    return text


def add_viewer_arguments(parser) -> None:
    """``--wait SECONDS`` / ``--no-wait`` before the run and ``--exit-when-done`` /
    ``--keep-serving`` after it, for a run with Meshcat."""
    parser.add_argument(
        "--wait",
        type=_wait,
        metavar="SECONDS",
        help=f"with Meshcat, wait up to SECONDS (0 to {WAIT_MAX:g}) for a browser to open the "
        f"page before the clock starts (default: {WAIT_TIMEOUT:g} on a terminal, 0 otherwise)",
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
        if not (math.isfinite(args.wait) and 0 <= args.wait <= WAIT_MAX):
            raise UserError(f"--wait {args.wait} must be from 0 to {WAIT_MAX:g} [s]")
        return args.wait
    return WAIT_TIMEOUT if interactive() else 0.0


def keeps_serving(args) -> bool:
    """Whether Meshcat stays up after the run (``--keep-serving`` / ``--exit-when-done``)."""
    return interactive() if args.keep_serving is None else args.keep_serving


def add_description_arguments(parser, default: str) -> None:
    """``--description PATH``, repeatable ``--package-path DIR`` and ``--xacro-arg``."""
    parser.add_argument(
        "--description",
        metavar="PATH",
        help="robot description: .urdf/.xacro file, package directory, package://pkg/file, "
        f"or a Gazebo model (model.sdf, or its folder with model.config) (default: {default})",
    )
    parser.add_argument(
        "--package-path",
        action="append",
        type=package_folder,
        default=[],
        metavar="DIR",
        help="a folder to search for ROS packages before ROS_PACKAGE_PATH (repeatable)",
    )
    parser.add_argument(
        "--xacro-arg",
        action="append",
        default=[],
        metavar="NAME:=VALUE",
        help="a xacro:arg value, as on the xacro command line (repeatable)",
    )


# The longest message printed (a list of choices fits): a value the user gave may be
# megabytes long.
MAX_MESSAGE = 5000


def _one_line(text: str) -> str:
    line = " ".join(str(text).split())
    if len(line) <= MAX_MESSAGE:
        return line
    half = MAX_MESSAGE // 2
    return f"{line[:half]} ... ({len(line) - 2 * half} characters left out) ... {line[-half:]}"


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
    - Ctrl-C (SIGINT), SIGTERM or SIGHUP (a closed terminal), also one that breaks an
      import half way (``ImportError: initialization failed``): ``interrupted`` on
      stderr, exit 130;
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
            previous = {sig: signal.signal(sig, on_sigint) for sig in STOP_SIGNALS}
        yield
        # A library may catch the KeyboardInterrupt and go on (trimesh's imports catch
        # BaseException): the signal still stops the command.
        if interrupted:
            raise KeyboardInterrupt
    except KeyboardInterrupt as interrupt:
        _exit_interrupted(f"interrupted: {interrupt}" if str(interrupt) else "interrupted")
    except SystemExit:
        raise
    except Exception as error:
        if interrupted:  # Ctrl-C inside an extension's import surfaces as ImportError
            _exit_interrupted("interrupted")
        if isinstance(error, UserInputError):
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
        for sig, handler in (previous or {}).items():
            signal.signal(sig, handler)
