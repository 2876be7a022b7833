"""A robot described in SDFormat (Gazebo Sim's ``model.sdf``) as the URDF the loader reads.

Gazebo Sim spawns robots from model folders whose ``model.sdf`` carries the robot's
systems (DiffDrive, JointStatePublisher, ...) and sensors (``gpu_lidar``, ``camera``,
``imu``). :func:`sdf_to_urdf` writes the model as a URDF so that the rest of the loader
(meshes, collision modes, inertia repairs, the hardware interface, the drives and
sensors of ``<gazebo>`` blocks) treats it as it treats a URDF:

- each ``<link>`` is a URDF link; a link that is a joint's child takes the joint's
  frame (URDF's rule), so its inertial, visuals, collisions and sensors are re-expressed
  in that frame. Poses follow SDFormat: a link's ``<pose>`` is in the model frame, a
  joint's in its child link's, an inertial's, visual's, collision's or sensor's in its
  link's; ``relative_to`` may name the model, a link, a joint or a ``<frame>``.
- joints: ``revolute`` (``continuous`` when it has no finite limits), ``continuous``,
  ``prismatic`` and ``fixed`` as in URDF; the axis is in the joint frame (SDFormat 1.4's
  ``use_parent_model_frame`` and 1.7's ``expressed_in`` are turned into it). A ``ball``
  joint (a caster) becomes fixed with a frictionless contact, rolling as the ball does.
  A joint to ``world`` welds the robot.
- geometry: box, cylinder, sphere, mesh (``model://`` and ``package://`` URIs resolved
  through the model resource path, the folders around the model and the ROS packages),
  capsule as its bounding cylinder; ``<diffuse>`` colours kept; a collision's
  ``<surface><friction><ode><mu>`` is the link's ``<mu1>``.
- the model's ``<plugin>`` blocks go into ``<gazebo>``, each link's ``<sensor>`` blocks
  into ``<gazebo reference="LINK">``: exactly where a URDF keeps them.

What the URDF cannot hold (nested models, ``<frame>``-attached sensors, other joint
types) is one error line naming the file and the element.
"""

from __future__ import annotations

import copy
import logging
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

from armando_drake.description.importer import parse_with_lines
from armando_drake.description.packages import DescriptionError, PackageSearch
from armando_drake.description.worlds import model_file_of, resource_roots

LOGGER = logging.getLogger("armando_drake.description")

# A revolute joint whose limits are beyond these is continuous (SDFormat's default
# limits are +-1e16).
UNLIMITED = 1e15
MODEL_FRAME = "__model__"


def is_sdf_model(path: Path) -> bool:
    """Whether ``path`` is an SDFormat robot: a ``.sdf`` file, or a model folder (one
    with ``model.config`` or ``model.sdf``)."""
    if path.is_dir():
        return (path / "model.config").is_file() or (path / "model.sdf").is_file()
    return path.suffix == ".sdf"


def sdf_model_file(folder: Path) -> Path:
    """The SDFormat file of a model folder (``model.config``'s newest, else model.sdf)."""
    found = model_file_of(folder)
    if found is None:
        raise DescriptionError(f"{folder}: a model folder without model.config or model.sdf")
    return found


def _pose(element: ET.Element | None, where: str) -> RigidTransform:
    text = element.findtext("pose") if element is not None else None
    if not text or not text.strip():
        return RigidTransform()
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != 6:
        raise DescriptionError(f"{where}: <pose> {text.strip()!r} is not 6 numbers")
    return RigidTransform(RollPitchYaw(values[3:]), values[:3])


def _origin(X: RigidTransform) -> ET.Element:
    rpy = RollPitchYaw(X.rotation()).vector()
    return ET.Element(
        "origin",
        xyz=" ".join(_text(v) for v in X.translation()),
        rpy=" ".join(_text(v) for v in rpy),
    )


def _text(value: float) -> str:
    """A number as URDF text: 9 digits, round-off below 1e-12 and -0 written as 0."""
    return f"{round(float(value), 12) + 0.0:.9g}"


class _MissingMesh(Exception):
    """A mesh URI that names no file (a visual without it is left out, as Gazebo does)."""


