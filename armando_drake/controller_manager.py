"""The controller manager: every active controller of a world in one Drake system.

Upstream's ``controller_manager`` runs one loop at ``update_rate``: read the
hardware state, update the joint state broadcaster and each active
controller in turn, write the commands. :class:`ControllerManager` does the
same in one periodic unrestricted update, hosting the controllers' logic as
plain objects (:mod:`armando_drake.controllers`), so a world pays for one
Python system in the diagram instead of one per controller (pydrake calls
into every Python system at every plant step, even an idle one).

Each controller behaves as its standalone system in
:mod:`armando_drake.controllers` does: the same validation, log lines,
status and desired state at the same update times.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from armando_drake.controllers import (
    ControllerMemory,
    JointStateBroadcasterLogic,
    PositionControllerLogic,
    TrajectoryControllerLogic,
)
from armando_drake.hardware import HardwareInterface
from armando_drake.messages import ControllerStatus, PublicationValue


@dataclasses.dataclass(frozen=True)
class ManagedController:
    """One command controller run by the manager."""

    name: str  # the controller's name in the YAML, e.g. "position_controller"
    logic: PositionControllerLogic | TrajectoryControllerLogic
    topic: str  # its command input: "commands" or "joint_trajectory"


def _Measure(x: np.ndarray | None, q_rows: np.ndarray, v_rows: np.ndarray):
    """A controller's ``measure(desired)``: its (q, v) from the state vector ``x``, or its
    desired state when the state input is unconnected (``x`` None)."""
    if x is None:
        n = len(q_rows)
        return lambda desired: (desired[:n].copy(), desired[n:].copy())
    return lambda desired: (x[q_rows], x[v_rows])


@dataclasses.dataclass(frozen=True)
class _Memories:
    """Per controller, the publication count handled so far and its memory. Never
    mutated, so Drake's copy of it at each update is free."""

    handled: tuple[int, ...]
    memories: tuple[ControllerMemory, ...]

    def __deepcopy__(self, memo):
        return self


