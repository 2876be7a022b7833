"""The sweep's main figure: one metric over one or two axes.

- two axes whose values form a grid (at least half of the value pairs ran): a
  heat map, one cell per pair of values, the metric written in each cell (the
  median where other axes vary too);
  a cell whose runs all failed says so, a cell without the metric (a step that
  never settled) is grey;
- two axes of random values: a scatter plot coloured by the metric;
- one axis of numbers: the metric against the axis values, as a line (points only
  for random values; the median where other axes vary too);
- one axis of names (a categorical axis: planners, controllers, files): one bar per
  value, its height the metric, written on it.

Drawn with Matplotlib's object API (no pyplot, no display needed).
"""

from __future__ import annotations

import math
import statistics
import textwrap
from collections.abc import Sequence
from pathlib import Path

from armando_drake.sweeps.errors import SweepError
from armando_drake.sweeps.table import METRICS, NAVIGATION_METRICS, ResultsTable

FIGURE_SIZE = (8.0, 6.0)  # [inch]
DPI = 100  # [pixel/inch]
LONG_LABEL = 30  # [characters] longer axis values are numbered on the axis, listed below
MAX_GRID_VALUES = 40  # more distinct values on an axis than this: drawn as random samples


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _ordered(values: Sequence) -> list:
    """Distinct values, sorted when they are all numbers, else in order of appearance."""
    distinct = list(dict.fromkeys(values))
    return sorted(distinct) if all(_is_number(v) for v in distinct) else distinct


def _label(value) -> str:
    return f"{value:g}" if _is_number(value) else str(value)


def _finite(value) -> bool:
    return value is not None and math.isfinite(value)


def _metric_label(metric: str) -> str:
    described = {**METRICS, **NAVIGATION_METRICS}
    return f"{metric}: {described[metric]}" if metric in described else metric


def _cells(table: ResultsTable, axes: Sequence[str], metric: str):
    """{axis values: (median of the finite metric values or None, runs, failed runs)}."""
    keys = list(zip(*(table.column(a) for a in axes), strict=True))
    values = table.column(metric)
    statuses = table.column("status")
    groups: dict[tuple, list] = {}
    for key, value, status in zip(keys, values, statuses, strict=True):
        groups.setdefault(key, []).append((value, status))
    cells = {}
    for key, members in groups.items():
        finite = [v for v, s in members if s == "ok" and _finite(v)]
        failed = sum(s != "ok" for _, s in members)
        cells[key] = (statistics.median(finite) if finite else None, len(members), failed)
    return cells


def plot_sweep(
    table: ResultsTable, axes: Sequence[str], metric: str, path: str | Path, title: str = ""
) -> Path:
    """Draws ``metric`` over ``axes`` (one or two column names) into ``path`` (PNG)."""
    figure = draw_sweep(table, axes, metric, title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path)
    return path


def draw_sweep(table: ResultsTable, axes: Sequence[str], metric: str, title: str = ""):
    """The figure of :func:`plot_sweep` (a Matplotlib ``Figure``, one Axes)."""
    from matplotlib.figure import Figure

    numbers = [c for c, t in table.types.items() if t in ("int", "float") and c != "variant"]
    if metric not in table.types or table.types[metric] not in ("int", "float"):
        raise SweepError(
            f"--metric {metric!r} is not a number column of the table; choose from "
            + ", ".join(numbers)
        )
    for axis in axes:
        if axis not in table.types:
            raise SweepError(f"--plot-axes: {axis!r} is not a column of the table")
    if not table.rows:
        raise SweepError("the table has no rows to draw")
    cells = _cells(table, axes, metric)
    others = len(table.rows) > len(cells)
    figure = Figure(figsize=FIGURE_SIZE, dpi=DPI, layout="constrained")
    ax = figure.add_subplot()
    levels = [_ordered([key[i] for key in cells]) for i in range(len(axes))]
    failed = sum(f for _, _, f in cells.values())
    grid = len(axes) == 2 and len(cells) >= 0.5 * len(levels[0]) * len(levels[1])
    if grid and max(len(v) for v in levels) <= MAX_GRID_VALUES:
        _heat_map(figure, ax, cells, levels, metric)
    elif len(axes) == 2:
        _scatter(figure, ax, cells, metric)
    else:
        _line(ax, cells, levels[0], metric)
    if not ax.get_xlabel():
        ax.set_xlabel(axes[0])
    if len(axes) == 2:
        ax.set_ylabel(axes[1])
    else:
        ax.set_ylabel(_metric_label(metric))
    notes = [f"{len(table.rows)} runs"]
    if failed:
        notes.append(f"{failed} failed")
    if others:
        notes.append("median over the other axes")
    ax.set_title(title or f"{_metric_label(metric)}\n({', '.join(notes)})", fontsize=10)
    return figure


