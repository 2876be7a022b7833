"""The true occupancy of a world: its collision geometry cut at the lidar's height.

:func:`world_map` rasterises the collision shapes of every body that is not the robot's
into an :class:`~armando_drake.navigation.maps.OccupancyMap`: a cell is occupied (100)
when the shape's slice at height ``z`` comes within half a cell of the cell's centre
(the cell overlaps the obstacle), free (0) otherwise. Boxes, cylinders, spheres,
capsules and ellipsoids are tested exactly in their own frame; meshes and convex shapes
through their convex hull (Drake's ``GetConvexHull``, as the world's concave meshes are
already split into convex pieces when loaded). Half spaces and shapes that do not reach
the height (the ground) are not obstacles. Each shape is tested only over the cells of
its world-aligned bounding box, vectorised with numpy.

This is the map the navigation uses when a scenario gives none, and the one its tests
compare against; :func:`~armando_drake.navigation.maps.save_map` writes it as
``map.yaml`` + ``map.pgm``.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import (
    Box,
    Capsule,
    Convex,
    Cylinder,
    Ellipsoid,
    HalfSpace,
    Mesh,
    SceneGraphInspector,
    Sphere,
)
from pydrake.multibody.tree import BodyIndex, ModelInstanceIndex

from armando_drake.navigation.maps import FREE, MAX_MAP_CELLS, OCCUPIED, MapError, OccupancyMap

LIDAR_TYPES = ("gpu_lidar", "lidar", "gpu_ray", "ray")
DEFAULT_SCAN_HEIGHT = 0.2  # [m] without a lidar
DEFAULT_MARGIN = 0.5  # [m] free border around the obstacles when no extent is given


def _hull_planes(shape):
    """(n, 4) unit outward normals and offsets of a mesh's convex hull (n.p + d <= 0
    inside), and its vertices (3, n)."""
    from scipy.spatial import ConvexHull  # the navigation extra: imported where used

    hull = shape.GetConvexHull()
    vertices = np.array([hull.vertex(k) for k in range(hull.num_vertices())])
    if len(vertices) < 4:
        return None
    return ConvexHull(vertices).equations, vertices.T


def _inside(shape, p: np.ndarray, margin: float, planes) -> np.ndarray | None:
    """Whether the points ``p`` (n, 3) in the shape's frame are within ``margin`` of it;
    None for a shape that is no obstacle (a half space) or unknown."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    if isinstance(shape, Box):
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2 + margin
        return np.all(np.abs(p) <= half, axis=1)
    if isinstance(shape, Cylinder):
        radius = shape.radius() + margin
        return (x * x + y * y <= radius * radius) & (np.abs(z) <= shape.length() / 2 + margin)
    if isinstance(shape, Sphere):
        return np.einsum("ij,ij->i", p, p) <= (shape.radius() + margin) ** 2
    if isinstance(shape, Capsule):
        zc = np.clip(z, -shape.length() / 2, shape.length() / 2)
        return x * x + y * y + (z - zc) ** 2 <= (shape.radius() + margin) ** 2
    if isinstance(shape, Ellipsoid):
        axes = np.array([shape.a(), shape.b(), shape.c()]) + margin
        return np.sum((p / axes) ** 2, axis=1) <= 1.0
    if planes is not None:
        faces = planes[0]
        return np.all(p @ faces[:, :3].T + faces[:, 3] <= margin, axis=1)
    return None


def _half_extent(shape, R: np.ndarray, planes) -> np.ndarray | None:
    """[m] the half sizes (x, y, z) of the world-aligned box around the shape centred at
    its origin, with rotation ``R`` (None for a hull: see :func:`_bounds`)."""
    if isinstance(shape, Box):
        return np.abs(R) @ (np.array([shape.width(), shape.depth(), shape.height()]) / 2)
    if isinstance(shape, (Cylinder, Capsule)):
        axis = np.abs(R[:, 2])
        extra = shape.radius() if isinstance(shape, Capsule) else 0.0
        side = shape.radius() * np.sqrt(np.clip(1.0 - axis**2, 0.0, 1.0))
        return axis * shape.length() / 2 + side + extra
    if isinstance(shape, Sphere):
        return np.full(3, shape.radius())
    if isinstance(shape, Ellipsoid):
        return np.sqrt((R**2) @ (np.array([shape.a(), shape.b(), shape.c()]) ** 2))
    return None


def _bounds(shape, X_WG, planes) -> tuple[np.ndarray, np.ndarray] | None:
    """(low, high) corners [m] of the world-aligned box around the shape."""
    R = X_WG.rotation().matrix()
    half = _half_extent(shape, R, planes)
    if half is not None:
        return X_WG.translation() - half, X_WG.translation() + half
    if planes is None:
        return None
    vertices = X_WG @ planes[1]
    return vertices.min(axis=1), vertices.max(axis=1)


def obstacle_shapes(plant, inspector: SceneGraphInspector, context, exclude=()) -> list:
    """(geometry id, shape, X_WG, hull planes) of the collision geometries of every body of
    the plant whose model instance is not in ``exclude``, at ``context``'s poses."""
    shapes = []
    excluded = set(exclude)
    for index in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        if body.model_instance() in excluded:
            continue
        geometries = plant.GetCollisionGeometriesForBody(body)
        if not geometries:
            continue
        X_WB = plant.EvalBodyPoseInWorld(context, body)
        for geometry in geometries:
            shape = inspector.GetShape(geometry)
            if isinstance(shape, HalfSpace):
                continue
            planes = _hull_planes(shape) if isinstance(shape, (Mesh, Convex)) else None
            X_WG = X_WB @ inspector.GetPoseInFrame(geometry)
            shapes.append((geometry, shape, X_WG, planes))
    return shapes


