"""Joint state logging: the subscriber half of the course's arm controller node.

:class:`JointStateLogger` records the joint states the broadcaster publishes,
one CSV row per broadcaster tick, and prints the joint positions to the
console once a second, like the ROS 2 node that subscribes to
``joint_states`` and logs ``Joint j0: 0.123`` lines.

CSV layout (``joint_states.csv``)::

    time,j0_position,j0_velocity,j0_effort,j1_position,j1_velocity,j1_effort,...

- ``time`` [s] is the simulation time of the sample, printed with 6 decimals;
- then, per joint in ``joint_names`` order, position [rad or m], velocity
  [rad/s or m/s] and effort [N m or N]; a quantity the input does not carry
  is written as ``nan``.

The logger is Drake's ``VectorLogSink`` (C++) with two Python events added:
the sink records its input at ``update_rate`` at no Python cost, and a
periodic flush at ``flush_rate`` (1 Hz by default) appends the rows
recorded since the last flush to the file in one write, then clears the log,
so memory stays bounded however long the run; a simulation slower than real time
flushes also once :data:`FLUSH_WALL` seconds of wall time have passed since the last
flush (checked ten times a simulated second). A run stopped with Ctrl-C
ends with :meth:`JointStateLogger.flush`, which writes the rest; a process
killed outright keeps every row up to its last flush (at most
``1 / flush_rate`` of simulated time, and about a second of wall time, is lost),
and every line on disk is complete.

Listeners added with :meth:`JointStateLogger.add_listener` receive the same
rows (time and positions) at each flush, in memory: the run's step table is
computed that way, with or without a CSV file.

Reading: :func:`read_csv` is the project's one CSV reader (``joint_states.csv``,
``commands.csv``); :func:`read_joint_states` gives a joint-state CSV by
quantity and joint.
"""

from __future__ import annotations

import csv
import math
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from time import monotonic
from typing import Any, BinaryIO, TextIO

import numpy as np
from pydrake.systems.framework import Context, LeafSystem
from pydrake.systems.primitives import VectorLogSink

from armando_drake.control.manager import AddJointStateVector
from armando_drake.control.stack import ControlStack
from armando_drake.outputs.config import LoggingConfig
from armando_drake.tools.files import OutputFile

FLUSH_WALL = 0.5  # [s] of wall time: the longest rows wait for a flush (besides flush_rate)


def csv_header(joint_names: list[str] | tuple[str, ...]) -> str:
    """The header line (without newline) of a joint state CSV for ``joint_names``."""
    columns = ["time"]
    for name in joint_names:
        columns += [f"{name}_position", f"{name}_velocity", f"{name}_effort"]
    return ",".join(columns)


def _rate(name: str, value: float) -> float:
    if isinstance(value, bool) or not (
        isinstance(value, (int, float)) and math.isfinite(value) and value > 0
    ):
        raise ValueError(f"{name}={value!r} must be positive [Hz]")
    return float(value)


def rounded(value: float, digits: int = 3) -> float:
    """``value`` rounded to ``digits`` decimals, a negative zero made 0 (printed as
    ``0.000``, not ``-0.000``)."""
    return round(float(value), digits) + 0.0


