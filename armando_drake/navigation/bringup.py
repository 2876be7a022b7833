"""Nav2's bringup as run here: which servers of a Nav2 file run, one warning naming the rest.

Nav2's ``navigation_launch.py`` starts controller_server, smoother_server, planner_server,
behavior_server, velocity_smoother, collision_monitor, bt_navigator, waypoint_follower,
docking_server (and ``localization_launch.py`` map_server and amcl). Here the planner
server, the controller server, the costmaps, the behaviour server's Spin, BackUp and Wait,
the velocity smoother (:mod:`.velocity_smoother`), AMCL (``localization: amcl``) and the
map server (a ``navigation.map``) run; NavigateToPose's default behaviour tree is the
navigator's own loop (:mod:`.navigator`). :func:`not_run` names every other node of the
file, and the behaviour and smoother plugins the default tree never calls;
:func:`warn_not_run` says them in one warning line (never dropped silently).
"""

from __future__ import annotations

import logging

from armando_drake.navigation.behaviors import NotRun
from armando_drake.navigation.nav2_params import ROS, Nav2Params
from armando_drake.navigation.registry import BEHAVIORS, normal

_log = logging.getLogger("armando_drake.navigation")

# The nodes that run whatever the scenario (the costmaps are nested: name/name).
RUN = ("planner_server", "controller_server", "global_costmap", "local_costmap")


def _is_node(value) -> bool:
    """A node of a parameter file: ``ros__parameters``, or a namespace holding one."""
    if not isinstance(value, dict):
        return False
    return ROS in value or any(isinstance(v, dict) and ROS in v for v in value.values())


def _plugins_of(ros: dict, key: str) -> list[tuple[str, str]]:
    """(name, plugin type) of the plugins ``ros[key]`` lists."""
    names = ros.get(key, [])
    names = names if isinstance(names, list) else []
    spec = {name: ros.get(name) for name in names}
    return [(n, normal(s.get("plugin", "?"))) for n, s in spec.items() if isinstance(s, dict)]


def not_run(nav2: Nav2Params, *, localization: str = "ground_truth", map_given=False):
    """The nodes and plugins of ``nav2`` not run here, each as ``name`` or
    ``node.plugin (type)``, in the file's order."""
    run = set(RUN) | {"behavior_server", "velocity_smoother"}
    if localization == "amcl":
        run.add("amcl")
    if map_given:
        run.add("map_server")
    names = []
    for node, value in nav2.doc.items():
        if not _is_node(value):
            continue
        if node not in run:
            names.append(node if node != "amcl" else f"amcl (localization: {localization})")
            continue
        if node == "behavior_server":
            ros = nav2.node(node) or {}
            key = "behavior_plugins" if "behavior_plugins" in ros else "recovery_plugins"
            implemented = {p.name: p for p in BEHAVIORS.implemented()}
            for name, kind in _plugins_of(ros, key):
                plugin = implemented.get(kind)
                if plugin is not None and plugin.cls is NotRun:
                    names.append(f"behavior_server.{name} ({kind.rpartition('::')[2]})")
    return names


def warn_not_run(nav2: Nav2Params, *, localization: str = "ground_truth", map_given=False):
    """One warning naming what :func:`not_run` finds (none when everything runs)."""
    names = not_run(nav2, localization=localization, map_given=map_given)
    if names:
        _log.warning("%s: not run here (Nav2 would start them): %s", nav2.path, ", ".join(names))
    return names
