"""Navigation to goals as a Drake system: NavigateToPose's plan, follow, check, in order.

:func:`~.building.AddNavigation` composes it from the Nav2 file's servers: the planner
plugin, the controller server's parameters and controller plugin, the costmaps (the
static one on the map; with obstacle layers, those the scans update: :mod:`.layers`) and
the behaviour server's recoveries.

:class:`Navigator` is one discrete update at ``controller_frequency``, as Nav2's
controller server's loop: the pose from the localization (the ground truth: the
plant's state), the planner's plan (NavFn) on a new goal and at ``expected_planner_frequency`` (the
default behaviour tree replans at 1 Hz), the controller plugin on it (Regulated Pure
Pursuit: :mod:`.follower`), the goal checker (``xy_goal_tolerance`` then, stateful, the
``yaw_goal_tolerance``) and the progress checker (``required_movement_radius`` within
``movement_time_allowance``, else the goal is aborted); the goals in the chosen order.
Between updates nothing runs in Python. Its state is an immutable :class:`NavState`
(Drake's copy of it is free).
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, LeafSystem

from armando_drake.control.manager import planar_base
from armando_drake.messages.types import Odometry, PublicationValue, Twist, TwistStamped
from armando_drake.navigation.behaviors import (
    CLEAR,
    BehaviorParameters,
    Recovery,
    recovery_command,
)
from armando_drake.navigation.config import NavigationGoal
from armando_drake.navigation.cost_values import INSCRIBED_INFLATED_OBSTACLE
from armando_drake.navigation.costmap import Costmap, blocked_behind, path_blocked
from armando_drake.navigation.follower import (
    ControllerParameters,
    goal_reached,
    progress,
    prune,
    to_robot,
    wrap,
)
from armando_drake.navigation.layers import Layers, observe_layers
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.planner import PlanningError, path_length, plan_heading
from armando_drake.navigation.pose_buffer import RobotPoses, compose
from armando_drake.navigation.registry import CONTROLLERS
from armando_drake.navigation.results import GoalResult, navigation_summary

_log = logging.getLogger("armando_drake.navigation")


# The robot's body frames a goal may be given in (its current pose).
BASE_FRAMES = ("base_link", "base_footprint")


def goal_in_map(goal: NavigationGoal, frame_id: str, map_to_odom, base_pose) -> NavigationGoal:
    """``goal`` given in ``frame_id`` as a map goal: ``map`` (or ``world``, or none),
    ``odom`` (through ``map_to_odom``, (x, y, yaw)), ``base_link`` / ``base_footprint``
    (``base_pose()``: the robot's pose on the map at the goal's stamp). :class:`ValueError`
    naming an unknown frame."""
    frame = frame_id.strip("/").rpartition("/")[2]  # a robot's namespace dropped
    if frame in ("", "map", "world"):
        return goal
    if frame == "odom":
        offset = map_to_odom
    elif frame in BASE_FRAMES:
        offset = base_pose()
    else:
        known = ", ".join(["map", "odom", *BASE_FRAMES])
        raise ValueError(f"goal frame {frame_id!r} is unknown (known: {known})")
    x, y, yaw = compose(tuple(offset), (goal.x, goal.y, goal.yaw))
    return dc.replace(goal, x=x, y=y, yaw=yaw)


@dc.dataclass(frozen=True)
class FramedGoal:
    """A goal as a message gives it: in the frame ``frame_id`` (map, odom, base_link...)
    at ``stamp`` [s] (0: the latest, as tf2 reads a zero stamp)."""

    goal: NavigationGoal
    frame_id: str = "map"
    stamp: float = 0.0


@dc.dataclass(frozen=True)
class NavState:
    """The navigator's state; never mutated (a new one at each update)."""

    goal: int = -1  # index of the current goal in the visits (-1: not started)
    path: Any = None  # the current plan (n, 2), or None
    path_index: int = 0  # the nearest point of the path so far
    planned_at: float = -math.inf
    started: float = math.nan
    xy_reached: bool = False  # the stateful goal checker's latch
    rotating_to_goal: bool = False  # RPP's stateful rotation to the goal's heading
    baseline: tuple = ()  # the progress checker's (x, y, yaw, time)
    failing_since: float = math.nan  # the controller's first failure in a row
    last_pose: tuple = ()  # the ground truth's (x, y, yaw): the results are measured on it
    driven: float = 0.0  # [m] path length so far on this goal
    plan_length: float = 0.0
    results: tuple = ()
    # The goals sent so far, in order (results[k] is goals[k]'s): the scenario's, then
    # each task's (a /goal_pose, the commander's); a new task drops the pending ones.
    goals: tuple = ()
    task_start: int = 0  # the index of the current task's first goal
    pending: Any = None  # a task the commander requested (a tuple of goals; () cancels)
    received: int = 0  # the goal_pose publications taken so far
    updates: int = 0  # the goal_update publications taken so far
    rejected: int = 0  # the goal_pose messages refused (a frame the world does not know)
    # With AMCL: (time, position error [m], yaw error [rad]) of the estimate against the
    # ground truth, each second.
    localization: tuple = ()
    estimate: tuple = ()  # the localization's (x, y, yaw) at the last update
    explore: Any = None  # the exploration's own state (navigation/explore.py)
    # With an obstacle layer: per costmap (global, local) its layer's grid and the
    # layered costmap, and when they were last updated.
    obstacles: tuple = ()
    costmaps: tuple = ()
    observed_at: tuple = ()
    # The recovery running (behaviors.Recovery) or None; the retries of the current goal
    # and its recoveries so far ((behaviour, start, end), ...).
    recovery: Any = None
    retries: int = 0
    recoveries: tuple = ()
    blocked_replans: int = 0
    first_plan: Any = None

    def __deepcopy__(self, memo):
        return self


