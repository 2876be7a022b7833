"""The controller manager: every active controller of a world in one Drake system.

Upstream's ``controller_manager`` runs one loop at ``update_rate``: read the
hardware state, update the joint state broadcaster and each active
controller in turn, write the commands. :class:`ControllerManager` does the
same in one periodic unrestricted update, hosting the controllers' logic as
plain objects (:mod:`armando_drake.control.controllers`), so a world pays for one
Python system in the diagram instead of one per controller.

Each command controller behaves as its standalone system in
:mod:`armando_drake.control.controllers` does: the same validation, log lines,
status and desired state at the same update times. What the manager adds is
thrift, since Python at every controller tick is what a world pays most for
beyond the physics:

- a tick at which no controller has anything to do (no new command, no
  trajectory running) returns ``EventStatus.DidNothing()``, so Drake
  neither copies the manager's state back nor invalidates what depends on
  it (the plant's desired-state input, the gravity feed-forward);
- the broadcaster's ``joint_states`` is computed when someone reads it (the
  joint state logger and the recorder sample it at ``update_rate``), not
  stored at every tick.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus, LeafSystem

from armando_drake.control.controllers import (
    DID_NOTHING,
    ControllerMemory,
    JointStateBroadcasterLogic,
    PositionControllerLogic,
    TrajectoryControllerLogic,
)
from armando_drake.control.hardware import GravityFeedforward, HardwareInterface
from armando_drake.control.messages import ControllerStatus, PublicationValue


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
        - feedforward
        - <controller>.status

    - ``state``: [q; v] of the robot's model instance (``hardware.num_model_states``).
    - ``effort``: the robot's actuator torques [N m], hardware joint order;
      optional, when unconnected ``JointState.effort`` is empty.
    - ``<controller>.commands`` / ``<controller>.joint_trajectory``: the
      command topic of each position / trajectory controller (a
      ``Publication``).
    - ``joint_states``: the broadcaster's :class:`JointState` of
      ``broadcaster.joint_names`` at the time it is evaluated (``stamp`` =
      that time), from the ``state`` and ``effort`` inputs; only with a
      broadcaster. Its consumers sample it at ``update_rate``, as a
      subscriber of upstream's broadcaster receives it.
    - ``desired_state``: [q_d; v_d] of every hardware joint in actuator order
      (2n) [rad, rad/s]: each controller's desired state on its joints, the
      initial position (and zero velocity) on joints no controller claims.
    - ``feedforward``: ``gravity(q_d)``, the torques [N m] that hold the arm
      against gravity at the desired positions, one per actuator of the
      robot, for the plant's actuation input; only with ``gravity``. It
      depends on ``desired_state`` alone, so Drake computes it again only
      when that changes.
    - ``<controller>.status``: each controller's ControllerStatus.

    The command controllers run in one periodic update at ``update_rate``
    [Hz] from t = 0; ``desired_state`` and the statuses are state and
    ``feedforward`` is cached, so reading them costs nothing.
    """

    def __init__(
        self,
        *,
        hardware: HardwareInterface,
        update_rate: float,
        broadcaster: JointStateBroadcasterLogic | None = None,
        controllers: Sequence[ManagedController] = (),
        gravity: GravityFeedforward | None = None,
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
            self.DeclareAbstractOutputPort(
                "joint_states",
                lambda: AbstractValue.Make(broadcaster.initial_message()),
                self._CalcJointStates,
                {
                    self.time_ticket(),
                    self._state.ticket(),
                    self._effort.ticket(),
                },
            )

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
        if gravity is not None:
            # A function of desired_state alone: Drake caches it and calls back into
            # Python only when desired_state changes, never per plant step.
            self.DeclareVectorOutputPort(
                "feedforward",
                gravity.size,
                lambda context, output: output.SetFromVector(
                    gravity(context.get_discrete_state(self._desired_index).get_value()[:n])
                ),
                {self.discrete_state_ticket(self._desired_index)},
            )
        for k, controller in enumerate(self._controllers):
            self.DeclareAbstractOutputPort(
                f"{controller.name}.status",
                lambda: AbstractValue.Make(ControllerStatus()),
                lambda context, output, k=k: output.set_value(self._Status(context, k)),
                {self.abstract_state_ticket(self._memory_index)},
            )

        if self._controllers:
            self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / update_rate, 0.0, self._Update)

    @property
    def broadcaster(self) -> JointStateBroadcasterLogic | None:
        return self._broadcaster

    @property
    def controllers(self) -> tuple[ManagedController, ...]:
        return self._controllers

    def _Status(self, context, k: int) -> ControllerStatus:
        return context.get_abstract_state(self._memory_index).get_value().memories[k].status

    def _CalcJointStates(self, context, output) -> None:
        if not self._state.HasValue(context):
            output.set_value(self._broadcaster.initial_message())
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
        output.set_value(message)

    def _Update(self, context, state) -> EventStatus:
        # Every pybind call costs microseconds here (the physics between ticks leaves
        # the caches cold), so a tick with nothing to do makes as few as it can.
        memories = context.get_abstract_state(self._memory_index).get_value()
        handled, items = memories.handled, memories.memories
        new_handled = new_items = None  # copies, made at the first change
        x = None  # the measured state, evaluated when a controller needs it
        for k, controller in enumerate(self._controllers):
            message = None
            port = self._command_ports[k]
            if port.HasValue(context):
                publication = port.Eval(context)
                if publication.count > handled[k]:
                    new_handled = new_handled or list(handled)
                    new_handled[k] = publication.count
                    message = publication.message
            if message is None and not items[k].busy:
                continue  # what logic.needs_update() says, without the call
            if x is None and self._state.HasValue(context):
                x = self._state.Eval(context)
            new_items = new_items or list(items)
            new_items[k] = controller.logic.update(
                context.get_time(), message, items[k], _Measure(x, *self._measured_rows[k])
            )
        if new_handled is None and new_items is None:
            return DID_NOTHING
        new = _Memories(tuple(new_handled or handled), tuple(new_items or items))
        state.get_mutable_abstract_state(self._memory_index).set_value(new)
        changed = [k for k in range(len(items)) if new.memories[k].desired is not items[k].desired]
        if changed:
            desired = np.array(context.get_discrete_state(self._desired_index).get_value())
            for k in changed:
                desired[self._desired_rows[k]] = new.memories[k].desired
            state.get_mutable_discrete_state(self._desired_index).SetFromVector(desired)
        return EventStatus.Succeeded()
