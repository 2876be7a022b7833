"""Nav2's recovery behaviours (``behavior_server``) as the default behaviour tree runs them.

When a goal fails (no plan, the controller's collision check past its
``failure_tolerance``, or no progress), the default tree of NavigateToPose
(``navigate_to_pose_w_replanning_and_recovery.xml``) retries it up to
``number_of_retries`` (6) times, running one recovery before each retry, round robin:
clearing the costmaps (their obstacle layers), ``Spin`` 1.57 rad, ``Wait`` 5 s, ``BackUp``
0.30 m at 0.15 m/s (the tree's arguments), each behaviour within a ``time_allowance`` of
10 s. Only the behaviours that ``behavior_server``'s ``behavior_plugins`` lists run; a goal
still failing after the retries is aborted with its reason.

Behaviour parameters read: ``cycle_frequency`` (the behaviours run at the navigator's
rate here), ``max_rotational_vel``, ``min_rotational_vel``, ``rotational_acc_lim``,
``simulate_ahead_time`` (BackUp's collision check ahead of the motion); ``local_frame``,
``global_frame``, ``robot_base_frame``, ``transform_tolerance``, ``use_sim_time`` are
frames and clocks of the ROS node. ``DriveOnHeading`` and ``AssistedTeleop`` are not in
the default tree: accepted, not run.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from armando_drake.tools.errors import ConfigError

_log = logging.getLogger("armando_drake.navigation")

SPIN, BACKUP, WAIT = "nav2_behaviors::Spin", "nav2_behaviors::BackUp", "nav2_behaviors::Wait"
NOT_RUN = ("nav2_behaviors::DriveOnHeading", "nav2_behaviors::AssistedTeleop")
BEHAVIOR_TYPES = (SPIN, BACKUP, WAIT, *NOT_RUN)
CLEAR = "clear_costmaps"  # the tree's ClearEntireCostmap of both costmaps (no plugin)

# The default tree's arguments and retries.
NUMBER_OF_RETRIES = 6
SPIN_DIST = 1.57  # [rad]
WAIT_DURATION = 5.0  # [s]
BACKUP_DIST, BACKUP_SPEED = 0.30, 0.15  # [m], [m/s]
TIME_ALLOWANCE = 10.0  # [s]

_KNOWN = {
    "use_sim_time",
    "costmap_topic",
    "footprint_topic",
    "local_costmap_topic",
    "global_costmap_topic",
    "local_footprint_topic",
    "global_footprint_topic",
    "local_frame",
    "global_frame",
    "robot_base_frame",
    "transform_tolerance",
    "transform_timeout",
    "enable_stamped_cmd_vel",
}
_READ = {
    "behavior_plugins",
    "recovery_plugins",
    "cycle_frequency",
    "max_rotational_vel",
    "min_rotational_vel",
    "rotational_acc_lim",
    "simulate_ahead_time",
}


@dataclass
class BehaviorParameters:
    """behavior_server's parameters (defaults: Nav2's)."""

    plugins: dict[str, str] = field(default_factory=dict)  # name -> type
    cycle_frequency: float = 10.0
    max_rotational_vel: float = 1.0
    min_rotational_vel: float = 0.4
    rotational_acc_lim: float = 3.2
    simulate_ahead_time: float = 2.0
    number_of_retries: int = NUMBER_OF_RETRIES

    def round_robin(self) -> list[str]:
        """The recoveries run in turn: clearing, then the tree's Spin, Wait, BackUp if
        listed."""
        kinds = set(self.plugins.values())
        return [CLEAR] + [k for k in (SPIN, WAIT, BACKUP) if k in kinds]


def behavior_parameters(path: str | Path) -> BehaviorParameters | None:
    """``behavior_server`` of a Nav2 YAML (None without one)."""
    path = Path(path)
    try:
        doc = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ConfigError(f"{path}: cannot be read ({' '.join(str(error).split())})") from None
    node = doc.get("behavior_server") if isinstance(doc, dict) else None
    ros = node.get("ros__parameters") if isinstance(node, dict) else None
    if not isinstance(ros, dict):
        return None
    where = f"{path}: behavior_server.ros__parameters"
    params = BehaviorParameters()
    key = "behavior_plugins" if "behavior_plugins" in ros else "recovery_plugins"
    names = ros.get(key, ["spin", "backup", "drive_on_heading", "assisted_teleop", "wait"])
    if not isinstance(names, list):
        raise ConfigError(f"{where}.{key} must be a list of names, not {names!r}")
    for name in names:
        spec = ros.get(name)
        if not isinstance(spec, dict) or "plugin" not in spec:
            raise ConfigError(f"{where}.{name}.plugin: the behaviour '{name}' has no plugin type")
        kind = str(spec["plugin"]).replace("/", "::")
        if kind not in BEHAVIOR_TYPES:
            raise ConfigError(
                f"{where}.{name}.plugin: unknown behaviour {spec['plugin']!r} "
                f"(known: {', '.join(BEHAVIOR_TYPES)})"
            )
        params.plugins[name] = kind
    for key in sorted(_READ - {"behavior_plugins", "recovery_plugins"}):
        if key in ros:
            value = ros[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
                raise ConfigError(f"{where}.{key} must be a number >= 0, not {value!r}")
            setattr(params, key, float(value))
    for key in ros:
        if key not in _READ | _KNOWN and key not in names:
            _log.warning("%s.%s: not used by the behaviours here", where, key)
    return params


@dataclass(frozen=True)
class Recovery:
    """A recovery running: its kind, when and where it started."""

    kind: str
    started: float
    pose: tuple[float, float, float]


def recovery_command(
    params: BehaviorParameters, recovery: Recovery, pose, now: float, blocked_behind
) -> tuple[float, float, bool]:
    """(v, w, done) of a running recovery; ``blocked_behind(distance)`` tells whether
    backing up ``distance`` [m] from ``pose`` would enter an obstacle."""
    elapsed = now - recovery.started
    if elapsed > TIME_ALLOWANCE:
        return 0.0, 0.0, True
    if recovery.kind == WAIT:
        return 0.0, 0.0, elapsed >= WAIT_DURATION
    if recovery.kind == SPIN:
        turned = abs(math.remainder(pose[2] - recovery.pose[2], 2 * math.pi))
        # The turn is measured modulo 2 pi: SPIN_DIST < pi, so it is the turn so far.
        remaining = SPIN_DIST - turned
        if remaining <= 0:
            return 0.0, 0.0, True
        w = math.sqrt(2 * params.rotational_acc_lim * remaining)
        w = min(max(w, params.min_rotational_vel), params.max_rotational_vel)
        return 0.0, w, False
    if recovery.kind == BACKUP:
        moved = math.hypot(pose[0] - recovery.pose[0], pose[1] - recovery.pose[1])
        if moved >= BACKUP_DIST:
            return 0.0, 0.0, True
        ahead = min(BACKUP_DIST - moved, BACKUP_SPEED * params.simulate_ahead_time)
        if blocked_behind(ahead):
            _log.warning("BackUp: an obstacle behind; the behaviour ends")
            return 0.0, 0.0, True
        return -BACKUP_SPEED, 0.0, False
    return 0.0, 0.0, True  # clearing: done at once
