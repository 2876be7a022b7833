"""Gazebo worlds (SDFormat ``<world>`` files) as the scene of a Drake plant.

Drake's own SDFormat parser cannot take a Gazebo world as it is: it does not find
``model://`` includes, and it neither renders nor collides with STL. So the world is
read here, model by model: each ``<include>`` (and each ``<model>`` written in the
world) becomes one SDFormat model given to Drake's parser, after these edits:

- ``<include>``: ``<uri>`` ``model://NAME`` is the folder ``NAME`` on the resource
  path: ``GZ_SIM_RESOURCE_PATH``, ``IGN_GAZEBO_RESOURCE_PATH``,
  ``GAZEBO_MODEL_PATH``, ``SDF_PATH``, the scenario's ``world_resource_paths``,
  then the ``models/`` folder of the world's ROS package and the folders next to
  the world file; then the ROS packages (``model://pkg/...`` and ``package://pkg``
  as in ``robot.description``). A Fuel URL is looked for by its model name in the
  same places and in Gazebo's Fuel cache. In the folder, ``model.config`` names
  the SDFormat file (else ``model.sdf``). The include's ``<name>``, ``<pose>`` and
  ``<static>`` replace the model's own. Nested ``<model>`` and ``<include>`` elements are
  read at any depth (Drake composes their poses; a model inside a static model is made
  static, as SDFormat says). ``ground_plane`` and ``sun``, which Gazebo
  installs, are built in when not found. A ``<plane>`` (Gazebo's ground) becomes a box
  slab (:func:`plane_to_slab`): Drake 1.51's HalfSpace can crash its proximity engine.
- meshes: STL and Collada files are converted to OBJ once, into the mesh cache
  (:func:`~armando_drake.description.meshes.convert_mesh`). A mesh's collision
  becomes convex pieces Drake collides with: each connected part of the mesh that
  is (within 5 % of its volume) convex is its convex hull; any other part is one
  thin prism (1 cm deep, behind each face) per triangle, so that concave shapes
  (a tunnel, an L-shaped wall) keep their openings.
- materials: ``<diffuse>`` colours are kept; Gazebo classic's named colours
  (``Gazebo/White`` ...) become their colour; a texture (a classic
  ``<script>`` material's ``texture`` image, Gazebo Sim's ``<pbr>`` ``albedo_map``)
  on a box is drawn on each of its faces (the ArUco marker models).
- lights, physics, plugins, the GUI and other world settings Drake has no use
  for are ignored, named in one warning line.

A world that names a model the resource path does not hold is one error line naming
the world file, the ``<include>``'s line and the URI, and where it was looked for.

Bounded work: a world file or model file is read as a regular file (a FIFO or a device
is refused, not waited on) of at most :data:`MAX_WORLD_FILE_BYTES`; the links and
geometries a world holds, its includes expanded, are counted as each file is read and
refused past :data:`MAX_WORLD_ELEMENTS` (and its models past :data:`MAX_WORLD_MODELS`),
before any reaches Drake; a collision mesh of
more than :data:`MAX_MESH_PARTS` separate parts, or that would make more than
:data:`MAX_MESH_PIECES` collision pieces, is refused before its pieces are made.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import re
import shutil
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.geometry import (
    AddContactMaterial,
    AddRigidHydroelasticProperties,
    Convex,
    Mesh,
    ProximityProperties,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex

from armando_drake.description.importer import parse_with_lines
from armando_drake.description.meshes import cache_dir, convert_mesh, load_mesh
from armando_drake.description.packages import DescriptionError, PackageSearch, find_packages
from armando_drake.tools.files import FileInputError, read_text_file

_log = logging.getLogger("armando_drake.world")

# Environment variables of model folders, in Gazebo Sim's order, then classic's.
RESOURCE_PATH_VARIABLES = (
    "GZ_SIM_RESOURCE_PATH",
    "IGN_GAZEBO_RESOURCE_PATH",
    "GAZEBO_MODEL_PATH",
    "SDF_PATH",
)
# Where Gazebo keeps the models it downloaded from Fuel.
FUEL_CACHES = ("~/.gz/fuel", "~/.ignition/fuel")
# World elements that are scene content; every other one is ignored (named once).
SCENE_ELEMENTS = ("include", "model")
# Model elements Drake has no use for, taken out before Drake reads the model.
STRIPPED_ELEMENTS = (
    "plugin",
    "sensor",
    "light",
    "cast_shadows",
    "audio_source",
    "audio_sink",
    "battery",
    "projector",
    "particle_emitter",
    "laser_retro",
    "enable_wind",
    "velocity_decay",
)
# Gazebo classic's named materials (gazebo.material), as diffuse RGBA.
NAMED_COLORS = {
    "white": (1.0, 1.0, 1.0, 1.0),
    "grey": (0.7, 0.7, 0.7, 1.0),
    "gray": (0.7, 0.7, 0.7, 1.0),
    "darkgrey": (0.35, 0.35, 0.35, 1.0),
    "black": (0.0, 0.0, 0.0, 1.0),
    "red": (1.0, 0.0, 0.0, 1.0),
    "green": (0.0, 1.0, 0.0, 1.0),
    "blue": (0.0, 0.0, 1.0, 1.0),
    "yellow": (1.0, 1.0, 0.0, 1.0),
    "orange": (1.0, 0.5088, 0.0468, 1.0),
    "purple": (1.0, 0.0, 1.0, 1.0),
    "turquoise": (0.0, 1.0, 1.0, 1.0),
    "wood": (0.66, 0.47, 0.26, 1.0),
}
# Convexity threshold: a part whose volume is this fraction of its hull's is convex.
CONVEX_FRACTION = 0.95
PRISM_DEPTH = 0.01  # [m] of a face's collision prism
PRISM_FACES = np.array(
    [[0, 1, 2], [3, 5, 4], [0, 3, 1], [1, 3, 4], [1, 4, 2], [2, 4, 5], [2, 5, 0], [0, 5, 3]]
)
# A concave part of more faces than this is one non-convex mesh: Drake collides with its
# true surface under hydroelastic contact, with its convex hull under point contact.
MAX_PRISMS = 128
# Bounded work. The course's race field holds 13 models, 14 links and meshes of at most
# 104 collision pieces; a house or warehouse world of Gazebo's samples, about a hundred
# models of a few links each.
MAX_WORLD_FILE_BYTES = 64 * 2**20  # [bytes] of one world or model file (SDFormat text)
# <link>, <collision> and <visual> elements of a world: Drake's SDFormat parser grows
# about with the square of a model's links (1,000 links take 3 s of CPU, 3,000 take 25 s).
MAX_WORLD_ELEMENTS = 4_000
# Models (each a model instance of the plant; an <include> is one): Drake's diagram build
# grows about with the cube of their number (150 take 3 s, 300 take 20 s on one core).
MAX_WORLD_MODELS = 200
MAX_MESH_PARTS = 2_000  # separate (connected) parts of one collision mesh
MAX_MESH_PIECES = 6_000  # collision pieces (hulls, prisms) one collision mesh makes
ELEMENT_TAGS = ("link", "collision", "visual")
DEFAULT_FRICTION = 1.0  # Gazebo's default mu
# A <plane> becomes a box slab (Drake 1.51's HalfSpace crashes its proximity engine once a
# dozen static models follow it; see docs/worlds.md): at least this wide, this deep
# below the plane (collision), this thin (visual).
PLANE_MIN_SIZE = 100.0  # [m]
PLANE_SLAB_DEPTH = 0.1  # [m]
PLANE_VISUAL_DEPTH = 0.01  # [m]

BUILTIN_MODELS = {
    "ground_plane": """<sdf version="1.6"><model name="ground_plane"><static>true</static>
  <link name="link">
    <collision name="collision"><pose>0 0 -0.05 0 0 0</pose>
      <geometry><box><size>100 100 0.1</size></box></geometry></collision>
    <visual name="visual"><pose>0 0 -0.005 0 0 0</pose>
      <geometry><box><size>100 100 0.01</size></box></geometry>
      <material><diffuse>0.8 0.8 0.8 1</diffuse></material></visual>
  </link></model></sdf>""",
    "sun": None,  # a light: nothing to add
}


class WorldError(DescriptionError):
    """A world file that cannot be loaded; one line naming the file, line and value."""


@dataclass
class LoadedWorld:
    """What :func:`load_world` put into the plant."""

    source: Path
    name: str  # the <world name>
    models: dict[str, ModelInstanceIndex] = field(default_factory=dict)  # by include name
    ignored: list[str] = field(default_factory=list)  # world elements not simulated
    warnings: list[str] = field(default_factory=list)
    planes: list[str] = field(default_factory=list)  # models whose <plane> became a slab
    builtins: list[str] = field(default_factory=list)  # include URIs found nowhere, built in


@dataclass
class _Resources:
    """Where ``model://`` and ``package://`` URIs point."""

    roots: list[tuple[str, Path]]
    packages: PackageSearch

    def searched(self) -> str:
        return "; ".join(f"{label}: {path}" for label, path in self.roots) or "(nothing)"

    def model_dir(self, name: str) -> Path | None:
        for _, root in self.roots:
            if (root / name).is_dir():
                return root / name
        if name in self.packages.packages:
            return self.packages.packages[name]
        return None

    def resolve(self, uri: str, base: Path) -> Path | None:
        """The file a mesh or texture URI names (None if it is nowhere)."""
        uri = uri.strip()
        for scheme in ("model://", "package://"):
            if uri.startswith(scheme):
                name, _, rest = uri[len(scheme) :].partition("/")
                folder = self.model_dir(name)
                return folder / rest if folder is not None else None
        if uri.startswith("file://"):
            uri = uri[len("file://") :]
        path = Path(uri).expanduser()
        return path if path.is_absolute() else base / path


