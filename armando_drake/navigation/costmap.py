"""Costmaps as nav2_costmap_2d builds them: the static layer and the inflation layer.

Costs are nav2_costmap_2d's (``cost_values.hpp``): 0 free, 1..252 inflated, 253
inscribed (the robot's centre there means a collision), 254 lethal, 255 unknown.

- Static layer (``StaticLayer::interpretValue``): an occupancy of -1 is unknown (255), or
  free with ``track_unknown_space: false``; occupancy >= ``lethal_cost_threshold`` (100)
  lethal; any other cell free (``trinary_costmap: true``) or ``254 * value / 100``.
- Inflation layer (``InflationLayer::computeCost``): with ``d`` the Euclidean distance from
  a cell's centre to the nearest lethal cell's (a distance transform, as upstream's own),
  the cost is 254 at ``d = 0``, 253 for ``d <= inscribed_radius``, else
  ``int(252 * exp(-cost_scaling_factor * (d - inscribed_radius)))``, for cells with
  ``d <= ceil(inflation_radius / resolution)`` cells; a cell keeps the larger of its cost and
  the inflated one (an unknown cell only becomes >= 253). Distances are quantized to
  1/100 cell, as upstream's lookup table.

- Obstacle layer (``ObstacleLayer``, ``data_type: LaserScan`` sources): each scan clears
  the cells along its beams (``clearing``: from ``raytrace_min_range`` to the hit, or to
  ``raytrace_max_range``) and then marks the hit cells lethal (``marking``: ranges within
  ``obstacle_min_range``..``obstacle_max_range``, the scan's height within
  ``min_obstacle_height``..``max_obstacle_height``); the layer is combined into the master
  grid by its maximum (``updateWithMax``: an unknown cell of the layer leaves the master's),
  then inflated. ``VoxelLayer`` runs as this obstacle layer (a planar lidar, 2-D).

The costmap takes the map's size and resolution (a non-rolling global costmap resizes to
the static map, whatever its ``resolution`` parameter). A local costmap (``rolling_window:
true``) is a ``width`` x ``height`` window centred on the robot, on the same grid.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.navigation.registry import LAYERS
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import param

FREE_SPACE = 0
MAX_NON_OBSTACLE = 252
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255
COST_LUT_PRECISION = 100

STATIC_LAYER = "nav2_costmap_2d::StaticLayer"
INFLATION_LAYER = "nav2_costmap_2d::InflationLayer"
OBSTACLE_LAYER = "nav2_costmap_2d::ObstacleLayer"
VOXEL_LAYER = "nav2_costmap_2d::VoxelLayer"

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
}
_KNOWN = {
    "use_sim_time",
    "update_frequency",
    "publish_frequency",
    "global_frame",
    "robot_base_frame",
    "always_send_full_costmap",
    "footprint_padding",
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
    "track_unknown_space", "trinary_costmap", "lethal_cost_threshold",
)  # fmt: skip
_INFLATION_KEYS = {
    "plugin",
    "enabled",
    "inflation_radius",
    "cost_scaling_factor",
    "inflate_unknown",
    "inflate_around_unknown",
}
_STATIC_KEYS = {
    "plugin",
    "enabled",
    "map_subscribe_transient_local",
    "subscribe_to_updates",
    "map_topic",
    "transform_tolerance",
    "footprint_clearing_enabled",
    "restore_cleared_footprint",
}

_OBSTACLE_KEYS = {
    "plugin",
    "enabled",
    "observation_sources",
    "max_obstacle_height",
    "min_obstacle_height",
    "footprint_clearing_enabled",
    "combination_method",
    # the VoxelLayer's own (its z voxels: a planar scan fills one)
    "publish_voxel_map",
    "origin_z",
    "z_resolution",
    "z_voxels",
    "mark_threshold",
    "unknown_threshold",
}
_SOURCE_KEYS = {
    "topic",
    "data_type",
    "marking",
    "clearing",
    "max_obstacle_height",
    "min_obstacle_height",
    "obstacle_max_range",
    "obstacle_min_range",
    "raytrace_max_range",
    "raytrace_min_range",
    "inf_is_valid",
    "expected_update_rate",
    "observation_persistence",
    "sensor_frame",
    "clear_after_reading",
}
_RANGES = (
    "min_obstacle_height", "max_obstacle_height", "obstacle_min_range", "obstacle_max_range",
    "raytrace_min_range", "raytrace_max_range",
)  # fmt: skip


def _m(default, doc):
    return param(default, unit="m", ge=0, doc=doc)


@dataclass
class ObservationSource:
    """One of an obstacle layer's ``observation_sources`` (defaults: Nav2's)."""

    name: str = "scan"
    topic: str = "scan"
    data_type: str = "LaserScan"
    marking: bool = param(True, doc="the scan's hits are marked lethal")
    clearing: bool = param(False, doc="the cells along the beams are cleared")
    min_obstacle_height: float = param(0.0, unit="m", doc="the lowest height marked")
    max_obstacle_height: float = _m(2.0, "the highest height marked")
    obstacle_min_range: float = _m(0.0, "nearer hits are not marked")
    obstacle_max_range: float = _m(2.5, "farther hits are not marked")
    raytrace_min_range: float = _m(0.0, "clearing starts this far from the sensor")
    raytrace_max_range: float = _m(3.0, "clearing ends this far from the sensor")
    inf_is_valid: bool = param(False, doc="an infinite range clears to the range's end")


@dataclass
class ObstacleParameters:
    """An obstacle layer (``nav2_costmap_2d::ObstacleLayer``)."""

    name: str = "obstacle_layer"
    enabled: bool = True
    sources: list[ObservationSource] = field(default_factory=list)
    footprint_clearing_enabled: bool = True
    combination_method: int = 1  # 0 overwrite, 1 maximum


@dataclass
class CostmapParameters:
    """A costmap's parameters as Nav2 reads them (defaults: nav2_costmap_2d's)."""

    resolution: float = param(
        0.05, unit="m", gt=0, doc="the costmap's cell size (a static map's resolution wins)"
    )
    robot_radius: float = param(
        0.1, unit="m", gt=0, doc="the circular footprint's radius: the inscribed radius"
    )
    track_unknown_space: bool = param(
        False, doc="unknown cells stay NO_INFORMATION (255) instead of free"
    )
    lethal_cost_threshold: int = param(
        100, unit="-", doc="occupancy at or above which a map cell is lethal"
    )
    trinary_costmap: bool = param(
        True, doc="map cells are free, lethal or unknown (else scaled occupancy)"
    )
    static_layer: bool = True
    inflation_layer: bool = True
    inflation_radius: float = _m(0.55, "how far from obstacles costs are inflated")
    cost_scaling_factor: float = param(
        10.0, unit="-", doc="the exponential decay of the inflated cost with distance"
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
    ignored: list[str] = field(default_factory=list)
    """Keys read from the file that this package does not use (each one warned about)."""

    @property
    def inscribed_radius(self) -> float:
        """The inscribed radius: the robot's radius (a circular footprint)."""
        if self.footprint:
            ring = self.footprint[1:] + self.footprint[:1]
            return min(
                abs(a[0] * b[1] - a[1] * b[0]) / max(math.dist(a, b), 1e-9)
                for a, b in zip(self.footprint, ring, strict=True)
            )
        return self.robot_radius


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


