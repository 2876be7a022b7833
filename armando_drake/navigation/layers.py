"""The costmaps the lidar's scans update, as Nav2's costmap servers do: the global
costmap's obstacle layer (if its plugins list one) and the local costmap
(``local_costmap``, if the file has it), each at its ``update_frequency``.

:class:`Layers` is what they need (their parameters, the laser's pose on the base and
height); :func:`observe_layers` is one scan taken into the navigator's state: each
costmap's obstacle layer (:func:`~.costmap.observe`, the footprint cleared) and its layered
costmap (:func:`~.costmap.layered_costmap`), seen from the pose at the scan's stamp (as
the transform at the stamp in Nav2).
"""

from __future__ import annotations

import dataclasses as dc
import math

from armando_drake.navigation.costmap import Costmap, CostmapParameters, layered_costmap
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.obstacle_layer import clear_footprint, empty_obstacles, observe
from armando_drake.navigation.pose_buffer import compose


@dc.dataclass(frozen=True)
class Layers:
    """The costmaps updated from the lidar's scans: the global one (its obstacle layer,
    if its plugins list one) and the local one (``local_costmap``, if the file has it),
    with the laser's planar pose on the base (x, y, yaw) and its height [m]."""

    global_params: CostmapParameters | None
    local_params: CostmapParameters | None
    laser: tuple[float, float, float]
    height: float

    def all(self) -> tuple:
        return (self.global_params, self.local_params)


def observe_layers(
    nav, layers: Layers, grid: OccupancyMap, costmap: Costmap, scan, pose, now: float
):
    """The navigator's state ``nav`` with its costmaps' obstacle layers after ``scan``
    (each at its update_frequency) on the map ``grid`` (``costmap``: its static costmap),
    seen from the base's ``pose`` (x, y, yaw) at the scan's stamp (the pose buffer's)."""
    laser = compose(pose, layers.laser)
    shape = grid.data.shape
    obstacles = list(nav.obstacles or (None, None))
    costmaps = list(nav.costmaps or (None, None))
    observed = list(nav.observed_at or (-math.inf, -math.inf))
    for k, params in enumerate(layers.all()):
        if params is None or now - observed[k] < 1.0 / params.update_frequency - 1e-9:
            continue
        layer = params.obstacle_layer
        grid_k = obstacles[k] if obstacles[k] is not None else empty_obstacles(shape, params)
        if layer is not None and layer.enabled:
            for source in layer.sources:
                grid_k = observe(grid_k, costmap, laser, layers.height, scan, source)
            if layer.footprint_clearing_enabled:
                grid_k = clear_footprint(grid_k, costmap, pose, params.inscribed_radius)
        obstacles[k] = grid_k
        costmaps[k] = layered_costmap(grid, params, grid_k, robot=pose[:2])
        observed[k] = now
    return dc.replace(
        nav, obstacles=tuple(obstacles), costmaps=tuple(costmaps), observed_at=tuple(observed)
    )