class JointStateLogger(VectorLogSink):
    """Records joint states at ``update_rate``, writes them to CSV, prints positions.

    .. pydrake_system::

        name: JointStateLogger
        input_ports:
        - data

    The input is a vector of size ``input_size`` (default ``3 n`` for ``n``
    joints) that holds each joint's position at ``position_index``, velocity
    at ``velocity_index`` and effort at ``effort_index`` (defaults: [q; v;
    effort] in ``joint_names`` order); ``effort_index=()`` logs no effort
    (``nan``). In a world it is the plant's state and net actuation of the
    robot, as the joint state broadcaster publishes them.

    A sample is recorded at every tick of ``update_rate`` [Hz] from t = 0, at
    the end of the plant step that reaches the tick, so a run of duration D
    at rate R writes the rows 0, 1/R, ..., D (D R + 1 rows).

    Every ``1 / console_rate`` seconds (from t = 0) it prints::

        [t=1.000 s] Joint positions:
        Joint j0: 0.123
        Joint j1: -0.456

    to ``stream`` (``sys.stdout`` at the time of printing when None), unless
    ``quiet``.

    Call :meth:`flush` with the logger's context when a run ends early (the
    world's ``close(context)`` does), and :meth:`close` when it is done;
    closing twice is harmless.
    """

    def __init__(
        self,
        *,
        joint_names: Sequence[str],
        update_rate: float,
        position_index: Sequence[int] | None = None,
        velocity_index: Sequence[int] | None = None,
        effort_index: Sequence[int] | None = None,
        input_size: int | None = None,
        console_rate: float = 1.0,
        flush_rate: float = 1.0,
        csv_path: str | Path | None = None,
        stream: TextIO | None = None,
        quiet: bool = False,
    ):
        joint_names = tuple(joint_names)
        n = len(joint_names)
        if not joint_names:
            raise ValueError("joint_names=() must name at least one joint")
        if len(set(joint_names)) != n:
            raise ValueError(f"joint_names={list(joint_names)!r} has duplicates")
        update_rate = _rate("update_rate", update_rate)
        console_rate = _rate("console_rate", console_rate)
        flush_rate = _rate("flush_rate", flush_rate)
        input_size = 3 * n if input_size is None else int(input_size)
        columns = {
            "position_index": range(0, n) if position_index is None else position_index,
            "velocity_index": range(n, 2 * n) if velocity_index is None else velocity_index,
            "effort_index": range(2 * n, 3 * n) if effort_index is None else effort_index,
        }
        for name, index in columns.items():
            index = list(index)
            if name == "effort_index" and not index:
                continue
            if len(index) != n or not all(0 <= i < input_size for i in index):
                raise ValueError(
                    f"{name}={index!r} must give one row in [0, {input_size}) per joint "
                    f"of {list(joint_names)!r}"
                )
        super().__init__(input_size, 1.0 / update_rate)
        self._joint_names = joint_names
        self._stream = stream
        self._quiet = quiet
        # Row layout: per joint position, velocity, effort; input_size means "nan".
        self._columns = np.array(
            [
                list(columns["position_index"]),
                list(columns["velocity_index"]),
                list(columns["effort_index"]) or [input_size] * n,
            ],
            dtype=int,
        ).T.ravel()
        self._input_size = input_size
        self._nan_effort = not list(columns["effort_index"])
        self._positions = np.array(list(columns["position_index"]), dtype=int)
        self._rows_written = 0
        self._last_time = -math.inf  # [s] time of the last row written
        self._last_row: np.ndarray | None = None
        self._closed = False
        self._listeners: list[Callable[[np.ndarray, np.ndarray], None]] = []
        # One CSV line: time with 6 decimals, then 10 significant digits per value.
        self._line_format = "%.6f" + ",%.10g" * (3 * n) + "\n"

        self._csv_path = None if csv_path is None else Path(csv_path)
        self._file: BinaryIO | None = None
        if self._csv_path is not None:
            self._csv_path.parent.mkdir(parents=True, exist_ok=True)
            # Unbuffered: each flush is one write() of complete lines.
            self._file = OutputFile(self._csv_path, "wb", buffering=0)
            self._file.write((csv_header(joint_names) + "\n").encode())

        # The sink records at update_rate (declared first, so at a common time the
        # sample is recorded before it is flushed or printed).
        LeafSystem.DeclarePeriodicPublishEvent(self, 1.0 / flush_rate, 0.0, self.flush)
        # The wall clock's check, at a multiple of the sample period (no new event times).
        check = max(1, round(0.1 * update_rate)) / update_rate
        self._flushed_at = monotonic()  # [s] wall time of the last flush
        LeafSystem.DeclarePeriodicPublishEvent(self, check, 0.0, self._FlushIfDue)
        LeafSystem.DeclarePeriodicPublishEvent(self, 1.0 / console_rate, 0.0, self._Print)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._joint_names

    @property
    def csv_path(self) -> Path | None:
        return self._csv_path

    @property
    def rows_written(self) -> int:
        """Number of data rows flushed (or, without a CSV file, that would have been)."""
        return self._rows_written

    @property
    def last_row(self) -> np.ndarray | None:
        """The latest row flushed: [time, then position, velocity, effort per joint]."""
        return None if self._last_row is None else self._last_row.copy()

    def add_listener(self, listener: Callable[[np.ndarray, np.ndarray], None]) -> None:
        """Calls ``listener(times, positions)`` at each flush with the rows it writes:
        ``times`` [s] (m,), ``positions`` [rad or m] (m, n) in ``joint_names`` order.
        Every row reaches the listeners once, in time order, CSV file or not."""
        self._listeners.append(listener)

    def flush(self, context: Context) -> None:
        """Writes the rows recorded since the last flush and clears them from the log.

        ``context`` is the logger's own (``GetMyContextFromRoot``).
        """
        self._flushed_at = monotonic()
        log = self.GetMutableLog(context)
        if log.num_samples() == 0:
            return
        if self._closed:
            raise RuntimeError(
                f"JointStateLogger for {self._csv_path} was closed before the run ended"
            )
        times = log.sample_times().tolist()
        block = log.data()[self._columns[self._columns < self._input_size]].T.tolist()
        # Rows a flush interrupted (Ctrl-C) before Clear() were written already.
        first = next((i for i, t in enumerate(times) if t > self._last_time), len(times))
        if first < len(times):
            if self._nan_effort:
                n = len(self._joint_names)
                block = [
                    [x for j in range(n) for x in (row[2 * j], row[2 * j + 1], math.nan)]
                    for row in block
                ]
            format_ = self._line_format
            text = "".join(
                [format_ % (t, *row) for t, row in zip(times[first:], block[first:], strict=True)]
            )
            if self._file is not None:
                data = memoryview(text.encode())
                while data:  # an unbuffered write may take part of it
                    data = data[self._file.write(data) :]
            if self._listeners:
                times_array = log.sample_times()[first:]
                positions = log.data()[self._positions][:, first:].T
                for listener in self._listeners:
                    listener(times_array, positions)
            self._rows_written += len(times) - first
            self._last_time = times[-1]
            self._last_row = np.array([times[-1], *block[-1]])
        log.Clear()

    def _FlushIfDue(self, context: Context) -> None:
        """:meth:`flush` when :data:`FLUSH_WALL` seconds of wall time have passed since
        the last one (a simulation slower than real time)."""
        if monotonic() - self._flushed_at >= FLUSH_WALL:
            self.flush(context)

    def close(self) -> None:
        """Closes the CSV file. Safe to call more than once."""
        self._closed = True
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> JointStateLogger:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def _Print(self, context: Context) -> None:
        if self._quiet:
            return
        positions = self.get_input_port().Eval(context)[self._positions]
        lines = [f"[t={context.get_time():.3f} s] Joint positions:"]
        lines += [
            f"Joint {name}: {rounded(position):.3f}"
            for name, position in zip(self._joint_names, positions, strict=True)
        ]
        stream = sys.stdout if self._stream is None else self._stream
        stream.write("\n".join(lines) + "\n")
        stream.flush()


