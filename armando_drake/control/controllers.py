"""ros2_control's controllers as Drake systems.

Each system reproduces one upstream controller (``joint_state_broadcaster``,
``position_controllers/JointGroupPositionController``,
``joint_trajectory_controller``) on its own joint list, in its own order.
All Python work happens in one periodic unrestricted update at the
controller manager's ``update_rate``; the outputs are state output ports, so
reading them between updates costs nothing. A controller reads a topic port
(a :class:`~armando_drake.control.messages.Publication`) and handles each message
once, when the publication count has grown since the last update it ran.

Every rejected message is logged on ``armando_drake.control.controllers`` with
upstream's wording and counted on the ``status`` output; the controller keeps
its previous command.

Each controller's logic is a plain class (:class:`JointStateBroadcasterLogic`,
:class:`PositionControllerLogic`, :class:`TrajectoryControllerLogic`) that
the standalone systems here and the
:class:`~armando_drake.control.manager.ControllerManager` (all controllers
of a world in one system and one update, as upstream's controller_manager)
share: ``update(now, message, memory, measure)`` takes the controller's
:class:`ControllerMemory` and returns the next one.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.polynomial import Polynomial
from pydrake.systems.framework import EventStatus, LeafSystem
from pydrake.trajectories import PiecewisePolynomial

from armando_drake.control.config import JointTrajectoryControllerParams
from armando_drake.control.messages import (
    ControllerStatus,
    Float64MultiArray,
    JointState,
    JointTrajectory,
    PublicationValue,
)

_logger = logging.getLogger("armando_drake.control.controllers")

# Upstream's "is this velocity zero" threshold: std::numeric_limits<float>::epsilon().
_FLOAT_EPSILON = float(np.finfo(np.float32).eps)


def _joint_names(joint_names: Sequence[str]) -> tuple[str, ...]:
    names = tuple(joint_names)
    if not names:
        raise ValueError(f"joint_names={joint_names!r} must not be empty")
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise ValueError(f"joint_names={joint_names!r} repeats {duplicates}")
    return names


def _period(update_rate: float) -> float:
    if isinstance(update_rate, bool) or not (
        isinstance(update_rate, (int, float)) and math.isfinite(update_rate) and update_rate > 0
    ):
        raise ValueError(f"update_rate={update_rate!r} must be a positive number [Hz]")
    return 1.0 / update_rate


def _limits(
    names: tuple[str, ...], lower: Sequence[float] | None, upper: Sequence[float] | None
) -> tuple[np.ndarray, np.ndarray]:
    n = len(names)
    low = np.full(n, -np.inf) if lower is None else np.asarray(lower, dtype=float)
    high = np.full(n, np.inf) if upper is None else np.asarray(upper, dtype=float)
    if low.shape != (n,) or high.shape != (n,):
        raise ValueError(f"lower={lower!r} and upper={upper!r} must each have {n} values")
    for name, lo, hi in zip(names, low.tolist(), high.tolist(), strict=True):
        if np.isnan(lo) or np.isnan(hi) or lo > hi:
            raise ValueError(f"limits [{lo}, {hi}] of joint '{name}' are not an interval")
    return low, high


def _initial_positions(
    names: tuple[str, ...],
    initial_positions: Sequence[float] | None,
    lower: np.ndarray,
    upper: np.ndarray,
) -> np.ndarray:
    if initial_positions is None:
        return np.clip(np.zeros(len(names)), lower, upper)
    q0 = np.asarray(initial_positions, dtype=float)
    if q0.shape != (len(names),) or not np.all(np.isfinite(q0)):
        raise ValueError(
            f"initial_positions={initial_positions!r} must be {len(names)} finite values"
        )
    clamped = np.clip(q0, lower, upper)
    for name, value, inside in zip(names, q0.tolist(), clamped.tolist(), strict=True):
        if value != inside:
            _logger.warning(
                "initial position %r of joint '%s' is outside its limits; starting at %r",
                value,
                name,
                inside,
            )
    return clamped


# What an update with nothing to do returns: Drake then neither copies the system's
# state back nor invalidates what depends on it.
DID_NOTHING = EventStatus.DidNothing()


class _Rejected(Exception):
    """A message the controller drops; the argument is the logged reason."""


@dataclasses.dataclass(frozen=True)
class ControllerMemory:
    """What a command controller keeps between updates. Never mutated: an update
    that changes something returns a new one (so Drake's copy of it is free)."""

    desired: np.ndarray  # [rad, rad/s] [q_d; v_d] (2n) in the controller's joint order
    status: ControllerStatus  # what it reports; replaced, never mutated
    trajectory: _ActiveTrajectory | None = None  # the running trajectory, if any
    # Whether the controller has work at every update, without a new message: a
    # trajectory being executed. Derived from the fields above.
    busy: bool = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self):
        busy = self.trajectory is not None and self.status.state == "executing"
        object.__setattr__(self, "busy", busy)

    def __deepcopy__(self, memo):
        return self