def resource_roots(world: Path, extra=()) -> list[tuple[str, Path]]:
    """The folders ``model://NAME`` is looked for in, in order (see the module docstring)."""
    roots = []
    for variable in RESOURCE_PATH_VARIABLES:
        for entry in filter(None, os.environ.get(variable, "").split(os.pathsep)):
            roots.append((variable, Path(entry).expanduser()))
    roots += [("world_resource_paths", Path(entry).expanduser()) for entry in extra]
    folder = world.resolve().parent
    for candidate in [folder, *list(folder.parents)[:3]]:
        if (candidate / "package.xml").is_file() or (candidate / "models").is_dir():
            roots.append(("models of the world's package", candidate / "models"))
            break
    roots.append(("next to the world", folder))
    return [(label, path) for label, path in roots if path.is_dir()]


def _fuel_model(uri: str) -> Path | None:
    """The newest version of a Fuel model in Gazebo's cache, by its URL."""
    match = re.match(r"https?://([^/]+)/(?:[^/]+/)?([^/]+)/models/([^/]+)", uri)
    if not match:
        return None
    host, owner, name = match.groups()
    name = name.replace("%20", " ")
    for cache in FUEL_CACHES:
        folder = Path(cache).expanduser() / host / owner.lower() / "models" / name.lower()
        versions = sorted((p for p in folder.glob("*") if p.is_dir()), key=lambda p: p.name)
        if versions:
            return versions[-1]
    return None