def read_csv(path: str | Path) -> tuple[list[str], np.ndarray]:
    """(header, rows as floats, one array row per line) of a CSV file the project
    writes; a last line cut short by a kill is skipped. Read by numpy's C parser (an
    hour at 100 Hz is 360 000 rows: as Python floats they would take hundreds of MB)."""
    max_rows = None  # all of them, unless the last line is cut short (no newline)
    with open(path, "rb") as raw:
        size = raw.seek(0, os.SEEK_END)
        if size:
            raw.seek(size - 1)
            if raw.read(1) != b"\n":
                raw.seek(0)
                lines = sum(chunk.count(b"\n") for chunk in iter(lambda: raw.read(1 << 20), b""))
                max_rows = max(lines - 1, 0)  # the complete lines after the header
    with open(path, newline="", encoding="utf-8") as file:
        header = next(csv.reader(file), None)
        if header is None:
            return [], np.zeros((0, 0))
        if max_rows == 0:
            return header, np.zeros((0, len(header)))
        try:
            with warnings.catch_warnings():  # a header alone is no rows, not a warning
                warnings.simplefilter("ignore", UserWarning)
                rows = np.loadtxt(file, delimiter=",", ndmin=2, dtype=float, max_rows=max_rows)
        except ValueError:  # a line cut short (or another layout): line by line below
            rows = None
    if rows is not None:
        return header, rows if rows.size else np.zeros((0, len(header)))
    with open(path, newline="", encoding="utf-8") as file:
        text = file.read()
    if not text.endswith("\n"):  # cut short by a kill, possibly within a number
        text = text[: text.rfind("\n") + 1]
    lines = list(csv.reader(text.splitlines()))
    if not lines:
        return [], np.zeros((0, 0))
    header = lines[0]
    data = [[float(v) for v in line] for line in lines[1:] if len(line) == len(header)]
    return header, np.array(data) if data else np.zeros((0, len(header)))


