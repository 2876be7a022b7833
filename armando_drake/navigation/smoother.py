"""Nav2's smoother server: the slot of its ``smoother_plugins`` (:data:`~.registry.SMOOTHERS`).

``smoother_server.ros__parameters.smoother_plugins`` names the smoothers a behaviour tree
may call with ``SmoothPath``. NavigateToPose's default tree never calls it, so no smoother
runs on the plan here; :func:`smoother_plugins` loads those of the file whose plugin is
registered (each made with its parameters, read and checked as any plugin's), for a
navigator that smooths its plans; the others are left, as the default tree leaves them.
"""

from __future__ import annotations

from pathlib import Path

from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.navigation.registry import SMOOTHERS, normal
from armando_drake.tools.errors import ConfigError


def smoother_plugins(source: Nav2Params | str | Path) -> dict:
    """The registered smoothers the file's smoother_server lists: {name: plugin made with
    its parameters}; {} without a smoother_server."""
    nav2 = as_nav2(source)
    ros = nav2.node("smoother_server")
    if ros is None:
        return {}
    where = nav2.where("smoother_server")
    names = ros.get("smoother_plugins", [])
    if not isinstance(names, list):
        raise ConfigError(f"{where}.smoother_plugins must be a list of names, not {names!r}")
    registered = {p.name for p in SMOOTHERS.implemented()}
    smoothers = {}
    for name in names:
        node = ros.get(name)
        if not isinstance(node, dict) or normal(node.get("plugin", "")) not in registered:
            continue
        plugin, node = SMOOTHERS.load(node, f"{where}.{name}")
        params = plugin.cls.Parameters()
        fill(params, node, f"{where}.{name}")
        smoothers[name] = plugin.cls(params)
    return smoothers