@LAYERS.register(STATIC_LAYER)
class StaticLayer:
    """nav2_costmap_2d's StaticLayer: the map's cells (:func:`static_layer`)."""

    title, keys, declared_in, honoured = "static_layer", _STATIC_KEYS, CostmapParameters, ()

    @staticmethod
    def configure(params: CostmapParameters, name: str, layer: dict, where: str, ignored) -> None:
        params.static_layer = bool(layer.get("enabled", True))
        ignored += [f"{where}.{name}.{k}" for k in layer if k not in _STATIC_KEYS]


@LAYERS.register(INFLATION_LAYER)
class InflationLayer:
    """nav2_costmap_2d's InflationLayer (:func:`inflate`)."""

    title, keys, declared_in = "inflation_layer", _INFLATION_KEYS, CostmapParameters
    honoured = _INFLATION_KEYS - {"plugin", "enabled"}

    @staticmethod
    def configure(params: CostmapParameters, name: str, layer: dict, where: str, ignored) -> None:
        params.inflation_layer = bool(layer.get("enabled", True))
        fill(params, layer, f"{where}.{name}", _INFLATION_KEYS - {"plugin", "enabled"})
        ignored += [f"{where}.{name}.{k}" for k in layer if k not in _INFLATION_KEYS]


@LAYERS.register(OBSTACLE_LAYER, instead="the obstacle layer runs instead (a planar scan, 2-D)")
class ObstacleLayer:
    """nav2_costmap_2d's ObstacleLayer on LaserScan sources (:func:`observe`)."""

    title, keys, declared_in = "obstacle_layer", _OBSTACLE_KEYS | _SOURCE_KEYS, ObservationSource
    honoured = {*_RANGES, "marking", "clearing", "inf_is_valid", "observation_sources", "topic",
                "data_type",
                "footprint_clearing_enabled", "combination_method"}  # fmt: skip

    @staticmethod
    def configure(params: CostmapParameters, name: str, layer: dict, where: str, ignored) -> None:
        obstacles = _obstacle_layer(name, layer, bool(layer.get("enabled", True)), where, ignored)
        if params.obstacle_layer is None or not params.obstacle_layer.enabled:
            params.obstacle_layer = obstacles
        elif obstacles.enabled:  # two obstacle layers (obstacle + voxel): their sources
            params.obstacle_layer.sources += obstacles.sources


