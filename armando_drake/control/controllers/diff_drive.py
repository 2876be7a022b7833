"""Differential drives: ``diff_drive_controller/DiffDriveController`` and the Gazebo plugins.

**diff_drive_controller/DiffDriveController** as upstream's (ros2_controllers ``jazzy``;
chainable: :meth:`DiffDriveController.set_chained_mode`): a ``geometry_msgs/TwistStamped``
(a plain ``Twist`` too, stamped when it arrives) on ``/<controller>/cmd_vel`` sets the
reference (``linear.x`` [m/s], ``angular.z`` [rad/s]); at every update the reference goes
through the speed limiters (control_toolbox's RateLimiter: velocity, acceleration and jerk
limits per axis, from the two previous commands) and becomes the wheels' velocity commands [rad/s]::

    left  = (v - w * wheel_separation / 2) / left_wheel_radius
    right = (v + w * wheel_separation / 2) / right_wheel_radius

with the multipliers applied (``wheel_separation_multiplier``, ``*_wheel_radius_multiplier``).
Before any command the reference is NaN and nothing is written (the wheels hold still) and
no odometry is integrated or published, as upstream's update returns early. A
command older than ``cmd_vel_timeout`` [s] (its stamp, 0 taken as the time it arrived)
brakes: the reference becomes zero, through the limiters; one that is already that old
when it arrives is ignored; 0 disables the timeout. A NaN in ``linear.x`` or
``angular.z`` leaves the reference as it was.

The odometry (``nav_msgs/Odometry`` ``odom_frame_id`` -> ``base_frame_id``, with
``tf_frame_prefix`` or the robot's namespace; the TF ``odom -> base`` it broadcasts with
``enable_odom_tf``) is integrated at every update as upstream's ``Odometry`` does: from the
wheels' positions (``position_feedback``, the default; the mean of each side), from their
velocities, or with ``open_loop`` from the limited commands; exact arc integration (second-
order Runge-Kutta when the turn is under 1e-6 rad), the twist a rolling mean over
``velocity_rolling_window_size`` updates. It is published at ``publish_rate`` [Hz] on the
output ``<controller>.odom``. So it drifts from the ground truth exactly where the wheels
slip.

**Gazebo's drive plugins** (:class:`PluginDiffDrive`, not a ros2_control type: the world
runs one for each drive a description's ``<gazebo><plugin>`` declares, see
:mod:`armando_drake.description.drive`): Gazebo Sim's DiffDrive system (gz-math's
SpeedLimiter: each bound on its own, jerk always limited; no command timeout; odometry
from the first wheel of each side) and Gazebo classic's ``gazebo_ros_diff_drive``
(each wheel's rim speed limited to ``max_wheel_acceleration``; no timeout; odometry from
the wheel encoders, or with ``odometry_source`` world, as its default, the model's pose).

The wheels are velocity joints: Drake's PD actuator with kp = 0 is the velocity servo
(:mod:`armando_drake.control.hardware`), within the joint's effort limit (a plugin's
wheel torque).
"""

# No `from __future__ import annotations` here: yaml_load_typed reads the dataclass
# field types at run time and does not resolve string annotations.

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from armando_drake.control.controllers import (
    Controller,
    ControllerMemory,
    ParameterError,
    register,
)
from armando_drake.description.drive import GZ_SIM, DrivePlugin
from armando_drake.messages.types import (
    ControllerStatus,
    Odometry,
    Twist,
    TwistStamped,
)
from armando_drake.tools.schema import Refusal, param

NAN = math.nan
# [rad/s] the velocity limit of a wheel whose description gives none: a received twist is
# clamped to what the wheels can give (a command of 1e308 never reaches the contact solver).
MAX_WHEEL_SPEED = 1000.0


# --------------------------------------------------------------------------------------
# Speed limiting


