"""Scenario objects: simple static shapes for the camera (and the arm) to see.

A scenario lists them in YAML, loaded with Drake's ``yaml_load_typed``::

    objects:
    - name: blue_disc
      shape: cylinder
      size: [0.15, 0.05]          # radius, length [m]
      xyz: [0.3, 0.0, 0.025]
      color: [0.0, 0.0, 1.0, 1.0]

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
from pydrake.geometry import Box, Cylinder, Shape, Sphere
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant

# The number of size values each shape takes, and what they are.
SHAPE_SIZES = {
    "box": ("x", "y", "z"),
    "cylinder": ("radius", "length"),
    "sphere": ("radius",),
}


class SceneObjectError(ValueError):
    """A scenario object with a bad shape, size, pose or colour."""


@dataclass
class SceneObject:
    """A static object of the scenario, welded to the world."""

    name: str = ""  # unique name (geometry names derive from it)
    shape: str = "box"  # box | cylinder | sphere
    # [m] box: x y z edge lengths; cylinder: radius length (axis = z); sphere: radius
    size: list[float] = field(default_factory=lambda: [0.05, 0.05, 0.05])
    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # [m] centre in world
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # [rad] roll pitch yaw
    color: list[float] = field(default_factory=lambda: [0.8, 0.2, 0.2, 1.0])  # RGBA in [0, 1]
    collision: bool = True  # also register collision geometry
    friction: float = 0.8  # [-] Coulomb friction coefficient (static = dynamic)

    def X_WO(self) -> RigidTransform:
        """Pose of the object frame O in the world."""
        return RigidTransform(RollPitchYaw(self.rpy), self.xyz)

    def make_shape(self) -> Shape:
        """The Drake shape (after :func:`validate_object`)."""
        if self.shape == "box":
            return Box(*self.size)
        if self.shape == "cylinder":
            return Cylinder(self.size[0], self.size[1])
        return Sphere(self.size[0])


def _numbers(obj: SceneObject, label: str, values, count: int) -> list[float]:
    try:
        numbers = [float(v) for v in values]
    except (TypeError, ValueError):
        raise SceneObjectError(f"object {obj.name!r}: {label}={values!r} is not numbers") from None
    if len(numbers) != count or not all(math.isfinite(v) for v in numbers):
        raise SceneObjectError(f"object {obj.name!r}: {label}={values!r} must be {count} numbers")
    return numbers


def validate_object(obj: SceneObject) -> None:
    """Raises :class:`SceneObjectError` naming the object and the bad value."""
    if not obj.name:
        raise SceneObjectError(f"scene object {obj!r} has no name")
    if obj.shape not in SHAPE_SIZES:
        raise SceneObjectError(
            f"object {obj.name!r}: shape={obj.shape!r} is not one of {', '.join(SHAPE_SIZES)}"
        )
    meaning = SHAPE_SIZES[obj.shape]
    size = _numbers(obj, "size", obj.size, len(meaning))
    for label, value in zip(meaning, size, strict=True):
        if not value > 0:
            raise SceneObjectError(
                f"object {obj.name!r}: {obj.shape} {label}={value!r} must be positive "
                f"(size={obj.size!r} is {' '.join(meaning)} in metres)"
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
        plant.RegisterVisualGeometry(
            world, X_WO, shape, f"{obj.name}_visual", np.asarray(obj.color, dtype=float)
        )
        if obj.collision:
            friction = CoulombFriction(obj.friction, obj.friction)
            plant.RegisterCollisionGeometry(world, X_WO, shape, f"{obj.name}_collision", friction)
