"""The controller registry: every ros2_control controller type, by its ROS type string.

As pluginlib does for upstream's controller_manager, one table maps a type
string (``position_controllers/JointGroupPositionController``, ...) to the
class that implements it. Each type is one module of this package that
registers itself with :func:`register`; the YAML loader, the world builder and
the :class:`~armando_drake.control.manager.ControllerManager` look types up
here and never compare type strings. A controller class declares:

- ``parameters``: its parameters dataclass, loaded from the controller's
  ``ros__parameters`` with Drake's ``yaml_load_typed`` (every field commented
  with its meaning) whose fields are declared with
  :func:`~armando_drake.tools.schema.param` (unit, range, choices, ``required``, ...:
  checked by the one checker, :func:`check_parameters`); the rules between fields in
  its ``check(self)``, raising :class:`~armando_drake.tools.schema.Refusal`; the
  YAML loader's error names the file, the node key and the parameter;
- ``ignored_parameters``: upstream parameters it accepts and does not simulate;
- ``refused_parameters``: upstream parameters it refuses, each with the reason (the
  whole error after the parameter's name);
- ``command_interface(params)``: the command interface it claims on each of its
  joints (``position``, ``velocity`` or ``effort``; ``None`` for a broadcaster);
- ``message`` and ``topic``: the command message class it reads and the
  topic it reads it on (``/<controller>/<topic>``);
- its logic: ``initial_memory()`` and ``update(now, message, memory, measure)``
  (see :class:`Controller`).

ROS 1 controller YAML (``ros_control``) names some types the same as ROS 2
(``position_controllers/JointGroupPositionController``) but reads them on
other topics (``command`` instead of ``commands``), and has types ROS 2 lacks
(``effort_controllers/JointPositionController``); so the registry has one
table per ROS generation, ``register(type, ros=1)`` for the ROS 1 ones
(:mod:`.ros1`, mapped onto the same logic and command interfaces as their
ROS 2 counterparts).

The rest of the code never names a type string: it asks the registry by *kind*
(``register(type, kind="position")``; :func:`controller_type_for`), finds the
controller of a YAML that an activation names by name or type with
:func:`find_controller`, and gets the configuration of a robot that comes without
one from :func:`default_controller_config`.

Adding a controller type is one module that subclasses :class:`Controller` and
decorates it with ``@register("<ros type>")``. The modules of this package are
found and imported when it is imported (:func:`pkgutil.iter_modules`: no list to
keep); a module of another distribution is declared as a Python entry point in the
group ``armando_drake.controllers`` (as pluginlib's plugin XML declares a
library) and imported once, before the first lookup::

    [project.entry-points."armando_drake.controllers"]
    my_controllers = "my_package.my_controllers"

A module that fails to import is an :class:`ImportError` naming it.

Every rejected message is logged on ``armando_drake.control.controllers`` with
upstream's wording and counted in the controller's status; the controller keeps
its previous command.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.metadata
import logging
import pkgutil
import typing
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import yaml
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.framework import EventStatus

from armando_drake.messages.types import ControllerStatus
from armando_drake.tools.schema import check_config

if TYPE_CHECKING:  # the YAML's dataclasses import this package
    from armando_drake.control.config import ControllerManagerConfig

_logger = logging.getLogger("armando_drake.control.controllers")

COMMAND_INTERFACES = ("position", "velocity", "effort")  # what the hardware simulates

# What an update with nothing to do returns: Drake then neither copies the system's
# state back nor invalidates what depends on it.
DID_NOTHING = EventStatus.DidNothing()


class ParameterError(ValueError):
    """A bad controller parameter: ``parameter`` is its (dotted) name, the message the
    problem. The YAML loader adds the file and the node key in front."""

    def __init__(self, parameter: str, problem: str):
        super().__init__(problem)
        self.parameter = parameter
        self.problem = problem


class Rejected(Exception):
    """A message the controller drops; the argument is the logged reason."""


# --------------------------------------------------------------------------------------
# The registry


# One table per ROS generation: ROS 2 (ros2_control) and ROS 1 (ros_control).
_REGISTRIES: dict[int, dict[str, type[Controller]]] = {1: {}, 2: {}}
_REGISTRY = _REGISTRIES[2]
# Per ROS generation, the type of each kind (see register()).
_KINDS: dict[int, dict[str, str]] = {1: {}, 2: {}}

# The entry-point group of the controller modules of other distributions.
ENTRY_POINT_GROUP = "armando_drake.controllers"


def _table(ros: int) -> dict[str, type[Controller]]:
    if ros not in _REGISTRIES:
        raise ValueError(f"ros={ros!r} must be 1 (ros_control) or 2 (ros2_control)")
    _load_entry_points_once()
    return _REGISTRIES[ros]


def register(
    type_name: str, *, ros: int = 2, kind: str | None = None
) -> Callable[[type[Controller]], type[Controller]]:
    """Class decorator: registers a :class:`Controller` subclass under ``type_name``
    (the ROS plugin type string) of ROS generation ``ros`` (2: ros2_control, 1:
    ros_control). ``kind`` names the role the rest of the code asks for by
    (``"broadcaster"``, ``"position"``, ``"trajectory"``: the joint state broadcaster,
    the controller a sequence of position targets drives, the one a JointTrajectory
    drives); one type per kind and generation. Registering a name (or a kind) twice
    in one generation is an error."""
    if ros not in _REGISTRIES:
        raise ValueError(f"ros={ros!r} must be 1 (ros_control) or 2 (ros2_control)")
    table, kinds = _REGISTRIES[ros], _KINDS[ros]

    def decorate(cls: type[Controller]) -> type[Controller]:
        if type_name in table and table[type_name] is not cls:
            raise ValueError(
                f"controller type {type_name!r} is already registered by "
                f"{table[type_name].__module__}.{table[type_name].__qualname__}"
            )
        if kind is not None and kinds.get(kind, type_name) != type_name:
            raise ValueError(
                f"kind={kind!r} of {type_name!r} is already the kind of {kinds[kind]!r}"
            )
        if not dataclasses.is_dataclass(cls.parameters):
            raise TypeError(f"{cls.__qualname__}.parameters must be a dataclass")
        table[type_name] = cls
        if kind is not None:
            kinds[kind] = type_name
        cls.type_names = (*cls.__dict__.get("type_names", ()), type_name)
        cls.ros = ros
        return cls

    return decorate


def unregister(type_name: str, *, ros: int = 2) -> None:
    """Removes a registered type, and its kind (for tests that register a toy type)."""
    _table(ros).pop(type_name, None)
    kinds = _KINDS[ros]
    for kind in [kind for kind, name in kinds.items() if name == type_name]:
        del kinds[kind]


def lookup(type_name: str, *, ros: int = 2) -> type[Controller]:
    """The class registered under ``type_name`` (ROS generation ``ros``); KeyError
    naming the known types."""
    table = _table(ros)
    try:
        return table[type_name]
    except KeyError:
        raise KeyError(
            f"unknown controller type {type_name!r}; supported: {', '.join(table)}"
        ) from None


def registered_types(*, ros: int = 2) -> tuple[str, ...]:
    """Every registered type string of ROS generation ``ros``, in registration order."""
    return tuple(_table(ros))


def types_accepting(message: type, interface: str | None = None) -> tuple[str, ...]:
    """The registered types whose command message is ``message`` (and, when given,
    whose fixed command interface is ``interface``), in registration order."""
    return tuple(
        name
        for name, cls in _table(2).items()
        if cls.message is message
        and (interface is None or cls.fixed_interface in (None, interface))
    )


def controller_kinds(*, ros: int = 2) -> tuple[str, ...]:
    """The kinds some type of ROS generation ``ros`` is registered as, in registration
    order."""
    _table(ros)
    return tuple(_KINDS[ros])


def controller_type_for(kind: str, *, ros: int = 2) -> str:
    """The type string registered as ``kind`` in ROS generation ``ros``; KeyError
    naming the known kinds."""
    _table(ros)
    try:
        return _KINDS[ros][kind]
    except KeyError:
        known = ", ".join(_KINDS[ros]) or "none"
        raise KeyError(f"no controller type of kind {kind!r}; kinds: {known}") from None


def find_controller(entry: str, config: ControllerManagerConfig, where: str = "") -> str:
    """The controller of ``config`` an activation ``entry`` names: a controller name as
    it is, or for ``type:<plugin>`` the first supported controller of that type.

    Else, for a broadcaster type, the first broadcaster (ROS 1's joint state
    controller for ROS 2's broadcaster); for a command type, one of another type that
    reads the same message on the same command interface (a ForwardCommandController
    on position for the group position controller, ROS 1's position trajectory
    controller for the trajectory controller) or, for a position type, one that takes
    positions whatever it commands (ROS 1's effort trajectory controller). No match
    is a :class:`LookupError` starting with ``where`` (the scenario's file or
    override) and naming the controllers the file defines."""
    if not entry.startswith("type:"):
        return entry
    wanted = entry[len("type:") :]
    try:
        wanted_class = lookup(wanted)
    except KeyError as error:
        raise LookupError(f"{where}controllers.activate: {error.args[0]}") from None
    supported = [(name, c) for name, c in config.controllers.items() if c.supported]
    matches = [name for name, c in supported if c.type == wanted]
    if not matches and wanted_class.broadcaster:
        matches = [name for name, c in supported if c.controller_class.broadcaster]
    if not matches and not wanted_class.broadcaster:
        matches = [
            name
            for name, c in supported
            if c.controller_class.message is wanted_class.message
            and (
                c.interface_name == wanted_class.fixed_interface
                or (wanted_class.fixed_interface == "position" and c.position_targets)
            )
        ]
    if matches:
        return matches[0]
    raise LookupError(
        f"{where}controllers.activate asks for a {wanted} controller; {config.source} "
        f"defines none (defined: {', '.join(config.controllers) or 'none'})"
    )


# The controllers of the default configuration, by name: the kind of each.
DEFAULT_CONTROLLERS = {
    "joint_state_broadcaster": "broadcaster",
    "position_controller": "position",
    "trajectory_controller": "trajectory",
}


def default_controller_config(joints: Sequence[str], *, update_rate: int = 100) -> dict:
    """A ros2_control controller configuration (YAML layout, as a dict) for ``joints``,
    for a robot that comes without one.

    One controller of each kind of :data:`DEFAULT_CONTROLLERS` (a joint state
    broadcaster, a group position controller and a joint trajectory controller, as
    the registry's types of those kinds), on ``joints`` with the smallest parameters
    their types load with (:meth:`Controller.minimal_ros_parameters`), at
    ``update_rate`` Hz.
    """
    if not joints:
        raise ValueError(f"joints={list(joints)!r} must name at least one joint")
    if update_rate <= 0:
        raise ValueError(f"update_rate={update_rate!r} must be positive")
    manager: dict[str, Any] = {"update_rate": update_rate}
    config: dict[str, Any] = {"controller_manager": {"ros__parameters": manager}}
    for name, kind in DEFAULT_CONTROLLERS.items():
        type_name = controller_type_for(kind)
        manager[name] = {"type": type_name}
        parameters = lookup(type_name).minimal_ros_parameters(list(joints))
        if parameters:
            config[name] = {"ros__parameters": parameters}
    return config


# --------------------------------------------------------------------------------------
# Parameters


def load_parameters(
    cls: type[Controller],
    raw: dict[str, Any],
    *,
    undeclared: list[str] | None = None,
    ignored: list[str] | None = None,
):
    """``cls.parameters`` from the ``ros__parameters`` mapping ``raw`` (dotted names
    already nested): a parameter the type does not declare (upstream's schema) is
    dropped and its dotted name appended to ``undeclared``, as ROS ignores it; refused
    ones are errors; ignored ones (declared, not simulated: :attr:`Controller.ignored_parameters`,
    dotted names for nested ones) are dropped and appended to ``ignored``; the rest is
    read with ``yaml_load_typed`` and checked by :func:`check_parameters`."""
    notes = undeclared if undeclared is not None else []
    for name, reason in cls.refused_parameters.items():
        if name in raw:
            raise ParameterError(name, reason)
    raw = dict(raw)
    for name in sorted(cls.ignored_parameters):
        *parents, leaf = name.split(".")
        holder = raw
        for parent in parents:
            holder = holder.get(parent) if isinstance(holder, dict) else None
        if isinstance(holder, dict) and leaf in holder:
            if parents:
                holder = _copied_path(raw, parents)
            del holder[leaf]
            if ignored is not None:
                ignored.append(name)
    declared = cls.known_parameters() | _COMMON_IGNORED
    kept = {}
    for name, value in raw.items():
        if name in declared:
            kept[name] = value
        else:
            notes.append(name)
    raw = cls.ros_layout(kept, undeclared=notes)
    fields = {f.name for f in dataclasses.fields(cls.parameters)}
    data = {}
    for name, value in raw.items():
        if name in fields:
            data[name] = _declared_only(cls.parameters, name, value, notes)
        elif name not in _COMMON_IGNORED:
            notes.append(name)
    try:
        params = _load_typed(cls.parameters, data)
    except Exception as whole:  # yaml_load_typed raises RuntimeError, TypeError, ValueError
        # Find the parameter at fault: load them one at a time.
        name, problem = next(iter(data), "ros__parameters"), str(whole)
        for candidate, value in data.items():
            try:
                _load_typed(cls.parameters, {candidate: value})
            except Exception as single:  # as above
                name, problem = candidate, str(single)
                break
        raise ParameterError(ros_name(cls.parameters, name), " ".join(problem.split())) from None
    check_parameters(cls.parameters, params, given=raw)
    return params


class _Refused(ValueError):
    """What :func:`check_config` raises for a controller's parameters (its ``key`` and
    ``text`` become the :class:`ParameterError`)."""


def ros_name(schema: type, key: str, *, indices: bool = False) -> str:
    """The ROS parameter name of the dotted ``key`` of a parameters dataclass
    (``trajectory_tolerance.j1`` -> ``constraints.j1.trajectory`` through the
    dataclass's ``ROS_NAMES``); list indices dropped unless ``indices``."""
    parts = [part for part in key.split(".") if indices or not part.isdigit()]
    head = getattr(schema, "ROS_NAMES", {}).get(parts[0], parts[0])
    rest = parts[1:]
    if "<joint>" in head and rest:
        head, rest = head.replace("<joint>", rest[0]), rest[1:]
    return ".".join([head, *rest])


def check_parameters(schema: type, params: Any, *, given: dict[str, Any] | None = None) -> None:
    """Checks ``params`` (an instance of the parameters dataclass ``schema``) against
    the rules declared beside its fields (:func:`~armando_drake.tools.schema.param`,
    the one checker :func:`~armando_drake.tools.schema.check_config`) and the rules
    between fields of its ``check()``; ``given``: what the YAML gave, in the layout
    of the dataclass (a ``required`` field it leaves out is missing). Raises
    :class:`ParameterError` naming the ROS parameter
    (``constraints.goal_time=-1.0 must be zero or positive [s]``)."""
    try:
        check_config(params, error=_Refused, given=given or {})
    except _Refused as refused:
        key, text = refused.key, refused.text
        if key and text.startswith(key):
            rest = text[len(key) :]
            # "=<value> <problem>" after the parameter's name; a sentence alone.
            text = rest[2:] if rest.startswith(": ") else ros_name(schema, key, indices=True) + rest
        raise ParameterError(ros_name(schema, key) if key else "ros__parameters", text) from None


def _copied_path(raw: dict[str, Any], parents: list[str]) -> dict[str, Any]:
    """The mapping at ``parents`` in ``raw``, each mapping on the way copied (so that
    removing from it leaves the caller's data alone)."""
    holder = raw
    for parent in parents:
        holder[parent] = dict(holder[parent])
        holder = holder[parent]
    return holder


def _declared_only(schema: type, name: str, value: Any, notes: list[str]) -> Any:
    """``value`` of the field ``name`` of ``schema`` without the keys a nested
    parameters dataclass (or a mapping of them, per joint) does not declare; each
    dropped key's dotted name is appended to ``notes``."""
    hint = typing.get_type_hints(schema).get(name)
    arguments = typing.get_args(hint)
    if dataclasses.is_dataclass(hint) and isinstance(value, dict):
        return _known_keys(hint, value, name, notes)
    if typing.get_origin(hint) is dict and arguments and dataclasses.is_dataclass(arguments[-1]):
        if isinstance(value, dict):
            return {
                key: _known_keys(arguments[-1], item, f"{name}.{key}", notes)
                if isinstance(item, dict)
                else item
                for key, item in value.items()
            }
    return value


def _known_keys(schema: type, value: dict[str, Any], prefix: str, notes: list[str]) -> dict:
    fields = {f.name for f in dataclasses.fields(schema)}
    kept = {}
    for key, item in value.items():
        if key in fields:
            kept[key] = _declared_only(schema, key, item, notes)
        else:
            notes.append(f"{prefix}.{key}")
    return kept


def _load_typed(schema: type, data: dict[str, Any]):
    return yaml_load_typed(schema=schema, data=yaml.safe_dump(data), defaults=schema())


# Parameters every controller accepts and the simulation has no use for.
_COMMON_IGNORED = frozenset({"use_sim_time", "type", "update_rate", "is_async"})


@dataclasses.dataclass
class NoParameters:
    """A controller without parameters."""


# --------------------------------------------------------------------------------------
# Joints and memory


@dataclasses.dataclass(frozen=True)
class ControllerJoints:
    """The joints a controller claims, in its order, with their hardware limits."""

    names: tuple[str, ...]
    lower: np.ndarray  # [rad] position command limits (n)
    upper: np.ndarray  # [rad] position command limits (n)
    velocity: np.ndarray  # [rad/s] velocity limits (n); inf = none
    effort: np.ndarray  # [N m] effort limits (n); inf = none
    initial_positions: np.ndarray  # [rad] positions held until the first command (n)
    # Whether each joint is continuous in the robot description (n), or () for none.
    continuous: tuple[bool, ...] = ()

    @property
    def n(self) -> int:
        return len(self.names)

    @property
    def wraparound(self) -> np.ndarray:
        """Per joint whether it is continuous (upstream's ``joints_angle_wraparound_``)."""
        return np.array(self.continuous or (False,) * self.n, dtype=bool)

    @staticmethod
    def make(
        joint_names: Sequence[str],
        *,
        lower: Sequence[float] | None = None,
        upper: Sequence[float] | None = None,
        velocity: Sequence[float] | None = None,
        effort: Sequence[float] | None = None,
        initial_positions: Sequence[float] | None = None,
        continuous: Sequence[bool] | None = None,
    ) -> ControllerJoints:
        """Checked joints: names non-empty and unique, limits intervals, initial
        positions finite (clamped into the limits, with a warning)."""
        names = tuple(joint_names)
        if not names:
            raise ValueError(f"joint_names={joint_names!r} must not be empty")
        duplicates = sorted({name for name in names if names.count(name) > 1})
        if duplicates:
            raise ValueError(f"joint_names={joint_names!r} repeats {duplicates}")
        n = len(names)
        low = np.full(n, -np.inf) if lower is None else np.asarray(lower, dtype=float)
        high = np.full(n, np.inf) if upper is None else np.asarray(upper, dtype=float)
        if low.shape != (n,) or high.shape != (n,):
            raise ValueError(f"lower={lower!r} and upper={upper!r} must each have {n} values")
        for name, lo, hi in zip(names, low.tolist(), high.tolist(), strict=True):
            if np.isnan(lo) or np.isnan(hi) or lo > hi:
                raise ValueError(f"limits [{lo}, {hi}] of joint '{name}' are not an interval")
        limits = {}
        for label, values in (("velocity", velocity), ("effort", effort)):
            array = np.full(n, np.inf) if values is None else np.asarray(values, dtype=float)
            if array.shape != (n,) or np.any(np.isnan(array)) or np.any(array <= 0):
                raise ValueError(f"{label}={values!r} must be {n} positive limits")
            limits[label] = array
        if initial_positions is None:
            q0 = np.clip(np.zeros(n), low, high)
        else:
            given = np.asarray(initial_positions, dtype=float)
            if given.shape != (n,) or not np.all(np.isfinite(given)):
                raise ValueError(
                    f"initial_positions={initial_positions!r} must be {n} finite values"
                )
            q0 = np.clip(given, low, high)
            for name, value, inside in zip(names, given.tolist(), q0.tolist(), strict=True):
                if value != inside:
                    _logger.warning(
                        "initial position %r of joint '%s' is outside its limits; starting at %r",
                        value,
                        name,
                        inside,
                    )
        wraps = (False,) * n if continuous is None else tuple(bool(c) for c in continuous)
        if len(wraps) != n:
            raise ValueError(f"continuous={continuous!r} must have {n} values")
        return ControllerJoints(names, low, high, limits["velocity"], limits["effort"], q0, wraps)


@dataclasses.dataclass(frozen=True)
class ControllerMemory:
    """What a command controller keeps between updates. Never mutated: an update
    that changes something returns a new one (so Drake's copy of it is free)."""

    # [rad, rad/s] [q_d; v_d] (2n) in the controller's joint order: the desired state
    # of its position joints (q_d, v_d) and velocity joints (v_d; q_d unused).
    desired: np.ndarray
    status: ControllerStatus  # what it reports; replaced, never mutated
    trajectory: Any = None  # a running trajectory, if the controller has one
    # [N m] commanded torques (n) of an effort controller; None for the others.
    effort: np.ndarray | None = None
    # The controller's own state between updates (a PID's integral), if any.
    internal: Any = None
    # Whether the controller works at every update whatever arrives (a PID loop).
    running: bool = False
    # A value the controller keeps for its next update (the trajectory controller: the
    # time and [q; v] of its latest sample), if any.
    reference: Any = None
    # [s] the trajectory time of the latest update, where it runs apart from the simulation
    # time (the trajectory controller's speed scaling), else None.
    clock: float | None = None
    # [-] the factor by which that time runs (the trajectory controller's speed scaling).
    speed_scaling: float = 1.0
    # Whether the controller has work at every update, without a new message: a
    # trajectory being executed, or a running loop. Derived from the fields above.
    busy: bool = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self):
        busy = self.running or (self.trajectory is not None and self.status.state == "executing")
        object.__setattr__(self, "busy", busy)

    def __deepcopy__(self, memo):
        return self


Measure = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


class Controller:
    """The base of every command controller's logic (and of the broadcaster's).

    A subclass sets the class attributes below, implements :meth:`update`, and is
    registered with :func:`register`. The manager builds it with
    ``cls(name=..., joints=ControllerJoints, params=<its parameters>)``.
    """

    parameters: ClassVar[type] = NoParameters  # the parameters dataclass
    ignored_parameters: ClassVar[frozenset[str]] = frozenset()  # accepted, not simulated
    # Upstream parameters refused, with the reason (the error names the parameter).
    refused_parameters: ClassVar[dict[str, str]] = {}
    message: ClassVar[type | None] = None  # the command message class
    topic: ClassVar[str | None] = None  # the command topic: /<controller>/<topic>
    fixed_interface: ClassVar[str | None] = None  # the interface claimed, if fixed
    # Further input topics, by topic leaf: the message class each carries (upstream's other
    # subscriptions); their messages go to receive(), before update().
    extra_topics: ClassVar[dict[str, type]] = {}
    # Topics it publishes, by topic leaf: the message class of each (upstream's publishers:
    # a drive's odometry); the manager's outputs ``<controller>.<leaf>`` (see output()).
    outputs: ClassVar[dict[str, type]] = {}
    initial_state: ClassVar[str] = "holding"  # ControllerStatus.state before any command
    broadcaster: ClassVar[bool] = False  # publishes joint states instead of commanding
    type_names: ClassVar[tuple[str, ...]] = ()  # set by register()
    ros: ClassVar[int] = 2  # the ROS generation it is registered in; set by register()

    @classmethod
    def type_name(cls) -> str:
        return cls.type_names[0] if cls.type_names else cls.__qualname__

    @classmethod
    def known_parameters(cls) -> frozenset[str]:
        return frozenset(f.name for f in dataclasses.fields(cls.parameters))

    @classmethod
    def ros_layout(cls, raw: dict[str, Any], *, undeclared: list[str]) -> dict[str, Any]:
        """``raw`` (the ROS parameters the type declares) in the layout of
        :attr:`parameters`; a nested parameter it does not declare is dropped, its dotted
        name appended to ``undeclared``."""
        return raw

    @classmethod
    def command_interface(cls, params) -> str | None:
        """The command interface the controller claims on each of its joints."""
        return cls.fixed_interface

    @classmethod
    def hardware_interfaces(cls, params) -> dict[str, str]:
        """Further hardware interfaces it claims (``<component>/<interface>``), by the
        parameter that names each: activating it fails where the robot's
        ``<ros2_control>`` declares none of that name, as upstream's."""
        return {}

    @classmethod
    def commands_effort(cls, params) -> bool:
        """Whether it writes efforts [N m] (its memory's ``effort``): on the effort
        interface, or as a feed-forward torque added to another interface's actuator."""
        return cls.command_interface(params) == "effort"

    @classmethod
    def position_targets(cls, params) -> bool:
        """Whether its command messages carry joint positions [rad or m] (so a sequence
        of position targets can drive it), whatever interface it commands."""
        return cls.command_interface(params) == "position"

    @classmethod
    def joints_of(cls, params) -> list[str]:
        """The joints the controller claims ([] = every hardware joint)."""
        return list(params.joints)

    @classmethod
    def minimal_ros_parameters(cls, joints: list[str]) -> dict[str, Any]:
        """The smallest ``ros__parameters`` a controller YAML gives this type to run it
        on ``joints`` with its defaults (:func:`default_controller_config`): the joints,
        when its parameters have them."""
        fields = {f.name for f in dataclasses.fields(cls.parameters)}
        return {"joints": list(joints)} if "joints" in fields else {}

    def __init__(self, *, name: str, joints: ControllerJoints, params=None):
        self.name = name  # the controller's name in log lines
        self.joints = joints
        self.joint_names = joints.names
        self.n = n = joints.n
        self.lower, self.upper = joints.lower, joints.upper
        self.params = params if params is not None else self.default_parameters(joints)
        self.interface = self.command_interface(self.params)
        # Whether its memory has efforts [N m] (the effort interface, or a feed-forward).
        self.effort_output = self.commands_effort(self.params)
        self._initial = ControllerMemory(
            desired=np.concatenate([joints.initial_positions, np.zeros(n)]),
            status=ControllerStatus(state=self.initial_state),
            effort=np.zeros(n) if self.effort_output else None,
        )

    @classmethod
    def default_parameters(cls, joints: ControllerJoints):
        """Parameters when none are given (tests): the controller's joints."""
        return cls.parameters(joints=list(joints.names))

    def configure(self, *, update_rate: int) -> None:
        """Called by the controller manager with its ``update_rate`` [Hz] before the run
        (upstream's ``on_configure`` reads ``get_update_rate()``); the default ignores it."""

    def set_namespace(self, namespace: str) -> None:
        """Called by the world builder with the robot's namespace ("/left"; "" for the
        only robot), the node namespace upstream's controller runs in; the default ignores
        it (a drive prefixes its frames with it)."""

    def connect_plant(self, plant, model_instance) -> None:
        """Called by the world builder once the plant is finalized, before the run:
        a controller that computes from the robot's model (inverse dynamics) keeps
        what it needs; the others ignore it."""

    def initial_memory(self) -> ControllerMemory:
        return self._initial

    def update(
        self, now: float, message: Any, memory: ControllerMemory, measure: Measure
    ) -> ControllerMemory:
        """The memory after the update at ``now`` [s]; ``message`` is the new message
        or None; ``measure(desired)`` gives the measured (q, v) [rad, rad/s] of the
        controller's joints. Returns ``memory`` itself when nothing changes."""
        raise NotImplementedError

    def output(self, topic: str, memory: ControllerMemory) -> Any:
        """The latest message published on ``topic`` (a key of :attr:`outputs`)."""
        raise NotImplementedError

    @classmethod
    def joint_key(cls, params, joint: str) -> str:
        """The parameter naming ``joint``, for messages (``joints``)."""
        return "joints"

    def receive(self, topic: str, message: Any, memory: ControllerMemory) -> ControllerMemory:
        """A message on one of :attr:`extra_topics`: the memory with it taken in."""
        return memory

    def reject(self, status: ControllerStatus, reason: str) -> ControllerStatus:
        """``status`` after rejecting a message for ``reason`` (logged)."""
        _logger.error("%s: %s", self.name, reason)
        return dataclasses.replace(
            status, rejected=status.rejected + 1, last_error=reason, detail=dict(status.detail)
        )

    def accept(self, status: ControllerStatus, state: str, detail: dict) -> ControllerStatus:
        return dataclasses.replace(status, state=state, accepted=status.accepted + 1, detail=detail)

    @staticmethod
    def log_warning(name: str, text: str) -> None:
        _logger.warning("%s: %s", name, text)


class CommandStream:
    """A controller that can take its commands as a stream (mixed into a
    :class:`Controller`): joint positions evaluated in C++ and checked when the world
    is built (a sinusoid within the joint limits), each sample then accepted as it is,
    so the stream drives the hardware directly without the manager's update."""

    @classmethod
    def accepts_stream(cls, params) -> bool:
        """Whether the controller, with ``params``, takes such a stream."""
        return False

    def stream_status(self, status: ControllerStatus, count: int) -> ControllerStatus:
        """``status`` after accepting ``count`` samples of a stream."""
        raise NotImplementedError


def takes_stream(logic) -> bool:
    """Whether the controller ``logic`` takes its commands as a stream now."""
    return isinstance(logic, CommandStream) and logic.accepts_stream(logic.params)


# --------------------------------------------------------------------------------------
# Discovery: the modules of this package, then the entry points of other distributions


def _import(module: str, origin: str):
    """Imports ``module`` (the controller module ``origin`` names); an ImportError naming
    it when it fails, whatever it raised."""
    try:
        return importlib.import_module(module)
    except Exception as error:  # a module's import can raise anything
        raise ImportError(
            f"controller module {module!r} ({origin}) failed to import: "
            f"{type(error).__name__}: {error}",
            name=module,
        ) from error


def _import_package_modules() -> None:
    """Imports every module of this package (each registers its types), in name order;
    private modules (``_name``) are helpers, not controller types."""
    for module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if not module.name.startswith("_"):
            _import(f"{__name__}.{module.name}", f"in {__name__}")


_entry_points_loaded = False
_loaded_entry_points: set[str] = set()  # the values already imported


def load_entry_points() -> tuple[str, ...]:
    """Imports each module declared in the entry-point group ``armando_drake.controllers``
    that is not imported yet (each registers its types); the values imported now.
    :func:`lookup` and the other queries call it once, before their first answer."""
    global _entry_points_loaded
    _entry_points_loaded = True  # already while loading: a module may look a type up
    loaded = []
    try:
        for entry_point in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
            if entry_point.value in _loaded_entry_points:
                continue
            dist = entry_point.dist.name if entry_point.dist else "an unknown distribution"
            imported = _import(
                entry_point.module,
                f"entry point {entry_point.name!r} of {ENTRY_POINT_GROUP!r} in {dist}",
            )
            if entry_point.attr and not hasattr(imported, entry_point.attr):
                raise ImportError(
                    f"controller entry point {entry_point.name!r} = {entry_point.value!r}: "
                    f"module {entry_point.module!r} has no {entry_point.attr!r}",
                    name=entry_point.module,
                )
            _loaded_entry_points.add(entry_point.value)
            loaded.append(entry_point.value)
    except ImportError:
        _entry_points_loaded = False  # the next lookup raises it again
        raise
    return tuple(loaded)


def _load_entry_points_once() -> None:
    if not _entry_points_loaded:
        load_entry_points()


# The controller types shipped with the package register themselves on import.
_import_package_modules()

__all__ = [
    "COMMAND_INTERFACES",
    "DEFAULT_CONTROLLERS",
    "DID_NOTHING",
    "ENTRY_POINT_GROUP",
    "Controller",
    "ControllerJoints",
    "ControllerMemory",
    "ParameterError",
    "Rejected",
    "controller_kinds",
    "controller_type_for",
    "default_controller_config",
    "find_controller",
    "load_entry_points",
    "check_parameters",
    "load_parameters",
    "lookup",
    "ros_name",
    "register",
    "registered_types",
    "types_accepting",
    "unregister",
]