def _measured(system, port, context, desired: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Measured [q, v] from ``port``, or the desired state when it is unconnected."""
    n = system._n
    if port.HasValue(context):
        x = port.Eval(context)
        return np.array(x[:n]), np.array(x[n:])
    return desired[:n].copy(), desired[n:].copy()


class JointStateBroadcasterLogic:
    """The broadcaster's message: a :class:`JointState` of ``joint_names``."""

    def __init__(self, *, joint_names: Sequence[str]):
        self.joint_names = _joint_names(joint_names)
        self.n = len(self.joint_names)

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


class JointStateBroadcaster(LeafSystem):
    """``joint_state_broadcaster/JointStateBroadcaster``: publishes the joint states.

    .. pydrake_system::

        name: JointStateBroadcaster
        input_ports:
        - state
        - effort
        output_ports:
        - joint_states

    - ``state``: [q; v] of ``joint_names`` in that order (2n) [rad, rad/s].
    - ``effort``: measured joint efforts (n) [N m]; optional, when
      unconnected ``JointState.effort`` is empty.
    - ``joint_states``: a :class:`JointState` sampled at every update
      (``stamp`` = the update time), refreshed at ``update_rate`` [Hz].
    """

    def __init__(self, *, joint_names: Sequence[str], update_rate: float):
        super().__init__()
        self._logic = JointStateBroadcasterLogic(joint_names=joint_names)
        self._names = self._logic.joint_names
        self._n = n = self._logic.n
        period = _period(update_rate)
        self._state = self.DeclareVectorInputPort("state", 2 * n)
        self._effort = self.DeclareVectorInputPort("effort", n)
        initial = self._logic.initial_message()
        self._joint_states_index = self.DeclareAbstractState(AbstractValue.Make(initial))
        self.DeclareStateOutputPort("joint_states", self._joint_states_index)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._UpdateJointStates)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._UpdateJointStates)

    def _UpdateJointStates(self, context, state):
        if not self._state.HasValue(context):
            return
        x = self._state.Eval(context).tolist()  # Python floats
        effort = []
        if self._effort.HasValue(context):
            effort = self._effort.Eval(context).tolist()
        n = self._n
        message = self._logic.message(context.get_time(), x[:n], x[n:], effort)
        state.get_mutable_abstract_state(self._joint_states_index).set_value(message)


