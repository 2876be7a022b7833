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

from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.navigation.registry import BEHAVIORS
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import param

_log = logging.getLogger("armando_drake.navigation")

SPIN, BACKUP, WAIT = "nav2_behaviors::Spin", "nav2_behaviors::BackUp", "nav2_behaviors::Wait"
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
_LISTS = ("behavior_plugins", "recovery_plugins")


@dataclass
class BehaviorParameters:
    """behavior_server's parameters (defaults: Nav2's)."""

    plugins: dict[str, str] = field(default_factory=dict)  # name -> type
    cycle_frequency: float = param(
        10.0, unit="Hz", ge=0, doc="the behaviours' rate (they run at the navigator's here)"
    )
    max_rotational_vel: float = param(1.0, unit="rad/s", ge=0, doc="Spin's fastest turn rate")
    min_rotational_vel: float = param(0.4, unit="rad/s", ge=0, doc="Spin's slowest turn rate")
    rotational_acc_lim: float = param(
        3.2, unit="rad/s^2", ge=0, doc="Spin's angular acceleration limit"
    )
    simulate_ahead_time: float = param(
        2.0, unit="s", ge=0, doc="BackUp's collision check ahead of the motion"
    )
    number_of_retries: int = NUMBER_OF_RETRIES

    def round_robin(self) -> list[str]:
        """The recoveries run in turn: clearing, then the tree's Spin, Wait, BackUp if
        listed."""
        kinds = set(self.plugins.values())
        return [CLEAR] + [k for k in (SPIN, WAIT, BACKUP) if k in kinds]


_READ = (
    "cycle_frequency",
    "max_rotational_vel",
    "min_rotational_vel",
    "rotational_acc_lim",
    "simulate_ahead_time",
)


def behavior_parameters(source: Nav2Params | str | Path) -> BehaviorParameters | None:
    """``behavior_server`` of a Nav2 file (None without one)."""
    nav2 = as_nav2(source)
    ros = nav2.node("behavior_server")
    if ros is None:
        return None
    where = nav2.where("behavior_server")
    params = BehaviorParameters()
    key = "behavior_plugins" if "behavior_plugins" in ros else "recovery_plugins"
    names = ros.get(key, ["spin", "backup", "drive_on_heading", "assisted_teleop", "wait"])
    if not isinstance(names, list):
        raise ConfigError(f"{where}.{key} must be a list of names, not {names!r}")
    for name in names:
        spec = ros.get(name)
        if not isinstance(spec, dict) or "plugin" not in spec:
            raise ConfigError(f"{where}.{name}.plugin: the behaviour '{name}' has no plugin type")
        params.plugins[name] = BEHAVIORS.load(spec, f"{where}.{name}")[0].name
    unused = fill(params, ros, where, _READ)
    for key in unused:
        if key not in _KNOWN and key not in _LISTS and key not in names:
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
    if elapsed > TIME_ALLOWANCE or recovery.kind == CLEAR:  # clearing: done at once
        return 0.0, 0.0, True
    behavior = BEHAVIORS.lookup(recovery.kind, "behavior_server").cls
    return behavior.command(params, recovery, pose, elapsed, blocked_behind)


@BEHAVIORS.register(WAIT)
class Wait:
    """nav2_behaviors' Wait: still for the tree's ``WAIT_DURATION``."""

    @staticmethod
    def command(params, recovery, pose, elapsed, blocked_behind):
        return 0.0, 0.0, elapsed >= WAIT_DURATION


@BEHAVIORS.register(SPIN)
class Spin:
    """nav2_behaviors' Spin: ``SPIN_DIST`` in place, within the rotational limits."""

    @staticmethod
    def command(params, recovery, pose, elapsed, blocked_behind):
        turned = abs(math.remainder(pose[2] - recovery.pose[2], 2 * math.pi))
        # The turn is measured modulo 2 pi: SPIN_DIST < pi, so it is the turn so far.
        remaining = SPIN_DIST - turned
        if remaining <= 0:
            return 0.0, 0.0, True
        w = math.sqrt(2 * params.rotational_acc_lim * remaining)
        w = min(max(w, params.min_rotational_vel), params.max_rotational_vel)
        return 0.0, w, False


@BEHAVIORS.register(BACKUP)
class BackUp:
    """nav2_behaviors' BackUp: ``BACKUP_DIST`` backwards at ``BACKUP_SPEED``, stopped by an
    obstacle within ``simulate_ahead_time`` of the motion."""

    @staticmethod
    def command(params, recovery, pose, elapsed, blocked_behind):
        moved = math.hypot(pose[0] - recovery.pose[0], pose[1] - recovery.pose[1])
        if moved >= BACKUP_DIST:
            return 0.0, 0.0, True
        ahead = min(BACKUP_DIST - moved, BACKUP_SPEED * params.simulate_ahead_time)
        if blocked_behind(ahead):
            _log.warning("BackUp: an obstacle behind; the behaviour ends")
            return 0.0, 0.0, True
        return -BACKUP_SPEED, 0.0, False


@BEHAVIORS.register("nav2_behaviors::DriveOnHeading")
@BEHAVIORS.register("nav2_behaviors::AssistedTeleop")
class NotRun:
    """Behaviours the default tree does not call: accepted, never run."""

    @staticmethod
    def command(params, recovery, pose, elapsed, blocked_behind):
        return 0.0, 0.0, True