@dataclass
class JointStates:
    """A joint_states.csv by quantity: one row per sample, one column per joint."""

    joint_names: list[str]
    times: np.ndarray  # [s] (m,)
    position: np.ndarray  # [rad or m] (m, n)
    velocity: np.ndarray  # [rad/s or m/s] (m, n)
    effort: np.ndarray  # [N m or N] (m, n), nan where not logged


def read_joint_states(path: str | Path, joint_names: Sequence[str] | None = None) -> JointStates:
    """The joint states of a joint_states.csv (see the module's docstring for the
    layout), for ``joint_names`` (default: every joint of the file, in its order).
    A joint the file does not hold is a ValueError naming it and the file."""
    header, rows = read_csv(path)
    in_file = [name[: -len("_position")] for name in header if name.endswith("_position")]
    names = in_file if joint_names is None else list(joint_names)
    missing = [name for name in names if name not in in_file]
    if missing:
        raise ValueError(f"{path}: no columns for joints {missing} (joints: {in_file})")

    def columns(quantity: str) -> np.ndarray:
        return rows[:, [header.index(f"{name}_{quantity}") for name in names]].reshape(
            len(rows), len(names)
        )

    return JointStates(
        joint_names=names,
        times=rows[:, 0] if len(rows) else np.zeros(0),
        position=columns("position"),
        velocity=columns("velocity"),
        effort=columns("effort"),
    )


class CommandsCsv:
    """Streams every published command to ``commands.csv`` (time, one column per joint).

    A JointTrajectory is written as one row per point, at the time the point
    is due (publication time + time_from_start).
    """

    def __init__(self, path: Path, joint_names: list[str]):
        self._joint_names = list(joint_names)
        self._file: TextIO | None = OutputFile(  # type: ignore[assignment]
            path, "w", buffering=1, newline="", encoding="utf-8"
        )
        self._writer = csv.writer(self._file)
        self._writer.writerow(["time", *self._joint_names])

    def __call__(self, time_s: float, topic: str, message: Any) -> None:
        if self._file is None:
            return
        if topic == "joint_trajectory":
            order = [list(message.joint_names).index(name) for name in self._joint_names]
            start = message.stamp if message.stamp > 0 else time_s
            for point in message.points:
                values = [point.positions[i] for i in order]
                self._row(start + point.time_from_start, values)
        else:
            self._row(time_s, message.data)

    def _row(self, time_s: float, values) -> None:
        self._writer.writerow([f"{time_s:.6f}", *(f"{v:.10g}" for v in values)])

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def AddJointStateLogger(
    builder,
    config: LoggingConfig,
    stack: ControlStack,
    *,
    output_dir: str | os.PathLike | None = None,
    quiet: bool = False,
) -> JointStateLogger | None:
    """The joint state logger on what the broadcaster of ``stack`` publishes: its C++
    vector view ([q; v; effort] of its joints), sampled at the controllers' rate (ROS
    1's joint_state_controller: at its own publish_rate); ``joint_states.csv`` in
    ``output_dir``; printed at ``config.console_rate`` [Hz] (0: never). None without a
    broadcaster."""
    console_rate = config.console_rate
    if stack.broadcaster is None:
        return None
    joints = stack.controller_joints[stack.broadcaster_name]
    view = AddJointStateVector(
        builder,
        stack.plant,
        stack.hardware,
        stack.robot.model_instance,
        joints,
        effort=stack.effort_state,
    )
    csv_path = None if output_dir is None else Path(output_dir) / "joint_states.csv"
    broadcaster = stack.manager.broadcaster
    rate = broadcaster.publish_rate(broadcaster.params) or stack.update_rate
    logger = builder.AddSystem(
        JointStateLogger(
            joint_names=joints,
            update_rate=rate,
            console_rate=console_rate if console_rate > 0 else 1.0,
            csv_path=csv_path,
            quiet=quiet or console_rate <= 0,
        )
    )
    logger.set_name("joint_state_logger")
    builder.Connect(view, logger.get_input_port())
    return logger
