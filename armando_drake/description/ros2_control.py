"""The ``<ros2_control>`` block of a URDF, parsed and checked as upstream does.

Upstream (``hardware_interface/component_parser.cpp``) reads
``<ros2_control name=".." type="system|actuator|sensor">`` holding one
``<hardware>`` with a ``<plugin>`` and ``<param>``s, and ``<joint>``,
``<sensor>``, ``<gpio>`` components with ``<command_interface>`` and
``<state_interface>`` children. The messages here follow upstream's and name
the tag and attribute at fault; the description file is named in front.
"""

from __future__ import annotations

import ast
import contextlib
import logging
import math
import operator
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from armando_drake.tools.errors import UserInputError

LOGGER = logging.getLogger("armando_drake.description.ros2_control")
# Interfaces that move a joint; a <joint> of a block with none of them is I/O.
MOTION_INTERFACES = frozenset({"position", "velocity", "effort", "acceleration"})


class Ros2ControlError(UserInputError, ValueError):
    """A ``<ros2_control>`` block that upstream would refuse."""


@dataclass
class InterfaceInfo:
    """One command or state interface of a joint."""

    name: str  # position | velocity | effort | acceleration | ...
    min: float | None = None
    max: float | None = None
    initial_value: float | None = None
    data_type: str = "double"
    size: int = 1
    parameters: dict[str, str] = field(default_factory=dict)


@dataclass
class ComponentInfo:
    """A ``<joint>``, ``<sensor>`` or ``<gpio>`` of the block."""

    name: str
    type: str  # joint | sensor | gpio
    command_interfaces: list[InterfaceInfo] = field(default_factory=list)
    state_interfaces: list[InterfaceInfo] = field(default_factory=list)
    parameters: dict[str, str] = field(default_factory=dict)

    def command_interface(self, name: str) -> InterfaceInfo | None:
        return next((i for i in self.command_interfaces if i.name == name), None)

    def state_interface(self, name: str) -> InterfaceInfo | None:
        return next((i for i in self.state_interfaces if i.name == name), None)


@dataclass
class HardwareInfo:
    """One ``<ros2_control>`` block."""

    name: str
    type: str  # system | actuator | sensor
    plugin: str
    hardware_parameters: dict[str, str] = field(default_factory=dict)
    joints: list[ComponentInfo] = field(default_factory=list)
    sensors: list[ComponentInfo] = field(default_factory=list)
    gpios: list[ComponentInfo] = field(default_factory=list)


_COMPONENT_TAGS = ("joint", "sensor", "gpio")
_TOP_TAGS = ("hardware", *_COMPONENT_TAGS, "transmission")
_INTERFACE_TAGS = ("command_interface", "state_interface")


def _attribute(element: ET.Element, name: str, where: str) -> str:
    value = element.get(name)
    if value is None:
        raise Ros2ControlError(f"{where}no attribute '{name}' in '{element.tag}' tag")
    return value


def _parameters(element: ET.Element, where: str) -> dict[str, str]:
    result = {}
    for param in element.findall("param"):
        name = param.get("name")
        if name is None:
            raise Ros2ControlError(f"{where}no attribute 'name' in 'param' tag")
        result[name] = (param.text or "").strip()
    return result


_OPERATORS = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
}


def _arithmetic(node: ast.AST) -> float:
    """The value of an expression of numbers, ``pi``, + - * / ** and brackets."""
    if isinstance(node, ast.Expression):
        return _arithmetic(node.body)
    if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
        return float(node.value)
    if isinstance(node, ast.Name) and node.id == "pi":
        return math.pi
    if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
        return _OPERATORS[type(node.op)](_arithmetic(node.left), _arithmetic(node.right))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _OPERATORS:
        return _OPERATORS[type(node.op)](_arithmetic(node.operand))
    raise ValueError(f"not arithmetic: {ast.dump(node)}")


def _number(text: str, what: str, where: str) -> float:
    """A number, or an expression in braces as the ros2_control docs write them
    (``{-2*pi}``, as ur_description does: upstream keeps it as a string)."""
    try:
        return float(text)
    except ValueError:
        pass
    stripped = text.strip()
    if stripped.startswith("{") and stripped.endswith("}"):
        with contextlib.suppress(ValueError, SyntaxError, ZeroDivisionError, OverflowError):
            return _arithmetic(ast.parse(stripped[1:-1], mode="eval"))
    raise Ros2ControlError(f"{where}{what}={text!r} is not a number")


def _interface(element: ET.Element, owner: str, where: str) -> InterfaceInfo:
    name = _attribute(element, "name", where)
    if not name.strip():
        raise Ros2ControlError(f"{where}empty interface type in '{element.tag}' of '{owner}'")
    parameters = _parameters(element, where)
    size_text = element.get("size", "1")
    try:
        size = int(size_text)
    except ValueError:
        raise Ros2ControlError(
            f"{where}size={size_text!r} of {element.tag} '{name}' of '{owner}' is not an integer"
        ) from None
    if size < 0:
        raise Ros2ControlError(
            f"{where}size={size} of {element.tag} '{name}' of '{owner}' is negative"
        )
    info = InterfaceInfo(
        name=name,
        data_type=element.get("data_type", "double"),
        size=size,
        parameters=parameters,
    )
    for key in ("min", "max", "initial_value"):
        if key in parameters:
            label = f"{element.tag} '{name}' of '{owner}' {key}"
            value = _number(parameters[key], label, where)
            # min/max may be +-inf (no limit); nothing may be NaN, nor an initial value inf.
            if math.isnan(value) or (key == "initial_value" and not math.isfinite(value)):
                raise Ros2ControlError(f"{where}{label}={parameters[key]!r} is not a finite number")
            setattr(info, key, value)
    if info.min is not None and info.max is not None and info.min > info.max:
        raise Ros2ControlError(
            f"{where}{element.tag} '{name}' of '{owner}' has min={info.min} > max={info.max}"
        )
    return info


