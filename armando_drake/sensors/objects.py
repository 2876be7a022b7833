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

import math
from dataclasses import dataclass, field

import numpy as np
from pydrake import geometry
from pydrake.geometry import GeometryInstance, PerceptionProperties, Rgba
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant

from armando_drake.sensors.marker import ArucoMarker, MarkerError
from armando_drake.tools.errors import UserInputError

GROUND_COLOR = (0.85, 0.85, 0.82, 1.0)  # RGBA of the ground, in Meshcat and in cameras


class SceneObjectError(UserInputError, ValueError):
    """A scenario object with a bad shape, size, pose or colour."""


@dataclass
class Box:
    """A box centred on the object frame."""

    # [m] edge lengths along the object frame's x, y and z.
    size: list[float] = field(default_factory=lambda: [0.05, 0.05, 0.05])


@dataclass
class Cylinder:
    """A cylinder centred on the object frame, its axis the frame's z axis."""

    radius: float = 0.05  # [m]
    length: float = 0.05  # [m] along z


@dataclass
class Sphere:
    """A sphere centred on the object frame."""

    radius: float = 0.05  # [m]


# The shape of a scene object; a YAML tag chooses (!Box, !Cylinder, !Sphere,
# !ArucoMarker: a thin box showing an OpenCV ArUco marker, see vision/marker.py).
ObjectShape = Box | Cylinder | Sphere | ArucoMarker


@dataclass
class SceneObject:
    """A static object of the scenario, welded to the world."""

    name: str = ""  # unique name (geometry names derive from it)
    # !Box {size: [x, y, z]} | !Cylinder {radius, length} | !Sphere {radius}, in metres;
    # !ArucoMarker {dictionary, id, side_length, margin, thickness}.
    shape: ObjectShape = field(default_factory=Box)
    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # [m] centre in world
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # [rad] roll pitch yaw
    color: list[float] = field(default_factory=lambda: [0.8, 0.2, 0.2, 1.0])  # RGBA in [0, 1]
    collision: bool = True  # also register collision geometry
    friction: float = 0.8  # [-] Coulomb friction coefficient (static = dynamic)

    def X_WO(self) -> RigidTransform:
        """Pose of the object frame O in the world."""
        return RigidTransform(RollPitchYaw(self.rpy), self.xyz)

    def make_shape(self) -> geometry.Shape:
        """The Drake shape (after :func:`validate_object`)."""
        shape = self.shape
        if isinstance(shape, Box):
            return geometry.Box(*shape.size)
        if isinstance(shape, Cylinder):
            return geometry.Cylinder(shape.radius, shape.length)
        if isinstance(shape, ArucoMarker):  # the box of the marker (collision)
            return geometry.Box(shape.face, shape.face, shape.thickness)
        return geometry.Sphere(shape.radius)


def _numbers(obj: SceneObject, label: str, values, count: int) -> list[float]:
    try:
        numbers = [float(v) for v in values]
    except (TypeError, ValueError):
        raise SceneObjectError(f"object {obj.name!r}: {label}={values!r} is not numbers") from None
    if len(numbers) != count or not all(math.isfinite(v) for v in numbers):
        raise SceneObjectError(f"object {obj.name!r}: {label}={values!r} must be {count} numbers")
    return numbers


def _dimensions(obj: SceneObject) -> dict[str, float]:
    """The shape's dimensions [m] by name; raises for a shape of the wrong type."""
    shape = obj.shape
    if isinstance(shape, Box):
        x, y, z = _numbers(obj, "Box size", shape.size, 3)
        return {"x": x, "y": y, "z": z}
    if isinstance(shape, Cylinder):
        return {"radius": shape.radius, "length": shape.length}
    if isinstance(shape, Sphere):
        return {"radius": shape.radius}
    if isinstance(shape, ArucoMarker):
        try:
            shape.check(f"object {obj.name!r}: ArucoMarker")
        except MarkerError as error:
            raise SceneObjectError(str(error)) from None
        return {"side_length": shape.side_length, "thickness": shape.thickness}
    raise SceneObjectError(
        f"object {obj.name!r}: shape={shape!r} is not one of !Box, !Cylinder, !Sphere, !ArucoMarker"
    )


def validate_object(obj: SceneObject) -> None:
    """Raises :class:`SceneObjectError` naming the object and the bad value."""
    if not obj.name:
        raise SceneObjectError(f"scene object {obj!r} has no name")
    kind = type(obj.shape).__name__
    for label, value in _dimensions(obj).items():
        if not (math.isfinite(value) and value > 0):
            raise SceneObjectError(
                f"object {obj.name!r}: {kind} {label}={value!r} must be positive [m]"
            )
    _numbers(obj, "xyz", obj.xyz, 3)
    _numbers(obj, "rpy", obj.rpy, 3)
    color = _numbers(obj, "color", obj.color, 4)
    if not all(0.0 <= c <= 1.0 for c in color):
        raise SceneObjectError(f"object {obj.name!r}: color={obj.color!r} must be RGBA in [0, 1]")
    if not obj.friction >= 0:
        raise SceneObjectError(f"object {obj.name!r}: friction={obj.friction!r} must be >= 0")


def AddSceneObjects(plant: MultibodyPlant, objects: list[SceneObject]) -> None:
    """Welds each object's visual (+ collision) geometry to the world of ``plant``.

    Call before ``plant.Finalize()``. All objects are validated before any is added.
    """
    names = set()
    for obj in objects:
        validate_object(obj)
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


def AddGround(plant: MultibodyPlant) -> None:
    """A 2 m x 2 m slab whose top face is the plane z = 0.

    Cameras see it (perception role); Meshcat does not (no illustration role):
    :class:`~armando_drake.outputs.view.ViewFramer` draws a ground there that
    fits the scene.
    """
    X_WG = RigidTransform([0.0, 0.0, -0.025])
    ground = geometry.Box(2.0, 2.0, 0.05)
    plant.RegisterCollisionGeometry(
        plant.world_body(), X_WG, ground, "ground", CoulombFriction(0.8, 0.8)
    )
    instance = GeometryInstance(X_WG, ground, "ground")
    perception = PerceptionProperties()
    perception.AddProperty("phong", "diffuse", Rgba(*GROUND_COLOR))
    instance.set_perception_properties(perception)
    plant.RegisterVisualGeometry(plant.world_body(), instance)