def _clamp(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


@dataclasses.dataclass(frozen=True)
class RateLimiter:
    """Limits a value, its first and its second derivative.

    ``ros`` True is control_toolbox's RateLimiter (jazzy): a NaN maximum disables that
    limit, a NaN minimum is minus the maximum, the first derivative has its own bounds
    when the previous value is positive (``min_first_derivative_pos``,
    ``max_first_derivative_pos``) or negative (``min_first_derivative_neg``,
    ``max_first_derivative_neg``; NaN: symmetric), and the second derivative is limited
    only while accelerating. ``ros`` False is gz-math's SpeedLimiter: every bound on its
    own (+-inf when not given), the second derivative always limited.
    """

    min_value: float = -math.inf
    max_value: float = math.inf
    min_first_derivative_neg: float = -math.inf
    max_first_derivative_pos: float = math.inf
    min_first_derivative_pos: float = -math.inf
    max_first_derivative_neg: float = math.inf
    min_second_derivative: float = -math.inf
    max_second_derivative: float = math.inf
    ros: bool = True

    @staticmethod
    def ros_limiter(
        min_value: float = NAN,
        max_value: float = NAN,
        min_first_derivative_neg: float = NAN,
        max_first_derivative_pos: float = NAN,
        min_first_derivative_pos: float = NAN,
        max_first_derivative_neg: float = NAN,
        min_second_derivative: float = NAN,
        max_second_derivative: float = NAN,
    ) -> "RateLimiter":
        """control_toolbox's ``RateLimiter::set_params``: ValueError for bounds that are
        not an interval (upstream's ``std::invalid_argument``)."""
        inf = math.inf
        if math.isnan(min_value):
            min_value = -max_value
        if math.isnan(max_value):
            min_value, max_value = -inf, inf
        elif min_value > max_value:
            raise ValueError("Invalid value limits")
        if math.isnan(min_first_derivative_neg):
            min_first_derivative_neg = -max_first_derivative_pos
        if math.isnan(max_first_derivative_pos):
            first = (-inf, inf, -inf, inf)
        else:
            if min_first_derivative_neg > max_first_derivative_pos:
                raise ValueError("Invalid first derivative limits")
            if math.isnan(max_first_derivative_neg):
                max_first_derivative_neg = max_first_derivative_pos
            if math.isnan(min_first_derivative_pos):
                min_first_derivative_pos = min_first_derivative_neg
            if min_first_derivative_pos > max_first_derivative_neg:
                raise ValueError("Invalid first derivative limits")
            first = (
                min_first_derivative_neg,
                max_first_derivative_pos,
                min_first_derivative_pos,
                max_first_derivative_neg,
            )
        if math.isnan(min_second_derivative):
            min_second_derivative = -max_second_derivative
        if math.isnan(max_second_derivative):
            second = (-inf, inf)
        elif min_second_derivative > max_second_derivative:
            raise ValueError("Invalid second derivative limits")
        else:
            second = (min_second_derivative, max_second_derivative)
        return RateLimiter(min_value, max_value, *first, *second, ros=True)

    def limit(self, v: float, v0: float, v1: float, dt: float) -> float:
        """``v`` limited, ``v0`` and ``v1`` the two previous values, ``dt`` [s] the step."""
        # The second derivative.
        dv, dv0 = v - v0, v0 - v1
        if (not self.ros or (dv - dv0) * (v - v0) > 0) and (
            math.isfinite(self.min_second_derivative) or math.isfinite(self.max_second_derivative)
        ):
            dt2 = dt * dt
            da = _clamp(
                dv - dv0, self.min_second_derivative * dt2, self.max_second_derivative * dt2
            )
            v = v0 + dv0 + da
        # The first derivative.
        if v0 > 0:
            low, high = self.min_first_derivative_pos, self.max_first_derivative_pos
        elif v0 < 0:
            low, high = self.min_first_derivative_neg, self.max_first_derivative_neg
        else:
            low, high = self.min_first_derivative_neg, self.max_first_derivative_pos
        if math.isfinite(low) or math.isfinite(high):
            v = v0 + _clamp(v - v0, low * dt, high * dt)
        return _clamp(v, self.min_value, self.max_value)


# --------------------------------------------------------------------------------------
# Odometry


@dataclasses.dataclass(frozen=True)
class OdometryState:
    """Upstream's ``Odometry``: the pose integrated so far, and the rolling means."""

    timestamp: float = 0.0  # [s] of the latest integration
    x: float = 0.0  # [m]
    y: float = 0.0  # [m]
    heading: float = 0.0  # [rad]
    linear: float = 0.0  # [m/s] rolling mean
    angular: float = 0.0  # [rad/s] rolling mean
    left_old: float = 0.0  # [m] left wheel travel at the latest update
    right_old: float = 0.0  # [m]
    linear_window: tuple[float, ...] = ()  # the latest linear / dt values
    angular_window: tuple[float, ...] = ()

    def integrate(self, linear: float, angular: float) -> tuple[float, float, float]:
        """(x, y, heading) after moving ``linear`` [m] and turning ``angular`` [rad]."""
        if abs(angular) < 1e-6:  # second-order Runge-Kutta
            direction = self.heading + angular * 0.5
            return (
                self.x + linear * math.cos(direction),
                self.y + linear * math.sin(direction),
                self.heading + angular,
            )
        heading = self.heading + angular  # exact
        r = linear / angular
        return (
            self.x + r * (math.sin(heading) - math.sin(self.heading)),
            self.y - r * (math.cos(heading) - math.cos(self.heading)),
            heading,
        )

    def from_travel(
        self, left: float, right: float, separation: float, time: float, window: int
    ) -> "OdometryState":
        """``updateFromVelocity``: the wheels travelled ``left``, ``right`` [m] since the
        latest update (unchanged under 0.1 ms)."""
        dt = time - self.timestamp
        if dt < 0.0001:
            return self
        linear = (left + right) * 0.5
        angular = (right - left) / separation
        x, y, heading = self.integrate(linear, angular)
        linear_window = (*self.linear_window, linear / dt)[-window:]
        angular_window = (*self.angular_window, angular / dt)[-window:]
        return dataclasses.replace(
            self,
            timestamp=time,
            x=x,
            y=y,
            heading=heading,
            linear=sum(linear_window) / len(linear_window),
            angular=sum(angular_window) / len(angular_window),
            linear_window=linear_window,
            angular_window=angular_window,
        )

    def from_positions(
        self, left: float, right: float, separation: float, time: float, window: int
    ) -> "OdometryState":
        """``update``: the wheels' travel [m] (position times radius) now."""
        if time - self.timestamp < 0.0001:
            return self
        moved = self.from_travel(
            left - self.left_old, right - self.right_old, separation, time, window
        )
        return dataclasses.replace(moved, left_old=left, right_old=right)

    def open_loop(self, linear: float, angular: float, time: float) -> "OdometryState":
        """``updateOpenLoop``: the commanded twist [m/s, rad/s] integrated over the step."""
        dt = time - self.timestamp
        x, y, heading = self.integrate(linear * dt, angular * dt)
        return dataclasses.replace(
            self, timestamp=time, x=x, y=y, heading=heading, linear=linear, angular=angular
        )


def heading_quaternion(heading: float) -> tuple[float, float, float, float]:
    """(w, x, y, z) of a rotation by ``heading`` [rad] about z."""
    return (math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2))


