"""A navigation drawn live in Meshcat, as RViz shows Nav2: the map, the global costmap, the
plan and the goals.

==================================== ==================================================
Meshcat path                         what
==================================== ==================================================
``/drake/navigation/map``            the map's occupied cells (dark grey points); with
                                     exploration, the mapper's published map (``/map``),
                                     redrawn when a new one is published
``/drake/navigation/costmap``        the global costmap's inflated cells, coloured by cost
                                     from light blue (low) to magenta (inscribed); with
                                     an obstacle layer, as the scans update it, each second
``/drake/navigation/plan/<k>``       the global plans (green lines), the current one
                                     shown; a replay shows each while it was current
``/drake/navigation/goals/<name>``   each goal: a sphere, and a short line for its heading
==================================== ==================================================

In a world of several robots each robot's navigation is under
``/drake/navigation/<robot>``.

:class:`NavigationView` reads the navigator's state at a few hertz and redraws only what
changed (a new plan, a new goal, a new map): nothing at the plant's steps.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Meshcat, Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.perception import BaseField, Fields, PointCloud
from pydrake.systems.framework import LeafSystem

from armando_drake.navigation.navigator import NavState

NAV_PATH = "/drake/navigation"
MAP_COLOUR = Rgba(0.15, 0.15, 0.15, 1.0)
PLAN_COLOUR = Rgba(0.1, 0.8, 0.2, 1.0)
GOAL_COLOUR = Rgba(1.0, 0.6, 0.0, 0.9)
MAP_HEIGHT = 0.01  # [m] above the floor, under the robot
COSTMAP_HEIGHT = 0.005  # [m]
PLAN_HEIGHT = 0.02  # [m]
GOAL_RADIUS = 0.06  # [m]
RATE = 4.0  # [Hz] the view's redraws
MAX_PLANS = 1000  # plans kept for the replay (a longer run keeps its latest)
LETHAL = 253  # nav2_costmap_2d's inscribed cost; 254 lethal, 255 unknown


def cell_centres(mask: np.ndarray, resolution: float, origin) -> np.ndarray:
    """The world (x, y) of the centres of the cells where ``mask`` is true, (2, n); row 0
    of the grid is at the bottom, at ``origin`` (x, y, yaw)."""
    rows, cols = np.nonzero(mask)
    local = np.vstack([(cols + 0.5) * resolution, (rows + 0.5) * resolution])
    x0, y0, yaw = origin
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]]) @ local + np.array([[x0], [y0]])


def _cloud(xy: np.ndarray, z: float, rgb: np.ndarray | None = None) -> PointCloud:
    fields = BaseField.kXYZs | (BaseField.kRGBs if rgb is not None else 0)
    cloud = PointCloud(xy.shape[1], Fields(fields))
    cloud.mutable_xyzs()[:] = np.vstack([xy, np.full(xy.shape[1], z)]).astype(np.float32)
    if rgb is not None:
        cloud.mutable_rgbs()[:] = rgb
    return cloud


def cost_colours(costs: np.ndarray) -> np.ndarray:
    """RViz's costmap scheme, simplified: light blue at cost 1 to magenta at the
    inscribed cost; (3, n) uint8."""
    t = np.clip(costs.astype(float) / LETHAL, 0.0, 1.0)
    low, high = np.array([[170], [210], [255]]), np.array([[230], [0], [230]])
    return (low + (high - low) * t).astype(np.uint8)


class NavigationView(LeafSystem):
    """Draws a navigation in Meshcat (see the module docstring).

    Ports:
      - input ``nav_state`` (the Navigator's :class:`NavState`);
      - input ``map`` (an OccupancyMap), with a mapper: the map it publishes.

    The view reads only its own input ports: it is handed its own context, never the
    root one (the diagram's Simulator, the replay's publish events and a notebook's
    ``ForcedPublish`` all hand it that).
    """

    replayed = True  # publish_replay forces its publish at each frame (:meth:`_Replay`)

    def __init__(self, meshcat: Meshcat, navigation, *, point_size: float, space: str = ""):
        super().__init__()
        self._meshcat = meshcat
        self.path = f"{NAV_PATH}/{space}" if space else NAV_PATH  # its Meshcat folder
        self._navigation = navigation
        self._point_size = point_size
        self._nav = self.DeclareAbstractInputPort("nav_state", AbstractValue.Make(NavState()))
        self._map = None
        if navigation.mapper is not None:
            blank = navigation.mapper.blank
            self._map = self.DeclareAbstractInputPort("map", AbstractValue.Make(blank))
        self._planned_at = None
        self._goals: tuple = ()
        self._map_drawn = None  # the published map drawn last
        self._costmap = None  # the costmap drawn last
        self._costmap_drawn_at = -math.inf
        self.plan_points = 0  # the points of the plan drawn last
        self.plans: list[float] = []  # [s] when each plan drawn (plan/<k>) was made
        self._replayed = None  # the plan a replay's frame shows (its index)
        self._replayed_at = math.inf  # the time of that frame
        self.map_cells = 0  # the occupied cells drawn last
        self.costmap_cells = 0  # the inflated cells drawn
        self.goals_drawn: list[str] = []
        self.DeclareInitializationPublishEvent(self._Start)
        self.DeclarePeriodicPublishEvent(1.0 / RATE, 0.0, self._Draw)
        self.DeclareForcedPublishEvent(self._Replay)

    def _Start(self, context, event=None) -> None:
        self._DrawMap(self._navigation.grid)
        self._DrawCostmap()
        self._Draw(context)

    def _DrawMap(self, grid) -> None:
        xy = cell_centres(np.asarray(grid.data) >= 65, grid.resolution, grid.origin)
        self._meshcat.SetObject(
            f"{self.path}/map", _cloud(xy, MAP_HEIGHT), self._point_size, MAP_COLOUR
        )
        self.map_cells = xy.shape[1]

    def _DrawCostmap(self, costmap=None) -> None:
        costmap = costmap if costmap is not None else self._navigation.costmap
        self._costmap = costmap
        costs = np.asarray(costmap.costs)
        inflated = (costs > 0) & (costs < 254)
        xy = cell_centres(inflated, costmap.resolution, costmap.origin)
        cloud = _cloud(xy, COSTMAP_HEIGHT, cost_colours(costs[inflated]))
        self._meshcat.SetObject(f"{self.path}/costmap", cloud, self._point_size)
        self.costmap_cells = xy.shape[1]

    def _Draw(self, context) -> None:
        nav = self._nav.Eval(context)
        now = context.get_time()
        if self._map is not None:
            published = self._map.Eval(context)
            if published is not self._map_drawn:
                self._map_drawn = published
                self._DrawMap(published)
        # With an obstacle layer, the global costmap the scans update (redrawn each second).
        live = nav.costmaps[0] if nav.costmaps else None
        if live is not None and live is not self._costmap and now - self._costmap_drawn_at >= 1:
            self._costmap_drawn_at = now
            self._DrawCostmap(live)
        if nav.goals != self._goals:
            self._goals = nav.goals
            for goal in nav.goals:
                self._DrawGoal(goal)
        if nav.path is not None and nav.planned_at != self._planned_at:
            self._planned_at = nav.planned_at
            path = np.asarray(nav.path, dtype=float).T
            vertices = np.vstack([path, np.full(path.shape[1], PLAN_HEIGHT)])
            if len(self.plans) >= MAX_PLANS:  # the oldest's place: the newest is what counts
                self.plans.pop(0)
                self._meshcat.Delete(f"{self.path}/plan/{len(self.plans)}")
            k = len(self.plans)
            self._meshcat.SetLine(f"{self.path}/plan/{k}", vertices, 3.0, PLAN_COLOUR)
            if k:
                self._meshcat.SetProperty(f"{self.path}/plan/{k - 1}", "visible", False)
            self.plans.append(float(nav.planned_at))
            self.plan_points = path.shape[1]

    def _Replay(self, context, event=None) -> None:
        """In a replay's frame at ``context``'s time (publish_replay forces a publish at
        each): the plan that was current then shown, the others hidden."""
        now = context.get_time()
        if now < self._replayed_at:  # a new replay from its start: every plan set again
            self._replayed = None
        self._replayed_at = now
        current = sum(1 for made in self.plans if made <= now + 1e-9) - 1
        if current == self._replayed:
            return
        shown = {current} if self._replayed is not None else set(range(len(self.plans)))
        for k in shown | ({self._replayed} if self._replayed is not None else set()):
            if 0 <= k < len(self.plans):
                visible = k == current
                self._meshcat.SetProperty(f"{self.path}/plan/{k}", "visible", visible, now)
        self._replayed = current

    def _DrawGoal(self, goal) -> None:
        path = f"{self.path}/goals/{goal.name or 'goal'}"
        self._meshcat.SetObject(f"{path}/position", Sphere(GOAL_RADIUS), GOAL_COLOUR)
        self._meshcat.SetTransform(path, RigidTransform([goal.x, goal.y, GOAL_RADIUS]))
        heading = np.array([[0.0, 0.25 * math.cos(goal.yaw)], [0.0, 0.25 * math.sin(goal.yaw)]])
        self._meshcat.SetLine(
            f"{path}/heading", np.vstack([heading, np.zeros(2)]), 4.0, GOAL_COLOUR
        )
        self.goals_drawn.append(goal.name)


def AddNavigationView(
    builder, navigation, meshcat: Meshcat, *, space: str = ""
) -> NavigationView | None:
    """A :class:`NavigationView` of ``navigation`` (a robot's Navigation) in ``meshcat``
    (None without one); ``space``: the robot's namespace in a world of several."""
    if navigation is None:
        return None
    size = navigation.grid.resolution
    view = builder.AddNamedSystem(
        f"{space}/navigation_view" if space else "navigation_view",
        NavigationView(meshcat, navigation, point_size=size, space=space),
    )
    builder.Connect(navigation.navigator.GetOutputPort("nav_state"), view.GetInputPort("nav_state"))
    if navigation.mapper is not None:
        builder.Connect(navigation.mapper.GetOutputPort("map"), view.GetInputPort("map"))
    return view
