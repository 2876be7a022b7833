"""One variant of a sweep: a headless world run in a process of its own.

A variant is the command line

    python -m armando_drake.world --scenario S [--set BASE ...] --set OVERRIDE ...
        --no-meshcat --realtime-rate 0 --no-replay --output DIR --quiet [WORLD_ARGS ...]

and its result is what that process leaves: ``DIR/summary.json``, the exit
code and, when it fails, the last line of its standard error (the world's
input errors are one line, exit code 2). Each variant is a fresh process, so
variants run in parallel are as deterministic as single runs. The process's
standard output and error are kept in ``DIR/stdout.txt`` and ``DIR/stderr.txt``.

:func:`run_variant` is what an engine executes (a local pool worker or a Ray
task); it takes and returns plain data, so it pickles to any machine that has
the package installed.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import armando_drake
from armando_drake.sweeps.engines import waits_on_child_process

OK = "ok"  # exit code 0 and a summary.json
FAILED = "failed"  # any other exit, or no summary.json
TIMEOUT = "timeout"  # killed after the task's timeout
INTERRUPTED = "interrupted"  # stopped by a signal (Ctrl-C: exit code 130, or killed)


@dataclass
class VariantTask:
    """Everything a worker needs to run one variant."""

    index: int  # the variant's position in the sweep
    scenario: str  # --scenario: a name in diagrams/ or a path valid where the task runs
    overrides: list[str]  # the variant's --set strings, after the sweep's common ones
    output: str  # --output folder of the run
    common_overrides: list[str] = field(default_factory=list)  # the sweep's own --set
    world_args: list[str] = field(default_factory=list)  # more arguments for the world
    timeout: float | None = None  # [s] of wall time before the run is killed; None: no limit

    def command(self, python: str | None = None) -> list[str]:
        """The world's command line."""
        texts = [*self.common_overrides, *self.overrides]
        sets = [arg for text in texts for arg in ("--set", text)]
        return [
            python or sys.executable,
            "-m",
            "armando_drake.world",
            "--scenario",
            self.scenario,
            *sets,
            "--no-meshcat",
            "--realtime-rate",
            "0",
            "--no-replay",
            "--output",
            self.output,
            "--quiet",
            *self.world_args,
        ]


@dataclass
class VariantResult:
    """What one variant's run left."""

    index: int  # the variant's position in the sweep
    status: str  # OK, FAILED, TIMEOUT or INTERRUPTED
    exit_code: int | None  # the process's exit code (negative: killed by that signal)
    error: str  # the last non-empty line of stderr when the run failed, else ""
    wall_time: float  # [s] from process start to exit, start-up included
    summary: dict[str, Any] | None  # summary.json as written by the run, None without one
    host: str  # the machine it ran on
    command: list[str]  # the command line, for reproducing it by hand

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _environment() -> dict[str, str]:
    """This process's environment, with this package importable in the child."""

    root = str(Path(armando_drake.__file__).resolve().parents[1])
    environment = dict(os.environ)
    paths = environment.get("PYTHONPATH", "").split(os.pathsep)
    if root not in paths:
        environment["PYTHONPATH"] = os.pathsep.join([root, *[p for p in paths if p]])
    return environment


_running: set[subprocess.Popen] = set()  # world processes of this process's variants
_lock = threading.Lock()


def interrupt_running() -> None:
    """Sends SIGINT to every world run still going: each stops and writes its summary."""
    with _lock:
        processes = list(_running)
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)


@waits_on_child_process
def run_variant(task: VariantTask) -> VariantResult:
    """Runs one variant to its end and collects its result; never raises for a failed run."""
    output = Path(task.output)
    output.mkdir(parents=True, exist_ok=True)
    for stale in ("summary.json", "stdout.txt", "stderr.txt"):
        (output / stale).unlink(missing_ok=True)
    command = task.command()
    start = time.perf_counter()
    status = None
    try:
        process = subprocess.Popen(
            command,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            env=_environment(),
        )
    except OSError as error:
        raise RuntimeError(f"cannot start {command[0]}: {error}") from None
    with _lock:
        _running.add(process)
    try:
        stdout, stderr = process.communicate(timeout=task.timeout)
        exit_code = process.returncode
    except subprocess.TimeoutExpired:
        process.kill()
        stdout, stderr = process.communicate()
        status, exit_code = TIMEOUT, None
        stderr += f"\ntimeout: killed after {task.timeout:g} s"
    except BaseException:  # interrupted (a Ray task cancelled): let the run stop cleanly
        process.send_signal(signal.SIGINT)
        process.wait()
        raise
    finally:
        with _lock:
            _running.discard(process)
    wall_time = time.perf_counter() - start
    (output / "stdout.txt").write_text(stdout)
    (output / "stderr.txt").write_text(stderr)
    summary = None
    summary_path = output / "summary.json"
    if summary_path.is_file():
        try:
            summary = json.loads(summary_path.read_text())
        except (OSError, ValueError):
            summary = None
    if status is None and (exit_code == 130 or exit_code < 0):
        status = INTERRUPTED
    if status is None:
        status = OK if exit_code == 0 and summary is not None else FAILED
    error = ""
    if status != OK:
        lines = [line.strip() for line in stderr.splitlines() if line.strip()]
        error = lines[-1] if lines else f"exit code {exit_code}, nothing on stderr"
        if exit_code == 0 and summary is None:
            error = f"exit code 0 but no summary.json in {output}"
    return VariantResult(
        index=task.index,
        status=status,
        exit_code=exit_code,
        error=error,
        wall_time=wall_time,
        summary=summary,
        host=socket.gethostname(),
        command=command,
    )


run_variant.on_interrupt = interrupt_running
