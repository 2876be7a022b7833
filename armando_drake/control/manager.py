"""The controller manager: every active controller of a world in one Drake system.

Upstream's ``controller_manager`` runs one loop at ``update_rate``: read the
hardware state, update the joint state broadcaster and each active
controller in turn, write the commands. :class:`ControllerManager` does the
same in one periodic unrestricted update, hosting the controllers' logic as
plain objects, so a world pays for one Python system in the diagram instead of
one per controller. It knows no controller type: it runs whatever
:class:`~armando_drake.control.controllers.Controller` objects it is given (the
world builder makes them from the registry, by their YAML ``type``), gives
each a command input named after its ``topic``, and routes what it commands
to its joints' interface (``desired_state`` for position and velocity joints,
``effort`` for effort joints). Python at every controller tick is what a world
pays most for beyond the physics, so:

- a tick at which no controller has anything to do (no new command, no
  trajectory running) returns ``EventStatus.DidNothing()``, so Drake
  neither copies the manager's state back nor invalidates what depends on
  it (the plant's desired-state input, the gravity feed-forward);
- the broadcaster's ``joint_states`` is computed when someone reads it (the
  recorder samples it at ``update_rate``), not stored at every tick; its
  vector view for the logger is C++ (:func:`AddJointStateVector`);
- the gravity feed-forward is C++ too (Drake's ``InverseDynamics``, see
  :func:`~armando_drake.control.hardware.ConnectHardwareInterface`);
- a controller whose commands are a stream evaluated in C++ and checked when
  the world is built (a sinusoid within the limits, see
  :meth:`~armando_drake.control.controllers.CommandStream`) is not
  updated at all: the stream, latched at the manager's ticks in C++, drives the
  hardware (:func:`AddStreamDesiredState`), and the controller's status is
  computed from the stream's sample count when read. A manager with only such
  controllers has no update.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import (
    DiagramBuilder,
    EventStatus,
    LeafSystem,
    OutputPort,
)
from pydrake.systems.primitives import MatrixGain, Multiplexer

from armando_drake.control.config import check_update_rate
from armando_drake.control.controllers import (
    DID_NOTHING,
    Controller,
    ControllerMemory,
    takes_stream,
)
from armando_drake.control.controllers.broadcaster import JointStateBroadcaster
from armando_drake.control.hardware import HardwareInterface
from armando_drake.messages.types import ControllerStatus, PublicationValue


@dataclasses.dataclass(frozen=True)
class ManagedController:
    """One command controller run by the manager."""

    name: str  # the controller's name in the YAML, e.g. "position_controller"
    logic: Controller  # its logic, an instance of a registered controller class
    # Its commands come as a stream evaluated in C++ (a sinusoid checked against the
    # limits when the world is built, see CommandStream) that drives the
    # hardware directly; the manager reads only the stream's sample count, for the
    # status, on the input "<name>.command_count".
    stream: bool = False

    @property
    def topic(self) -> str:
        """Its command input: ``<name>.<topic>``."""
        return self.logic.topic


class _Measure:
    """A controller's ``measure(desired)``: its (q, v) from the state vector ``x``, or its
    desired state when the state input is unconnected (``x`` None). ``base()`` gives a
    floating base's planar pose and twist (x, y, heading [m, m, rad], forward speed [m/s],
    yaw rate [rad/s]) when the robot has one (``base_rows``: its 7 position and 6 velocity
    rows in ``x``), else None."""

    __slots__ = ("x", "q_rows", "v_rows", "base_rows")

    def __init__(self, x, q_rows, v_rows, base_rows=None):
        self.x, self.q_rows, self.v_rows, self.base_rows = x, q_rows, v_rows, base_rows

    def __call__(self, desired):
        if self.x is None:
            n = len(self.q_rows)
            return desired[:n].copy(), desired[n:].copy()
        return self.x[self.q_rows], self.x[self.v_rows]

    def base(self):
        if self.x is None or self.base_rows is None:
            return None
        return planar_base(self.x[self.base_rows[0]], self.x[self.base_rows[1]])


def _base_rows(hardware: HardwareInterface):
    """A floating base's (position rows, velocity rows) in the state input, or None."""
    if not hardware.base_position_index:
        return None
    return np.array(hardware.base_position_index), np.array(hardware.base_velocity_index)


