"""nav2_costmap_2d's InflationLayer (``InflationLayer::computeCost``).

With ``d`` the Euclidean distance from a cell's centre to the nearest lethal cell's (a
distance transform, as upstream's own), the cost is 254 at ``d = 0``, 253 for ``d <=
inscribed_radius``, else ``int(252 * exp(-cost_scaling_factor * (d - inscribed_radius)))``,
for cells with ``d <= ceil(inflation_radius / resolution)`` cells; a cell keeps the larger
of its cost and the inflated one (an unknown cell only becomes >= 253). Distances are
exact (``hypot`` of the cell offsets, as jazzy's ``cached_distances_``; not quantized to
1/100 cell as later releases' lookup table). Its parameters are the costmap's
(:class:`~.costmap.CostmapParameters`: ``inflation_radius``, ``cost_scaling_factor``,
``inflate_unknown``, ``inflate_around_unknown``).
"""

from __future__ import annotations

import math

import numpy as np

from armando_drake.navigation.cost_values import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
)
from armando_drake.navigation.nav2_params import fill
from armando_drake.navigation.registry import LAYERS

INFLATION_LAYER = "nav2_costmap_2d::InflationLayer"

_INFLATION_KEYS = {
    "plugin",
    "enabled",
    "inflation_radius",
    "cost_scaling_factor",
    "inflate_unknown",
    "inflate_around_unknown",
}


@LAYERS.register(INFLATION_LAYER)
class InflationLayer:
    """nav2_costmap_2d's InflationLayer (:func:`inflate`)."""

    title, keys, declared_in = "inflation_layer", _INFLATION_KEYS, None
    honoured = _INFLATION_KEYS - {"plugin", "enabled"}

    @staticmethod
    def configure(params, name: str, layer: dict, where: str, ignored) -> None:
        params.inflation_layer = bool(layer.get("enabled", True))
        fill(params, layer, f"{where}.{name}", _INFLATION_KEYS - {"plugin", "enabled"})
        ignored += [f"{where}.{name}.{k}" for k in layer if k not in _INFLATION_KEYS]


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


def inflate(costs: np.ndarray, resolution: float, params) -> np.ndarray:
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
    inflated = inflation_cost(
        distance, resolution, params.inscribed_radius, params.cost_scaling_factor
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
