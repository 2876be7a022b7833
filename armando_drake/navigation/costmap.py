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

The costmap takes the map's size and resolution (a non-rolling global costmap resizes to
the static map, whatever its ``resolution`` parameter). The obstacle layer needs a live scan:
it is accepted in the plugin list but not applied yet.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from armando_drake.navigation.maps import OccupancyMap
from armando_drake.tools.errors import ConfigError

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
LAYER_TYPES = (STATIC_LAYER, INFLATION_LAYER, OBSTACLE_LAYER, VOXEL_LAYER)

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
}
_KNOWN = {
    "use_sim_time",
    "update_frequency",
    "publish_frequency",
    "global_frame",
    "robot_base_frame",
    "width",
    "height",
    "rolling_window",
    "always_send_full_costmap",
    "footprint",
    "footprint_padding",
    "origin_x",
    "origin_y",
    "transform_tolerance",
    "map_topic",
    "filters",
    "initial_transform_timeout",
    "use_maximum",
}
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


@dataclass
class CostmapParameters:
    """A costmap's parameters as Nav2 reads them (defaults: nav2_costmap_2d's)."""

    resolution: float = 0.05
    robot_radius: float = 0.1
    track_unknown_space: bool = False
    lethal_cost_threshold: int = 100
    trinary_costmap: bool = True
    static_layer: bool = True
    inflation_layer: bool = True
    inflation_radius: float = 0.55
    cost_scaling_factor: float = 10.0
    inflate_unknown: bool = False
    inflate_around_unknown: bool = False
    plugins: list[str] = field(default_factory=list)
    ignored: list[str] = field(default_factory=list)
    """Keys read from the file that this package does not use (each one warned about)."""

    @property
    def inscribed_radius(self) -> float:
        """The inscribed radius: the robot's radius (a circular footprint)."""
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


def _number(value, where: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where} must be a number, not {value!r}")
    if positive and not value > 0:
        raise ConfigError(f"{where} must be positive, not {value}")
    return float(value)


def _layer(params: CostmapParameters, name: str, layer, where: str, ignored: list[str]) -> None:
    if not isinstance(layer, dict) or "plugin" not in layer:
        raise ConfigError(f"{where}.{name}.plugin: the layer '{name}' has no plugin type")
    kind = layer["plugin"]
    if kind not in LAYER_TYPES:
        raise ConfigError(
            f"{where}.{name}.plugin: unknown costmap layer {kind!r} "
            f"(known: {', '.join(LAYER_TYPES)})"
        )
    enabled = bool(layer.get("enabled", True))
    if kind == STATIC_LAYER:
        params.static_layer = enabled
        ignored += [f"{where}.{name}.{k}" for k in layer if k not in _STATIC_KEYS]
    elif kind == INFLATION_LAYER:
        params.inflation_layer = enabled
        for key in ("inflation_radius", "cost_scaling_factor"):
            if key in layer:
                setattr(params, key, _number(layer[key], f"{where}.{name}.{key}"))
        if params.inflation_radius < 0:
            raise ConfigError(
                f"{where}.{name}.inflation_radius must be >= 0, not {params.inflation_radius}"
            )
        for key in ("inflate_unknown", "inflate_around_unknown"):
            setattr(params, key, bool(layer.get(key, getattr(params, key))))
        ignored += [f"{where}.{name}.{k}" for k in layer if k not in _INFLATION_KEYS]
    else:
        _log.warning("%s.%s: %s needs a live scan; not applied yet", where, name, kind)


def costmap_parameters(path: str | Path, costmap: str = "global_costmap") -> CostmapParameters:
    """The parameters of ``<costmap>/<costmap>/ros__parameters`` in a Nav2 YAML; keys not
    used here are warned about (and listed in ``ignored``)."""
    path = Path(path)
    try:
        doc = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ConfigError(f"{path}: cannot be read ({' '.join(str(error).split())})") from None
    where = f"{path}: {costmap}.{costmap}.ros__parameters"
    node = doc.get(costmap, {}) if isinstance(doc, dict) else {}
    node = node.get(costmap, {}) if isinstance(node, dict) else {}
    ros = node.get("ros__parameters") if isinstance(node, dict) else None
    if not isinstance(ros, dict):
        raise ConfigError(f"{where}: missing (no costmap '{costmap}' in the file)")
    params = CostmapParameters()
    for key in ("resolution", "robot_radius"):
        if key in ros:
            setattr(params, key, _number(ros[key], f"{where}.{key}", positive=True))
    for key in ("track_unknown_space", "trinary_costmap"):
        setattr(params, key, bool(ros.get(key, getattr(params, key))))
    if "lethal_cost_threshold" in ros:
        params.lethal_cost_threshold = int(_number(ros["lethal_cost_threshold"], where))
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
