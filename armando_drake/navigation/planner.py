"""NavFn's global planner over a costmap: the least-cost path from a start to a goal.

NavFn's cost of a cell (``NavFn::setCostmap``): ``COST_NEUTRAL + COST_FACTOR * cost`` =
``50 + 0.8 cost`` for costs below 253 (capped at 253); inscribed (253) and lethal (254)
cells are blocked, unknown (255) ones cost 253 with ``allow_unknown`` and are blocked
without. The path is the least-cost one on the 8-connected grid (a step costs the mean of
its two cells' costs times its length, 1 or sqrt 2 cells) found by SciPy's Dijkstra
(``scipy.sparse.csgraph``) from the start cell; ``use_astar`` is accepted and gives the
same path (A* with an admissible heuristic finds the same least cost; only the search
order differs). Upstream interpolates a smooth path on the potential field; here the path
is the sequence of cell centres between the robot's position (its first point) and the
goal's (its last point, placed as ``smoothApproachToGoal`` places it: it replaces the last
cell centre when that one is farther from the one before than the goal, else it follows
it); a goal at the start's very position is a plan of one pose (``createPlan``'s corner
case). With ``use_final_approach_orientation`` the plan's last pose faces along its last
segment (:meth:`NavfnPlanner.final_orientation`), else the goal's heading.

As NavfnPlanner, the start cell is cleared (the robot stands there), and a goal that is
blocked or unreachable is replaced by the reachable cell nearest to it within
``tolerance`` metres; with none, the goal is refused.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armando_drake.navigation.cost_values import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION
from armando_drake.navigation.costmap import Costmap
from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.navigation.registry import PLANNERS
from armando_drake.tools.errors import ConfigError, UserInputError
from armando_drake.tools.schema import param

_log = logging.getLogger("armando_drake.navigation")

COST_NEUTRAL = 50
COST_FACTOR = 0.8
COST_OBS = 254
NAVFN = "nav2_navfn_planner/NavfnPlanner"
# planner_server's own keys accepted without effect (expected_planner_frequency is the
# controller's to read).
PLANNER_SERVER_KNOWN = {"use_sim_time", "planner_plugins", "expected_planner_frequency"}


class PlanningError(UserInputError):
    """A start or goal the planner refuses; one line naming the point and why."""


@dataclass
class PlannerParameters:
    """NavfnPlanner's parameters (defaults: upstream's)."""

    tolerance: float = param(
        0.5, unit="m", ge=0, doc="a blocked goal is replaced by the nearest free cell within it"
    )
    use_astar: bool = param(False, doc="A* instead of Dijkstra (the same plan cost)")
    allow_unknown: bool = param(True, doc="the plan may cross unknown cells")
    use_final_approach_orientation: bool = param(
        False, doc="the plan's last pose faces along its last segment, not the goal's heading"
    )


@PLANNERS.register(NAVFN, instead="NavFn plans instead")
class NavfnPlanner:
    """nav2_navfn_planner's NavfnPlanner: :func:`plan` with its parameters."""

    Parameters = PlannerParameters

    def __init__(self, params: PlannerParameters):
        self.params = params

    def plan(self, costmap: Costmap, start, goal) -> np.ndarray:
        """The path (n, 2) from ``start`` (x, y) to ``goal`` (x, y)."""
        return plan(costmap, start, goal, self.params)

    def final_orientation(self, path: np.ndarray, start_yaw: float, goal_yaw: float) -> float:
        """The heading of the plan's last pose (:func:`final_orientation`)."""
        return final_orientation(path, start_yaw, goal_yaw, self.params)


# Planners Nav2 ships that are not implemented here: NavFn plans instead (their
# ``tolerance`` and ``allow_unknown`` read, as NavFn's).
for _name in (
    "nav2_smac_planner::SmacPlanner2D",
    "nav2_smac_planner::SmacPlannerHybrid",
    "nav2_smac_planner::SmacPlannerLattice",
    "nav2_theta_star_planner::ThetaStarPlanner",
):
    PLANNERS.substitute(_name, NAVFN)


