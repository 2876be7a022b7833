"""A script's or a notebook's navigation, as nav2_simple_commander's BasicNavigator.

::

    from armando_drake.simulation.commander import BasicNavigator, TaskResult

    navigator = BasicNavigator("fra2mo_goals")       # a scenario with a navigation
    navigator.goToPose((1.5, 1.3, 1.5708))           # (x, y, yaw) in the map frame
    while not navigator.isTaskComplete():            # advances the simulation 0.1 s
        feedback = navigator.getFeedback()
        print(f"{feedback.distance_remaining:.2f} m to go")
    assert navigator.getResult() == TaskResult.SUCCEEDED
    navigator.close()

Unlike ROS 2's, there is no server to wait for: the world is built and simulated here, and
time passes only while :meth:`BasicNavigator.isTaskComplete` (or
:meth:`~BasicNavigator.spin`) advances it. The scenario's own goals are dropped: the
robot waits for a task. The results are those of the navigator (``summary.json``'s
``navigation`` section: :meth:`BasicNavigator.summary`).
"""

from __future__ import annotations

import dataclasses as dc
import enum
import logging
import math
from typing import Any

import numpy as np
from pydrake.systems.analysis import Simulator

from armando_drake.navigation.config import NavigationGoal
from armando_drake.navigation.navigator import check_goals
from armando_drake.navigation.planner import PlanningError, path_length
from armando_drake.navigation.topics import GOAL_RANGE, goal_pose_of
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import Scenario, load_scenario
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.rejections import RejectedMessage, require_finite, require_within

_log = logging.getLogger("armando_drake.navigation")


class TaskResult(enum.Enum):
    """nav2_simple_commander's TaskResult."""

    UNKNOWN = 0
    SUCCEEDED = 1
    CANCELED = 2
    FAILED = 3


@dc.dataclass(frozen=True)
class Feedback:
    """NavigateToPose's (and FollowWaypoints') feedback."""

    current_pose: tuple[float, float, float]  # (x, y, yaw) [m, m, rad]
    navigation_time: float  # [s] since the current goal was sent
    distance_remaining: float  # [m] along the plan from its pose nearest the robot
    current_waypoint: int  # the index of the goal under way in the task
    number_of_recoveries: int = 0


def as_goal(pose: Any, name: str, navigator=None, context=None) -> NavigationGoal:
    """A NavigationGoal of ``(x, y, yaw)``, a NavigationGoal, or a PoseStamped dictionary;
    :class:`~armando_drake.tools.rejections.RejectedMessage` for a value that is not
    finite (or not a number), a position beyond GOAL_RANGE, a quaternion that is no
    rotation. A PoseStamped in another frame than ``map`` is taken to the map by
    ``navigator`` at ``context`` (its own) (:class:`ValueError` for an unknown frame)."""
    if isinstance(pose, NavigationGoal):
        goal = pose
    elif isinstance(pose, dict):  # geometry_msgs/PoseStamped, in its header's frame
        framed = goal_pose_of(pose)
        goal = dc.replace(framed.goal, name=name)
        if navigator is not None:
            goal = navigator.goal_in_map(context, goal, framed.frame_id, framed.stamp)
    else:
        values = list(pose)
        if len(values) != 3:
            raise RejectedMessage(f"pose={pose!r} is not (x, y, yaw)")
        x, y, yaw = values
        goal = NavigationGoal(name=name, x=x, y=y, yaw=yaw)
    require_within((("x", goal.x), ("y", goal.y)), GOAL_RANGE, " m")
    require_finite([("yaw", goal.yaw)])
    return dc.replace(goal, x=float(goal.x), y=float(goal.y), yaw=float(goal.yaw))


