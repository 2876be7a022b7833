"""The trajectory of ``joint_trajectory_controller/JointTrajectoryController``: upstream's
``trajectory.cpp``, precomputed per segment (linear, cubic or quintic splines, or the next
point's values), the points of a message in the controller's joint order, and the stop
ramp of ``decelerate_on_cancel``. A helper of :mod:`.joint_trajectory` (a private module:
the controller discovery imports no controller type from it)."""

import bisect
import dataclasses
import math

import numpy as np

from armando_drake.messages.types import JointTrajectory, JointTrajectoryPoint

# Upstream's "is this velocity zero" threshold: std::numeric_limits<float>::epsilon().
FLOAT_EPSILON = float(np.finfo(np.float32).eps)


@dataclasses.dataclass
class Point:
    """One point in controller joint order; None = not given (upstream's empty vector)."""

    time: float  # [s] simulation time
    positions: np.ndarray | None  # [rad] (n)
    velocities: np.ndarray | None  # [rad/s] (n)
    accelerations: np.ndarray | None  # [rad/s^2] (n)
    # [N m] (n): the feed-forward effort of the effort command interface.
    effort: np.ndarray | None = None

    def filled(self, field: str) -> np.ndarray:
        values = getattr(self, field)
        return np.zeros(len(self.positions)) if values is None else values


def _segment_coefficients(a: Point, b: Point) -> np.ndarray:
    """Per joint, the ascending coefficients in (t - a.time) of the position on a -> b
    (upstream's ``interpolate_between_points``): cubic when both ends give velocities,
    quintic when both also give accelerations, else linear. (n, 6)"""
    T = b.time - a.time
    p0, p1 = a.positions, b.positions
    table = np.zeros((len(p0), 6))
    table[:, 0] = p0
    if a.velocities is None or b.velocities is None:
        # Linear; also for accelerations without velocities, where upstream has no
        # branch and commands zeros (one of our documented differences).
        table[:, 1] = (p1 - p0) / T
        return table
    v0, v1 = a.velocities, b.velocities
    table[:, 1] = v0
    if a.accelerations is None or b.accelerations is None:
        table[:, 2] = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * T) / T**2
        table[:, 3] = (2.0 * (p0 - p1) + (v0 + v1) * T) / T**3
        return table
    a0, a1 = a.accelerations, b.accelerations
    table[:, 2] = 0.5 * a0
    table[:, 3] = (20.0 * (p1 - p0) - (8.0 * v1 + 12.0 * v0) * T - (3.0 * a0 - a1) * T**2) / (
        2.0 * T**3
    )
    c4 = 30.0 * (p0 - p1) + (14.0 * v1 + 16.0 * v0) * T + (3.0 * a0 - 2.0 * a1) * T**2
    table[:, 4] = c4 / (2.0 * T**4)
    table[:, 5] = (12.0 * (p1 - p0) - 6.0 * (v1 + v0) * T - (a0 - a1) * T**2) / (2.0 * T**5)
    return table


