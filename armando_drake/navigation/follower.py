"""Nav2's controller server: Regulated Pure Pursuit, its goal and progress checkers.

:func:`controller_parameters` reads ``controller_server.ros__parameters`` of a Nav2 YAML:
``controller_frequency``, ``min_x_velocity_threshold`` / ``min_theta_velocity_threshold``
(a measured speed below them counts as 0), ``failure_tolerance``, the goal checker
(``nav2_controller::SimpleGoalChecker`` or ``StoppedGoalChecker``), the progress checker
(``SimpleProgressChecker`` or ``PoseProgressChecker``) and the ``FollowPath`` plugin,
``nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController``. A key of
these plugins that is not applied here is warned about by name (``transform_tolerance``:
there are no transforms to wait for), as any unknown one.

:func:`rpp_command` is ``RegulatedPurePursuitController::computeVelocityCommands``: the
path pruned to the part ahead of the robot (within ``max_robot_pose_search_dist``), the
path cut at its first point beyond half the costmap's larger side (``transformGlobalPlan``),
the lookahead (``lookahead_dist``, or ``|v| lookahead_time`` clamped to
``[min_lookahead_dist, max_lookahead_dist]``; with ``allow_reversing`` not beyond the
path's first cusp), the carrot on the path at that distance (on the segment that crosses
the circle with ``use_interpolation``: ``circleSegmentIntersection``), the curvature
``2 y / (x^2 + y^2)`` to it (or to the point at ``curvature_lookahead_dist``, projected
past the path's end with ``interpolate_curvature_after_goal``);
rotation in place toward the path beyond ``rotate_to_heading_min_angle`` or to the goal's
heading within the goal checker's ``xy_goal_tolerance`` (``rotate_to_heading_angular_vel``
within ``max_angular_accel`` of the current turn rate, then at most the rate that stops on
the heading); else
``desired_linear_vel`` regulated by curvature (below ``regulated_linear_scaling_min_radius``
scaled by ``radius / min_radius``), by the cost under the robot (``cost_scaling_dist``,
``cost_scaling_gain``, ``inflation_cost_scaling_factor``), not below
``regulated_linear_scaling_min_speed``, then, on a path shorter than
``approach_velocity_scaling_dist``, slowed by the straight-line distance to its end (not below
``min_approach_linear_velocity``); the
angular velocity is the linear one times the curvature. With ``use_collision_detection``
the arc is projected forward (up to ``max_allowed_time_to_collision_up_to_carrot`` and
the carrot) and a cell at or above the inscribed cost on it stops the robot: a failure
of the controller (the goal is aborted after ``failure_tolerance`` seconds of them).
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
import sys
from pathlib import Path

import numpy as np

from armando_drake.navigation.cost_values import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION
from armando_drake.navigation.costmap import Costmap, CostmapParameters
from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.navigation.registry import CONTROLLERS
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import is_number, param

RPP = "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
GOAL_CHECKERS = ("nav2_controller::SimpleGoalChecker", "nav2_controller::StoppedGoalChecker")
PROGRESS_CHECKERS = (
    "nav2_controller::SimpleProgressChecker",
    "nav2_controller::PoseProgressChecker",
)

_log = logging.getLogger("armando_drake.navigation")

NO_SPEED_LIMIT = 0.0  # nav2_costmap_2d's filter value: no speed limit


def _m(default, doc, **rule):
    return param(default, unit="m", ge=0, doc=doc, **rule)


def _on(default, doc):
    return param(default, doc=doc)


@dc.dataclass
class RppParameters:
    """RegulatedPurePursuitController's parameters (defaults: upstream's)."""

    desired_linear_vel: float = param(
        0.5,
        unit="m/s",
        ge=0,
        over=(10.0, "no mobile base here drives that fast"),
        doc="the cruise speed",
    )
    lookahead_dist: float = _m(0.6, "the carrot's distance on the plan (fixed look-ahead)")
    min_lookahead_dist: float = _m(0.3, "the velocity-scaled look-ahead's lower bound")
    max_lookahead_dist: float = _m(0.9, "the velocity-scaled look-ahead's upper bound")
    lookahead_time: float = param(
        1.5, unit="s", ge=0, doc="speed x this = the velocity-scaled look-ahead"
    )
    rotate_to_heading_angular_vel: float = param(
        1.8, unit="rad/s", ge=0, doc="the turn rate when rotating in place"
    )
    use_velocity_scaled_lookahead_dist: bool = _on(False, "the look-ahead grows with the speed")
    min_approach_linear_velocity: float = param(
        0.05, unit="m/s", ge=0, doc="the slowest speed near the goal"
    )
    approach_velocity_scaling_dist: float = _m(0.6, "from this far from the goal the speed drops")
    use_collision_detection: bool = _on(
        True, "stop when the arc to the carrot collides in the costmap"
    )
    max_allowed_time_to_collision_up_to_carrot: float = param(
        1.0, unit="s", ge=0, doc="of motion checked for collisions"
    )
    use_regulated_linear_velocity_scaling: bool = _on(True, "slower on tight curves")
    use_cost_regulated_linear_velocity_scaling: bool = _on(
        True, "slower near obstacles (costmap cost)"
    )
    cost_scaling_dist: float = _m(0.6, "the obstacle distance from which cost regulation slows")
    cost_scaling_gain: float = param(1.0, unit="-", ge=0, doc="the cost regulation's gain")
    inflation_cost_scaling_factor: float = param(
        3.0,
        unit="-",
        doc="the inflation layer's factor, to recover distances (<= 0: no cost regulation)",
    )
    regulated_linear_scaling_min_radius: float = _m(0.9, "curvature radius below which it slows")
    regulated_linear_scaling_min_speed: float = param(
        0.25, unit="m/s", ge=0, doc="the regulated speed's floor"
    )
    use_fixed_curvature_lookahead: bool = _on(False, "the curvature taken at a fixed distance")
    curvature_lookahead_dist: float = _m(0.6, "that distance")
    use_rotate_to_heading: bool = _on(
        True, "rotate in place toward the path and the goal's heading"
    )
    rotate_to_heading_min_angle: float = param(
        0.785, unit="rad", ge=0, doc="heading error above which it rotates in place"
    )
    max_angular_accel: float = param(
        3.2, unit="rad/s^2", ge=0, doc="the in-place rotation's acceleration limit"
    )
    allow_reversing: bool = _on(False, "drive backwards when the carrot is behind")
    max_robot_pose_search_dist: float = param(
        10.0,
        unit="m",
        doc="how far along the plan the robot is searched (unset: half the local costmap's "
        "width; negative: the whole plan)",
    )
    use_interpolation: bool = _on(True, "the carrot interpolated between plan poses")
    interpolate_curvature_after_goal: bool = _on(
        False,
        "the curvature's carrot projected past the path's end (with use_fixed_curvature_lookahead)",
    )
    stateful: bool = _on(True, "the rotation to the goal's heading, once begun, goes on")


@dc.dataclass
class ControllerParameters:
    """controller_server's parameters and its plugins': the server's, the goal
    checker's, the progress checker's; ``rpp`` the controller plugin's (``plugin`` its
    registered name)."""

    controller_frequency: float = param(
        20.0,
        unit="Hz",
        gt=0,
        over=(1000.0, "faster than the simulation can step the controller"),
        doc="the rate of the controller (a discrete update)",
    )
    min_x_velocity_threshold: float = param(
        0.0001, unit="m/s", ge=0, doc="smaller odometry speeds count as 0"
    )
    min_theta_velocity_threshold: float = param(
        0.0001, unit="rad/s", ge=0, doc="smaller odometry turn rates count as 0"
    )
    failure_tolerance: float = param(
        0.0, unit="s", ge=-1, doc="how long the controller may fail before the goal aborts"
    )
    xy_goal_tolerance: float = _m(0.25, "the goal's position tolerance")
    yaw_goal_tolerance: float = param(0.25, unit="rad", ge=0, doc="the goal's heading tolerance")
    goal_stateful: bool = _on(True, "the position, once within tolerance, stays reached")
    stopped_goal_checker: bool = False
    trans_stopped_velocity: float = param(
        0.25, unit="m/s", ge=0, doc="StoppedGoalChecker: below it the robot has stopped"
    )
    rot_stopped_velocity: float = param(
        0.25, unit="rad/s", ge=0, doc="StoppedGoalChecker: below it the robot has stopped"
    )
    required_movement_radius: float = _m(0.5, "the progress checker's distance to cover")
    required_movement_angle: float = param(
        math.inf, unit="rad", ge=0, doc="PoseProgressChecker: a turn that counts as progress"
    )  # only with PoseProgressChecker
    movement_time_allowance: float = param(
        10.0, unit="s", ge=0, doc="... within this time, else the goal aborts"
    )
    expected_planner_frequency: float = param(
        1.0, unit="Hz", ge=0, doc="how often the global plan is recomputed"
    )
    rpp: RppParameters = dc.field(default_factory=RppParameters)
    plugin: str = RPP
    ignored: list[str] = dc.field(default_factory=list)


_SERVER_KNOWN = {
    "use_sim_time", "odom_topic", "speed_limit_topic", "use_realtime_priority",
    "enable_stamped_cmd_vel", "publish_zero_velocity", "costmap_update_timeout",
    "controller_plugins", "goal_checker_plugins", "goal_checker_plugin",
    "progress_checker_plugins", "progress_checker_plugin", "min_y_velocity_threshold",
}  # fmt: skip
_NOT_APPLIED = {"transform_tolerance"}
SERVER_KEYS = (
    "controller_frequency", "min_x_velocity_threshold", "min_theta_velocity_threshold",
    "failure_tolerance",
)  # fmt: skip
GOAL_KEYS = ("xy_goal_tolerance", "yaw_goal_tolerance")
STOPPED_KEYS = ("trans_stopped_velocity", "rot_stopped_velocity")
PROGRESS_KEYS = ("required_movement_radius", "movement_time_allowance")


# controller_server's default plugin of each kind: its name and its type, declared when the
# plugin list is the default one (``default_goal_checker_ids_``/``default_goal_checker_types_``)
_DEFAULT_TYPES = {
    "goal_checker": GOAL_CHECKERS[0],
    "progress_checker": PROGRESS_CHECKERS[0],
    "FollowPath": "dwb_core::DWBLocalPlanner",
}


def _plugin(ros: dict, names_key: str, name_key: str, default: str, where: str):
    """(name, parameters) of the server's first plugin of a kind (Nav2 takes a list
    ``<kind>_plugins`` or, before Humble, one ``<kind>_plugin``); the default list's plugin
    without a ``plugin`` type has the server's default type."""
    names = ros.get(names_key, [ros.get(name_key, default)])
    if names in (default, [default]):
        node = ros.get(default, {})
        if isinstance(node, dict) and "plugin" not in node:
            return default, {"plugin": _DEFAULT_TYPES[default], **node}
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, list) or not names:
        raise ConfigError(f"{where}.{names_key} must be a list of plugin names, not {names!r}")
    if len(names) > 1:
        _log.warning("%s.%s: only the first, %r, is used", where, names_key, names[0])
    node = ros.get(names[0])
    if not isinstance(node, dict) or "plugin" not in node:
        raise ConfigError(f"{where}.{names[0]}.plugin: the plugin '{names[0]}' has no type")
    return names[0], node