LAYERS.substitute(VOXEL_LAYER, OBSTACLE_LAYER)  # a planar lidar fills one voxel


def _layer(params: CostmapParameters, name: str, layer, where: str, ignored: list[str]) -> None:
    if not isinstance(layer, dict) or "plugin" not in layer:
        raise ConfigError(f"{where}.{name}.plugin: the layer '{name}' has no plugin type")
    plugin, _ = LAYERS.load(layer, f"{where}.{name}")
    plugin.cls.configure(params, name, layer, where, ignored)


def _source(name: str, node, layer: dict, where: str, ignored: list[str]) -> ObservationSource:
    if not isinstance(node, dict):
        raise ConfigError(f"{where}.{name}: the observation source '{name}' has no parameters")
    source = ObservationSource(name=name, topic=str(node.get("topic", "")) or name)
    source.data_type = str(node.get("data_type", "PointCloud2"))
    if source.data_type not in ("LaserScan", "PointCloud2"):
        raise ConfigError(
            f"{where}.{name}.data_type: {source.data_type!r} is not LaserScan or PointCloud2"
        )
    for key in ("marking", "clearing", "inf_is_valid"):
        setattr(source, key, bool(node.get(key, getattr(source, key))))
    given = {k: node[k] if k in node else layer[k] for k in _RANGES if k in node or k in layer}
    fill(source, given, f"{where}.{name}", _RANGES)
    ignored += [f"{where}.{name}.{k}" for k in node if k not in _SOURCE_KEYS]
    return source


def _obstacle_layer(name: str, layer: dict, enabled: bool, where, ignored) -> ObstacleParameters:
    here = f"{where}.{name}"
    names = layer.get("observation_sources", "")
    if not isinstance(names, str):
        raise ConfigError(f"{here}.observation_sources must be a string of names, not {names!r}")
    params = ObstacleParameters(name=name, enabled=enabled)
    params.footprint_clearing_enabled = bool(layer.get("footprint_clearing_enabled", True))
    params.combination_method = int(layer.get("combination_method", 1))
    for source in names.split():
        params.sources.append(_source(source, layer.get(source), layer, here, ignored))
    known = _OBSTACLE_KEYS | set(names.split())
    ignored += [f"{here}.{k}" for k in layer if k not in known]
    return params


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
    """A footprint polygon, as Nav2 takes it: a string "[[x, y], ...]" (or a list)."""
    if isinstance(value, str):
        try:
            value = yaml.safe_load(value)
        except yaml.YAMLError:
            raise ConfigError(f"{where}: {value!r} is not [[x, y], ...]") from None
    if not value:
        return []
    if not isinstance(value, list) or len(value) < 3 or any(len(p) != 2 for p in value):
        raise ConfigError(f"{where}: {value!r} is not a polygon [[x, y], ...] of 3 points or more")
    return [(float(p[0]), float(p[1])) for p in value]