@dataclass
class _Frames:
    """The model-frame poses of the model's links, joints and ``<frame>`` elements."""

    model: ET.Element
    source: Path

    def __post_init__(self) -> None:
        self.elements = {}
        for tag in ("link", "joint", "frame"):
            for element in self.model.findall(tag):
                self.elements[element.get("name", "")] = element
        self.cache: dict[str, RigidTransform] = {}
        self.visiting: list[str] = []

    def default_base(self, element: ET.Element) -> str:
        if element.tag == "joint":
            return (element.findtext("child") or "").strip()
        if element.tag == "frame":
            return (element.get("attached_to") or "").strip() or MODEL_FRAME
        return MODEL_FRAME

    def X_M(self, name: str) -> RigidTransform:
        """The pose of the frame ``name`` in the model frame."""
        if name in ("", MODEL_FRAME):
            return RigidTransform()
        if name in self.cache:
            return self.cache[name]
        element = self.elements.get(name)
        if element is None or name in self.visiting:
            raise DescriptionError(
                f"{self.source}: frame {name!r} is not a link, joint or frame of the model"
                + (" (a loop of relative_to)" if name in self.visiting else "")
            )
        self.visiting.append(name)
        pose = element.find("pose")
        base = pose.get("relative_to", "").strip() if pose is not None else ""
        X = self.X_M(base or self.default_base(element)) @ _pose(
            element, f"{self.source}: <{element.tag} name={name!r}>"
        )
        self.visiting.pop()
        self.cache[name] = X
        return X