class _CommandLogic:
    """What the position and trajectory controllers' logic shares: joints, limits."""

    def __init__(
        self,
        *,
        joint_names: Sequence[str],
        lower: Sequence[float] | None,
        upper: Sequence[float] | None,
        initial_positions: Sequence[float] | None,
        initial_state: str,
        log_name: Callable[[], str],
    ):
        self.joint_names = _joint_names(joint_names)
        self.n = n = len(self.joint_names)
        self.lower, self.upper = _limits(self.joint_names, lower, upper)
        q0 = _initial_positions(self.joint_names, initial_positions, self.lower, self.upper)
        self._initial = ControllerMemory(
            desired=np.concatenate([q0, np.zeros(n)]),
            status=ControllerStatus(state=initial_state),
        )
        self._log_name = log_name  # the controller's name in log lines

    def initial_memory(self) -> ControllerMemory:
        return self._initial

    def needs_update(self, message, memory: ControllerMemory) -> bool:
        """Whether :meth:`update` could change anything (else the memory holds): a new
        message, or a controller that is busy (``memory.busy``)."""
        return message is not None or memory.busy

    def update(self, now: float, message, memory: ControllerMemory, measure) -> ControllerMemory:
        """The memory after the update at ``now`` [s]; ``message`` is the new message or None;
        ``measure(desired)`` gives the measured (q, v) [rad, rad/s]. Returns ``memory``
        itself when nothing changes."""
        raise NotImplementedError

    def _Reject(self, status: ControllerStatus, reason: str) -> ControllerStatus:
        _logger.error("%s: %s", self._log_name(), reason)
        return dataclasses.replace(
            status, rejected=status.rejected + 1, last_error=reason, detail=dict(status.detail)
        )


class _CommandController(LeafSystem):
    """What the position and trajectory controller systems share: ports and state."""

    def __init__(self, *, logic: _CommandLogic, update_rate: float, command_port: str):
        super().__init__()
        self._logic = logic
        self._names = logic.joint_names
        self._n = n = logic.n
        self._period = _period(update_rate)
        self._lower, self._upper = logic.lower, logic.upper
        initial = logic.initial_memory()
        self._commands = self.DeclareAbstractInputPort(command_port, PublicationValue())
        self._state = self.DeclareVectorInputPort("state", 2 * n)
        self._desired_index = self.DeclareDiscreteState(initial.desired)
        self._handled_index = self.DeclareAbstractState(AbstractValue.Make(0))
        self._status_index = self.DeclareAbstractState(AbstractValue.Make(initial.status))
        self._trajectory_index = self.DeclareAbstractState(AbstractValue.Make(None))
        self.DeclareStateOutputPort("desired_state", self._desired_index)
        self.DeclareStateOutputPort("status", self._status_index)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._Update)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._names

    def _LogName(self) -> str:
        return self.get_name() or type(self).__name__

    def _NewMessage(self, context, state):
        """The message published since the last update, or None; marks it handled."""
        if not self._commands.HasValue(context):
            return None
        publication = self._commands.Eval(context)
        handled = context.get_abstract_state(self._handled_index).get_value()
        if publication.count <= handled:
            return None
        state.get_mutable_abstract_state(self._handled_index).set_value(publication.count)
        return publication.message

    def _Update(self, context, state):
        message = self._NewMessage(context, state)
        memory = ControllerMemory(
            desired=None,
            status=context.get_abstract_state(self._status_index).get_value(),
            trajectory=context.get_abstract_state(self._trajectory_index).get_value(),
        )
        if not self._logic.needs_update(message, memory):
            return DID_NOTHING  # Drake then copies and invalidates nothing
        memory = dataclasses.replace(
            memory, desired=np.array(context.get_discrete_state(self._desired_index).get_value())
        )
        new = self._logic.update(
            context.get_time(),
            message,
            memory,
            lambda desired: _measured(self, self._state, context, desired),
        )
        if new.desired is not memory.desired:
            state.get_mutable_discrete_state(self._desired_index).SetFromVector(new.desired)
        if new.status is not memory.status:
            state.get_mutable_abstract_state(self._status_index).set_value(new.status)
        if new.trajectory is not memory.trajectory:
            state.get_mutable_abstract_state(self._trajectory_index).set_value(new.trajectory)


