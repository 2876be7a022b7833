"""Scenario objects: simple static shapes for the camera (and the arm) to see.

A scenario lists them in YAML, loaded with Drake's ``yaml_load_typed``; the
shape is a tagged union, each variant with only its own dimensions::

    objects:
    - name: blue_disc
      shape: !Cylinder {radius: 0.15, length: 0.05}   # [m]
      xyz: [0.3, 0.0, 0.025]
      color: [0.0, 0.0, 1.0, 1.0]
    - name: cube
      shape: !Box {size: [0.05, 0.05, 0.05]}          # [m] x y z
    - name: ball
      shape: !Sphere {radius: 0.03}                    # [m]

Each object is welded to the world with visual geometry (illustration and
perception roles, so Meshcat and the cameras both see it) and, unless turned
off, collision geometry of the same shape. Shapes follow Drake (and
SDFormat): a box is centred on its frame, a cylinder's axis is its frame's z
axis. (No ``from __future__ import annotations`` here: ``yaml_load_typed``
needs the field types as types, not strings.)
"""

import logging
from dataclasses import dataclass, field

import numpy as np
from pydrake import geometry
from pydrake.geometry import Role, SceneGraph
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant

from armando_drake import MODELS_DIR
from armando_drake.sensors.marker import ArucoMarker
from armando_drake.tools.schema import ConfigError, Refusal, check_config, param

GROUND_COLOR = (0.85, 0.85, 0.82, 1.0)  # RGBA of the ground, in Meshcat and in cameras
# The default scene: the ground slab the cameras see (its colour GROUND_COLOR).
GROUND_SCENE = MODELS_DIR / "scenes" / "ground.urdf"


class SceneObjectError(ConfigError):
    """A scenario object with a bad shape, size, pose or colour."""


@dataclass
class Box:
    """A box centred on the object frame."""

    # [m] edge lengths along the object frame's x, y and z.
    size: list[float] = param(
        [0.05, 0.05, 0.05], unit="m", gt=0, length=3, item_names=("x", "y", "z")
    )

    def message_prefix(self, parent: str, name: str) -> str:
        """Named after its type in messages (``Box x=-1.0``)."""
        return f"{parent}Box " if name else ""


@dataclass
class Cylinder:
    """A cylinder centred on the object frame, its axis the frame's z axis."""

    radius: float = param(0.05, unit="m", gt=0)  # [m]
    length: float = param(0.05, unit="m", gt=0)  # [m] along z

    def message_prefix(self, parent: str, name: str) -> str:
        """Named after its type in messages (``Cylinder length=0.0``)."""
        return f"{parent}Cylinder " if name else ""


@dataclass
class Sphere:
    """A sphere centred on the object frame."""

    radius: float = param(0.05, unit="m", gt=0)  # [m]

    def message_prefix(self, parent: str, name: str) -> str:
        """Named after its type in messages (``Sphere radius=-0.1``)."""
        return f"{parent}Sphere " if name else ""


# The shape of a scene object; a YAML tag chooses (!Box, !Cylinder, !Sphere,
# !ArucoMarker: a thin box showing an OpenCV ArUco marker, see sensors/marker.py).
ObjectShape = Box | Cylinder | Sphere | ArucoMarker


@dataclass
class SceneObject:
    """A static object of the scenario, welded to the world."""

    name: str = ""  # unique name (geometry names derive from it)
    # !Box {size: [x, y, z]} | !Cylinder {radius, length} | !Sphere {radius}, in metres;
    # !ArucoMarker {dictionary, id, side_length, margin, thickness}.
    shape: ObjectShape = field(default_factory=Box)
    # [m] centre in world
    xyz: list[float] = param([0.0, 0.0, 0.0], unit="m", length=3, coordinate=True)
    rpy: list[float] = param([0.0, 0.0, 0.0], unit="rad", length=3)  # [rad] roll pitch yaw
    color: list[float] = param([0.8, 0.2, 0.2, 1.0], unit="-", length=4)  # RGBA in [0, 1]
    collision: bool = True  # also register collision geometry
    # [-] Coulomb friction coefficient (static = dynamic)
    friction: float = param(0.8, unit="-", ge=0)

    def message_prefix(self, parent: str, name: str) -> str:
        """Messages name the object: ``objects.0: object 'ball': xyz=...``."""
        return f"{parent}{name}: object {self.name!r}: " if name else f"object {self.name!r}: "

    def check(self) -> None:
        """A name, a shape of the known kinds, a colour in [0, 1]."""
        if not self.name:
            raise Refusal("name", "='': every object needs a name")
        if not isinstance(self.shape, (Box, Cylinder, Sphere, ArucoMarker)):
            raise Refusal(
                "shape", f"={self.shape!r} is not one of !Box, !Cylinder, !Sphere, !ArucoMarker"
            )
        if not all(0.0 <= c <= 1.0 for c in self.color):
            raise Refusal("color", f"={self.color!r} must be RGBA in [0, 1]")

    def X_WO(self) -> RigidTransform:
        """Pose of the object frame O in the world."""
        return RigidTransform(RollPitchYaw(self.rpy), self.xyz)

    def make_shape(self) -> geometry.Shape:
        """The Drake shape (of a checked object)."""
        shape = self.shape
        if isinstance(shape, Box):
            return geometry.Box(*shape.size)
        if isinstance(shape, Cylinder):
            return geometry.Cylinder(shape.radius, shape.length)
        if isinstance(shape, ArucoMarker):  # the box of the marker (collision)
            return geometry.Box(shape.face, shape.face, shape.thickness)
        return geometry.Sphere(shape.radius)