# --------------------------------------------------------------------------------------
# The drive's state between updates


@dataclasses.dataclass(frozen=True)
class DriveState:
    """What a drive keeps between updates (never mutated)."""

    # [m/s, rad/s] the reference (NaN before any command), and the stamp [s] of the
    # command it came from.
    reference: tuple[float, float] = (NAN, NAN)
    command_stamp: float = 0.0
    # [m/s, rad/s] the two previous limited commands (the older first).
    previous: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    odometry: OdometryState = dataclasses.field(default_factory=OdometryState)
    last_publish: float = -math.inf  # [s] the latest odometry publication
    message: Odometry = dataclasses.field(default_factory=Odometry)  # the latest published
    last_update: float | None = None  # [s] the latest update
    # [m/s] each wheel's commanded rim speed (Gazebo classic's acceleration limit).
    rim_speeds: tuple[float, ...] = ()
    timed_out: bool = False  # the latest update braked for a stale command
    inactive: bool = False  # deactivated: its subscriber takes no command (upstream's)

    def __deepcopy__(self, memo):
        return self


class _Feedback(tuple):
    """The wheels' measured (q, v) [rad, rad/s] of one update, read when first used;
    :meth:`base` gives the floating base's planar (x, y, heading, forward speed, yaw
    rate) when the world measures one (None otherwise)."""

    def __new__(cls, measure, desired):
        q, v = measure(desired)
        feedback = super().__new__(cls, (q, v))
        feedback._measure = measure
        return feedback

    def base(self):
        base = getattr(self._measure, "base", None)
        return base() if base is not None else None


def twist_of(message: Any, now: float) -> tuple[float, float, float]:
    """(stamp [s], linear.x, angular.z) of a TwistStamped or Twist; a zero stamp (and a
    plain Twist) is ``now``."""
    if isinstance(message, TwistStamped):
        stamp, twist = message.stamp, message.twist
    elif isinstance(message, Twist):
        stamp, twist = 0.0, message
    else:
        raise TypeError(f"expected a TwistStamped or Twist message, got {type(message).__name__}")
    return (stamp if stamp != 0.0 else now), float(twist.linear[0]), float(twist.angular[2])


