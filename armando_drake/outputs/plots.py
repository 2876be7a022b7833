"""Plots of a run: the seed's joint position and torque plots, from the run's logs.

:func:`write_plots` reads ``joint_states.csv``, ``commands.csv`` and
``summary.json`` of an output folder and writes, next to them, one PNG per
quantity with one panel per joint:

Each figure is titled once: the quantity with its unit, then the run (:func:`plot_title`).

- ``positions.png``: measured joint positions [rad] with the commanded
  positions drawn as steps;
- ``tracking_error.png``: |q - commanded| [rad] per joint, where "commanded"
  is the latest row of ``commands.csv`` at or before each sample (nothing
  before the first command); for a trajectory run (``commands.csv`` then
  holds each point at the time it is due) it is the point the trajectory is
  heading to, the same reference as the step table's, so the error shrinks
  to the step table's error as each point comes due;
- ``efforts.png``: joint efforts [N m] (the effort columns).

Only the plots that apply to what ran are written: ``tracking_error.png`` when a joint
was commanded (``commands.csv``); ``positions.png`` when a joint was commanded, or moved
on a robot without a mobile base (whose wheels' angles say less than ``base_path.png``);
``efforts.png`` when an effort was logged other than zero.

A task-space run (``task_space.csv``, see :mod:`armando_drake.outputs.task_space`)
also gets ``task_error.png`` (position [mm] and orientation [rad] error norms of
the end effector against time, as the seed's figures), ``joint_torques.png``
(the commanded torque of every joint [N m], one axis) and ``task_path.png``
(desired and actual end-effector path in three projections: x-y, x-z, y-z [m]).

A run longer than a few thousand samples is drawn through the envelope of its samples
(:func:`envelope`: each line's smallest and largest value per pixel-wide bucket), so an
hour-long run plots in seconds and bounded memory with its peaks intact.

Each step's start (``summary.json`` steps[*].start) is marked by a dotted
vertical line. The figures are :data:`FIGURE_SIZE` at :data:`DPI`, so each PNG
is 1000 x 700 pixels whatever the number of joints. Matplotlib runs with
its non-interactive Agg backend.

Also a command: ``python -m armando_drake.plots DIR`` redraws the plots of a
run folder.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from armando_drake.outputs.base import BASE_CSV, write_base_plots
from armando_drake.outputs.logger import read_csv, read_joint_states
from armando_drake.tools.cli import add_version_argument
from armando_drake.tools.errors import UserInputError
from armando_drake.tools.files import writing

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FIGURE_SIZE = (10.0, 7.0)  # [inch]
DPI = 100  # [pixel/inch]
PLOTS = ("positions.png", "tracking_error.png", "efforts.png")  # an arm's commanded run
MOVED = 1e-3  # [rad or m] a joint whose range is larger moved
# Blank pixels of a joint figure: at its left edge, right of the panels, above them
# (title and offset text), below them (time ticks and label) and between two panels.
LAYOUT_GAPS = {"edge": 8.0, "right": 20.0, "top": 45.0, "bottom": 48.0, "between": 18.0}


def envelope(values: np.ndarray, max_points: int = 4000) -> np.ndarray:
    """Indices into the rows of ``values`` (m, k) that keep, for every column, its
    smallest and largest value in each of ``max_points / 2`` consecutive buckets, plus the
    first and last row: a line drawn through them looks as the whole series does at the
    plots' width (peaks included) with a few thousand points instead of every sample.
    NaN counts as neither; one column at a time, so it takes little memory."""
    m = len(values)
    if m <= max_points:
        return np.arange(m)
    values = values.reshape(m, -1)
    buckets = max(1, max_points // 2)
    size = -(-m // buckets)  # ceil
    starts = np.arange(buckets) * size
    keep = [np.array([0, m - 1])]
    for column in values.T:
        padded = np.empty(buckets * size)
        padded[:m] = column
        padded[m:] = column[-1]
        blocks = padded.reshape(buckets, size)
        nan = np.isnan(blocks)
        keep.append(starts + np.argmin(np.where(nan, np.inf, blocks), axis=1))
        keep.append(starts + np.argmax(np.where(nan, -np.inf, blocks), axis=1))
    keep = np.concatenate(keep)
    return np.unique(keep[keep < m])


def commanded_at(
    times: np.ndarray, command_times: np.ndarray, commands: np.ndarray, ahead: bool = False
) -> np.ndarray:
    """The command in force at each of ``times``.

    The latest command at or before each time (NaN before the first); with
    ``ahead``, the first command due after each time (the last one after the
    last).
    """
    result = np.full((len(times), commands.shape[1]), np.nan)
    if len(command_times) == 0:
        return result
    index = np.searchsorted(command_times, times + 1e-9, side="right")
    if ahead:
        index = np.minimum(index, len(command_times) - 1)
    else:
        index = index - 1
    valid = index >= 0
    result[valid] = commands[index[valid]]
    return result


def _read_commands(folder: Path, joints: list[str]) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(times [s], commands [rad] (rows by time), joints commanded) of ``commands.csv``,
    only the columns of ``joints``; empty without the file."""
    command_times = np.zeros(0)
    commands = np.zeros((0, len(joints)))
    command_joints: list[str] = []
    if (folder / "commands.csv").is_file():
        command_header, command_rows = read_csv(folder / "commands.csv")
        command_joints = [name for name in command_header[1:] if name in joints]
        if command_joints and len(command_rows):
            order = np.argsort(command_rows[:, 0], kind="stable")
            command_rows = command_rows[order]
            command_times = command_rows[:, 0]
            columns = [command_header.index(name) for name in command_joints]
            commands = command_rows[:, columns]
    return command_times, commands, command_joints


