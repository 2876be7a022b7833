"""nav2_costmap_2d's ObstacleLayer on ``data_type: LaserScan`` sources.

Each scan clears the cells along its beams (``clearing``: Nav2's Bresenham from
``raytrace_min_range`` to the hit's cell, or to the cell at ``raytrace_max_range``,
included; :func:`raytrace`) and then marks the hit cells lethal (``marking``:
ranges within ``obstacle_min_range``..``obstacle_max_range``, the scan's height within
``min_obstacle_height``..``max_obstacle_height``); the layer is combined into the master
grid by its maximum (``updateWithMax``: an unknown cell of the layer leaves the master's;
:func:`~.costmap.layered_costmap`), then inflated. ``VoxelLayer`` runs as this obstacle
layer (a planar lidar, 2-D): a substitution of the registry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from armando_drake.navigation.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from armando_drake.navigation.nav2_params import fill
from armando_drake.navigation.registry import LAYERS
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import param

OBSTACLE_LAYER = "nav2_costmap_2d::ObstacleLayer"
VOXEL_LAYER = "nav2_costmap_2d::VoxelLayer"
# 0 overwrite, 1 maximum, 2 maximum leaving unknown master cells (updateWithOverwrite,
# updateWithMax, updateWithMaxWithoutUnknownOverwrite)
COMBINATION_METHODS = (0, 1, 2)

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
    combination_method: int = 1  # COMBINATION_METHODS: 0 overwrite, 1 maximum, 2 (unknown kept)


@LAYERS.register(OBSTACLE_LAYER, instead="the obstacle layer runs instead (a planar scan, 2-D)")
class ObstacleLayer:
    """nav2_costmap_2d's ObstacleLayer on LaserScan sources (:func:`observe`)."""

    title, keys, declared_in = "obstacle_layer", _OBSTACLE_KEYS | _SOURCE_KEYS, ObservationSource
    honoured = {*_RANGES, "marking", "clearing", "inf_is_valid", "observation_sources", "topic",
                "data_type",
                "footprint_clearing_enabled", "combination_method"}  # fmt: skip

    @staticmethod
    def configure(params, name: str, layer: dict, where: str, ignored) -> None:
        obstacles = _obstacle_layer(name, layer, bool(layer.get("enabled", True)), where, ignored)
        if params.obstacle_layer is None or not params.obstacle_layer.enabled:
            params.obstacle_layer = obstacles
        elif obstacles.enabled:  # two obstacle layers (obstacle + voxel): their sources
            params.obstacle_layer.sources += obstacles.sources


LAYERS.substitute(VOXEL_LAYER, OBSTACLE_LAYER)  # a planar lidar fills one voxel


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
    method = layer.get("combination_method", 1)
    if method not in COMBINATION_METHODS or isinstance(method, bool):
        raise ConfigError(
            f"{here}.combination_method={method!r} is not one of 0 (overwrite), 1 (maximum), "
            "2 (maximum without overwriting unknown)"
        )
    params.combination_method = int(method)
    for source in names.split():
        params.sources.append(_source(source, layer.get(source), layer, here, ignored))
    known = _OBSTACLE_KEYS | set(names.split())
    ignored += [f"{here}.{k}" for k in layer if k not in known]
    return params


def empty_obstacles(shape, params) -> np.ndarray:
    """An obstacle layer with no observation yet (unknown when tracking unknown space)."""
    fill = NO_INFORMATION if params.track_unknown_space else FREE_SPACE
    return np.full(shape, fill, dtype=np.uint8)


