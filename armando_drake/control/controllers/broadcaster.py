"""``joint_state_broadcaster/JointStateBroadcaster``: publishes the joint states.

It commands nothing. The controller manager publishes ``sensor_msgs/JointState``
(``name``, ``position``, ``velocity``, ``effort``) of the broadcaster's joints,
in its order, at ``update_rate``; and the same numbers as one vector
``[q; v; effort]``, which Drake's C++ ``VectorLogSink`` records without Python.
"""

import dataclasses
from typing import Any

from armando_drake.control.controllers import Controller, joint_list, register
from armando_drake.control.messages import JointState


@dataclasses.dataclass
class JointStateBroadcasterParameters:
    """The parameters of the joint state broadcaster."""

    # Joints published, in this order; empty = every joint of the hardware interface.
    joints: list[str] = dataclasses.field(default_factory=list)

    def check(self, raw: dict[str, Any]) -> None:
        joint_list(raw.get("joints"), allow_empty=True)


@register("joint_state_broadcaster/JointStateBroadcaster")
class JointStateBroadcaster(Controller):
    """The broadcaster's message: a :class:`JointState` of its joints."""

    parameters = JointStateBroadcasterParameters
    ignored_parameters = frozenset(
        {
            "interfaces",
            "extra_joints",
            "use_local_topics",
            "use_urdf_to_filter",
            "map_interface_to_joint_state",
            "frame_id",
        }
    )
    broadcaster = True
    initial_state = "active"

    def initial_message(self) -> JointState:
        n = self.n
        return JointState(
            stamp=0.0, name=self.joint_names, position=(0.0,) * n, velocity=(0.0,) * n
        )

    def message(self, stamp: float, positions: list, velocities: list, effort: list) -> JointState:
        """The sample at ``stamp`` [s] from lists of Python floats, joint order (effort may be
        empty)."""
        return JointState(
            stamp=stamp,
            name=self.joint_names,
            position=tuple(positions),
            velocity=tuple(velocities),
            effort=tuple(effort),
        )

    def update(self, now, message, memory, measure):
        return memory
