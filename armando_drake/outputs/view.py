"""The world's Meshcat view: framed on the robot, waited for, kept after the run.

:class:`ViewFramer` points the Meshcat camera at the robot when the
simulation starts: it looks at the robot's illustration geometry (at the
initial state) from the direction of the view preset (``diagrams/display.yaml``,
:class:`~armando_drake.description.viewer.ViewConfig`), from the nearest
distance at which the robot fills :data:`FILL` of the camera's field of view,
and draws the ground (:data:`GROUND_PATH`) as a square slab
:data:`GROUND_MARGIN` times the scene's largest extent (robot and objects,
height included). The world, the replay (which saves the camera and the
ground with the scene) and the notebooks all get it from the world builder.

:func:`wait_for_browser` holds the start of a run until a browser shows the
page (or a timeout); :func:`serve_until_interrupted` keeps the Meshcat
server, and its replay, up after the run until Ctrl-C.
"""

from __future__ import annotations

import math
import sys
import time
from typing import TextIO

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import Box, Meshcat, QueryObject, Rgba, Role
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import LeafSystem

from armando_drake.description.viewer import load_view_config
from armando_drake.sensors.objects import GROUND_COLOR

GROUND_PATH = "/ground"  # Meshcat path of the ground drawn to fit the scene
GROUND_THICKNESS = 0.01  # [m] of the drawn ground slab (its top face is z = 0)
GROUND_MARGIN = 1.5  # the drawn ground's side over the scene's largest extent
GROUND_MIN_SIDE = 0.5  # [m] smallest side of the drawn ground
FIELD_OF_VIEW = math.radians(75.0)  # vertical field of view of Meshcat's default camera
FILL = 0.9  # share of the half field of view the robot may fill
VIEW_ASPECT = 1.5  # width over height assumed of the browser's view (4:3 to 16:9 screens)


def _shape_corners(shape) -> np.ndarray:
    """(8, 3) corners of the box around ``shape`` in its own frame [m]."""
    from pydrake.geometry import Capsule, Convex, Cylinder, Ellipsoid, Mesh, Sphere

    if isinstance(shape, Box):
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
    elif isinstance(shape, Sphere):
        half = np.full(3, shape.radius())
    elif isinstance(shape, Cylinder):
        half = np.array([shape.radius(), shape.radius(), shape.length() / 2])
    elif isinstance(shape, Capsule):
        half = np.array([shape.radius(), shape.radius(), shape.length() / 2 + shape.radius()])
    elif isinstance(shape, Ellipsoid):
        half = np.array([shape.a(), shape.b(), shape.c()])
    elif isinstance(shape, (Mesh, Convex)):
        try:
            hull = shape.GetConvexHull()
        except RuntimeError:  # a mesh format Drake cannot read: its origin only
            return np.zeros((1, 3))
        vertices = np.array([hull.vertex(i) for i in range(hull.num_vertices())])
        low, high = vertices.min(axis=0), vertices.max(axis=0)
        return np.array(
            [
                [x, y, z]
                for x in (low[0], high[0])
                for y in (low[1], high[1])
                for z in (low[2], high[2])
            ]
        )
    else:  # a half space or an unknown shape: its origin only
        return np.zeros((1, 3))
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    return signs * half


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
    from pydrake.multibody.tree import JointIndex

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


def scene_points(query, frames) -> np.ndarray:
    """(n, 3) corners [m] of the boxes around the illustration geometry on ``frames``
    (geometry frame ids), at the poses of ``query`` (a SceneGraph QueryObject); (0, 3)
    if there is none."""
    inspector = query.inspector()
    points = [np.zeros((0, 3))]
    for geometry in inspector.GetAllGeometryIds(Role.kIllustration):
        if inspector.GetFrameId(geometry) not in frames:
            continue
        X_WG = query.GetPoseInWorld(geometry)
        corners = _shape_corners(inspector.GetShape(geometry))
        points.append(X_WG.multiply(corners.T).T)
    return np.vstack(points)


def scene_bounds(query, frames) -> np.ndarray | None:
    """(2, 3) lowest and highest corner [m] of :func:`scene_points`; None without any."""
    points = scene_points(query, frames)
    if not len(points):
        return None
    return np.array([points.min(axis=0), points.max(axis=0)])


def camera_pose_for(points: np.ndarray, direction) -> tuple[np.ndarray, np.ndarray]:
    """Camera position and target [m] that show ``points`` (n, 3) from ``direction``
    (camera minus target; any length): the camera looks at the middle of their extents
    across the view from the nearest distance at which every point lies within
    :data:`FILL` of the half field of view, up and down and left and right (on a view
    :data:`VIEW_ASPECT` times as wide as high)."""
    direction = np.asarray(direction, dtype=float)
    norm = np.linalg.norm(direction)
    if not norm > 0:
        raise ValueError(f"direction={direction.tolist()!r} must not be zero")
    back = direction / norm  # from the target towards the camera
    up = np.array([0.0, 0.0, 1.0]) - back[2] * back
    if np.linalg.norm(up) < 1e-6:  # looking straight down or up
        up = np.array([0.0, 1.0, 0.0]) - back[1] * back
    up /= np.linalg.norm(up)
    right = np.cross(up, back)
    points = np.asarray(points, dtype=float)
    # The centre of the points' box, moved across the view to the middle of their
    # extents seen from the camera's direction.
    center = (points.min(axis=0) + points.max(axis=0)) / 2
    for axis in (right, up):
        across = (points - center) @ axis
        center = center + axis * (across.min() + across.max()) / 2
    relative = points - center
    slope = FILL * math.tan(FIELD_OF_VIEW / 2)
    # A point p is in view when |p . up| <= slope (D - p . back) and
    # |p . right| <= VIEW_ASPECT slope (D - p . back).
    lateral = np.maximum(np.abs(relative @ right) / VIEW_ASPECT, np.abs(relative @ up))
    distance = max(float((lateral / slope + relative @ back).max()), 0.05)
    return center + back * distance, center


