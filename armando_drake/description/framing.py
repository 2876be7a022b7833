"""Framing a scene in Meshcat: every page (the display, the world, the replay, the jog)
opens with the camera placed by :func:`frame_view`.

The content (the robot at its pose, and the scenario's objects) is reduced to points
whose convex hull is its visual geometry (:func:`geometry_points`: box corners, rims of
cylinders, points on spheres, the convex hull of meshes). The camera looks from the
view preset's direction (``diagrams/display.yaml``) and is placed, across the view and
along it, at the nearest distance where every point lies within :data:`FILL` of the
half view both up-down and left-right, with the content centred: on the screen the
content's larger extent is :data:`FILL` of the view's height, whatever the width of
a landscape view (the browser keeps the vertical field of view and widens the
horizontal one with the window). The camera's vertical field of view is
:data:`FIELD_OF_VIEW`, narrower than Meshcat's default (75 degrees) so that the parts
of the robot nearest the camera are not drawn out of proportion.
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
    Mesh,
    Meshcat,
    Role,
    Sphere,
)
from pydrake.multibody.tree import BodyIndex, JointIndex

FIELD_OF_VIEW = 30.0  # [deg] vertical field of view of the Meshcat camera
FILL = 0.9  # share of the view's height the content's larger extent fills
NEAREST = 0.02  # [m] least distance from the camera to the content along the view
CIRCLE_POINTS = 48  # points on a cylinder's rim
SPHERE_POINTS = 200  # points on a sphere (Fibonacci lattice)


def _sphere_points(count: int = SPHERE_POINTS) -> np.ndarray:
    """(count, 3) points spread evenly on the unit sphere."""
    index = np.arange(count) + 0.5
    z = 1 - 2 * index / count
    radius = np.sqrt(1 - z * z)
    angle = math.pi * (3 - math.sqrt(5)) * index
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle), z])


def _box_corners(low, high) -> np.ndarray:
    return np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1])
                     for z in (low[2], high[2])])  # fmt: skip


def geometry_points(shape) -> np.ndarray:
    """(n, 3) points in the frame of ``shape`` whose convex hull is the shape (or very
    nearly: circles and spheres are sampled). The origin alone for a half space, an
    unknown shape or a mesh Drake cannot read."""
    if isinstance(shape, Box):
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
        return _box_corners(-half, half)
    if isinstance(shape, (Sphere, Ellipsoid, Capsule)):
        points = _sphere_points()
        if isinstance(shape, Sphere):
            return points * shape.radius()
        if isinstance(shape, Ellipsoid):
            return points * [shape.a(), shape.b(), shape.c()]
        points = points * shape.radius()  # a capsule: two half spheres
        return points + np.outer(np.sign(points[:, 2]), [0, 0, shape.length() / 2])
    if isinstance(shape, Cylinder):
        angle = np.linspace(0, 2 * math.pi, CIRCLE_POINTS, endpoint=False)
        rim = np.column_stack([np.cos(angle), np.sin(angle)]) * shape.radius()
        half = shape.length() / 2
        return np.vstack([np.column_stack([rim, np.full(len(rim), z)]) for z in (-half, half)])
    if isinstance(shape, (Mesh, Convex)):
        try:
            hull = shape.GetConvexHull()
        except RuntimeError:  # a mesh format Drake cannot read: its origin only
            return np.zeros((1, 3))
        return np.array([hull.vertex(i) for i in range(hull.num_vertices())])
    return np.zeros((1, 3))  # a half space or an unknown shape: its origin only


def scene_points(query, frames) -> np.ndarray:
    """(n, 3) points [m] of the illustration geometry on ``frames`` (geometry frame
    ids) at the poses of ``query`` (a SceneGraph QueryObject), see
    :func:`geometry_points`; (0, 3) without any."""
    inspector = query.inspector()
    points = [np.zeros((0, 3))]
    for geometry in inspector.GetAllGeometryIds(Role.kIllustration):
        if inspector.GetFrameId(geometry) not in frames:
            continue
        X_WG = query.GetPoseInWorld(geometry)
        points.append(X_WG.multiply(geometry_points(inspector.GetShape(geometry)).T).T)
    return np.vstack(points)


def body_frames(plant, model_instances=None) -> set:
    """The geometry frames of the bodies of ``model_instances`` (every body but the
    world's when None) of the finalized ``plant``."""
    frames = set()
    for index in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        if body.index() == plant.world_body().index():
            continue
        if model_instances is not None and body.model_instance() not in model_instances:
            continue
        frame = plant.GetBodyFrameIdIfExists(body.index())
        if frame is not None:
            frames.add(frame)
    return frames


def arm_frames(plant, model_instances) -> set:
    """The geometry frames of the bodies of ``model_instances`` that make up the arm:
    every body but the accessories fixed to the world, that is anchored bodies (welded to
    the world through welds only) that carry no moving joint, such as a camera on a
    stand beside the robot. All the bodies' frames when that would leave none."""
    carriers = set()  # anchored bodies with a moving joint somewhere below them
    parent_of = {}  # child body index -> parent body index
    moving_parents = []
    for index in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(index))
        parent_of[joint.child_body().index()] = joint.parent_body().index()
        if joint.num_velocities() > 0:
            moving_parents.append(joint.parent_body().index())
    for body in moving_parents:
        while body is not None and body not in carriers:
            carriers.add(body)
            body = parent_of.get(body)
    frames = set()
    for index in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        if body.index() == plant.world_body().index():
            continue
        if body.model_instance() not in model_instances:
            continue
        if plant.IsAnchored(body) and body.index() not in carriers:
            continue  # an accessory fixed to the world
        frame = plant.GetBodyFrameIdIfExists(body.index())
        if frame is not None:
            frames.add(frame)
    return frames or body_frames(plant, model_instances)