def planner_plugin(source: Nav2Params | str | Path, name: str = "GridBased"):
    """The ``planner_server`` plugin ``name`` of a Nav2 file: its registered class made
    with its parameters (keys it does not read warned about)."""
    nav2 = as_nav2(source)
    where = f"{nav2.where('planner_server')}.{name}"
    node = (nav2.node("planner_server") or {}).get(name)
    if not isinstance(node, dict):
        raise ConfigError(f"{where}: missing")
    plugin, node = PLANNERS.load(node, where)
    params = plugin.cls.Parameters()
    for key in fill(params, node, where):
        if key != "plugin":
            _log.warning("%s.%s: not used here", where, key)
    return plugin.cls(params)


def planner_parameters(source: Nav2Params | str | Path, name: str = "GridBased"):
    """The ``planner_server`` plugin ``name``'s parameters of a Nav2 file."""
    return planner_plugin(source, name).params


def navfn_costs(costs: np.ndarray, allow_unknown: bool) -> np.ndarray:
    """NavFn's cell costs (float, ``inf`` where blocked) of a costmap's costs."""
    c = np.minimum(COST_NEUTRAL + COST_FACTOR * costs.astype(float), COST_OBS - 1)
    c = np.floor(c)  # NavFn stores them as unsigned char
    c[costs >= INSCRIBED_INFLATED_OBSTACLE] = np.inf
    if allow_unknown:
        c[costs == NO_INFORMATION] = COST_OBS - 1
    return c


def _graph(cell_costs: np.ndarray):
    """The 8-connected grid graph between passable cells (undirected, upper half; a
    SciPy CSR matrix)."""
    from scipy import sparse  # the navigation extra: imported where used

    h, w = cell_costs.shape
    index = np.arange(h * w).reshape(h, w)
    rows, cols, weights = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r0, r1 = slice(0, h - dr), slice(dr, h)
        c0, c1 = (slice(0, w - dc), slice(dc, w)) if dc >= 0 else (slice(1, w), slice(0, w - 1))
        a, b = cell_costs[r0, c0], cell_costs[r1, c1]
        ok = np.isfinite(a) & np.isfinite(b)
        step = math.hypot(dr, dc)
        rows.append(index[r0, c0][ok])
        cols.append(index[r1, c1][ok])
        weights.append(step * 0.5 * (a[ok] + b[ok]))
    return sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
        shape=(h * w, h * w),
    )


def _goal_cell(costmap: Costmap, reachable: np.ndarray, goal, tolerance: float):
    """The goal's cell, or the reachable one nearest to it within ``tolerance``."""
    row, col = costmap.world_to_cell(*goal)
    if costmap.contains(row, col) and reachable[row, col]:
        return row, col
    radius = int(math.ceil(tolerance / costmap.resolution))
    h, w = reachable.shape
    r0, r1 = max(0, row - radius), min(h, row + radius + 1)
    c0, c1 = max(0, col - radius), min(w, col + radius + 1)
    if r0 < r1 and c0 < c1:
        rr, cc = np.nonzero(reachable[r0:r1, c0:c1])
        centres = costmap.cell_to_world(rr + r0, cc + c0)
        d = np.hypot(centres[:, 0] - goal[0], centres[:, 1] - goal[1])
        if d.size and d.min() <= tolerance:
            k = int(np.argmin(d))
            return int(rr[k] + r0), int(cc[k] + c0)
    where = (
        "outside the map"
        if not costmap.contains(row, col)
        else (
            f"in an obstacle (cost {int(costmap.costs[row, col])})"
            if costmap.costs[row, col] >= INSCRIBED_INFLATED_OBSTACLE
            else "unreachable from the start"
        )
    )
    raise PlanningError(
        f"goal ({goal[0]:.3f}, {goal[1]:.3f}) is {where}, with no reachable cell within "
        f"the tolerance of {tolerance} m"
    )