def static_layer(grid: OccupancyMap, params: CostmapParameters) -> np.ndarray:
    """StaticLayer's costs of an occupancy grid (uint8, the grid's shape)."""
    data = grid.data.astype(np.int16)
    unknown = data < 0
    costs = np.zeros(data.shape, dtype=np.uint8)
    if not params.trinary_costmap:
        scaled = np.clip(data, 0, None) / params.lethal_cost_threshold * LETHAL_OBSTACLE
        costs[:] = np.clip(scaled, 0, LETHAL_OBSTACLE).astype(np.uint8)
    costs[data >= params.lethal_cost_threshold] = LETHAL_OBSTACLE
    costs[unknown] = NO_INFORMATION if params.track_unknown_space else FREE_SPACE
    return costs


def inflation_cost(
    distance_cells, resolution: float, inscribed_radius: float, cost_scaling_factor: float
) -> np.ndarray:
    """InflationLayer::computeCost at distances in cells (array in, uint8 array out)."""
    d = np.asarray(distance_cells, dtype=float) * resolution
    factor = np.exp(-cost_scaling_factor * (d - inscribed_radius))
    costs = (MAX_NON_OBSTACLE * factor).astype(np.int64)  # static_cast truncates
    costs = np.where(d <= inscribed_radius, INSCRIBED_INFLATED_OBSTACLE, costs)
    costs = np.where(np.asarray(distance_cells) == 0, LETHAL_OBSTACLE, costs)
    return costs.astype(np.uint8)


def inflate(costs: np.ndarray, resolution: float, params: CostmapParameters) -> np.ndarray:
    """The inflation layer over ``costs`` (a new array)."""
    cell_radius = max(0, math.ceil(params.inflation_radius / resolution))
    if not params.inflation_layer or cell_radius == 0:
        return costs.copy()
    sources = costs == LETHAL_OBSTACLE
    if params.inflate_around_unknown:
        sources |= costs == NO_INFORMATION
    if not sources.any():
        return costs.copy()
    from scipy import ndimage  # the navigation extra: imported where used

    distance = ndimage.distance_transform_edt(~sources)
    quantized = np.floor(distance * COST_LUT_PRECISION + 0.5) / COST_LUT_PRECISION
    inflated = inflation_cost(
        quantized, resolution, params.inscribed_radius, params.cost_scaling_factor
    )
    inside = distance <= cell_radius
    out = costs.copy()
    unknown = costs == NO_INFORMATION
    threshold = FREE_SPACE + 1 if params.inflate_unknown else INSCRIBED_INFLATED_OBSTACLE
    take_unknown = inside & unknown & (inflated >= threshold)
    keep_max = inside & ~take_unknown
    out[keep_max] = np.maximum(costs[keep_max], inflated[keep_max])
    out[take_unknown] = inflated[take_unknown]
    return out


def make_costmap(grid: OccupancyMap, params: CostmapParameters) -> Costmap:
    """The costmap of a map: its static layer, then its inflation layer."""
    costs = (
        static_layer(grid, params)
        if params.static_layer
        else np.zeros(grid.data.shape, dtype=np.uint8)
    )
    costs = inflate(costs, grid.resolution, params)
    return Costmap(costs=costs, resolution=grid.resolution, origin=grid.origin)


# ---------------------------------------------------------------------------- obstacle layer


def empty_obstacles(shape, params: CostmapParameters) -> np.ndarray:
    """An obstacle layer with no observation yet (unknown when tracking unknown space)."""
    fill = NO_INFORMATION if params.track_unknown_space else FREE_SPACE
    return np.full(shape, fill, dtype=np.uint8)