class _Writer:
    """Writes one SDFormat ``<model>`` as URDF (see the module docstring)."""

    def __init__(self, model: ET.Element, source: Path, resolve):
        self.model, self.source, self.resolve = model, source, resolve
        self.frames = _Frames(model, source)
        self.urdf = ET.Element("robot", name=model.get("name", "robot"))
        self.X_ML: dict[str, RigidTransform] = {}  # each URDF link frame in the model
        self.friction: dict[str, float] = {}
        self.notes: list[str] = []

    def where(self, element: ET.Element) -> str:
        return f"{self.source}: <{element.tag} name={element.get('name', '')!r}>"

    def write(self) -> ET.Element:
        for nested in self.model.findall("model") + self.model.findall("include"):
            raise DescriptionError(
                f"{self.where(nested)}: a nested model in a robot description is not "
                "supported; include the robot in a world instead"
            )
        joints = self.model.findall("joint")
        children = {(j.findtext("child") or "").strip(): j for j in joints}
        for link in self.model.findall("link"):
            name = link.get("name", "")
            joint = children.get(name)
            # A child link takes its joint's frame; a root link keeps its own.
            self.X_ML[name] = self.frames.X_M(joint.get("name") if joint is not None else name)
        for link in self.model.findall("link"):
            self.link(link)
        static = (self.model.findtext("static") or "").strip().lower() in ("true", "1")
        roots = [
            link.get("name", "")
            for link in self.model.findall("link")
            if link.get("name", "") not in children
        ]
        if static and roots:
            self.world_joint("static_model", roots[0], self.X_ML[roots[0]])
        for joint in joints:
            self.joint(joint)
        for plugin in self.model.findall("plugin"):
            ET.SubElement(self.urdf, "gazebo").append(copy.deepcopy(plugin))
        for link, mu in self.friction.items():
            gazebo = ET.SubElement(self.urdf, "gazebo", reference=link)
            ET.SubElement(gazebo, "mu1").text = _text(mu)
            ET.SubElement(gazebo, "mu2").text = _text(mu)
        return self.urdf

    # ---- links --------------------------------------------------------------

    def X_LE(self, link: ET.Element, element: ET.Element) -> RigidTransform:
        """The pose of a link's inertial, visual, collision or sensor in the URDF link."""
        name = link.get("name", "")
        pose = element.find("pose")
        base = pose.get("relative_to", "").strip() if pose is not None else ""
        X_MB = self.frames.X_M(base or name)
        return self.X_ML[name].inverse() @ X_MB @ _pose(element, self.where(element))

    def link(self, link: ET.Element) -> None:
        name = link.get("name", "")
        out = ET.SubElement(self.urdf, "link", name=name)
        inertial = link.find("inertial")
        if inertial is not None and inertial.find("mass") is not None:
            self.inertial(link, inertial, out)
        for visual in link.findall("visual"):
            self.shape(link, visual, out, "visual")
        for collision in link.findall("collision"):
            self.shape(link, collision, out, "collision")
            mu = collision.findtext("surface/friction/ode/mu")
            if mu is not None and mu.strip():
                self.friction[name] = min(self.friction.get(name, np.inf), float(mu))
        sensors = link.findall("sensor")
        if sensors:
            gazebo = ET.SubElement(self.urdf, "gazebo", reference=name)
            for sensor in sensors:
                copied = copy.deepcopy(sensor)
                for old in copied.findall("pose"):
                    copied.remove(old)
                X = self.X_LE(link, sensor)
                pose = ET.Element("pose")
                xyz = X.translation()
                rpy = RollPitchYaw(X.rotation()).vector()
                pose.text = " ".join(_text(v) for v in [*xyz, *rpy])
                copied.insert(0, pose)
                gazebo.append(copied)

    def inertial(self, link: ET.Element, inertial: ET.Element, out: ET.Element) -> None:
        element = ET.SubElement(out, "inertial")
        element.append(_origin(self.X_LE(link, inertial)))
        ET.SubElement(element, "mass", value=(inertial.findtext("mass") or "0").strip())
        values = {
            key: (inertial.findtext(f"inertia/{key}") or "0").strip()
            for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        }
        ET.SubElement(element, "inertia", **values)

    def shape(self, link: ET.Element, element: ET.Element, out: ET.Element, tag: str) -> None:
        geometry = element.find("geometry")
        if geometry is None or len(geometry) == 0:
            return
        kind = geometry[0]
        try:
            shape = self.geometry(kind, element)
        except _MissingMesh as missing:
            if tag == "collision":
                raise DescriptionError(str(missing)) from None
            self.notes.append(f"{missing}: the visual is left out")
            return
        if shape is None:
            return
        written = ET.SubElement(out, tag, name=element.get("name", ""))
        written.append(_origin(self.X_LE(link, element)))
        ET.SubElement(written, "geometry").append(shape)
        diffuse = element.findtext("material/diffuse")
        if tag == "visual" and diffuse and diffuse.strip():
            values = diffuse.split() + ["1"] * 4
            # SDFormat's visual names are unique within their link only; URDF's material
            # names are the robot's.
            name = f"{link.get('name', '')}_{element.get('name', '')}_color"
            material = ET.SubElement(written, "material", name=name)
            ET.SubElement(material, "color", rgba=" ".join(values[:4]))

    def geometry(self, kind: ET.Element, element: ET.Element) -> ET.Element | None:
        where = self.where(element)
        if kind.tag == "box":
            return ET.Element("box", size=(kind.findtext("size") or "1 1 1").strip())
        if kind.tag == "sphere":
            return ET.Element("sphere", radius=(kind.findtext("radius") or "1").strip())
        if kind.tag in ("cylinder", "capsule"):
            radius = float(kind.findtext("radius") or 1)
            length = float(kind.findtext("length") or 1)
            if kind.tag == "capsule":
                self.notes.append(f"{where}: a capsule is its bounding cylinder")
                length += 2 * radius
            return ET.Element("cylinder", radius=_text(radius), length=_text(length))
        if kind.tag == "mesh":
            uri = (kind.findtext("uri") or "").strip()
            path = self.resolve(uri)
            if path is None or not path.is_file():
                raise _MissingMesh(f"{where}: mesh {uri!r} not found")
            mesh = ET.Element("mesh", filename=f"file://{path}")
            scale = (kind.findtext("scale") or "").strip()
            if scale:
                mesh.set("scale", scale)
            return mesh
        if kind.tag in ("plane", "empty"):
            return None
        raise DescriptionError(f"{where}: <{kind.tag}> geometry is not supported")

    # ---- joints -------------------------------------------------------------

    def world_joint(self, name: str, child: str, X_WC: RigidTransform) -> None:
        if self.urdf.find("link[@name='world']") is None:
            self.urdf.insert(0, ET.Element("link", name="world"))
        joint = ET.SubElement(self.urdf, "joint", name=name, type="fixed")
        joint.append(_origin(X_WC))
        ET.SubElement(joint, "parent", link="world")
        ET.SubElement(joint, "child", link=child)

    def joint(self, joint: ET.Element) -> None:
        name = joint.get("name", "")
        kind = joint.get("type", "").strip()
        parent = (joint.findtext("parent") or "").strip()
        child = (joint.findtext("child") or "").strip()
        where = self.where(joint)
        if child not in self.X_ML:
            raise DescriptionError(f"{where}: child {child!r} is not a link of the model")
        if parent == "world":
            self.world_joint(name, child, self.X_ML[child])
            return
        if parent not in self.X_ML:
            raise DescriptionError(f"{where}: parent {parent!r} is not a link of the model")
        if kind == "ball":
            self.notes.append(
                f"{where}: a ball joint (a caster) is fixed, its contact frictionless"
            )
            self.friction[child] = 0.0
            kind = "fixed"
        if kind not in ("revolute", "continuous", "prismatic", "fixed"):
            raise DescriptionError(f"{where}: a {kind!r} joint is not supported")
        lower = float(joint.findtext("axis/limit/lower") or -1e16)
        upper = float(joint.findtext("axis/limit/upper") or 1e16)
        if kind == "revolute" and lower <= -UNLIMITED and upper >= UNLIMITED:
            kind = "continuous"
        out = ET.SubElement(self.urdf, "joint", name=name, type=kind)
        out.append(_origin(self.X_ML[parent].inverse() @ self.X_ML[child]))
        ET.SubElement(out, "parent", link=parent)
        ET.SubElement(out, "child", link=child)
        if kind == "fixed":
            return
        ET.SubElement(out, "axis", xyz=" ".join(_text(v) for v in self.axis(joint, child)))
        effort = float(joint.findtext("axis/limit/effort") or -1)
        velocity = float(joint.findtext("axis/limit/velocity") or -1)
        limit = {
            "effort": _text(effort if effort >= 0 else 0.0),
            "velocity": _text(velocity if velocity >= 0 else 0.0),
        }
        if kind != "continuous":
            limit.update(lower=_text(lower), upper=_text(upper))
        ET.SubElement(out, "limit", **limit)
        damping = joint.findtext("axis/dynamics/damping")
        friction = joint.findtext("axis/dynamics/friction")
        if damping or friction:
            ET.SubElement(
                out,
                "dynamics",
                damping=(damping or "0").strip(),
                friction=(friction or "0").strip(),
            )

    def axis(self, joint: ET.Element, child: str) -> np.ndarray:
        """The joint's axis in its own (the URDF child link's) frame."""
        xyz = joint.find("axis/xyz")
        text = xyz.text if xyz is not None and xyz.text else "0 0 1"
        axis = np.array([float(v) for v in text.split()])
        expressed = xyz.get("expressed_in", "").strip() if xyz is not None else ""
        parent_model = (joint.findtext("axis/use_parent_model_frame") or "").strip()
        if parent_model.lower() in ("true", "1"):
            expressed = MODEL_FRAME
        if expressed:
            R_MJ: RotationMatrix = self.X_ML[child].rotation()
            R_ME = self.frames.X_M(expressed).rotation()
            axis = R_MJ.inverse() @ R_ME @ axis
        return axis / np.linalg.norm(axis)


