"""Any ROS robot description, prepared so that Drake loads and simulates it.

ROS descriptions are written for RViz and Gazebo, which forgive a lot. Before
Drake parses an expanded URDF, :func:`prepare_urdf` rewrites it (XML to XML):

1. meshes: STL and Collada files are converted to cached OBJ files (see
   :mod:`armando_drake.description.meshes`) and the ``filename`` attributes point at them;
   missing files, unknown packages and unsupported formats are errors naming
   the file, the link and the URDF line, except for a visual's mesh: a visual whose
   file is missing is dropped with a warning (it only draws the link);
2. collision geometry, by ``collision`` mode:

   - ``boxes``: each link's collisions become one box around its visual geometry;
   - ``convex``: each collision mesh (STL, DAE, OBJ, glTF) becomes its convex
     hull, computed by trimesh and cached as an OBJ keyed by the mesh's content
     (:func:`~armando_drake.description.meshes.convex_hull`), declared convex
     (``<drake:declare_convex/>``); one hull per mesh, primitives kept;
   - ``as-is``: kept (meshes converted);
   - ``none``: removed;
   - ``auto``: ``convex`` when a link collides through a mesh, else ``as-is``;
     a wheel (the child of a continuous joint) with a collision mesh collides as a
     cylinder about the joint's axis around its mesh (a hull would thump as it turns);

   and, unless ``none``, links on the two sides of a moving joint (with every
   link welded to them) never collide with each other;
3. inertias: a link whose inertia is not physically valid, or whose largest
   principal moment exceeds :data:`INERTIA_RATIO_LIMIT` times that of its visual
   bounding box at its declared mass, gets the bounding box's inertia (one
   warning each); a link on the child side of a moving joint that carries no
   mass at all (neither it nor the links welded below it) gets the mass and
   inertia of its collision (else visual) geometry at ``density``
   (:mod:`armando_drake.description.inertia`), and a link with a mass but no
   ``<inertia>`` its geometry's inertia at that mass (one warning per robot
   listing them); a massless link without geometry gets :data:`DEFAULT_MASS`
   (a warning).

Before any of this, a negative mass is taken as no mass (with a warning), and
a Collada visual shows its own materials rather than the URDF ``<material>``.

:func:`actuation` tells which joints are actuated, with their command
interfaces (from ``<ros2_control>``, ROS 1 transmissions, or every moving
joint; never a ``<mimic>`` joint), :func:`actuated_joints` which of them take
position commands (the joints of the default controller configuration,
:func:`armando_drake.control.controllers.default_controller_config`, of a robot that
comes without one).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix

from armando_drake.description.inertia import (
    DEFAULT_DENSITY,
    parse_floats,
    parse_origin,
)
from armando_drake.description.inertia_repairs import (
    MIN_BOX_SIDE,
    MOVING_JOINT_TYPES,
    InertiaFix,
    InertiaRepair,
)
from armando_drake.description.meshes import (
    DRAKE_FORMATS,
    ConvertedMesh,
    convert_mesh,
    convex_hull,
    resolve_mesh,
)
from armando_drake.description.packages import DescriptionError, PackageSearch
from armando_drake.description.ros2_control import (
    ComponentInfo,
    HardwareInfo,
    InterfaceInfo,
    Ros2ControlError,
    parse_ros2_control,
)
from armando_drake.description.urdf import parse_joints, parse_transmissions

LOGGER = logging.getLogger("armando_drake.description.importer")

COLLISION_MODES = ("auto", "boxes", "convex", "as-is", "none")
# Mesh formats Drake can use as collision geometry.
COLLIDABLE_FORMATS = DRAKE_FORMATS


@dataclass
class PreparedUrdf:
    """The URDF Drake loads, and what preparing it changed."""

    urdf: str  # the rewritten URDF text
    warnings: list[str] = field(default_factory=list)  # one line per change made
    converted: list[ConvertedMesh] = field(default_factory=list)  # meshes this call converted
    meshes: list[ConvertedMesh] = field(default_factory=list)  # every mesh file used, once each
    collision: str = "as-is"  # the collision mode applied ("auto" resolved)
    inertia_fixes: list[InertiaFix] = field(default_factory=list)


# --------------------------------------------------------------------------
# XML with line numbers
# --------------------------------------------------------------------------


def parse_with_lines(text: str, source: str = "") -> tuple[ET.Element, dict[ET.Element, int]]:
    """The XML root of ``text`` and the line each element starts on.

    Namespaced names (``drake:declare_convex``, ``xmlns:xacro``) are kept
    literally, so writing the tree back changes nothing but what was edited.
    """
    builder = ET.TreeBuilder()
    lines: dict[ET.Element, int] = {}
    parser = expat.ParserCreate()
    parser.buffer_text = True

    def start(tag: str, attributes: dict[str, str]) -> None:
        lines[builder.start(tag, attributes)] = parser.CurrentLineNumber

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    try:
        parser.Parse(text, True)
    except expat.ExpatError as error:
        raise DescriptionError(
            f"{source or '<urdf>'}:{error.lineno}: not valid XML: {error}"
        ) from None
    return builder.close(), lines


def xacro_origin(
    source: str, written: list[str], parents: dict, element: ET.Element, line: int | None
) -> str:
    """``element`` of the URDF expanded from the xacro ``source`` (whose lines are
    ``written``; ``parents``: each element's parent in the expanded tree); see ``where``."""
    named = element
    while named is not None and not named.get("name"):
        named = parents.get(named)
    if named is None:
        return f"{source} (line {line} of the expanded URDF)" if line else source
    name = named.get("name")
    hits = [
        number
        for number, text in enumerate(written, 1)
        if f'name="{name}"' in text or f"name='{name}'" in text
    ]
    if len(hits) == 1:
        return f"{source}:{hits[0]} (<{named.tag} name={name!r}>)"
    what = f"<{named.tag} name={name!r}>"
    return f"{source} ({what}, line {line} of the expanded URDF)" if line else source


def _box_corners(half: np.ndarray) -> np.ndarray:
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    return signs * half


# --------------------------------------------------------------------------
# Preparation
# --------------------------------------------------------------------------


class _Preparation:
    """State of one :func:`prepare_urdf` call."""

    def __init__(self, text: str, search: PackageSearch, source: str):
        self.source = source or "<urdf>"
        self.base_dir = Path(source).parent if source else None
        self.search = search
        self.root, self.lines = parse_with_lines(text, self.source)
        self.result = PreparedUrdf(urdf="")
        self.files: dict[ET.Element, Path] = {}  # <mesh> element -> its source file
        self.meshes: dict[Path, ConvertedMesh] = {}
        self.hulls: dict[Path, ConvertedMesh] = {}  # convex hulls, by source file
        self.density = DEFAULT_DENSITY
        self.vertices: dict[Path, np.ndarray] = {}
        self.links = {link.get("name", ""): link for link in self.root.findall("link")}
        self._xacro: tuple | None = None  # (the xacro's lines, parents), for where()

    def where(self, element: ET.Element) -> str:
        """Where ``element`` came from: ``file:line`` of a URDF. xacro keeps no map from
        its output back to its input, so for a xacro the line is the xacro's own line of
        the nearest named element (``name="..."`` written there once), else the expanded
        URDF's line, said as such."""
        line = self.lines.get(element)
        if not self.source.endswith(".xacro"):
            return f"{self.source}:{line}" if line else self.source
        if self._xacro is None:
            written: list[str] = []
            with contextlib.suppress(OSError, UnicodeDecodeError):
                written = Path(self.source).read_text(encoding="utf-8").splitlines()
            parents = {child: parent for parent in self.root.iter() for child in parent}
            self._xacro = (written, parents)
        return xacro_origin(self.source, *self._xacro, element, line)

    def warn(self, message: str) -> None:
        LOGGER.warning("%s", message)
        self.result.warnings.append(message)

    def check_tree(self) -> None:
        """Refuses a link that is the child of two joints (a kinematic loop, which a URDF
        cannot describe and ROS's parser refuses too), naming both joints."""
        parents: dict[str, ET.Element] = {}
        for joint in self.root.findall("joint"):
            child = joint.find("child")
            link = child.get("link", "") if child is not None else ""
            first = parents.setdefault(link, joint)
            if first is not joint:
                raise DescriptionError(
                    f"{self.where(joint)}: joint {joint.get('name')!r} makes link {link!r} the "
                    f"child of a second joint (the first is {first.get('name')!r}, line "
                    f"{self.lines.get(first, '?')}): the joints form a kinematic loop, which a "
                    "URDF cannot describe"
                )

    def check_shapes(self) -> None:
        """Refuses a box, cylinder or sphere with a size that is not a positive finite
        length (Drake cannot build it), naming the file, line, link and value."""
        sizes = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",)}
        for name, link in self.links.items():
            for kind in ("visual", "collision"):
                for item in link.findall(kind):
                    for shape in item.findall("geometry/*"):
                        for attribute in sizes.get(shape.tag, ()):
                            text = shape.get(attribute, "")
                            try:
                                values = [float(v) for v in text.split()]
                            except ValueError:
                                values = []
                            count = 3 if attribute == "size" else 1
                            if len(values) != count or not all(
                                math.isfinite(v) and v > 0 for v in values
                            ):
                                raise DescriptionError(
                                    f"{self.where(shape)}: link {name!r} <{kind}> <{shape.tag} "
                                    f'{attribute}="{text}">: must be {count} positive length'
                                    f"{'s' if count > 1 else ''} [m]"
                                )

    # Meshes ---------------------------------------------------------------

    def mesh_elements(self, link: ET.Element, kind: str) -> list[ET.Element]:
        return [m for item in link.findall(kind) for m in item.findall("geometry/mesh")]

    def check_mesh(self, link: ET.Element, mesh: ET.Element) -> Path:
        """The source file of a mesh element; errors name file, link and line."""
        filename = mesh.get("filename", "")
        where = f"{self.where(mesh)}: link {link.get('name')!r}"
        if not filename:
            raise DescriptionError(f"{where}: <mesh> without a filename")
        try:
            path = resolve_mesh(filename, self.search, self.base_dir)
        except DescriptionError as error:
            raise DescriptionError(f"{where}: mesh {filename!r}: {error}") from None
        if not path.is_file():
            raise DescriptionError(f"{where}: mesh file {filename!r} not found (looked for {path})")
        suffix = path.suffix.lower()
        if suffix not in (".stl", ".dae") + DRAKE_FORMATS:
            try:
                convert_mesh(path)  # raises the unsupported-format message
            except DescriptionError as error:
                raise DescriptionError(f"{where}: {error}") from None
        return path

    def converted(self, path: Path) -> ConvertedMesh:
        if path not in self.meshes:
            mesh = convert_mesh(path)
            self.meshes[path] = mesh
            self.result.meshes.append(mesh)
            if mesh.converted:
                self.result.converted.append(mesh)
        return self.meshes[path]

    def hull(self, path: Path) -> ConvertedMesh:
        if path not in self.hulls:
            self.hulls[path] = hull = convex_hull(path)
            if hull.converted:
                self.result.converted.append(hull)
        return self.hulls[path]

    def mesh_vertices(self, path: Path) -> np.ndarray:
        if path not in self.vertices:
            self.vertices[path] = self.converted(path).vertices()
        return self.vertices[path]

    # Geometry -------------------------------------------------------------

    def geometry_points(self, item: ET.Element) -> np.ndarray | None:
        """Points bounding a <visual>/<collision>, in the link frame (None if no geometry)."""
        geometry = item.find("geometry")
        if geometry is None or len(geometry) == 0:
            return None
        shape = geometry[0]
        kind = shape.tag.removeprefix("drake:")
        try:
            if kind == "box":
                points = _box_corners(parse_floats(shape.get("size"), 3) / 2)
            elif kind == "cylinder":
                radius, length = float(shape.get("radius")), float(shape.get("length"))
                points = _box_corners(np.array([radius, radius, length / 2]))
            elif kind == "capsule":
                radius, length = float(shape.get("radius")), float(shape.get("length"))
                points = _box_corners(np.array([radius, radius, length / 2 + radius]))
            elif kind == "sphere":
                points = _box_corners(np.full(3, float(shape.get("radius"))))
            elif kind == "ellipsoid":
                points = _box_corners(np.array([float(shape.get(k)) for k in "abc"]))
            elif kind == "mesh":
                path = self.files[shape]
                points = self.mesh_vertices(path) * parse_floats(shape.get("scale"), 3, 1.0)
            else:
                return None
        except (TypeError, ValueError) as error:
            raise DescriptionError(f"{self.where(shape)}: bad <{shape.tag}>: {error}") from None
        X_LG = parse_origin(item)
        return (X_LG.rotation().matrix() @ points.T).T + X_LG.translation()

    def bounding_box(self, link: ET.Element, kinds=("visual",)) -> tuple[np.ndarray, np.ndarray]:
        """(centre, size) of the link-frame box around the link's geometry; size 0 if none."""
        points = [
            p
            for kind in kinds
            for item in link.findall(kind)
            if (p := self.geometry_points(item)) is not None
        ]
        if not points:
            return np.zeros(3), np.zeros(3)
        stacked = np.vstack(points)
        low, high = stacked.min(axis=0), stacked.max(axis=0)
        return (low + high) / 2, high - low

    # Steps ----------------------------------------------------------------

    def resolve_meshes(self) -> None:
        for link in self.links.values():
            for visual in link.findall("visual"):
                mesh = visual.find("geometry/mesh")
                if mesh is None:
                    continue
                try:
                    self.files[mesh] = self.check_mesh(link, mesh)
                except DescriptionError as error:
                    if "not found" not in str(error) and "unknown package" not in str(error):
                        raise
                    # A visual only draws the link: the robot runs without it (RViz and
                    # Gazebo show nothing there either).
                    link.remove(visual)
                    self.warn(f"{error}: the link is drawn without this visual")
            for mesh in self.mesh_elements(link, "collision"):
                self.files[mesh] = self.check_mesh(link, mesh)

    def rewrite_meshes(self) -> None:
        overridden = []
        for name, link in self.links.items():
            for mesh in self.mesh_elements(link, "visual"):
                mesh.set("filename", f"file://{self.converted(self.files[mesh]).path}")
            for mesh in self.mesh_elements(link, "collision"):
                source = self.files[mesh]
                if self.result.collision == "convex":  # the hull, one per mesh file
                    source = self.hull(source).path
                # Drake collides with its own formats as they are (an OBJ without normals
                # is rewritten for the renderers only).
                elif source.suffix.lower() not in COLLIDABLE_FORMATS:
                    source = self.converted(source).path
                mesh.set("filename", f"file://{source}")
            for visual in link.findall("visual"):
                mesh = visual.find("geometry/mesh")
                material = visual.find("material")
                if mesh is None or material is None:
                    continue
                if self.files[mesh].suffix.lower() == ".dae":
                    # The Collada file's own materials are shown (as RViz does); Drake
                    # would otherwise warn that the URDF colour is ignored.
                    visual.remove(material)
                    overridden.append(name)
        if overridden:
            LOGGER.info(
                "%s: Collada visuals of %s show their own materials, not the URDF <material>",
                self.source,
                ", ".join(dict.fromkeys(overridden)),
            )

    def resolve_collision_mode(self, collision: str) -> str:
        if collision not in COLLISION_MODES:
            raise DescriptionError(f"collision={collision!r} must be one of {COLLISION_MODES}")
        if collision != "auto":
            return collision
        meshes = {
            self.files[mesh].name
            for link in self.links.values()
            for mesh in self.mesh_elements(link, "collision")
        }
        if not meshes:
            return "as-is"
        LOGGER.info(
            "%s: %d collision mesh(es) collide as their convex hulls (collision='convex'; "
            "'boxes' makes each link one box)",
            self.source,
            len(meshes),
        )
        return "convex"

    def continuous_axes(self) -> dict[str, np.ndarray]:
        """The child link of each continuous joint -> the joint's unit axis (child frame)."""
        axes = {}
        for joint in self.root.findall("joint"):
            child = joint.find("child")
            if joint.get("type") != "continuous" or child is None:
                continue
            try:
                axis = parse_floats(joint.find("axis").get("xyz"), 3, 0.0)
            except (AttributeError, ValueError):
                axis = np.array([1.0, 0.0, 0.0])
            norm = np.linalg.norm(axis)
            axes[child.get("link")] = axis / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
        return axes

    def wheel_cylinder(self, name: str, link: ET.Element, axis: np.ndarray) -> None:
        """Replaces the collisions of ``link`` by one cylinder about ``axis`` (through the
        link origin) around its collision geometry: a wheel rolls on it as it would on
        its mesh, where a box would make it thump."""
        points = [
            p for item in link.findall("collision") if (p := self.geometry_points(item)) is not None
        ]
        if not points:
            return
        stacked = np.vstack(points)
        along = stacked @ axis
        radial = np.linalg.norm(stacked - np.outer(along, axis), axis=1)
        radius, low, high = float(radial.max()), float(along.min()), float(along.max())
        for item in link.findall("collision"):
            link.remove(item)
        # Drake's cylinder runs along its z: turn z onto the axis.
        z = np.array([0.0, 0.0, 1.0])
        rotation = RotationMatrix.MakeFromOneVector(axis, 2) if abs(axis @ z) < 1 else None
        rpy = RollPitchYaw(rotation).vector() if rotation is not None else np.zeros(3)
        centre = axis * (low + high) / 2
        element = ET.SubElement(link, "collision", name=f"{name}_wheel")
        ET.SubElement(
            element,
            "origin",
            xyz=" ".join(f"{c:.9g}" for c in centre),
            rpy=" ".join(f"{c:.9g}" for c in rpy),
        )
        geometry = ET.SubElement(element, "geometry")
        width = max(high - low, MIN_BOX_SIDE)
        ET.SubElement(geometry, "cylinder", radius=f"{radius:.9g}", length=f"{width:.9g}")
        LOGGER.info(
            "%s: link %r collides as a cylinder %.4g m in radius and %.4g m wide about its "
            "continuous joint's axis",
            self.source,
            name,
            radius,
            width,
        )

    def apply_collision_mode(self, mode: str) -> None:
        if mode == "convex":
            wheels = self.continuous_axes()
            for name, link in self.links.items():
                if name in wheels and self.mesh_elements(link, "collision"):
                    self.wheel_cylinder(name, link, wheels[name])
        for name, link in self.links.items():
            collisions = link.findall("collision")
            if mode in ("boxes", "none"):
                if mode == "boxes":
                    self.box_collision(name, link)
                else:
                    for item in collisions:
                        link.remove(item)
            elif mode == "convex":
                for mesh in self.mesh_elements(link, "collision"):
                    if mesh.find("drake:declare_convex") is None:
                        ET.SubElement(mesh, "drake:declare_convex")
        if mode != "none":
            self.filter_adjacent_collisions()
        uses_drake = any(e.tag.startswith("drake:") for e in self.root.iter())
        if uses_drake and "xmlns:drake" not in self.root.attrib:
            self.root.set("xmlns:drake", "http://drake.mit.edu")

    def box_collision(self, name: str, link: ET.Element) -> None:
        """Replaces the collisions of ``link`` by one box around its visual geometry (its
        collision geometry when it has no visual)."""
        centre, size = self.bounding_box(link)
        if not size.any():
            centre, size = self.bounding_box(link, ("collision",))
        for item in link.findall("collision"):
            link.remove(item)
        if size.any():
            box = ET.SubElement(link, "collision", name=f"{name}_bounding_box")
            ET.SubElement(box, "origin", xyz=" ".join(f"{c:.9g}" for c in centre))
            sides = np.maximum(size, MIN_BOX_SIDE)
            geometry = ET.SubElement(box, "geometry")
            ET.SubElement(geometry, "box", size=" ".join(f"{s:.9g}" for s in sides))

    def filter_adjacent_collisions(self) -> None:
        """Links on the two sides of a moving joint, and all links welded to them, never collide.

        Drake only excludes the joint's own parent and child; descriptions that
        hang the geometry on links welded to a bare joint frame (a bracket
        around its servo) would collide with themselves at rest. Gazebo lumps
        welded links, and MoveIt disables adjacent pairs, so neither sees this.
        """
        group = {name: name for name in self.links}

        def find(name: str) -> str:
            while group.setdefault(name, name) != name:
                name = group[name]
            return name

        joints = []
        for joint in self.root.findall("joint"):
            parent, child = joint.find("parent"), joint.find("child")
            if parent is None or child is None:
                continue
            ends = (parent.get("link"), child.get("link"))
            if joint.get("type") == "fixed":
                group[find(ends[0])] = find(ends[1])
            elif joint.get("type") in MOVING_JOINT_TYPES:
                joints.append((joint.get("name"), ends))
        for joint, (parent, child) in joints:
            members = [n for n in self.links if find(n) in (find(parent), find(child))]
            if len(members) <= 2:
                continue  # Drake already excludes a joint's parent and child
            name = f"adjacent_across_{joint}"
            element = ET.SubElement(self.root, "drake:collision_filter_group", name=name)
            for member in members:
                ET.SubElement(element, "drake:member", link=member)
            ET.SubElement(element, "drake:ignored_collision_filter_group", name=name)


def prepare_urdf(
    urdf_text: str,
    search: PackageSearch,
    *,
    collision: str = "auto",
    source: str | os.PathLike = "",
    edit=None,
    density: float = DEFAULT_DENSITY,
) -> PreparedUrdf:
    """Rewrites an expanded URDF so that Drake loads and simulates it.

    ``search`` resolves ``package://`` names; ``source`` is the description
    file (named in errors and warnings; relative mesh paths are relative to its
    folder). ``collision`` is one of :data:`COLLISION_MODES`; ``density``
    [kg/m^3] is that of the geometry of links without mass. See the module
    docstring for what is changed; every change is logged on
    ``armando_drake.description.importer`` and listed in ``warnings``.
    ``edit``, if given, is called with the parsed ``<robot>`` element first
    (the loader's joint repairs and ``world`` link removal), so that the line
    numbers in messages are still those of ``urdf_text``.
    """
    step = _Preparation(urdf_text, search, str(source))
    step.density = density
    if step.root.tag != "robot":
        raise DescriptionError(f"{step.source}: not a URDF: the root element is <{step.root.tag}>")
    if edit is not None:
        edit(step.root)
        step.links = {link.get("name", ""): link for link in step.root.findall("link")}
    step.check_tree()
    step.check_shapes()
    step.resolve_meshes()
    inertias = InertiaRepair(step)
    inertias.fix_negative_masses()
    mode = step.resolve_collision_mode(collision)
    step.result.collision = mode
    inertias.fix_inertias()
    step.apply_collision_mode(mode)
    step.rewrite_meshes()
    step.result.urdf = '<?xml version="1.0"?>\n' + ET.tostring(step.root, encoding="unicode")
    return step.result


# --------------------------------------------------------------------------
# Actuation
# --------------------------------------------------------------------------


def actuation(
    root: ET.Element, hardware: list | None = None, joints: list | None = None
) -> tuple[dict[str, list[str]], str, list[str | Warning]]:
    """The actuated joints with their command interfaces, where that was read, and notes.

    From the ``<ros2_control>`` blocks if the URDF has any (every joint with a
    command interface, in block order; a joint in two blocks keeps the first),
    else from ROS 1 top-level ``<transmission>`` blocks (their
    ``hardware_interface/<Kind>JointInterface`` mapped to position, velocity or
    effort), else every revolute, continuous and prismatic joint with
    ``["position"]``. Joints with a ``<mimic>`` are never actuated: Drake
    couples them to the joint they follow. The source is ``"ros2_control"``,
    ``"transmission"`` or ``"non-fixed joints"``; the notes say what was
    ignored (hardware plugins we do not run, mimic joints, transmissions on
    fixed joints), one line each.
    """

    if hardware is None:
        try:
            hardware = parse_ros2_control(root)
        except Ros2ControlError:  # checked where the description is loaded; read leniently
            hardware = [
                HardwareInfo(
                    name=block.get("name", ""),
                    type=block.get("type", ""),
                    plugin=(block.findtext("hardware/plugin") or "").strip(),
                    joints=[
                        ComponentInfo(
                            name=joint.get("name", ""),
                            type="joint",
                            command_interfaces=[
                                InterfaceInfo(name=i.get("name", ""))
                                for i in joint.findall("command_interface")
                            ],
                        )
                        for joint in block.findall("joint")
                    ],
                )
                for block in root.findall("ros2_control")
            ]
    if joints is None:
        joints = parse_joints(root)
    kinds = {joint.get("name"): joint.get("type") for joint in root.findall("joint")}
    mimics = {joint.name: joint.mimic for joint in joints if joint.mimic}
    result: dict[str, list[str]] = {}
    notes: list[str | Warning] = []

    def add(name: str, interfaces: list[str], where: str) -> None:
        if name in mimics:
            notes.append(
                f"{where}: joint {name!r} mimics {mimics[name]!r}: not actuated, Drake couples it"
            )
        elif name in result:
            notes.append(f"{where}: joint {name!r} is already actuated: this entry is ignored")
        else:
            result[name] = interfaces

    if hardware:
        for block in hardware:
            sensors = [sensor.name for sensor in block.sensors + block.gpios]
            notes.append(
                f"<ros2_control name={block.name!r}>: hardware plugin {block.plugin!r} is not "
                "run: "
                + ("Drake simulates its joints" if block.joints else "")
                + ("; " if block.joints and sensors else "")
                + (f"its sensors/GPIOs ({', '.join(sensors)}) give no readings" if sensors else "")
            )
            for component in block.joints:
                interfaces = [i.name for i in component.command_interfaces]
                if interfaces:
                    add(component.name, interfaces, f"<ros2_control name={block.name!r}>")
        return result, "ros2_control", notes
    transmissions = [t for t in parse_transmissions(root) if not t.ros2_control]
    if transmissions:
        for transmission in transmissions:
            where = f"<transmission name={transmission.name!r}>"
            for name, interfaces in transmission.joints.items():
                written = transmission.hardware_interfaces.get(name, [])
                if kinds.get(name) in (None, "fixed"):
                    notes.append(
                        f"{where} names joint {name!r}, which is not a moving joint: ignored"
                    )
                elif written and not interfaces:
                    notes.append(
                        f"{where}: {', '.join(written)} of joint {name!r} is not a joint "
                        "command interface (position, velocity, effort): ignored"
                    )
                elif name in result and name not in mimics:
                    # Gazebo descriptions give a joint one transmission per interface.
                    result[name] = list(dict.fromkeys(result[name] + interfaces))
                else:
                    add(name, interfaces or ["position"], where)
        if result:
            return result, "transmission", notes
        notes.append("no <transmission> names a joint command interface")
    for name, kind in kinds.items():
        if kind in MOVING_JOINT_TYPES[:3]:
            add(name, ["position"], "no <ros2_control> or <transmission>")
    notes.append(
        "no <ros2_control> or <transmission>: actuating every non-fixed joint: " + ", ".join(result)
    )
    several = [f"{name} ({kind})" for name, kind in kinds.items() if kind in MOVING_JOINT_TYPES[3:]]
    if several:
        notes.append(
            Warning(
                f"not actuated: {', '.join(several)}: a joint of several degrees of freedom "
                "has no joint command interface, so it moves freely"
            )
        )
    return result, "non-fixed joints", notes


def actuated_joints(root: ET.Element) -> tuple[list[str], str]:
    """The joints taking position commands, and where that was read from.

    From ``<ros2_control>`` (joints with a ``position`` command interface) if
    the URDF has one, else from top-level ``<transmission>`` blocks (every
    joint they name, whatever its hardware interface), else every non-fixed
    joint. Mimic joints are left out. The source is ``"ros2_control"``,
    ``"transmission"`` or ``"non-fixed joints"``; see :func:`actuation`.
    """
    interfaces, source, _ = actuation(root)  # load_robot logs the notes
    if source == "ros2_control":
        names = [name for name, kinds in interfaces.items() if "position" in kinds]
    else:
        names = list(interfaces)
    return names, source