def _model_file(folder: Path) -> Path | None:
    """The SDFormat file of a model folder: ``model.config``'s newest ``<sdf>``, else
    ``model.sdf``, else the folder's only ``.sdf``."""
    config = folder / "model.config"
    if config.is_file():
        try:
            entries = ET.parse(config).getroot().findall("sdf")
        except ET.ParseError:
            entries = []
        entries.sort(key=lambda e: [int(n) for n in re.findall(r"\d+", e.get("version", "0"))])
        for entry in reversed(entries):
            if entry.text and (folder / entry.text.strip()).is_file():
                return folder / entry.text.strip()
    if (folder / "model.sdf").is_file():
        return folder / "model.sdf"
    files = sorted(folder.glob("*.sdf"))
    return files[0] if len(files) == 1 else None  # a FIFO too: refused as it is read


def model_file_of(folder: Path) -> Path | None:
    """The SDFormat file of a model folder (see :func:`_model_file`)."""
    return _model_file(folder)


def _xml_text(path: Path, where: str) -> str:
    """The text of an SDFormat file; one line naming it when it is unreadable, binary, not
    a regular file (a FIFO) or over :data:`MAX_WORLD_FILE_BYTES`."""
    try:
        return read_text_file(path, what=where, max_bytes=MAX_WORLD_FILE_BYTES)
    except FileInputError as error:
        raise WorldError(str(error)) from None
    except OSError as error:
        raise WorldError(f"{path}: cannot read {where}: {error.strerror}") from None
    except UnicodeDecodeError:
        raise WorldError(f"{path}: {where} is not a text (SDFormat) file") from None


def _poses_without_frame(model: ET.Element) -> None:
    """SDFormat 1.6's ``<pose frame="...">`` as SDFormat 1.7 converts it, in place: an
    empty frame (the default, the parent's) is dropped, another one becomes
    ``relative_to`` (Drake reads the model as SDFormat 1.9, which has no ``frame``)."""
    for pose in model.iter("pose"):
        frame = pose.attrib.pop("frame", None)
        if frame and frame.strip() and not pose.get("relative_to"):
            pose.set("relative_to", frame.strip())


def _floats(text: str | None, count: int, where: str) -> list[float]:
    try:
        values = [float(v) for v in (text or "").split()]
    except ValueError:
        values = []
    if len(values) != count:
        raise WorldError(f"{where}: {text!r} is not {count} numbers")
    return values


@dataclass
class _MeshCollision:
    """A mesh ``<collision>`` taken out of a model, added as convex pieces after parsing."""

    model: str  # the scoped model instance name
    link: str
    name: str  # the <collision>'s own name
    X_LC: RigidTransform
    path: Path
    scale: np.ndarray
    mu: float