def plot_title(summary: dict, fallback: str) -> str:
    """The run, named once: the scenario's name (``fallback`` without one), then what
    drove the arm unless that name already says it: ``position``, ``task_js``,
    ``ros2 (dds)``, ``world (position)``, ``display (no controller)``."""
    name = Path(summary.get("scenario") or fallback).stem
    controller = summary.get("controller") or ""
    if not controller or controller in name.split("_"):
        return name
    return f"{name} ({'no controller' if controller == 'none' else controller})"


def _read_summary(folder: Path) -> tuple[list[float], str, bool]:
    """(step starts [s], plot title, whether a trajectory run) from ``summary.json``."""
    summary = {}
    if (folder / "summary.json").is_file():
        summary = json.loads((folder / "summary.json").read_text())
    step_starts = [step["start"] for step in summary.get("steps", [])]
    trajectory = summary.get("controller") == "trajectory"
    return step_starts, plot_title(summary, folder.name), trajectory


def _text_width(text: str, size: str | float) -> float:
    """The width [pixel] of ``text`` in the default font at ``size``, without drawing."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import text_to_path

    width, _, _ = text_to_path.get_text_width_height_descent(
        text, FontProperties(size=size), ismath=False
    )
    return width * DPI / 72.0  # [point] to [pixel]


def _fixed_layout(joints: list[str]) -> dict[str, float]:
    """The subplot parameters of a joint figure, computed from the text it holds instead
    of drawn twice by a layout engine: on the left the longest joint name and a tick
    label as wide as ``-0.00000``, the title and an axis' offset text (``1e-3``) above
    each panel, the time axis' labels below (:data:`LAYOUT_GAPS`, pixels)."""
    import matplotlib as mpl

    width, height = FIGURE_SIZE[0] * DPI, FIGURE_SIZE[1] * DPI
    rc = mpl.rcParams
    name = max((_text_width(joint, rc["axes.labelsize"]) for joint in joints), default=0.0)
    tick = _text_width("\N{MINUS SIGN}0.00000", rc["ytick.labelsize"])
    pads = (rc["axes.labelpad"] + rc["ytick.major.pad"] + rc["ytick.major.size"]) * DPI / 72.0
    left = LAYOUT_GAPS["edge"] + name + pads + tick
    panels = height - LAYOUT_GAPS["top"] - LAYOUT_GAPS["bottom"]  # with the gaps between
    space = min(LAYOUT_GAPS["between"], panels / len(joints) / 2)  # many joints: panels first
    panel = (panels - space * (len(joints) - 1)) / len(joints)
    return {
        "left": min(left / width, 0.5),
        "right": 1.0 - LAYOUT_GAPS["right"] / width,
        "top": 1.0 - LAYOUT_GAPS["top"] / height,
        "bottom": LAYOUT_GAPS["bottom"] / height,
        "hspace": space / panel,
    }


