"""``joint_trajectory_controller/JointTrajectoryController``.

Reads ``trajectory_msgs/JointTrajectory`` on ``/<controller>/joint_trajectory``
and drives its joints' position interfaces along it.

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

import bisect
import dataclasses
import math
from typing import Any

import numpy as np

from armando_drake.control.controllers import (
    Controller,
    ControllerMemory,
    ParameterError,
    Rejected,
    joint_list,
    non_negative,
    register,
)
from armando_drake.control.messages import JointTrajectory

# Upstream's "is this velocity zero" threshold: std::numeric_limits<float>::epsilon().
_FLOAT_EPSILON = float(np.finfo(np.float32).eps)

COMMAND_INTERFACES = ("position", "velocity", "acceleration", "effort")
STATE_INTERFACES = ("position", "velocity", "acceleration")
INTERPOLATION_METHODS = ("splines", "none")


@dataclasses.dataclass
class JointTrajectoryControllerParams:
    """The parameters of ``joint_trajectory_controller/JointTrajectoryController``.

    In the YAML the tolerances sit under ``constraints`` as upstream has them
    (``constraints.goal_time``, ``constraints.stopped_velocity_tolerance``,
    ``constraints.<joint>.trajectory`` / ``.goal``); they are read into the flat
    fields below.
    """

    # Controller joints, in the controller's order.
    joints: list[str] = dataclasses.field(default_factory=list)
    # Command interfaces; must hold position (the simulation drives positions).
    command_interfaces: list[str] = dataclasses.field(default_factory=lambda: ["position"])
    # State interfaces used; with velocity, a trajectory starts from the measured velocity.
    state_interfaces: list[str] = dataclasses.field(
        default_factory=lambda: ["position", "velocity"]
    )
    # Accept goals naming only some joints (the others hold their command).
    allow_partial_joints_goal: bool = False
    # splines (linear / cubic / quintic per segment) | none (hold each point).
    interpolation_method: str = "splines"
    # Accept a last point with non-zero velocities.
    allow_nonzero_velocity_at_trajectory_end: bool = False
    # [s] after the end to reach the goal; 0 = wait forever.
    goal_time: float = 0.0
    # [rad/s] "stopped" at the goal; 0 = unchecked.
    stopped_velocity_tolerance: float = 0.01
    # [rad] per joint: allowed |measured - desired| while running; absent or 0 = unchecked.
    trajectory_tolerance: dict[str, float] = dataclasses.field(default_factory=dict)
    # [rad] per joint: allowed |measured - goal| after the end; absent or 0 = unchecked.
    goal_tolerance: dict[str, float] = dataclasses.field(default_factory=dict)

    def check(self, raw: dict[str, Any]) -> None:
        """Ranges and choices, each error naming its parameter."""
        for name, allowed in (
            ("command_interfaces", COMMAND_INTERFACES),
            ("state_interfaces", STATE_INTERFACES),
        ):
            _interfaces(raw.get(name), allowed, name)
        if "effort" in self.command_interfaces:
            raise ParameterError(
                "command_interfaces",
                "the 'effort' command interface is not simulated; use position",
            )
        if self.interpolation_method not in INTERPOLATION_METHODS:
            raise ParameterError(
                "interpolation_method",
                f"unknown method {self.interpolation_method!r}; expected one of "
                f"{list(INTERPOLATION_METHODS)}",
            )


def _interfaces(value: Any, allowed: tuple[str, ...], parameter: str) -> list[str]:
    if value is None:
        raise ParameterError(parameter, f"parameter is missing; give a list from {list(allowed)}")
    if not isinstance(value, list) or not value:
        raise ParameterError(
            parameter, f"expected a non-empty list from {list(allowed)}, got {value!r}"
        )
    for name in value:
        if name not in allowed:
            raise ParameterError(
                parameter, f"unknown interface {name!r}; expected one of {list(allowed)}"
            )
    if len(set(value)) != len(value):
        raise ParameterError(parameter, f"interfaces listed more than once: {value!r}")
    if "position" not in value:
        raise ParameterError(
            parameter, f"{value!r} has no 'position'; the simulation drives positions"
        )
    return list(value)


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


_DEGREE = 5  # highest segment degree (quintic)
_EXPONENTS = np.arange(_DEGREE + 1)


@dataclasses.dataclass(frozen=True)
class _ActiveTrajectory:
    """An accepted trajectory, sampled at each update. Never mutated.

    The segments are kept as one coefficient table and sampled with one matrix
    product (no pybind call: inside a simulation each costs tens of microseconds,
    so Drake's ``PiecewisePolynomial.value`` here cost more than the rest of the
    tick).
    """

    breaks: tuple[float, ...]  # [s] knot times (segments + 1); () if it has ended on arrival
    # Per segment, ascending coefficients in (t - break) of [q_d; v_d] (2n rows): (s, 2n, 6);
    # for interpolation_method none, the held positions and velocities.
    coefficients: np.ndarray
    end_time: float  # [s] time of the last point
    goal: np.ndarray  # [rad] positions of the last point (n)

    def __deepcopy__(self, memo):
        return self

    def sample(self, time: float) -> tuple[np.ndarray, np.ndarray, bool]:
        """Desired (q, v) at ``time`` and whether the trajectory has ended."""
        if not self.breaks or time >= self.end_time:
            return self.goal.copy(), np.zeros_like(self.goal), True
        x_d = self.sample_state(time)
        n = len(self.goal)
        return x_d[:n], x_d[n:], False

    def sample_state(self, time: float) -> np.ndarray:
        """[q_d; v_d] (2n) at ``time`` before the end (one matrix product)."""
        k = max(bisect.bisect_right(self.breaks, time) - 1, 0)
        return self.coefficients[k] @ (max(time - self.breaks[k], 0.0) ** _EXPONENTS)

    @staticmethod
    def build(knots: list[_Knot], hold: bool) -> "_ActiveTrajectory":
        goal = knots[-1].positions.copy()
        n = len(goal)
        if len(knots) < 2:
            empty = np.zeros((0, 2 * n, _DEGREE + 1))
            return _ActiveTrajectory((), empty, knots[-1].time, goal)
        breaks = tuple(float(knot.time) for knot in knots)
        table = np.zeros((len(knots) - 1, 2 * n, _DEGREE + 1))
        for k, (a, b) in enumerate(zip(knots[:-1], knots[1:], strict=True)):
            if hold:
                # interpolation_method: none -- each point's values until the next one.
                table[k, :n, 0] = a.positions
                if a.velocities is not None:
                    table[k, n:, 0] = a.velocities
                continue
            coefficients = _segment_coefficients(a, b)
            degree = coefficients.shape[1] - 1
            table[k, :n, : degree + 1] = coefficients
            table[k, n:, :degree] = coefficients[:, 1:] * np.arange(1, degree + 1)
        return _ActiveTrajectory(breaks, table, breaks[-1], goal)


_IGNORED = frozenset(
    {
        "open_loop_control",
        "state_publish_rate",
        "action_monitor_rate",
        "allow_integration_in_goal_trajectories",
        "gains",
        "cmd_timeout",
        "set_last_command_interface_value_as_state_on_activation",
        "interpolate_from_desired_state",
        "speed_scaling",
        "speed_scaling_interface_name",
    }
)


@register("joint_trajectory_controller/JointTrajectoryController")
class JointTrajectoryController(Controller):
    """The logic of ``joint_trajectory_controller/JointTrajectoryController`` (see the
    module docstring); the controller manager runs it."""

    parameters = JointTrajectoryControllerParams
    ignored_parameters = _IGNORED
    message = JointTrajectory
    topic = "joint_trajectory"
    fixed_interface = "position"
    initial_state = "idle"

    @classmethod
    def known_parameters(cls) -> frozenset[str]:
        return frozenset(
            {
                "joints",
                "command_joints",
                "command_interfaces",
                "state_interfaces",
                "allow_partial_joints_goal",
                "interpolation_method",
                "allow_nonzero_velocity_at_trajectory_end",
                "constraints",
            }
        )

    @classmethod
    def ros_layout(cls, raw: dict[str, Any]) -> dict[str, Any]:
        """ROS's ``constraints`` mapping as the flat fields of the parameters."""
        if "joints" not in raw:
            raise ParameterError("joints", "'joints' parameter is missing")
        joints = joint_list(raw["joints"])
        command_joints = raw.pop("command_joints", None)
        if command_joints not in (None, [], joints):
            raise ParameterError(
                "command_joints", f"{command_joints!r} differs from joints {joints}; not simulated"
            )
        constraints = raw.pop("constraints", None) or {}
        if not isinstance(constraints, dict):
            raise ParameterError("constraints", f"expected a mapping, got {constraints!r}")
        trajectory_tolerance, goal_tolerance = {}, {}
        for name, value in constraints.items():
            where = f"constraints.{name}"
            if name in ("goal_time", "stopped_velocity_tolerance"):
                raw[name] = non_negative(value, where)
            elif name in joints:
                if not isinstance(value, dict):
                    raise ParameterError(where, f"expected 'trajectory' and 'goal', got {value!r}")
                for tolerance, number in value.items():
                    if tolerance == "trajectory":
                        trajectory_tolerance[name] = non_negative(number, f"{where}.trajectory")
                    elif tolerance == "goal":
                        goal_tolerance[name] = non_negative(number, f"{where}.goal")
                    else:
                        raise ParameterError(
                            f"{where}.{tolerance}", "unknown tolerance; expected trajectory, goal"
                        )
            else:
                raise ParameterError(
                    where,
                    f"'{name}' is neither goal_time, stopped_velocity_tolerance nor one of the "
                    f"controller's joints {joints}",
                )
        raw["trajectory_tolerance"] = trajectory_tolerance
        raw["goal_tolerance"] = goal_tolerance
        return raw

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        params = self.params
        names = self.joint_names
        if tuple(params.joints) != names:
            raise ValueError(f"params.joints={params.joints!r} differs from joint_names={names!r}")
        if params.interpolation_method not in INTERPOLATION_METHODS:
            raise ValueError(
                f"interpolation_method={params.interpolation_method!r} must be splines or none"
            )
        self._params = params
        self._path_tolerance = np.array(
            [params.trajectory_tolerance.get(name, 0.0) for name in names]
        )
        self._goal_tolerance = np.array([params.goal_tolerance.get(name, 0.0) for name in names])
        # [rad] the path tolerance as a bound to compare with (inf where unchecked).
        self._path_limit = np.where(self._path_tolerance > 0, self._path_tolerance, np.inf)
        # [rad, rad/s] bounds of [q_d; v_d]: the position limits, velocities unbounded.
        self._state_lower = np.concatenate([self.lower, np.full(self.n, -np.inf)])
        self._state_upper = np.concatenate([self.upper, np.full(self.n, np.inf)])

    def _clamped(self, x_d: np.ndarray) -> np.ndarray:
        """[q_d; v_d] with q_d clamped into the position limits; a clamped joint's (and
        a non-finite) desired velocity is 0: a spline through a point far outside the
        limits (1e300 rad in 1e-12 s) would otherwise send inf or NaN to the plant."""
        x = np.minimum(np.maximum(x_d, self._state_lower), self._state_upper)
        n = self.n
        hold = (x[:n] != x_d[:n]) | ~np.isfinite(x[n:])
        x[n:][hold] = 0.0
        return x

    def _Validate(self, message, now: float) -> list[int]:
        """Controller index of each message joint; raises _Rejected in upstream's order."""
        if not isinstance(message, JointTrajectory):
            raise Rejected(f"expected a JointTrajectory message, got {type(message).__name__}")
        names = list(message.joint_names)
        points = message.points
        if not self._params.allow_partial_joints_goal and len(names) != self.n:
            raise Rejected("Joints on incoming trajectory don't match the controller joints.")
        if not names:
            raise Rejected("Empty joint names on incoming trajectory.")
        if not points:
            raise Rejected("Empty trajectory received.")
        for i, name in enumerate(names):
            if name not in self.joint_names:
                raise Rejected(f"Incoming joint {name} doesn't match the controller's joints.")
            if name in names[:i]:
                raise Rejected(f"Incoming joint {name} appears more than once.")
        if not self._params.allow_nonzero_velocity_at_trajectory_end:
            for name, velocity in zip(names, points[-1].velocities, strict=False):
                if abs(velocity) > _FLOAT_EPSILON:
                    raise Rejected(
                        f"Velocity of last trajectory point of joint {name} is not zero: "
                        f"{velocity:.15f}"
                    )
        if not math.isfinite(message.stamp):
            raise Rejected(f"Non-finite header stamp received: {message.stamp}")
        if message.stamp != 0.0:
            end = message.stamp + points[-1].time_from_start
            if end < now:
                raise Rejected(
                    f"Received trajectory with non-zero start time ({message.stamp:f}) "
                    f"that ends in the past ({end:f})"
                )
        for i, point in enumerate(points):
            time = point.time_from_start
            if not math.isfinite(time):
                raise Rejected(f"Non-finite time_from_start at point #{i}: {time}")
            if time < 0.0:
                raise Rejected(f"Time from start of point #{i} is negative: {time:f}")
            if i > 0 and time <= points[i - 1].time_from_start:
                raise Rejected(
                    f"Time between points {i - 1} and {i} is not strictly increasing, "
                    f"it is {points[i - 1].time_from_start:f} and {time:f} respectively"
                )
            for field in ("positions", "velocities", "accelerations"):
                values = getattr(point, field)
                if field != "positions" and len(values) == 0:
                    continue
                if len(values) != len(names):
                    raise Rejected(
                        f"Mismatch between joint_names size ({len(names)}) and {field} "
                        f"({len(values)}) at point #{i}."
                    )
            if len(point.effort) != 0:
                raise Rejected(
                    "Trajectories with effort fields are only supported for controllers using "
                    "the 'effort' command interface."
                )
            for field in ("positions", "velocities", "accelerations"):
                if not np.all(np.isfinite(np.asarray(getattr(point, field), dtype=float))):
                    raise Rejected(f"Non-finite value in {field} at point #{i}.")
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
        if message is None and not memory.busy:
            return memory  # nothing new and nothing running: the desired state holds
        if message is None and now < memory.trajectory.end_time and memory.trajectory.breaks:
            # The common tick: sample the running trajectory, check the path tolerance
            # (vectorised), nothing else; any event goes the long way below.
            x_d = memory.trajectory.sample_state(now)
            q, _ = measure(memory.desired)
            if not (np.abs(q - x_d[: self.n]) > self._path_limit).any():
                x_d = self._clamped(x_d)
                return ControllerMemory(x_d, memory.status, memory.trajectory)
        n = self.n
        desired = memory.desired
        status, trajectory = memory.status, memory.trajectory
        q, v = measure(desired)
        if message is not None:
            try:
                indices = self._Validate(message, now)
            except Rejected as rejection:
                status = self.reject(status, str(rejection))
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
                    self.log_warning(self.name, detail["warning"])
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
            self.log_warning(self.name, outcome[1])
            status = dataclasses.replace(
                status, state="aborted", last_error=outcome[1], detail=dict(status.detail)
            )
        elif outcome is not None:
            status = dataclasses.replace(status, state="succeeded", detail=dict(status.detail))
        if outcome is not None:
            trajectory = None
        return ControllerMemory(self._clamped(np.concatenate([q_d, v_d])), status, trajectory)

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
