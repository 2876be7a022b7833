"""The URDF read as ROS reads it: joints and their limits, transmissions, the
``world`` link, the controller files a ``<gazebo>`` plugin names, the tags Drake
ignores; each repair or omission a warning."""

from __future__ import annotations

import contextlib
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw

from armando_drake.description.packages import DescriptionError


@dataclass
class JointInfo:
    """A non-fixed joint of the description, with its URDF limits (repaired, see load_robot)."""

    name: str
    type: str  # revolute | continuous | prismatic
    lower: float  # [rad] or [m], -inf if unlimited
    upper: float  # [rad] or [m], +inf if unlimited
    effort: float  # [N m] or [N], inf if not given or 0 (Gazebo's "no limit")
    velocity: float  # [rad/s] or [m/s], inf if not given or 0
    damping: float = 0.0  # [N m s/rad] or [N s/m], <dynamics damping>, simulated by Drake
    friction: float = 0.0  # [N m] or [N], <dynamics friction>, NOT simulated (Drake has none)
    mimic: str | None = None  # the joint this one follows (<mimic joint=..>), None if none
    mimic_multiplier: float = 1.0  # q = multiplier * q_mimicked + offset
    mimic_offset: float = 0.0  # [rad] or [m]
    parent: str = ""  # parent link
    child: str = ""  # child link


# ROS 1 ``hardware_interface/...JointInterface`` -> the ros2_control command interface.
HARDWARE_INTERFACES = {
    "PositionJointInterface": "position",
    "VelocityJointInterface": "velocity",
    "EffortJointInterface": "effort",
}


@dataclass
class Transmission:
    """A ``<transmission>`` block: ROS 1 (top level) or ROS 2 (inside ``<ros2_control>``)."""

    name: str
    type: str  # e.g. transmission_interface/SimpleTransmission (ROS 2: the <plugin>)
    # joint -> its command interfaces, from ROS 1 <hardwareInterface> mapped with
    # HARDWARE_INTERFACES (others, such as franka_hw/FrankaStateInterface, left out);
    # empty for ROS 2
    joints: dict[str, list[str]] = field(default_factory=dict)
    # joint -> the <hardwareInterface> texts as written (ROS 1),
    # e.g. "hardware_interface/EffortJointInterface"
    hardware_interfaces: dict[str, list[str]] = field(default_factory=dict)
    mechanical_reduction: float = 1.0  # actuator turns per joint turn, as written
    ros2_control: str = ""  # the <ros2_control name> holding it; "" for a ROS 1 block


@dataclass
class BaseWeld:
    """A link welded to Drake's world, and where, in the description's own world frame."""

    link: str
    X_DL: RigidTransform  # pose of the link in the description's world frame D
    joint: str = ""  # the fixed joint from the URDF's `world` link; "" for a plain root link


def _float(value: str | None, default: float) -> float:
    return default if value in (None, "") else float(value)


def _link_of(joint: ET.Element, tag: str) -> str:
    element = joint.find(tag)
    return "" if element is None else element.get("link", "")


def parse_joints(root: ET.Element, source: str | os.PathLike = "") -> list[JointInfo]:
    """The non-fixed joints of a URDF, with their limits as written; errors name
    ``source``."""
    joints = []
    for element in root.findall("joint"):
        kind = element.get("type", "")
        if kind in ("fixed", "floating", "planar", ""):
            continue
        limit = element.find("limit")
        get = (lambda key: None) if limit is None else limit.get
        dynamics = element.find("dynamics")
        dyn = (lambda key: None) if dynamics is None else dynamics.get
        mimic = element.find("mimic")
        unlimited = kind == "continuous"
        name = element.get("name", "")
        try:
            joints.append(
                JointInfo(
                    name=name,
                    type=kind,
                    lower=-np.inf if unlimited else _float(get("lower"), -np.inf),
                    upper=np.inf if unlimited else _float(get("upper"), np.inf),
                    effort=_float(get("effort"), np.inf),
                    velocity=_float(get("velocity"), np.inf),
                    damping=_float(dyn("damping"), 0.0),
                    friction=_float(dyn("friction"), 0.0),
                    mimic=None if mimic is None else mimic.get("joint"),
                    mimic_multiplier=1.0 if mimic is None else _float(mimic.get("multiplier"), 1.0),
                    mimic_offset=0.0 if mimic is None else _float(mimic.get("offset"), 0.0),
                    parent=_link_of(element, "parent"),
                    child=_link_of(element, "child"),
                )
            )
        except ValueError as error:
            where = f"{source}: " if source else ""
            raise DescriptionError(f"{where}joint {name!r}: {error}") from None
    return joints