def planar_base(q: np.ndarray, v: np.ndarray) -> tuple[float, float, float, float, float]:
    """(x, y, heading, forward speed, yaw rate) [m, m, rad, m/s, rad/s] of a floating base
    from its quaternion and position (qw qx qy qz x y z) and world spatial velocity (wx wy
    wz vx vy vz)."""
    w, qx, qy, qz = q[:4]
    heading = math.atan2(2.0 * (w * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    forward = v[3] * math.cos(heading) + v[4] * math.sin(heading)
    return float(q[4]), float(q[5]), heading, float(forward), float(v[2])


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
        - <controller>.<topic>
        output_ports:
        - joint_states
        - desired_state
        - effort_command
        - <controller>.status

    - ``state``: [q; v] of the robot's model instance (``hardware.num_model_states``).
    - ``effort``: the robot's actuator torques [N m], hardware joint order;
      optional, when unconnected ``JointState.effort`` is empty.
    - ``<controller>.<topic>``: the command topic of each controller (a
      ``Publication`` of its ``message``), e.g. ``position_controller.commands``,
      ``trajectory_controller.joint_trajectory``.
    - ``joint_states``: the broadcaster's :class:`JointState` of its joints at the
      time it is evaluated (``stamp`` = that time), from the ``state`` and
      ``effort`` inputs; only with a broadcaster. Its consumers sample it at
      ``update_rate``, as a subscriber of upstream's broadcaster receives it.
    - ``desired_state``: [q_d; v_d] of every hardware joint in actuator order
      (2n) [rad, rad/s]: each controller's desired state on its position and
      velocity joints, the initial position (and zero velocity) on joints no
      controller claims. Entries of effort joints are unused.
    - ``effort_command``: the commanded torques [N m] of every hardware joint
      (n), non-zero only on effort joints and on the joints of a controller that
      feeds efforts forward (the trajectory controller's [position, effort]); only
      when a controller commands efforts.
    - ``<controller>.status``: each controller's ControllerStatus.
    - ``<controller>.command_count``: only for a stream controller
      (``ManagedController.stream``): vector of one, the number of samples of its
      stream applied so far (a SinusoidSequencer's ``tick_count``); its status is
      computed from it. The stream drives the hardware itself
      (:func:`AddStreamDesiredState`), so the rows of ``desired_state`` of its joints
      hold the initial positions.

    Each controller must claim joints whose hardware command interface is the
    one it commands. The controllers run in one periodic update at
    ``update_rate`` [Hz] from t = 0; ``desired_state``, ``effort_command`` and
    the statuses are state, so reading them costs nothing.
    """

    def __init__(
        self,
        *,
        hardware: HardwareInterface,
        update_rate: int,
        broadcaster: JointStateBroadcaster | None = None,
        controllers: Sequence[ManagedController] = (),
    ):
        super().__init__()
        check_update_rate(update_rate, "ControllerManager")
        names = [controller.name for controller in controllers]
        duplicates = sorted({name for name in names if names.count(name) > 1})
        if duplicates:
            raise ValueError(f"controllers {duplicates} are given more than once")
        n = len(hardware.joints)
        self._hardware = hardware
        self._broadcaster = broadcaster
        self._controllers = tuple(controllers)
        self._state = self.DeclareVectorInputPort("state", hardware.num_model_states)
        self._base_rows = _base_rows(hardware)
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
        interfaces = hardware.interfaces()
        self._command_ports = []
        self._measured_rows = []  # per controller: (q indices, v indices) into ``state``
        self._desired_rows = []  # per controller: its [q_d; v_d] rows in ``desired_state``
        self._effort_rows = []  # per controller: its rows in ``effort_command``, or None
        # The controllers' further topics: (controller index, topic leaf, input port); their
        # handled counts follow the controllers' in _Memories.handled.
        self._extra_ports: list[tuple[int, str, Any]] = []
        memories = []
        self._count_ports = []  # per controller: its "<name>.command_count" input, or None
        for controller in self._controllers:
            logic = controller.logic
            if not logic.topic:
                raise ValueError(f"controller {controller.name!r} has no command topic")
            self._command_ports.append(
                self.DeclareAbstractInputPort(
                    f"{controller.name}.{logic.topic}", PublicationValue()
                )
            )
            for topic in logic.extra_topics:
                self._extra_ports.append(
                    (
                        len(self._command_ports) - 1,
                        topic,
                        self.DeclareAbstractInputPort(
                            f"{controller.name}.{topic}", PublicationValue()
                        ),
                    )
                )
            if controller.stream and not takes_stream(logic):
                raise ValueError(
                    f"controller {controller.name!r} ({logic.type_name()}) takes no command stream"
                )
            self._count_ports.append(
                self.DeclareVectorInputPort(f"{controller.name}.command_count", 1)
                if controller.stream
                else None
            )
            unknown = [j for j in logic.joint_names if j not in hardware.joint_names]
            if unknown:
                raise ValueError(
                    f"controller {controller.name!r} claims {unknown}, which the hardware "
                    f"interface {hardware.name!r} does not actuate "
                    f"({', '.join(hardware.joint_names)})"
                )
            rows = hardware.find(list(logic.joint_names))
            for row in rows:
                if interfaces[row] != logic.interface:
                    raise ValueError(
                        f"controller {controller.name!r} commands the {logic.interface} "
                        f"interface of joint {hardware.joint_names[row]!r}, which the hardware "
                        f"interface {hardware.name!r} drives through {interfaces[row]}"
                    )
            self._measured_rows.append(
                (
                    np.array([hardware.position_index[i] for i in rows], dtype=int),
                    np.array([hardware.velocity_index[i] for i in rows], dtype=int),
                )
            )
            desired_rows = np.concatenate([rows, np.asarray(rows, dtype=int) + n]).astype(int)
            self._desired_rows.append(desired_rows)
            self._effort_rows.append(np.asarray(rows, dtype=int) if logic.effort_output else None)
            logic.configure(update_rate=update_rate)
            memory = logic.initial_memory()
            initial[desired_rows] = memory.desired
            memories.append(memory)
        self._memory_index = self.DeclareAbstractState(
            AbstractValue.Make(
                _Memories((0,) * (len(memories) + len(self._extra_ports)), tuple(memories))
            )
        )
        self._desired_index = self.DeclareDiscreteState(initial)
        # [0] when the only controller's desired state is the whole desired_state.
        self._whole = (
            [0]
            if len(self._desired_rows) == 1
            and np.array_equal(self._desired_rows[0], np.arange(2 * n))
            else None
        )
        self.DeclareStateOutputPort("desired_state", self._desired_index)
        self._effort_index = None
        if any(rows is not None for rows in self._effort_rows):
            self._effort_index = self.DeclareDiscreteState(np.zeros(n))
            self.DeclareStateOutputPort("effort_command", self._effort_index)
        for k, controller in enumerate(self._controllers):
            prerequisites = {self.abstract_state_ticket(self._memory_index)}
            if controller.stream:
                prerequisites.add(self._count_ports[k].ticket())
            self.DeclareAbstractOutputPort(
                f"{controller.name}.status",
                lambda: AbstractValue.Make(ControllerStatus()),
                lambda context, output, k=k: output.set_value(self._Status(context, k)),
                prerequisites,
            )

        self._DeclarePublications()

        # Streams need no update: they drive the hardware in C++.
        if any(not controller.stream for controller in self._controllers):
            self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / update_rate, 0.0, self._Update)

    def _DeclarePublications(self) -> None:
        """What the controllers publish (a drive's odometry): ``<controller>.<leaf>``
        outputs computed from their memory."""
        for k, controller in enumerate(self._controllers):
            for leaf in controller.logic.outputs:
                self.DeclareAbstractOutputPort(
                    f"{controller.name}.{leaf}",
                    lambda logic=controller.logic, leaf=leaf: AbstractValue.Make(
                        logic.output(leaf, logic.initial_memory())
                    ),
                    lambda context, output, k=k, leaf=leaf: output.set_value(
                        self._Output(context, k, leaf)
                    ),
                    {self.abstract_state_ticket(self._memory_index)},
                )

    @property
    def broadcaster(self) -> JointStateBroadcaster | None:
        return self._broadcaster

    @property
    def controllers(self) -> tuple[ManagedController, ...]:
        return self._controllers

    def _Status(self, context, k: int) -> ControllerStatus:
        status = context.get_abstract_state(self._memory_index).get_value().memories[k].status
        port = self._count_ports[k]
        if port is None:
            return status
        count = round(float(port.Eval(context)[0])) if port.HasValue(context) else 0
        return self._controllers[k].logic.stream_status(status, count)

    def _Output(self, context, k: int, leaf: str):
        memory = context.get_abstract_state(self._memory_index).get_value().memories[k]
        return self._controllers[k].logic.output(leaf, memory)

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
        for e, (k, topic, port) in enumerate(self._extra_ports):
            slot = len(items) + e
            if port.HasValue(context):
                publication = port.Eval(context)
                if publication.count > handled[slot]:
                    new_handled = new_handled or list(handled)
                    new_handled[slot] = publication.count
                    new_items = new_items or list(items)
                    new_items[k] = self._controllers[k].logic.receive(
                        topic, publication.message, new_items[k]
                    )
        x = None  # the measured state, evaluated when a controller needs it
        for k, controller in enumerate(self._controllers):
            if controller.stream:
                continue  # driven in C++; its status is computed from the sample count
            message = None
            port = self._command_ports[k]
            if port.HasValue(context):
                publication = port.Eval(context)
                if publication.count > handled[k]:
                    new_handled = new_handled or list(handled)
                    new_handled[k] = publication.count
                    message = publication.message
            memory = items[k] if new_items is None else new_items[k]
            if message is None and not memory.busy:
                continue  # nothing new and nothing running: the commands hold
            if x is None and self._state.HasValue(context):
                x = self._state.Eval(context)
            new_items = new_items or list(items)
            new_items[k] = controller.logic.update(
                context.get_time(),
                message,
                memory,
                _Measure(x, *self._measured_rows[k], self._base_rows),
            )
        if new_handled is None and new_items is None:
            return DID_NOTHING
        new = _Memories(tuple(new_handled or handled), tuple(new_items or items))
        state.get_mutable_abstract_state(self._memory_index).set_value(new)
        changed = [k for k in range(len(items)) if new.memories[k].desired is not items[k].desired]
        if changed == self._whole:  # one controller on every joint, in hardware order
            state.get_mutable_discrete_state(self._desired_index).SetFromVector(
                new.memories[0].desired
            )
        elif changed:
            desired = np.array(context.get_discrete_state(self._desired_index).get_value())
            for k in changed:
                desired[self._desired_rows[k]] = new.memories[k].desired
            state.get_mutable_discrete_state(self._desired_index).SetFromVector(desired)
        changed = [
            k
            for k in range(len(items))
            if self._effort_rows[k] is not None and new.memories[k].effort is not items[k].effort
        ]
        if changed:
            effort = np.array(context.get_discrete_state(self._effort_index).get_value())
            for k in changed:
                effort[self._effort_rows[k]] = new.memories[k].effort
            state.get_mutable_discrete_state(self._effort_index).SetFromVector(effort)
        return EventStatus.Succeeded()


def AddStreamDesiredState(
    builder: DiagramBuilder,
    hardware: HardwareInterface,
    joint_names: Sequence[str],
    command: OutputPort,
) -> OutputPort:
    """The desired state [q_d; v_d] (2n, hardware order) [rad, rad/s] of a stream
    controller that commands every hardware joint: ``command`` (its joint positions,
    in ``joint_names`` order, as the manager's ticks apply them, e.g. a
    SinusoidSequencer's ``tick_command``) placed into q_d, v_d = 0, as the position
    controller writes a command. A ``MatrixGain`` named ``stream_desired_state``,
    C++: its output depends on its input only, so what it feeds (the plant's desired
    state, the gravity feed-forward) changes when the command does, not at every
    plant step."""
    n = len(hardware.joints)
    if sorted(joint_names) != sorted(hardware.joint_names):
        raise ValueError(
            f"a stream controller on {list(joint_names)} must command every joint of "
            f"{hardware.name!r} ({', '.join(hardware.joint_names)})"
        )
    place = np.zeros((2 * n, len(joint_names)))
    for column, row in enumerate(hardware.find(list(joint_names))):
        place[row, column] = 1.0
    gain = builder.AddNamedSystem("stream_desired_state", MatrixGain(place))
    builder.Connect(command, gain.get_input_port())
    return gain.get_output_port()


def AddJointStateVector(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    hardware: HardwareInterface,
    instance,
    joint_names: Sequence[str],
    effort: OutputPort | None = None,
) -> OutputPort:
    """The broadcaster's vector view, in C++: [positions; velocities; efforts] of
    ``joint_names`` in that order (3n) [rad, rad/s, N m], from the plant's state and
    net actuation of ``instance``. What the broadcaster publishes as
    ``JointState``, as one vector that Drake's ``VectorLogSink`` records without
    any Python. Returns that output port: a ``Multiplexer`` named
    ``joint_state_vector`` of the state and ``effort`` (default: the plant's net
    actuation), followed by a ``MatrixGain`` named ``joint_state_select`` that
    picks the rows, only when the joints are not the state's own, in its order (every
    system costs a little at each plant step, even one that computes only when read).
    """
    state = plant.get_state_output_port(instance)
    if effort is None:
        effort = plant.get_net_actuation_output_port(instance)
    rows = hardware.find(list(joint_names))
    n = len(rows)
    select = np.zeros((3 * n, state.size() + effort.size()))
    for i, row in enumerate(rows):
        select[i, hardware.position_index[row]] = 1.0
        select[n + i, hardware.velocity_index[row]] = 1.0
        select[2 * n + i, state.size() + row] = 1.0
    stack = builder.AddNamedSystem("joint_state_vector", Multiplexer([state.size(), effort.size()]))
    builder.Connect(state, stack.get_input_port(0))
    builder.Connect(effort, stack.get_input_port(1))
    if np.array_equal(select, np.eye(3 * n)):  # False when the shapes differ
        return stack.get_output_port()
    gain = builder.AddNamedSystem("joint_state_select", MatrixGain(select))
    builder.Connect(stack.get_output_port(), gain.get_input_port())
    return gain.get_output_port()