class _WorldReader:
    """Reads one world file into a plant (see the module docstring)."""

    def __init__(self, plant: MultibodyPlant, path: Path, resources: _Resources):
        self.plant, self.path, self.resources = plant, path, resources
        self.stripped: set[str] = set()
        self.collisions: list[_MeshCollision] = []
        self.warnings: list[str] = []
        self.lines: dict[ET.Element, int] = {}
        self.planes: list[str] = []  # scoped names of the models whose <plane> became a slab
        self.including: list[Path] = [path.resolve()]  # the files being read, outermost first
        self.elements = 0  # links and geometries read so far (MAX_WORLD_ELEMENTS)
        self.models = 0  # models and includes read so far (MAX_WORLD_MODELS)
        self.builtins: list[str] = []  # include URIs replaced by a built-in model

    def where(self, element: ET.Element) -> str:
        return f"{self.path}:{self.lines.get(element, 0)}"

    def count(self, root: ET.Element, source: Path, included: bool = False) -> None:
        """Adds the models (an ``<include>`` is one, before it is read: an ``included``
        model ``root`` is not counted again) and the links and geometries under ``root``
        (read from ``source``) to the world's counts; refuses
        the world past :data:`MAX_WORLD_MODELS` or :data:`MAX_WORLD_ELEMENTS`, before
        Drake sees any."""
        tags = [e.tag for e in root.iter()]
        self.models += sum(1 for tag in tags if tag in ("model", "include")) - included
        self.elements += sum(1 for tag in tags if tag in ELEMENT_TAGS)
        if self.models > MAX_WORLD_MODELS:
            raise WorldError(
                f"{self.path}: about {self.models} models (<model>, <include>) by {source}, "
                f"over the limit of {MAX_WORLD_MODELS} a world may hold (Drake's diagram "
                "takes minutes to build past it; merge static models into one)"
            )
        if self.elements > MAX_WORLD_ELEMENTS:
            raise WorldError(
                f"{self.path}: about {self.elements} links and geometries (<link>, "
                f"<collision>, <visual>) by {source}, over the limit of "
                f"{MAX_WORLD_ELEMENTS} a world may hold"
            )

    # ---- includes --------------------------------------------------------

    def included_model(self, include: ET.Element) -> tuple[ET.Element, Path] | None:
        """The ``<model>`` an include names, with the include's name, pose and static, and
        the file it was read from (its nested includes not yet resolved)."""
        uri = (include.findtext("uri") or "").strip()
        where = f"{self.where(include)}: <include> {uri or '(no <uri>)'}"
        if not uri:
            raise WorldError(f"{where}: the include has no <uri>")
        name = uri.rstrip("/").split("/")[-1]
        if uri.startswith(("model://", "package://")):
            folder = self.resources.model_dir(uri.split("://", 1)[1].split("/")[0])
        elif uri.startswith(("http://", "https://")):
            folder = _fuel_model(uri) or self.resources.model_dir(name.lower().replace(" ", "_"))
            name = name.lower().replace("%20", "_").replace(" ", "_")
        else:
            candidate = self.resources.resolve(uri, self.path.parent)
            folder = candidate if candidate is not None and candidate.exists() else None
        if folder is None and name in BUILTIN_MODELS:
            text = BUILTIN_MODELS[name]
            if text is None:
                self.stripped.add(f"include {name} (a light)")
                return None
            model = ET.fromstring(text).find("model")
            model_file = self.path
            self.builtins.append(uri)
        else:
            if folder is None:
                raise WorldError(
                    f"{where}: model not found (looked in {self.resources.searched()}; "
                    "add its folder to GZ_SIM_RESOURCE_PATH or world_resource_paths)"
                )
            model_file = folder if folder.is_file() else _model_file(folder)
            if model_file is None:
                raise WorldError(f"{where}: {folder} has no model.config or model.sdf")
            if model_file.resolve() in self.including:
                chain = " -> ".join(str(f) for f in [*self.including, model_file.resolve()])
                raise WorldError(f"{where}: {model_file} includes itself ({chain})")
            root, _ = parse_with_lines(
                _xml_text(model_file, f"the model of {where}"), str(model_file)
            )
            model = root if root.tag == "model" else root.find("model")
            if model is None:
                raise WorldError(f"{where}: {model_file} has no <model>")
            self.count(model, model_file, included=True)
        for tag in ("name", "pose", "static"):
            value = include.find(tag)
            if value is not None and (value.text or "").strip():
                if tag == "name":
                    model.set("name", value.text.strip())
                    continue
                old = model.find(tag)
                if old is not None:
                    model.remove(old)
                model.insert(0, value)
        return model, model_file

    # ---- model edits -----------------------------------------------------

    def rewrite(
        self, model: ET.Element, model_file: Path, scope: str = "", static: bool = False
    ) -> None:
        """Edits one model (and its nested models, at any depth) for Drake, in place.

        ``scope`` is the scoped name of the enclosing model (Drake names a nested model
        instance ``outer::inner``); a model inside a static model is static, as SDFormat
        says, so ``<static>true</static>`` is written into it."""
        name = model.get("name", "").strip()
        model.set("name", name)
        scoped = f"{scope}::{name}" if scope else name
        _poses_without_frame(model)
        static = static or (model.findtext("static") or "").strip().lower() in ("true", "1")
        if static and scope:
            for old in model.findall("static"):
                model.remove(old)
            element = ET.Element("static")
            element.text = "true"
            model.insert(0, element)
        if static:
            # A static model does not move: Gazebo never reads its links' inertia, which
            # published worlds leave invalid (a floor of 1000 kg with moments that fail
            # the triangle inequality), and Drake would refuse.
            for link in model.findall("link"):
                for inertial in link.findall("inertial"):
                    link.remove(inertial)
        for child in list(model):
            if child.tag == "include":
                index = list(model).index(child)
                model.remove(child)
                included = self.included_model(child)
                if included is not None:
                    nested, nested_file = included
                    model.insert(index, nested)
                    self.including.append(nested_file.resolve())
                    self.rewrite(nested, nested_file, scoped, static)
                    self.including.pop()
            elif child.tag == "model":
                self.rewrite(child, model_file, scoped, static)
        for child in list(model):
            if child.tag == "model":
                continue
            if child.tag in STRIPPED_ELEMENTS:
                model.remove(child)
                self.stripped.add(child.tag)
                continue
            for parent in list(child.iter()):
                for element in list(parent):
                    if element.tag in STRIPPED_ELEMENTS:
                        parent.remove(element)
                        self.stripped.add(element.tag)
        for link in model.findall("link"):
            for element in link.findall("collision") + link.findall("visual"):
                if element.find("geometry/plane") is not None:
                    plane_to_slab(element, f"{model_file}: <plane>")
                    self.planes.append(scoped)
            for visual in link.findall("visual"):
                self.visual(visual, model_file)
            for collision in link.findall("collision"):
                self.collision(scoped, link, collision, model_file)

    def mesh_file(self, mesh: ET.Element, model_file: Path) -> Path:
        uri = (mesh.findtext("uri") or "").strip()
        path = self.resources.resolve(uri, model_file.parent)
        if path is None or not path.is_file():
            raise WorldError(f"{model_file}: mesh {uri!r} not found")
        return path

    def visual(self, visual: ET.Element, model_file: Path) -> None:
        geometry = visual.find("geometry")
        mesh = geometry.find("mesh") if geometry is not None else None
        if mesh is not None:
            mesh.find("uri").text = convert_mesh(self.mesh_file(mesh, model_file)).path.as_uri()
        material = visual.find("material")
        if material is None:
            return
        texture = self.texture(material, model_file)
        script = material.find("script")
        if script is not None:
            material.remove(script)
            color = NAMED_COLORS.get((script.findtext("name") or "").split("/")[-1].lower())
            if color and material.find("diffuse") is None:
                ET.SubElement(material, "diffuse").text = " ".join(map(str, color))
        if material.text and material.text.strip():  # <material>Gazebo/White</material>
            color = NAMED_COLORS.get(material.text.strip().split("/")[-1].lower())
            material.text = None
            if color:
                ET.SubElement(material, "diffuse").text = " ".join(map(str, color))
        for tag in ("pbr", "shader", "lighting", "double_sided"):
            for child in material.findall(tag):
                material.remove(child)
        box = geometry.find("box") if geometry is not None else None
        if texture is not None and box is not None:
            size = _floats(box.findtext("size"), 3, f"{model_file}: <box><size>")
            geometry.remove(box)
            mesh = ET.SubElement(geometry, "mesh")
            ET.SubElement(mesh, "uri").text = textured_box(size, texture).as_uri()
            visual.remove(material)  # the MTL's texture, not a colour, is drawn
        elif texture is not None:
            shape = geometry[0].tag if geometry is not None and len(geometry) else "?"
            self.warnings.append(
                f"{model_file}: texture {texture.name} on a {shape} visual is not drawn "
                "(textures are drawn on boxes and on meshes' own materials)"
            )

    def texture(self, material: ET.Element, model_file: Path) -> Path | None:
        """The image of a classic material script or of a PBR albedo map (None if none)."""
        albedo = material.findtext("pbr/metal/albedo_map") or material.findtext(
            "pbr/specular/albedo_map"
        )
        if albedo and albedo.strip():
            path = self.resources.resolve(albedo, model_file.parent)
            return path if path is not None and path.is_file() else None
        script = material.find("script")
        if script is None:
            return None
        name = (script.findtext("name") or "").strip()
        folders = [
            self.resources.resolve(u.text or "", model_file.parent) for u in script.iter("uri")
        ]
        folders = [f for f in folders if f is not None and f.is_dir()]
        for folder in folders:
            for script_file in sorted(folder.glob("*.material")):
                image = _script_texture(script_file.read_text(errors="replace"), name)
                for candidate in folders:
                    if image and (candidate / image).is_file():
                        return candidate / image
        return None

    def collision(
        self, model: str, link: ET.Element, collision: ET.Element, model_file: Path
    ) -> None:
        """A mesh collision is taken out, to be added as convex pieces after parsing."""
        mesh = collision.find("geometry/mesh")
        if mesh is None:
            return
        pose = collision.find("pose")
        if pose is not None and pose.get("relative_to"):
            declare = ET.SubElement(mesh, "drake:declare_convex")
            declare.text = None
            mesh.find("uri").text = convert_mesh(self.mesh_file(mesh, model_file)).path.as_uri()
            return
        values = _floats(pose.text, 6, f"{model_file}: <pose>") if pose is not None else [0] * 6
        scale = mesh.findtext("scale")
        scale3 = np.array(_floats(scale, 3, f"{model_file}: <scale>") if scale else [1, 1, 1])
        mu = collision.findtext("surface/friction/ode/mu") or collision.findtext(
            "surface/friction/bullet/friction"
        )
        self.collisions.append(
            _MeshCollision(
                model=model,
                link=link.get("name", ""),
                name=(collision.get("name") or "").strip(),
                X_LC=RigidTransform(RollPitchYaw(values[3:]), values[:3]),
                path=self.mesh_file(mesh, model_file),
                scale=scale3,
                mu=float(mu) if mu else DEFAULT_FRICTION,
            )
        )
        link.remove(collision)

    # ---- the world -------------------------------------------------------

    def read(self) -> LoadedWorld:
        text = _xml_text(self.path, "the world file")
        root, self.lines = parse_with_lines(text, str(self.path))
        world = root.find("world") if root.tag == "sdf" else None
        if world is None:
            raise WorldError(f"{self.path}: no <sdf><world> (is it a model file?)")
        loaded = LoadedWorld(source=self.path, name=world.get("name", ""))
        self.count(world, self.path)
        models: list[tuple[str, ET.Element]] = []
        for element in world:
            if not isinstance(element.tag, str):
                continue
            if element.tag not in SCENE_ELEMENTS:
                loaded.ignored.append(element.tag)
                continue
            where = self.where(element)
            included = (element, self.path) if element.tag == "model" else None
            if element.tag == "include":
                included = self.included_model(element)
            if included is not None:
                self.including.append(included[1].resolve())
                self.rewrite(*included)
                self.including.pop()
                models.append((where, included[0]))
        for where, model in models:
            name = model.get("name", "").strip()
            model.set("name", name)
            if name in loaded.models:
                raise WorldError(f"{where}: model name {name!r} is used twice")
            loaded.models[name] = self.add(model, where)
        self.add_collisions(loaded)
        loaded.ignored += sorted(self.stripped)
        loaded.warnings = self.warnings
        loaded.planes = list(dict.fromkeys(self.planes))
        loaded.builtins = list(dict.fromkeys(self.builtins))
        return loaded

    def add(self, model: ET.Element, where: str) -> ModelInstanceIndex:
        sdf = ET.Element("sdf", version="1.9")
        sdf.append(model)
        text = ET.tostring(sdf, encoding="unicode").replace(
            "<sdf ", '<sdf xmlns:drake="http://drake.mit.edu" ', 1
        )
        try:
            # A model with nested models is one instance per model, the outer one first.
            instance = Parser(self.plant).AddModelsFromString(text, "sdf")[0]
        except Exception as error:  # Drake's parser raises RuntimeError with its diagnostic
            message = " ".join(str(error).split())
            raise WorldError(
                f"{where}: Drake could not load model {model.get('name')!r}: {message}"
            ) from None
        return instance

    def add_collisions(self, loaded: LoadedWorld) -> None:
        plant = self.plant
        used: set[tuple[str, str]] = set()
        for item in self.collisions:
            model, link, X_LC, path, mu = item.model, item.link, item.X_LC, item.path, item.mu
            scale = item.scale
            instance = loaded.models.get(model) or plant.GetModelInstanceByName(model)
            body = plant.GetBodyByName(link, instance)
            friction = CoulombFriction(mu, mu)
            pieces = convex_pieces(path, tuple(scale))
            concave = sum(1 for convex, _ in pieces if not convex)
            if concave:
                self.warnings.append(
                    f"{path.name} of {model!r}: {concave} concave part(s) of over {MAX_PRISMS} "
                    "faces collide as their convex hull under point contact (their true "
                    "surface under hydroelastic contact)"
                )
            # Named by the <collision>'s own name (unique in its link, as SDFormat says;
            # a repeated or missing name gets a number).
            stem = f"{link}_{item.name or path.stem}"
            base, count = stem, 1
            while (model, stem) in used:
                count += 1
                stem = f"{base}{count}"
            used.add((model, stem))
            for index, (convex, piece) in enumerate(pieces):
                # A file, not an in-memory mesh: Drake 1.51's proximity engine crashes when
                # it copies a Convex of an InMemoryMesh once an earlier plant is freed.
                data = _piece_file(piece)
                name = f"{stem}_{index}"
                if convex:
                    plant.RegisterCollisionGeometry(body, X_LC, Convex(data), name, friction)
                    continue
                properties = ProximityProperties()
                AddContactMaterial(friction=friction, properties=properties)
                AddRigidHydroelasticProperties(properties=properties)
                plant.RegisterCollisionGeometry(body, X_LC, Mesh(data), name, properties)


