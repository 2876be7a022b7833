"""nav2_costmap_2d's StaticLayer: the map's occupancy as costs (``StaticLayer::interpretValue``).

An occupancy of -1 is unknown (255), or free with ``track_unknown_space: false``; occupancy
>= ``lethal_cost_threshold`` (100) lethal; any other cell free (``trinary_costmap: true``)
or ``254 * value / 100``. Its parameters are the costmap's (:class:`~.costmap.CostmapParameters`).
"""

from __future__ import annotations

import numpy as np

from armando_drake.navigation.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.registry import LAYERS

STATIC_LAYER = "nav2_costmap_2d::StaticLayer"

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


@LAYERS.register(STATIC_LAYER)
class StaticLayer:
    """nav2_costmap_2d's StaticLayer: the map's cells (:func:`static_layer`)."""

    title, keys, declared_in, honoured = "static_layer", _STATIC_KEYS, None, ()

    @staticmethod
    def configure(params, name: str, layer: dict, where: str, ignored) -> None:
        params.static_layer = bool(layer.get("enabled", True))
        ignored += [f"{where}.{name}.{k}" for k in layer if k not in _STATIC_KEYS]


def static_layer(grid: OccupancyMap, params) -> np.ndarray:
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