def _joint_figure(
    quantity: str, unit: str, title: str, joints: list[str], step_starts: list[float]
) -> tuple[Figure, np.ndarray]:
    """A figure with one panel per joint, each step's start marked; (figure, axes).

    The unit is in the title; each panel's joint name is written across, beside it, and
    the left margin makes room for the longest (:func:`_fixed_layout`), so long names
    (``iiwa_joint_7``) never run into the next panel's."""
    # A bare Figure draws with the Agg canvas and leaves pyplot's backend (and a
    # notebook's inline plots) alone.
    from matplotlib.figure import Figure

    fig = Figure(figsize=FIGURE_SIZE, dpi=DPI)
    fig.subplots_adjust(**_fixed_layout(joints))
    axes = fig.subplots(len(joints), 1, sharex=True, squeeze=False)
    axes = axes[:, 0]
    fig.suptitle(f"{quantity} [{unit}]: {title}")
    for axis, name in zip(axes, joints, strict=True):
        axis.set_ylabel(name, rotation=0, ha="right", va="center")
        axis.grid(True, alpha=0.3)
        for start in step_starts:
            axis.axvline(start, color="grey", linestyle=":", linewidth=1)
    axes[-1].set_xlabel("time [s]")
    return fig, axes


def _plot_positions(
    axes: np.ndarray,
    joints: list[str],
    times: np.ndarray,
    position: np.ndarray,
    shown: np.ndarray,
    commands: tuple[np.ndarray, np.ndarray, list[str]],
    trajectory: bool,
) -> None:
    """Measured positions, with the commands as points (trajectory) or held steps."""
    command_times, values, command_joints = commands
    for j, (axis, name) in enumerate(zip(axes, joints, strict=True)):
        axis.plot(times[shown], position[shown, j], label="measured")
        if name in command_joints and len(command_times):
            k = command_joints.index(name)
            if trajectory:  # each point, reached at the time it is due
                axis.plot(command_times, values[:, k], "o", color="tab:orange", label="points")
            else:  # steps held to the end of the log
                end = max(times[-1] if len(times) else 0.0, command_times[-1])
                t = np.append(command_times, end)
                q = np.append(values[:, k], values[-1, k])
                axis.step(t, q, where="post", linestyle="--", label="commanded")
    axes[0].legend(loc="upper right")


def write_plots(output_dir: str | Path) -> list[Path]:
    """Writes the PNG plots of the run in ``output_dir``; returns their paths (none when
    the run logged no joint states: no joint state broadcaster was active)."""
    folder = Path(output_dir)
    if (folder / BASE_CSV).is_file():  # a mobile base: its path and velocities
        _, title, _ = _read_summary(folder)
        base_plots = write_base_plots(folder, title, DPI, FIGURE_SIZE)
    else:
        base_plots = []
    if not (folder / "joint_states.csv").is_file():
        return base_plots
    states = read_joint_states(folder / "joint_states.csv")
    joints = states.joint_names
    if not joints:
        return []
    times, position, effort = states.times, states.position, states.effort
    command_times, commands, command_joints = _read_commands(folder, joints)
    step_starts, title, trajectory = _read_summary(folder)

    commanded = np.full_like(position, np.nan)
    if command_joints:
        held = commanded_at(times, command_times, commands, ahead=trajectory)
        for k, name in enumerate(command_joints):
            commanded[:, joints.index(name)] = held[:, k]

    written = base_plots
    commanded_any = bool(command_joints) and len(command_times) > 0
    moved = len(times) > 0 and float(np.ptp(position, axis=0).max(initial=0.0)) > MOVED
    mobile = bool(base_plots)

    def save(fig, name: str) -> None:
        path = folder / name
        with writing(path):
            fig.savefig(path, dpi=DPI)
        written.append(path)

    # A long run is drawn through the envelope of its samples (same look, bounded memory).
    error = np.abs(position - commanded)
    shown = np.union1d(envelope(position), np.union1d(envelope(effort), envelope(error)))

    if commanded_any or (moved and not mobile):
        fig, axes = _joint_figure("Joint positions", "rad", title, joints, step_starts)
        commands_drawn = (command_times, commands, command_joints)
        _plot_positions(axes, joints, times, position, shown, commands_drawn, trajectory)
        save(fig, "positions.png")

    if commanded_any:
        title_error = "Tracking error |q - commanded|"
        fig, axes = _joint_figure(title_error, "rad", title, joints, step_starts)
        for j, axis in enumerate(axes):
            if np.isnan(commanded[:, j]).all():
                axis.text(0.5, 0.5, "no command", transform=axis.transAxes, ha="center")
                continue
            axis.plot(times[shown], error[shown, j], color="tab:red")
        save(fig, "tracking_error.png")

    if len(times) and float(np.abs(effort).max(initial=0.0)) > 0.0:
        fig, axes = _joint_figure("Joint efforts", "N m", title, joints, step_starts)
        for j, axis in enumerate(axes):
            axis.plot(times[shown], effort[shown, j], color="tab:green")
        save(fig, "efforts.png")
    if (folder / "task_space.csv").is_file():
        _task_space_plots(folder, title, times, effort, joints, save)
    return written


