"""Nav2's velocity smoother (``nav2_velocity_smoother``) between the controller and the base.

Nav2's bringup runs ``velocity_smoother`` on the controller server's command (remapped
``cmd_vel_nav`` -> ``cmd_vel``) and sends its output to the base. When the Nav2 file has a
``velocity_smoother`` section, :class:`VelocitySmoother` does the same here: at
``smoothing_frequency`` it takes the latest command, clamps it to ``min_velocity`` ..
``max_velocity`` and moves the current velocity towards it by at most
``max_accel / smoothing_frequency`` (speeding up: the command's magnitude is above the
current one's, same sign) or ``-max_decel / smoothing_frequency`` (slowing down or
passing through 0) per cycle, each axis (x, y, theta) on its own, or, with
``scale_velocities``, all scaled by the most limited axis' factor so that the command's
direction is kept. The current velocity is the last output (``feedback: OPEN_LOOP``) or
the mean twist of the odometry received within ``odom_duration`` (``CLOSED_LOOP``: the
drive's odometry, ``odom_topic``). Speeds below ``deadband_velocity`` are sent as 0 (the
next cycle starts from the value before the deadband, as Nav2's does). No command for
``velocity_timeout``: the target is 0, and once stopped nothing more is published.

:func:`find_eta_constraint` and :func:`apply_constraints` are Nav2's ``findEtaConstraint``
and ``applyConstraints``; :func:`smooth` is one cycle of its ``smootherTimer``, a pure
function of a :class:`SmootherState`.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from pathlib import Path

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from armando_drake.messages.types import Odometry, PublicationValue, Twist, TwistStamped
from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import param

_log = logging.getLogger("armando_drake.navigation")

NODE = "velocity_smoother"
FEEDBACKS = ("OPEN_LOOP", "CLOSED_LOOP")
AXES = "x, y, theta"
_VECTORS = ("max_velocity", "min_velocity", "max_accel", "max_decel", "deadband_velocity")
# Keys of the node that are the ROS node's own (clock, priority, topics' stamping).
_KNOWN = {
    "use_sim_time",
    "use_realtime_priority",
    "enable_stamped_cmd_vel",
    "bond_heartbeat_period",
}


@dc.dataclass
class VelocitySmootherParameters:
    """``velocity_smoother.ros__parameters`` (defaults: Nav2's). The vectors are
    (x, y, theta), or Nav2's 6-DoF (x, y, z, roll, pitch, yaw) of which x, y, yaw apply."""

    smoothing_frequency: float = param(
        20.0, unit="Hz", gt=0, doc="the rate of the smoothed commands"
    )
    feedback: str = param(
        "OPEN_LOOP",
        choices=FEEDBACKS,
        doc="the current velocity: the last command sent (OPEN_LOOP) or the odometry's "
        "(CLOSED_LOOP)",
    )
    scale_velocities: bool = param(
        False, doc="all axes scaled by the most limited one's factor (the direction kept)"
    )
    max_velocity: list[float] = param(
        [0.5, 0.0, 2.5], unit="m/s, m/s, rad/s", doc="the command clamped to at most this"
    )
    min_velocity: list[float] = param(
        [-0.5, 0.0, -2.5], unit="m/s, m/s, rad/s", doc="the command clamped to at least this"
    )
    max_accel: list[float] = param(
        [2.5, 0.0, 3.2], unit="m/s^2, m/s^2, rad/s^2", doc="the largest speed-up (>= 0)"
    )
    max_decel: list[float] = param(
        [-2.5, 0.0, -3.2], unit="m/s^2, m/s^2, rad/s^2", doc="the largest slow-down (<= 0)"
    )
    deadband_velocity: list[float] = param(
        [0.0, 0.0, 0.0], unit="m/s, m/s, rad/s", doc="a speed below it is sent as 0"
    )
    velocity_timeout: float = param(
        1.0, unit="s", ge=0, doc="no command for this long: the target is 0"
    )
    odom_topic: str = param("odom", doc="CLOSED_LOOP's odometry (the drive's here)")
    odom_duration: float = param(
        0.1, unit="s", ge=0, doc="CLOSED_LOOP: the odometry's twist averaged over this"
    )

    def check(self, where: str) -> None:
        """Nav2's on_configure checks, each a ConfigError naming the key."""
        sizes = {key: len(getattr(self, key)) for key in _VECTORS}
        size = sizes["max_velocity"]
        if size not in (3, 6) or any(n != size for n in sizes.values()):
            given = ", ".join(f"{k} {n}" for k, n in sizes.items())
            raise ConfigError(
                f"{where}: invalid setting of kinematic and/or deadband limits ({given}): all "
                f"must be of size 3 ({AXES}) or 6 (x, y, z, roll, pitch, yaw)"
            )
        for key in _VECTORS:
            values = getattr(self, key)
            if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
                raise ConfigError(f"{where}.{key}={values!r} must be finite numbers")
        rules = (
            ("max_decel", lambda v: v > 0.0, "positive deceleration: it must be <= 0"),
            ("max_accel", lambda v: v < 0.0, "negative acceleration: it must be >= 0"),
            ("min_velocity", lambda v: v > 0.0, "a positive minimum velocity: it must be <= 0"),
            ("max_velocity", lambda v: v < 0.0, "a negative maximum velocity: it must be >= 0"),
        )
        for key, bad, why in rules:
            values = getattr(self, key)
            if any(bad(v) for v in values):
                raise ConfigError(f"{where}.{key}={values!r}: {why}")
        if any(lo > hi for lo, hi in zip(self.min_velocity, self.max_velocity, strict=True)):
            raise ConfigError(
                f"{where}.min_velocity={self.min_velocity!r} is above "
                f"max_velocity={self.max_velocity!r}"
            )

    def planar(self, key: str) -> tuple[float, float, float]:
        """The (x, y, theta) of the vector ``key`` (a 6-DoF one's x, y, yaw)."""
        values = [float(v) for v in getattr(self, key)]
        return (values[0], values[1], values[-1])


def velocity_smoother_parameters(
    source: Nav2Params | str | Path,
) -> VelocitySmootherParameters | None:
    """The file's ``velocity_smoother`` node read and checked (None without one)."""
    nav2 = as_nav2(source)
    ros = nav2.node(NODE)
    if ros is None:
        return None
    where = nav2.where(NODE)
    params = VelocitySmootherParameters()
    for key in _VECTORS:
        if key in ros and not isinstance(ros[key], list):
            raise ConfigError(f"{where}.{key}={ros[key]!r} must be a list of numbers ({AXES})")
    for key in ("feedback", "odom_topic"):
        if key in ros and not isinstance(ros[key], str):
            raise ConfigError(f"{where}.{key}={ros[key]!r} must be a string")
    for key in fill(params, ros, where):
        if key not in _KNOWN:
            _log.warning("%s.%s: not used here", where, key)
    params.check(where)
    return params


def find_eta_constraint(
    v_curr: float, v_cmd: float, accel: float, decel: float, frequency: float
) -> float:
    """Nav2's ``findEtaConstraint``: the factor of the change ``v_cmd - v_curr`` that fits
    this cycle's limit, or -1 when the whole change fits."""
    dv = v_cmd - v_curr
    if abs(v_cmd) >= abs(v_curr) and v_curr * v_cmd >= 0.0:
        v_max, v_min = accel / frequency, -accel / frequency
    else:
        v_max, v_min = -decel / frequency, decel / frequency
    if dv > v_max:
        return v_max / dv
    if dv < v_min:
        return v_min / dv
    return -1.0


def apply_constraints(
    v_curr: float, v_cmd: float, accel: float, decel: float, eta: float, frequency: float
) -> float:
    """Nav2's ``applyConstraints``: ``v_curr`` moved by ``eta`` times the change towards
    ``v_cmd``, clamped to this cycle's acceleration (or deceleration) window."""
    dv = v_cmd - v_curr
    if abs(v_cmd) >= abs(v_curr) and v_curr * v_cmd >= 0.0:
        v_max, v_min = accel / frequency, -accel / frequency
    else:
        v_max, v_min = -decel / frequency, decel / frequency
    return v_curr + min(max(eta * dv, v_min), v_max)


@dc.dataclass(frozen=True)
class SmootherState:
    """The smoother's state between cycles; never mutated."""

    command: tuple = ()  # the latest command (vx, vy, wz); () before the first
    stamp: float = 0.0  # its header stamp (its arrival when 0)
    frame_id: str = ""
    command_time: float = 0.0  # [s] when it was received
    last: tuple = (0.0, 0.0, 0.0)  # the last output before the deadband (last_cmd_)
    stopped: bool = False  # timed out and stopped: nothing published
    odom: tuple = ()  # CLOSED_LOOP: ((stamp, vx, vy, wz), ...) within odom_duration
    received: int = 0  # the cmd_vel publications taken so far

    def __deepcopy__(self, memo):
        return self


def receive(state: SmootherState, message: TwistStamped, now: float) -> SmootherState:
    """``message`` taken as the latest command (one with NaN or inf is ignored)."""
    twist = message.twist
    command = (twist.linear[0], twist.linear[1], twist.angular[2])
    if not all(math.isfinite(v) for v in (*twist.linear, *twist.angular)):
        _log.error("velocity_smoother: a command with NaN or inf: ignored")
        return state
    stamp = message.stamp
    return dc.replace(
        state,
        command=command,
        stamp=stamp,
        frame_id=message.frame_id,
        command_time=stamp if stamp != 0.0 else now,
    )


def odom_twist(state: SmootherState, message: Odometry, duration: float) -> SmootherState:
    """``message`` added to the odometry window (nav2_util's OdomSmoother): the twists
    within ``duration`` of the newest kept."""
    sample = (message.stamp, message.linear[0], message.linear[1], message.angular[2])
    if state.odom and state.odom[-1][0] == sample[0]:
        return state
    kept = tuple(s for s in (*state.odom, sample) if s[0] >= sample[0] - duration)
    return dc.replace(state, odom=kept)


def smooth(
    params: VelocitySmootherParameters, state: SmootherState, now: float
) -> tuple[SmootherState, TwistStamped | None]:
    """One cycle of Nav2's ``smootherTimer`` at ``now``: (the state, the command to send,
    or None when nothing is sent)."""
    if not state.command:
        return state, None
    since = now - state.command_time
    command = state.command
    if since > params.velocity_timeout:
        if state.last == (0.0, 0.0, 0.0) or state.stopped:
            return dc.replace(state, stopped=True), None
        command = (0.0, 0.0, 0.0)
        state = dc.replace(state, command=command)
    if params.feedback == "OPEN_LOOP":
        current = state.last
    elif not state.odom:  # no odometry yet: OdomSmoother's zero twist
        current = (0.0, 0.0, 0.0)
    else:
        n = len(state.odom)
        current = tuple(sum(s[k] for s in state.odom) / n for k in (1, 2, 3))
    low, high = params.planar("min_velocity"), params.planar("max_velocity")
    command = tuple(min(max(c, lo), hi) for c, lo, hi in zip(command, low, high, strict=True))
    accel, decel = params.planar("max_accel"), params.planar("max_decel")
    f = params.smoothing_frequency
    eta = 1.0
    if params.scale_velocities:
        for v, c, a, d in zip(current, command, accel, decel, strict=True):
            e = find_eta_constraint(v, c, a, d, f)
            if e > 0.0 and abs(1.0 - e) > abs(1.0 - eta):
                eta = e
    out = tuple(
        apply_constraints(v, c, a, d, eta, f)
        for v, c, a, d in zip(current, command, accel, decel, strict=True)
    )
    state = dc.replace(state, last=out, stopped=False)
    band = params.planar("deadband_velocity")
    sent = [0.0 if abs(v) < b else v for v, b in zip(out, band, strict=True)]
    message = TwistStamped(
        stamp=state.stamp + since,
        frame_id=state.frame_id,
        twist=Twist(linear=(sent[0], sent[1], 0.0), angular=(0.0, 0.0, sent[2])),
    )
    return state, message


class VelocitySmoother(LeafSystem):
    """Nav2's velocity_smoother as a Drake system (see the module docstring).

    .. pydrake_system::

        name: VelocitySmoother
        input_ports:
        - cmd_vel
        - odom (CLOSED_LOOP)
        output_ports:
        - cmd_vel_smoothed

    - ``cmd_vel``: a Publication of TwistStamped (the controller's command);
    - ``odom``: the drive's Odometry (``feedback: CLOSED_LOOP`` only);
    - ``cmd_vel_smoothed``: a Publication of TwistStamped, to the base.
    """

    def __init__(self, params: VelocitySmootherParameters):
        super().__init__()
        self.params = params
        self._cmd = self.DeclareAbstractInputPort("cmd_vel", PublicationValue())
        self._odom = None
        if params.feedback == "CLOSED_LOOP":
            self._odom = self.DeclareAbstractInputPort("odom", AbstractValue.Make(Odometry()))
        self._state = self.DeclareAbstractState(AbstractValue.Make(SmootherState()))
        self._topic = self.DeclareAbstractState(PublicationValue())
        self.DeclareStateOutputPort("cmd_vel_smoothed", self._topic)
        period = 1.0 / params.smoothing_frequency
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._Update)

    def _Update(self, context, out) -> None:
        now = context.get_time()
        state = context.get_abstract_state(self._state).get_value()
        publication = self._cmd.Eval(context)
        if publication.count > state.received:
            state = receive(dc.replace(state, received=publication.count), publication.message, now)
        if self._odom is not None:
            state = odom_twist(state, self._odom.Eval(context), self.params.odom_duration)
        state, message = smooth(self.params, state, now)
        out.get_mutable_abstract_state(self._state).set_value(state)
        if message is not None:
            sent = context.get_abstract_state(self._topic).get_value()
            out.get_mutable_abstract_state(self._topic).set_value(sent.publish(message, now))
