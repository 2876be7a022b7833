"""``joint_state_broadcaster/JointStateBroadcaster``: publishes the joint states.

It commands nothing. The controller manager publishes ``sensor_msgs/JointState``
(``name``, ``position``, ``velocity``, ``effort``) of the broadcaster's joints,
in its order, at ``update_rate``; and the same numbers as one vector
``[q; v; effort]``, which Drake's C++ ``VectorLogSink`` records without Python.

As upstream, with ``joints`` or ``interfaces`` empty it publishes every joint of
the hardware and all its interfaces; with both given, the listed joints, and
NaN in the arrays of the standard interfaces (position, velocity, effort) not
listed; ``extra_joints`` are appended with zero position, velocity and effort.
The C++ vector view (the joint-state CSV) records the measured values of the
broadcaster's joints, without the extra joints.
"""

import dataclasses
import math
from typing import Any

from armando_drake.control.controllers import (
    Controller,
    register,
)
from armando_drake.messages.types import JointState
from armando_drake.tools.schema import Refusal, param

_DEFAULT_MAPPING = {"position": "position", "velocity": "velocity", "effort": "effort"}


@dataclasses.dataclass
class InterfaceMapping:
    """``map_interface_to_joint_state``: the state interface behind each JointState field."""

    # Interface published as JointState.position (ignored when position is listed in
    # interfaces; a name the joints do not have publishes their position interface).
    position: str = "position"
    # Interface published as JointState.velocity (ignored when velocity is listed in
    # interfaces; a name the joints do not have publishes their velocity interface).
    velocity: str = "velocity"
    # Interface published as JointState.effort (ignored when effort is listed in
    # interfaces; a name the joints do not have publishes their effort interface).
    effort: str = "effort"


@dataclasses.dataclass
class JointStateBroadcasterParameters:
    """The parameters of the joint state broadcaster."""

    # Joints published, in this order; empty (or interfaces empty) = every joint of the
    # hardware interface.
    joints: list[str] = param([], unique=True)
    # State interfaces published (position, velocity, effort, ...); a standard one not
    # listed is NaN in JointState; empty (or joints empty) = all of them.
    interfaces: list[str] = param(
        [],
        unique=True,
        choices=tuple(_DEFAULT_MAPPING.values()),
        why="the state interfaces of the simulated joints (upstream's activation fails on "
        "an interface the hardware does not export)",
    )
    # Names appended to JointState with zero position, velocity and effort (joints the
    # hardware does not have, e.g. a passive gripper finger).
    extra_joints: list[str] = param([], unique=True)
    # Publish on ~/joint_states (<broadcaster>/joint_states in the robot's namespace)
    # instead of joint_states.
    use_local_topics: bool = False
    # Publish only joints the URDF has; every simulated joint is a URDF joint, so both
    # values publish the same.
    use_urdf_to_filter: bool = True
    # JointState header.frame_id; only upstream's default base_link is simulated.
    frame_id: str = param(
        "base_link", choices=("base_link",), why="JointState carries upstream's default"
    )
    # The state interface behind each JointState field (upstream's mapping).
    map_interface_to_joint_state: InterfaceMapping = dataclasses.field(
        default_factory=InterfaceMapping
    )

    def check(self) -> None:
        """The rules between fields (the fields' own are declared beside them)."""
        for index, name in enumerate(self.extra_joints):
            if name in self.joints:
                raise Refusal(f"extra_joints.{index}", f"={name!r} is also one of the joints")
        for field in _DEFAULT_MAPPING:
            given = getattr(self.map_interface_to_joint_state, field)
            # Upstream's get_map_interface_parameter: a field listed in interfaces keeps its
            # own interface (the mapping ignored, with a warning); else the interface named
            # is published in its place. The simulated joints' state interfaces are
            # position, velocity and effort: another name maps nothing (every joint keeps
            # publishing its own), a name listed in interfaces is refused above.
            if given == field or field in self.interfaces or given not in _DEFAULT_MAPPING:
                continue
            raise Refusal(
                f"map_interface_to_joint_state.{field}",
                f"={given!r} is not simulated: publishing the {given} interface as "
                f"JointState.{field} (in the {given} field too) mixes two interfaces in one "
                "field",
            )

    @property
    def all_interfaces(self) -> bool:
        """Upstream's ``use_all_available_interfaces``: joints or interfaces empty."""
        return not self.joints or not self.interfaces


@register("joint_state_broadcaster/JointStateBroadcaster", kind="broadcaster")
class JointStateBroadcaster(Controller):
    """The broadcaster's message: a :class:`JointState` of its joints."""

    parameters = JointStateBroadcasterParameters
    # Upstream's DynamicJointState topic, not published here.
    ignored_parameters = frozenset({"publish_dynamic_joint_states"})
    broadcaster = True
    initial_state = "active"

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return [] if params.all_interfaces else list(params.joints)

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters()

    @classmethod
    def minimal_ros_parameters(cls, joints: list[str]) -> dict[str, Any]:
        return {}  # every joint of the hardware

    @classmethod
    def publish_rate(cls, params) -> float | None:
        """[Hz] the rate it publishes at, when its parameters set one (ROS 1's
        ``publish_rate``); None = the controller manager's update rate."""
        return None

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        params = self.params
        # (ROS 1's JointStateController has none of these parameters: every interface.)
        every = getattr(params, "all_interfaces", True)
        listed = set(getattr(params, "interfaces", ()))
        # Which standard interfaces are published (the others are NaN).
        self._published = {field: every or field in listed for field in _DEFAULT_MAPPING}
        self._extra = tuple(getattr(params, "extra_joints", ()))
        mapping = getattr(params, "map_interface_to_joint_state", None)
        for field in _DEFAULT_MAPPING if mapping is not None else ():
            given = getattr(mapping, field)
            if given != field and field in listed:
                self.log_warning(
                    name,
                    f"Mapping from '{given}' to interface '{field}' will not be done, because "
                    f"'{field}' is defined in 'interface' parameter.",
                )
        self.names = self.joint_names + self._extra  # the JointState names

    def initial_message(self) -> JointState:
        n = self.n
        return self.message(0.0, [0.0] * n, [0.0] * n, [])

    def message(self, stamp: float, positions: list, velocities: list, effort: list) -> JointState:
        """The sample at ``stamp`` [s] from lists of Python floats, joint order (effort may be
        empty: no effort measured)."""
        if self._extra or not all(self._published.values()):
            nan = [math.nan] * self.n
            zeros = [0.0] * len(self._extra)
            positions = (positions if self._published["position"] else nan) + zeros
            velocities = (velocities if self._published["velocity"] else nan) + zeros
            if effort or not self._published["effort"]:
                effort = (effort if self._published["effort"] else nan) + zeros
        return JointState(
            stamp=stamp,
            name=self.names,
            position=tuple(positions),
            velocity=tuple(velocities),
            effort=tuple(effort),
        )

    def update(self, now, message, memory, measure):
        return memory