class _Drive(Controller):
    """What the diff_drive_controller and the Gazebo plugins share: cmd_vel in, wheel
    velocities and odometry out. A subclass sets the kinematics in ``__init__``
    (:meth:`_setup`) and may override :meth:`_reference`, :meth:`_limit`,
    :meth:`_wheels` and :meth:`_odometry`."""

    message = TwistStamped
    topic = "cmd_vel"
    fixed_interface = "velocity"
    initial_state = "active"
    # Published topics of the controller (leaf -> message class), outputs of the manager.
    outputs: ClassVar[dict[str, type]] = {"odom": Odometry}
    # Whether the odometry is integrated and published before the first command (Gazebo's
    # plugins); diff_drive_controller returns early while its reference is NaN.
    odometry_before_command: ClassVar[bool] = True

    def _setup(
        self,
        *,
        left: list[str],
        separation: float,
        radii: tuple[float, float],
        publish_rate: float,
        frames: tuple[str, str],
        linear: RateLimiter,
        angular: RateLimiter,
        period: float = 0.0,
    ) -> None:
        self.left_rows = np.array([name in left for name in self.joint_names])
        self.separation = separation
        self.left_radius, self.right_radius = radii
        self.publish_period = 1.0 / publish_rate if publish_rate > 0 else math.inf
        self.odom_frame, self.base_frame = frames
        self.linear_limiter, self.angular_limiter = linear, angular
        self.period = period  # [s] the update period (set by configure); 0 = every tick
        self.covariances = ((0.0,) * 6, (0.0,) * 6)

    def configure(self, *, update_rate: int) -> None:
        self.update_period = 1.0 / update_rate

    def initial_memory(self) -> ControllerMemory:
        memory = super().initial_memory()
        state = DriveState(rim_speeds=(0.0,) * self.n)
        state = dataclasses.replace(state, message=self._message(0.0, state.odometry))
        return dataclasses.replace(memory, internal=state, running=True)

    def twist_limits(self) -> tuple[float, float]:
        """([m/s], [rad/s]) the largest twist the wheels can give: each axis alone at the
        wheels' velocity limit (the slowest wheel's; MAX_WHEEL_SPEED for wheels without
        one)."""
        limits = np.asarray(self.joints.velocity, dtype=float)
        finite = limits[np.isfinite(limits) & (limits > 0)]
        wheel = float(finite.min()) if finite.size else MAX_WHEEL_SPEED
        linear = wheel * min(self.left_radius, self.right_radius)
        return linear, 2.0 * linear / self.separation if self.separation > 0 else math.inf

    def clamped(self, linear: float, angular: float) -> tuple[float, float]:
        """A received twist clamped into :meth:`twist_limits` (a command beyond what the
        wheels can do never reaches the plant)."""
        top_linear, top_angular = self.twist_limits()
        return (
            min(max(linear, -top_linear), top_linear),
            min(max(angular, -top_angular), top_angular),
        )

    def wheel_commands(self, linear: float, angular: float) -> np.ndarray:
        """[rad/s] the velocity of each wheel (controller order) for a twist."""
        left = (linear - angular * self.separation / 2.0) / self.left_radius
        right = (linear + angular * self.separation / 2.0) / self.right_radius
        return np.where(self.left_rows, left, right)

    def _message(self, now: float, odometry: OdometryState) -> Odometry:
        return Odometry(
            stamp=now,
            frame_id=self.odom_frame,
            child_frame_id=self.base_frame,
            position=(odometry.x, odometry.y, 0.0),
            orientation=heading_quaternion(odometry.heading),
            linear=(odometry.linear, 0.0, 0.0),
            angular=(0.0, 0.0, odometry.angular),
            pose_covariance=self.covariances[0],
            twist_covariance=self.covariances[1],
        )

    def output(self, topic: str, memory: ControllerMemory) -> Any:
        """The latest message published on ``topic`` (a key of :attr:`outputs`)."""
        return memory.internal.message

    # Steps of an update -----------------------------------------------------------

    def _reference(self, now: float, message: Any, state: DriveState, status: ControllerStatus):
        """(state, status) with a new message taken in; the reference at ``now``."""
        if message is not None:
            try:
                stamp, linear, angular = twist_of(message, now)
            except TypeError as error:
                return state, self.reject(status, str(error))
            if math.isfinite(linear) and math.isfinite(angular):
                linear, angular = self.clamped(linear, angular)
                state = dataclasses.replace(state, reference=(linear, angular), command_stamp=stamp)
                status = self.accept(status, "active", {})
            else:
                status = self.reject(
                    status, "Command message contains NaNs. Not updating reference interfaces."
                )
        return state, status

    def _limit(self, state: DriveState, dt: float) -> tuple[float, float] | None:
        """The limited command [m/s, rad/s], or None when there is none yet."""
        linear, angular = state.reference
        if not (math.isfinite(linear) and math.isfinite(angular)):
            return None
        (l1, a1), (l0, a0) = state.previous
        return (
            self.linear_limiter.limit(linear, l0, l1, dt),
            self.angular_limiter.limit(angular, a0, a1, dt),
        )

    def _wheels(self, command, state: DriveState, dt: float):
        """(wheel velocities [rad/s], state) for the limited ``command``."""
        return self.wheel_commands(*command), state

    def _odometry(self, now, command, state: DriveState, feedback, dt) -> OdometryState:
        """The odometry after this update, from the wheels' positions (``feedback``: the
        wheels' (q, v) [rad, rad/s], with ``base()`` the floating base's planar pose and
        twist when the world has one)."""
        q, _ = feedback
        left = float(np.mean(q[self.left_rows])) * self.left_radius
        right = float(np.mean(q[~self.left_rows])) * self.right_radius
        return state.odometry.from_positions(left, right, self.separation, now, 10)

    def update(self, now, message, memory, measure):
        state: DriveState = memory.internal
        if (
            message is None
            and self.period > 0
            and state.last_update is not None
            and now - state.last_update < self.period - 1e-9
        ):
            return memory  # the plugin updates at its own rate
        dt = now - state.last_update if state.last_update is not None else self.update_period
        state, status = self._reference(now, message, state, memory.status)
        command = self._limit(state, dt)
        desired = memory.desired
        if command is not None:
            state = dataclasses.replace(state, previous=(state.previous[1], command))
            velocities, state = self._wheels(command, state, dt)
            desired = np.concatenate([desired[: self.n], velocities])
        elif not self.odometry_before_command:
            state = dataclasses.replace(state, last_update=now)
            return ControllerMemory(desired, status, internal=state, running=True)
        odometry = self._odometry(now, command, state, _Feedback(measure, memory.desired), dt)
        state = dataclasses.replace(state, odometry=odometry, last_update=now)
        if state.last_publish + self.publish_period < now or state.last_publish == -math.inf:
            published = state.last_publish + self.publish_period
            state = dataclasses.replace(
                state,
                last_publish=now if not math.isfinite(published) else published,
                message=self._message(now, odometry),
            )
        return ControllerMemory(desired, status, internal=state, running=True)