def interpolate_between_points(
    time_a: float,
    state_a: JointTrajectoryPoint,
    time_b: float,
    state_b: JointTrajectoryPoint,
    sample_time: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Upstream's ``Trajectory::interpolate_between_points``: positions, velocities and
    accelerations at ``sample_time`` on the segment a -> b (times [s]), of the degree
    both ends allow; clamped to the segment's ends."""

    def point(time, state):
        def array(values):
            return np.asarray(values, float) if len(values) else None

        return Point(
            time, array(state.positions), array(state.velocities), array(state.accelerations)
        )

    a, b = point(time_a, state_a), point(time_b, state_b)
    tau = min(max(sample_time - time_a, 0.0), time_b - time_a)
    if not time_a <= sample_time <= time_b:  # upstream clamps, and goes linear
        b = dataclasses.replace(b, velocities=None, accelerations=None)
    coefficients = _segment_coefficients(a, b)
    powers = tau**_EXPONENTS
    velocity = coefficients[:, 1:] @ (_DERIVATIVE * tau ** (_DERIVATIVE - 1))
    acceleration = coefficients[:, 2:] @ (
        _DERIVATIVE[1:] * _DERIVATIVE[:-1] * tau ** (_DERIVATIVE[:-1] - 1)
    )
    return coefficients @ powers, velocity, acceleration


def _deduce_from_derivatives(a: Point, b: Point) -> None:
    """Upstream's ``deduce_from_derivatives``: b's missing positions (and velocities)
    integrated from a's, with the trapezoid rule (a's missing ones are zero)."""
    if b.positions is not None:
        return
    n = len(a.positions)
    dt = b.time - a.time
    if a.velocities is None:
        a.velocities = np.zeros(n)
    if b.velocities is None:
        if a.accelerations is None:
            a.accelerations = np.zeros(n)
        b.velocities = a.velocities + (a.accelerations + b.filled("accelerations")) * 0.5 * dt
    b.positions = a.positions + (a.velocities + b.velocities) * 0.5 * dt


def shortest_angular_distance(start, end) -> np.ndarray:
    """[rad] ROS angles' ``shortest_angular_distance(start, end)``: ``end - start``
    normalized into (-pi, pi] (``normalize_angle``: fmod(a + pi, 2 pi), shifted back)."""
    angle = np.asarray(end, dtype=float) - np.asarray(start, dtype=float)
    result = np.fmod(angle + math.pi, 2.0 * math.pi)
    return np.where(result <= 0.0, result + math.pi, result - math.pi)


def wraparound_joint(current, next_positions, wraparound) -> np.ndarray:
    """Upstream's ``wraparound_joint``: ``current`` [rad] with each joint flagged in
    ``wraparound`` moved by a multiple of 2 pi to within pi of ``next_positions`` (the first
    point), so a continuous joint's first segment is its shortest rotation; at exactly pi
    away (within 1e-9) the distance takes the sign of ``next - current``."""
    current = np.array(current, dtype=float)
    mask = np.asarray(wraparound, dtype=bool)
    if not mask.any():
        return current
    target = np.asarray(next_positions, dtype=float)
    distance = shortest_angular_distance(current, target)
    tie = np.abs(np.abs(distance) - math.pi) < 1e-9
    distance = np.where(tie, np.where(target > current, 1.0, -1.0) * np.abs(distance), distance)
    return np.where(mask, target - distance, current)


@dataclasses.dataclass(frozen=True)
class TrajectorySample:
    """What upstream's ``Trajectory::sample`` returns, in controller joint order."""

    positions: np.ndarray  # [rad] (n)
    velocities: np.ndarray  # [rad/s] (n)
    accelerations: np.ndarray  # [rad/s^2] (n)
    segment: tuple[int, int]  # indices of the points around the sample (see sample())
    effort: np.ndarray | None = None  # [N m] (n), zero where no point gives one


_DEGREE = 5  # highest segment degree (quintic)
_EXPONENTS = np.arange(_DEGREE + 1)
_DERIVATIVE = np.arange(1, _DEGREE + 1)  # d/dt of c_k t^k is k c_k t^(k-1)


@dataclasses.dataclass(frozen=True)
class SampledTrajectory:
    """An accepted trajectory as upstream's ``Trajectory::sample`` sees it, with each
    segment's coefficients computed once. Never mutated.

    The segments are one coefficient table sampled with one matrix product (no
    pybind call: inside a simulation each costs tens of microseconds, so Drake's
    ``PiecewisePolynomial.value`` here cost more than the rest of the tick).
    """

    breaks: tuple[float, ...]  # [s] segment start times, then the last point's time
    # Per segment, ascending coefficients in (t - break) of [q; v] (2n rows): (s, 2n, 6).
    # For interpolation_method none each segment is constant (column 0).
    coefficients: np.ndarray
    end_time: float  # [s] time of the last point
    # [rad, rad/s, rad/s^2] what upstream commands after the last point: its positions,
    # velocities and accelerations (zero where not given), as [q; v; a] (3n).
    final: np.ndarray
    # [rad/s^2] per segment the constant accelerations of interpolation_method none (s, n).
    held_accelerations: np.ndarray | None = None
    # [s] time of the state before the trajectory (the update that first sampled it).
    before_time: float = -math.inf
    # Whether the first segment runs from the state before the trajectory to the first
    # point (the first point was still to come when the trajectory was first sampled).
    from_before: bool = False
    # [N m] per segment, the effort at its start and its slope [N m/s] (s, n, 2): linear
    # between points, an effort not given read as zero (upstream's has_effort after
    # deduce_from_derivatives fills empty efforts with zeros); None: zero throughout.
    effort_coefficients: np.ndarray | None = None
    # [N m] (n) the effort after the last point: its effort, zero where not given.
    final_effort: np.ndarray | None = None

    def __deepcopy__(self, memo):
        return self

    @property
    def n(self) -> int:
        return len(self.final) // 3

    def ended(self, time: float) -> bool:
        """Whether ``time`` is at or past the last point (upstream: "whole animation has
        played out", the end segment iterator at ``end()``)."""
        return time >= self.end_time

    def state(self, time: float) -> np.ndarray:
        """[q; v] (2n) at ``time`` [s]: the segment's polynomial, or the last point."""
        if time >= self.end_time:
            return self.final[: 2 * self.n]
        k = max(bisect.bisect_right(self.breaks, time) - 1, 0)
        return self.coefficients[k] @ (max(time - self.breaks[k], 0.0) ** _EXPONENTS)

    def acceleration(self, time: float) -> np.ndarray:
        """[rad/s^2] (n) at ``time`` [s]."""
        n = self.n
        if time >= self.end_time:
            return self.final[2 * n :]
        k = max(bisect.bisect_right(self.breaks, time) - 1, 0)
        if self.held_accelerations is not None:
            return self.held_accelerations[k]
        tau = max(time - self.breaks[k], 0.0)
        return self.coefficients[k, n:, 1:] @ (_DERIVATIVE * tau ** (_DERIVATIVE - 1))

    def effort(self, time: float) -> np.ndarray:
        """[N m] (n) the feed-forward effort at ``time`` [s]."""
        if time >= self.end_time:
            return np.zeros(self.n) if self.final_effort is None else self.final_effort
        if self.effort_coefficients is None:
            return np.zeros(self.n)
        k = max(bisect.bisect_right(self.breaks, time) - 1, 0)
        tau = min(max(time - self.breaks[k], 0.0), self.breaks[k + 1] - self.breaks[k])
        start, slope = self.effort_coefficients[k, :, 0], self.effort_coefficients[k, :, 1]
        return start + slope * tau

    def sample(self, time: float) -> "TrajectorySample | None":
        """Upstream's ``Trajectory::sample`` at ``time`` [s]: None before the state
        before the trajectory, else the positions, velocities, accelerations and the
        segment's point indices (upstream's start and end iterators: (0, 0) before the
        first point, (i, i + 1) from point i to i + 1, (last, count) after the end)."""
        if time < self.before_time:
            return None
        n = self.n
        x = self.state(time)
        count = len(self.breaks) - (1 if self.from_before else 0)
        if self.ended(time):
            segment = (count - 1, count)
        else:
            k = max(bisect.bisect_right(self.breaks, time) - 1, 0)
            k -= 1 if self.from_before else 0
            segment = (0, 0) if k < 0 else (k, k + 1)
        return TrajectorySample(
            x[:n].copy(),
            x[n:].copy(),
            self.acceleration(time),
            segment,
            np.array(self.effort(time), dtype=float),
        )

    @staticmethod
    def from_message(
        message: JointTrajectory,
        *,
        time: float,
        positions,
        velocities=None,
        accelerations=None,
        effort=None,
        interpolation_method: str = "splines",
        wraparound=None,
    ) -> "SampledTrajectory":
        """Upstream's ``Trajectory(current_time, current_point, msg)`` first sampled at
        ``time`` [s] (the start, when the message's stamp is 0): ``message`` (its joints in
        the controller's order) from the state before it, ``positions`` [rad] and, when
        given, ``velocities`` [rad/s], ``accelerations`` [rad/s^2] and ``effort`` [N m];
        ``wraparound`` flags the continuous joints (upstream's ``joints_angle_wraparound``)."""
        start = message.stamp if message.stamp != 0.0 else time

        def array(values):
            return None if values is None or len(values) == 0 else np.asarray(values, float)

        points = [
            Point(
                start + point.time_from_start,
                array(point.positions),
                array(point.velocities),
                array(point.accelerations),
                array(point.effort),
            )
            for point in message.points
        ]
        before = Point(
            time, array(positions), array(velocities), array(accelerations), array(effort)
        )
        return SampledTrajectory.build(
            before, points, interpolate=interpolation_method == "splines", wraparound=wraparound
        )

    @staticmethod
    def hold(
        positions: np.ndarray,
        velocities: np.ndarray | None = None,
        effort: np.ndarray | None = None,
    ) -> "SampledTrajectory":
        """Upstream's hold trajectory: one point at ``positions`` (zero velocities and
        efforts unless given, zero accelerations), commanded from its start on."""
        n = len(positions)
        velocities = np.zeros(n) if velocities is None else velocities
        final = np.concatenate([positions, velocities, np.zeros(n)])
        table = np.zeros((0, 2 * n, _DEGREE + 1))
        return SampledTrajectory((), table, -math.inf, final, final_effort=effort)

    @staticmethod
    def build(
        before: Point, points: list[Point], *, interpolate: bool, wraparound=None
    ) -> "SampledTrajectory":
        """The trajectory through ``points`` (controller order, absolute times) that
        starts from ``before``, the state before the trajectory at the update that
        first samples it; the joints flagged in ``wraparound`` (continuous) start from
        the representation of ``before``'s position nearest the first point's
        (``wraparound_joint``). ``points`` are not changed."""
        points = [dataclasses.replace(point) for point in points]
        before = dataclasses.replace(before)
        first = points[0]
        # set_point_before_trajectory_msg: the first segment gets the trajectory's degree.
        if before.velocities is None and first.velocities is not None:
            before.velocities = np.zeros(len(before.positions))
        if before.accelerations is None and first.accelerations is not None:
            before.accelerations = np.zeros(len(before.positions))
        if wraparound is not None and first.positions is not None:
            before.positions = wraparound_joint(before.positions, first.positions, wraparound)
        knots = [before, *points] if first.time > before.time else points
        for a, b in zip(knots[:-1], knots[1:], strict=True):
            _deduce_from_derivatives(a, b)
        if knots[0].positions is None:  # the first point is already due: nothing to integrate
            knots[0].positions = before.positions.copy()
        last = knots[-1]
        n = len(last.positions)
        final = np.concatenate(
            [last.positions, last.filled("velocities"), last.filled("accelerations")]
        )
        breaks = tuple(float(knot.time) for knot in knots)
        table = np.zeros((len(knots) - 1, 2 * n, _DEGREE + 1))
        held = None if interpolate else np.zeros((len(knots) - 1, n))
        efforts = None
        if any(knot.effort is not None for knot in knots):
            efforts = np.zeros((len(knots) - 1, n, 2))
        for k, (a, b) in enumerate(zip(knots[:-1], knots[1:], strict=True)):
            if not interpolate:
                # interpolation_method none: the next point's values until it is reached;
                # before the first point, the state before the trajectory.
                shown = a if a is before else b
                table[k, :n, 0] = shown.positions
                table[k, n:, 0] = shown.filled("velocities")
                held[k] = shown.filled("accelerations")
                if efforts is not None:
                    efforts[k, :, 0] = shown.filled("effort")
                continue
            coefficients = _segment_coefficients(a, b)
            table[k, :n] = coefficients
            table[k, n:, :_DEGREE] = coefficients[:, 1:] * _DERIVATIVE
            if efforts is not None:
                # Linear, from zero where an end gives none (deduce_from_derivatives).
                efforts[k, :, 0] = a.filled("effort")
                efforts[k, :, 1] = (b.filled("effort") - a.filled("effort")) / (b.time - a.time)
        final_effort = None if last.effort is None else last.effort.copy()
        return SampledTrajectory(
            breaks,
            table,
            breaks[-1],
            final,
            held,
            before.time,
            knots[0] is before,
            efforts,
            final_effort,
        )


def message_points(message, indices, now: float, desired: np.ndarray, n: int) -> list[Point]:
    """The message's points in controller order (``fill_partial_goal``: a joint it
    leaves out gets its last command, zero velocity and acceleration); ``indices``: the
    controller index of each message joint, ``desired``: the last command [q_d; v_d],
    ``n`` the controller's joint count."""
    start = message.stamp if message.stamp != 0.0 else now
    command = desired[:n]
    zeros = np.zeros(n)

    def full(values, fill):
        if len(values) == 0:
            return None
        result = fill.copy()
        result[indices] = values
        return result

    return [
        Point(
            time=start + point.time_from_start,
            positions=full(point.positions, command),
            velocities=full(point.velocities, zeros),
            accelerations=full(point.accelerations, zeros),
            effort=full(point.effort, zeros),
        )
        for point in message.points
    ]


def stop_trajectory(
    now: float, q: np.ndarray, v: np.ndarray, a: np.ndarray, dt: float
) -> "SampledTrajectory":
    """Upstream's ``decelerate_to_hold_position``: from the measured ``q``, ``v`` a
    ramp at constant deceleration ``a`` [rad/s^2] to ``q + sign(v) v^2 / (2 a)``, one
    point per update period ``dt`` [s], starting at the next update (``now`` + dt)."""
    direction = np.where(v >= 0.0, 1.0, -1.0)
    stop_time = np.abs(v) / a
    hold = q + direction * v * v / (2.0 * a)
    count = int(math.ceil(float(stop_time.max()) / dt)) + 1 if dt > 0 else 1
    start = now + dt
    points = []
    for k in range(count):
        t = k * dt
        moving = (t < stop_time) & (np.abs(v) > FLOAT_EPSILON)
        velocity = v - direction * a * t
        velocity = np.where(velocity * direction < 0.0, 0.0, velocity)
        position = q + v * t - 0.5 * direction * a * t * t
        points.append(
            Point(
                start + t,
                np.where(moving, position, hold),
                np.where(moving, velocity, 0.0),
                np.where(moving, -direction * a, 0.0),
            )
        )
    before = Point(start, points[0].positions, points[0].velocities, None)
    return SampledTrajectory.build(before, points, interpolate=True)


def last_command_point(now: float, memory, n: int, has_effort: bool, effort) -> Point:
    """The state before a trajectory when it starts from the last command (open loop:
    ``interpolate_from_desired_state``): the running trajectory's sample at ``now``, the
    hold point of a finished one, else the desired state of the controller's ``memory``
    (``effort``: the last effort command, with an effort command interface)."""
    trajectory = memory.trajectory
    if trajectory is not None and memory.status.state == "executing":
        x = trajectory.state(now)
        last = trajectory.effort(now).copy() if has_effort else None
        return Point(now, x[:n].copy(), x[n:].copy(), trajectory.acceleration(now), last)
    if trajectory is not None:  # holding: the hold point
        final = trajectory.final
        last = trajectory.effort(now).copy() if has_effort else None
        return Point(now, final[:n].copy(), final[n : 2 * n].copy(), final[2 * n :], last)
    return Point(now, memory.desired[:n].copy(), memory.desired[n:].copy(), np.zeros(n), effort)