def _heat_map(figure, ax, cells, levels, metric) -> None:
    import numpy as np
    from matplotlib import colormaps

    xs, ys = levels
    grid = np.full((len(ys), len(xs)), np.nan)
    for (x, y), (value, _, _) in cells.items():
        if value is not None:
            grid[ys.index(y), xs.index(x)] = value
    cmap = colormaps["viridis"].with_extremes(bad="lightgrey")
    image = ax.imshow(np.ma.masked_invalid(grid), origin="lower", cmap=cmap, aspect="auto")
    figure.colorbar(image, ax=ax, label=metric)
    ax.set_xticks(range(len(xs)), [_label(x) for x in xs])
    ax.set_yticks(range(len(ys)), [_label(y) for y in ys])
    if len(xs) * len(ys) <= 150:
        finite = grid[np.isfinite(grid)]
        middle = (finite.min() + finite.max()) / 2 if finite.size else 0.0
        for (x, y), (value, runs, failed) in cells.items():
            if value is not None:
                text = f"{value:.3g}"
            else:
                text = "failed" if failed == runs else "n/a"
            dark = value is not None and value < middle
            ax.text(
                xs.index(x),
                ys.index(y),
                text,
                ha="center",
                va="center",
                fontsize=10,
                color="white" if dark else "black",
            )


def _scatter(figure, ax, cells, metric) -> None:
    points = [(x, y, v) for (x, y), (v, _, _) in cells.items() if v is not None]
    missing = [(x, y) for (x, y), (v, _, _) in cells.items() if v is None]
    if points:
        x, y, v = zip(*points, strict=True)
        image = ax.scatter(x, y, c=v, cmap="viridis", s=30)
        figure.colorbar(image, ax=ax, label=metric)
    if missing:
        x, y = zip(*missing, strict=True)
        ax.scatter(x, y, marker="x", color="red", label="failed or n/a")
        ax.legend(loc="best", fontsize=8)


def _line(ax, cells, xs, metric) -> None:
    points = [(x, cells[(x,)][0]) for x in xs]
    numeric = all(_is_number(x) for x in xs)
    positions = xs if numeric else list(range(len(xs)))
    values = [float("nan") if v is None else v for _, v in points]
    if numeric:
        style = "o-" if len(xs) <= MAX_GRID_VALUES else "o"
        ax.plot(positions, values, style, markersize=4)
    else:  # names have no order between them: bars, not a line through them
        drawn = [(p, v) for p, v in zip(positions, values, strict=True) if math.isfinite(v)]
        if drawn:
            bars = ax.bar(*zip(*drawn, strict=True), color="tab:blue", width=0.6)
            ax.bar_label(bars, fmt="%.3g", fontsize=8)
    bad = [p for p, (_, v) in zip(positions, points, strict=True) if v is None]
    if bad:  # at the bottom edge of the axes
        from matplotlib.transforms import blended_transform_factory

        edge = blended_transform_factory(ax.transData, ax.transAxes)
        ax.plot(bad, [0.02] * len(bad), "x", color="red", transform=edge, label="failed or n/a")
        ax.legend(loc="best", fontsize=8)
    if not numeric:
        labels = [_label(x) for x in xs]
        if max(len(label) for label in labels) > LONG_LABEL:  # numbered, listed below
            notes = [f"[{k}] {label}" for k, label in enumerate(labels)]
            text = "\n".join(textwrap.fill(note, 120, subsequent_indent="    ") for note in notes)
            ax.set_xlabel(text, fontsize=7, loc="left")
            labels = [f"[{k}]" for k in range(len(labels))]
        ax.set_xticks(positions, labels)
    ax.grid(True, alpha=0.3)
