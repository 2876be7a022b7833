"""The checks of ``joint_trajectory_controller/JointTrajectoryController``: a received
JointTrajectory validated as upstream does, in upstream's order and words (and then more
strictly), and the tolerances a running trajectory is held to (upstream's
``constraints``: path, goal, stopped velocity, ``goal_time``, ``cmd_timeout``). A helper
of :mod:`.joint_trajectory` (a private module: the controller discovery imports no
controller type from it)."""

import math

import numpy as np

from armando_drake.control.controllers import Rejected
from armando_drake.control.controllers._trajectory import FLOAT_EPSILON, shortest_angular_distance
from armando_drake.messages.types import JointTrajectory


def validate_trajectory(
    message, now: float, joint_names: tuple[str, ...], params, has_effort: bool
) -> list[int]:
    """The controller index of each joint of the JointTrajectory ``message`` received at
    ``now`` [s] by a controller of ``joint_names`` with parameters ``params`` (and an
    effort command interface: ``has_effort``); raises Rejected in upstream's order."""
    if not isinstance(message, JointTrajectory):
        raise Rejected(f"expected a JointTrajectory message, got {type(message).__name__}")
    names = list(message.joint_names)
    points = message.points
    if not params.allow_partial_joints_goal and len(names) != len(joint_names):
        raise Rejected("Joints on incoming trajectory don't match the controller joints.")
    if not names:
        raise Rejected("Empty joint names on incoming trajectory.")
    if not points:
        raise Rejected("Empty trajectory received.")
    for i, name in enumerate(names):
        if name not in joint_names:
            raise Rejected(f"Incoming joint {name} doesn't match the controller's joints.")
        if name in names[:i]:
            raise Rejected(f"Incoming joint {name} appears more than once.")
    if not params.allow_nonzero_velocity_at_trajectory_end:
        for name, velocity in zip(names, points[-1].velocities, strict=False):
            if abs(velocity) > FLOAT_EPSILON:
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
    integrate = params.allow_integration_in_goal_trajectories
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
        if integrate and not (point.positions or point.velocities or point.accelerations):
            raise Rejected(f"Point #{i} has no positions, velocities or accelerations.")
        for field in ("positions", "velocities", "accelerations"):
            values = getattr(point, field)
            optional = field != "positions" or integrate
            if optional and len(values) == 0:
                continue
            if len(values) != len(names):
                raise Rejected(
                    f"Mismatch between joint_names size ({len(names)}) and {field} "
                    f"({len(values)}) at point #{i}."
                )
        if not has_effort and len(point.effort) != 0:
            raise Rejected(
                "Trajectories with effort fields are only supported for controllers using "
                "the 'effort' command interface."
            )
        if len(point.effort) not in (0, len(names)):
            raise Rejected(
                f"Mismatch between joint_names size ({len(names)}) and effort "
                f"({len(point.effort)}) at point #{i}."
            )
        for field in ("positions", "velocities", "accelerations", "effort"):
            if not np.all(np.isfinite(np.asarray(getattr(point, field), dtype=float))):
                raise Rejected(f"Non-finite value in {field} at point #{i}.")
    return [joint_names.index(name) for name in names]


class Tolerances:
    """The tolerances of one controller's joints: ``trajectory`` while running,
    ``goal`` after the end, ``stopped_velocity_tolerance`` (compared only where
    upstream has a velocity error: a velocity state interface and a velocity or effort
    command interface), ``goal_time`` and ``cmd_timeout``; and the position error
    (wrapped on continuous joints)."""

    def __init__(self, params, joint_names, wraparound: np.ndarray, cmd_timeout: float):
        self.joint_names = tuple(joint_names)
        self.path = np.array([params.trajectory_tolerance.get(n, 0.0) for n in joint_names])
        self.goal = np.array([params.goal_tolerance.get(n, 0.0) for n in joint_names])
        # [rad] the tolerances as bounds to compare with (inf where unchecked).
        self.path_limit = np.where(self.path > 0, self.path, np.inf)
        self.goal_limit = np.where(self.goal > 0, self.goal, np.inf)
        self.wraparound = wraparound
        self.wraps = bool(wraparound.any())
        commands, states = params.command_interfaces, params.state_interfaces
        self.velocity_error = "velocity" in states and (
            "velocity" in commands or "effort" in commands
        )
        self.stopped_velocity_tolerance = params.stopped_velocity_tolerance
        self.goal_time = params.goal_time
        self.cmd_timeout = cmd_timeout  # [s] 0 when off

    def error(self, desired: np.ndarray, q: np.ndarray) -> np.ndarray:
        """[rad] upstream's compute_error_for_joint position error ``desired - q``, the
        shortest angular distance for continuous joints."""
        error = desired - q
        if self.wraps:
            error = np.where(self.wraparound, shortest_angular_distance(q, desired), error)
        return error

    def path_violation(self, error: np.ndarray, x_now: np.ndarray) -> str | None:
        """Why the |position error| ``error`` to the desired state ``x_now`` aborts a
        running trajectory ("path tolerance violated: ..."), None if it does not."""
        if not (error > self.path_limit).any():
            return None
        j = int(np.argmax(error > self.path_limit))
        return (
            f"path tolerance violated: joint '{self.joint_names[j]}' is "
            f"{error[j]:.6g} rad from its desired position {x_now[j]:.6g} (trajectory "
            f"tolerance {self.path[j]:g})"
        )

    def goal_outcome(
        self, late: float, error: np.ndarray, x_now: np.ndarray, v: np.ndarray
    ) -> tuple[bool, str | None]:
        """``late`` [s] after the end: (whether the goal is reached, else why it aborts
        or None while it may still be)."""
        n = len(self.joint_names)
        far = error > self.goal_limit
        velocity_error = np.abs(x_now[n:] - v) if self.velocity_error else np.zeros(n)
        tolerance = self.stopped_velocity_tolerance
        moving = (tolerance > 0) & (velocity_error > tolerance)
        if not far.any() and not moving.any():
            return True, None
        if self.goal_time > 0 and late > self.goal_time:
            if far.any():
                j = int(np.argmax(far))
                problem = (
                    f"joint '{self.joint_names[j]}' is {error[j]:.6g} rad from its desired "
                    f"position {x_now[j]:.6g} (goal tolerance {self.goal[j]:g})"
                )
            else:
                j = int(np.argmax(moving))
                problem = (
                    f"joint '{self.joint_names[j]}' moves at {v[j]:.6g} rad/s, "
                    f"{velocity_error[j]:.6g} rad/s from its desired velocity "
                    f"(stopped_velocity_tolerance {tolerance:g})"
                )
            return False, f"goal tolerance violated: {problem} {late:.6g} s after the end"
        if self.cmd_timeout > 0 and late > self.cmd_timeout:
            return False, (
                f"Aborted due to command timeout: the goal is not reached {late:.6g} s "
                f"after the end (cmd_timeout {self.cmd_timeout:g})"
            )
        return False, None