def plane_to_slab(element: ET.Element, where: str) -> None:
    """Turns the ``<plane>`` of a ``<collision>`` or ``<visual>`` into the project's box
    slab, in place: its top face on the plane (through the element's pose, facing the
    plane's ``<normal>``), at least :data:`PLANE_MIN_SIZE` wide (a plane is infinite to
    Gazebo), :data:`PLANE_SLAB_DEPTH` deep (collision) or :data:`PLANE_VISUAL_DEPTH`
    (visual). Friction and material are kept."""
    geometry = element.find("geometry")
    plane = geometry.find("plane")
    normal = np.array(_floats(plane.findtext("normal") or "0 0 1", 3, f"{where}<normal>"))
    if not np.linalg.norm(normal) > 0:
        raise WorldError(f"{where}<normal>: {plane.findtext('normal')!r} is not a direction")
    size = _floats(plane.findtext("size") or "100 100", 2, f"{where}<size>")
    depth = PLANE_SLAB_DEPTH if element.tag == "collision" else PLANE_VISUAL_DEPTH
    pose = element.find("pose")
    values = _floats(pose.text, 6, f"{where}<pose>") if pose is not None else [0.0] * 6
    X_LP = RigidTransform(RollPitchYaw(values[3:]), values[:3])
    R_PS = RotationMatrix.MakeFromOneVector(normal / np.linalg.norm(normal), 2)
    X_LS = X_LP @ RigidTransform(R_PS, [0, 0, 0]) @ RigidTransform([0, 0, -depth / 2])
    if pose is None:
        pose = ET.SubElement(element, "pose")
    rpy = RollPitchYaw(X_LS.rotation()).vector()
    pose.text = " ".join(f"{v:.17g}" for v in [*X_LS.translation(), *rpy])
    geometry.remove(plane)
    box = ET.SubElement(geometry, "box")
    width = [max(PLANE_MIN_SIZE, v) for v in size]
    ET.SubElement(box, "size").text = f"{width[0]:g} {width[1]:g} {depth:g}"


