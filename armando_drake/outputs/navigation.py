"""A navigation run's outputs: summary.json's ``navigation`` section, the map and
``navigation.png``.

:func:`navigation_summary` is the navigator's per-goal results (reached, position and
yaw errors when the goal checker took the goal, time, path length driven and planned)
with the run's collisions: the base logger's episodes of contact between the robot and
an obstacle (outputs/base.py). :func:`write_navigation_map` writes the map the
navigation used (``map.yaml`` + ``map.pgm``, map_saver's format; a run writes it with
its logs, before the plots), :func:`write_navigation_plot` ``navigation.png``: the x-y
path over the map, with heading arrows, the goals as coloured dots and arrows, and where
each was reached; :func:`write_navigation_outputs` both.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from armando_drake.navigation.maps import save_map
from armando_drake.navigation.slam import map_accuracy
from armando_drake.outputs.base import COLUMNS

NAVIGATION_PNG = "navigation.png"
MAP_NAME = "map"  # map.yaml + map.pgm


def navigation_summary(world, context) -> dict[str, Any] | None:
    """summary.json's ``navigation`` section of a world with a navigation (None without)."""
    robot = world.robot_with("navigation")
    navigation = robot.navigation
    if navigation is None:
        return None
    navigator = navigation.navigator
    summary = navigator.summary(navigator.GetMyContextFromRoot(context))
    base = robot.base_log.summary() if robot.base_log is not None else None
    contacts = (base or {}).get("contacts") or {}
    summary["collisions"] = contacts.get("episodes", 0)
    summary["collision_bodies"] = contacts.get("bodies", [])
    grid, _ = navigation.final_map(context)
    if navigation.mapper is not None:
        summary["mapping"] = mapping_summary(world, navigation, grid, context)
    marker_goal = getattr(robot.detectors, "marker_goal", None)
    if marker_goal is not None:
        summary["aruco"] = marker_goal.summary(marker_goal.GetMyContextFromRoot(context))
    summary["map"] = {
        "source": grid.source,
        "resolution": grid.resolution,
        "origin": list(grid.origin),
        "size": [grid.width, grid.height],
    }
    return summary


def goal_rejections(world, context) -> dict[str, int]:
    """``/goal_pose`` messages the navigator refused (a frame the world does not know),
    for summary.json's ``rejected_messages`` (empty without a navigation or a refusal)."""
    robot = world.robot_with("navigation")
    if robot is None or robot.navigation is None:
        return {}
    navigator = robot.navigation.navigator
    rejected = navigator.nav_state(navigator.GetMyContextFromRoot(context)).rejected
    return {"/goal_pose": rejected} if rejected else {}


def mapping_summary(world, navigation, built, context) -> dict[str, Any]:
    """summary.json's ``navigation.mapping``: the map ``built`` (which becomes the
    navigation's map, saved and drawn) against the world's, the exploration, the drift
    corrected."""
    mapper, explorer = navigation.mapper, navigation.navigator
    mapper_context = mapper.GetMyContextFromRoot(context)
    explorer_context = explorer.GetMyContextFromRoot(context)
    start = mapper.start
    summary = map_accuracy(built, navigation.truth, start[:2], explorer.inscribed)
    summary.update(explorer.exploration(explorer_context))
    summary["scans_used"] = mapper.scans_used(mapper_context)
    plant = world.plant
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    X = plant.EvalBodyPoseInWorld(plant.GetMyContextFromRoot(context), body)
    truth = (*X.translation()[:2], X.rotation().ToRollPitchYaw().yaw_angle())
    odometry, corrected = mapper.poses(mapper_context)
    for name, pose in (("odometry", odometry), ("slam", corrected)):
        summary[f"{name}_position_error"] = math.hypot(pose[0] - truth[0], pose[1] - truth[1])
        summary[f"{name}_yaw_error"] = abs(math.remainder(pose[2] - truth[2], 2 * math.pi))
    return summary


def write_navigation_outputs(folder: Path, world, summary: dict, context) -> list[Path]:
    """:func:`write_navigation_map` and :func:`write_navigation_plot`: the files written."""
    return [
        write_navigation_map(folder, world, context),
        write_navigation_plot(folder, world, summary, context),
    ]