def _pose(element: ET.Element, where: str) -> RigidTransform:
    origin = element.find("origin")
    if origin is None:
        return RigidTransform()
    try:
        xyz = [float(v) for v in (origin.get("xyz") or "0 0 0").split()]
        rpy = [float(v) for v in (origin.get("rpy") or "0 0 0").split()]
        return RigidTransform(RollPitchYaw(rpy), xyz)
    except (ValueError, TypeError) as error:
        raise DescriptionError(f"{where}: bad <origin>: {error}") from None


def detach_world(root: ET.Element, source: str | os.PathLike = "<urdf>") -> list[BaseWeld]:
    """Takes the URDF's ``world`` link out of ``root``; returns the links to weld to Drake's world.

    Gazebo descriptions fix the arm to a link named ``world``. Each fixed joint
    from it is removed and its child is to be welded at that joint's origin;
    a moving joint from it is kept, hung on a massless link ``world_anchor``
    that is welded at the identity. Without a ``world`` link the one root
    link is welded at the identity. Errors name the links: no root left, or
    more than one tree.
    """
    where = str(source)
    links = [link.get("name", "") for link in root.findall("link")]
    welds: list[BaseWeld] = []
    if "world" in links:
        for joint in list(root.findall("joint")):
            if _link_of(joint, "child") == "world":
                raise DescriptionError(
                    f"{where}: joint {joint.get('name')!r} has the `world` link as its child; "
                    "`world` can only be a parent"
                )
            if _link_of(joint, "parent") != "world":
                continue
            if joint.get("type") == "fixed":
                welds.append(
                    BaseWeld(
                        _link_of(joint, "child"),
                        _pose(joint, f"{where}: joint {joint.get('name')!r}"),
                        joint.get("name", ""),
                    )
                )
                root.remove(joint)
            else:
                anchor = "world_anchor"
                while anchor in links:
                    anchor += "_"
                joint.find("parent").set("link", anchor)
                if all(w.link != anchor for w in welds):
                    welds.append(BaseWeld(anchor, RigidTransform(), ""))
                    ET.SubElement(root, "link", name=anchor)
        for link in root.findall("link"):
            if link.get("name") == "world":
                root.remove(link)
        links = [link.get("name", "") for link in root.findall("link")]
        if not welds:
            raise DescriptionError(
                f"{where}: the `world` link holds no joint: nothing of the robot is attached to it"
            )
    children = {_link_of(joint, "child") for joint in root.findall("joint")}
    roots = [name for name in links if name not in children]
    welded = {weld.link for weld in welds}
    if not links:
        raise DescriptionError(f"{where}: the URDF has no links")
    if not roots:
        raise DescriptionError(
            f"{where}: the URDF has no root link: every link ({', '.join(links)}) is the child "
            "of a joint, so the joints form a loop"
        )
    if welds:
        loose = [name for name in roots if name not in welded]
        if loose:
            raise DescriptionError(
                f"{where}: link(s) {', '.join(loose)} are attached neither to the `world` link "
                f"nor to the robot on it ({', '.join(sorted(welded))}): two disconnected trees"
            )
        return welds
    if len(roots) > 1:
        raise DescriptionError(
            f"{where}: the URDF has {len(roots)} root links ({', '.join(roots)}): two "
            "disconnected trees; join them with a joint, or fix each to a `world` link"
        )
    return [BaseWeld(roots[0], RigidTransform(), "")]


