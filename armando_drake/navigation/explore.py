"""Frontier exploration as explore_lite (m-explore-ros2) does it, driving the navigator.

:func:`explore_parameters` reads ``explore_node.ros__parameters`` (or ``explore``) of an
explore YAML; applied: ``planner_frequency`` (how often the frontiers are searched),
``progress_timeout`` (a goal whose distance has not shrunk for so long is blacklisted),
``potential_scale``, ``gain_scale``, ``min_frontier_size``. ``orientation_scale`` is
unused upstream too (warned); frames, topics and ``visualize`` are the ROS node's.

:func:`frontiers` (``FrontierSearch``): the free cells of the map with an unknown
4-neighbour, clustered 8-connected (SciPy's ``ndimage.label``); a cluster shorter than
``min_frontier_size`` (cells times resolution) is dropped; its cost is
``potential_scale * d - gain_scale * size`` with ``d`` [m] its nearest cell's distance to
the robot and ``size`` [m] its length. Its goal is the known cell nearest its centroid whose
cost is below 128 (clear of the obstacles: 0.37 m away with fra2mo's inflation), within
1 m of it (upstream sends the centroid and lets the planner's tolerance cope); a cluster
with none is dropped.

:class:`Explorer` is the :class:`~.navigator.Navigator` on the frontiers: at
``planner_frequency`` it rebuilds the global costmap on the map being built (the
:class:`~.slam.SlamMapper`'s) and searches the frontiers; it keeps its goal while the goal
still lies on a frontier, else sends the cheapest frontier not blacklisted (within 5
cells of a blacklisted goal, as upstream; the goal replaced is "superseded"); a goal
reached, aborted or timed out is blacklisted. When no frontier is left the exploration is
done and the robot stops.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue

from armando_drake.navigation.config import NavigationGoal
from armando_drake.navigation.costmap import (
    Costmap,
    CostmapParameters,
    make_costmap,
)
from armando_drake.navigation.maps import FREE, UNKNOWN, OccupancyMap
from armando_drake.navigation.nav2_params import fill, read_yaml
from armando_drake.navigation.navigator import Navigator, NavState
from armando_drake.navigation.results import GoalResult
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import param

NODES = ("explore_node", "explore")
BLACKLIST_CELLS = 5  # upstream's blacklist radius, in cells
KEEP_GOAL = 0.3  # [m] a goal is kept while a frontier cell is this near it
GOAL_COST = 128  # a frontier's goal: a cell whose cost is below, clear of the obstacles
GOAL_REACH = 1.0  # [m] at most this far from the frontier's centroid

_log = logging.getLogger("armando_drake.navigation")


@dc.dataclass
class ExploreParameters:
    """explore_lite's parameters (defaults: upstream's), each declared with its unit,
    range and meaning (checked by the schema's rules: :func:`.nav2_params.fill`)."""

    planner_frequency: float = param(
        1.0, unit="Hz", gt=0, doc="how often the frontiers are recomputed"
    )
    progress_timeout: float = param(
        30.0, unit="s", ge=0, doc="without progress, the frontier is blacklisted"
    )
    potential_scale: float = param(
        1e-3, unit="-", ge=0, doc="weight of a frontier's distance in its cost"
    )
    gain_scale: float = param(1.0, unit="-", ge=0, doc="weight of a frontier's size in its cost")
    min_frontier_size: float = param(0.5, unit="m", ge=0, doc="smaller frontiers are ignored")
    ignored: list[str] = dc.field(default_factory=list)


_KNOWN = {
    "use_sim_time", "robot_base_frame", "costmap_topic", "costmap_updates_topic", "visualize",
    "transform_tolerance", "return_to_init",
}  # fmt: skip


def explore_parameters(path: str | Path) -> ExploreParameters:
    """The explore node's parameters of a YAML; keys not applied are warned about by name."""
    path = Path(path)
    doc = read_yaml(path)
    node = next((n for n in NODES if isinstance(doc.get(n), dict)), None)
    ros = doc[node].get("ros__parameters") if node else None
    if not isinstance(ros, dict):
        raise ConfigError(f"{path}: explore_node.ros__parameters: missing (no explore_node)")
    where = f"{path}: {node}.ros__parameters"
    params = ExploreParameters()
    keys = [f.name for f in dc.fields(ExploreParameters) if f.name != "ignored"]
    ignored = []
    for key in fill(params, ros, where, keys):
        if key not in _KNOWN:
            ignored.append(key)
            why = "unused by explore_lite too" if key == "orientation_scale" else "not used here"
            _log.warning("%s.%s: %s", where, key, why)
    params.ignored = [f"{where}.{k}" for k in ignored]
    return params


@dc.dataclass(frozen=True)
class Frontier:
    """A frontier: its goal (x, y), length [m], nearest distance [m], cost."""

    goal: tuple[float, float]
    size: float
    distance: float
    cost: float


def frontier_cells(grid: OccupancyMap) -> np.ndarray:
    """The free cells with an unknown 4-neighbour (bool, the grid's shape)."""
    from scipy import ndimage  # the navigation extra: imported where used

    cross = ndimage.generate_binary_structure(2, 1)
    near_unknown = ndimage.binary_dilation(grid.data == UNKNOWN, structure=cross)
    return (grid.data == FREE) & near_unknown


def frontiers(
    grid: OccupancyMap, costmap: Costmap, position, params: ExploreParameters, blacklist=()
) -> list[Frontier]:
    """The frontiers of ``grid`` seen from ``position`` (x, y), cheapest first."""
    from scipy import ndimage  # the navigation extra: imported where used

    labels, count = ndimage.label(frontier_cells(grid), structure=np.ones((3, 3), dtype=bool))
    if count == 0:
        return []
    rows, cols = np.nonzero(labels)
    which = labels[rows, cols]
    xy = costmap.cell_to_world(rows, cols)
    clear = costmap.cell_to_world(*np.nonzero(costmap.costs < GOAL_COST))
    near = np.hypot(xy[:, 0] - position[0], xy[:, 1] - position[1])
    black = np.asarray(blacklist, dtype=float).reshape(-1, 2)
    found = []
    for label in range(1, count + 1):
        mine = which == label
        size = int(mine.sum()) * grid.resolution
        if size < params.min_frontier_size:
            continue
        centroid = xy[mine].mean(axis=0)
        reach = np.hypot(*(clear - centroid).T) if len(clear) else np.zeros(0)
        if not len(reach) or reach.min() > GOAL_REACH:
            continue
        goal = clear[int(np.argmin(reach))]
        if len(black) and np.hypot(*(black - goal).T).min() <= BLACKLIST_CELLS * grid.resolution:
            continue
        distance = float(near[mine].min())
        cost = params.potential_scale * distance - params.gain_scale * size
        found.append(Frontier((float(goal[0]), float(goal[1])), size, distance, cost))
    return sorted(found, key=lambda f: f.cost)


@dc.dataclass(frozen=True)
class ExploreState:
    """The exploration's part of the navigator's state."""

    goal: NavigationGoal | None = None
    grid: OccupancyMap | None = None  # the map last searched
    costmap: Costmap | None = None  # its costmap
    searched_at: float = -math.inf
    frontiers: int = -1  # frontiers found at the last search (-1: none yet)
    blacklist: tuple = ()  # ((x, y), ...)
    sent: int = 0  # goals sent
    best_distance: float = math.inf  # the progress timeout's
    progress_at: float = 0.0
    done_at: float = math.nan  # when no frontier was left

    def __deepcopy__(self, memo):
        return self


class Explorer(Navigator):
    """The navigator driving to frontiers of the map being built (module docstring).

    .. pydrake_system::

        name: Explorer
        input_ports:
        - state
        - odom
        - map_to_odom
        - map
        output_ports:
        - cmd_vel
        - command

    ``map``: the SlamMapper's OccupancyMap; the pose is map -> odom and the odometry.
    """

    LOCALIZATION = "slam"  # slam_toolbox's pose against the ground truth

    def __init__(self, explore: ExploreParameters, costmap_params: CostmapParameters,
                 blank: OccupancyMap, *args: Any, **kwargs: Any):  # fmt: skip
        self.explore = explore
        self.costmap_params = costmap_params
        self.blank = blank
        self.inscribed = costmap_params.inscribed_radius
        super().__init__([], make_costmap(blank, costmap_params), *args, **kwargs)
        self._map = self.DeclareAbstractInputPort("map", AbstractValue.Make(blank))

    def _costmap(self, nav: NavState) -> Costmap:
        return nav.explore.costmap

    def _advance(self, context, nav: NavState, pose, speed, now: float):
        ex = nav.explore or ExploreState(costmap=self.costmap, progress_at=now)
        nav = dc.replace(nav, explore=ex)
        if not math.isnan(ex.done_at):
            return nav, 0.0, 0.0
        if now - ex.searched_at >= 1.0 / self.explore.planner_frequency - 1e-9:
            nav = self._search(self._map.Eval(context), nav, pose, now)
            ex = nav.explore
        if ex.goal is None:
            return nav, 0.0, 0.0
        distance = math.hypot(pose[0] - ex.goal.x, pose[1] - ex.goal.y)
        if distance < ex.best_distance - 0.01:
            nav = dc.replace(nav, explore=dc.replace(ex, best_distance=distance, progress_at=now))
        elif now - ex.progress_at > self.explore.progress_timeout:
            return self._finish(nav, pose, now, "progress timeout"), 0.0, 0.0
        return self._step(nav, pose, speed, now)

    def _search(self, grid: OccupancyMap, nav: NavState, pose, now: float) -> NavState:
        """The frontiers on the map as published; the goal kept or a new one sent."""
        ex = nav.explore
        costmap = ex.costmap
        if grid is not ex.grid:  # a map published since: its costmap
            costmap = make_costmap(grid, self.costmap_params)
        found = frontiers(grid, costmap, pose[:2], self.explore, ex.blacklist)
        ex = dc.replace(ex, grid=grid, costmap=costmap, searched_at=now, frontiers=len(found))
        if ex.goal is not None:
            cells = costmap.cell_to_world(*np.nonzero(frontier_cells(grid)))
            if len(cells) and np.hypot(*(cells - (ex.goal.x, ex.goal.y)).T).min() <= KEEP_GOAL:
                return dc.replace(nav, explore=ex)
        if not found:
            if (grid.data != UNKNOWN).any():
                if ex.goal is not None:
                    result = self._result(dc.replace(nav, explore=ex), now, "explored")
                    nav = dc.replace(nav, results=(*nav.results, result))
                ex = dc.replace(ex, goal=None, done_at=now)
                _log.info("exploration done at %.2f s: no frontier left", now)
            return dc.replace(nav, explore=ex)
        if ex.goal is not None:  # the frontier explored on the way: a new goal replaces it
            nav = dc.replace(nav, results=(*nav.results, self._result(nav, now, "superseded")))
        best = found[0]
        heading = math.atan2(best.goal[1] - pose[1], best.goal[0] - pose[0])
        goal = NavigationGoal(f"frontier_{ex.sent + 1}", best.goal[0], best.goal[1], heading)
        ex = dc.replace(ex, goal=goal, sent=ex.sent + 1, best_distance=math.inf, progress_at=now)
        nav = dc.replace(nav, explore=ex, goals=(*nav.goals, goal))
        return self._start(nav, len(nav.goals) - 1, pose, now)

    def _plan(self, nav: NavState, pose, now: float) -> NavState:
        """NavFn's plan on the map as it is; when it fails the old plan is dropped (the
        frontier is aborted: the map showed it unreachable)."""
        return super()._plan(dc.replace(nav, path=None), pose, now)

    def _goal_reached(self, nav: NavState, pose, speed):
        """A frontier is reached within the goal checker's xy tolerance, at any heading."""
        goal = nav.explore.goal
        return math.hypot(pose[0] - goal.x, pose[1] - goal.y) <= (
            self.controller.xy_goal_tolerance
        ), nav

    def _finish(self, nav: NavState, pose, now: float, reason: str, then=True) -> NavState:
        """The frontier's result; its goal blacklisted; a new search at the next cycle."""
        ex = nav.explore
        goal, result = ex.goal, self._result(nav, now, reason)
        _log.info("frontier %r: %s at %.2f s", goal.name, reason, now)
        ex = dc.replace(
            ex, goal=None, blacklist=(*ex.blacklist, (goal.x, goal.y)), searched_at=-math.inf
        )
        return dc.replace(nav, explore=ex, path=None, results=(*nav.results, result))

    @staticmethod
    def _result(nav: NavState, now: float, reason: str) -> GoalResult:
        goal, truth = nav.explore.goal, nav.last_pose
        return GoalResult(
            name=goal.name, reached=reason == "reached", reason=reason, start=nav.started,
            end=now, pose=tuple(float(v) for v in truth),
            position_error=math.hypot(truth[0] - goal.x, truth[1] - goal.y), yaw_error=0.0,
            path_length=nav.driven, plan_length=nav.plan_length,
        )  # fmt: skip

    def exploration(self, context) -> dict[str, Any]:
        """The exploration's figures at ``context``'s time."""
        nav = context.get_abstract_state(self._nav).get_value()
        ex = nav.explore or ExploreState()
        return {
            "frontier_goals": ex.sent,
            "frontiers_left": max(ex.frontiers, 0),
            "done": not math.isnan(ex.done_at),
            "done_at": None if math.isnan(ex.done_at) else ex.done_at,
            "blacklisted": len(ex.blacklist),
        }
