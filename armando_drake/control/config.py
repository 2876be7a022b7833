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

It is read as ROS reads it (:mod:`armando_drake.control.param_files`): several files
in order (later values win), a node key given again merged, wildcards (``/**``,
``/*``) and fully qualified names (``/ns/controller_manager``), the manager's
namespace taken from the file; ROS parameter names with dots
(``constraints.goal_time``) are the same as nested mappings. A controller is a
mapping of the manager with a ``type``, or a node whose own parameters have a
``type`` (``spawner --param-file``); there may be no manager node at all. Which types
exist, and which parameters each declares, the controller registry
(:mod:`armando_drake.control.controllers`) says: a parameter the type does not declare
is ignored with one warning, as ROS ignores it. Every error names the file and the key
at fault, as ``<file>: <key>: <problem>``.

A ROS 1 (``ros_control``) file, one with no ``ros__parameters`` anywhere, is
read too (several, as ``rosparam load`` loads them in turn into one tree)::

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
the type (:attr:`ControllerConfig.controller_class`). Read leniently (``strict=False``,
as a world reads it), a controller whose parameters cannot be used is the same: one
warning, and the error when it is activated.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from armando_drake.control.controllers import (
    Controller,
    ParameterError,
    load_parameters,
    lookup,
)
from armando_drake.control.param_files import (
    PARAMETERS_KEY,
    NodeEntry,
    NodeParameters,
    ParamFileError,
    collect_nodes,
    merge_trees,
    node_parameters,
    read_param_file,
)
from armando_drake.tools.errors import UserInputError

_logger = logging.getLogger("armando_drake.control.config")

DEFAULT_UPDATE_RATE = 100  # [Hz] upstream controller_manager default
# [Hz] the rate of a ROS 1 file's controllers: gazebo_ros_control's control period is
# Gazebo's physics step, 1 ms by default.
ROS1_UPDATE_RATE = 1000

# The controller manager's parameters upstream (Jazzy) declares that the simulation has
# no use for (the timing, the threads, the diagnostics); accepted and ignored.
_MANAGER_PARAMETERS = frozenset(
    {
        "update_rate",
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
    # type is not registered (or, read leniently, its parameters cannot be used); "" for
    # a supported controller.
    unsupported: str = ""
    file: str = ""  # the parameter file of its parameters (of several, the first)

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
    source: str = ""  # the file(s) it was read from, for error messages ("a.yaml, b.yaml")
    sources: list[str] = field(default_factory=list)  # each file, in the order read
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
    return ControllerConfigError(f"{source}: {key}: {problem}" if source else f"{key}: {problem}")


def _generation(data: Any) -> int:
    """The ROS generation of a parameter file's data: 2 (``ros__parameters``), 1 (a
    mapping with a ``type`` and no ``ros__parameters``), 0 (neither: either)."""
    if _holds_key(data, PARAMETERS_KEY):
        return 2
    return 1 if _holds_key(data, "type") else 0


def _holds_key(data: Any, key: str) -> bool:
    """Whether ``key`` is a key of ``data`` or of any mapping inside it (in lists too)."""
    if isinstance(data, list):
        return any(_holds_key(value, key) for value in data)
    if not isinstance(data, dict):
        return False
    return key in data or any(_holds_key(value, key) for value in data.values())


def file_generation(path: str | os.PathLike) -> int:
    """The ROS generation of the parameter file ``path`` (see :func:`_generation`)."""
    try:
        return _generation(read_param_file(path, {}))
    except ParamFileError as error:
        if "$(var" in str(error):
            return 2  # launch substitutions: a ROS 2 launch reads it
        raise ControllerConfigError(str(error)) from None


def parse_controller_config(data: Any, source: str, *, strict: bool = True):
    """The controller manager and controllers described by YAML ``data`` (one
    parameter file; ``source`` names it in error messages). See
    :func:`parse_controller_documents`."""
    return parse_controller_documents([(source, data)], strict=strict)


def parse_controller_documents(
    documents: Sequence[tuple[str, Any]], *, strict: bool = True
) -> ControllerManagerConfig:
    """The controller manager and controllers of the parameter files ``documents``
    ((file, YAML data), in the order given: later values win), all ROS 2 or all ROS 1.

    With ``strict``, a controller whose parameters cannot be used is an error; without,
    it is noted with one warning and fails only when activated (as upstream's
    controller manager, which reads a controller's parameters when it loads it)."""
    generations = {}
    for source, data in documents:
        if data is not None and not isinstance(data, dict):
            raise ControllerConfigError(f"{source}: expected a mapping of ROS nodes, got {data!r}")
        generations[source] = _generation(data)
    ros1 = [source for source, generation in generations.items() if generation == 1]
    ros2 = [source for source, generation in generations.items() if generation == 2]
    if ros1 and ros2:
        raise ControllerConfigError(
            f"{ros1[0]}: a ROS 1 (ros_control) file, given with the ROS 2 file {ros2[0]}; "
            "give files of one ROS generation"
        )
    try:
        if ros1:
            return _parse_ros1(documents, strict)
        return _parse_ros2(documents, strict)
    except ParamFileError as error:
        raise ControllerConfigError(str(error)) from None


def _parse_ros2(documents: Sequence[tuple[str, Any]], strict: bool) -> ControllerManagerConfig:
    entries: dict[str, NodeEntry] = {}
    for source, data in documents:
        collect_nodes(data, source, entries)
    sources = [source for source, _ in documents]
    namespace = _namespace(entries)
    manager = node_parameters(entries, f"{namespace}/controller_manager")
    names = _controller_names(entries, namespace, manager)
    if not manager.found and not names:
        raise _fail(
            sources[0],
            "controller_manager",
            "no 'controller_manager: ros__parameters:' node and no node with a 'type' "
            "parameter (ROS 2), and no mapping with a 'type' (a ROS 1 controller)",
        )
    file, key = manager.where("update_rate")
    update_rate = check_update_rate(
        manager.params.get("update_rate", DEFAULT_UPDATE_RATE), f"{file}: {key}.update_rate"
    )
    config = ControllerManagerConfig(
        update_rate=update_rate, source=", ".join(sources), sources=sources
    )
    for name, value in manager.params.items():
        if name not in names and name != "update_rate" and name not in _MANAGER_PARAMETERS:
            file, key = manager.where(name)
            _logger.warning(
                "%s: %s.%s: controller_manager (ROS 2 Jazzy) does not declare %r (%r); "
                "ignored, as ROS ignores it",
                file,
                key,
                name,
                name,
                value,
            )
    used = {id(entry) for entry in manager.entries}
    for name in names:
        node = _controller_node(entries, namespace, name)
        used.update(id(entry) for entry in node.entries)
        config.controllers[name] = _deferred(
            strict, name, lambda n=name, p=node: _ros2_controller(n, p, manager, update_rate)
        )
    for entry in entries.values():
        if id(entry) in used or entry.wildcard:
            continue
        if entry.namespace != namespace:
            _logger.warning(
                "%s: %s: a node of namespace %s, not of the controller manager's (%s); ignored",
                entry.file,
                entry.key,
                entry.namespace or "/",
                namespace or "/",
            )
        else:
            _logger.warning(
                "%s: %s: '%s' is not a controller of controller_manager; ignored",
                entry.file,
                entry.key,
                entry.basename,
            )
    return config


def _namespace(entries: dict[str, NodeEntry]) -> str:
    """The namespace of the controller manager the files describe: that of the first
    fully qualified ``controller_manager`` key, else of the first node key without
    wildcards; "" (the root) without one."""
    concrete = [entry for entry in entries.values() if not entry.wildcard]
    for entry in [e for e in concrete if e.basename == "controller_manager"] + concrete:
        return entry.namespace
    return ""


def _controller_names(
    entries: dict[str, NodeEntry], namespace: str, manager: NodeParameters
) -> list[str]:
    """The controllers: those the manager lists (``<name>: {type: ...}``), then each
    node with a ``type`` parameter of its own, in the files' order."""
    names = [
        str(name)
        for name, value in manager.params.items()
        if (isinstance(value, dict) or value is None) and name not in _MANAGER_PARAMETERS
    ]
    for entry in entries.values():
        name = entry.basename
        if "*" in name or name == "controller_manager" or name in names:
            continue
        if "type" in _controller_node(entries, namespace, name).params:
            names.append(name)
    return names


def _controller_node(entries: dict[str, NodeEntry], namespace: str, name: str) -> NodeParameters:
    """The parameters of controller ``name``'s node (``<namespace>/<name>``); a file
    whose keys name it in another namespace only gives it those."""
    node = node_parameters(entries, f"{namespace}/{name}")
    if any(entry.basename == name for entry in node.entries):
        return node
    others = {p: e for p, e in entries.items() if e.basename == name and not e.wildcard}
    if not others:
        return node
    wildcards = {p: e for p, e in entries.items() if e.wildcard and e.matches(f"/{name}")}
    return node_parameters({**wildcards, **others}, next(iter(others)))


def _deferred(strict: bool, name: str, build) -> ControllerConfig:
    """``build()``; without ``strict``, its error as an unusable controller (noted with
    one warning) that fails when activated."""
    try:
        return build()
    except ControllerConfigError as error:
        if strict:
            raise
        _logger.warning("%s; '%s' fails if activated", error, name)
        return ControllerConfig(name, "", [], None, {}, "", unsupported=str(error))


def _ros2_controller(
    name: str, node: NodeParameters, manager: NodeParameters, update_rate: int
) -> ControllerConfig:
    """Controller ``name`` of the manager, with its node's parameters."""
    entry = manager.params.get(name) or {}
    manager_file, manager_key = manager.where(name)
    key = f"{manager_key}.{name}"
    for entry_key, value in entry.items():
        if entry_key != "type" and entry_key not in _IGNORED_ENTRY_KEYS:
            _logger.warning(
                "%s: %s.%s: controller_manager (ROS 2 Jazzy) does not declare %r (%r); "
                "ignored, as ROS ignores it",
                manager_file,
                key,
                entry_key,
                f"{name}.{entry_key}",
                value,
            )
    params = node.params
    node_file, node_key = node.where()
    type_ = entry.get("type", params.get("type"))
    type_where = (manager_file, f"{key}.type") if "type" in entry else _at(node.where, "type")
    if type_ is None:
        raise _fail(manager_file, key, f"The 'type' param was not defined for '{name}'")
    if "type" in params and "type" in entry and params["type"] != type_:
        file, at = node.where("type")
        raise _fail(file, f"{at}.type", f"type {params['type']!r} differs from {type_!r}")
    return _controller(
        name, type_, params, node.where, type_where=type_where, update_rate=update_rate
    )


def _controller(
    name: str,
    type_: Any,
    raw: dict[str, Any],
    where,
    *,
    type_where: tuple[str, str],
    update_rate: int,
    ros: int = 2,
    namespace: str = "",
) -> ControllerConfig:
    """The controller ``name`` of type ``type_`` (written at ``type_where``: file, key)
    with its parameters ``raw``; ``where(parameter)`` is the (file, node key) that set
    a parameter. An unknown type gives an unsupported entry."""
    type_file, type_key = type_where
    file, key = where("")
    if not isinstance(type_, str) or not type_:
        raise _fail(type_file, type_key, f"expected a controller type string, got {type_!r}")
    try:
        cls = lookup(type_, ros=ros)
    except KeyError as error:
        unsupported = f"{type_file}: {type_key}: {error.args[0]}"
        _logger.warning(
            "%s: %s: controller type %r is not supported; %r fails if activated",
            type_file,
            type_key,
            type_,
            name,
        )
        return ControllerConfig(
            name, type_, [], None, raw, key, ros=ros, namespace=namespace,
            unsupported=unsupported, file=file,
        )  # fmt: skip
    _check_node_parameters(raw, where, update_rate, cls, ros)
    undeclared: list[str] = []
    ignored: list[str] = []
    try:
        params = load_parameters(cls, raw, undeclared=undeclared, ignored=ignored)
    except ParameterError as error:
        raise _fail(*_at(where, error.parameter), error.problem) from None
    for parameter in ignored:
        _logger.warning(
            "%s: %s: declared by %s, not simulated: ignored (it does not change the motion here)",
            *_at(where, parameter),
            type_,
        )
    release = "ROS 2 Jazzy" if ros == 2 else "ROS 1"
    for parameter in undeclared:
        at_file, at_key = _at(where, parameter)
        _logger.warning(
            "%s: %s: %s (%s) does not declare it; ignored, as ROS ignores it",
            at_file,
            at_key,
            type_,
            release,
        )
    joints = cls.joints_of(params)
    return ControllerConfig(
        name, type_, joints, params, raw, key, ros=ros, namespace=namespace, file=file
    )


def _at(where, parameter: str) -> tuple[str, str]:
    """(file, ``<node key>.<parameter>``) of a parameter."""
    file, key = where(parameter)
    return file, f"{key}.{parameter}"


def _check_node_parameters(raw: dict[str, Any], where, update_rate: int, cls, ros: int) -> None:
    """The parameters every ros2_control controller node has (``update_rate``,
    ``is_async``). A controller's own rate above the manager's is the manager's, as
    upstream runs it; below it, a broadcaster's is ignored (it publishes at the
    manager's), a command controller's refused (it would move at another rate)."""
    if ros != 2:
        return
    own = raw.get("update_rate")
    if own is not None and own != update_rate:
        file, key = _at(where, "update_rate")
        if isinstance(own, bool) or not isinstance(own, int) or own <= 0:
            raise _fail(file, key, f"update_rate={own!r} must be a positive integer [Hz]")
        if own > update_rate or cls.broadcaster:
            _logger.warning(
                "%s: %s: update_rate=%d: runs at controller_manager's %d Hz (each controller "
                "runs in the manager's update)",
                file,
                key,
                own,
                update_rate,
            )
        else:
            raise _fail(
                file,
                key,
                f"update_rate={own!r} differs from controller_manager's {update_rate}; a "
                "controller's own rate is not simulated (each runs at the manager's)",
            )
    if raw.get("is_async", False) is not False:
        file, key = _at(where, "is_async")
        raise _fail(
            file,
            key,
            f"is_async={raw['is_async']!r} is not simulated: every controller runs "
            "synchronously in the manager's update",
        )


def _parse_ros1(documents: Sequence[tuple[str, Any]], strict: bool) -> ControllerManagerConfig:
    """The controllers of ROS 1 (ros_control) parameter files, loaded in turn into one
    tree: every mapping with a ``type``, in any namespace."""
    tree, origins = merge_trees(list(documents))
    sources = [source for source, _ in documents]
    config = ControllerManagerConfig(
        update_rate=ROS1_UPDATE_RATE, source=", ".join(sources), sources=sources, ros=1
    )

    def walk(mapping: dict[str, Any], path: str) -> tuple[int, list[str]]:
        """(controllers found under ``mapping``, keys that hold none)."""
        found, ignored = 0, []
        for raw_key, value in mapping.items():
            key = str(raw_key)
            where = f"{path}/{key}" if path else key
            file = origins.get(where, sources[0])
            if key == "gazebo_ros_control" and isinstance(value, dict):
                ignored += _gazebo_pid_gains(value, file, where, config.pid_gains)
                continue
            if isinstance(value, dict) and "type" in value:
                if key in config.controllers:
                    raise _fail(
                        file,
                        where,
                        f"controller '{key}' is also defined at {config.controllers[key].key}",
                    )
                params = {str(k): v for k, v in value.items() if k != "type"}
                config.controllers[key] = _deferred(
                    strict,
                    key,
                    lambda k=key, p=params, w=where, f=file, t=value["type"]: _controller(
                        k, t, p, lambda _, f=f, w=w: (f, w), type_where=(f, f"{w}.type"),
                        update_rate=ROS1_UPDATE_RATE, ros=1,
                        namespace=f"/{path}" if path else "",
                    ),
                )  # fmt: skip
                found += 1
            elif isinstance(value, dict):
                inner, inner_ignored = walk(value, where)
                found += inner
                ignored += inner_ignored if inner else [(file, where)]
            else:
                ignored.append((file, where))
        return found, ignored

    _, ignored = walk(tree, "")
    for file, where in ignored:
        _logger.warning("%s: %s holds no controller (no 'type'); ignored", file, where)
    return config


def _gazebo_pid_gains(
    block: dict[str, Any], source: str, where: str, gains: dict[str, tuple[float, float, float]]
) -> list[tuple[str, str]]:
    """Reads ``gazebo_ros_control: {pid_gains: {<joint>: {p, i, d}}}`` into ``gains``;
    returns the (file, key) it ignores."""
    ignored = [(source, f"{where}/{key}") for key in block if key != "pid_gains"]
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


def load_controller_config(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    *,
    strict: bool = True,
    arguments: dict[str, str] | None = None,
    prefix: str = "",
    joint_names: Sequence[str] = (),
) -> ControllerManagerConfig:
    """The controller manager configuration in the parameter file(s) ``paths`` (several
    as ``--param-file`` takes them: in order, later values winning). ``arguments``:
    the launch arguments ``$(var name)`` stands for (else the defaults the launch files
    of the file's package declare). ``strict``: see
    :func:`parse_controller_documents`.

    ``prefix``: the description's joints (``joint_names``) carry it (its ``prefix``
    xacro argument): a joint the files name without it, as a launch file substitutes
    the prefix into them, is read as the prefixed one (one info line); a joint that
    matches neither stays, for :func:`validate_joints` to refuse."""
    files = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    if not files:
        raise ControllerConfigError("no controller file given")
    documents = []
    for path in files:
        try:
            documents.append((str(Path(path)), read_param_file(path, arguments)))
        except ParamFileError as error:
            raise ControllerConfigError(str(error)) from None
    config = parse_controller_documents(documents, strict=strict)
    if not prefix:
        return config
    known = set(joint_names)
    named = {joint for controller in config.controllers.values() for joint in controller.joints}
    renamed = {
        joint: prefix + joint for joint in named if joint not in known and prefix + joint in known
    }
    if not renamed:
        return config
    _logger.info(
        "%s names the description's joints without their prefix %r: read as %s",
        config.source,
        prefix,
        ", ".join(renamed[joint] for joint in sorted(renamed)),
    )
    documents = [(source, _renamed(data, renamed)) for source, data in documents]
    return parse_controller_documents(documents, strict=strict)


def _renamed(data: Any, names: dict[str, str]) -> Any:
    """``data`` (a parameter file's YAML) with each string and mapping key of ``names``
    replaced by its value (a joint named in a list, or as a key of its gains)."""
    if isinstance(data, dict):
        return {names.get(key, key): _renamed(value, names) for key, value in data.items()}
    if isinstance(data, list):
        return [_renamed(value, names) for value in data]
    if isinstance(data, str):
        return names.get(data, data)
    return data


def validate_joints(
    config: ControllerManagerConfig,
    robot_joint_names: list[str] | tuple[str, ...],
    source: str,
    names: Sequence[str] | None = None,
) -> None:
    """Fails if a controller (of ``names``, default all) names a joint the robot
    (described by ``source``) lacks."""
    known = list(robot_joint_names)
    for controller in config.controllers.values():
        if names is not None and controller.name not in names:
            continue
        for joint in controller.joints:  # none for an unsupported type
            where = "joint" if "joint" in controller.parameters else "joints"
            if where == "joints":
                where = controller.controller_class.joint_key(controller.params, joint)
            if joint not in known:
                raise ControllerConfigError(
                    f"{controller.file or config.source}: {controller.key}.{where}: unknown joint "
                    f"'{joint}' of controller '{controller.name}'; {source} has known joints: "
                    f"{', '.join(known)}"
                )