class ControllerManager(LeafSystem):
    """The joint state broadcaster and the command controllers of a world.

    .. pydrake_system::

        name: ControllerManager
        input_ports:
        - state
        - effort
        - <controller>.commands
        - <controller>.joint_trajectory
        output_ports:
        - joint_states
        - desired_state
        - <controller>.status

    - ``state``: [q; v] of the robot's model instance (``hardware.num_model_states``).
    - ``effort``: the robot's actuator torques [N m], hardware joint order;
      optional, when unconnected ``JointState.effort`` is empty.
    - ``<controller>.commands`` / ``<controller>.joint_trajectory``: the
      command topic of each position / trajectory controller (a
      ``Publication``).
    - ``joint_states``: the broadcaster's :class:`JointState` of
      ``broadcaster.joint_names``, sampled at every update; only with a
      broadcaster.
    - ``desired_state``: [q_d; v_d] of every hardware joint in actuator order
      (2n) [rad, rad/s]: each controller's desired state on its joints, the
      initial position (and zero velocity) on joints no controller claims.
    - ``<controller>.status``: each controller's ControllerStatus.

    Everything is refreshed by one periodic update at ``update_rate`` [Hz]
    from t = 0 (the broadcaster also at initialization); the outputs are
    state, so reading them costs nothing.
    """

    def __init__(
        self,
        *,
        hardware: HardwareInterface,
        update_rate: float,
        broadcaster: JointStateBroadcasterLogic | None = None,
        controllers: Sequence[ManagedController] = (),
    ):
        super().__init__()
        if isinstance(update_rate, bool) or not (
            isinstance(update_rate, (int, float)) and math.isfinite(update_rate) and update_rate > 0
        ):
            raise ValueError(f"update_rate={update_rate!r} must be a positive number [Hz]")
        names = [controller.name for controller in controllers]
        duplicates = sorted({name for name in names if names.count(name) > 1})
        if duplicates:
            raise ValueError(f"controllers {duplicates} are given more than once")
        n = len(hardware.joints)
        self._hardware = hardware
        self._broadcaster = broadcaster
        self._controllers = tuple(controllers)
        self._state = self.DeclareVectorInputPort("state", hardware.num_model_states)
        self._effort = self.DeclareVectorInputPort("effort", n)

        # The broadcaster's joints: where they are in the state and effort inputs.
        if broadcaster is not None:
            rows = hardware.find(list(broadcaster.joint_names))
            self._broadcast_q = [hardware.position_index[i] for i in rows]
            self._broadcast_v = [hardware.velocity_index[i] for i in rows]
            self._broadcast_effort = rows
            self._joint_states_index = self.DeclareAbstractState(
                AbstractValue.Make(broadcaster.initial_message())
            )
            self.DeclareStateOutputPort("joint_states", self._joint_states_index)

        # The controllers: command inputs, where their joints are, initial memories.
        initial = np.concatenate(
            [[joint.initial_position for joint in hardware.joints], np.zeros(n)]
        )
        self._command_ports = []
        self._measured_rows = []  # per controller: (q indices, v indices) into ``state``
        self._desired_rows = []  # per controller: its [q_d; v_d] rows in ``desired_state``
        memories = []
        for controller in self._controllers:
            if controller.topic not in ("commands", "joint_trajectory"):
                raise ValueError(
                    f"topic={controller.topic!r} of {controller.name!r} must be commands or "
                    "joint_trajectory"
                )
            self._command_ports.append(
                self.DeclareAbstractInputPort(
                    f"{controller.name}.{controller.topic}", PublicationValue()
                )
            )
            rows = hardware.find(list(controller.logic.joint_names))
            self._measured_rows.append(
                (
                    np.array([hardware.position_index[i] for i in rows], dtype=int),
                    np.array([hardware.velocity_index[i] for i in rows], dtype=int),
                )
            )
            desired_rows = np.concatenate([rows, np.asarray(rows, dtype=int) + n]).astype(int)
            self._desired_rows.append(desired_rows)
            memory = controller.logic.initial_memory()
            initial[desired_rows] = memory.desired
            memories.append(memory)
        self._memory_index = self.DeclareAbstractState(
            AbstractValue.Make(_Memories((0,) * len(memories), tuple(memories)))
        )
        self._desired_index = self.DeclareDiscreteState(initial)
        self.DeclareStateOutputPort("desired_state", self._desired_index)
        for k, controller in enumerate(self._controllers):
            self.DeclareAbstractOutputPort(
                f"{controller.name}.status",
                lambda: AbstractValue.Make(ControllerStatus()),
                lambda context, output, k=k: output.set_value(self._Status(context, k)),
                {self.abstract_state_ticket(self._memory_index)},
            )

        period = 1.0 / update_rate
        if broadcaster is not None:
            self.DeclareInitializationUnrestrictedUpdateEvent(self._UpdateJointStates)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._Update)

    @property
    def broadcaster(self) -> JointStateBroadcasterLogic | None:
        return self._broadcaster

    @property
    def controllers(self) -> tuple[ManagedController, ...]:
        return self._controllers

    def _Status(self, context, k: int) -> ControllerStatus:
        return context.get_abstract_state(self._memory_index).get_value().memories[k].status

    def _UpdateJointStates(self, context, state, x=None) -> None:
        if x is None:
            if not self._state.HasValue(context):
                return
            x = self._state.Eval(context)
        effort = []
        if self._effort.HasValue(context):
            effort = self._effort.Eval(context)[self._broadcast_effort].tolist()
        message = self._broadcaster.message(
            context.get_time(),
            x[self._broadcast_q].tolist(),
            x[self._broadcast_v].tolist(),
            effort,
        )
        state.get_mutable_abstract_state(self._joint_states_index).set_value(message)

    def _Update(self, context, state) -> None:
        x = self._state.Eval(context) if self._state.HasValue(context) else None
        if self._broadcaster is not None and x is not None:
            self._UpdateJointStates(context, state, x)
        if not self._controllers:
            return
        now = context.get_time()
        memories = context.get_abstract_state(self._memory_index).get_value()
        handled = list(memories.handled)
        items = list(memories.memories)
        changed = []  # indices of controllers whose desired state changed
        for k, controller in enumerate(self._controllers):
            message = None
            port = self._command_ports[k]
            if port.HasValue(context):
                publication = port.Eval(context)
                if publication.count > handled[k]:
                    handled[k] = publication.count
                    message = publication.message
            memory = items[k]
            if not controller.logic.needs_update(message, memory):
                continue
            memory = items[k] = controller.logic.update(
                now, message, memory, _Measure(x, *self._measured_rows[k])
            )
            if memory.desired is not memories.memories[k].desired:
                changed.append(k)
        new = _Memories(tuple(handled), tuple(items))
        if new.handled != memories.handled or any(
            a is not b for a, b in zip(new.memories, memories.memories, strict=True)
        ):
            state.get_mutable_abstract_state(self._memory_index).set_value(new)
        if changed:
            desired = np.array(context.get_discrete_state(self._desired_index).get_value())
            for k in changed:
                desired[self._desired_rows[k]] = items[k].desired
            state.get_mutable_discrete_state(self._desired_index).SetFromVector(desired)