def repair_joints(
    root: ET.Element, joints: list[JointInfo], source: str | os.PathLike = "<urdf>"
) -> list[str]:
    """Repairs physically meaningless joint values in ``root`` and ``joints``; one warning each.

    - lower limit above upper: swapped (Drake refuses such a joint);
    - ``effort="0"``: Gazebo applies no effort limit; neither do we (effort = inf);
    - negative effort or velocity: its magnitude;
    - ``velocity="0"``: no velocity limit (inf);
    - ``<dynamics friction>``: reported, Drake simulates no joint friction.
    """
    warnings = []
    elements = {joint.get("name"): joint for joint in root.findall("joint")}
    for info in joints:
        where = f"{source}: joint {info.name!r}"
        limit = elements[info.name].find("limit") if info.name in elements else None
        if info.lower > info.upper:
            warnings.append(
                f"{where}: lower limit {info.lower:g} is above upper {info.upper:g}: swapped"
            )
            info.lower, info.upper = info.upper, info.lower
            if limit is not None:
                limit.set("lower", repr(info.lower))
                limit.set("upper", repr(info.upper))
        if info.effort == 0:
            warnings.append(
                f'{where}: effort="0", which Gazebo takes as no effort limit: '
                "its actuator here has no effort limit either"
            )
            info.effort = math.inf
        elif info.effort < 0:
            warnings.append(f"{where}: effort={info.effort:g} is negative: using {-info.effort:g}")
            info.effort = -info.effort
            if limit is not None:
                limit.set("effort", repr(info.effort))
        if info.velocity == 0:
            warnings.append(f'{where}: velocity="0": taken as no velocity limit')
            info.velocity = math.inf
            if limit is not None:
                del limit.attrib["velocity"]
        elif info.velocity < 0:
            warnings.append(
                f"{where}: velocity={info.velocity:g} is negative: using {-info.velocity:g}"
            )
            info.velocity = -info.velocity
            if limit is not None:
                limit.set("velocity", repr(info.velocity))
        if info.friction:
            warnings.append(
                f"{where}: <dynamics friction={info.friction:g}> is not simulated (Drake has "
                f"no joint friction); damping={info.damping:g} is"
            )
            dynamics = elements[info.name].find("dynamics") if info.name in elements else None
            if dynamics is not None:
                dynamics.attrib.pop("friction", None)  # said once, here, not again by Drake
        if info.damping < 0:
            warnings.append(f"{where}: damping={info.damping:g} is negative: using 0")
            info.damping = 0.0
            elements[info.name].find("dynamics").set("damping", "0")
    names = {info.name for info in joints}
    for info in joints:
        if info.mimic and info.mimic not in names:
            raise DescriptionError(
                f"{source}: joint {info.name!r} mimics {info.mimic!r}, which is not a moving "
                "joint of the URDF"
            )
    return warnings


def parse_transmissions(root: ET.Element) -> list[Transmission]:
    """ROS 1 top-level ``<transmission>`` blocks and ROS 2 ones inside ``<ros2_control>``."""
    result = []
    for block, holder in [(t, "") for t in root.findall("transmission")] + [
        (t, r.get("name", ""))
        for r in root.findall("ros2_control")
        for t in r.findall("transmission")
    ]:
        kind = (block.findtext("type") or block.findtext("plugin") or "").strip()
        transmission = Transmission(name=block.get("name", ""), type=kind, ros2_control=holder)
        reduction = next(
            (
                text
                for path in (
                    "actuator/mechanicalReduction",
                    "joint/mechanicalReduction",
                    "actuator/mechanical_reduction",
                    "joint/mechanical_reduction",
                )
                if (text := block.findtext(path))
            ),
            None,
        )
        with contextlib.suppress(TypeError, ValueError):
            transmission.mechanical_reduction = float(reduction)
        for joint in block.findall("joint"):
            written = [(e.text or "").strip() for e in joint.findall("hardwareInterface") if e.text]
            written += [
                (e.text or "").strip()
                for e in block.findall("actuator/hardwareInterface")
                if e.text and not written
            ]
            interfaces = []
            for text in written:
                short = text.rsplit("/", 1)[-1]
                if short in HARDWARE_INTERFACES:  # not e.g. franka_hw/FrankaStateInterface
                    interfaces.append(HARDWARE_INTERFACES[short])
            name = joint.get("name", "")
            transmission.joints[name] = list(dict.fromkeys(interfaces))
            transmission.hardware_interfaces[name] = written
        result.append(transmission)
    return result