class PositionControllerLogic(_CommandLogic):
    """The logic of :class:`JointGroupPositionController`."""

    def __init__(
        self,
        *,
        joint_names: Sequence[str],
        lower: Sequence[float] | None = None,
        upper: Sequence[float] | None = None,
        initial_positions: Sequence[float] | None = None,
        log_name: Callable[[], str] = lambda: "JointGroupPositionController",
    ):
        super().__init__(
            joint_names=joint_names,
            lower=lower,
            upper=upper,
            initial_positions=initial_positions,
            initial_state="holding",
            log_name=log_name,
        )

    def _Validate(self, message) -> tuple[np.ndarray, str]:
        """The command to write and a clamping warning ("" if none)."""
        if not isinstance(message, Float64MultiArray):
            raise _Rejected(f"expected a Float64MultiArray message, got {type(message).__name__}")
        data = np.asarray(message.data, dtype=float).reshape(-1)
        if not np.all(np.isfinite(data)):
            raise _Rejected("Non-finite value received. Dropping message")
        if data.size != self.n:
            raise _Rejected(
                f"command size ({data.size}) does not match number of interfaces ({self.n})"
            )
        command = np.clip(data, self.lower, self.upper)
        warnings = [
            f"command {value!r} for joint '{name}' is outside its limits [{lo!r}, {hi!r}]; "
            f"clamped to {clamped!r}"
            for name, value, clamped, lo, hi in zip(
                self.joint_names,
                data.tolist(),
                command.tolist(),
                self.lower.tolist(),
                self.upper.tolist(),
                strict=True,
            )
            if value != clamped
        ]
        return command, "; ".join(warnings)

    def update(self, now, message, memory, measure):
        if message is None:
            return memory
        status = memory.status
        try:
            command, warning = self._Validate(message)
        except _Rejected as rejection:
            return dataclasses.replace(memory, status=self._Reject(status, str(rejection)))
        if warning:
            _logger.warning("%s: %s", self._log_name(), warning)
        status = dataclasses.replace(
            status,
            state="active",
            accepted=status.accepted + 1,
            detail={"warning": warning} if warning else {},
        )
        return ControllerMemory(np.concatenate([command, np.zeros(self.n)]), status, None)


class JointGroupPositionController(_CommandController):
    """``position_controllers/JointGroupPositionController`` (and
    ``forward_command_controller/ForwardCommandController`` on ``position``).

    .. pydrake_system::

        name: JointGroupPositionController
        input_ports:
        - commands
        - state
        output_ports:
        - desired_state
        - status

    - ``commands``: a ``Publication`` of :class:`Float64MultiArray`, one
      position per joint in ``joint_names`` order [rad] (the topic
      ``/<controller>/commands``).
    - ``state``: measured [q; v] (2n); not needed for position commands.
    - ``desired_state``: [q_d; v_d] (2n) with v_d = 0; until the first command
      q_d holds ``initial_positions`` (default 0 clamped into the limits).
    - ``status``: :class:`ControllerStatus`, state ``holding`` until the first
      accepted command, then ``active``.

    A message with a NaN/Inf element ("Non-finite value received. Dropping
    message") or with the wrong size, empty included ("command size (N) does
    not match number of interfaces (M)"), is dropped and the previous command
    kept; the controller stays active. A position outside
    [``lower``, ``upper``] is clamped into the limits and the command
    accepted, with the warning in ``status.detail["warning"]``.
    """

    def __init__(
        self,
        *,
        joint_names: Sequence[str],
        lower: Sequence[float] | None = None,
        upper: Sequence[float] | None = None,
        update_rate: float,
        initial_positions: Sequence[float] | None = None,
    ):
        _joint_names(joint_names)
        _period(update_rate)
        logic = PositionControllerLogic(
            joint_names=joint_names,
            lower=lower,
            upper=upper,
            initial_positions=initial_positions,
            log_name=lambda: self._LogName(),
        )
        super().__init__(logic=logic, update_rate=update_rate, command_port="commands")