def rasterise(
    shapes, *, height: float, resolution: float, extent=None, margin: float = DEFAULT_MARGIN
) -> tuple[OccupancyMap, list]:
    """The occupancy map of ``shapes`` (:func:`obstacle_shapes`) cut at ``height`` [m],
    at ``resolution`` [m/cell], over ``extent`` ((xmin, ymin, xmax, ymax) [m]; None: the
    occupied cells' bounding box and ``margin``); and the ids of the geometries that
    occupy a cell (the obstacles at that height). Cells lie on the lattice of multiples
    of ``resolution``."""
    pad = resolution / 2
    occupied_rows, occupied_cols, obstacles = [], [], []
    for geometry, shape, X_WG, planes in shapes:
        bounds = _bounds(shape, X_WG, planes)
        if bounds is None or not bounds[0][2] - pad <= height <= bounds[1][2] + pad:
            continue
        lo, hi = bounds
        if extent is not None:  # only the cells of the extent
            lo = np.maximum(lo, [extent[0] - pad, extent[1] - pad, -np.inf])
            hi = np.minimum(hi, [extent[2] + pad, extent[3] + pad, np.inf])
        c0, r0 = (math.floor((v - pad) / resolution) for v in lo[:2])
        c1, r1 = (math.ceil((v + pad) / resolution) + 1 for v in hi[:2])
        if c0 >= c1 or r0 >= r1:
            continue
        _check_cells((c1 - c0) * (r1 - r0), resolution)
        rows, cols = (a.ravel() for a in np.mgrid[r0:r1, c0:c1])
        points = np.stack(
            [(cols + 0.5) * resolution, (rows + 0.5) * resolution, np.full(rows.size, height)],
            axis=1,
        )
        X_GW = X_WG.inverse()
        local = points @ X_GW.rotation().matrix().T + X_GW.translation()
        inside = _inside(shape, local, pad, planes)
        if inside is None or not inside.any():
            continue
        occupied_rows.append(rows[inside])
        occupied_cols.append(cols[inside])
        obstacles.append(geometry)
    rows = np.concatenate(occupied_rows) if occupied_rows else np.zeros(0, dtype=int)
    cols = np.concatenate(occupied_cols) if occupied_cols else np.zeros(0, dtype=int)
    if extent is None and not len(rows):
        extent = (-5.0, -5.0, 5.0, 5.0)
    if extent is None:
        lo = np.array([cols.min(), rows.min()]) * resolution - margin
        hi = np.array([cols.max() + 1, rows.max() + 1]) * resolution + margin
        extent = (lo[0], lo[1], hi[0], hi[1])
    col0 = math.floor(extent[0] / resolution + 1e-9)
    row0 = math.floor(extent[1] / resolution + 1e-9)
    width = max(1, math.ceil(extent[2] / resolution - 1e-9) - col0)
    height_cells = max(1, math.ceil(extent[3] / resolution - 1e-9) - row0)
    _check_cells(width * height_cells, resolution)
    data = np.full((height_cells, width), FREE, dtype=np.int8)
    rows, cols = rows - row0, cols - col0
    keep = (rows >= 0) & (rows < height_cells) & (cols >= 0) & (cols < width)
    data[rows[keep], cols[keep]] = OCCUPIED
    origin = (col0 * resolution, row0 * resolution, 0.0)
    grid = OccupancyMap(data=data, resolution=resolution, origin=origin, source="<world>")
    return grid, obstacles


def _check_cells(cells: int, resolution: float) -> None:
    """A MapError when a grid of ``cells`` cells (estimated before it is made) is over
    :data:`~armando_drake.navigation.maps.MAX_MAP_CELLS`."""
    if cells > MAX_MAP_CELLS:
        raise MapError(
            f"resolution {resolution!r} m: the world's map would be {cells:,} cells, over the "
            f"limit of {MAX_MAP_CELLS:,} cells (a coarser resolution is needed)"
        )


def world_map(
    plant,
    scene_graph,
    *,
    height: float,
    resolution: float = 0.05,
    exclude=(),
    extent=None,
    context=None,
) -> OccupancyMap:
    """The occupancy map of a finalized ``plant``'s world at ``height`` [m] (the lidar's),
    without the model instances in ``exclude`` (the robot); poses from ``context`` (the
    plant's; None: its default context, where the world's bodies stand as loaded)."""
    context = plant.CreateDefaultContext() if context is None else context
    shapes = obstacle_shapes(plant, scene_graph.model_inspector(), context, exclude)
    grid, _ = rasterise(shapes, height=height, resolution=resolution, extent=extent)
    return grid


def lidar_height(plant, scene_graph, robot) -> float:
    """[m] the height of the robot's first lidar above the lowest point of its collision
    geometry (where it stands on the ground); :data:`DEFAULT_SCAN_HEIGHT` without one."""
    lidars = [block for block in robot.sensors if block.type in LIDAR_TYPES]
    if not lidars:
        return DEFAULT_SCAN_HEIGHT
    context = plant.CreateDefaultContext()
    frame = plant.GetBodyByName(lidars[0].link, robot.model_instance).body_frame()
    z = plant.CalcRelativeTransform(context, plant.world_frame(), frame) @ lidars[0].X_LS
    shapes = obstacle_shapes(
        plant,
        scene_graph.model_inspector(),
        context,
        exclude=[i for i in _instances(plant) if i != robot.model_instance],
    )
    lows = [b[0][2] for _, shape, X_WG, planes in shapes if (b := _bounds(shape, X_WG, planes))]
    ground = min(lows) if lows else 0.0
    return float(z.translation()[2] - ground)


def _instances(plant) -> list:
    return [ModelInstanceIndex(k) for k in range(plant.num_model_instances())]