def controller_files(root: ET.Element, source: str | os.PathLike = "<urdf>") -> list[Path]:
    """The controller YAML files named in ``<gazebo><plugin><parameters>`` blocks.

    gazebo_ros2_control and gz_ros2_control read their controller configuration
    from there; a relative path is taken relative to the description's folder.
    """
    files = []
    base = Path(source).parent
    for plugin in root.findall("gazebo/plugin"):
        for parameters in plugin.findall("parameters"):
            text = (parameters.text or "").strip()
            if not text:
                continue
            path = Path(text.removeprefix("file://")).expanduser()
            if not path.is_absolute():
                path = base / path
            if path.suffix.lower() in (".yaml", ".yml"):
                files.append(path)
    return files


# Tags of ROS tools that mean nothing to Drake: (parent tag, child tag) -> what they are.
UNUSED_TAGS = {
    ("joint", "safety_controller"): "soft limits of ROS 1's safety controller",
    ("joint", "calibration"): "encoder calibration",
    ("link", "self_collision_checking"): "MoveIt's self-collision shapes",
}


def strip_unused(root: ET.Element, source: str | os.PathLike = "<urdf>") -> list[str]:
    """Removes the tags of :data:`UNUSED_TAGS`; one note per kind, naming how many and where."""
    notes = []
    for (parent_tag, tag), meaning in UNUSED_TAGS.items():
        owners = []
        for parent in root.findall(parent_tag):
            found = parent.findall(tag)
            for element in found:
                parent.remove(element)
            if found:
                owners.append(parent.get("name", ""))
        if owners:
            notes.append(
                f"{source}: <{tag}> ({meaning}) ignored on {len(owners)} {parent_tag}(s): "
                + ", ".join(owners)
            )
    return notes


def parse_urdf(urdf: str, source: str | os.PathLike = "<string>") -> ET.Element:
    """The XML root of a URDF text; errors name the source and line."""
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as error:
        raise DescriptionError(f"{source}: not valid XML: {error}") from None
    if root.tag != "robot":
        raise DescriptionError(
            f"{source}: not a URDF: the root element is <{root.tag}>, not <robot>"
        )
    return root


@dataclass(frozen=True)
class SensorBlock:
    """A ``<gazebo reference="LINK"><sensor type=...>`` block of the URDF, as Gazebo
    reads it: the fields every sensor type has, and the element for its own tags."""

    link: str  # the link it is mounted on
    type: str  # Gazebo's sensor type: camera, gpu_lidar, imu, ...
    name: str  # its name attribute
    update_rate: float  # [Hz] <update_rate>; 0: at every step
    X_LS: RigidTransform  # <pose> "x y z roll pitch yaw" of the sensor in the link
    element: ET.Element  # the whole <sensor> element
    source: str  # the description, for messages

    def where(self) -> str:
        """``<source>: <gazebo reference="LINK"><sensor name="NAME">``, for messages."""
        return f'{self.source}: <gazebo reference="{self.link}"><sensor name="{self.name}">'


def parse_sensor_blocks(root: ET.Element, source: str | os.PathLike = "") -> list[SensorBlock]:
    """Every ``<gazebo reference="LINK"><sensor>`` block of an expanded URDF, in document
    order (a block without a reference or on a link the URDF lacks is left to the
    reader of its type, which names it)."""
    blocks = []
    for gazebo in root.findall("gazebo"):
        link = (gazebo.get("reference") or "").strip()
        for sensor in gazebo.findall("sensor"):
            name = sensor.get("name", "(unnamed)")
            where = f'{source}: <sensor name="{name}">'
            try:
                rate = float((sensor.findtext("update_rate") or "0").strip())
                pose = [float(v) for v in (sensor.findtext("pose") or "0 0 0 0 0 0").split()]
                X_LS = RigidTransform(RollPitchYaw(pose[3:6]), pose[0:3])
            except (ValueError, IndexError) as error:
                raise DescriptionError(f"{where}: bad <update_rate> or <pose>: {error}") from None
            blocks.append(
                SensorBlock(
                    link=link,
                    type=sensor.get("type", "").strip(),
                    name=name,
                    update_rate=rate,
                    X_LS=X_LS,
                    element=sensor,
                    source=str(source),
                )
            )
    return blocks
