"""Mass properties of a link's geometry, as MuJoCo's ``inertiafromgeom`` gives them.

A link that declares no mass gets the mass of the solid its geometry bounds at a
density (:data:`DEFAULT_DENSITY`, water's, MuJoCo's default): the link's collision
geometry, else its visual geometry. Boxes, cylinders, spheres, ellipsoids and capsules
are computed analytically; a mesh is the solid it encloses when it is closed, else its
convex hull (:func:`~armando_drake.description.meshes.mass_properties`, by trimesh).
Several shapes of one link add up (overlaps counted twice, as MuJoCo does), each placed
by its ``<origin>``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw

# [kg/m^3] the density of a link's geometry when the link declares no mass: water's.
DEFAULT_DENSITY = 1000.0


@dataclass
class SolidProperties:
    """The mass properties of a solid of unit density, in the link frame."""

    volume: float  # [m^3] (its mass per unit density)
    centre: np.ndarray  # [m] the centroid, link frame
    inertia: np.ndarray  # [m^5] (3, 3) about the centroid, link axes, per unit density
    shapes: list[str]  # what was measured, e.g. ["collision mesh link_1.stl"]

    def at_density(self, density: float) -> tuple[float, np.ndarray]:
        """(mass [kg], inertia [kg m^2] about the centroid) at ``density`` [kg/m^3]."""
        return density * self.volume, density * self.inertia


def parse_floats(text: str | None, count: int, default: float = 0.0) -> np.ndarray:
    if text is None or not text.strip():
        return np.full(count, default)
    values = np.array([float(v) for v in text.split()])
    if len(values) != count:
        raise ValueError(f"expected {count} numbers, got {text!r}")
    return values


def parse_origin(item: ET.Element) -> RigidTransform:
    origin = item.find("origin")
    if origin is None:
        return RigidTransform()
    rpy = parse_floats(origin.get("rpy"), 3)
    return RigidTransform(RollPitchYaw(rpy), parse_floats(origin.get("xyz"), 3))


def primitive_properties(shape: ET.Element) -> tuple[float, np.ndarray] | None:
    """(volume [m^3], inertia [m^5] about its centre, per unit density) of a URDF
    primitive (box, cylinder along z, sphere, Drake's ellipsoid and capsule); None for
    anything else."""
    kind = shape.tag.removeprefix("drake:")
    if kind == "box":
        a, b, c = np.abs(parse_floats(shape.get("size"), 3))
        volume = a * b * c
        return volume, volume / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    if kind == "cylinder":
        r, h = abs(float(shape.get("radius"))), abs(float(shape.get("length")))
        volume = math.pi * r * r * h
        side = volume * (3 * r * r + h * h) / 12
        return volume, np.diag([side, side, volume * r * r / 2])
    if kind == "sphere":
        r = abs(float(shape.get("radius")))
        volume = 4 / 3 * math.pi * r**3
        return volume, np.eye(3) * volume * 2 / 5 * r * r
    if kind == "ellipsoid":
        a, b, c = (abs(float(shape.get(k))) for k in "abc")
        volume = 4 / 3 * math.pi * a * b * c
        return volume, volume / 5 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    if kind == "capsule":  # a cylinder and the two half spheres at its ends
        r, h = abs(float(shape.get("radius"))), abs(float(shape.get("length")))
        cylinder = math.pi * r * r * h
        ball = 4 / 3 * math.pi * r**3
        # Each half sphere about the capsule's centre: its own moment plus its offset.
        offset = h / 2 + 3 * r / 8
        half_side = ball / 2 * (83 / 320 * r * r) + ball / 2 * offset * offset
        side = cylinder * (3 * r * r + h * h) / 12 + 2 * half_side
        axial = cylinder * r * r / 2 + ball * 2 / 5 * r * r
        return cylinder + ball, np.diag([side, side, axial])
    return None


def geometry_properties(
    link: ET.Element,
    kind: str,
    mesh_properties: Callable[[ET.Element], tuple[float, np.ndarray, np.ndarray]],
) -> SolidProperties | None:
    """The unit-density mass properties of the ``kind`` (``collision`` or ``visual``)
    geometry of ``link``, in the link frame; None when it has none with a volume.
    ``mesh_properties(mesh_element)`` gives (volume, centre, inertia) of a ``<mesh>``
    in its own frame, its ``scale`` applied."""
    parts = []
    shapes = []
    for item in link.findall(kind):
        geometry = item.find("geometry")
        if geometry is None or len(geometry) == 0:
            continue
        shape = geometry[0]
        if shape.tag == "mesh":
            volume, centre, inertia = mesh_properties(shape)
            name = (shape.get("filename") or "").rsplit("/", 1)[-1]
            shapes.append(f"{kind} mesh {name}")
        else:
            found = primitive_properties(shape)
            if found is None:
                continue
            volume, inertia = found
            centre = np.zeros(3)
            shapes.append(f"{kind} {shape.tag.removeprefix('drake:')}")
        if not volume > 0:
            continue
        X = parse_origin(item)
        R = X.rotation().matrix()
        parts.append((volume, X.multiply(np.asarray(centre, dtype=float)), R @ inertia @ R.T))
    if not parts:
        return None
    total = sum(volume for volume, _, _ in parts)
    centre = sum(volume * c for volume, c, _ in parts) / total
    inertia = np.zeros((3, 3))
    for volume, c, own in parts:
        d = c - centre
        inertia += own + volume * (d @ d * np.eye(3) - np.outer(d, d))
    return SolidProperties(volume=total, centre=centre, inertia=inertia, shapes=shapes)