class BasicNavigator:
    """Goals from Python to the world's navigator, the simulation advanced meanwhile."""

    def __init__(self, scenario: Scenario | str, *, step: float = 0.1, **world_options):
        if isinstance(scenario, str):
            scenario = load_scenario(scenario)
        if scenario.navigation is None:
            raise ScenarioError("BasicNavigator needs a scenario with a navigation: section")
        navigation = dc.replace(scenario.navigation, goals=[], order=[])  # it waits for a task
        scenario = dc.replace(scenario, navigation=navigation)
        world_options.setdefault("quiet", True)
        self.world = MakeWorld(scenario, **world_options)
        self.simulator = Simulator(self.world.diagram)
        self.simulator.set_target_realtime_rate(scenario.simulator_config.target_realtime_rate)
        self.simulator.Initialize()
        self.step = step
        self.navigation = self.world.robot_with("navigation").navigation
        self.navigator = self.navigation.navigator
        self._number = 0  # tasks sent
        self.rejected = ""  # why the last goal was rejected

    # -- time

    @property
    def context(self):
        return self.simulator.get_context()

    @property
    def time(self) -> float:
        """[s] simulation time."""
        return self.context.get_time()

    def spin(self, seconds: float) -> None:
        """Advances the simulation by ``seconds``."""
        self.simulator.AdvanceTo(self.time + seconds)

    def _state(self):
        return self.navigator.nav_state(self.navigator.GetMyContextFromRoot(self.context))

    # -- tasks

    def _send(self, poses, prefix: str) -> bool:
        try:
            context = self.navigator.GetMyContextFromRoot(self.context)
            goals = [as_goal(pose, f"{prefix}_{k}" if len(poses) > 1 else prefix,
                             self.navigator, context)
                     for k, pose in enumerate(poses)]  # fmt: skip
            check_goals(goals, self.navigation.costmap)
        except (PlanningError, ValueError, TypeError, KeyError) as error:
            _log.warning("goal rejected: %s", error)
            self.rejected = str(error)
            return False
        self._number += 1
        context = self.navigator.GetMyMutableContextFromRoot(self.simulator.get_mutable_context())
        self.navigator.request(context, goals)
        return True

    def goToPose(self, pose, behavior_tree: str = "") -> bool:
        """NavigateToPose: ``pose`` ((x, y, yaw), a NavigationGoal or a PoseStamped);
        False (rejected, the reason logged and in :attr:`rejected`) for a goal off the map
        or in an obstacle, or one with a value that is NaN, infinite or no number."""
        return self._send([pose], "goal")

    def followWaypoints(self, poses) -> bool:
        """FollowWaypoints: each pose in turn (a missed one is skipped, as Nav2's
        ``stop_on_failure: false``)."""
        return self._send(list(poses), "waypoint")

    def goThroughPoses(self, poses, behavior_tree: str = "") -> bool:
        """As :meth:`followWaypoints` (each pose taken by the goal checker)."""
        return self._send(list(poses), "pose")

    def cancelTask(self) -> None:
        """Cancels the task: the navigator's next update stops the base."""
        context = self.navigator.GetMyMutableContextFromRoot(self.simulator.get_mutable_context())
        self.navigator.cancel(context)
        self.spin(1.0 / self.navigator.controller.controller_frequency)

    def isTaskComplete(self) -> bool:
        """Advances the simulation by ``step`` and tells whether the task is over."""
        self.spin(self.step)
        nav = self._state()
        return nav.pending is None and nav.goal >= len(nav.goals)

    def _task_results(self):
        nav = self._state()
        return list(nav.results[nav.task_start :])

    def getResult(self) -> TaskResult:
        """SUCCEEDED (every goal reached), CANCELED, FAILED; UNKNOWN while under way."""
        nav = self._state()
        if nav.pending is not None or nav.goal < len(nav.goals) or self._number == 0:
            return TaskResult.UNKNOWN
        results = self._task_results()
        if any(r.reason == "canceled" for r in results):
            return TaskResult.CANCELED
        return TaskResult.SUCCEEDED if all(r.reached for r in results) else TaskResult.FAILED

    @property
    def missed_waypoints(self) -> list[str]:
        """The names of the task's goals not reached (FollowWaypoints' result)."""
        return [r.name for r in self._task_results() if not r.reached]

    def getFeedback(self) -> Feedback | None:
        """The current goal's feedback (None when no goal is under way)."""
        nav = self._state()
        if nav.pending is not None or not 0 <= nav.goal < len(nav.goals):
            return None
        pose = nav.last_pose
        remaining = math.nan
        if nav.path is not None:  # bt_navigator's: the plan's length from its pose nearest
            ahead = nav.path[nav.path_index :]  # the robot
            remaining = path_length(ahead[int(np.argmin(np.hypot(*(ahead - pose[:2]).T))) :])
        return Feedback(
            current_pose=tuple(pose),
            navigation_time=self.time - nav.started,
            distance_remaining=remaining,
            current_waypoint=nav.goal - nav.task_start,
        )

    # -- the rest of BasicNavigator's interface

    def waitUntilNav2Active(self, *args, **kwargs) -> None:
        """Nothing to wait for: the navigator is part of the world."""

    def lifecycleStartup(self) -> None:
        """Nothing to start."""

    def summary(self) -> dict:
        """The navigator's summary (every goal sent so far)."""
        return self.navigator.summary(self.navigator.GetMyContextFromRoot(self.context))

    def close(self) -> None:
        """Closes the world (its recorder, its DDS participant)."""
        self.world.close(self.context)