@dataclasses.dataclass(frozen=True)
class _Knot:
    """One knot of the desired trajectory, in controller joint order."""

    time: float  # [s] simulation time
    positions: np.ndarray  # [rad] (n)
    velocities: np.ndarray | None  # [rad/s] (n), None when not given
    accelerations: np.ndarray | None  # [rad/s^2] (n), None when not given


def _segment_coefficients(a: _Knot, b: _Knot) -> np.ndarray:
    """Per joint, the ascending coefficients in (t - a.time) of the segment a -> b.

    Linear with positions only at either end, cubic Hermite when both ends give
    velocities, quintic when both also give accelerations (upstream's rule).
    """
    T = b.time - a.time
    p0, p1 = a.positions, b.positions
    if a.velocities is None or b.velocities is None:
        return np.stack([p0, (p1 - p0) / T], axis=1)
    v0, v1 = a.velocities, b.velocities
    if a.accelerations is None or b.accelerations is None:
        c2 = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * T) / T**2
        c3 = (2.0 * (p0 - p1) + (v0 + v1) * T) / T**3
        return np.stack([p0, v0, c2, c3], axis=1)
    a0, a1 = a.accelerations, b.accelerations
    c3 = (20.0 * (p1 - p0) - (8.0 * v1 + 12.0 * v0) * T - (3.0 * a0 - a1) * T**2) / (2.0 * T**3)
    c4 = (30.0 * (p0 - p1) + (14.0 * v1 + 16.0 * v0) * T + (3.0 * a0 - 2.0 * a1) * T**2) / (
        2.0 * T**4
    )
    c5 = (12.0 * (p1 - p0) - 6.0 * (v1 + v0) * T - (a0 - a1) * T**2) / (2.0 * T**5)
    return np.stack([p0, v0, 0.5 * a0, c3, c4, c5], axis=1)


@dataclasses.dataclass(frozen=True)
class _ActiveTrajectory:
    """An accepted trajectory, sampled at each update. Never mutated."""

    position: PiecewisePolynomial | None  # q_d(t) (n x 1); None if it has ended on arrival
    velocity: PiecewisePolynomial | None  # v_d(t) (n x 1)
    end_time: float  # [s] time of the last point
    goal: np.ndarray  # [rad] positions of the last point (n)

    def __deepcopy__(self, memo):
        return self

    def sample(self, time: float) -> tuple[np.ndarray, np.ndarray, bool]:
        """Desired (q, v) at ``time`` and whether the trajectory has ended."""
        if self.position is None or time >= self.end_time:
            return self.goal.copy(), np.zeros_like(self.goal), True
        time = max(time, self.position.start_time())
        return (
            self.position.value(time).reshape(-1),
            self.velocity.value(time).reshape(-1),
            False,
        )

    @staticmethod
    def build(knots: list[_Knot], hold: bool) -> _ActiveTrajectory:
        goal = knots[-1].positions.copy()
        if len(knots) < 2:
            return _ActiveTrajectory(None, None, knots[-1].time, goal)
        breaks = [knot.time for knot in knots]
        if hold:
            # interpolation_method: none -- each point's values until the next one.
            positions = np.stack([knot.positions for knot in knots], axis=1)
            velocities = np.stack(
                [
                    np.zeros_like(knot.positions) if knot.velocities is None else knot.velocities
                    for knot in knots
                ],
                axis=1,
            )
            return _ActiveTrajectory(
                PiecewisePolynomial.ZeroOrderHold(breaks, positions),
                PiecewisePolynomial.ZeroOrderHold(breaks, velocities),
                breaks[-1],
                goal,
            )
        segments = []
        for a, b in zip(knots[:-1], knots[1:], strict=True):
            coefficients = _segment_coefficients(a, b)
            segments.append(np.array([[Polynomial(row)] for row in coefficients], dtype=object))
        position = PiecewisePolynomial(segments, breaks)
        return _ActiveTrajectory(position, position.derivative(1), breaks[-1], goal)