def _task_space_plots(folder: Path, title: str, times, effort, joints, save) -> None:
    from matplotlib.figure import Figure

    header, rows = read_csv(folder / "task_space.csv")
    if not len(rows):
        return
    column = {name: rows[:, header.index(name)] for name in header}
    fig = Figure(figsize=FIGURE_SIZE, dpi=DPI)
    top, bottom = fig.subplots(2, 1, sharex=True)
    fig.suptitle(f"End-effector tracking error: {title}")
    top.plot(column["time"], column["position_error"] * 1e3, color="tab:red")
    top.set_ylabel("|position error| [mm]")
    bottom.plot(column["time"], column["orientation_error"], color="tab:purple")
    bottom.set_ylabel("|orientation error| [rad]")
    bottom.set_xlabel("time [s]")
    for axis in (top, bottom):
        axis.grid(True, alpha=0.3)
    save(fig, "task_error.png")

    fig = Figure(figsize=FIGURE_SIZE, dpi=DPI)
    axis = fig.subplots()
    fig.suptitle(f"Commanded joint torques: {title}")
    for j, name in enumerate(joints):
        axis.plot(times, effort[:, j], label=name)
    axis.set_xlabel("time [s]")
    axis.set_ylabel("torque [N m]")
    axis.grid(True, alpha=0.3)
    axis.legend(loc="upper right", fontsize="small")
    save(fig, "joint_torques.png")

    fig = Figure(figsize=FIGURE_SIZE, dpi=DPI)
    axes = fig.subplots(1, 3)
    fig.suptitle(f"End-effector path, desired and actual [m]: {title}")
    for axis, (a, b) in zip(axes, (("x", "y"), ("x", "z"), ("y", "z")), strict=True):
        axis.plot(column[f"desired_{a}"], column[f"desired_{b}"], "--", label="desired")
        axis.plot(column[f"actual_{a}"], column[f"actual_{b}"], label="actual", alpha=0.8)
        axis.set_xlabel(f"{a} [m]")
        axis.set_ylabel(f"{b} [m]")
        axis.set_aspect("equal", adjustable="datalim")
        axis.grid(True, alpha=0.3)
    axes[0].legend(loc="best", fontsize="small")
    fig.tight_layout()
    save(fig, "task_path.png")


def main(argv: list[str] | None = None) -> int:
    """Redraws the plots of a run folder written by ``python -m armando_drake.world --output``."""
    parser = argparse.ArgumentParser(prog="python -m armando_drake.plots", description=main.__doc__)
    add_version_argument(parser)
    parser.add_argument("folder", metavar="DIR", help="a run's --output folder")
    args = parser.parse_args(argv)
    folder = Path(args.folder)
    if not (folder / "joint_states.csv").is_file():
        print(f"error: {folder}: no joint_states.csv there", file=sys.stderr)
        return 2
    try:
        written = write_plots(folder)
    except UserInputError as error:  # a garbled file: named with its line
        print(f"error: {error}", file=sys.stderr)
        return 2
    except (ValueError, KeyError, IndexError, OSError) as error:
        print(f"error: {folder}: a file that cannot be read: {error}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