def sdf_to_urdf(path: Path, search: PackageSearch) -> str:
    """The URDF text of the SDFormat robot ``path`` (a ``.sdf`` file or a model folder);
    the conversion's notes are one info line."""
    path = Path(path)
    if path.is_dir():
        path = sdf_model_file(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise DescriptionError(f"{path}: cannot read the SDFormat file: {error}") from None
    root, _ = parse_with_lines(text, str(path))
    model = root if root.tag == "model" else root.find("model")
    if model is None:
        raise DescriptionError(f"{path}: no <model> (a world is a world_file, not a robot)")
    roots = [folder for _, folder in resource_roots(path)]
    roots.insert(0, path.resolve().parent.parent)  # model://NAME next to this model

    def resolve(uri: str) -> Path | None:
        for scheme in ("model://", "package://"):
            if uri.startswith(scheme):
                name, _, rest = uri[len(scheme) :].partition("/")
                for folder in roots:
                    if (folder / name).is_dir():
                        return folder / name / rest
                if name in search.packages:
                    return search.packages[name] / rest
                return None
        if uri.startswith("file://"):
            uri = uri[len("file://") :]
        candidate = Path(uri).expanduser()
        return candidate if candidate.is_absolute() else path.parent / candidate

    writer = _Writer(model, path, resolve)
    urdf = writer.write()
    if writer.notes:
        LOGGER.info("%s as URDF: %s", path.name, "; ".join(writer.notes))
    ET.indent(urdf)
    return ET.tostring(urdf, encoding="unicode")