def _checkers(params: ControllerParameters, ros: dict, where: str) -> tuple[set, list]:
    """The goal checker's and the progress checker's parameters: (their names, the keys
    not used)."""
    name, goal = _plugin(ros, "goal_checker_plugins", "goal_checker_plugin", "goal_checker", where)
    if goal["plugin"] not in GOAL_CHECKERS:
        raise ConfigError(f"{where}.{name}.plugin {goal['plugin']!r}: known: {GOAL_CHECKERS}")
    params.stopped_goal_checker = goal["plugin"] == GOAL_CHECKERS[1]
    keys = GOAL_KEYS + (STOPPED_KEYS if params.stopped_goal_checker else ())
    unused = fill(params, goal, f"{where}.{name}", keys)
    params.goal_stateful = bool(goal.get("stateful", params.goal_stateful))
    ignored = [f"{where}.{name}.{k}" for k in unused if k not in ("plugin", "stateful")]
    known = {name}
    name, progress = _plugin(
        ros, "progress_checker_plugins", "progress_checker_plugin", "progress_checker", where
    )
    if progress["plugin"] not in PROGRESS_CHECKERS:
        raise ConfigError(
            f"{where}.{name}.plugin {progress['plugin']!r}: known: {PROGRESS_CHECKERS}"
        )
    keys = PROGRESS_KEYS
    if progress["plugin"] == PROGRESS_CHECKERS[1]:
        params.required_movement_angle = 0.5
        keys += ("required_movement_angle",)
    unused = fill(params, progress, f"{where}.{name}", keys)
    ignored += [f"{where}.{name}.{k}" for k in unused if k != "plugin"]
    known.add(name)
    return known, ignored