def _piece_file(piece: bytes) -> str:
    """The OBJ file of a collision piece in the mesh cache, named by its content."""
    folder = cache_dir() / "pieces"
    path = folder / f"{hashlib.sha256(piece).hexdigest()[:32]}.obj"
    if not path.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        temporary = path.with_suffix(f".{os.getpid()}.tmp")
        temporary.write_bytes(piece)
        os.replace(temporary, path)
    return str(path)


def _script_texture(text: str, name: str) -> str | None:
    """The ``texture`` image of material ``name`` in an OGRE material script."""
    match = re.search(r"material\s+" + re.escape(name) + r"\s*(?::\s*\S+\s*)?\{", text)
    if not match:
        return None
    found = re.search(r"\btexture\s+(\S+)", text[match.end() :])
    return found.group(1) if found else None


def _obj(vertices: np.ndarray, faces: np.ndarray) -> str:
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    return "\n".join(lines) + "\n"


@functools.lru_cache(maxsize=256)
def convex_pieces(path: Path, scale: tuple[float, float, float]) -> tuple[tuple[bool, bytes], ...]:
    """The collision pieces of a mesh, each (convex, OBJ text); see the module docstring.
    A concave part of more than :data:`MAX_PRISMS` faces is one non-convex piece."""
    import trimesh

    mesh = load_mesh(path)  # in metres by its Collada <unit>, as the visual's OBJ
    mesh.merge_vertices(merge_tex=True, merge_norm=True)  # connected through shared corners
    mesh.apply_scale(np.asarray(scale, dtype=float))
    labels = trimesh.graph.connected_component_labels(
        mesh.face_adjacency, node_count=len(mesh.faces)
    )
    parts, sizes = np.unique(labels, return_counts=True)
    if len(parts) > MAX_MESH_PARTS:
        raise WorldError(
            f"{path}: {len(parts)} separate parts in the collision mesh, over the limit of "
            f"{MAX_MESH_PARTS} (each becomes collision pieces: join or simplify the mesh)"
        )
    # At most: one piece per large or convex part, one prism per face of a small one.
    estimate = int(np.where(sizes > MAX_PRISMS, 1, sizes).sum())
    if estimate > MAX_MESH_PIECES:
        raise WorldError(
            f"{path}: its collision mesh would make up to {estimate} collision pieces "
            f"({len(parts)} parts), over the limit of {MAX_MESH_PIECES}"
        )
    pieces = []
    for label in parts:
        part = trimesh.Trimesh(mesh.vertices, mesh.faces[labels == label], process=True)
        try:
            hull = part.convex_hull
            convex = part.is_watertight and part.volume >= CONVEX_FRACTION * hull.volume
        except Exception:  # a flat or degenerate part has no hull
            convex = False
        if convex:
            pieces.append((True, _obj(hull.vertices, hull.faces).encode()))
        elif len(part.faces) > MAX_PRISMS:
            pieces.append((False, _obj(part.vertices, part.faces).encode()))
        else:
            for triangle, normal in zip(part.triangles, part.face_normals, strict=True):
                prism = np.vstack([triangle, triangle - PRISM_DEPTH * normal])
                pieces.append((True, _obj(prism, PRISM_FACES).encode()))
    return tuple(pieces)