def observe(
    layer: np.ndarray,
    costmap: Costmap,
    laser: tuple[float, float, float],
    height: float,
    scan,
    source: ObservationSource,
) -> np.ndarray:
    """The obstacle layer after one LaserScan of ``source`` from the laser's world pose
    (x, y, yaw) at ``height`` [m]: clearing along the beams, then marking their ends (a new
    array)."""
    out = layer.copy()
    ranges = np.asarray(scan.ranges, dtype=float)
    if ranges.size == 0:
        return out
    angles = laser[2] + scan.angle_min + scan.angle_increment * np.arange(ranges.size)
    c, s = np.cos(angles), np.sin(angles)
    res = costmap.resolution
    rows_n, cols_n = out.shape
    if source.clearing:
        reach = np.where(np.isposinf(ranges) & source.inf_is_valid, scan.range_max, ranges)
        reach = np.where(np.isfinite(reach), reach, np.nan)
        reach = np.minimum(reach, source.raytrace_max_range)
        ok = np.isfinite(reach) & (reach > source.raytrace_min_range)
        steps = np.arange(source.raytrace_min_range, source.raytrace_max_range, 0.5 * res)
        # each beam sampled every half cell up to one cell short of its end
        d = steps[None, :] * np.ones((ok.sum(), 1))
        keep = d < (reach[ok] - res)[:, None]
        px = laser[0] + d * c[ok][:, None]
        py = laser[1] + d * s[ok][:, None]
        cols = np.floor((px[keep] - costmap.origin[0]) / res).astype(int)
        rows = np.floor((py[keep] - costmap.origin[1]) / res).astype(int)
        inside = (rows >= 0) & (rows < rows_n) & (cols >= 0) & (cols < cols_n)
        out[rows[inside], cols[inside]] = FREE_SPACE
    if source.marking and source.min_obstacle_height <= height <= source.max_obstacle_height:
        hit = np.isfinite(ranges) & (ranges >= source.obstacle_min_range)
        hit &= ranges <= source.obstacle_max_range
        hit &= (ranges >= scan.range_min) & (ranges <= scan.range_max)
        px = laser[0] + ranges[hit] * c[hit]
        py = laser[1] + ranges[hit] * s[hit]
        cols = np.floor((px - costmap.origin[0]) / res).astype(int)
        rows = np.floor((py - costmap.origin[1]) / res).astype(int)
        inside = (rows >= 0) & (rows < rows_n) & (cols >= 0) & (cols < cols_n)
        out[rows[inside], cols[inside]] = LETHAL_OBSTACLE
    return out


def clear_footprint(layer: np.ndarray, costmap: Costmap, pose, radius: float) -> np.ndarray:
    """The cells under the robot (a disc of ``radius``) freed (``footprint_clearing``)."""
    rows, cols = np.indices(layer.shape)
    centres = costmap.cell_to_world(rows, cols)
    under = np.hypot(centres[..., 0] - pose[0], centres[..., 1] - pose[1]) <= radius
    out = layer.copy()
    out[under] = FREE_SPACE
    return out


def layered_costmap(
    grid: OccupancyMap,
    params: CostmapParameters,
    obstacles: np.ndarray | None,
    robot: tuple[float, float] | None = None,
) -> Costmap:
    """The master grid: the static layer, the obstacle layer by its maximum (as
    ``updateWithMax``; ``combination_method: 0`` overwrites), then the inflation layer; a
    rolling window keeps only the ``width`` x ``height`` around ``robot``."""
    costs = (
        static_layer(grid, params)
        if params.static_layer
        else empty_obstacles(grid.data.shape, params)
    )
    layer = params.obstacle_layer
    if obstacles is not None and layer is not None and layer.enabled:
        seen = obstacles != NO_INFORMATION
        if layer.combination_method == 0:
            costs[seen] = obstacles[seen]
        else:
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


def blocked_behind(costmap: Costmap, pose, distance: float, inscribed: float) -> bool:
    """Whether backing up ``distance`` [m] from ``pose`` (x, y, yaw) puts the robot's back
    (``inscribed`` [m] behind its centre) on a lethal cell."""
    for d in np.arange(0.0, distance + 1e-9, 0.5 * costmap.resolution):
        x = pose[0] - (d + inscribed) * math.cos(pose[2])
        y = pose[1] - (d + inscribed) * math.sin(pose[2])
        row, col = costmap.world_to_cell(x, y)
        if costmap.contains(row, col) and costmap.costs[row, col] == LETHAL_OBSTACLE:
            return True
    return False