# --------------------------------------------------------------------------------------
# diff_drive_controller/DiffDriveController


@dataclasses.dataclass
class AxisLimitParameters:
    """``linear.x.*`` or ``angular.z.*``: the limits of one axis of the commanded twist
    (NaN = none; a NaN minimum is minus the maximum)."""

    # [m/s or rad/s] largest velocity (>= 0).
    max_velocity: float = param(NAN, ge=0, nan=True)
    # [m/s or rad/s] smallest velocity (<= 0).
    min_velocity: float = param(NAN, le=0, nan=True)
    # [m/s^2 or rad/s^2] largest acceleration speeding up forward (>= 0).
    max_acceleration: float = param(NAN, ge=0, nan=True)
    # [m/s^2 or rad/s^2] largest deceleration slowing down forward (<= 0).
    max_deceleration: float = param(NAN, le=0, nan=True)
    # [m/s^2 or rad/s^2] largest acceleration speeding up in reverse (<= 0).
    max_acceleration_reverse: float = param(NAN, le=0, nan=True)
    # [m/s^2 or rad/s^2] largest deceleration slowing down in reverse (>= 0).
    max_deceleration_reverse: float = param(NAN, ge=0, nan=True)
    # [m/s^3 or rad/s^3] largest jerk (>= 0), applied while accelerating.
    max_jerk: float = param(NAN, ge=0, nan=True)
    # [m/s^3 or rad/s^3] smallest jerk (<= 0).
    min_jerk: float = param(NAN, le=0, nan=True)
    # Deprecated upstream (false = the velocity limits are NaN).
    has_velocity_limits: bool = True
    # Deprecated upstream (false = the acceleration limits are NaN).
    has_acceleration_limits: bool = True
    # Deprecated upstream (false = the jerk limits are NaN).
    has_jerk_limits: bool = True
    # Deprecated upstream and unused (use max_deceleration).
    min_acceleration: float = param(NAN, nan=True)

    def limiter(self, prefix: str) -> RateLimiter:
        """The speed limiter of these limits (upstream's on_configure)."""
        velocity = (
            (self.min_velocity, self.max_velocity) if self.has_velocity_limits else (NAN,) * 2
        )
        acceleration = (
            (
                self.max_acceleration_reverse,
                self.max_acceleration,
                self.max_deceleration,
                self.max_deceleration_reverse,
            )
            if self.has_acceleration_limits
            else (NAN,) * 4
        )
        jerk = (self.min_jerk, self.max_jerk) if self.has_jerk_limits else (NAN,) * 2
        try:
            return RateLimiter.ros_limiter(*velocity, *acceleration, *jerk)
        except ValueError as error:
            raise ParameterError(
                prefix, f"Failed to configure {prefix} speed limiter: {error}"
            ) from None


@dataclasses.dataclass
class LinearLimits:
    """``linear.*``: the forward axis."""

    # The limits of linear.x [m/s, m/s^2, m/s^3].
    x: AxisLimitParameters = dataclasses.field(default_factory=AxisLimitParameters)


@dataclasses.dataclass
class AngularLimits:
    """``angular.*``: the turning axis."""

    # The limits of angular.z [rad/s, rad/s^2, rad/s^3].
    z: AxisLimitParameters = dataclasses.field(default_factory=AxisLimitParameters)