def write_navigation_map(folder: Path, world, context) -> Path:
    """``map.yaml``/``map.pgm`` in ``folder``: the map ``world``'s navigation has at
    ``context`` (the diagram's; the map built when exploring). Returns the YAML's path."""
    grid, _ = world.robot_with("navigation").navigation.final_map(context)
    return save_map(grid, Path(folder) / MAP_NAME)


def write_navigation_plot(folder: Path, world, summary: dict, context) -> Path:
    """``navigation.png`` in ``folder``: the map ``world``'s navigation has at ``context``
    with its costmap, the base logger's path (:data:`~armando_drake.outputs.base.COLUMNS`)
    and the goals of ``summary`` (:func:`navigation_summary`). Returns its path."""
    from matplotlib.figure import Figure

    folder = Path(folder)
    robot = world.robot_with("navigation")
    rows = robot.base_log.array() if robot.base_log is not None else np.zeros((0, 1))
    grid, costmap = robot.navigation.final_map(context)
    fig = Figure(figsize=(7.0, 7.0), dpi=110)
    axis = fig.subplots()
    x0, y0, _ = grid.origin
    w, h = grid.size_m
    shade = np.where(grid.data >= 65, 0.15, np.where(grid.data < 0, 0.6, 1.0))
    axis.imshow(shade, cmap="gray", vmin=0, vmax=1, origin="lower", extent=(x0, x0 + w, y0, y0 + h))
    costs = costmap.costs.astype(float)
    inflated = np.ma.masked_where((costs == 0) | (costs >= 254), costs)
    axis.imshow(inflated, cmap="Blues", alpha=0.35, origin="lower", extent=(x0, x0 + w, y0, y0 + h))
    if len(rows):
        col = {name: rows[:, k] for k, name in enumerate(COLUMNS)}
        axis.plot(col["x"], col["y"], color="tab:red", lw=1.5, label="driven path")
        every = max(1, len(rows) // 40)
        axis.quiver(
            col["x"][::every],
            col["y"][::every],
            np.cos(col["yaw"][::every]),
            np.sin(col["yaw"][::every]),
            color="tab:red",
            scale=30,
            width=0.004,
        )
        axis.plot(col["x"][:1], col["y"][:1], "ks", label="start")
    colours = ["tab:orange", "tab:green", "tab:purple", "tab:cyan", "tab:olive", "tab:pink"]
    for k, result in enumerate(summary["goals"]):
        colour = colours[k % len(colours)]
        x, y, yaw = result["goal"]
        goal = SimpleNamespace(name=result["name"], x=x, y=y, yaw=yaw)
        mark = "reached" if result["reached"] else result["reason"]
        label = f"{k + 1}. {goal.name} ({mark}, {result['position_error']:.3f} m)"
        axis.plot(goal.x, goal.y, "o", color=colour, ms=10, label=label)
        axis.arrow(
            goal.x,
            goal.y,
            0.3 * math.cos(goal.yaw),
            0.3 * math.sin(goal.yaw),
            color=colour,
            width=0.02,
        )
        axis.annotate(str(k + 1), (goal.x, goal.y), ha="center", va="center", fontsize=7)
    mapping = summary.get("mapping")
    if mapping:
        axis.set_title(
            f"Exploration: {mapping['explored_area']:.1f} m² mapped, "
            f"{summary['collisions']} collisions\nmap precision {mapping['precision']:.3f}, "
            f"recall {mapping['recall']:.3f}, coverage {mapping['coverage']:.3f}"
        )
    else:
        axis.set_title(f"Navigation: {summary['reached']}/{len(summary['goals'])} goals "
                       f"reached, {summary['collisions']} collisions")  # fmt: skip
    axis.set_xlabel("x [m]")
    axis.set_ylabel("y [m]")
    axis.set_aspect("equal")
    axis.legend(loc="upper left", fontsize="x-small", framealpha=0.8)
    fig.tight_layout()
    fig.savefig(folder / NAVIGATION_PNG)
    return folder / NAVIGATION_PNG
