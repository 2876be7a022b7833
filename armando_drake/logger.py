"""Joint state logging: the subscriber half of the course's arm controller node.

:class:`JointStateLogger` reads the joint state broadcaster's ``joint_states``
topic, appends one CSV row per broadcaster sample and prints the joint
positions to the console once a second, like the ROS 2 node that subscribes to
``joint_states`` and logs ``Joint j0: 0.123`` lines.

CSV layout (``joint_states.csv``)::

    time,j0_position,j0_velocity,j0_effort,j1_position,j1_velocity,j1_effort,...

- ``time`` [s] is the sample's header stamp (the simulation time at which the
  broadcaster sampled the joints), printed with 6 decimals;
- then, per joint in ``joint_names`` order, position [rad or m], velocity
  [rad/s or m/s] and effort [N m or N]; a field the message leaves empty is
  written as ``nan``.

One row per broadcaster sample (per controller tick when ``update_rate`` equals
the controller rate): a sample whose stamp equals the previous row's is not
written again. Rows are flushed as they are written, so a run stopped with
Ctrl-C or killed keeps every complete row up to that moment, and memory stays
bounded however long the run.
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path
from typing import Any, TextIO

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem

from armando_drake.messages import JointState


def csv_header(joint_names: list[str] | tuple[str, ...]) -> str:
    """The header line (without newline) of a joint state CSV for ``joint_names``."""
    columns = ["time"]
    for name in joint_names:
        columns += [f"{name}_position", f"{name}_velocity", f"{name}_effort"]
    return ",".join(columns)


class JointStateLogger(LeafSystem):
    """Writes ``joint_states`` samples to a CSV file and prints positions.

    .. pydrake_system::

        name: JointStateLogger
        input_ports:
        - joint_states

    ``joint_states`` is an abstract-valued port holding a
    :class:`~armando_drake.messages.JointState`. A sample with no joint names
    (nothing broadcast yet) is ignored.

    A periodic publish event at ``update_rate`` [Hz], starting at t = 0,
    writes the latest sample when its stamp is new. Drake runs the publish
    events of time t at the end of the step that reaches t, before the
    discrete updates of time t, so a broadcaster whose output is discrete
    state refreshed at the same rate is seen one tick late: a run of duration
    D at rate R then logs the samples stamped 0, 1/R, ..., D - 1/R (D*R rows);
    a source whose output is computed from the current context is logged at
    0, 1/R, ..., D (D*R + 1 rows). Either way each row carries the time at
    which its sample was taken.

    A second publish event at ``console_rate`` [Hz] prints::

        [t=1.000 s] Joint positions:
        Joint j0: 0.123
        Joint j1: -0.456

    to ``stream`` (``sys.stdout`` at the time of printing when None), unless
    ``quiet``. The time in brackets is the simulation time of the print.

    Call :meth:`close` (or use the logger as a context manager) when the run
    ends; closing twice is harmless.
    """

    def __init__(
        self,
        *,
        joint_names: list[str] | tuple[str, ...],
        update_rate: float,
        console_rate: float = 1.0,
        csv_path: str | Path | None = None,
        stream: TextIO | None = None,
        quiet: bool = False,
    ):
        super().__init__()
        joint_names = tuple(joint_names)
        if not joint_names:
            raise ValueError("joint_names=() must name at least one joint")
        if len(set(joint_names)) != len(joint_names):
            raise ValueError(f"joint_names={list(joint_names)!r} has duplicates")
        if not (update_rate > 0 and math.isfinite(update_rate)):
            raise ValueError(f"update_rate={update_rate!r} must be positive [Hz]")
        if not (console_rate > 0 and math.isfinite(console_rate)):
            raise ValueError(f"console_rate={console_rate!r} must be positive [Hz]")
        self._joint_names = joint_names
        self._stream = stream
        self._quiet = quiet
        # What the run has logged so far (bounded: counters and the latest row).
        self._rows_written = 0
        self._last_stamp: float | None = None
        self._last_sample: JointState | None = None
        self._closed = False
        # The joint order of the latest sample's names (a broadcaster sends the same names).
        self._order_names: tuple[str, ...] | None = None
        self._order: list[int] = []
        # One CSV line: time with 6 decimals, then 10 significant digits per value.
        self._line_format = "%.6f" + ",%.10g" * (3 * len(joint_names)) + "\n"

        self._csv_path = None if csv_path is None else Path(csv_path)
        self._file: TextIO | None = None
        if self._csv_path is not None:
            self._csv_path.parent.mkdir(parents=True, exist_ok=True)
            # Line-buffered: every complete row reaches the OS as soon as it is written.
            self._file = open(self._csv_path, "w", buffering=1, newline="", encoding="utf-8")
            self._file.write(csv_header(joint_names) + "\n")

        self._joint_states = self.DeclareAbstractInputPort(
            "joint_states", AbstractValue.Make(JointState())
        )
        self.DeclarePeriodicPublishEvent(1.0 / update_rate, 0.0, self._PublishRow)
        self.DeclarePeriodicPublishEvent(1.0 / console_rate, 0.0, self._PublishConsole)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._joint_names

    @property
    def csv_path(self) -> Path | None:
        return self._csv_path

    @property
    def rows_written(self) -> int:
        """Number of data rows written (or, without a CSV file, that would have been)."""
        return self._rows_written

    @property
    def last_sample(self) -> JointState | None:
        """The latest sample logged, None before the first."""
        return self._last_sample

    def close(self) -> None:
        """Flush and close the CSV file. Safe to call more than once."""
        self._closed = True
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> JointStateLogger:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def _Sample(self, context: Context) -> JointState | None:
        sample = self._joint_states.Eval(context)
        return sample if sample.name else None

    def _Order(self, names: tuple[str, ...], stamp: float) -> list[int]:
        """Index in ``names`` of each of our joints; remembered for the latest ``names``."""
        if names is self._order_names or names == self._order_names:
            return self._order
        index = {name: i for i, name in enumerate(names)}
        missing = [name for name in self._joint_names if name not in index]
        if missing:
            raise ValueError(
                f"joint_states sample at t={stamp!r} has no joint {missing[0]!r} "
                f"(it names {list(names)!r})"
            )
        self._order_names = names
        self._order = [index[name] for name in self._joint_names]
        return self._order

    def _Row(self, sample: JointState) -> list[float]:
        """[position, velocity, effort] per joint of ours, in our order."""
        order = self._Order(sample.name, sample.stamp)
        fields = (sample.position, sample.velocity, sample.effort)
        if all(len(field) == len(sample.name) for field in fields):
            return [float(field[i]) for i in order for field in fields]
        return [float(field[i]) if i < len(field) else math.nan for i in order for field in fields]

    def _PublishRow(self, context: Context) -> None:
        sample = self._Sample(context)
        if sample is None or sample.stamp == self._last_stamp:
            return
        row = self._Row(sample)
        if self._closed:
            raise RuntimeError(
                f"JointStateLogger for {self._csv_path} was closed before the run ended"
            )
        if self._file is not None:
            self._file.write(self._line_format % (sample.stamp, *row))
        self._rows_written += 1
        self._last_stamp = sample.stamp
        self._last_sample = sample

    def _PublishConsole(self, context: Context) -> None:
        if self._quiet:
            return
        sample = self._Sample(context)
        if sample is None:
            return
        positions = self._Row(sample)[0::3]
        lines = [f"[t={context.get_time():.3f} s] Joint positions:"]
        lines += [
            f"Joint {name}: {position:.3f}"
            for name, position in zip(self._joint_names, positions, strict=True)
        ]
        stream = sys.stdout if self._stream is None else self._stream
        stream.write("\n".join(lines) + "\n")
        stream.flush()


class CommandsCsv:
    """Streams every published command to ``commands.csv`` (time, one column per joint).

    A JointTrajectory is written as one row per point, at the time the point
    is due (publication time + time_from_start).
    """

    def __init__(self, path: Path, joint_names: list[str]):
        self._joint_names = list(joint_names)
        self._file: TextIO | None = open(path, "w", buffering=1, newline="", encoding="utf-8")
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