@dataclasses.dataclass
class DiffDriveParameters:
    """The parameters of ``diff_drive_controller/DiffDriveController`` (jazzy)."""

    # The left wheels' joints (each a velocity joint; the mean of their feedback is used).
    left_wheel_names: list[str] = param([], nonempty=True, unique=True)
    # The right wheels' joints (as many as on the left).
    right_wheel_names: list[str] = param([], nonempty=True, unique=True)
    # [m] distance between the left and right wheels (> 0).
    wheel_separation: float = param(0.0, unit="m", gt=0)
    # [m] radius of a wheel (> 0).
    wheel_radius: float = param(0.0, unit="m", gt=0)
    # [-] correction factor of wheel_separation.
    wheel_separation_multiplier: float = param(1.0, unit="-", gt=0)
    # [-] correction factor of the left wheels' radius.
    left_wheel_radius_multiplier: float = param(1.0, unit="-", gt=0)
    # [-] correction factor of the right wheels' radius.
    right_wheel_radius_multiplier: float = param(1.0, unit="-", gt=0)
    # Put tf_frame_prefix (or the namespace, when empty: none here) before the frame ids.
    tf_frame_prefix_enable: bool = True
    # The prefix of the odometry's frame ids.
    tf_frame_prefix: str = ""
    # The odometry's frame (the parent of base_frame_id).
    odom_frame_id: str = "odom"
    # The robot's base frame (the odometry's child frame).
    base_frame_id: str = "base_link"
    # [-] the odometry pose's covariance diagonal (x, y, z, roll, pitch, yaw).
    pose_covariance_diagonal: list[float] = param([0.0] * 6, unit="-", length=6)
    # [-] the odometry twist's covariance diagonal.
    twist_covariance_diagonal: list[float] = param([0.0] * 6, unit="-", length=6)
    # Integrate the odometry from the limited commands instead of the wheels' feedback.
    open_loop: bool = False
    # Wheel feedback from the position state interfaces (else the velocity ones).
    position_feedback: bool = True
    # Broadcast the TF odom_frame_id -> base_frame_id.
    enable_odom_tf: bool = True
    # [s] a command older than this brakes the robot; 0 = no timeout.
    cmd_vel_timeout: float = param(0.5, unit="s", ge=0)
    # [-] number of updates of the odometry twist's rolling mean (>= 1).
    velocity_rolling_window_size: int = param(10, ge=1)
    # [Hz] rate of the odometry and TF publications (> 0).
    publish_rate: float = param(50.0, unit="Hz", gt=0)
    # The limits of the forward axis.
    linear: LinearLimits = dataclasses.field(default_factory=LinearLimits)
    # The limits of the turning axis.
    angular: AngularLimits = dataclasses.field(default_factory=AngularLimits)

    def check(self) -> None:
        """The rules between fields (the fields' own are declared beside them): as many
        wheels on each side, none on both, speed limiters that upstream configures."""
        if len(self.left_wheel_names) != len(self.right_wheel_names):
            raise Refusal(
                "right_wheel_names",
                f": The number of left wheels [{len(self.left_wheel_names)}] and the number of "
                f"right wheels [{len(self.right_wheel_names)}] are different",
            )
        both = set(self.left_wheel_names) & set(self.right_wheel_names)
        if both:
            raise Refusal("right_wheel_names", f": {sorted(both)} are on both sides")
        for prefix, axis in (("linear", self.linear.x), ("angular", self.angular.z)):
            try:
                axis.limiter(prefix)
            except ParameterError as error:
                raise Refusal(prefix, f": {error.problem}") from None

    def frames(self, namespace: str = "") -> tuple[str, str]:
        """(odom frame, base frame) as upstream's on_configure names them: with
        ``tf_frame_prefix_enable``, ``tf_frame_prefix`` or, when it is empty, the
        controller's ``namespace`` ("/" for none), a "/" after it and none before."""
        prefix = ""
        if self.tf_frame_prefix_enable:
            prefix = self.tf_frame_prefix or namespace or "/"
            prefix = prefix if prefix.endswith("/") else prefix + "/"
            prefix = prefix[1:] if prefix.startswith("/") else prefix
        return prefix + self.odom_frame_id, prefix + self.base_frame_id