def textured_box(size: list[float], image: Path) -> Path:
    """An OBJ box of ``size`` with ``image`` on each face (cached by size and image)."""
    digest = hashlib.sha256(image.read_bytes() + repr(size).encode()).hexdigest()[:16]
    folder = cache_dir() / "textured"
    obj = folder / f"box-{digest}.obj"
    if obj.is_file():
        return obj
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(image, folder / f"box-{digest}{image.suffix}")
    half = np.asarray(size, dtype=float) / 2
    lines = ["mtllib " + f"box-{digest}.mtl", "usemtl face"]
    lines += ["vt 0 0", "vt 1 0", "vt 1 1", "vt 0 1"]
    count = 0
    for axis in range(3):
        for sign in (1.0, -1.0):
            u_axis, v_axis = [(1, 2), (2, 0), (0, 1)][axis]
            if sign < 0:
                u_axis, v_axis = v_axis, u_axis
            normal = np.zeros(3)
            normal[axis] = sign
            lines.append("vn {:g} {:g} {:g}".format(*normal))
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                corner = normal * half
                corner[u_axis] = du * half[u_axis]
                corner[v_axis] = dv * half[v_axis]
                lines.append("v {:.9g} {:.9g} {:.9g}".format(*corner))
            n = count // 4 + 1
            a = count + 1
            lines.append(f"f {a}/1/{n} {a + 1}/2/{n} {a + 2}/3/{n} {a + 3}/4/{n}")
            count += 4
    (folder / f"box-{digest}.mtl").write_text(
        f"newmtl face\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nmap_Kd box-{digest}{image.suffix}\n"
    )
    obj.write_text("\n".join(lines) + "\n")
    return obj


