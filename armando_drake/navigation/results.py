"""A navigation's results: each goal's (:class:`GoalResult`), and summary.json's
``navigation`` section made of them (:func:`navigation_summary`).

The navigator's state (:class:`~.navigator.NavState`) holds the results of the goals
finished; :func:`goal_results` adds those not finished at a given time ("not reached").
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import Any

from armando_drake.navigation.follower import ControllerParameters, wrap


@dc.dataclass(frozen=True)
class GoalResult:
    """How a goal went."""

    name: str
    reached: bool
    reason: str  # "reached", "no progress", "collision ahead", "no plan", "not reached",
    # "canceled" (a new task preempted it, or a cancel)
    start: float  # [s] when the goal was sent
    end: float  # [s] when it was reached or given up (nan: still running)
    pose: tuple[float, float, float]  # (x, y, yaw) then
    position_error: float  # [m]
    yaw_error: float  # [rad]
    path_length: float  # [m] driven
    plan_length: float  # [m] the first plan's
    recoveries: tuple = ()  # (behaviour, start [s], end [s]) of each recovery run
    blocked_replans: int = 0  # replans made while the current plan crossed an obstacle
    first_plan: Any = None  # the first plan (n, 2), or None

    @property
    def status(self) -> str:
        """NavigateToPose's result: succeeded, canceled or aborted; or unfinished (the
        run ended first, or the goal is not sent yet)."""
        if self.reached:
            return "succeeded"
        return {"canceled": "canceled", "not reached": "unfinished"}.get(self.reason, "aborted")


def goal_results(nav, now: float) -> list[GoalResult]:
    """Every goal's result of the navigator's state ``nav`` at ``now`` (those not finished:
    not reached)."""
    results = list(nav.results)
    pose = nav.last_pose or (math.nan,) * 3
    for index in range(len(results), len(nav.goals)):
        goal = nav.goals[index]
        current = index == nav.goal
        results.append(
            GoalResult(
                name=goal.name,
                reached=False,
                reason="not reached",
                start=nav.started if current else math.nan,
                end=now if current else math.nan,
                pose=tuple(pose),
                position_error=math.hypot(pose[0] - goal.x, pose[1] - goal.y),
                yaw_error=abs(wrap(pose[2] - goal.yaw)),
                path_length=nav.driven if current else 0.0,
                plan_length=nav.plan_length if current else 0.0,
                recoveries=nav.recoveries if current else (),
                blocked_replans=nav.blocked_replans if current else 0,
            )
        )
    return results


def _goal_summary(r: GoalResult, g) -> dict[str, Any]:
    return {
        "name": r.name,
        "goal": [g.x, g.y, g.yaw],
        "reached": r.reached,
        "status": r.status,
        "reason": r.reason,
        "blocked_replans": r.blocked_replans,
        "recoveries": [{"behavior": k, "start": t0, "end": t1} for k, t0, t1 in r.recoveries],
        "position_error": r.position_error,
        "yaw_error": r.yaw_error,
        "time": r.end - r.start if r.reached else None,
        "reached_at": r.end if r.reached else None,
        "path_length": r.path_length,
        "plan_length": r.plan_length,
        "pose": list(r.pose),
    }


def navigation_summary(
    nav, now: float, controller: ControllerParameters, localized: str = ""
) -> dict[str, Any]:
    """``summary.json``'s ``navigation`` section of the state ``nav`` at ``now`` (the
    collisions are added by the run); with a localization (``localized``: ``amcl`` or
    ``slam``; "" for the ground truth) its errors too."""
    results = goal_results(nav, now)
    summary = {
        "goals": [_goal_summary(r, g) for r, g in zip(results, nav.goals, strict=True)],
        "reached": sum(r.reached for r in results),
        "xy_goal_tolerance": controller.xy_goal_tolerance,
        "yaw_goal_tolerance": controller.yaw_goal_tolerance,
    }
    if localized:
        summary["localization"] = localization_summary(nav, method=localized)
    return summary


def localization_summary(nav, settle: float = 5.0, method: str = "amcl") -> dict[str, Any]:
    """The localization's (``method``'s) errors against the ground truth: each second's,
    the last, and the largest from ``settle`` [s] after the navigation started on."""
    samples = nav.localization
    after = [s for s in samples if samples and s[0] >= samples[0][0] + settle]
    return {
        "method": method,
        "errors": [{"time": t, "position": e, "yaw": y} for t, e, y in samples],
        "final_position_error": samples[-1][1] if samples else None,
        "final_yaw_error": samples[-1][2] if samples else None,
        "settle_time": settle,
        "max_position_error_settled": max((s[1] for s in after), default=None),
        "max_yaw_error_settled": max((s[2] for s in after), default=None),
    }