def controller_parameters(source: Nav2Params | str | Path) -> ControllerParameters:
    """controller_server's parameters of a Nav2 file (and planner_server's
    ``expected_planner_frequency``); keys not applied are warned about by name."""
    nav2 = as_nav2(source)
    ros = nav2.required("controller_server")
    where = nav2.where("controller_server")
    params = ControllerParameters()
    fill(params, ros, where, SERVER_KEYS)
    known, ignored = _checkers(params, ros, where)
    name, follow = _plugin(ros, "controller_plugins", "controller_plugin", "FollowPath", where)
    plugin, follow = CONTROLLERS.load(follow, f"{where}.{name}")
    params.plugin = plugin.runs_as or plugin.name
    params.rpp = plugin.cls.Parameters()
    unused = fill(params.rpp, follow, f"{where}.{name}")
    rpp = params.rpp
    if rpp.interpolate_curvature_after_goal and not rpp.use_fixed_curvature_lookahead:
        _log.warning(
            "%s.%s.interpolate_curvature_after_goal: true needs use_fixed_curvature_lookahead:"
            " true; set to false (as Nav2 does)",
            where,
            name,
        )
        rpp.interpolate_curvature_after_goal = False
    _rpp_checks(rpp, follow, nav2, f"{where}.{name}")
    ignored += [f"{where}.{name}.{key}" for key in unused if key != "plugin"]
    known.add(name)
    ignored += [
        f"{where}.{k}"
        for k in ros
        if k not in known | _SERVER_KNOWN and not hasattr(params, k) and k not in ("plugin",)
    ]
    planner = nav2.node("planner_server")
    if planner is not None:
        fill(params, planner, nav2.where("planner_server"), ["expected_planner_frequency"])
    for key in ignored:
        why = "not applied here" if key.rsplit(".", 1)[-1] in _NOT_APPLIED else "not used here"
        _log.warning("%s: %s", key, why)
    params.ignored = ignored
    return params