def plan(costmap: Costmap, start, goal, params: PlannerParameters | None = None) -> np.ndarray:
    """NavFn's path from ``start`` (x, y) to ``goal`` (x, y) in world coordinates, shape
    (n, 2): ``start``, the centres of the cells it crosses after the start's, ``goal``
    (or, when the goal is blocked, the centre of the reachable cell within ``tolerance``
    nearest to it). A goal at the start's very position is a one-pose plan."""
    params = params or PlannerParameters()
    srow, scol = costmap.world_to_cell(*start)
    if not costmap.contains(srow, scol):
        raise PlanningError(f"start ({start[0]:.3f}, {start[1]:.3f}) is outside the map")
    if start[0] == goal[0] and start[1] == goal[1]:  # createPlan's corner case: one pose
        return np.array([start[:2]], dtype=float)
    cell_costs = navfn_costs(costmap.costs, params.allow_unknown)
    cell_costs[srow, scol] = COST_NEUTRAL  # clearRobotCell
    h, w = cell_costs.shape
    source = srow * w + scol
    from scipy.sparse import csgraph

    distances, predecessors = csgraph.dijkstra(
        _graph(cell_costs), directed=False, indices=source, return_predecessors=True
    )
    reachable = np.isfinite(distances).reshape(h, w)
    grow, gcol = _goal_cell(costmap, reachable, goal, params.tolerance)
    node = grow * w + gcol
    nodes = [node]
    while node != source:
        node = predecessors[node]
        nodes.append(node)
    nodes = np.array(nodes[::-1])
    cells = costmap.cell_to_world(nodes // w, nodes % w)
    exact = (grow, gcol) == costmap.world_to_cell(*goal)  # else the nearest cell's centre
    end = np.asarray(goal[:2], dtype=float) if exact else cells[-1]
    return smooth_approach_to_goal(np.vstack([np.asarray(start[:2], dtype=float), cells[1:]]), end)


def smooth_approach_to_goal(path: np.ndarray, goal) -> np.ndarray:
    """NavfnPlanner's ``smoothApproachToGoal``: ``goal`` replaces the path's last point
    when that one is farther from the point before it than the goal is (or is the goal's
    position), else it is appended."""
    goal = np.asarray(goal, dtype=float)
    if len(path) >= 2:
        before, last = path[-2], path[-1]
        if np.sum((last - before) ** 2) > np.sum((goal - before) ** 2) or (
            np.sum((last - goal) ** 2) < 1e-6
        ):
            return np.vstack([path[:-1], goal])
    return np.vstack([path, goal])


def final_orientation(path: np.ndarray, start_yaw: float, goal_yaw: float, params=None) -> float:
    """The heading of the plan's last pose: the goal's, or with
    ``use_final_approach_orientation`` the direction of its last segment (the one before
    when the last two points coincide; a one-point plan: the start's heading)."""
    if params is None or not params.use_final_approach_orientation:
        return goal_yaw
    if len(path) == 1:
        return start_yaw
    last, approach = path[-1], path[-2]
    if np.all(np.abs(last - approach) < 1e-4) and len(path) > 2:
        approach = path[-3]
    return math.atan2(last[1] - approach[1], last[0] - approach[0])


def plan_heading(planner, path: np.ndarray, start_yaw: float, goal_yaw: float) -> float:
    """The heading of ``planner``'s plan ``path`` at its end: the planner's own
    (:meth:`NavfnPlanner.final_orientation`), else the goal's."""
    final = getattr(planner, "final_orientation", None)
    return goal_yaw if final is None else final(path, start_yaw, goal_yaw)


def path_length(path: np.ndarray) -> float:
    """The length of a path of points (n, 2), in metres."""
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
