"""A ros2_control controller YAML, loaded into typed dataclasses.

The file is the one a ROS 2 user already has::

    controller_manager:
      ros__parameters:
        update_rate: 100
        position_controller:
          type: position_controllers/JointGroupPositionController
    position_controller:
      ros__parameters:
        joints: [j0, j1, j2, j3]

Node blocks may also sit under a namespace key (``/**:``, ``/robot:``) or be
named with one (``/**/controller_manager:``, ``robot/position_controller:``);
ROS parameter names with dots (``constraints.goal_time: 0.5``) are the same
as nested mappings. Every error names the file and the key at fault, as
``<file>: <key>: <problem>``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

_logger = logging.getLogger("armando_drake.control.config")

JOINT_STATE_BROADCASTER = "joint_state_broadcaster/JointStateBroadcaster"
JOINT_GROUP_POSITION_CONTROLLER = "position_controllers/JointGroupPositionController"
FORWARD_COMMAND_CONTROLLER = "forward_command_controller/ForwardCommandController"
JOINT_TRAJECTORY_CONTROLLER = "joint_trajectory_controller/JointTrajectoryController"
SUPPORTED_TYPES = (
    JOINT_STATE_BROADCASTER,
    JOINT_GROUP_POSITION_CONTROLLER,
    FORWARD_COMMAND_CONTROLLER,
    JOINT_TRAJECTORY_CONTROLLER,
)

DEFAULT_UPDATE_RATE = 100  # [Hz] upstream controller_manager default

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
_IGNORED_CONTROLLER_PARAMETERS = {
    JOINT_STATE_BROADCASTER: frozenset(
        {
            "interfaces",
            "extra_joints",
            "use_local_topics",
            "use_urdf_to_filter",
            "map_interface_to_joint_state",
            "frame_id",
        }
    ),
    JOINT_GROUP_POSITION_CONTROLLER: frozenset(),
    FORWARD_COMMAND_CONTROLLER: frozenset(),
    JOINT_TRAJECTORY_CONTROLLER: frozenset(
        {
            "open_loop_control",
            "state_publish_rate",
            "action_monitor_rate",
            "allow_integration_in_goal_trajectories",
            "gains",
            "cmd_timeout",
            "set_last_command_interface_value_as_state_on_activation",
            "interpolate_from_desired_state",
            "speed_scaling",
            "speed_scaling_interface_name",
        }
    ),
}
_KNOWN_CONTROLLER_PARAMETERS = {
    JOINT_STATE_BROADCASTER: frozenset({"joints"}),
    JOINT_GROUP_POSITION_CONTROLLER: frozenset({"joints"}),
    FORWARD_COMMAND_CONTROLLER: frozenset({"joints", "interface_name"}),
    JOINT_TRAJECTORY_CONTROLLER: frozenset(
        {
            "joints",
            "command_joints",
            "command_interfaces",
            "state_interfaces",
            "allow_partial_joints_goal",
            "interpolation_method",
            "allow_nonzero_velocity_at_trajectory_end",
            "constraints",
        }
    ),
}
_IGNORED_ENTRY_KEYS = frozenset({"params_file", "fallback_controllers"})
_COMMON_IGNORED = frozenset({"use_sim_time", "type", "update_rate", "is_async"})

COMMAND_INTERFACES = ("position", "velocity", "acceleration", "effort")
STATE_INTERFACES = ("position", "velocity", "acceleration")
INTERPOLATION_METHODS = ("splines", "none")


class ControllerConfigError(ValueError):
    """A controller YAML that cannot be used, with the file and key at fault."""


@dataclass
class JointTrajectoryControllerParams:
    """The parameters of ``joint_trajectory_controller/JointTrajectoryController``."""

    joints: list[str]  # controller joints, in the controller's order
    command_interfaces: list[str] = field(default_factory=lambda: ["position"])
    state_interfaces: list[str] = field(default_factory=lambda: ["position", "velocity"])
    allow_partial_joints_goal: bool = False  # accept goals naming only some joints
    interpolation_method: str = "splines"  # splines | none (hold each point)
    allow_nonzero_velocity_at_trajectory_end: bool = False
    goal_time: float = 0.0  # [s] after the end to reach the goal; 0 = wait forever
    stopped_velocity_tolerance: float = 0.01  # [rad/s] "stopped" at the goal; 0 = unchecked
    # [rad] per joint: allowed |measured - desired| while running; absent or 0 = unchecked.
    trajectory_tolerance: dict[str, float] = field(default_factory=dict)
    # [rad] per joint: allowed |measured - goal| after the end; absent or 0 = unchecked.
    goal_tolerance: dict[str, float] = field(default_factory=dict)


@dataclass
class ControllerConfig:
    """One controller declared under ``controller_manager``."""

    name: str  # the controller's name (its topics are /<name>/...)
    type: str  # the plugin type as written, one of SUPPORTED_TYPES
    joints: list[str]  # joints it claims, in its order; [] = all (broadcaster only)
    interface_name: str | None = None  # command interface (position controllers)
    params: JointTrajectoryControllerParams | None = None  # trajectory controllers only
    parameters: dict[str, Any] = field(default_factory=dict)  # its ros__parameters as read
    key: str = ""  # where its ros__parameters are in the file, for error messages

    @property
    def kind(self) -> str:
        """``joint_state_broadcaster`` | ``position`` | ``joint_trajectory``."""
        if self.type == JOINT_STATE_BROADCASTER:
            return "joint_state_broadcaster"
        if self.type == JOINT_TRAJECTORY_CONTROLLER:
            return "joint_trajectory"
        return "position"


@dataclass
class ControllerManagerConfig:
    """The ``controller_manager`` node and the controllers it loads."""

    update_rate: int = DEFAULT_UPDATE_RATE  # [Hz] rate of every controller update
    controllers: dict[str, ControllerConfig] = field(default_factory=dict)  # by name
    source: str = ""  # the file it was read from, for error messages


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


def _joint_list(value: Any, source: str, key: str, *, allow_empty: bool = False) -> list[str]:
    if value is None and allow_empty:
        return []
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise _fail(source, key, f"expected a list of joint names, got {value!r}")
    if not value and not allow_empty:
        raise _fail(source, key, "'joints' parameter is empty")
    seen = set()
    for name in value:
        if name in seen:
            raise _fail(source, key, f"joint '{name}' is listed more than once")
        seen.add(name)
    return list(value)


def _bool(value: Any, source: str, key: str) -> bool:
    if not isinstance(value, bool):
        raise _fail(source, key, f"expected true or false, got {value!r}")
    return value


def _non_negative(value: Any, source: str, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(source, key, f"expected a number, got {value!r}")
    if not math.isfinite(value) or value < 0:
        raise _fail(source, key, f"{key.rsplit('.', 1)[-1]}={value!r} must be >= 0")
    return float(value)


def _interfaces(value: Any, allowed: tuple[str, ...], source: str, key: str) -> list[str]:
    if value is None:
        raise _fail(source, key, f"parameter is missing; give a list from {list(allowed)}")
    if not isinstance(value, list) or not value:
        raise _fail(source, key, f"expected a non-empty list from {list(allowed)}, got {value!r}")
    for name in value:
        if name not in allowed:
            raise _fail(source, key, f"unknown interface {name!r}; expected one of {list(allowed)}")
    if len(set(value)) != len(value):
        raise _fail(source, key, f"interfaces listed more than once: {value!r}")
    if "position" not in value:
        raise _fail(source, key, f"{value!r} has no 'position'; the simulation drives positions")
    return list(value)


def _trajectory_params(
    params: dict[str, Any], joints: list[str], source: str, key: str
) -> JointTrajectoryControllerParams:
    result = JointTrajectoryControllerParams(
        joints=joints,
        command_interfaces=_interfaces(
            params.get("command_interfaces"),
            COMMAND_INTERFACES,
            source,
            f"{key}.command_interfaces",
        ),
        state_interfaces=_interfaces(
            params.get("state_interfaces"), STATE_INTERFACES, source, f"{key}.state_interfaces"
        ),
    )
    if "effort" in result.command_interfaces:
        raise _fail(
            source,
            f"{key}.command_interfaces",
            "the 'effort' command interface is not simulated; use position",
        )
    for name in ("allow_partial_joints_goal", "allow_nonzero_velocity_at_trajectory_end"):
        if name in params:
            setattr(result, name, _bool(params[name], source, f"{key}.{name}"))
    method = params.get("interpolation_method", "splines")
    if method not in INTERPOLATION_METHODS:
        raise _fail(
            source,
            f"{key}.interpolation_method",
            f"unknown method {method!r}; expected one of {list(INTERPOLATION_METHODS)}",
        )
    result.interpolation_method = method
    constraints = params.get("constraints") or {}
    if not isinstance(constraints, dict):
        raise _fail(source, f"{key}.constraints", f"expected a mapping, got {constraints!r}")
    for name, value in constraints.items():
        where = f"{key}.constraints.{name}"
        if name in ("goal_time", "stopped_velocity_tolerance"):
            setattr(result, name, _non_negative(value, source, where))
        elif name in joints:
            if not isinstance(value, dict):
                raise _fail(source, where, f"expected 'trajectory' and 'goal', got {value!r}")
            for tolerance, number in value.items():
                if tolerance == "trajectory":
                    result.trajectory_tolerance[name] = _non_negative(
                        number, source, f"{where}.trajectory"
                    )
                elif tolerance == "goal":
                    result.goal_tolerance[name] = _non_negative(number, source, f"{where}.goal")
                else:
                    raise _fail(
                        source,
                        f"{where}.{tolerance}",
                        "unknown tolerance; expected trajectory, goal",
                    )
        else:
            raise _fail(
                source,
                where,
                f"'{name}' is neither goal_time, stopped_velocity_tolerance nor one of the "
                f"controller's joints {joints}",
            )
    return result


def _controller(
    name: str, type_: str, params: dict[str, Any], source: str, key: str
) -> ControllerConfig:
    known = _KNOWN_CONTROLLER_PARAMETERS[type_]
    ignored = _IGNORED_CONTROLLER_PARAMETERS[type_] | _COMMON_IGNORED
    for parameter in params:
        if parameter not in known and parameter not in ignored:
            raise _fail(
                source,
                f"{key}.{parameter}",
                f"unknown parameter for {type_}; known: {sorted(known)}",
            )
        if parameter in ignored and parameter not in _COMMON_IGNORED:
            _logger.info("%s: %s.%s is not simulated; ignored", source, key, parameter)
    if type_ == JOINT_STATE_BROADCASTER:
        joints = _joint_list(params.get("joints"), source, f"{key}.joints", allow_empty=True)
        return ControllerConfig(name, type_, joints, parameters=params, key=key)
    if "joints" not in params:
        raise _fail(source, f"{key}.joints", "'joints' parameter is missing")
    joints = _joint_list(params["joints"], source, f"{key}.joints")
    if type_ == JOINT_TRAJECTORY_CONTROLLER:
        command_joints = params.get("command_joints")
        if command_joints not in (None, [], joints):
            raise _fail(
                source,
                f"{key}.command_joints",
                f"{command_joints!r} differs from joints {joints}; not simulated",
            )
        trajectory = _trajectory_params(params, joints, source, key)
        return ControllerConfig(name, type_, joints, "position", trajectory, params, key)
    if type_ == FORWARD_COMMAND_CONTROLLER:
        interface = params.get("interface_name")
        if not interface:
            raise _fail(source, f"{key}.interface_name", "'interface_name' parameter is missing")
        if interface != "position":
            raise _fail(
                source,
                f"{key}.interface_name",
                f"interface_name={interface!r} is not supported; only 'position' is simulated",
            )
    return ControllerConfig(name, type_, joints, "position", None, params, key)


def parse_controller_config(data: Any, source: str) -> ControllerManagerConfig:
    """The controller manager and controllers described by YAML ``data``.

    ``source`` names the file (or other origin) in error messages.
    """
    if not isinstance(data, dict):
        raise ControllerConfigError(f"{source}: expected a mapping of ROS nodes, got {data!r}")
    nodes: dict[str, tuple[str, dict[str, Any]]] = {}
    _collect_nodes(data, source, "", nodes)
    if "controller_manager" not in nodes:
        raise _fail(source, "controller_manager", "no 'controller_manager: ros__parameters:' node")
    manager_key, manager = nodes.pop("controller_manager")
    update_rate = manager.get("update_rate", DEFAULT_UPDATE_RATE)
    if isinstance(update_rate, bool) or not isinstance(update_rate, int) or update_rate <= 0:
        raise _fail(
            source,
            f"{manager_key}.update_rate",
            f"update_rate={update_rate!r} must be a positive integer [Hz]",
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
        if type_ not in SUPPORTED_TYPES:
            raise _fail(
                source,
                f"{key}.type",
                f"unknown controller type {type_!r}; supported: {', '.join(SUPPORTED_TYPES)}",
            )
        config.controllers[name] = _controller(name, type_, params, source, node_key)
    for name, (node_key, _) in nodes.items():
        _logger.warning(
            "%s: %s: '%s' is not a controller of controller_manager; ignored",
            source,
            node_key,
            name,
        )
    return config


def load_controller_config(path: str | Path) -> ControllerManagerConfig:
    """The controller manager configuration in the YAML file at ``path``."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ControllerConfigError(f"{path}: cannot read controller file: {error}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        problem = getattr(error, "problem", None) or str(error)
        raise ControllerConfigError(f"{where}: not valid YAML: {problem}") from None
    return parse_controller_config(data, str(path))


def validate_joints(
    config: ControllerManagerConfig, robot_joint_names: list[str] | tuple[str, ...], source: str
) -> None:
    """Fails if a controller names a joint the robot (described by ``source``) lacks."""
    known = list(robot_joint_names)
    for controller in config.controllers.values():
        for joint in controller.joints:
            if joint not in known:
                raise ControllerConfigError(
                    f"{config.source}: {controller.key}.joints: unknown joint "
                    f"'{joint}' of controller '{controller.name}'; {source} has known joints: "
                    f"{', '.join(known)}"
                )