class Navigator(LeafSystem):
    """NavigateToPose over a list of goals, with NavFn and Regulated Pure Pursuit.

    .. pydrake_system::

        name: Navigator
        input_ports:
        - state
        - poses
        - goal_pose (optional)
        - goal_update (optional)
        output_ports:
        - cmd_vel
        - command
        - nav_state

    - ``state``: the robot model instance's state (its floating base's pose and twist);
    - ``poses``: the robot's :class:`~.pose_buffer.RobotPoses` (a scan's or a goal's pose
      at its stamp, the controller's pose now);
    - ``goal_pose``: a Publication of a NavigationGoal (or a tuple of them): each new one
      is a task that preempts the current one (RViz's 2D goal on ``/goal_pose``);
    - ``goal_update``: a Publication of a NavigationGoal that replaces the current goal
      in its task (Nav2's ``GoalUpdater`` on ``goal_update``): replanned, no new result;
    - with AMCL, ``odom`` (the drive's Odometry) and ``map_to_odom`` (x, y, yaw) too;
    - ``cmd_vel``: a Publication of TwistStamped (``frame_id`` ``base_link``);
    - ``command``: vector (linear [m/s], angular [rad/s]) of the latest message;
    - ``nav_state``: the :class:`NavState` (the plan, the goals, the results).

    :meth:`request` and :meth:`cancel` send a task from a script between two steps of the
    simulator (:mod:`armando_drake.simulation.commander`).
    """

    LOCALIZATION = "amcl"  # summary.json's localization method (without the ground truth)

    def __init__(
        self,
        goals: list[NavigationGoal],
        costmap: Costmap,
        controller: ControllerParameters,
        planner,
        *,
        state_size: int,
        base_rows: tuple[list[int], list[int]],
        inscribed_radius: float,
        footprint: tuple = (),
        start_delay: float = 0.0,
        grid: OccupancyMap | None = None,
        odometry: bool = False,
        layers: Layers | None = None,
        behaviors: BehaviorParameters | None = None,
    ):
        super().__init__()
        self.layers = layers
        self.behaviors = behaviors
        self.goals = list(goals)
        self.costmap = costmap
        self.grid = grid
        self.controller = controller
        self.planner = planner  # the planner plugin (planner.plan(costmap, start, goal))
        self._follow = CONTROLLERS.lookup(controller.plugin, "controller_server").cls
        self._inscribed = inscribed_radius
        self._footprint = footprint  # the padded footprint polygon (the collision checker's)
        self._q_rows, self._v_rows = base_rows
        self._state = self.DeclareVectorInputPort("state", state_size)
        self._poses = self.DeclareAbstractInputPort("poses", AbstractValue.Make(RobotPoses()))
        self._localized = odometry  # False: the ground truth; True: map -> odom, then odometry
        if odometry:
            self._odom = self.DeclareAbstractInputPort("odom", AbstractValue.Make(Odometry()))
            self._map_to_odom = self.DeclareVectorInputPort("map_to_odom", 3)
        self._nav = self.DeclareAbstractState(AbstractValue.Make(NavState(goals=tuple(goals))))
        self._goal_pose = self.DeclareAbstractInputPort("goal_pose", PublicationValue())
        self._goal_update = self.DeclareAbstractInputPort("goal_update", PublicationValue())
        if layers is not None:
            self._scan = self.DeclareAbstractInputPort("scan", PublicationValue())
        self._topic = self.DeclareAbstractState(PublicationValue())
        self._command = self.DeclareDiscreteState(BasicVector(np.zeros(2)))
        self.DeclareStateOutputPort("cmd_vel", self._topic)
        self.DeclareStateOutputPort("command", self._command)
        self.DeclareStateOutputPort("nav_state", self._nav)
        period = 1.0 / controller.controller_frequency
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, start_delay, self._Update)

    # -- the loop

    def _truth(self, context) -> tuple[float, float, float, float, float]:
        x = self._state.Eval(context)
        return planar_base(x[self._q_rows], x[self._v_rows])

    def _pose_at(self, context, stamp: float) -> tuple[float, float, float]:
        """The localization's pose (x, y, yaw) at ``stamp`` (the pose buffer's: the ground
        truth, or AMCL's map -> odom then the odometry)."""
        map_to_odom = None if not self._localized else self._map_to_odom.Eval(context)
        return self._poses.Eval(context).map_pose(stamp, map_to_odom)

    def _pose(self, context):
        """The localization's pose (x, y, yaw) now and the measured twist (v, w)."""
        px, py, yaw = self._pose_at(context, context.get_time())
        if not self._localized:
            v, w = self._truth(context)[3:]
        else:  # the odometry's twist
            message = self._odom.Eval(context)
            v, w = message.linear[0], message.angular[2]
        c = self.controller
        v = 0.0 if abs(v) < c.min_x_velocity_threshold else v
        w = 0.0 if abs(w) < c.min_theta_velocity_threshold else w
        return (px, py, yaw), (v, w)

    def _Update(self, context, state) -> None:
        now = context.get_time()
        nav = context.get_abstract_state(self._nav).get_value()
        pose, speed = self._pose(context)
        truth = self._truth(context)[:3]
        if nav.last_pose:
            step = math.hypot(truth[0] - nav.last_pose[0], truth[1] - nav.last_pose[1])
            nav = dc.replace(nav, driven=nav.driven + step)
        nav = dc.replace(nav, last_pose=truth, estimate=tuple(pose))
        if self.layers is not None and self._scan.HasValue(context):
            nav = self._observe(context, nav, self._scan.Eval(context).message, now)
        if self._localized and (
            not nav.localization or now - nav.localization[-1][0] >= 1.0 - 1e-9
        ):
            error = math.hypot(pose[0] - truth[0], pose[1] - truth[1])
            sample = (now, error, abs(wrap(pose[2] - truth[2])))
            nav = dc.replace(nav, localization=(*nav.localization, sample))
        nav, linear, angular = self._advance(context, nav, pose, speed, now)
        state.get_mutable_abstract_state(self._nav).set_value(nav)
        message = TwistStamped(
            stamp=now,
            frame_id="base_link",
            twist=Twist(linear=(linear, 0.0, 0.0), angular=(0.0, 0.0, angular)),
        )
        publication = context.get_abstract_state(self._topic).get_value()
        state.get_mutable_abstract_state(self._topic).set_value(publication.publish(message, now))
        state.get_mutable_discrete_state(self._command).set_value([linear, angular])

    def _advance(self, context, nav: NavState, pose, speed, now: float):
        """One cycle on the goals (a task requested taken first): (state, v, w)."""
        nav, task = self._requested(context, nav)
        if task is not None:
            nav = self._new_task(nav, task, pose, now)
        if self._goal_update.HasValue(context):
            nav = goal_updated(nav, self._goal_update.Eval(context))
        if nav.goal < 0:
            nav = self._start(nav, 0, pose, now)
        if 0 <= nav.goal < len(nav.goals):
            return self._step(nav, pose, speed, now)
        return nav, 0.0, 0.0

    def _costmap(self, nav: NavState) -> Costmap:
        """The costmap the current goal is planned on (the global one)."""
        return nav.costmaps[0] if nav.costmaps and nav.costmaps[0] is not None else self.costmap

    def _local(self, nav: NavState) -> Costmap:
        """The costmap the controller checks its motion on (the local one, if any)."""
        if len(nav.costmaps) > 1 and nav.costmaps[1] is not None:
            return nav.costmaps[1]
        return self._costmap(nav)

    def _observe(self, context, nav: NavState, scan, now: float) -> NavState:
        """The costmaps' obstacle layers after ``scan`` (:mod:`.layers`), seen from the
        pose at its stamp."""
        if scan is None or self.grid is None:
            return nav
        pose = self._pose_at(context, scan.stamp)
        return observe_layers(nav, self.layers, self.grid, self.costmap, scan, pose, now)

    # -- tasks

    def request(self, context, goals) -> None:
        """Sends the task ``goals`` (NavigationGoals; () cancels) in ``context`` (this
        system's): taken at the next update, it preempts the current task."""
        nav = context.get_abstract_state(self._nav).get_value()
        context.SetAbstractState(self._nav, dc.replace(nav, pending=tuple(goals)))

    def cancel(self, context) -> None:
        """Cancels the current task at the next update (the base is stopped)."""
        self.request(context, ())

    def nav_state(self, context) -> NavState:
        """The state in ``context`` (this system's)."""
        return context.get_abstract_state(self._nav).get_value()

    def goal_in_map(
        self, context, goal: NavigationGoal, frame_id: str, stamp: float = 0.0
    ) -> NavigationGoal:
        """``goal`` in ``frame_id`` at ``stamp`` (0: now) as a map goal at ``context``
        (:func:`goal_in_map`; a base frame's pose at the stamp, from the pose buffer)."""
        odom = (0.0, 0.0, 0.0) if not self._localized else tuple(self._map_to_odom.Eval(context))
        at = stamp if stamp > 0.0 else context.get_time()
        return goal_in_map(goal, frame_id, odom, lambda: self._pose_at(context, at))

    def _requested(self, context, nav: NavState):
        """(state, the task requested since the last update or None)."""
        if nav.pending is not None:
            return dc.replace(nav, pending=None), nav.pending
        if self._goal_pose.HasValue(context):
            publication = self._goal_pose.Eval(context)
            if publication.count > nav.received:
                message = publication.message
                task = tuple(message) if isinstance(message, (tuple, list)) else (message,)
                try:  # a goal in its header's frame at its stamp, to the map
                    task = tuple(self.goal_in_map(context, g.goal, g.frame_id, g.stamp)
                                 if isinstance(g, FramedGoal) else g for g in task)  # fmt: skip
                except ValueError as error:  # the current task goes on
                    _log.warning("goal_pose rejected: %s", error)
                    return dc.replace(
                        nav, received=publication.count, rejected=nav.rejected + 1
                    ), None
                return dc.replace(nav, received=publication.count), task
        return nav, None

    def _new_task(self, nav: NavState, task: tuple, pose, now: float) -> NavState:
        """The current goal canceled (if any), the pending ones dropped, ``task`` started."""
        if nav.goal < 0:  # before the first update: instead of the scenario's goals
            return dc.replace(nav, goals=task, task_start=0)
        if nav.goal < len(nav.goals):
            nav = self._finish(nav, pose, now, "canceled", then=False)
        kept = nav.goals[: len(nav.results)]
        start = len(kept) if task else nav.task_start  # a cancel ends the current task
        nav = dc.replace(nav, goals=kept + task, task_start=start)
        for goal in task:
            _log.info("task: goal %r (%.3f, %.3f, %.3f)", goal.name, goal.x, goal.y, goal.yaw)
        if not task:
            _log.info("task canceled at %.2f s", now)
        return self._start(nav, len(kept), pose, now)

    def _start(self, nav: NavState, index: int, pose, now: float) -> NavState:
        """The goal ``index`` sent: reset the checkers, plan."""
        nav = dc.replace(
            nav,
            goal=index,
            path=None,
            path_index=0,
            started=now,
            xy_reached=False,
            rotating_to_goal=False,
            baseline=(*pose, now),
            failing_since=math.nan,
            driven=0.0,
            plan_length=0.0,
            planned_at=-math.inf,
            recovery=None,
            retries=0,
            recoveries=(),
            blocked_replans=0,
            first_plan=None,
        )
        if index < len(nav.goals):
            goal = nav.goals[index]
            _log.info("goal %r sent: (%.3f, %.3f, %.3f)", goal.name, goal.x, goal.y, goal.yaw)
            nav = self._plan(nav, pose, now)
        return nav

    def _plan(self, nav: NavState, pose, now: float) -> NavState:
        goal = nav.goals[nav.goal]
        if nav.path is not None and self._blocked(nav):
            nav = dc.replace(nav, blocked_replans=nav.blocked_replans + 1)
        try:
            path = self.planner.plan(self._costmap(nav), pose[:2], (goal.x, goal.y))
        except PlanningError as error:
            _log.warning("goal %r: no plan: %s", goal.name, error)
            if self.behaviors is not None:  # the tree's ComputePathToPose fails
                return dc.replace(nav, path=None, planned_at=now)
            return nav if nav.path is not None else dc.replace(nav, planned_at=now)
        if np.hypot(path[-1, 0] - goal.x, path[-1, 1] - goal.y) <= self._costmap(nav).resolution:
            path = np.vstack([path[:-1], [goal.x, goal.y]])  # the goal's own pose ends it
        if len(path) == 1:
            path = np.vstack([path, path])
        length = nav.plan_length or path_length(path)
        first = path if nav.first_plan is None else nav.first_plan
        return dc.replace(
            nav, path=path, path_index=0, planned_at=now, plan_length=length, first_plan=first
        )

    def _blocked(self, nav: NavState) -> bool:
        """Whether the rest of the current plan crosses an obstacle of the costmap."""
        return path_blocked(self._costmap(nav), nav.path[nav.path_index :])

    def _finish(self, nav: NavState, pose, now: float, reason: str, then=True) -> NavState:
        """The goal's result (:func:`goal_result`); the next goal sent from ``pose`` (the
        localization's) if ``then``."""
        nav = dc.replace(nav, results=(*nav.results, goal_result(nav, now, reason)))
        return self._start(nav, nav.goal + 1, pose, now) if then else nav

    def _goal_reached(self, nav: NavState, pose, speed) -> tuple[bool, NavState]:
        """The goal checker (:func:`~.follower.goal_reached`)."""
        goal = nav.goals[nav.goal]
        reached, latch = goal_reached(self.controller, goal, pose, speed, nav.xy_reached)
        return reached, nav if latch == nav.xy_reached else dc.replace(nav, xy_reached=latch)

    def _progress(self, nav: NavState, pose, now: float) -> tuple[bool, NavState]:
        """The progress checker (:func:`~.follower.progress`)."""
        progressing, baseline = progress(self.controller, nav.baseline, pose, now)
        return progressing, dc.replace(nav, baseline=baseline)

    def _step(self, nav: NavState, pose, speed, now: float):
        """One cycle of the controller server on the current goal: (state, v, w)."""
        c = self.controller
        goal = nav.goals[nav.goal]
        if nav.recovery is not None:
            return self._recover(nav, pose, now)
        replan = c.expected_planner_frequency > 0 and (
            now - nav.planned_at >= 1.0 / c.expected_planner_frequency - 1e-9
        )
        if nav.path is None or (replan and not nav.xy_reached):
            nav = self._plan(nav, pose, now)
        if nav.path is None:
            return self._fail(nav, pose, now, "no plan")
        index = prune(nav.path, nav.path_index, pose, c.rpp.max_robot_pose_search_dist)
        nav = dc.replace(nav, path_index=index)
        local = to_robot(nav.path[index:], pose)
        command = self._follow.command(
            c,
            self._local(nav),
            local,
            pose,
            speed,
            (goal.x, goal.y, plan_heading(self.planner, nav.path, pose[2], goal.yaw)),
            rotating_to_goal=nav.rotating_to_goal,
            inscribed_radius=self._inscribed,
        )
        nav = dc.replace(nav, rotating_to_goal=command.rotating_to_goal)
        reached, nav = self._goal_reached(nav, pose, speed)
        if reached:
            return self._finish(nav, pose, now, "reached"), 0.0, 0.0
        if command.collision:
            since = nav.failing_since if not math.isnan(nav.failing_since) else now
            nav = dc.replace(nav, failing_since=since)
            if c.failure_tolerance >= 0 and now - since > c.failure_tolerance:
                return self._fail(nav, pose, now, "collision ahead")
            return nav, 0.0, 0.0
        nav = dc.replace(nav, failing_since=math.nan)
        progressing, nav = self._progress(nav, pose, now)
        if not progressing:
            return self._fail(nav, pose, now, "no progress")
        return nav, command.linear, command.angular

    # -- recoveries

    def _fail(self, nav: NavState, pose, now: float, reason: str):
        """A failure of the goal: the next recovery and a retry, or the goal aborted."""
        b = self.behaviors
        if b is None or nav.retries >= b.number_of_retries:
            return self._finish(nav, pose, now, reason), 0.0, 0.0
        kinds = b.round_robin()
        kind = kinds[nav.retries % len(kinds)]
        _log.warning(
            "goal %r: %s at %.2f s; recovery %d/%d: %s",
            nav.goals[nav.goal].name,
            reason,
            now,
            nav.retries + 1,
            b.number_of_retries,
            kind.rpartition("::")[2],
        )
        nav = dc.replace(nav, recovery=Recovery(kind, now, tuple(pose)), retries=nav.retries + 1)
        if kind == CLEAR:  # ClearEntireCostmap: the obstacle layers start again
            nav = dc.replace(nav, obstacles=(), costmaps=(), observed_at=())
        return self._recover(nav, pose, now)

    def _recover(self, nav: NavState, pose, now: float):
        """One cycle of the running recovery; when it ends, a new plan and the checkers
        reset (the retry)."""
        recovery = nav.recovery
        v, w, done = recovery_command(
            self.behaviors,
            recovery,
            pose,
            now,
            lambda d: blocked_behind(self._local(nav), pose, d, self._footprint),
        )
        if not done:
            return nav, v, w
        record = (recovery.kind.rpartition("::")[2], recovery.started, now)
        nav = dc.replace(
            nav,
            recovery=None,
            recoveries=(*nav.recoveries, record),
            path=None,
            planned_at=-math.inf,
            baseline=(*pose, now),
            failing_since=math.nan,
        )
        return nav, 0.0, 0.0

    # -- results

    def summary(self, context) -> dict[str, Any]:
        """``summary.json``'s ``navigation`` section (collisions are added by the run)."""
        nav, now = self.nav_state(context), context.get_time()
        localized = self.LOCALIZATION if self._localized else ""
        return navigation_summary(nav, now, self.controller, localized)