class TrajectoryControllerLogic(_CommandLogic):
    """The logic of :class:`JointTrajectoryController`."""

    def __init__(
        self,
        *,
        joint_names: Sequence[str],
        lower: Sequence[float] | None = None,
        upper: Sequence[float] | None = None,
        params: JointTrajectoryControllerParams | None = None,
        initial_positions: Sequence[float] | None = None,
        log_name: Callable[[], str] = lambda: "JointTrajectoryController",
    ):
        super().__init__(
            joint_names=joint_names,
            lower=lower,
            upper=upper,
            initial_positions=initial_positions,
            initial_state="idle",
            log_name=log_name,
        )
        names = self.joint_names
        if params is None:
            params = JointTrajectoryControllerParams(joints=list(names))
        if tuple(params.joints) != names:
            raise ValueError(f"params.joints={params.joints!r} differs from joint_names={names!r}")
        if params.interpolation_method not in ("splines", "none"):
            raise ValueError(
                f"interpolation_method={params.interpolation_method!r} must be splines or none"
            )
        self._params = params
        self._path_tolerance = np.array(
            [params.trajectory_tolerance.get(name, 0.0) for name in names]
        )
        self._goal_tolerance = np.array([params.goal_tolerance.get(name, 0.0) for name in names])

    def _Validate(self, message, now: float) -> list[int]:
        """Controller index of each message joint; raises _Rejected in upstream's order."""
        if not isinstance(message, JointTrajectory):
            raise _Rejected(f"expected a JointTrajectory message, got {type(message).__name__}")
        names = list(message.joint_names)
        points = message.points
        if not self._params.allow_partial_joints_goal and len(names) != self.n:
            raise _Rejected("Joints on incoming trajectory don't match the controller joints.")
        if not names:
            raise _Rejected("Empty joint names on incoming trajectory.")
        if not points:
            raise _Rejected("Empty trajectory received.")
        for i, name in enumerate(names):
            if name not in self.joint_names:
                raise _Rejected(f"Incoming joint {name} doesn't match the controller's joints.")
            if name in names[:i]:
                raise _Rejected(f"Incoming joint {name} appears more than once.")
        if not self._params.allow_nonzero_velocity_at_trajectory_end:
            for name, velocity in zip(names, points[-1].velocities, strict=False):
                if abs(velocity) > _FLOAT_EPSILON:
                    raise _Rejected(
                        f"Velocity of last trajectory point of joint {name} is not zero: "
                        f"{velocity:.15f}"
                    )
        if not math.isfinite(message.stamp):
            raise _Rejected(f"Non-finite header stamp received: {message.stamp}")
        if message.stamp != 0.0:
            end = message.stamp + points[-1].time_from_start
            if end < now:
                raise _Rejected(
                    f"Received trajectory with non-zero start time ({message.stamp:f}) "
                    f"that ends in the past ({end:f})"
                )
        for i, point in enumerate(points):
            time = point.time_from_start
            if not math.isfinite(time):
                raise _Rejected(f"Non-finite time_from_start at point #{i}: {time}")
            if time < 0.0:
                raise _Rejected(f"Time from start of point #{i} is negative: {time:f}")
            if i > 0 and time <= points[i - 1].time_from_start:
                raise _Rejected(
                    f"Time between points {i - 1} and {i} is not strictly increasing, "
                    f"it is {points[i - 1].time_from_start:f} and {time:f} respectively"
                )
            for field in ("positions", "velocities", "accelerations"):
                values = getattr(point, field)
                if field != "positions" and len(values) == 0:
                    continue
                if len(values) != len(names):
                    raise _Rejected(
                        f"Mismatch between joint_names size ({len(names)}) and {field} "
                        f"({len(values)}) at point #{i}."
                    )
            if len(point.effort) != 0:
                raise _Rejected(
                    "Trajectories with effort fields are only supported for controllers using "
                    "the 'effort' command interface."
                )
            for field in ("positions", "velocities", "accelerations"):
                if not np.all(np.isfinite(np.asarray(getattr(point, field), dtype=float))):
                    raise _Rejected(f"Non-finite value in {field} at point #{i}.")
        return [self.joint_names.index(name) for name in names]

    def _Knots(self, message, indices, now, desired, q, v) -> list[_Knot]:
        """The trajectory's knots in controller order, starting from the current state."""
        n = self.n
        named = np.zeros(n, dtype=bool)
        named[indices] = True
        command = desired[:n]
        start = message.stamp if message.stamp != 0.0 else now

        def full(values, fill):
            if len(values) == 0:
                return None
            result = fill.copy()
            result[indices] = values
            return result

        knots = [
            _Knot(
                time=start + point.time_from_start,
                positions=full(point.positions, command),
                velocities=full(point.velocities, np.zeros(n)),
                accelerations=full(point.accelerations, np.zeros(n)),
            )
            for point in message.points
        ]
        if knots[0].time > now:
            hold = self._params.interpolation_method == "none"
            measured_velocity = "velocity" in self._params.state_interfaces and not hold
            current = _Knot(
                time=now,
                positions=np.where(named, q, command),
                velocities=np.where(named, v, 0.0) if measured_velocity else None,
                accelerations=None,
            )
            knots.insert(0, current)
        return knots

    def update(self, now, message, memory, measure):
        if not self.needs_update(message, memory):
            return memory  # nothing new and nothing running: the desired state holds
        n = self.n
        desired = memory.desired
        status, trajectory = memory.status, memory.trajectory
        q, v = measure(desired)
        if message is not None:
            try:
                indices = self._Validate(message, now)
            except _Rejected as rejection:
                status = self._Reject(status, str(rejection))
            else:
                knots = self._Knots(message, indices, now, desired, q, v)
                trajectory = _ActiveTrajectory.build(
                    knots, self._params.interpolation_method == "none"
                )
                detail = {"start_time": knots[0].time, "end_time": trajectory.end_time}
                outside = [
                    f"point positions of joint '{name}' leave its limits [{lo!r}, {hi!r}]; "
                    f"the desired position is clamped"
                    for j, (name, lo, hi) in enumerate(
                        zip(self.joint_names, self.lower.tolist(), self.upper.tolist(), strict=True)
                    )
                    if any(not lo <= k.positions[j] <= hi for k in knots[-len(message.points) :])
                ]
                if outside:
                    detail["warning"] = "; ".join(outside)
                    _logger.warning("%s: %s", self._log_name(), detail["warning"])
                status = dataclasses.replace(
                    status, state="executing", accepted=status.accepted + 1, detail=detail
                )
        if trajectory is None or status.state != "executing":
            return ControllerMemory(desired, status, trajectory)
        q_d, v_d, ended = trajectory.sample(now)
        outcome = None
        if not ended:
            error = np.abs(q - q_d)
            violated = (self._path_tolerance > 0) & (error > self._path_tolerance)
            if np.any(violated):
                j = int(np.argmax(violated))
                outcome = (
                    "aborted",
                    f"path tolerance violated: joint '{self.joint_names[j]}' is "
                    f"{error[j]:.6g} rad from its desired position {q_d[j]:.6g} (trajectory "
                    f"tolerance {self._path_tolerance[j]:g})",
                )
        else:
            outcome = self._GoalOutcome(now, trajectory, q, v)
        if outcome is not None and outcome[0] == "aborted":
            q_d, v_d = q.copy(), np.zeros(n)
            _logger.warning("%s: %s", self._log_name(), outcome[1])
            status = dataclasses.replace(
                status, state="aborted", last_error=outcome[1], detail=dict(status.detail)
            )
        elif outcome is not None:
            status = dataclasses.replace(status, state="succeeded", detail=dict(status.detail))
        if outcome is not None:
            trajectory = None
        q_d = np.clip(q_d, self.lower, self.upper)
        return ControllerMemory(np.concatenate([q_d, v_d]), status, trajectory)

    def _GoalOutcome(self, now, trajectory, q, v) -> tuple[str, str] | None:
        """("succeeded", "") at the goal, ("aborted", reason) past goal_time, else None."""
        goal = np.clip(trajectory.goal, self.lower, self.upper)
        error = np.abs(q - goal)
        far = (self._goal_tolerance > 0) & (error > self._goal_tolerance)
        stopped_tolerance = self._params.stopped_velocity_tolerance
        moving = (stopped_tolerance > 0) & (np.abs(v) > stopped_tolerance)
        if not np.any(far) and not np.any(moving):
            return ("succeeded", "")
        goal_time = self._params.goal_time
        late = now - trajectory.end_time
        if goal_time <= 0 or late <= goal_time:
            return None
        if np.any(far):
            j = int(np.argmax(far))
            problem = (
                f"joint '{self.joint_names[j]}' is {error[j]:.6g} rad from its goal {goal[j]:.6g} "
                f"(goal tolerance {self._goal_tolerance[j]:g})"
            )
        else:
            j = int(np.argmax(moving))
            problem = (
                f"joint '{self.joint_names[j]}' still moves at {v[j]:.6g} rad/s "
                f"(stopped_velocity_tolerance {stopped_tolerance:g})"
            )
        return ("aborted", f"goal tolerance violated: {problem} {late:.6g} s after the end")


