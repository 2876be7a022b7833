"""Navigation to goals as a Drake system: NavigateToPose's plan, follow, check, in order.

:func:`AddNavigation` reads the scenario's ``navigation:`` section and its Nav2 YAML,
makes the map (the given map_server map, or the world's true occupancy at the lidar's
height: :mod:`.world_map`) and the global costmap (:mod:`.costmap`), refuses a goal in
an obstacle (its name in the one-line error), and adds a :class:`Navigator` that
publishes cmd_vel to the drive controller.

:class:`Navigator` is one discrete update at ``controller_frequency``, as Nav2's
controller server's loop: the pose from the localization (the ground truth: the
plant's state), NavFn's plan on a new goal and at ``expected_planner_frequency`` (the
default behaviour tree replans at 1 Hz), Regulated Pure Pursuit on it
(:mod:`.follower`), the goal checker (``xy_goal_tolerance`` then, stateful, the
``yaw_goal_tolerance``) and the progress checker (``required_movement_radius`` within
``movement_time_allowance``, else the goal is aborted); the goals in the chosen order.
Between updates nothing runs in Python. Its state is an immutable :class:`NavState`
(Drake's copy of it is free).
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, LeafSystem

from armando_drake.control.manager import planar_base
from armando_drake.description.packages import find_packages
from armando_drake.messages.types import Odometry, PublicationValue, Twist, TwistStamped
from armando_drake.navigation.amcl import (
    AmclLocalizer,
    ParticleFilter,
    amcl_parameters,
    body_odometry,
    compose,
)
from armando_drake.navigation.behaviors import (
    CLEAR,
    BehaviorParameters,
    Recovery,
    behavior_parameters,
    recovery_command,
)
from armando_drake.navigation.config import NavigationConfig, NavigationGoal
from armando_drake.navigation.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    Costmap,
    CostmapParameters,
    clear_footprint,
    costmap_parameters,
    empty_obstacles,
    has_costmap,
    layered_costmap,
    make_costmap,
    observe,
)
from armando_drake.navigation.follower import (
    ControllerParameters,
    controller_parameters,
    prune,
    rpp_command,
    to_robot,
    wrap,
)
from armando_drake.navigation.maps import OccupancyMap, load_map
from armando_drake.navigation.overrides import overridden_file
from armando_drake.navigation.planner import (
    PlannerParameters,
    PlanningError,
    path_length,
    plan,
    planner_parameters,
)
from armando_drake.navigation.world_map import LIDAR_TYPES, lidar_height, world_map
from armando_drake.tools.errors import ConfigError, ScenarioError
from armando_drake.tools.extras import require_extra

_log = logging.getLogger("armando_drake.navigation")


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


@dc.dataclass(frozen=True)
class Layers:
    """The costmaps updated from the lidar's scans: the global one (its obstacle layer,
    if its plugins list one) and the local one (``local_costmap``, if the file has it),
    with the laser's planar pose on the base (x, y, yaw) and its height [m]."""

    global_params: CostmapParameters
    local_params: CostmapParameters | None
    laser: tuple[float, float, float]
    height: float

    def all(self) -> tuple:
        return (self.global_params, self.local_params)


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
    poses: tuple = ()  # the localization's last (time, (x, y, yaw)): a scan's at its stamp
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
        input_ports:
        - goal_pose (optional)
        output_ports:
        - cmd_vel
        - command
        - nav_state

    - ``state``: the robot model instance's state (its floating base's pose and twist);
    - ``goal_pose``: a Publication of a NavigationGoal (or a tuple of them): each new one
      is a task that preempts the current one (RViz's 2D goal on ``/goal_pose``);
    - with AMCL, ``odom`` (the drive's Odometry) and ``map_to_odom`` (x, y, yaw) too;
    - ``cmd_vel``: a Publication of TwistStamped (``frame_id`` ``base_link``);
    - ``command``: vector (linear [m/s], angular [rad/s]) of the latest message;
    - ``nav_state``: the :class:`NavState` (the plan, the goals, the results).

    :meth:`request` and :meth:`cancel` send a task from a script between two steps of the
    simulator (:mod:`armando_drake.simulation.commander`).
    """

    def __init__(
        self,
        goals: list[NavigationGoal],
        costmap: Costmap,
        controller: ControllerParameters,
        planner: PlannerParameters,
        *,
        state_size: int,
        base_rows: tuple[list[int], list[int]],
        inscribed_radius: float,
        start_delay: float = 0.0,
        grid: OccupancyMap | None = None,
        amcl_axle: float | None = None,
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
        self.planner = planner
        self._inscribed = inscribed_radius
        self._q_rows, self._v_rows = base_rows
        self._state = self.DeclareVectorInputPort("state", state_size)
        self._axle = amcl_axle  # None: the ground truth; else AMCL, the drive's axle offset
        if amcl_axle is not None:
            self._odom = self.DeclareAbstractInputPort("odom", AbstractValue.Make(Odometry()))
            self._map_to_odom = self.DeclareVectorInputPort("map_to_odom", 3)
        self._nav = self.DeclareAbstractState(AbstractValue.Make(NavState(goals=tuple(goals))))
        self._goal_pose = self.DeclareAbstractInputPort("goal_pose", PublicationValue())
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

    def _pose(self, context):
        """The localization's pose (x, y, yaw) and the measured twist (v, w)."""
        if self._axle is None:
            px, py, yaw, v, w = self._truth(context)
        else:  # AMCL's map -> odom, then the odometry
            message = self._odom.Eval(context)
            odom = body_odometry(message, self._axle)
            px, py, yaw = compose(self._map_to_odom.Eval(context), odom)
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
        if self.layers is not None:
            nav = dc.replace(nav, poses=(*nav.poses[-5:], (now, tuple(pose))))
            if self._scan.HasValue(context):
                nav = self._observe(nav, self._scan.Eval(context).message, now)
        if self._axle is not None and (
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

    def _observe(self, nav: NavState, scan, now: float) -> NavState:
        """The costmaps' obstacle layers after ``scan`` (each at its update_frequency),
        seen from the pose at the scan's stamp (as the transform at the stamp in Nav2)."""
        if scan is None or self.grid is None:
            return nav
        pose = min(nav.poses, key=lambda item: abs(item[0] - scan.stamp))[1]
        layers = self.layers
        laser = compose(pose, layers.laser)
        shape = self.grid.data.shape
        obstacles = list(nav.obstacles or (None, None))
        costmaps = list(nav.costmaps or (None, None))
        observed = list(nav.observed_at or (-math.inf, -math.inf))
        for k, params in enumerate(layers.all()):
            if params is None or now - observed[k] < 1.0 / params.update_frequency - 1e-9:
                continue
            layer = params.obstacle_layer
            grid = obstacles[k] if obstacles[k] is not None else empty_obstacles(shape, params)
            if layer is not None and layer.enabled:
                for source in layer.sources:
                    grid = observe(grid, self.costmap, laser, layers.height, scan, source)
                if layer.footprint_clearing_enabled:
                    grid = clear_footprint(grid, self.costmap, pose, params.inscribed_radius)
            obstacles[k] = grid
            costmaps[k] = layered_costmap(self.grid, params, grid, robot=pose[:2])
            observed[k] = now
        return dc.replace(
            nav, obstacles=tuple(obstacles), costmaps=tuple(costmaps), observed_at=tuple(observed)
        )

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

    def _requested(self, context, nav: NavState):
        """(state, the task requested since the last update or None)."""
        if nav.pending is not None:
            return dc.replace(nav, pending=None), nav.pending
        if self._goal_pose.HasValue(context):
            publication = self._goal_pose.Eval(context)
            if publication.count > nav.received:
                message = publication.message
                task = tuple(message) if isinstance(message, (tuple, list)) else (message,)
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
            path = plan(self._costmap(nav), pose[:2], (goal.x, goal.y), self.planner)
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
        """Whether the rest of the current plan crosses an obstacle of the costmap (a lethal
        cell, or one within the robot's inscribed radius of it)."""
        costmap = self._costmap(nav)
        rest = nav.path[nav.path_index :]
        cols = np.floor((rest[:, 0] - costmap.origin[0]) / costmap.resolution).astype(int)
        rows = np.floor((rest[:, 1] - costmap.origin[1]) / costmap.resolution).astype(int)
        inside = (rows >= 0) & (rows < costmap.costs.shape[0])
        inside &= (cols >= 0) & (cols < costmap.costs.shape[1])
        costs = costmap.costs[rows[inside], cols[inside]]
        return bool(((costs >= INSCRIBED_INFLATED_OBSTACLE) & (costs <= 254)).any())

    def _finish(self, nav: NavState, pose, now: float, reason: str, then=True) -> NavState:
        """The goal's result, measured on the ground truth; the next goal sent from
        ``pose`` (the localization's) if ``then``."""
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
        nav = dc.replace(nav, results=(*nav.results, result))
        return self._start(nav, nav.goal + 1, pose, now) if then else nav

    def _goal_reached(self, nav: NavState, pose, speed) -> tuple[bool, NavState]:
        """SimpleGoalChecker (StoppedGoalChecker: and stopped)."""
        c = self.controller
        goal = nav.goals[nav.goal]
        if not (c.goal_stateful and nav.xy_reached):
            if math.hypot(pose[0] - goal.x, pose[1] - goal.y) > c.xy_goal_tolerance:
                return False, nav
            if c.goal_stateful:
                nav = dc.replace(nav, xy_reached=True)
        if abs(wrap(pose[2] - goal.yaw)) > c.yaw_goal_tolerance:
            return False, nav
        if c.stopped_goal_checker and (
            abs(speed[0]) > c.trans_stopped_velocity or abs(speed[1]) > c.rot_stopped_velocity
        ):
            return False, nav
        return True, nav

    def _progress(self, nav: NavState, pose, now: float) -> tuple[bool, NavState]:
        """SimpleProgressChecker / PoseProgressChecker."""
        c = self.controller
        x, y, yaw, since = nav.baseline
        moved = math.hypot(pose[0] - x, pose[1] - y) > c.required_movement_radius
        turned = abs(wrap(pose[2] - yaw)) > c.required_movement_angle
        if moved or turned:
            return True, dc.replace(nav, baseline=(*pose, now))
        return now - since <= c.movement_time_allowance, nav

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
        command = rpp_command(
            c,
            self._local(nav),
            local,
            pose,
            speed,
            (goal.x, goal.y, goal.yaw),
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
            self.behaviors, recovery, pose, now, lambda d: self._blocked_behind(nav, pose, d)
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

    def _blocked_behind(self, nav: NavState, pose, distance: float) -> bool:
        costmap = self._local(nav)
        for d in np.arange(0.0, distance + 1e-9, 0.5 * costmap.resolution):
            x = pose[0] - (d + self._inscribed) * math.cos(pose[2])
            y = pose[1] - (d + self._inscribed) * math.sin(pose[2])
            row, col = costmap.world_to_cell(x, y)
            if costmap.contains(row, col) and costmap.costs[row, col] == 254:
                return True
        return False

    # -- results

    def results(self, context) -> list[GoalResult]:
        """Every goal's result at ``context``'s time (those not finished: not reached)."""
        nav = context.get_abstract_state(self._nav).get_value()
        results = list(nav.results)
        now = context.get_time()
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

    def summary(self, context) -> dict[str, Any]:
        """``summary.json``'s ``navigation`` section (collisions are added by the run)."""
        results = self.results(context)
        c = self.controller
        summary = {
            "goals": [
                {
                    "name": r.name,
                    "goal": [g.x, g.y, g.yaw],
                    "reached": r.reached,
                    "status": r.status,
                    "reason": r.reason,
                    "blocked_replans": r.blocked_replans,
                    "recoveries": [
                        {"behavior": k, "start": t0, "end": t1} for k, t0, t1 in r.recoveries
                    ],
                    "position_error": r.position_error,
                    "yaw_error": r.yaw_error,
                    "time": r.end - r.start if r.reached else None,
                    "reached_at": r.end if r.reached else None,
                    "path_length": r.path_length,
                    "plan_length": r.plan_length,
                    "pose": list(r.pose),
                }
                for r, g in zip(results, self.nav_state(context).goals, strict=True)
            ],
            "reached": sum(r.reached for r in results),
            "xy_goal_tolerance": c.xy_goal_tolerance,
            "yaw_goal_tolerance": c.yaw_goal_tolerance,
        }
        if self._axle is not None:
            summary["localization"] = localization_summary(self.nav_state(context))
        return summary


def localization_summary(nav: NavState, settle: float = 5.0) -> dict[str, Any]:
    """AMCL's errors against the ground truth: each second's, the last, and the largest
    from ``settle`` [s] after the navigation started on."""
    samples = nav.localization
    after = [s for s in samples if samples and s[0] >= samples[0][0] + settle]
    return {
        "method": "amcl",
        "errors": [{"time": t, "position": e, "yaw": y} for t, e, y in samples],
        "final_position_error": samples[-1][1] if samples else None,
        "final_yaw_error": samples[-1][2] if samples else None,
        "settle_time": settle,
        "max_position_error_settled": max((s[1] for s in after), default=None),
        "max_yaw_error_settled": max((s[2] for s in after), default=None),
    }


# ---------------------------------------------------------------------------- building


def resolve_file(name: str, key: str, where: str, near: Path | None = None) -> Path:
    """A path or ``package://pkg/rest`` to an existing file."""
    path = Path(name).expanduser()
    if name.startswith("package://"):
        package, _, rest = name[len("package://") :].partition("/")
        search = find_packages()
        if package not in search.packages:
            raise ScenarioError(f"{where}{key}={name!r}: unknown package {package!r}")
        path = search.packages[package] / rest
    if not path.is_file():
        raise ScenarioError(f"{where}{key}={name!r}: no such file")
    return path


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


@dc.dataclass
class Navigation:
    """What :func:`AddNavigation` built."""

    navigator: Navigator
    drive: str
    grid: OccupancyMap
    costmap: Costmap
    amcl: AmclLocalizer | None = None  # with localization: amcl (its scan is connected by
    # ConnectLocalization, once the sensors are added)
    lidar: str = ""  # the lidar AMCL (or the mapper) reads
    mapper: Any = None  # with exploration: the SlamMapper (navigation/slam.py)
    truth: OccupancyMap | None = None  # with exploration: the world's map, to compare


def navigation_map(config: NavigationConfig, plant, scene_graph, robot, where: str = ""):
    """The map of ``config``: its map_server map, or the world's at the lidar's height."""
    if config.map:
        return load_map(resolve_file(config.map, "navigation.map", where))
    height = config.scan_height or lidar_height(plant, scene_graph, robot)
    return world_map(
        plant,
        scene_graph,
        height=height,
        resolution=config.map_resolution,
        exclude=[robot.model_instance],
    )


def AddNavigation(builder, config: NavigationConfig, stack, *, where: str = "") -> Navigation:
    """The :class:`Navigator` of ``config`` on the floating base of ``stack``'s robot,
    publishing cmd_vel to the first active drive (or ``config.controller``); exports
    ``navigation_command``."""
    require_extra("navigation", f"{where}navigation")
    takers = stack.taking(TwistStamped)
    if config.controller:
        takers = [name for name in takers if name == config.controller]
    if not takers or not stack.hardware.base_position_index:
        raise ScenarioError(
            f"{where}navigation needs a floating base with an active drive "
            f"(active: {', '.join(stack.controllers) or 'none'})"
        )
    params_file = resolve_file(config.params_file, "navigation.params_file", where)
    params_file = overridden_file(params_file, config.params_overrides, where)
    try:
        costmap_params = costmap_parameters(params_file)
        planner = planner_parameters(params_file)
        controller = controller_parameters(params_file)
        behaviors = behavior_parameters(params_file)
    except ConfigError as error:
        raise ConfigError(f"{where}navigation.params_file: {error}") from None
    grid = navigation_map(config, stack.plant, stack.scene_graph, stack.robot, where)
    costmap = make_costmap(grid, costmap_params)
    goals = config.visits()
    check_goals(goals, costmap, where)
    hardware = stack.hardware
    axle = _axle_offset(stack, takers[0]) if config.localization == "amcl" else None
    layers = _layers(stack, costmap_params, params_file, where)
    if layers is not None and layers.local_params is not None:
        if not math.isclose(layers.local_params.resolution, grid.resolution):
            _log.warning(
                "%s: local_costmap resolution %g: the local costmap runs on the map's grid (%g)",
                params_file,
                layers.local_params.resolution,
                grid.resolution,
            )
    navigator = builder.AddSystem(
        Navigator(
            goals,
            costmap,
            controller,
            planner,
            state_size=hardware.num_model_states,
            base_rows=(hardware.base_position_index, hardware.base_velocity_index),
            inscribed_radius=costmap_params.inscribed_radius,
            start_delay=config.start_delay,
            grid=grid,
            amcl_axle=axle,
            layers=layers,
            behaviors=behaviors,
        )
    )
    navigator.set_name("navigator")
    plant, instance = stack.plant, stack.robot.model_instance
    builder.Connect(plant.get_state_output_port(instance), navigator.GetInputPort("state"))
    builder.Connect(navigator.GetOutputPort("cmd_vel"), stack.command_input(takers[0]))
    builder.ExportOutput(navigator.GetOutputPort("command"), "navigation_command")
    navigation = Navigation(navigator=navigator, drive=takers[0], grid=grid, costmap=costmap)
    if layers is not None:
        navigation.lidar = _lidars(stack, "the costmap's obstacle layer", where)[0].name
    if axle is not None:
        navigation.amcl = _add_amcl(builder, config, stack, navigation, params_file, axle, where)
    return navigation


def _lidars(stack, what: str, where: str) -> list:
    lidars = [b for b in stack.robot.sensors if b.type in LIDAR_TYPES]
    if not lidars:
        raise ScenarioError(f"{where}navigation: {what} needs a lidar on the robot")
    return lidars


def _layers(stack, global_params, params_file: Path, where: str) -> Layers | None:
    """The costmaps fed by the lidar's scans: the global one if it has an obstacle layer,
    the file's local_costmap if it has one; None if neither."""
    try:
        local = (
            costmap_parameters(params_file, "local_costmap")
            if has_costmap(params_file, "local_costmap")
            else None
        )
    except ConfigError as error:
        raise ConfigError(f"{where}navigation.params_file: {error}") from None
    if global_params.obstacle_layer is None:
        global_params = None
    if global_params is None and local is None:
        return None
    lidar = _lidars(stack, "the costmap's obstacle layer", where)[0]
    plant, robot = stack.plant, stack.robot
    context = plant.CreateDefaultContext()
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    link = plant.GetBodyByName(lidar.link, robot.model_instance).body_frame()
    X_BS = plant.CalcRelativeTransform(context, body.body_frame(), link) @ lidar.X_LS
    laser = (*X_BS.translation()[:2], X_BS.rotation().ToRollPitchYaw().yaw_angle())
    height = lidar_height(plant, stack.scene_graph, robot)
    return Layers(global_params, local, tuple(float(v) for v in laser), height)


def _axle_offset(stack, drive: str) -> float:
    """[m] the drive's wheel axle midpoint ahead of the floating base's origin."""
    plant, robot = stack.plant, stack.robot
    logic = next(c.logic for c in stack.manager.controllers if c.name == drive)
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    context = plant.CreateDefaultContext()
    points = [
        plant.CalcRelativeTransform(
            context,
            body.body_frame(),
            plant.GetJointByName(name, robot.model_instance).frame_on_child(),
        ).translation()
        for name in logic.joint_names
    ]
    return float(np.mean(points, axis=0)[0])


def _add_amcl(builder, config, stack, navigation: Navigation, params_file, axle, where):
    """The AmclLocalizer on the drive's odometry (and, later, the lidar's scan) feeding
    the navigator's map -> odom."""
    plant, robot = stack.plant, stack.robot
    lidars = [b for b in robot.sensors if b.type in LIDAR_TYPES]
    if not lidars:
        raise ScenarioError(f"{where}navigation.localization=amcl needs a lidar on the robot")
    try:
        params = amcl_parameters(params_file)
    except ConfigError as error:
        raise ConfigError(f"{where}navigation.params_file: {error}") from None
    context = plant.CreateDefaultContext()
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    link = plant.GetBodyByName(lidars[0].link, robot.model_instance).body_frame()
    X_BS = plant.CalcRelativeTransform(context, body.body_frame(), link) @ lidars[0].X_LS
    laser = (
        X_BS.translation()[0],
        X_BS.translation()[1],
        X_BS.rotation().ToRollPitchYaw().yaw_angle(),
    )
    X_WB = plant.EvalBodyPoseInWorld(context, body)
    spawn = (
        X_WB.translation()[0],
        X_WB.translation()[1],
        X_WB.rotation().ToRollPitchYaw().yaw_angle(),
    )
    initial = config.initial_pose or (params.initial_pose if params.set_initial_pose else None)
    pf = ParticleFilter(params, navigation.grid, laser)
    rate = 2.0 * max(lidars[0].update_rate, 1.0)  # twice the scans: odometry at each
    amcl = builder.AddSystem(AmclLocalizer(pf, initial or spawn, axle=axle, rate=rate))
    amcl.set_name("amcl")
    odom = stack.manager.GetOutputPort(f"{navigation.drive}.odom")
    builder.Connect(odom, amcl.GetInputPort("odom"))
    builder.Connect(odom, navigation.navigator.GetInputPort("odom"))
    builder.Connect(
        amcl.GetOutputPort("map_to_odom"), navigation.navigator.GetInputPort("map_to_odom")
    )
    builder.ExportOutput(amcl.GetOutputPort("estimate"), "amcl_estimate")
    navigation.lidar = lidars[0].name
    return amcl


def ConnectLocalization(builder, navigation: Navigation | None, sensors: dict) -> None:
    """Connects AMCL to its lidar's scan once the sensors are added (nothing to do for the
    ground truth or without a navigation)."""
    if navigation is None:
        return
    navigator = navigation.navigator if navigation.navigator.layers is not None else None
    for reader in (navigation.amcl, navigation.mapper, navigator):
        if reader is not None:
            builder.Connect(sensors[navigation.lidar]["scan"], reader.GetInputPort("scan"))