def content_frames(plant, model_instances) -> set:
    """The geometry frames a view frames: the arm of ``model_instances``
    (:func:`arm_frames`) and the world's, which carries the scenario's objects."""
    world = plant.GetBodyFrameIdIfExists(plant.world_body().index())
    return arm_frames(plant, model_instances) | ({world} if world is not None else set())


def view_axes(direction) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(right, up, back) unit axes of a camera looking from ``direction`` (camera minus
    target; any length) with the world's z axis up on the screen."""
    direction = np.asarray(direction, dtype=float)
    norm = np.linalg.norm(direction)
    if not norm > 0:
        raise ValueError(f"direction={direction.tolist()!r} must not be zero")
    back = direction / norm  # from the target towards the camera
    up = np.array([0.0, 0.0, 1.0]) - back[2] * back
    if np.linalg.norm(up) < 1e-6:  # looking straight down or up
        up = np.array([0.0, 1.0, 0.0]) - back[1] * back
    up /= np.linalg.norm(up)
    return np.cross(up, back), up, back


def camera_pose_for(
    points, direction, *, fill: float = FILL, field_of_view: float = FIELD_OF_VIEW
) -> tuple[np.ndarray, np.ndarray]:
    """Camera position and target [m] that frame ``points`` (n, 3) from ``direction``
    (camera minus target): the nearest camera from which every point lies within
    ``fill`` of the half view up-down and left-right (``field_of_view`` [deg], vertical,
    of a square view), the points' extremes equally far from the view's opposite edges
    (in slope, that is on the screen).
    The target is on the view's axis at the middle of the points' depth."""
    right, up, back = view_axes(direction)
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    slope = fill * math.tan(math.radians(field_of_view) / 2)
    depth = points @ back
    # The camera at x right + y up + z back sees p within the slope when
    # |p.up - y| <= slope (z - p.back), and likewise across: the least z for each axis.
    least = [depth.max() + NEAREST]
    for axis in (right, up):
        lateral = points @ axis
        high, low = (lateral + slope * depth).max(), (lateral - slope * depth).min()
        least.append((high - low) / (2 * slope))
    distance = max(least)
    # Across the view, the x (y) whose extreme points lie as far from both edges.
    across = [_centred(points @ axis, distance - depth) for axis in (right, up)]
    camera = across[0] * right + across[1] * up + distance * back
    target = camera - back * (distance - (depth.min() + depth.max()) / 2)
    return camera, target


def _centred(lateral: np.ndarray, depth: np.ndarray) -> float:
    """The offset c across the view for which the largest slope (lateral - c) / depth
    on one side equals the largest on the other (by bisection: their difference falls
    as c grows)."""
    low, high = float(lateral.min()), float(lateral.max())
    for _ in range(60):
        middle = (low + high) / 2
        if ((lateral - middle) / depth).max() > ((middle - lateral) / depth).max():
            low = middle
        else:
            high = middle
    return (low + high) / 2


def frame_view(meshcat: Meshcat, points, direction) -> tuple[np.ndarray, np.ndarray] | None:
    """Sets ``meshcat``'s camera (:data:`FIELD_OF_VIEW`) and places it to frame
    ``points`` from ``direction`` (:func:`camera_pose_for`); returns (camera, target)
    [m], None (the camera left alone) without points."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if not len(points):
        return None
    camera, target = camera_pose_for(points, direction)
    meshcat.SetCamera(Meshcat.PerspectiveCamera(fov=FIELD_OF_VIEW))
    meshcat.SetCameraPose(camera_in_world=camera, target_in_world=target)
    return camera, target