def _rpp_checks(rpp: RppParameters, follow: dict, nav2: Nav2Params, where: str) -> None:
    """ParameterHandler's corrections: ``max_robot_pose_search_dist`` unset is half the
    local costmap's width (``getSizeInMetersX() / 2``), negative the whole plan; an
    ``inflation_cost_scaling_factor`` <= 0 disables the cost regulation."""
    if "max_robot_pose_search_dist" not in follow:
        local = nav2.node("local_costmap", "local_costmap") or {}
        width = local.get("width", CostmapParameters().width)
        if is_number(width) and width > 0:
            rpp.max_robot_pose_search_dist = width / 2.0
    if rpp.max_robot_pose_search_dist < 0.0:
        _log.warning(
            "%s.max_robot_pose_search_dist: %s is negative, the whole plan is searched "
            "for the closest pose (as Nav2)",
            where,
            rpp.max_robot_pose_search_dist,
        )
        rpp.max_robot_pose_search_dist = sys.float_info.max
    if rpp.inflation_cost_scaling_factor <= 0.0:
        _log.warning(
            "%s.inflation_cost_scaling_factor: %s should be > 0; cost regulated linear "
            "velocity scaling disabled (as Nav2)",
            where,
            rpp.inflation_cost_scaling_factor,
        )
        rpp.use_cost_regulated_linear_velocity_scaling = False