def observe(
    layer: np.ndarray,
    costmap,
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
        ok = np.isfinite(reach)
        ends = (laser[0] + reach[ok] * c[ok], laser[1] + reach[ok] * s[ok])
        rows, cols = raytrace(costmap, laser[:2], ends, source)
        out[rows, cols] = FREE_SPACE
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


def _clip_to_map(costmap, origin, wx, wy):
    """``raytraceFreespace``'s endpoints (arrays) moved onto the map's edges along their
    rays from ``origin`` (x, y)."""
    ox, oy = origin
    x0, y0 = costmap.origin[0], costmap.origin[1]
    x_end = x0 + costmap.costs.shape[1] * costmap.resolution
    y_end = y0 + costmap.costs.shape[0] * costmap.resolution
    a, b = wx - ox, wy - oy
    with np.errstate(divide="ignore", invalid="ignore"):
        low = wx < x0
        wy = np.where(low, oy + b * (x0 - ox) / a, wy)
        wx = np.where(low, x0, wx)
        low = wy < y0
        wx = np.where(low, ox + a * (y0 - oy) / b, wx)
        wy = np.where(low, y0, wy)
        high = wx > x_end
        wy = np.where(high, oy + b * (x_end - ox) / a, wy)
        wx = np.where(high, x_end - 0.001, wx)
        high = wy > y_end
        wx = np.where(high, ox + a * (y_end - oy) / b, wx)
        wy = np.where(high, y_end - 0.001, wy)
    return wx, wy


def raytrace(costmap, origin, ends, source: ObservationSource) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) of the cells Nav2's ``raytraceFreespace`` clears for rays from the
    sensor at ``origin`` (x, y) to ``ends`` (xs, ys): each endpoint clipped to the map,
    ``Costmap2D::raytraceLine``'s Bresenham from the origin's cell (moved
    ``raytrace_min_range`` cells along the ray) to the endpoint's cell, cut after
    ``raytrace_max_range`` cells (``cellDistance``: rounded up) scaled onto the dominant
    axis, the last cell included (the clip cell, or the hit's cell: marked after)."""
    res = costmap.resolution
    rows_n, cols_n = costmap.costs.shape
    empty = (np.zeros(0, dtype=int), np.zeros(0, dtype=int))
    x0 = int(math.floor((origin[0] - costmap.origin[0]) / res))
    y0 = int(math.floor((origin[1] - costmap.origin[1]) / res))
    if not (0 <= x0 < cols_n and 0 <= y0 < rows_n) or not len(ends[0]):
        return empty  # Nav2: "Sensor origin ... is out of map bounds"
    wx, wy = _clip_to_map(costmap, origin, *(np.asarray(e, dtype=float) for e in ends))
    with np.errstate(invalid="ignore"):
        x1 = np.floor((wx - costmap.origin[0]) / res)
        y1 = np.floor((wy - costmap.origin[1]) / res)
    legal = (x1 >= 0) & (x1 < cols_n) & (y1 >= 0) & (y1 < rows_n)
    x1, y1 = x1[legal].astype(int), y1[legal].astype(int)
    max_cells = max(0.0, math.ceil(source.raytrace_max_range / res))
    min_cells = max(0.0, math.ceil(source.raytrace_min_range / res))
    dx_full, dy_full = x1 - x0, y1 - y0
    dist = np.hypot(dx_full, dy_full)
    keep = dist >= min_cells
    x1, y1, dx_full, dy_full, dist = (v[keep] for v in (x1, y1, dx_full, dy_full, dist))
    safe = np.where(dist > 0, dist, 1.0)
    sx0 = np.where(dist > 0, np.trunc(x0 + dx_full / safe * min_cells), x0).astype(int)
    sy0 = np.where(dist > 0, np.trunc(y0 + dy_full / safe * min_cells), y0).astype(int)
    dx, dy = x1 - sx0, y1 - sy0
    scale = np.where(dist > 0, np.minimum(1.0, max_cells / safe), 1.0)
    x_major = np.abs(dx) >= np.abs(dy)
    da = np.where(x_major, np.abs(dx), np.abs(dy))
    db = np.where(x_major, np.abs(dy), np.abs(dx))
    end = np.minimum((scale * da).astype(int), da)
    i = np.arange(int(end.max()) + 1 if len(end) else 0)[None, :]
    crossings = (da[:, None] // 2 + i * db[:, None]) // np.maximum(da, 1)[:, None]
    along_x = np.where(x_major[:, None], i * np.sign(dx)[:, None], crossings * np.sign(dx)[:, None])
    along_y = np.where(x_major[:, None], crossings * np.sign(dy)[:, None], i * np.sign(dy)[:, None])
    valid = i <= end[:, None]
    cols = (sx0[:, None] + along_x)[valid]
    rows = (sy0[:, None] + along_y)[valid]
    inside = (rows >= 0) & (rows < rows_n) & (cols >= 0) & (cols < cols_n)
    return rows[inside], cols[inside]


def clear_footprint(layer: np.ndarray, costmap, pose, radius: float) -> np.ndarray:
    """The cells under the robot (a disc of ``radius``) freed (``footprint_clearing``)."""
    rows, cols = np.indices(layer.shape)
    centres = costmap.cell_to_world(rows, cols)
    under = np.hypot(centres[..., 0] - pose[0], centres[..., 1] - pose[1]) <= radius
    out = layer.copy()
    out[under] = FREE_SPACE
    return out