def AddSceneObjects(plant: MultibodyPlant, objects: list[SceneObject]) -> None:
    """Welds each object's visual (+ collision) geometry to the world of ``plant``.

    Call before ``plant.Finalize()``. All objects are checked (their schema, see
    :func:`~armando_drake.tools.schema.check_config`) before any is added.
    """
    names = set()
    for obj in objects:
        check_config(obj, error=SceneObjectError)
        if obj.name in names:
            raise SceneObjectError(f"object {obj.name!r} is listed twice")
        names.add(obj.name)
    if plant.is_finalized():
        raise SceneObjectError("AddSceneObjects: the plant is already finalized")
    if objects and not plant.geometry_source_is_registered():
        raise SceneObjectError(
            "AddSceneObjects: the plant has no SceneGraph (use AddMultibodyPlantSceneGraph)"
        )
    world = plant.world_body()
    for obj in objects:
        X_WO = obj.X_WO()
        shape = obj.make_shape()
        if isinstance(obj.shape, ArucoMarker):  # the textured mesh: its MTL gives the colours
            instance = geometry.GeometryInstance(
                X_WO, geometry.Mesh(str(obj.shape.mesh_file())), f"{obj.name}_visual"
            )
            # The cameras see the texture; Meshcat (illustration) shows the mesh's MTL.
            perception = geometry.PerceptionProperties()
            perception.AddProperty("phong", "diffuse", geometry.Rgba(1.0, 1.0, 1.0, 1.0))
            perception.AddProperty(
                "phong", "diffuse_map", str(obj.shape.mesh_file().with_suffix(".png"))
            )
            instance.set_perception_properties(perception)
            instance.set_illustration_properties(geometry.IllustrationProperties())
            plant.RegisterVisualGeometry(world, instance)
        else:
            plant.RegisterVisualGeometry(
                world, X_WO, shape, f"{obj.name}_visual", np.asarray(obj.color, dtype=float)
            )
        if obj.collision:
            friction = CoulombFriction(obj.friction, obj.friction)
            plant.RegisterCollisionGeometry(world, X_WO, shape, f"{obj.name}_collision", friction)


def AddGround(plant: MultibodyPlant, scene_graph: SceneGraph) -> None:
    """The default scene, ``models/scenes/ground.urdf``: a 2 m x 2 m slab whose top face
    is the plane z = 0.

    Cameras see it (perception role); Meshcat does not (its illustration role is
    removed): :class:`~armando_drake.outputs.view.ViewFramer` draws a ground there that
    fits the scene.
    """
    (instance,) = Parser(plant, "scene").AddModels(str(GROUND_SCENE))
    for body in plant.GetBodyIndices(instance):
        for geometry_id in plant.GetVisualGeometriesForBody(plant.get_body(body)):
            scene_graph.RemoveRole(plant.get_source_id(), geometry_id, Role.kIllustration)


# [m] side of the floor a mobile robot drives on, as the cameras see it (its collision is
# a half space: no edge to drive off).
FLOOR_SIDE = 40.0
GROUND_FRICTION = 0.8  # [-] the ground's friction (models/scenes/ground.urdf's)


class _NoDeformableNote(logging.Filter):
    """Drops Drake's note that deformable bodies ignore a rigid half space: the floor's
    (a world has no deformable body)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "half spaces are not currently supported for deformable" not in record.getMessage()


_DRAKE_LOG = logging.getLogger("drake")
_DRAKE_LOG.addFilter(_NoDeformableNote())


def AddFloor(plant: MultibodyPlant, scene_graph: SceneGraph) -> None:
    """The ground of a mobile robot: the plane z = 0 as a half space (friction
    :data:`GROUND_FRICTION`, the default scene's), and for the cameras a slab
    :data:`FLOOR_SIDE` m wide of the ground's colour (Meshcat draws its own ground, as for
    :func:`AddGround`). A half space costs less at every contact query than a box."""
    world = plant.world_body()
    friction = CoulombFriction(GROUND_FRICTION, GROUND_FRICTION)
    plant.RegisterCollisionGeometry(
        world, RigidTransform(), geometry.HalfSpace(), "floor", friction
    )
    slab = geometry.Box(FLOOR_SIDE, FLOOR_SIDE, 0.05)
    X_WS = RigidTransform([0.0, 0.0, -0.025])
    visual = plant.RegisterVisualGeometry(world, X_WS, slab, "floor_visual", np.array(GROUND_COLOR))
    scene_graph.RemoveRole(plant.get_source_id(), visual, Role.kIllustration)