def goal_updated(nav: NavState, publication) -> NavState:
    """``nav`` with its current goal replaced by a new ``goal_update`` ``publication``
    (Nav2's GoalUpdater): the same task and result, the plan and the goal checker's
    latches redone."""
    if publication.count <= nav.updates:
        return nav
    nav = dc.replace(nav, updates=publication.count)
    if not 0 <= nav.goal < len(nav.goals):
        return nav
    goal = publication.message
    _log.info("goal %r updated: (%.3f, %.3f, %.3f)", goal.name, goal.x, goal.y, goal.yaw)
    goals = (*nav.goals[: nav.goal], goal, *nav.goals[nav.goal + 1 :])
    return dc.replace(nav, goals=goals, path=None, xy_reached=False, rotating_to_goal=False)


def goal_result(nav: NavState, now: float, reason: str) -> GoalResult:
    """The current goal's result, measured on the ground truth, logged."""
    goal = nav.goals[nav.goal]
    truth = nav.last_pose
    error = math.hypot(truth[0] - goal.x, truth[1] - goal.y)
    yaw_error = abs(wrap(truth[2] - goal.yaw))
    result = GoalResult(
        name=goal.name,
        reached=reason == "reached",
        reason=reason,
        start=nav.started,
        end=now,
        pose=tuple(float(v) for v in truth),
        position_error=error,
        yaw_error=yaw_error,
        path_length=nav.driven,
        recoveries=nav.recoveries,
        blocked_replans=nav.blocked_replans,
        first_plan=nav.first_plan,
        plan_length=nav.plan_length,
    )
    log = _log.info if result.reached else _log.warning
    log(
        "goal %r %s at %.2f s: position error %.3f m, yaw error %.3f rad",
        goal.name,
        reason,
        now,
        error,
        yaw_error,
    )
    return result


def check_goals(goals: list[NavigationGoal], costmap: Costmap, where: str = "") -> None:
    """Refuses the first goal outside the map or in an obstacle (within the robot's
    radius of one: the costmap's inscribed cost or more), naming it."""
    for goal in goals:
        row, col = costmap.world_to_cell(goal.x, goal.y)
        if not costmap.contains(row, col):
            raise PlanningError(
                f"{where}navigation goal {goal.name!r} ({goal.x:g}, {goal.y:g}) is outside the map"
            )
        cost = int(costmap.costs[row, col])
        if INSCRIBED_INFLATED_OBSTACLE <= cost <= 254:
            what = "an obstacle" if cost == 254 else "an obstacle's inflation (robot radius)"
            raise PlanningError(
                f"{where}navigation goal {goal.name!r} ({goal.x:g}, {goal.y:g}) is in "
                f"{what}: cost {cost} on the map"
            )