@register("diff_drive_controller/DiffDriveController")
class DiffDriveController(_Drive):
    """A differential drive base: cmd_vel to wheel velocities, wheel odometry."""

    parameters = DiffDriveParameters
    ignored_parameters = frozenset(
        {"wheels_per_side", "use_stamped_vel", "publish_limited_velocity"}
    )
    odometry_before_command = False
    chained_mode = False  # set_chained_mode: the reference written by a preceding controller

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return list(params.left_wheel_names) + list(params.right_wheel_names)

    @classmethod
    def joint_key(cls, params, joint: str) -> str:
        """The parameter that names ``joint``, for messages."""
        return "left_wheel_names" if joint in params.left_wheel_names else "right_wheel_names"

    @classmethod
    def minimal_ros_parameters(cls, joints: list[str]) -> dict[str, Any]:
        half = len(joints) // 2
        return {
            "left_wheel_names": joints[:half],
            "right_wheel_names": joints[half:],
            "wheel_separation": 1.0,
            "wheel_radius": 0.1,
        }

    @classmethod
    def default_parameters(cls, joints):
        names = list(joints.names)
        half = len(names) // 2
        return cls.parameters(
            left_wheel_names=names[:half],
            right_wheel_names=names[half:],
            wheel_separation=1.0,
            wheel_radius=0.1,
        )

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        p = self.params
        self._setup(
            left=list(p.left_wheel_names),
            separation=p.wheel_separation_multiplier * p.wheel_separation,
            radii=(
                p.left_wheel_radius_multiplier * p.wheel_radius,
                p.right_wheel_radius_multiplier * p.wheel_radius,
            ),
            publish_rate=p.publish_rate,
            frames=p.frames(),
            linear=p.linear.x.limiter("linear"),
            angular=p.angular.z.limiter("angular"),
        )
        self.covariances = (
            tuple(map(float, p.pose_covariance_diagonal)),
            tuple(map(float, p.twist_covariance_diagonal)),
        )

    # Lifecycle (upstream's on_configure, on_activate, on_deactivate, on_cleanup) --------

    def set_namespace(self, namespace: str) -> None:
        """The controller's node namespace ("/left"; "" for none): the frames' prefix
        when ``tf_frame_prefix_enable`` and ``tf_frame_prefix`` is empty."""
        self.odom_frame, self.base_frame = self.params.frames(namespace)

    def set_chained_mode(self, chained: bool) -> bool:
        """``set_chained_mode``: in chained mode the reference is what a preceding
        controller writes (:meth:`write_reference`); cmd_vel and its timeout are not read."""
        self.chained_mode = bool(chained)
        return True

    def reference_interfaces(self) -> list[str]:
        """The exported reference interfaces: ``<name>/linear/velocity``,
        ``<name>/angular/velocity``."""
        return [f"{self.name}/linear/velocity", f"{self.name}/angular/velocity"]

    def write_reference(self, memory, linear: float, angular: float) -> ControllerMemory:
        """A preceding controller's write to the reference interfaces (chained mode)."""
        state = dataclasses.replace(memory.internal, reference=(float(linear), float(angular)))
        return dataclasses.replace(memory, internal=state)

    def _reset_buffers(self, state: DriveState, now: float) -> DriveState:
        """``reset_buffers``: the reference NaN, the two previous commands zero, the
        command message NaN stamped ``now`` (its timeout counts from it)."""
        return dataclasses.replace(
            state, reference=(NAN, NAN), previous=((0.0, 0.0), (0.0, 0.0)), command_stamp=now
        )

    def deactivate(self, now: float, memory: ControllerMemory) -> ControllerMemory:
        """``on_deactivate``: the subscriber off, the wheels halted (velocity 0), the
        buffers reset."""
        state = dataclasses.replace(self._reset_buffers(memory.internal, now), inactive=True)
        desired = np.concatenate([memory.desired[: self.n], np.zeros(self.n)])
        status = dataclasses.replace(memory.status, state="inactive")
        return ControllerMemory(desired, status, internal=state, running=True)

    def activate(self, now: float, memory: ControllerMemory) -> ControllerMemory:
        """``on_activate``: the subscriber takes commands again; the wheels keep the
        command they last had."""
        state = dataclasses.replace(memory.internal, inactive=False)
        status = dataclasses.replace(memory.status, state="active")
        return ControllerMemory(memory.desired, status, internal=state, running=True)

    def reset(self, now: float, memory: ControllerMemory) -> ControllerMemory:
        """``reset`` (on_configure, on_cleanup, on_error): the odometry's pose back to 0
        (``resetOdometry``: the wheels' last positions and the rolling means kept), the
        buffers reset, the subscriber off until activated."""
        state = memory.internal
        odometry = dataclasses.replace(state.odometry, x=0.0, y=0.0, heading=0.0)
        state = dataclasses.replace(self._reset_buffers(state, now), odometry=odometry)
        state = dataclasses.replace(state, inactive=True)
        status = dataclasses.replace(memory.status, state="inactive")
        return ControllerMemory(memory.desired, status, internal=state, running=True)

    def _reference(self, now, message, state, status):
        if self.chained_mode:  # update_reference_from_subscribers is not called
            return state, status
        if state.inactive and message is not None:
            message = None  # "Can't accept new commands. subscriber is inactive"
        timeout = self.params.cmd_vel_timeout
        if message is not None and timeout > 0:
            try:
                stamp = twist_of(message, now)[0]
            except TypeError:
                stamp = now  # rejected below
            if now - stamp >= timeout:
                reason = (
                    f"Ignoring the received message (timestamp {stamp:.10f}) because it is "
                    f"older than the current time by {now - stamp:.10f} seconds, which "
                    f"exceeds the allowed timeout ({timeout:.4f})"
                )
                return state, self.reject(status, reason)
        if state.command_stamp == 0.0 and state.last_update is None:
            state = dataclasses.replace(state, command_stamp=now)  # configured now
        state, status = super()._reference(now, message, state, status)
        stale = timeout > 0 and now - state.command_stamp > timeout
        if stale:  # "Velocity command timed out. Braking."
            state = dataclasses.replace(state, reference=(0.0, 0.0))
        if stale != state.timed_out:
            state = dataclasses.replace(state, timed_out=stale)
            status = dataclasses.replace(status, detail={**status.detail, "timed_out": stale})
        return state, status

    def _odometry(self, now, command, state, feedback, dt):
        p = self.params
        if p.open_loop:
            if command is None:
                return dataclasses.replace(state.odometry, timestamp=now)
            return state.odometry.open_loop(*command, now)
        q, v = feedback
        window = p.velocity_rolling_window_size
        if p.position_feedback:
            left = float(np.mean(q[self.left_rows])) * self.left_radius
            right = float(np.mean(q[~self.left_rows])) * self.right_radius
            return state.odometry.from_positions(left, right, self.separation, now, window)
        left = float(np.mean(v[self.left_rows])) * self.left_radius * dt
        right = float(np.mean(v[~self.left_rows])) * self.right_radius * dt
        return state.odometry.from_travel(left, right, self.separation, now, window)