class JointTrajectoryController(_CommandController):
    """``joint_trajectory_controller/JointTrajectoryController``.

    .. pydrake_system::

        name: JointTrajectoryController
        input_ports:
        - joint_trajectory
        - state
        output_ports:
        - desired_state
        - status

    - ``joint_trajectory``: a ``Publication`` of :class:`JointTrajectory`
      (the topic ``/<controller>/joint_trajectory``).
    - ``state``: measured [q; v] (2n) of ``joint_names``; the start of a new
      trajectory and the tolerance checks use it. Unconnected, the controller
      takes its own desired state as the measurement.
    - ``desired_state``: [q_d; v_d] (2n) sampled at each update [rad, rad/s],
      clamped into [``lower``, ``upper``]; holds ``initial_positions`` until
      the first trajectory.
    - ``status``: :class:`ControllerStatus` with state ``idle``, ``executing``,
      ``succeeded`` or ``aborted`` (reason in ``last_error``).

    A message is validated as upstream does, in upstream's order, and then
    more strictly: a joint named twice, a negative ``time_from_start`` and
    NaN/Inf anywhere are rejected too. An accepted trajectory replaces the
    running one. Its first segment runs from the measured state at the update
    that accepts it (the state's velocities only if ``state_interfaces``
    lists velocity; accelerations are not measured) to the first point;
    joints a partial goal leaves out hold their current command. Each segment
    is linear, cubic or quintic as the data at both ends allow
    (``interpolation_method: none`` holds each point's values instead). After
    the last point the controller holds it and checks the goal: every joint
    within ``goal_tolerance`` and slower than ``stopped_velocity_tolerance``
    -> ``succeeded``; still not so ``goal_time`` after the end ->
    ``aborted`` ("goal tolerance violated"). While running, a joint further
    than ``trajectory_tolerance`` from the desired position aborts with "path
    tolerance violated". An abort holds the measured position of that moment.
    """

    def __init__(
        self,
        *,
        joint_names: Sequence[str],
        lower: Sequence[float] | None = None,
        upper: Sequence[float] | None = None,
        update_rate: float,
        params: JointTrajectoryControllerParams | None = None,
        initial_positions: Sequence[float] | None = None,
    ):
        _joint_names(joint_names)
        _period(update_rate)
        logic = TrajectoryControllerLogic(
            joint_names=joint_names,
            lower=lower,
            upper=upper,
            params=params,
            initial_positions=initial_positions,
            log_name=lambda: self._LogName(),
        )
        super().__init__(logic=logic, update_rate=update_rate, command_port="joint_trajectory")
