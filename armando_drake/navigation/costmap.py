"""Costmaps as nav2_costmap_2d builds them: a costmap's parameters and its layers composed.

Costs are nav2_costmap_2d's (:mod:`.cost_values`): 0 free, 1..252 inflated, 253 inscribed
(the robot's centre there means a collision), 254 lethal, 255 unknown. The layers are
plugins registered by their Nav2 names (:data:`~.registry.LAYERS`), each in its module:
:mod:`.static_layer`, :mod:`.inflation_layer`, :mod:`.obstacle_layer` (``VoxelLayer``
runs as it). :func:`costmap_parameters` reads a costmap of a Nav2 file, each layer of its
``plugins`` configured by its registered plugin.

The costmap takes the map's size and resolution (a non-rolling global costmap resizes to
the static map, whatever its ``resolution`` parameter). A local costmap (``rolling_window:
true``) is a ``width`` x ``height`` window centred on the robot, on the same grid.
:func:`make_costmap` is the static layer then the inflation layer; :func:`layered_costmap`
the static layer, the obstacle layer by its maximum (``updateWithMax``;
``combination_method: 0`` overwrites, ``2`` keeps unknown cells unknown), the rolling window,
then the inflation layer. The footprint (``robot_radius`` as upstream's 16-point polygon,
``footprint_padding`` applied) and its collision checker are :mod:`.footprint`'s.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armando_drake.navigation.cost_values import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
)
from armando_drake.navigation.footprint import (
    footprint_cost,
    footprint_from_radius,
    footprint_from_string,
    min_max_distances,
    pad_footprint,
)
from armando_drake.navigation.inflation_layer import inflate
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.navigation.obstacle_layer import ObstacleParameters, empty_obstacles
from armando_drake.navigation.registry import LAYERS
from armando_drake.navigation.static_layer import static_layer
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import is_number, param

MAX_FOOTPRINT_POINTS = 100  # a footprint polygon's points
MAX_ROBOT_SIZE = 10.0  # [m] the largest robot_radius, and footprint point's distance
MAX_INFLATION_RADIUS = 50.0  # [m]

_log = logging.getLogger("armando_drake.navigation")

# The costmap parameters this package reads, and those it knows and leaves to what is to
# come (frames, rates, topics of the ROS node); any other key is warned about.
_READ = {
    "resolution",
    "robot_radius",
    "plugins",
    "track_unknown_space",
    "lethal_cost_threshold",
    "trinary_costmap",
    "unknown_cost_value",
    "rolling_window",
    "width",
    "height",
    "update_frequency",
    "footprint",
    "footprint_padding",
}
_KNOWN = {
    "use_sim_time",
    "update_frequency",
    "publish_frequency",
    "global_frame",
    "robot_base_frame",
    "always_send_full_costmap",
    "origin_x",
    "origin_y",
    "transform_tolerance",
    "map_topic",
    "filters",
    "initial_transform_timeout",
    "use_maximum",
}
_COSTMAP_KEYS = (
    "resolution", "robot_radius", "rolling_window", "width", "height", "update_frequency",
    "track_unknown_space", "trinary_costmap", "lethal_cost_threshold", "footprint_padding",
)  # fmt: skip


def _m(default, doc):
    return param(default, unit="m", ge=0, doc=doc)


@dataclass
class CostmapParameters:
    """A costmap's parameters as Nav2 reads them (defaults: nav2_costmap_2d's)."""

    resolution: float = param(
        0.05,
        unit="m",
        gt=0,
        under=(1e-4, "a grid that fine is too large to build"),
        le=100.0,
        doc="the costmap's cell size (a static map's resolution wins)",
    )
    robot_radius: float = param(
        0.1,
        unit="m",
        gt=0,
        over=(MAX_ROBOT_SIZE, "no mobile base here is that large"),
        doc="the circular footprint's radius (a padded 16-point polygon)",
    )
    track_unknown_space: bool = param(
        False, doc="unknown cells stay NO_INFORMATION (255) instead of free"
    )
    lethal_cost_threshold: int = param(
        100, unit="-", ge=1, le=100, doc="occupancy at or above which a map cell is lethal"
    )
    trinary_costmap: bool = param(
        True, doc="map cells are free, lethal or unknown (else scaled occupancy)"
    )
    static_layer: bool = True
    inflation_layer: bool = True
    inflation_radius: float = param(
        0.55,
        unit="m",
        ge=0,
        over=(MAX_INFLATION_RADIUS, "the inflation would cover the whole map"),
        doc="how far from obstacles costs are inflated",
    )
    cost_scaling_factor: float = param(
        10.0, unit="-", ge=0, doc="the exponential decay of the inflated cost with distance"
    )
    inflate_unknown: bool = param(False, doc="unknown cells are inflated too")
    inflate_around_unknown: bool = param(False, doc="unknown cells are inflation sources")
    plugins: list[str] = field(default_factory=list)
    obstacle_layer: ObstacleParameters | None = None
    rolling_window: bool = param(False, doc="a window centred on the robot (local costmap)")
    width: float = param(5.0, unit="m", gt=0, doc="a rolling window's width")
    height: float = param(5.0, unit="m", gt=0, doc="a rolling window's height")
    update_frequency: float = param(
        5.0, unit="Hz", gt=0, doc="how often the obstacle layer takes a scan"
    )
    footprint: list = field(default_factory=list)  # [[x, y], ...]; [] = robot_radius
    footprint_padding: float = param(
        0.01, unit="m", ge=0, doc="added to each footprint point's x and y, away from the centre"
    )
    ignored: list[str] = field(default_factory=list)
    """Keys read from the file that this package does not use (each one warned about)."""

    @property
    def polygon(self) -> list[tuple[float, float]]:
        """The padded footprint, as Costmap2DROS sets it: ``footprint``, or ``robot_radius``
        as the 16-point polygon, with ``footprint_padding`` (:mod:`.footprint`)."""
        points = self.footprint or footprint_from_radius(self.robot_radius)
        return pad_footprint([tuple(p) for p in points], self.footprint_padding)

    @property
    def inscribed_radius(self) -> float:
        """The inscribed radius the inflation and the controller use, as LayeredCostmap
        computes it: the padded polygon's nearest vertex or edge (:attr:`polygon`; for a
        ``robot_radius`` its padded 16-gon's: 0.2059 m for 0.2 m)."""
        return min_max_distances(self.polygon)[0]

    @property
    def nav2_inscribed_radius(self) -> float:
        """The padded footprint's inscribed radius as LayeredCostmap computes it (the same
        as :attr:`inscribed_radius`)."""
        return self.inscribed_radius