def load_world(
    plant: MultibodyPlant, path: str | os.PathLike, *, resource_paths=(), package_paths=()
) -> LoadedWorld:
    """Adds every model of the world file ``path`` to ``plant`` (before ``Finalize``);
    ignored world elements are named in one warning line. ``package_paths``: the ROS
    package folders (``--package-path``) its ``package://`` and ``model://`` URIs may
    name, searched as for the robot description."""
    path = Path(path).expanduser()
    if not path.exists():  # one that is not a regular file (a FIFO) is refused as read
        raise WorldError(f"{path}: the world file does not exist")
    search = find_packages([*package_paths, *resource_paths], near=path)
    resources = _Resources(resource_roots(path, resource_paths), search)
    reader = _WorldReader(plant, path, resources)
    loaded = reader.read()
    if loaded.ignored:
        _log.warning(
            "%s: not simulated, ignored: %s", path, ", ".join(dict.fromkeys(loaded.ignored))
        )
    for line in loaded.warnings:
        _log.warning("%s", line)
    if loaded.builtins:
        _log.info(
            "%s: %s found nowhere on the resource path: the built-in ground (a 100 m box "
            "slab, 0.1 m deep) is used",
            path,
            ", ".join(loaded.builtins),
        )
    if loaded.planes:
        _log.info(
            "%s: the <plane> ground of %s is a %g m deep box slab (Drake's HalfSpace "
            "can crash its proximity engine; docs/worlds.md)",
            path,
            ", ".join(loaded.planes),
            PLANE_SLAB_DEPTH,
        )
    _log.info("world %s: %d models from %s", loaded.name, len(loaded.models), path)
    return loaded


def AddWorld(
    plant: MultibodyPlant,
    world_file: str,
    *,
    resource_paths=(),
    package_paths=(),
    where: str = "",
) -> LoadedWorld:
    """The scenario's ``world_file`` (a path, or ``package://pkg/worlds/x.sdf``) as the
    scene; ``where``: the key's origin, named when the file is not there.
    ``package_paths`` (the robots', with ``--package-path``) and ``resource_paths`` are
    searched for ``package://`` as the robot description's packages are
    (:func:`~armando_drake.description.packages.find_packages`)."""
    path = Path(world_file).expanduser()
    if world_file.startswith("package://"):
        package, _, rest = world_file[len("package://") :].partition("/")
        search = find_packages([*package_paths, *resource_paths])
        if package not in search.packages:
            raise WorldError(
                f"{where}world_file={world_file!r}: unknown package {package!r} "
                f"(searched {'; '.join(search.searched)})"
            )
        path = search.packages[package] / rest
    if not path.exists():
        raise WorldError(f"{where}world_file={world_file!r}: no such file")
    return load_world(plant, path, resource_paths=resource_paths, package_paths=package_paths)