def _component(element: ET.Element, where: str) -> ComponentInfo:
    name = _attribute(element, "name", where)
    component = ComponentInfo(name=name, type=element.tag, parameters=_parameters(element, where))
    for child in element:
        if child.tag == "command_interface":
            component.command_interfaces.append(_interface(child, name, where))
        elif child.tag == "state_interface":
            component.state_interfaces.append(_interface(child, name, where))
        elif child.tag == "param":
            pass
        else:
            raise Ros2ControlError(
                f"{where}unknown tag <{child.tag}> in <{element.tag} name='{name}'>; "
                f"expected {', '.join(_INTERFACE_TAGS)} or param"
            )
    return component


def parse_ros2_control(root: ET.Element, source: str = "") -> list[HardwareInfo]:
    """Every ``<ros2_control>`` block of a URDF, checked against its joints.

    Joints named in a block must exist in the URDF and must not be fixed; a
    ``<joint>`` that is not in the URDF and has no position, velocity, effort or
    acceleration interface (older ur_description's ``speed_scaling``, ``gpio``)
    is taken as a GPIO, with a warning.
    """
    where = f"{source}: " if source else ""
    if root.tag != "robot":
        raise Ros2ControlError(f"{where}not a URDF: the root element is <{root.tag}>")
    urdf_joints = {j.get("name"): j.get("type") for j in root.findall("joint")}
    blocks = []
    claimed: dict[str, str] = {}  # joint -> the block that gave it first
    for block in root.findall("ros2_control"):
        name = _attribute(block, "name", where)
        kind = _attribute(block, "type", where)
        if kind not in ("system", "actuator", "sensor"):
            raise Ros2ControlError(
                f"{where}<ros2_control name='{name}'> has type='{kind}'; "
                "expected system, actuator or sensor"
            )
        hardware = block.find("hardware")
        plugin = None if hardware is None else hardware.find("plugin")
        if plugin is None or not (plugin.text or "").strip():
            raise Ros2ControlError(
                f"{where}Missing <plugin> tag of <hardware> element for '{name}'"
            )
        info = HardwareInfo(
            name=name,
            type=kind,
            plugin=plugin.text.strip(),
            hardware_parameters=_parameters(hardware, where),
        )
        for child in block:
            if child.tag not in _TOP_TAGS:
                raise Ros2ControlError(
                    f"{where}unknown tag <{child.tag}> in <ros2_control name='{name}'>; "
                    f"expected one of {', '.join(_TOP_TAGS)}"
                )
            if child.tag == "joint":
                joint = _component(child, where)
                interfaces = {i.name for i in joint.command_interfaces + joint.state_interfaces}
                if joint.name not in urdf_joints and not interfaces & MOTION_INTERFACES:
                    LOGGER.warning(
                        "%s<ros2_control name='%s'>: joint '%s' is not in the URDF and has no "
                        "%s interface: taken as a GPIO (older ur_description writes its I/O so)",
                        where,
                        name,
                        joint.name,
                        ", ".join(sorted(MOTION_INTERFACES)),
                    )
                    joint.type = "gpio"
                    info.gpios.append(joint)
                    continue
                if joint.name not in urdf_joints:
                    raise Ros2ControlError(
                        f"{where}<ros2_control name='{name}'>: "
                        f"Joint '{joint.name}' not found in URDF"
                    )
                if urdf_joints[joint.name] == "fixed":
                    raise Ros2ControlError(
                        f"{where}<ros2_control name='{name}'>: Joint '{joint.name}' is fixed "
                        "and cannot be controlled"
                    )
                if joint.name in claimed:
                    raise Ros2ControlError(
                        f"{where}<ros2_control name='{name}'>: joint '{joint.name}' is given "
                        f"twice (also in <ros2_control name='{claimed[joint.name]}'>): its "
                        "interfaces can be registered once only"
                    )
                claimed[joint.name] = name
                info.joints.append(joint)
            elif child.tag == "sensor":
                info.sensors.append(_component(child, where))
            elif child.tag == "gpio":
                info.gpios.append(_component(child, where))
        blocks.append(info)
    return blocks


def merge_limits(
    lower: float, upper: float, interface: InterfaceInfo | None
) -> tuple[float, float]:
    """URDF limits combined with an interface's ``min``/``max``: the tighter wins."""
    if interface is not None:
        if interface.min is not None:
            lower = max(lower, interface.min)
        if interface.max is not None:
            upper = min(upper, interface.max)
    return lower, upper


def initial_position(lower: float, upper: float, interface: InterfaceInfo | None) -> float:
    """``initial_value`` of a position state interface, else 0, clamped into the limits."""
    value = 0.0 if interface is None or interface.initial_value is None else interface.initial_value
    if not math.isfinite(value):
        value = 0.0
    return min(max(value, lower), upper)
