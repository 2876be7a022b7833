"""A scene graph of the cameras' own, so that a VTK engine costs only when it renders.

Drake's ``SceneGraph`` hands the new geometry poses to each of its render engines at
every pose update, that is at every plant step (the plant's contact query), whether
a camera (or a lidar, which renders depth) renders then or not. Drake's OpenGL engine
takes that in its stride; VTK's (through EGL, what a machine without an X server has)
costs more than the whole plant step on our 2-core machines
(``docs/design/performance.md``).

:func:`AddCameraScene` mirrors the perception geometry of the world's
``SceneGraph`` (same shapes, poses in their frames and perception properties, so
the same images) into a second ``SceneGraph`` that holds the cameras' renderer.
Its frames' poses come from a :class:`MirroredPoses` system that reads the world's
``QueryObject`` only when the second scene graph needs them, i.e. when a camera
renders (or a reader asks a camera's pose). Build it after the last geometry is
registered (after ``plant.Finalize()`` and the scene objects).

A camera inside a closed convex visual (the box of its own ``camera_link``, with the
sensor at the link's origin, as many descriptions have it) sees only the back faces of
that visual, which Gazebo's renderer and Drake's OpenGL engine cull: they see through it.
VTK draws back faces. Such a camera renders from a mirror of its own that leaves out the
visuals enclosing it (:func:`enclosing`), so it sees what Gazebo's camera sees.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Box,
    Capsule,
    Cylinder,
    Ellipsoid,
    FrameId,
    FramePoseVector,
    GeometryFrame,
    GeometryId,
    GeometryInstance,
    QueryObject,
    Role,
    SceneGraph,
    Sphere,
)
from pydrake.systems.framework import DiagramBuilder, LeafSystem

_log = logging.getLogger("armando_drake.world")

CAMERA_SCENE = "camera_scene_graph"  # the name of the cameras' SceneGraph in the diagram
CAMERA_SCENE_POSES = "camera_scene_poses"  # the name of its MirroredPoses
WORLD_POSES = "camera_world_poses"  # the world's frames' poses a camera on it watches


class MirroredPoses(LeafSystem):
    """The world poses of frames of one scene graph, as poses of their mirrors in another.

    ``frames``: (frame of the source scene graph, its mirror) pairs. Computed on demand
    from the source's ``QueryObject`` (nothing runs per step).

    Ports:
      - input ``query`` (QueryObject of the source scene graph)
      - output ``poses`` (FramePoseVector of the mirror frames)
    """

    def __init__(self, frames: list[tuple[FrameId, FrameId]]):
        super().__init__()
        self._frames = list(frames)
        self._query = self.DeclareAbstractInputPort("query", AbstractValue.Make(QueryObject()))
        self.DeclareAbstractOutputPort(
            "poses", lambda: AbstractValue.Make(FramePoseVector()), self._CalcPoses
        )

    def _CalcPoses(self, context, output) -> None:
        query = self._query.Eval(context)
        poses = output.get_mutable_value()
        for source, mirror in self._frames:
            poses.set_value(mirror, query.GetPoseInWorld(source))


@dataclass
class CameraScene:
    """The cameras' scene graph and the map from the world's frames to its own."""

    scene_graph: SceneGraph
    frames: dict[FrameId, FrameId]  # world scene graph frame -> mirror frame
    poses: MirroredPoses  # the mirror frames' poses: all that the cameras' images depend on

    def frame(self, world_frame: FrameId) -> FrameId:
        """The mirror of a frame of the world's scene graph."""
        return self.frames[world_frame]


def _instance(inspector, geometry) -> GeometryInstance:
    pose, shape = inspector.GetPoseInFrame(geometry), inspector.GetShape(geometry)
    instance = GeometryInstance(pose, shape, inspector.GetName(geometry))
    instance.set_perception_properties(inspector.GetPerceptionProperties(geometry))
    return instance


def AddCameraScene(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    *,
    hidden: Collection[GeometryId] = (),
    suffix: str = "",
) -> CameraScene:
    """The cameras' scene graph: the perception geometry of ``scene_graph`` mirrored, its
    poses read from ``scene_graph``'s query port when needed (see the module); without
    the geometries ``hidden`` (a camera's own mirror, its systems' names ending in
    ``suffix``)."""
    inspector = scene_graph.model_inspector()
    mirror = builder.AddNamedSystem(CAMERA_SCENE + suffix, SceneGraph())
    source = mirror.RegisterSource("world_mirror")
    world = inspector.world_frame_id()
    frames: dict[FrameId, FrameId] = {}
    for frame in inspector.GetAllFrameIds():
        geometries = [
            geometry
            for geometry in inspector.GetGeometries(frame, Role.kPerception)
            if geometry not in hidden
        ]
        if frame == world:
            for geometry in geometries:
                mirror.RegisterAnchoredGeometry(source, _instance(inspector, geometry))
            continue
        name = f"{inspector.GetName(frame)}#{frame.get_value()}"  # unique whatever the source
        frames[frame] = mirror.RegisterFrame(
            source, GeometryFrame(name, inspector.GetFrameGroup(frame))
        )
        for geometry in geometries:
            mirror.RegisterGeometry(source, frames[frame], _instance(inspector, geometry))
    poses = builder.AddNamedSystem(CAMERA_SCENE_POSES + suffix, MirroredPoses(list(frames.items())))
    builder.Connect(scene_graph.get_query_output_port(), poses.get_input_port())
    builder.Connect(poses.get_output_port(), mirror.get_source_pose_port(source))
    poses.scene = CameraScene(scene_graph=mirror, frames=frames, poses=poses)
    return poses.scene