# --------------------------------------------------------------------------------------
# Gazebo's drive plugins


class PluginDiffDrive(_Drive):
    """The drive of a ``<gazebo><plugin>`` (:class:`~armando_drake.description.drive.DrivePlugin`
    as ``params``): Gazebo Sim's DiffDrive system or Gazebo classic's gazebo_ros_diff_drive.
    Not a ros2_control type: the world runs it for the description, as Gazebo loads the
    plugin with the model."""

    parameters = DrivePlugin  # its "parameters" are the plugin's tags, read by the loader

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return list(params.joints)

    def __init__(self, *, name, joints, params: DrivePlugin):
        super().__init__(name=name, joints=joints, params=params)
        drive = params
        gz = drive.dialect == GZ_SIM

        def limiter(limits) -> RateLimiter:
            return RateLimiter(
                limits.min_velocity,
                limits.max_velocity,
                limits.min_acceleration,
                limits.max_acceleration,
                limits.min_acceleration,
                limits.max_acceleration,
                limits.min_jerk,
                limits.max_jerk,
                ros=False,
            )

        self._setup(
            left=list(drive.left_joints),
            separation=drive.wheel_separation,
            radii=(drive.wheel_radius, drive.wheel_radius),
            publish_rate=drive.odom_rate,
            frames=(drive.odom_frame, drive.base_frame or "base_link"),
            linear=limiter(drive.linear),
            angular=limiter(drive.angular),
            period=0.0 if gz or drive.update_rate <= 0 else 1.0 / drive.update_rate,
        )
        self.gz = gz
        # Gazebo Sim's odometry reads the first joint of each side.
        self.first = (
            list(self.joint_names).index(drive.left_joints[0]),
            list(self.joint_names).index(drive.right_joints[0]),
        )

    def _wheels(self, command, state, dt):
        velocities = self.wheel_commands(*command)
        limit = self.params.max_wheel_acceleration
        if self.gz or not math.isfinite(limit):
            return velocities, state
        # gazebo_ros_diff_drive: each wheel's rim speed [m/s] moves toward the desired one
        # by at most max_wheel_acceleration * dt (set at once within 0.01 m/s).
        radius = self.params.wheel_radius
        desired = velocities * radius
        current = np.array(state.rim_speeds)
        if np.all(np.abs(desired - current) < 0.01):
            rims = desired
        else:
            rims = current + np.clip(desired - current, -limit * dt, limit * dt)
        return rims / radius, dataclasses.replace(state, rim_speeds=tuple(rims.tolist()))

    def _odometry(self, now, command, state, feedback, dt):
        if self.params.odometry_source == "world":
            pose = feedback.base()
            if pose is not None:
                x, y, heading, linear, angular = pose
                return dataclasses.replace(
                    state.odometry,
                    timestamp=now,
                    x=x,
                    y=y,
                    heading=heading,
                    linear=linear,
                    angular=angular,
                )
        q, v = feedback
        if self.gz:
            left = float(q[self.first[0]]) * self.left_radius
            right = float(q[self.first[1]]) * self.right_radius
            return state.odometry.from_positions(left, right, self.separation, now, 10)
        # gazebo_ros_diff_drive's encoder odometry: the wheels' velocities over the step.
        left = float(np.mean(v[self.left_rows])) * self.left_radius * dt
        right = float(np.mean(v[~self.left_rows])) * self.right_radius * dt
        return state.odometry.from_travel(left, right, self.separation, now, 1)