def frame_scene(
    meshcat: Meshcat, query, robot_frames, scene_frames=None, *, view=None
) -> np.ndarray | None:
    """Points ``meshcat``'s camera at the geometry on ``robot_frames`` (at the poses of
    ``query``, a SceneGraph QueryObject) from the view preset's direction and, given
    ``scene_frames`` (the robot's and the objects'), draws the ground to fit them.
    Returns the robot's bounds (2, 3) [m], None without geometry."""
    from pydrake.math import RigidTransform

    view = view or load_view_config()
    points = scene_points(query, robot_frames)
    if not len(points):
        return None
    robot = np.array([points.min(axis=0), points.max(axis=0)])
    direction = np.subtract(view.camera_position, view.camera_target)
    camera, target = camera_pose_for(points, direction)
    meshcat.SetCameraPose(camera_in_world=camera, target_in_world=target)
    scene = None if scene_frames is None else scene_bounds(query, scene_frames)
    if scene is not None:
        center = (scene[0, :2] + scene[1, :2]) / 2
        # The scene's largest extent, its height included: an arm reaches about as far
        # as it stands tall.
        extent = (scene[1] - scene[0]).max()
        side = max(GROUND_MIN_SIDE, GROUND_MARGIN * extent)
        meshcat.SetObject(GROUND_PATH, Box(side, side, GROUND_THICKNESS), Rgba(*GROUND_COLOR))
        meshcat.SetTransform(
            GROUND_PATH, RigidTransform([center[0], center[1], -GROUND_THICKNESS / 2])
        )
    return robot


class ViewFramer(LeafSystem):
    """Frames the robot in Meshcat when the simulation starts (:func:`frame_scene`).

    Input ports:
      query: the SceneGraph's query object.

    ``robot_frames``: geometry frames of the robot's bodies; ``scene_frames``: those of
    everything the ground should fit (None: no ground drawn); ``view``: the preset whose
    direction the camera takes (default ``diagrams/display.yaml``).
    """

    def __init__(self, *, meshcat: Meshcat, robot_frames, scene_frames=None, view=None):
        super().__init__()
        self._meshcat = meshcat
        self._robot_frames = set(robot_frames)
        self._scene_frames = None if scene_frames is None else set(scene_frames)
        self._view = view
        self._query_port = self.DeclareAbstractInputPort("query", Value[QueryObject]())
        self.DeclareInitializationPublishEvent(self._Frame)
        self.robot_bounds = None  # (2, 3) [m] once framed

    def _Frame(self, context) -> None:
        self.robot_bounds = frame_scene(
            self._meshcat,
            self._query_port.Eval(context),
            self._robot_frames,
            self._scene_frames,
            view=self._view,
        )


def AddViewFramer(
    builder, plant, scene_graph, meshcat: Meshcat, *, robot_instances, ground: bool, view=None
) -> ViewFramer:
    """Adds a :class:`ViewFramer` of the arm of ``robot_instances`` (:func:`arm_frames`:
    their bodies but accessories fixed to the world); with ``ground`` it draws the ground
    to fit every body."""
    framer = builder.AddSystem(
        ViewFramer(
            meshcat=meshcat,
            robot_frames=arm_frames(plant, robot_instances),
            scene_frames=body_frames(plant) if ground else None,
            view=view,
        )
    )
    framer.set_name("view_framer")
    builder.Connect(scene_graph.get_query_output_port(), framer.get_input_port())
    return framer


def wait_for_browser(meshcat: Meshcat, timeout: float, stream: TextIO = sys.stdout) -> bool:
    """Waits until a browser has ``meshcat``'s page open, up to ``timeout`` [s]; says on
    ``stream`` that it waits, then that a browser connected (or none did). Returns whether
    one is connected. Ctrl-C raises KeyboardInterrupt (the run ends there, as it would
    during the simulation)."""
    if meshcat.GetNumActiveConnections() > 0 or timeout <= 0:
        return meshcat.GetNumActiveConnections() > 0
    print(
        f"waiting up to {timeout:g} s for a browser to open the Meshcat page "
        "(--no-wait starts at once) ...",
        file=stream,
        flush=True,
    )
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if meshcat.GetNumActiveConnections() > 0:
            print("browser connected", file=stream, flush=True)
            return True
        time.sleep(0.1)
    print("no browser connected: starting anyway", file=stream, flush=True)
    return False


def serve_until_interrupted(meshcat: Meshcat, stream: TextIO = sys.stdout) -> None:
    """Keeps the process (and so ``meshcat``'s server) up until Ctrl-C or SIGTERM."""
    print(
        "Meshcat keeps serving the run as a replay (Animations: play, scrub); Ctrl-C to exit",
        file=stream,
        flush=True,
    )
    try:
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
