"""A run's chapter figures on the terminal, from the same summary ``summary.json`` holds.

Each kind of scenario prints the numbers its chapter is about, one line each, after the
run's headline:

=================  =======================================================================
``base:``          a mobile base's final pose, the distance it drove, its odometry drift
``goals:``         a navigation's goals reached, their largest errors, the collisions
``AMCL:``          the localisation error over time (its first estimate, its largest once
                   settled, the last); ``SLAM:`` an exploration's
``map:``           the map an exploration built against the world's (precision, recall,
                   coverage), its frontiers, SLAM's pose error against odometry's
``perception:``    the planes and clusters of the last point cloud
``tool points:``   in a world of several arms, how far apart their tool points ended
=================  =======================================================================
"""

from __future__ import annotations

import itertools
import math
from typing import Any

from armando_drake.outputs.logger import rounded


def chapter_lines(summary: dict[str, Any]) -> list[str]:
    """The chapter figures of a run's ``summary`` (the dictionary of summary.json)."""
    lines = []
    robots = summary.get("robots") or {}
    bases = {name: robot["base"] for name, robot in robots.items() if robot.get("base")}
    if summary.get("base") and not bases:  # of several robots, each its own line
        lines.append(base_line(summary["base"]))
    lines += [base_line(base, name) for name, base in bases.items()]
    navigation = summary.get("navigation") or {}
    if navigation.get("mapping"):
        lines.append(mapping_line(navigation["mapping"]))
    elif navigation.get("goals"):
        lines.append(goals_line(navigation))
    localization = navigation.get("localization") or {}
    if localization.get("errors"):
        lines.append(localization_line(localization))
    if summary.get("perception"):
        lines.append(perception_line(summary["perception"]))
    meeting = end_effectors_line(summary.get("robots") or {})
    if meeting:
        lines.append(meeting)
    return lines


def base_line(base: dict[str, Any], name: str = "") -> str:
    """``base: at (x, y) m, yaw ... rad after ... m driven; odometry drift ...``."""
    pose, drift = base["final_pose"], base.get("odometry_drift") or {}
    travelled = base.get("distance_travelled") or 0.0
    text = (
        f"base{f' {name}' if name else ''}: "
        f"at ({rounded(pose['x']):.3f}, {rounded(pose['y']):.3f}) m, "
        f"yaw {rounded(pose['yaw']):.3f} rad, after {travelled:.2f} m driven"
    )
    if drift.get("final_position") is not None:
        text += f"; odometry drift {drift['final_position']:.3f} m"
        if travelled > 0.05:
            text += f" ({100 * drift['final_position'] / travelled:.1f} % of the distance)"
        text += f", heading {rounded(drift['final_heading']):.3f} rad"
    return text


def goals_line(navigation: dict[str, Any]) -> str:
    """``goals: 4/4 reached, largest errors ... m and ... rad, 0 collisions``."""
    goals = navigation["goals"]
    reached = [goal for goal in goals if goal.get("reached")]
    text = f"goals: {len(reached)}/{len(goals)} reached"
    if reached:
        position = max(goal["position_error"] for goal in reached)
        yaw = max(goal["yaw_error"] for goal in reached)
        text += f", largest errors {position:.3f} m and {yaw:.3f} rad"
    missed = [goal["name"] for goal in goals if not goal.get("reached")]
    if missed:
        text += f", not reached: {', '.join(missed)}"
    return text + f", {navigation.get('collisions', 0)} collisions"


def localization_line(localization: dict[str, Any]) -> str:
    """``AMCL: position error ... m at its first estimate (t s), at most ... m from t s on
    (yaw ... rad), ... m at the end`` (``SLAM:`` for an exploration's)."""
    errors = localization["errors"]
    first, last = errors[0], errors[-1]
    text = f"{localization['method'].upper()}: position error {first['position']:.3f} m at "
    text += f"its first estimate ({first['time']:.1f} s)"
    if localization.get("max_position_error_settled") is not None:
        since = first["time"] + localization["settle_time"]
        text += (
            f", at most {localization['max_position_error_settled']:.3f} m from {since:.1f} s "
            f"on (yaw {localization['max_yaw_error_settled']:.3f} rad)"
        )
    return text + f", {last['position']:.3f} m at the end"


def mapping_line(mapping: dict[str, Any]) -> str:
    """``map: precision ..., recall ..., coverage ...; frontiers; SLAM's pose error``."""
    text = (
        f"map: precision {mapping['precision']:.3f}, recall {mapping['recall']:.3f}, "
        f"coverage {mapping['coverage']:.3f} of the world's free area; "
        f"{mapping.get('frontier_goals', 0)} frontiers visited, "
        f"{mapping.get('frontiers_left', 0)} left"
    )
    if mapping.get("done_at") is not None:
        text += f", done at {mapping['done_at']:.1f} s"
    if mapping.get("slam_position_error") is not None:
        text += (
            f"; pose error {mapping['slam_position_error']:.3f} m with SLAM, "
            f"{mapping['odometry_position_error']:.3f} m on odometry alone"
        )
    return text


def perception_line(perception: dict[str, Any]) -> str:
    """``perception: plane ... (n points); k clusters: ...``."""
    if not perception.get("computed"):
        return "perception: no point cloud processed yet"
    parts = []
    for plane in perception["planes"]:
        a, b, c, d = plane["coefficients"]
        parts.append(
            f"plane {rounded(a):+.3f} x {rounded(b):+.3f} y {rounded(c):+.3f} z "
            f"{rounded(d):+.3f} = 0 ({plane['inliers']} points)"
        )
    clusters = perception["clusters"]
    found = f"{len(clusters)} cluster{'s' if len(clusters) != 1 else ''}"
    if clusters:
        found += ": " + ", ".join(
            f"{c['count']} points at ({', '.join(f'{rounded(v):.3f}' for v in c['centroid'])}) m"
            for c in clusters
        )
    parts.append(found)
    return f"perception ({perception['frame']} frame, t={perception['time']:.2f} s): " + "; ".join(
        parts
    )


def end_effectors_line(robots: dict[str, Any]) -> str:
    """``tool points: left's (crawer_base) and right's (crawer_base) 0.3 mm apart`` for
    each pair of arms (empty with fewer than two)."""
    arms = {n: r["end_effector"] for n, r in robots.items() if r.get("end_effector")}
    pairs = []
    for (a, ea), (b, eb) in itertools.combinations(arms.items(), 2):
        distance = math.dist(ea["position"], eb["position"])
        apart = f"{distance * 1e3:.1f} mm" if distance < 0.1 else f"{distance:.3f} m"
        pairs.append(f"{a}'s ({ea['frame']}) and {b}'s ({eb['frame']}) {apart} apart")
    return "tool points: " + "; ".join(pairs) if pairs else ""