def WorldPosesOf(builder: DiagramBuilder, scene_graph: SceneGraph) -> MirroredPoses:
    """The poses of every frame of ``scene_graph`` (a :class:`MirroredPoses` of each frame
    to itself, read only when asked): what the images of a camera rendering on it depend
    on. One per diagram, shared by its cameras."""
    if builder.HasSubsystemNamed(WORLD_POSES):
        return builder.GetSubsystemByName(WORLD_POSES)
    inspector = scene_graph.model_inspector()
    world = inspector.world_frame_id()
    frames = [(frame, frame) for frame in inspector.GetAllFrameIds() if frame != world]
    poses = builder.AddNamedSystem(WORLD_POSES, MirroredPoses(frames))
    builder.Connect(scene_graph.get_query_output_port(), poses.get_input_port())
    return poses


def CameraSceneOf(builder: DiagramBuilder, scene_graph: SceneGraph) -> CameraScene:
    """The cameras' scene graph of the diagram ``builder`` builds: the one added already
    (the VTK cameras and lidars share it), else a new one (:func:`AddCameraScene`)."""
    if builder.HasSubsystemNamed(CAMERA_SCENE_POSES):
        return builder.GetSubsystemByName(CAMERA_SCENE_POSES).scene
    return AddCameraScene(builder, scene_graph)


def _half_extents(shape) -> np.ndarray:
    """Half the sides of the box around a convex primitive, in its frame."""
    if isinstance(shape, Box):
        return np.array([shape.width(), shape.depth(), shape.height()]) / 2
    if isinstance(shape, Sphere):
        return np.full(3, shape.radius())
    if isinstance(shape, Cylinder):
        return np.array([shape.radius(), shape.radius(), shape.length() / 2])
    if isinstance(shape, Capsule):
        return np.array([shape.radius(), shape.radius(), shape.length() / 2 + shape.radius()])
    return np.array([shape.a(), shape.b(), shape.c()])  # Ellipsoid


def _inside(shape, p_G: np.ndarray) -> bool:
    """Whether the point ``p_G`` (in the shape's frame) is strictly inside ``shape``; False
    for shapes other than Drake's convex primitives (meshes may be open or concave)."""
    x, y, z = (abs(float(value)) for value in p_G)
    if isinstance(shape, Box):
        return x < shape.width() / 2 and y < shape.depth() / 2 and z < shape.height() / 2
    if isinstance(shape, Sphere):
        return math.sqrt(x * x + y * y + z * z) < shape.radius()
    if isinstance(shape, Cylinder):
        return math.hypot(x, y) < shape.radius() and z < shape.length() / 2
    if isinstance(shape, Capsule):
        return math.hypot(x, y, max(z - shape.length() / 2, 0.0)) < shape.radius()
    if isinstance(shape, Ellipsoid):
        return (x / shape.a()) ** 2 + (y / shape.b()) ** 2 + (z / shape.c()) ** 2 < 1.0
    return False


def enclosing(
    scene_graph: SceneGraph, frame: FrameId, p_F, beyond: float = 0.0
) -> list[GeometryId]:
    """The perception geometries on ``frame`` of ``scene_graph`` whose closed convex
    shape (box, sphere, cylinder, capsule, ellipsoid) holds the point ``p_F`` [m, in the
    frame] strictly inside: a camera there sees only their back faces. With ``beyond``
    (a camera's near clipping distance [m]) only those that reach farther than that from
    the point: the near plane hides the others."""
    inspector = scene_graph.model_inspector()
    p_F = np.asarray(p_F, dtype=float)
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    found = []
    for geometry in inspector.GetGeometries(frame, Role.kPerception):
        shape = inspector.GetShape(geometry)
        p_G = inspector.GetPoseInFrame(geometry).inverse() @ p_F
        if not _inside(shape, p_G):
            continue
        if np.linalg.norm(corners * _half_extents(shape) - p_G, axis=1).max() > beyond:
            found.append(geometry)
    return found


def SceneFor(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    frame: FrameId,
    p_F,
    near: float,
    sensor: tuple[str, str],
) -> CameraScene:
    """The mirror a VTK sensor at ``p_F`` on ``frame`` (its near clipping distance
    ``near`` [m]) renders from: the shared one (:func:`CameraSceneOf`), or, for a sensor
    inside convex visuals that reach past its near plane, a mirror of its own without
    them, named after ``sensor`` (its kind and name: ``("camera", NAME)``) and logged."""
    hidden = enclosing(scene_graph, frame, p_F, near)
    if not hidden:
        return CameraSceneOf(builder, scene_graph)
    inspector = scene_graph.model_inspector()
    _log.info(
        "%s sits inside the visual %s of %s: left out of what it sees, as Gazebo, which "
        "culls back faces, leaves it out",
        " ".join(sensor),
        ", ".join(repr(inspector.GetName(geometry)) for geometry in hidden),
        inspector.GetName(frame),
    )
    return AddCameraScene(builder, scene_graph, hidden=hidden, suffix=f"_{sensor[1]}")
