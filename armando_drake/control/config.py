"""A ros2_control controller YAML, loaded into typed dataclasses.

The file is the one a ROS 2 user already has::

    controller_manager:
      ros__parameters:
        update_rate: 100
        position_controller:
          type: <package>/<Type>         # a type of the controller registry
    position_controller:
      ros__parameters:
        joints: [j0, j1, j2, j3]

Node blocks may also sit under a namespace key (``/**:``, ``/robot:``) or be
named with one (``/**/controller_manager:``, ``robot/position_controller:``);
ROS parameter names with dots (``constraints.goal_time: 0.5``) are the same
as nested mappings. Which types exist, and which parameters each reads, the
controller registry (:mod:`armando_drake.control.controllers`) says. Every error
names the file and the key at fault, as
``<file>: <key>: <problem>``.

A ROS 1 (``ros_control``) file, one with no ``ros__parameters`` anywhere, is
read too::

    rrbot:                               # any namespace, or none
      joint1_position_controller:
        type: <package>/<Type>           # a ROS 1 type of the registry
        joint: joint1
        pid: {p: 100.0, i: 0.01, d: 10.0}

Every mapping with a ``type`` is a controller (its other keys its parameters),
looked up among the ROS 1 types of the registry (:mod:`.controllers.ros1`);
mappings without one are namespaces; what holds no controller is ignored
with one warning, but for ``gazebo_ros_control: {pid_gains: {<joint>: {p, i,
d}}}``, the gains Gazebo closes its position (and velocity) joints with, read
into :attr:`ControllerManagerConfig.pid_gains`. ROS 1 has no update
rate in the file: the controllers run at :data:`ROS1_UPDATE_RATE`, as
``gazebo_ros_control`` runs them at every 1 ms physics step.

As upstream's controller manager, which fails only when it loads a controller
of a type it has no plugin for, a controller of a type the registry does not
know (``GripperActionController``, ...) is noted with one warning and the file
loads; activating that controller is the error, naming the file, the key and
the type (:attr:`ControllerConfig.controller_class`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from armando_drake.control.controllers import (
    Controller,
    ParameterError,
    load_parameters,
    lookup,
)
from armando_drake.tools.errors import UserInputError
from armando_drake.tools.files import read_yaml_file
from armando_drake.tools.yaml_keys import duplicate_key

_logger = logging.getLogger("armando_drake.control.config")

DEFAULT_UPDATE_RATE = 100  # [Hz] upstream controller_manager default
# [Hz] the rate of a ROS 1 file's controllers: gazebo_ros_control's control period is
# Gazebo's physics step, 1 ms by default.
ROS1_UPDATE_RATE = 1000

# Parameters upstream knows that the simulation has no use for; they are
# accepted (so an existing file loads unchanged) and otherwise ignored.
_IGNORED_MANAGER_PARAMETERS = frozenset(
    {
        "use_sim_time",
        "enforce_command_limits",
        "thread_priority",
        "cpu_affinity",
        "lock_memory",
        "handle_exceptions",
        "robot_description",
        "hardware_components_initial_state",
        "diagnostics",
        "statistics",
        "activate_components_on_start",
        "configure_components_on_start",
    }
)
_IGNORED_ENTRY_KEYS = frozenset({"params_file", "fallback_controllers"})


class ControllerConfigError(UserInputError, ValueError):
    """A controller YAML that cannot be used, with the file and key at fault."""


@dataclass
class ControllerConfig:
    """One controller declared under ``controller_manager``."""

    name: str  # the controller's name (its topics are /<name>/...)
    type: str  # the plugin type as written
    joints: list[str]  # joints it claims, in its order; [] = all (broadcaster only)
    params: Any = None  # its parameters dataclass (the registered type's ``parameters``)
    parameters: dict[str, Any] = field(default_factory=dict)  # its ros__parameters as read
    key: str = ""  # where its ros__parameters are in the file, for error messages
    ros: int = 2  # the ROS generation of the file: 2 (ros2_control) or 1 (ros_control)
    namespace: str = ""  # ROS 1: the namespace it was declared in ("/rrbot"), "" = none
    # Why it cannot run ("<file>: <key>.type: unknown controller type ..."), when its
    # type is not registered; "" for a supported controller.
    unsupported: str = ""

    @property
    def supported(self) -> bool:
        return not self.unsupported

    @property
    def controller_class(self) -> type[Controller]:
        """The registered class that implements :attr:`type`; for an unsupported type
        the :class:`ControllerConfigError` naming the file, key and type."""
        if self.unsupported:
            raise ControllerConfigError(self.unsupported)
        return lookup(self.type, ros=self.ros)

    @property
    def interface_name(self) -> str | None:
        """The command interface it claims on its joints (None: a broadcaster or an
        unsupported type)."""
        return self.controller_class.command_interface(self.params) if self.supported else None

    @property
    def position_targets(self) -> bool:
        """Whether its commands are joint positions (a position or trajectory sequence can
        drive it: a position controller, a trajectory controller, ROS 1's PID ones)."""
        return self.supported and self.controller_class.position_targets(self.params)

    @property
    def topic(self) -> str | None:
        """Its command topic (``commands``, ``joint_trajectory``; ROS 1: ``command``),
        None for a broadcaster or an unsupported type."""
        return self.controller_class.topic if self.supported else None

    @property
    def ros_topic(self) -> str | None:
        """Its full command topic name as ROS would resolve it:
        ``/<controller>/commands``, ROS 1 ``/<namespace>/<controller>/command``."""
        topic = self.topic
        return None if topic is None else f"{self.namespace}/{self.name}/{topic}"


@dataclass
class ControllerManagerConfig:
    """The ``controller_manager`` node and the controllers it loads."""

    update_rate: int = DEFAULT_UPDATE_RATE  # [Hz] rate of every controller update
    controllers: dict[str, ControllerConfig] = field(default_factory=dict)  # by name
    source: str = ""  # the file it was read from, for error messages
    ros: int = 2  # the file's ROS generation: 2 (ros2_control) or 1 (ros_control)
    # ROS 1: gazebo_ros_control's pid_gains per joint, as {joint: (p, i, d)} [N m/rad,
    # N m/(rad s), N m s/rad] (on a velocity joint, p is per rad/s); the gains Gazebo
    # closes a position or velocity interface with.
    pid_gains: dict[str, tuple[float, float, float]] = field(default_factory=dict)


def check_update_rate(update_rate: Any, where: str) -> int:
    """``update_rate`` [Hz] if it is a positive integer, else the error naming ``where``
    (the file and key, or the scenario field). The one check of the rate."""
    if isinstance(update_rate, bool) or not isinstance(update_rate, int) or update_rate <= 0:
        raise ControllerConfigError(
            f"{where}: update_rate={update_rate!r} must be a positive integer [Hz]"
        )
    return update_rate


def _fail(source: str, key: str, problem: str) -> ControllerConfigError:
    return ControllerConfigError(f"{source}: {key}: {problem}")


def _unflatten(params: Any, source: str, key: str) -> dict[str, Any]:
    """ROS dotted names (``constraints.goal_time``) as nested mappings."""
    if params is None:
        return {}
    if not isinstance(params, dict):
        raise _fail(source, key, f"expected a mapping, got {params!r}")
    result: dict[str, Any] = {}
    for name, value in params.items():
        name = str(name)
        if isinstance(value, dict):
            value = _unflatten(value, source, f"{key}.{name}")
        *parents, leaf = name.split(".")
        target = result
        for parent in parents:
            target = target.setdefault(parent, {})
            if not isinstance(target, dict):
                raise _fail(source, f"{key}.{name}", "conflicts with a parameter of the same name")
        if isinstance(value, dict) and isinstance(target.get(leaf), dict):
            _merge(target[leaf], value)
        else:
            target[leaf] = value
    return result


def _merge(into: dict[str, Any], other: dict[str, Any]) -> None:
    for name, value in other.items():
        if isinstance(value, dict) and isinstance(into.get(name), dict):
            _merge(into[name], value)
        else:
            into[name] = value


def _collect_nodes(
    data: dict[str, Any], source: str, prefix: str, nodes: dict[str, tuple[str, dict[str, Any]]]
) -> None:
    """Node name -> (key path, ros__parameters), looking through namespace keys."""
    for raw_key, value in data.items():
        key = str(raw_key)
        path = f"{prefix}/{key}" if prefix else key
        if not isinstance(value, dict):
            raise _fail(source, path, f"expected a node or namespace mapping, got {value!r}")
        if "ros__parameters" in value:
            extra = sorted(str(k) for k in value if k != "ros__parameters")
            if extra:
                raise _fail(source, f"{path}.{extra[0]}", "a node holds only 'ros__parameters'")
            node = key.rstrip("/").split("/")[-1]
            params = _unflatten(value["ros__parameters"], source, f"{path}.ros__parameters")
            if node in nodes:
                _merge(nodes[node][1], params)
            else:
                nodes[node] = (f"{path}.ros__parameters", params)
        else:
            _collect_nodes(value, source, path, nodes)


def _controller(
    name: str,
    type_: Any,
    raw: dict[str, Any],
    source: str,
    key: str,
    *,
    type_key: str,
    ros: int = 2,
    namespace: str = "",
) -> ControllerConfig:
    """The controller ``name`` of type ``type_`` (written at ``type_key``) with its
    parameters ``raw`` (at ``key``); an unknown type gives an unsupported entry."""
    if not isinstance(type_, str) or not type_:
        raise _fail(source, type_key, f"expected a controller type string, got {type_!r}")
    try:
        cls = lookup(type_, ros=ros)
    except KeyError as error:
        unsupported = f"{source}: {type_key}: {error.args[0]}"
        _logger.warning(
            "%s: %s: controller type %r is not supported; %r fails if activated",
            source,
            type_key,
            type_,
            name,
        )
        return ControllerConfig(
            name, type_, [], None, raw, key, ros=ros, namespace=namespace, unsupported=unsupported
        )
    for parameter in raw:
        if parameter in cls.ignored_parameters:
            _logger.info("%s: %s.%s is not simulated; ignored", source, key, parameter)
    try:
        params = load_parameters(cls, raw)
    except ParameterError as error:
        raise _fail(source, f"{key}.{error.parameter}", error.problem) from None
    joints = cls.joints_of(params)
    return ControllerConfig(name, type_, joints, params, raw, key, ros=ros, namespace=namespace)


def parse_controller_config(data: Any, source: str) -> ControllerManagerConfig:
    """The controller manager and controllers described by YAML ``data``.

    ``source`` names the file (or other origin) in error messages.
    """
    if not isinstance(data, dict):
        raise ControllerConfigError(f"{source}: expected a mapping of ROS nodes, got {data!r}")
    if not _holds_key(data, "ros__parameters") and _holds_key(data, "type"):
        return _parse_ros1(data, source)
    nodes: dict[str, tuple[str, dict[str, Any]]] = {}
    _collect_nodes(data, source, "", nodes)
    if "controller_manager" not in nodes:
        raise _fail(
            source,
            "controller_manager",
            "no 'controller_manager: ros__parameters:' node (ROS 2) and no mapping with a "
            "'type' (a ROS 1 controller)",
        )
    manager_key, manager = nodes.pop("controller_manager")
    update_rate = check_update_rate(
        manager.get("update_rate", DEFAULT_UPDATE_RATE), f"{source}: {manager_key}.update_rate"
    )
    config = ControllerManagerConfig(update_rate=update_rate, source=source)
    for name, entry in manager.items():
        if name == "update_rate" or name in _IGNORED_MANAGER_PARAMETERS:
            continue
        key = f"{manager_key}.{name}"
        if entry is not None and not isinstance(entry, dict):
            raise _fail(
                source,
                key,
                f"unknown controller_manager parameter ({entry!r}); a controller is a mapping "
                "with 'type'",
            )
        entry = entry or {}
        for entry_key in entry:
            if entry_key != "type" and entry_key not in _IGNORED_ENTRY_KEYS:
                raise _fail(
                    source, f"{key}.{entry_key}", "unknown key; a controller entry has 'type'"
                )
        node_key, params = nodes.pop(name, (f"{name}.ros__parameters", {}))
        type_ = entry.get("type", params.get("type"))
        if type_ is None:
            raise _fail(source, key, f"The 'type' param was not defined for '{name}'")
        if "type" in params and params["type"] != type_:
            raise _fail(
                source, f"{node_key}.type", f"type {params['type']!r} differs from {type_!r}"
            )
        _check_node_parameters(params, source, node_key, update_rate)
        config.controllers[name] = _controller(
            name, type_, params, source, node_key, type_key=f"{key}.type"
        )
    for name, (node_key, _) in nodes.items():
        _logger.warning(
            "%s: %s: '%s' is not a controller of controller_manager; ignored",
            source,
            node_key,
            name,
        )
    return config


def _check_node_parameters(params: dict[str, Any], source: str, key: str, update_rate: int) -> None:
    """The parameters every ros2_control controller node has (``update_rate``,
    ``is_async``), refused where they would change the timing: every controller runs
    in the manager's update at its rate."""
    own = params.get("update_rate")
    if own is not None and own != update_rate:
        raise _fail(
            source,
            f"{key}.update_rate",
            f"update_rate={own!r} differs from controller_manager's {update_rate}; a "
            "controller's own rate is not simulated (each runs at the manager's)",
        )
    if params.get("is_async", False) is not False:
        raise _fail(
            source,
            f"{key}.is_async",
            f"is_async={params['is_async']!r} is not simulated: every controller runs "
            "synchronously in the manager's update",
        )


def _holds_key(data: Any, key: str) -> bool:
    """Whether ``key`` is a key of ``data`` or of any mapping inside it."""
    if not isinstance(data, dict):
        return False
    return key in data or any(_holds_key(value, key) for value in data.values())


def _parse_ros1(data: dict[str, Any], source: str) -> ControllerManagerConfig:
    """The controllers of a ROS 1 (ros_control) parameter file: every mapping with a
    ``type``, in any namespace."""
    config = ControllerManagerConfig(update_rate=ROS1_UPDATE_RATE, source=source, ros=1)

    def walk(mapping: dict[str, Any], path: str) -> tuple[int, list[str]]:
        """(controllers found under ``mapping``, keys that hold none)."""
        found, ignored = 0, []
        for raw_key, value in mapping.items():
            key = str(raw_key)
            where = f"{path}/{key}" if path else key
            if key == "gazebo_ros_control" and isinstance(value, dict):
                ignored += _gazebo_pid_gains(value, source, where, config.pid_gains)
                continue
            if isinstance(value, dict) and "type" in value:
                if key in config.controllers:
                    raise _fail(
                        source,
                        where,
                        f"controller '{key}' is also defined at {config.controllers[key].key}",
                    )
                params = {str(k): v for k, v in value.items() if k != "type"}
                config.controllers[key] = _controller(
                    key,
                    value["type"],
                    params,
                    source,
                    where,
                    type_key=f"{where}.type",
                    ros=1,
                    namespace=f"/{path}" if path else "",
                )
                found += 1
            elif isinstance(value, dict):
                inner, inner_ignored = walk(value, where)
                found += inner
                ignored += inner_ignored if inner else [where]
            else:
                ignored.append(where)
        return found, ignored

    _, ignored = walk(data, "")
    for where in ignored:
        _logger.warning("%s: %s holds no controller (no 'type'); ignored", source, where)
    return config


def _gazebo_pid_gains(
    block: dict[str, Any], source: str, where: str, gains: dict[str, tuple[float, float, float]]
) -> list[str]:
    """Reads ``gazebo_ros_control: {pid_gains: {<joint>: {p, i, d}}}`` into ``gains``;
    returns the keys it ignores."""
    ignored = [f"{where}/{key}" for key in block if key != "pid_gains"]
    entries = block.get("pid_gains") or {}
    if not isinstance(entries, dict):
        raise _fail(source, f"{where}/pid_gains", f"expected a mapping of joints, got {entries!r}")
    for joint, values in entries.items():
        key = f"{where}/pid_gains/{joint}"
        if not isinstance(values, dict) or "p" not in values:
            raise _fail(source, f"{key}.p", "No p gain specified for pid")
        numbers = []
        for name in ("p", "i", "d"):
            value = values.get(name, 0.0)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
                raise _fail(source, f"{key}.{name}", f"{name}={value!r} must be a number >= 0")
            numbers.append(float(value))
        gains[str(joint)] = tuple(numbers)
    return ignored


def load_controller_config(path: str | Path) -> ControllerManagerConfig:
    """The controller manager configuration in the YAML file at ``path``."""
    path = Path(path)
    try:
        text = read_yaml_file(path, what="a controller file")
    except OSError as error:
        raise ControllerConfigError(f"{path}: cannot read controller file: {error}") from None
    except UnicodeDecodeError as error:
        raise ControllerConfigError(
            f"{path}: not a text (UTF-8) YAML file: byte {error.start} is "
            f"{error.object[error.start]:#x}"
        ) from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        problem = getattr(error, "problem", None) or str(error)
        raise ControllerConfigError(f"{where}: not valid YAML: {problem}") from None

    found = duplicate_key(text)
    if found is not None:
        raise ControllerConfigError(f"{path}:{found[0]}: {found[1]}")
    return parse_controller_config(data, str(path))


def validate_joints(
    config: ControllerManagerConfig, robot_joint_names: list[str] | tuple[str, ...], source: str
) -> None:
    """Fails if a controller names a joint the robot (described by ``source``) lacks."""
    known = list(robot_joint_names)
    for controller in config.controllers.values():
        for joint in controller.joints:  # none for an unsupported type
            where = "joint" if "joint" in controller.parameters else "joints"
            if where == "joints":
                where = controller.controller_class.joint_key(controller.params, joint)
            if joint not in known:
                raise ControllerConfigError(
                    f"{config.source}: {controller.key}.{where}: unknown joint "
                    f"'{joint}' of controller '{controller.name}'; {source} has known joints: "
                    f"{', '.join(known)}"
                )