# ---------------------------------------------------------------------------- the follower


def wrap(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def to_robot(points: np.ndarray, pose) -> np.ndarray:
    """World points (n, 2) in the robot's frame at ``pose`` (x, y, yaw)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = points - np.asarray(pose[:2])
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def prune(path: np.ndarray, start: int, pose, search_dist: float) -> int:
    """The index of the path point nearest the robot, searched from ``start`` up to the
    first point past ``search_dist`` metres of path (``transformGlobalPlan``'s pruning);
    the last point of that window gives way to the one before it, so that at least two
    points remain to tell the path's end direction."""
    steps = np.linalg.norm(np.diff(path[start:], axis=0), axis=1)
    along = np.concatenate([[0.0], np.cumsum(steps)])
    end = start + int(np.searchsorted(along, search_dist, side="right"))
    window = path[start : max(end, start + 1)]
    d = np.hypot(window[:, 0] - pose[0], window[:, 1] - pose[1])
    nearest = start + int(np.argmin(d))
    if len(path) - start > 1 and nearest == start + len(window) - 1:
        nearest = max(start, nearest - 1)
    return nearest


def circle_segment_intersection(p1, p2, r: float) -> np.ndarray:
    """RPP's ``circleSegmentIntersection``: the point at ``r`` from the origin (the robot)
    on the line through ``p1`` and ``p2`` (robot frame), the one on the segment: toward
    ``p2`` when the segment leaves the circle, toward ``p1`` when it enters it."""
    x1, y1 = float(p1[0]), float(p1[1])
    x2, y2 = float(p2[0]), float(p2[1])
    dx, dy = x2 - x1, y2 - y1
    dr2 = dx * dx + dy * dy
    big_d = x1 * y2 - x2 * y1
    dd = (x2 * x2 + y2 * y2) - (x1 * x1 + y1 * y1)
    root = math.sqrt(max(0.0, r * r * dr2 - big_d * big_d))
    sign = math.copysign(1.0, dd)
    return np.array([(big_d * dy + sign * dx * root) / dr2, (-big_d * dx + sign * dy * root) / dr2])


def carrot(
    local: np.ndarray, lookahead: float, interpolate: bool, after_goal: bool = False
) -> np.ndarray:
    """RPP's ``getLookAheadPoint`` on the path ``local`` (robot frame, from the nearest
    point on): the first point at least ``lookahead`` from the robot, or, with
    ``interpolate``, the crossing of that circle on the segment before it
    (:func:`circle_segment_intersection`); when no point is that far, the last one or,
    ``after_goal`` (``interpolate_curvature_after_goal``), the last segment projected
    past the path's end to the circle."""
    d = np.hypot(local[:, 0], local[:, 1])
    beyond = np.nonzero(d >= lookahead)[0]
    if not len(beyond):
        if after_goal and len(local) > 1:
            last, before = local[-1], local[-2]
            heading = math.atan2(last[1] - before[1], last[0] - before[0])
            projected = last + lookahead * np.array([math.cos(heading), math.sin(heading)])
            return circle_segment_intersection(last, projected, lookahead)
        return local[-1]
    k = int(beyond[0])
    if not interpolate or k == 0:
        return local[k]
    return circle_segment_intersection(local[k - 1], local[k], lookahead)


def velocity_sign_change(local: np.ndarray) -> float:
    """RPP's ``findVelocitySignChange``: the distance from the robot to the first cusp of
    the path ``local`` (robot frame; where it turns back: the dot product of two
    consecutive segments negative), or the largest float when it has none. (The plans
    here carry no orientations: overlapping poses of different headings are not cusps.)"""
    seg = np.diff(local, axis=0)
    for k in range(1, len(local) - 1):
        if float(seg[k - 1] @ seg[k]) < 0.0:
            return float(math.hypot(*local[k]))
    return sys.float_info.max


def within_costmap(local: np.ndarray, costmap: Costmap) -> np.ndarray:
    """``transformGlobalPlan``'s cut: the path ``local`` (robot frame) up to its first
    point farther from the robot than half the costmap's larger side."""
    extent = max(costmap.costs.shape) * costmap.resolution / 2.0
    far = np.nonzero(np.hypot(local[:, 0], local[:, 1]) > extent)[0]
    return local[: int(far[0])] if len(far) else local


def transform_global_plan(path: np.ndarray, start: int, pose, search_dist: float, costmap):
    """RPP's ``transformGlobalPlan``: (the index the plan is pruned to, the plan from it in
    the robot's frame up to the costmap's extent; empty when even its nearest point is
    beyond). The navigator keeps the index; :func:`rpp_command` makes the cut."""
    index = prune(path, start, pose, search_dist)
    return index, within_costmap(to_robot(path[index:], pose), costmap)


def lookahead_distance(p: RppParameters, speed_x: float) -> float:
    """RPP's ``getLookAheadDistance``: ``lookahead_dist``, or (velocity-scaled)
    ``|v| lookahead_time`` within ``[min_lookahead_dist, max_lookahead_dist]``."""
    if not p.use_velocity_scaled_lookahead_dist:
        return p.lookahead_dist
    return min(max(abs(speed_x) * p.lookahead_time, p.min_lookahead_dist), p.max_lookahead_dist)


def angle_to_path(target, sign: float = 1.0) -> float:
    """RPP's ``shouldRotateToPath`` angle: the carrot's bearing (reversing: from behind)."""
    angle = math.atan2(target[1], target[0])
    return wrap(angle + math.pi) if sign < 0.0 else angle


def speed_limited(p: RppParameters, speed_limit: float, percentage: bool) -> RppParameters:
    """RPP's ``setSpeedLimit``: ``desired_linear_vel`` under a speed limit (a costmap speed
    filter's ``speed_limit_topic``): ``speed_limit`` percent of it (``percentage``) or
    ``speed_limit`` m/s; ``NO_SPEED_LIMIT`` (0) keeps it."""
    if speed_limit == NO_SPEED_LIMIT:
        return p
    desired = p.desired_linear_vel * speed_limit / 100.0 if percentage else speed_limit
    return dc.replace(p, desired_linear_vel=desired)


@dc.dataclass(frozen=True)
class Command:
    """The follower's output and what it decided."""

    linear: float
    angular: float
    rotating_to_goal: bool = False
    collision: bool = False


def rotate_to_heading(angle: float, current_w: float, p: RppParameters, dt: float) -> float:
    """RPP's ``rotateToHeading``: ``rotate_to_heading_angular_vel`` toward ``angle``,
    within ``max_angular_accel`` of ``current_w`` over ``dt``, then at most the speed that
    stops on the heading, ``sqrt(2 max_angular_accel |angle|)`` (at 1.8 rad/s and 0.1 rad:
    0.8 rad/s)."""
    sign = 1.0 if angle > 0.0 else -1.0
    step = p.max_angular_accel * dt
    w = min(max(sign * p.rotate_to_heading_angular_vel, current_w - step), current_w + step)
    stop = math.sqrt(2.0 * p.max_angular_accel * abs(angle))
    return sign * stop if abs(w) > stop else w


def _cost_at(costmap: Costmap, x: float, y: float) -> int:
    row, col = costmap.world_to_cell(x, y)
    if not costmap.contains(row, col):
        return NO_INFORMATION
    return int(costmap.costs[row, col])


def _collision_ahead(costmap, pose, v, w, carrot_dist, p: RppParameters) -> bool:
    """isCollisionImminent: the arc of (v, w) from ``pose``, in steps of a cell, up to
    the carrot and the allowed time, through a cell of inscribed cost or more."""
    if _cost_at(costmap, pose[0], pose[1]) in (INSCRIBED_INFLATED_OBSTACLE, 254):
        return True
    speed = abs(v) if abs(v) > 0.01 else abs(w) * 0.2
    if speed <= 0:
        return False
    dt = costmap.resolution / speed
    n = int(p.max_allowed_time_to_collision_up_to_carrot / dt)
    t = dt * np.arange(1, n + 1)
    theta = pose[2] + w * t
    if abs(w) > 1e-9:
        x = pose[0] + v / w * (np.sin(theta) - math.sin(pose[2]))
        y = pose[1] - v / w * (np.cos(theta) - math.cos(pose[2]))
    else:
        x = pose[0] + v * t * math.cos(pose[2])
        y = pose[1] + v * t * math.sin(pose[2])
    keep = np.hypot(x - pose[0], y - pose[1]) <= carrot_dist
    for xi, yi in zip(x[keep], y[keep], strict=True):
        cost = _cost_at(costmap, xi, yi)
        if INSCRIBED_INFLATED_OBSTACLE <= cost < NO_INFORMATION:
            return True
    return False


def regulate(
    p: RppParameters, linear: float, curvature: float, cost: int, local: np.ndarray, inscribed
) -> float:
    """RPP's ``applyConstraints`` on the speed ``linear``: regulated by curvature (below
    ``regulated_linear_scaling_min_radius``) and by the cost under the robot (the
    obstacle distance that cost means in the inflation, ``log(253 / cost)``), not below
    ``regulated_linear_scaling_min_speed``; then, once the length of the path ``local``
    (robot frame) is under ``approach_velocity_scaling_dist``, scaled by the straight-line
    distance to its end over that distance (not below ``min_approach_linear_velocity``); at most
    ``desired_linear_vel`` (unsigned)."""
    curvature_vel = cost_vel = linear
    radius = abs(1.0 / curvature) if curvature != 0.0 else math.inf
    if p.use_regulated_linear_velocity_scaling and radius < p.regulated_linear_scaling_min_radius:
        curvature_vel *= 1.0 - abs(radius - p.regulated_linear_scaling_min_radius) / (
            p.regulated_linear_scaling_min_radius
        )
    if p.use_cost_regulated_linear_velocity_scaling and cost not in (NO_INFORMATION, 0):
        k = p.inflation_cost_scaling_factor
        distance = (k * inscribed - math.log(cost) + math.log(253.0)) / k
        if distance < p.cost_scaling_dist:
            cost_vel *= p.cost_scaling_gain * distance / p.cost_scaling_dist
    linear = max(min(curvature_vel, cost_vel), p.regulated_linear_scaling_min_speed)
    # approachVelocityScalingFactor: the path's length decides when, the straight-line
    # distance to its end how much.
    length = float(np.linalg.norm(np.diff(local, axis=0), axis=1).sum())
    if length < p.approach_velocity_scaling_dist:
        scale = math.hypot(*local[-1]) / p.approach_velocity_scaling_dist
        linear = min(linear, max(linear * scale, p.min_approach_linear_velocity))
    return min(abs(linear), p.desired_linear_vel)


def rpp_command(
    params: ControllerParameters,
    costmap: Costmap,
    local: np.ndarray,
    pose,
    speed: tuple[float, float],
    goal,
    *,
    rotating_to_goal: bool,
    inscribed_radius: float,
) -> Command:
    """RegulatedPurePursuitController::computeVelocityCommands for the robot at ``pose``
    (x, y, yaw) moving at ``speed`` (v, w; thresholded), on the pruned path ``local``
    (robot frame, nearest point first), toward ``goal`` (x, y, yaw)."""
    p = params.rpp
    dt = 1.0 / params.controller_frequency
    v0, w0 = speed
    local = within_costmap(local, costmap)
    if not len(local):  # Nav2: "Resulting plan has 0 poses in it": no valid control
        return Command(0.0, 0.0, collision=True)
    lookahead = lookahead_distance(p, v0)
    bend_dist = p.curvature_lookahead_dist
    if p.allow_reversing:  # a cusp nearer than the look-ahead: the carrot at the cusp
        cusp = velocity_sign_change(local)
        lookahead, bend_dist = min(lookahead, cusp), min(bend_dist, cusp)
    target = carrot(local, lookahead, p.use_interpolation)
    bend = target
    if p.use_fixed_curvature_lookahead:
        after_goal = p.interpolate_curvature_after_goal
        bend = carrot(local, bend_dist, p.use_interpolation, after_goal)
    dist2 = float(bend @ bend)
    curvature = 2.0 * bend[1] / dist2 if dist2 > 0.001 else 0.0
    to_goal = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
    sign = -1.0 if p.allow_reversing and target[0] < 0.0 else 1.0
    rotating_to_goal = p.use_rotate_to_heading and (
        (p.stateful and rotating_to_goal) or to_goal < params.xy_goal_tolerance
    )
    if rotating_to_goal:
        w = rotate_to_heading(wrap(goal[2] - pose[2]), w0, p, dt)
        return Command(0.0, w, rotating_to_goal=True)
    angle = angle_to_path(bend, sign)
    if p.use_rotate_to_heading and abs(angle) > p.rotate_to_heading_min_angle:
        w = rotate_to_heading(angle, w0, p, dt)
        v = 0.0
    else:
        cost = _cost_at(costmap, pose[0], pose[1])
        v = sign * regulate(p, p.desired_linear_vel, curvature, cost, local, inscribed_radius)
        w = v * curvature
    carrot_dist = float(math.hypot(*target))
    if p.use_collision_detection and _collision_ahead(costmap, pose, v, w, carrot_dist, p):
        return Command(0.0, 0.0, collision=True)
    return Command(v, w)


@CONTROLLERS.register(RPP, instead="Regulated Pure Pursuit follows instead")
class RegulatedPurePursuit:
    """nav2_regulated_pure_pursuit_controller: :func:`rpp_command` on its parameters."""

    Parameters = RppParameters
    command = staticmethod(rpp_command)


# Controllers Nav2 ships that are not implemented here: Regulated Pure Pursuit follows
# instead, with their parameters of the same meaning (RPP's name: theirs).
CONTROLLERS.substitute(
    "dwb_core::DWBLocalPlanner",
    RPP,
    {
        "desired_linear_vel": "max_vel_x",
        "rotate_to_heading_angular_vel": "max_vel_theta",
        "max_angular_accel": "acc_lim_theta",
    },
)
CONTROLLERS.substitute(
    "nav2_mppi_controller::MPPIController",
    RPP,
    {
        "desired_linear_vel": "vx_max",
        "rotate_to_heading_angular_vel": "wz_max",
        "max_angular_accel": "az_max",
    },
)


# ---------------------------------------------------------------------------- the checkers


def goal_reached(c: ControllerParameters, goal, pose, speed, xy_reached: bool):
    """SimpleGoalChecker (StoppedGoalChecker: and stopped) of ``goal`` at ``pose`` moving
    at ``speed``: (reached, the stateful checker's position latch)."""
    if not (c.goal_stateful and xy_reached):
        if math.hypot(pose[0] - goal.x, pose[1] - goal.y) > c.xy_goal_tolerance:
            return False, xy_reached
        if c.goal_stateful:
            xy_reached = True
    if abs(wrap(pose[2] - goal.yaw)) > c.yaw_goal_tolerance:
        return False, xy_reached
    if c.stopped_goal_checker and (
        abs(speed[0]) > c.trans_stopped_velocity or abs(speed[1]) > c.rot_stopped_velocity
    ):
        return False, xy_reached
    return True, xy_reached


def progress(c: ControllerParameters, baseline: tuple, pose, now: float):
    """SimpleProgressChecker / PoseProgressChecker from ``baseline`` (x, y, yaw, time):
    (progressing, the new baseline)."""
    x, y, yaw, since = baseline
    moved = math.hypot(pose[0] - x, pose[1] - y) > c.required_movement_radius
    turned = abs(wrap(pose[2] - yaw)) > c.required_movement_angle
    if moved or turned:
        return True, (*pose, now)
    return now - since <= c.movement_time_allowance, baseline