@dataclass
class Costmap:
    """A 2-D costmap: ``costs`` uint8 (height, width), row 0 at the bottom, with the map's
    resolution and origin."""

    costs: np.ndarray
    resolution: float
    origin: tuple[float, float, float]

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """The (row, column) of the cell holding the world point (x, y)."""
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        return row, col

    def cell_to_world(self, rows, cols) -> np.ndarray:
        """The world (x, y) of cell centres, shape (n, 2)."""
        rows = np.asarray(rows, dtype=float)
        cols = np.asarray(cols, dtype=float)
        x = self.origin[0] + (cols + 0.5) * self.resolution
        y = self.origin[1] + (rows + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    def contains(self, row: int, col: int) -> bool:
        return 0 <= row < self.costs.shape[0] and 0 <= col < self.costs.shape[1]


def _layer(params: CostmapParameters, name: str, layer, where: str, ignored: list[str]) -> None:
    if not isinstance(layer, dict) or "plugin" not in layer:
        raise ConfigError(f"{where}.{name}.plugin: the layer '{name}' has no plugin type")
    plugin, _ = LAYERS.load(layer, f"{where}.{name}")
    plugin.cls.configure(params, name, layer, where, ignored)


def has_costmap(source: Nav2Params | str | Path, costmap: str) -> bool:
    """Whether a Nav2 file has the costmap ``<costmap>/<costmap>/ros__parameters``."""
    return as_nav2(source).node(costmap, costmap) is not None


def costmap_parameters(
    source: Nav2Params | str | Path, costmap: str = "global_costmap"
) -> CostmapParameters:
    """The parameters of ``<costmap>/<costmap>/ros__parameters`` in a Nav2 file; keys not
    used here are warned about (and listed in ``ignored``)."""
    nav2 = as_nav2(source)
    where = nav2.where(costmap, costmap)
    ros = nav2.node(costmap, costmap)
    if ros is None:
        raise ConfigError(f"{where}: missing (no costmap '{costmap}' in the file)")
    params = CostmapParameters()
    fill(params, ros, where, _COSTMAP_KEYS)
    params.footprint = _footprint(ros.get("footprint", "[]"), f"{where}.footprint")
    plugins = ros.get("plugins", ["static_layer", "obstacle_layer", "inflation_layer"])
    if not isinstance(plugins, list) or not all(isinstance(p, str) for p in plugins):
        raise ConfigError(f"{where}.plugins must be a list of layer names, not {plugins!r}")
    params.plugins = list(plugins)
    params.static_layer = params.inflation_layer = False
    ignored: list[str] = []
    for name in plugins:
        _layer(params, name, ros.get(name), where, ignored)
    ignored += [f"{where}.{k}" for k in ros if k not in _READ | _KNOWN and k not in plugins]
    for key in ignored:
        _log.warning("%s: not used by the costmap here", key)
    params.ignored = ignored
    return params


def _footprint(value, where: str) -> list:
    """A footprint polygon, as Nav2 takes it: a string "[[x, y], ...]" (read as
    ``makeFootprintFromString``; "[]" none) or a list."""
    if isinstance(value, str):
        if value.strip() in ("", "[]"):
            return []
        try:
            value = [list(p) for p in footprint_from_string(value)]
        except ValueError as error:
            raise ConfigError(f"{where}: {value!r}: {error}") from None
    if not value:
        return []
    if (
        not isinstance(value, list)
        or len(value) < 3
        or not all(isinstance(p, list) and len(p) == 2 for p in value)
    ):
        raise ConfigError(f"{where}: {value!r} is not a polygon [[x, y], ...] of 3 points or more")
    if not all(is_number(c) and math.isfinite(c) for p in value for c in p):
        raise ConfigError(f"{where}: {value!r}: every coordinate must be a finite number [m]")
    if len(value) > MAX_FOOTPRINT_POINTS:
        raise ConfigError(f"{where}: {len(value)} points, over {MAX_FOOTPRINT_POINTS}")
    points = [(float(p[0]), float(p[1])) for p in value]
    if max(abs(c) for p in points for c in p) > MAX_ROBOT_SIZE:
        raise ConfigError(
            f"{where}: {value!r} reaches farther than {MAX_ROBOT_SIZE:g} m from the robot"
        )
    problem = polygon_problem(points)
    if problem:
        raise ConfigError(f"{where}: {value!r} {problem}")
    return points


def polygon_problem(points: list[tuple[float, float]]) -> str:
    """Why ``points`` is not a simple polygon of positive area ("" if it is one)."""
    area = 0.5 * sum(
        a[0] * b[1] - b[0] * a[1] for a, b in zip(points, points[1:] + points[:1], strict=True)
    )
    if abs(area) < 1e-9:
        return "has no area (its points are on a line)"
    edges = list(zip(points, points[1:] + points[:1], strict=True))
    for i, (a, b) in enumerate(edges):
        for j in range(i + 2, len(edges)):
            if i == 0 and j == len(edges) - 1:
                continue  # the first and the last edge meet at the first point
            if _cross(a, b, *edges[j]):
                return f"crosses itself (edges {i} and {j})"
    return ""


def _cross(a, b, c, d) -> bool:
    """Whether the segments ab and cd cross (properly: not only touching)."""

    def side(p, q, r) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    return side(a, b, c) * side(a, b, d) < 0 and side(c, d, a) * side(c, d, b) < 0


def make_costmap(grid: OccupancyMap, params: CostmapParameters) -> Costmap:
    """The costmap of a map: its static layer, then its inflation layer."""
    costs = (
        static_layer(grid, params)
        if params.static_layer
        else np.zeros(grid.data.shape, dtype=np.uint8)
    )
    costs = inflate(costs, grid.resolution, params)
    return Costmap(costs=costs, resolution=grid.resolution, origin=grid.origin)


def layered_costmap(
    grid: OccupancyMap,
    params: CostmapParameters,
    obstacles: np.ndarray | None,
    robot: tuple[float, float] | None = None,
) -> Costmap:
    """The master grid: the static layer, the obstacle layer by its maximum (as
    ``updateWithMax``; ``combination_method: 0`` overwrites, ``2`` takes the maximum but
    leaves an unknown master cell unknown), then the inflation layer; a
    rolling window keeps only the ``width`` x ``height`` around ``robot``."""
    costs = (
        static_layer(grid, params)
        if params.static_layer
        else empty_obstacles(grid.data.shape, params)
    )
    layer = params.obstacle_layer
    if obstacles is not None and layer is not None and layer.enabled:
        seen = obstacles != NO_INFORMATION
        if layer.combination_method == 0:  # updateWithOverwrite
            costs[seen] = obstacles[seen]
        elif layer.combination_method == 2:  # updateWithMaxWithoutUnknownOverwrite
            take = seen & (costs != NO_INFORMATION) & (costs < obstacles)
            costs[take] = obstacles[take]
        else:  # updateWithMax
            take = seen & ((costs == NO_INFORMATION) | (costs < obstacles))
            costs[take] = obstacles[take]
    if params.rolling_window and robot is not None:
        rows, cols = np.indices(costs.shape)
        centres = Costmap(costs, grid.resolution, grid.origin).cell_to_world(rows, cols)
        outside = (np.abs(centres[..., 0] - robot[0]) > params.width / 2) | (
            np.abs(centres[..., 1] - robot[1]) > params.height / 2
        )
        costs[outside] = FREE_SPACE
    costs = inflate(costs, grid.resolution, params)
    return Costmap(costs=costs, resolution=grid.resolution, origin=grid.origin)


def path_blocked(costmap: Costmap, path: np.ndarray) -> bool:
    """Whether ``path`` (n, 2) crosses an obstacle of the costmap (a lethal cell, or one
    within the robot's inscribed radius of it)."""
    cols = np.floor((path[:, 0] - costmap.origin[0]) / costmap.resolution).astype(int)
    rows = np.floor((path[:, 1] - costmap.origin[1]) / costmap.resolution).astype(int)
    inside = (rows >= 0) & (rows < costmap.costs.shape[0])
    inside &= (cols >= 0) & (cols < costmap.costs.shape[1])
    costs = costmap.costs[rows[inside], cols[inside]]
    return bool(((costs >= INSCRIBED_INFLATED_OBSTACLE) & (costs <= LETHAL_OBSTACLE)).any())


def blocked_behind(costmap: Costmap, pose, distance: float, footprint) -> bool:
    """Whether backing up ``distance`` [m] from ``pose`` (x, y, yaw) puts the robot's
    ``footprint`` (the padded polygon) on a lethal cell, as the behaviour's collision
    checker finds it (:func:`~.footprint.footprint_cost` at least lethal)."""
    for d in np.arange(0.0, distance + 1e-9, 0.5 * costmap.resolution):
        x = pose[0] - d * math.cos(pose[2])
        y = pose[1] - d * math.sin(pose[2])
        if footprint_cost(costmap, (x, y, pose[2]), footprint) >= LETHAL_OBSTACLE:
            return True
    return False
