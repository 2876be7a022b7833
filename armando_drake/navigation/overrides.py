"""Nav2 parameters overridden from the scenario: ``navigation.params_overrides``.

::

    navigation:
      params_file: package://fra2mo_description/config/navigation.yaml
      params_overrides:
        controller_server.FollowPath.desired_linear_vel: 0.3
        global_costmap.global_costmap.inflation_layer.inflation_radius: 0.35

A key is the parameter's path in the Nav2 YAML, its segments separated by dots, with
the ``ros__parameters`` level left out (``controller_server.FollowPath.lookahead_dist``
is ``controller_server: ros__parameters: FollowPath: lookahead_dist``). The value takes
the type of the one it replaces (an integer for ``max_particles``, true/false for
``use_collision_detection`` from 1/0). The parent of every key must be in the file; a
parameter it does not give is added. :func:`~.nav2_params.read_nav2` applies them to the
file's parsed mapping, which the planner server, the controller server, the costmaps and
AMCL then read (the file itself is read once and never rewritten); the sweep varies these
keys as ``nav.<key>`` (docs/navigation.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

from armando_drake.tools.errors import ConfigError

ROS = "ros__parameters"


def _typed(value: float, old, key: str, where: str):
    if isinstance(old, bool):
        if value not in (0, 1):
            raise ConfigError(f"{where}{key}={value!r}: {old!r} there is true/false (1 or 0)")
        return bool(value)
    if isinstance(old, int) and not isinstance(old, bool):
        if not math.isfinite(value) or value != int(value):
            raise ConfigError(f"{where}{key}={value!r}: an integer is needed ({old} there)")
        return int(value)
    return float(value)


def apply_overrides(
    doc: dict, overrides: Mapping[str, float], where: str = "", path: Path | None = None
) -> dict:
    """``doc`` (a Nav2 YAML's mapping, read from ``path``) with every dotted key of
    ``overrides`` set, in place."""
    file = str(path) if path is not None else "the Nav2 file"
    for key, value in overrides.items():
        segments = key.split(".")
        node = doc
        for depth, segment in enumerate(segments[:-1]):
            if isinstance(node, dict) and segment not in node and isinstance(node.get(ROS), dict):
                node = node[ROS]
            if not isinstance(node, dict) or not isinstance(node.get(segment), dict):
                known = ", ".join(k for k in (node if isinstance(node, dict) else {}) if k != ROS)
                raise ConfigError(
                    f"{where}{key}: no {'.'.join(segments[: depth + 1])!r} in {file}"
                    + (f" (there: {known})" if known else "")
                )
            node = node[segment]
        last = segments[-1]
        if last not in node and isinstance(node.get(ROS), dict):
            node = node[ROS]
        node[last] = _typed(value, node.get(last), key, where)
    return doc
