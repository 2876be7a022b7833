"""The inertia repairs of :func:`~armando_drake.description.importer.prepare_urdf`.

A link whose mass is negative is taken as massless; a massless link on the child side
of a moving joint (with nothing massive welded to it) gets its geometry's mass at a
density (:mod:`armando_drake.description.inertia`), else a small default mass and the
inertia of its bounding box; a declared inertia that is not physically valid, or far
larger than its bounding box's at its mass, is replaced by that box's. Each repair is
an :class:`InertiaFix` of the prepared URDF and one warning naming the file and line.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
from pydrake.multibody.tree import RotationalInertia

from armando_drake.description.inertia import SolidProperties, geometry_properties, parse_floats
from armando_drake.description.meshes import mass_properties
from armando_drake.description.packages import DescriptionError

# A declared inertia whose largest principal moment exceeds this many times
# that of the link's visual bounding box (at the declared mass) is replaced.
INERTIA_RATIO_LIMIT = 100.0
# [kg] mass given to a massless link on the child side of a moving joint.
DEFAULT_MASS = 0.01
# [m] side of the box standing in for a link without any geometry.
DEFAULT_BOX_SIDE = 0.01
# [m] thinnest side of a generated collision or inertia box.
MIN_BOX_SIDE = 0.001
MOVING_JOINT_TYPES = ("revolute", "continuous", "prismatic", "floating", "planar")


@dataclass
class InertiaFix:
    """A link inertia replaced by :func:`prepare_urdf`."""

    link: str
    reason: str  # why it was replaced, in words
    mass: float  # [kg] the mass the link now has
    old: tuple[float, ...] | None  # [kg m^2] declared (ixx, iyy, izz, ixy, ixz, iyz); None if none
    new: tuple[float, float, float]  # [kg m^2] new (ixx, iyy, izz) in link axes
    box: tuple[float, float, float]  # [m] size of the box whose inertia was taken (or around
    # the geometry whose was)
    volume: float | None = None  # [m^3] the geometry's volume, when its inertia was taken


def _format(values) -> str:
    return ", ".join(f"{v:.4g}" for v in values)


class InertiaRepair:
    """The inertia repairs of one URDF being prepared (``prep``, the importer's state:
    its parsed tree, links, lines, mesh files, bounding boxes, result and warnings)."""

    def __init__(self, prep):
        self.prep = prep
        self.solids: dict[tuple, tuple] = {}  # mesh mass properties, by (file, scale)
        self.from_geometry: list[tuple] = []  # (link, mass, solid, scaled to a declared mass)

    def fix_inertias(self) -> None:
        moving_children = set()
        fixed_children: dict[str, list[str]] = {}
        for joint in self.prep.root.findall("joint"):
            child = joint.find("child")
            parent = joint.find("parent")
            if child is None or parent is None:
                continue
            if joint.get("type") in MOVING_JOINT_TYPES:
                moving_children.add(child.get("link"))
            elif joint.get("type") == "fixed":
                fixed_children.setdefault(parent.get("link"), []).append(child.get("link"))
        masses = {name: self.declared_mass(link) for name, link in self.prep.links.items()}

        def welded_mass(name: str, seen: set[str]) -> float:
            seen.add(name)
            return masses.get(name, 0.0) + sum(
                welded_mass(child, seen)
                for child in fixed_children.get(name, [])
                if child not in seen
            )

        for name, link in self.prep.links.items():
            massless = masses[name] <= 0 and welded_mass(name, set()) <= 0
            if name in moving_children and massless:
                if not self.give_geometry_mass(name, link):
                    self.give_default_mass(name, link)
            else:
                self.check_inertia(name, link)
        self.report_geometry_masses()

    def fix_negative_masses(self) -> None:
        """A negative mass is taken as no mass (Drake refuses it), with a warning."""
        for name, link in self.prep.links.items():
            mass = link.find("inertial/mass")
            try:
                value = float(mass.get("value")) if mass is not None else 0.0
            except (TypeError, ValueError):
                raise DescriptionError(
                    f"{self.prep.where(mass)}: link {name!r}: mass value={mass.get('value')!r} is "
                    "not a number"
                ) from None
            if value < 0 or not math.isfinite(value):
                inertial = link.find("inertial")
                link.remove(inertial)
                self.prep.warn(
                    f"{self.prep.where(mass)}: link {name!r}: mass {value:g} kg is not physically "
                    "meaningful: taken as massless (its <inertial> is dropped)"
                )

    def declared_mass(self, link: ET.Element) -> float:
        mass = link.find("inertial/mass")
        try:
            value = float(mass.get("value")) if mass is not None else 0.0
        except (TypeError, ValueError):
            return 0.0
        return value if math.isfinite(value) and value > 0 else 0.0

    def box_inertia(self, mass: float, size: np.ndarray) -> tuple[float, float, float]:
        a, b, c = size
        return (
            mass * (b * b + c * c) / 12,
            mass * (a * a + c * c) / 12,
            mass * (a * a + b * b) / 12,
        )

    def inertia_box(self, link: ET.Element) -> tuple[np.ndarray, np.ndarray]:
        centre, size = self.prep.bounding_box(link)
        if not size.any():  # no visual (or a missing one): the collision geometry's box
            centre, size = self.prep.bounding_box(link, ("collision",))
        if not size.any():
            return centre, np.full(3, DEFAULT_BOX_SIDE)
        return centre, np.maximum(size, MIN_BOX_SIDE)

    def write_inertial(self, link, mass, centre, new, products=(0.0, 0.0, 0.0)) -> None:
        inertial = link.find("inertial")
        if inertial is None:
            inertial = ET.SubElement(link, "inertial")
        origin = inertial.find("origin")
        if origin is None:
            origin = ET.SubElement(inertial, "origin")
        if centre is not None:
            origin.set("xyz", " ".join(f"{c:.9g}" for c in centre))
        origin.set("rpy", "0 0 0")
        for tag in ("mass", "inertia"):
            for element in inertial.findall(tag):
                inertial.remove(element)
        ET.SubElement(inertial, "mass", value=f"{mass:.9g}")
        ixx, iyy, izz = new
        ixy, ixz, iyz = products
        ET.SubElement(
            inertial, "inertia", ixx=f"{ixx:.9g}", iyy=f"{iyy:.9g}", izz=f"{izz:.9g}",
            ixy=f"{ixy:.9g}", ixz=f"{ixz:.9g}", iyz=f"{iyz:.9g}",
        )  # fmt: skip

    def mesh_properties(self, shape: ET.Element):
        """(volume, centre, inertia per unit density) of a ``<mesh>`` with its scale."""
        key = (self.prep.files[shape], tuple(parse_floats(shape.get("scale"), 3, 1.0)))
        if key not in self.solids:
            self.solids[key] = mass_properties(*key)
        return self.solids[key]

    def geometry_solid(self, link: ET.Element) -> SolidProperties | None:
        """The unit-density solid of the link's collision geometry, else its visual one."""
        for kind in ("collision", "visual"):
            try:
                solid = geometry_properties(link, kind, self.mesh_properties)
            except (TypeError, ValueError) as error:
                raise DescriptionError(
                    f"{self.prep.where(link)}: link {link.get('name')!r}: "
                    f"bad {kind} geometry: {error}"
                ) from None
            if solid is not None:
                return solid
        return None

    def give_geometry_mass(self, name: str, link: ET.Element, mass: float = 0.0) -> bool:
        """Gives a link its geometry's inertia: at the density when it has no ``mass``,
        else scaled to ``mass`` (its declared centre of mass kept); False without geometry."""
        solid = self.geometry_solid(link)
        if solid is None:
            return False
        old = self.declared_inertia(link)
        if mass > 0:
            inertia, centre = solid.inertia * mass / solid.volume, None
        else:
            mass, inertia = solid.at_density(self.prep.density)
            centre = solid.centre
        diagonal = (inertia[0, 0], inertia[1, 1], inertia[2, 2])
        products = (inertia[0, 1], inertia[0, 2], inertia[1, 2])
        self.write_inertial(link, mass, centre, diagonal, products)
        reason = "no inertia: that of its geometry" if centre is None else "no mass: its geometry's"
        size = tuple(self.prep.bounding_box(link, ("collision", "visual"))[1])
        self.prep.result.inertia_fixes.append(
            InertiaFix(name, reason, mass, old, diagonal, size, volume=solid.volume)
        )
        self.from_geometry.append((name, mass, solid, centre is None))
        return True

    def report_geometry_masses(self) -> None:
        """One warning naming every link given its geometry's mass or inertia."""
        if not self.from_geometry:
            return
        masses = [(n, m, s) for n, m, s, scaled in self.from_geometry if not scaled]
        scaled = [(n, m, s) for n, m, s, scaled in self.from_geometry if scaled]

        def listed(rows) -> str:
            return ", ".join(f"{n} {m:.4g} kg ({' + '.join(s.shapes)})" for n, m, s in rows)

        parts = []
        if masses:
            total = sum(m for _, m, _ in masses)
            parts.append(
                f"{len(masses)} link(s) declare no mass: each given the mass and inertia of "
                f"its collision (else visual) geometry at {self.prep.density:g} kg/m^3, as "
                f"MuJoCo's inertiafromgeom: {listed(masses)}; {total:.4g} kg in all"
            )
        if scaled:
            parts.append(
                f"{len(scaled)} link(s) declare a mass but no <inertia>: given their "
                f"geometry's inertia at that mass: {listed(scaled)}"
            )
        self.prep.warn(f"{self.prep.source}: " + "; ".join(parts))

    def give_default_mass(self, name: str, link: ET.Element) -> None:
        centre, size = self.inertia_box(link)
        new = self.box_inertia(DEFAULT_MASS, size)
        old = self.declared_inertia(link)
        had = "no <inertial>" if link.find("inertial") is None else "no mass"
        self.write_inertial(link, DEFAULT_MASS, centre, new)
        self.record(
            InertiaFix(name, "massless on a moving joint", DEFAULT_MASS, old, new, tuple(size)),
            f"{self.prep.where(link)}: link {name!r} is the child of a moving joint and has {had} "
            f"(nor has anything welded to it): given a default mass of {DEFAULT_MASS} kg and "
            f"the inertia (ixx, iyy, izz) = ({_format(new)}) kg m^2 of a "
            f"{' x '.join(f'{s:.3g}' for s in size)} m box",
        )

    def declared_inertia(self, link: ET.Element) -> tuple[float, ...] | None:
        inertia = link.find("inertial/inertia")
        if inertia is None:
            return None
        try:
            return tuple(
                float(inertia.get(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
            )
        except ValueError as error:
            raise DescriptionError(f"{self.prep.where(inertia)}: bad <inertia>: {error}") from None

    def check_inertia(self, name: str, link: ET.Element) -> None:
        inertial = link.find("inertial")
        if inertial is None:
            return
        mass = self.declared_mass(link)
        old = self.declared_inertia(link)
        if mass > 0 and old is None and self.give_geometry_mass(name, link, mass):
            return
        if mass <= 0 or old is None:
            return  # a massless link welded to or carrying massive ones is fine for Drake
        ixx, iyy, izz, ixy, ixz, iyz = old
        reason = None
        if (
            not all(math.isfinite(v) for v in old)
            or not RotationalInertia(ixx, iyy, izz, ixy, ixz, iyz).CouldBePhysicallyValid()
        ):
            reason = "is not physically valid"
        centre, size = self.inertia_box(link)
        new = self.box_inertia(mass, size)
        if reason is None:
            matrix = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
            ratio = float(np.linalg.eigvalsh(matrix).max()) / max(new)
            if ratio <= INERTIA_RATIO_LIMIT:
                return
            reason = f"is {ratio:.3g} times that of its visual bounding box"
        self.write_inertial(link, mass, None, new)
        self.record(
            InertiaFix(name, reason, mass, old, new, tuple(size)),
            f"{self.prep.where(inertial)}: link {name!r}: inertia (ixx, iyy, izz, ixy, ixz, iyz) = "
            f"({_format(old)}) kg m^2 at mass {mass:.4g} kg {reason} "
            f"({' x '.join(f'{s:.3g}' for s in size)} m); replaced by that box's inertia "
            f"(ixx, iyy, izz) = ({_format(new)}) kg m^2",
        )

    def record(self, fix: InertiaFix, message: str) -> None:
        self.prep.result.inertia_fixes.append(fix)
        self.prep.warn(message)
