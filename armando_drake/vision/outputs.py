"""The vision outputs of a run: ``vision.csv`` and ``vision.png``.

- ``vision.csv``: per ArUco detection (or per blob target), the time [s], the unit
  vector ``s = p / |p|`` towards the marker (the disc) in the camera frame (s_x,
  s_y, s_z) and, with a look-at-point controller, the joint velocity commands
  [rad/s] in force then (the torques [N m] with a dynamic one);
- ``keypoints.csv``: with a blob detector, every frame's keypoints: time [s],
  centre u, v [px] and diameter [px];
- ``vision.png``: the seed's figures, the joint velocity commands and the
  components of s against time (s tends to (0, 0, 1) as the camera looks at the
  marker).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from armando_drake.vision.metrics import vision_summary

VISION_CSV = "vision.csv"
KEYPOINTS_CSV = "keypoints.csv"
VISION_PLOT = "vision.png"


def write_vision_csv(topics, context, path: str | Path) -> Path | None:
    """``vision.csv`` from the world's ArUco detector or blob target (None without)."""
    detectors = topics.detectors
    if detectors is None:
        return None
    if detectors.aruco is not None:
        history = detectors.aruco.history
    elif detectors.blob is not None and detectors.blob.target is not None:
        history = detectors.blob.target_history
    else:
        return None
    joints = detectors.command_joints
    commands = None
    if detectors.commands is not None:
        log = detectors.commands.FindLog(context)
        times, data = log.sample_times(), log.data()
        n = len(joints)
        rows = data[:n] if detectors.command_kind == "effort" else data[n : 2 * n]
        commands = (times, rows.T)
    path = Path(path)
    with path.open("w", newline="") as stream:
        writer = csv.writer(stream)
        kind = detectors.command_kind  # velocity | effort
        writer.writerow(["time", "s_x", "s_y", "s_z", *[f"{j}_{kind}_command" for j in joints]])
        for t, p in history:
            p = np.asarray(p)
            row = [t, *(p / np.linalg.norm(p)).tolist()]
            if commands is not None:
                k = max(0, int(np.searchsorted(commands[0], t + 1e-9, side="right")) - 1)
                row += commands[1][k].tolist() if len(commands[0]) else [np.nan] * len(joints)
            writer.writerow([f"{value:.6g}" for value in row])
    return path


def write_vision_plot(csv_path: str | Path, png_path: str | Path, title: str = "") -> Path:
    """``vision.png``: joint velocity commands and the components of s against time,
    titled with ``title`` (the run; the output folder's name by default)."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is left alone

    title = title or Path(png_path).parent.name
    with Path(csv_path).open() as stream:
        rows = list(csv.reader(stream))
    header, data = rows[0], np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))
    fig = Figure(figsize=(10.0, 7.0), dpi=100)
    top, bottom = fig.subplots(2, 1, sharex=True)
    effort = any(name.endswith("_effort_command") for name in header[4:])
    kind = "torque" if effort else "velocity"
    fig.suptitle(f"Vision: joint {kind} commands and the target's direction s: {title}")
    for k, name in enumerate(header[4:], start=4):
        label = name.replace("_effort_command", "").replace("_velocity_command", "")
        top.plot(data[:, 0], data[:, k], label=label)
    top.set_ylabel("joint torque command [N m]" if effort else "joint velocity command [rad/s]")
    if len(header) > 4:
        top.legend(fontsize="small", ncol=4)
    for k, name in enumerate(("s_x", "s_y", "s_z"), start=1):
        bottom.plot(data[:, 0], data[:, k], label=name)
    bottom.set_ylabel("s = p / |p| [-]")
    bottom.set_xlabel("time [s]")
    bottom.legend()
    top.grid(True)
    bottom.grid(True)
    fig.tight_layout()
    fig.savefig(png_path)
    return Path(png_path)


def write_vision_outputs(topics, diagram, context, scenario, output_dir, title: str = "") -> dict:
    """summary.json's ``vision`` (see :func:`~armando_drake.vision.metrics.vision_summary`);
    with ``output_dir``, also ``vision.csv`` and ``vision.png`` (titled ``title``) there."""

    summary = vision_summary(topics, diagram, context, scenario)
    blob = topics.detectors.blob
    if output_dir is not None and blob is not None:
        with (Path(output_dir) / KEYPOINTS_CSV).open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(["time", "u", "v", "diameter"])  # [s], [px], [px], [px]
            for detection in blob.history:
                for k in detection.keypoints:
                    writer.writerow([f"{detection.stamp:.6g}", f"{k.u:.3f}", f"{k.v:.3f}",
                                     f"{k.diameter:.3f}"])  # fmt: skip
    if output_dir is not None:
        csv_path = write_vision_csv(topics, context, Path(output_dir) / VISION_CSV)
        if csv_path is not None:
            write_vision_plot(csv_path, Path(output_dir) / VISION_PLOT, title)
    return summary
