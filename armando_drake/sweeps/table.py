"""The results table of a sweep: one row per variant, as CSV and Parquet.

Columns, in this order:

- ``variant``: the variant's index in the sweep (0, 1, ...);
- one column per axis, named by its key path (``actuators.kp``), holding the
  variant's value (lists and mappings as their YAML text);
- ``status``: ``ok``, ``failed``, ``timeout`` or ``interrupted``; ``exit_code``: the world's exit
  code (2 for an input error, empty after a timeout); ``error``: the last line
  of its standard error when it failed, else empty; ``wall_time`` [s]: the
  process's wall time, start-up included; ``host``: the machine it ran on;
- the metrics of :func:`metrics`: ``max_error`` [rad] (largest final error of
  any step), ``final_error`` [rad] (of the last step), ``settle_time`` [s]
  (longest time to settle of any step; empty if some step never settled);
- with a navigation (the summary's ``navigation`` section), the metrics of
  :data:`NAVIGATION_METRICS` (:func:`navigation_metrics`): ``nav_reached``,
  ``nav_time``, ``nav_path_length``, ``nav_position_error``, ``nav_yaw_error``,
  ``nav_collisions``;
- ``summary.<path>``: every number of the run's ``summary.json``, flattened
  with dots (``summary.sim_time``, ``summary.steps.1.final_error``,
  ``summary.steps.1.reached.0``); booleans too, strings not.

A column that a variant lacks (a failed run has no summary) is empty (null).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from armando_drake.sweeps.variant import VariantResult

RESULT_COLUMNS = ("status", "exit_code", "error", "wall_time", "host")
METRICS = {
    "max_error": "largest final error of any step [rad]",
    "final_error": "final error of the last step [rad]",
    "settle_time": "longest time to settle within 0.01 rad of any step [s]",
}

NAVIGATION_METRICS = {
    "nav_reached": "goals reached",
    "nav_time": "total time of the reached goals, each from its start to its end [s]",
    "nav_path_length": "length driven over all goals [m]",
    "nav_position_error": "mean final position error over the goals [m]",
    "nav_yaw_error": "mean final yaw error over the goals [rad]",
    "nav_collisions": "episodes of contact between the robot and the world",
}


def flatten(value: Any, prefix: str) -> dict[str, Any]:
    """Every number (and boolean, and null) under ``value``, keyed by its dotted path."""
    if isinstance(value, Mapping):
        result = {}
        for key, item in value.items():
            result.update(flatten(item, f"{prefix}.{key}"))
        return result
    if isinstance(value, list | tuple):
        result = {}
        for i, item in enumerate(value):
            result.update(flatten(item, f"{prefix}.{i}"))
        return result
    if value is None or isinstance(value, bool | int | float):
        return {prefix: value}
    return {}


def metrics(summary: Mapping[str, Any] | None) -> dict[str, float | None]:
    """The metrics of :data:`METRICS` from a run's ``summary.json`` (None where undefined)."""
    steps = (summary or {}).get("steps") or []
    errors = [step.get("final_error") for step in steps]
    errors = [e for e in errors if e is not None]
    settles = [step.get("settling_time") for step in steps]
    return {
        "max_error": max(errors) if errors else None,
        "final_error": errors[-1] if errors else None,
        "settle_time": max(settles) if settles and None not in settles else None,
    }


def navigation_metrics(summary: Mapping[str, Any] | None) -> dict[str, float | None]:
    """The metrics of :data:`NAVIGATION_METRICS` from a run's summary ({} without navigation)."""
    navigation = (summary or {}).get("navigation")
    if not isinstance(navigation, Mapping):
        return {}
    goals = navigation.get("goals") or []

    def mean(key: str) -> float | None:
        values = [g[key] for g in goals if g.get(key) is not None]
        return sum(values) / len(values) if values else None

    times = [g["time"] for g in goals if g.get("reached") and g.get("time") is not None]
    return {
        "nav_reached": navigation.get("reached"),
        "nav_time": sum(times) if times else None,
        "nav_path_length": sum(g.get("path_length") or 0.0 for g in goals),
        "nav_position_error": mean("position_error"),
        "nav_yaw_error": mean("yaw_error"),
        "nav_collisions": navigation.get("collisions"),
    }


def row(values: Mapping[str, Any], result: VariantResult) -> dict[str, Any]:
    """One row of the table: the variant's values, its result, metrics and summary numbers."""
    record = {"variant": result.index}
    record.update(values)
    record.update(
        status=result.status,
        exit_code=result.exit_code,
        error=result.error,
        wall_time=result.wall_time,
        host=result.host,
    )
    record.update(metrics(result.summary))
    record.update(navigation_metrics(result.summary))
    if result.summary is not None:
        record.update(flatten(result.summary, "summary"))
    return record


def _text(value: Any) -> str:
    if isinstance(value, str):
        return value
    text = yaml.safe_dump(value, default_flow_style=True, width=math.inf).strip()
    return text[: -len("\n...")] if text.endswith("\n...") else text


def _column_type(values: Sequence[Any]) -> str:
    """bool | int | float | string for a column's values (None ignored)."""
    present = [v for v in values if v is not None]
    if not present:
        return "float"
    if all(isinstance(v, bool) for v in present):
        return "bool"
    if all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return "int"
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in present):
        return "float"
    return "string"


class ResultsTable:
    """Rows of dicts with a fixed column order and one type per column."""

    def __init__(self, rows: Iterable[Mapping[str, Any]]):
        self.rows = sorted((dict(r) for r in rows), key=lambda r: r["variant"])
        columns: dict[str, None] = {}
        for record in self.rows:
            columns.update(dict.fromkeys(record))
        self.columns = list(columns)
        self.types = {c: _column_type([r.get(c) for r in self.rows]) for c in self.columns}

    def column(self, name: str) -> list[Any]:
        """The column's values in the column's type (strings for mixed columns)."""
        if name not in self.types:
            raise KeyError(name)
        kind = self.types[name]
        values = [r.get(name) for r in self.rows]
        if kind == "float":
            return [None if v is None else float(v) for v in values]
        if kind == "string":
            return [None if v is None else _text(v) for v in values]
        return values

    def to_arrow(self):
        import pyarrow as pa

        types = {"bool": pa.bool_(), "int": pa.int64(), "float": pa.float64()}
        types["string"] = pa.string()
        return pa.table(
            {c: pa.array(self.column(c), type=types[self.types[c]]) for c in self.columns}
        )

    def write(self, folder: Path) -> tuple[Path, Path]:
        """Writes ``results.csv`` and ``results.parquet`` into ``folder``; returns their paths."""
        import pyarrow.parquet as pq

        folder.mkdir(parents=True, exist_ok=True)
        csv_path = folder / "results.csv"
        columns = {c: self.column(c) for c in self.columns}
        with open(csv_path, "w", newline="", encoding="utf-8") as file:
            writer = csv.writer(file)
            writer.writerow(self.columns)
            for i in range(len(self.rows)):
                writer.writerow(["" if columns[c][i] is None else columns[c][i] for c in columns])
        parquet_path = folder / "results.parquet"
        pq.write_table(self.to_arrow(), parquet_path)
        return csv_path, parquet_path


def read_table(path: str | Path):
    """A results table written by :meth:`ResultsTable.write`, as a ``pyarrow.Table``."""
    import pyarrow.parquet as pq

    path = Path(path)
    return pq.read_table(path / "results.parquet" if path.is_dir() else path)
