"""A task-space motion as a scenario file describes it, and the trajectory it makes.

:class:`TaskSpaceMotion` is loaded with ``yaml_load_typed`` (unknown keys are
errors); :func:`make_cartesian_trajectory` turns it and the end effector's start
pose into a :class:`~armando_drake.kinematics.paths.CartesianTrajectory`.
"""

import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.math import RigidTransform, RotationMatrix

from armando_drake.kinematics.paths import (
    CartesianTrajectory,
    CircularPath,
    LinearPath,
    OrientationPath,
    PathError,
)
from armando_drake.kinematics.time_laws import (
    CubicTimeLaw,
    QuinticTimeLaw,
    TimeLaw,
    TrapezoidalTimeLaw,
)
from armando_drake.tools.schema import param

PATHS = ("linear", "circular")
TIME_LAWS = ("trapezoidal", "cubic", "quintic")


@dataclass
class TaskSpaceMotion:
    """One end-effector motion from the current pose, in the robot's base frame."""

    path: str = "linear"  # linear | circular
    # [m] linear: the goal position; empty: start + offset
    goal: list[float] = param([], unit="m")
    # [m] linear: goal - start, used when goal is empty
    offset: list[float] = param([0.0, 0.0, 0.0], unit="m")
    radius: float = param(0.05, unit="m", gt=0)  # [m] circular: the radius
    # [-] circular: the plane's normal (default: the y-z plane through the start, as
    # the course's seed)
    normal: list[float] = param([1.0, 0.0, 0.0], unit="-")
    # [-] circular: from the start towards the centre (projected into the plane)
    center_direction: list[float] = param([0.0, 0.0, -1.0], unit="-")
    # [rad] circular: the arc turned about the normal
    angle: float = param(2.0 * math.pi, unit="rad")
    # [rad] rotation vector (base frame) from the start orientation to the goal's,
    # slerped along the path; zero holds the orientation (arms with < 6 joints: zero)
    rotation: list[float] = param([0.0, 0.0, 0.0], unit="rad")
    profile: str = "trapezoidal"  # the time law: trapezoidal | cubic | quintic
    duration: float = param(3.0, unit="s", gt=0)  # [s] the motion's duration T
    # [s] trapezoidal: t_c, 0 < t_c <= T/2
    acceleration_time: float = param(0.6, unit="s", gt=0)
    # The frame that follows the path: a frame of the robot ("" = the child link of
    # its last moving joint).
    end_effector: str = ""
    # [rad] the joint positions at the start, in the hardware interface's joint
    # order; empty = the description's initial positions. The path starts at the
    # end effector's pose there.
    start_positions: list[float] = param([], unit="rad or m")
    # In a world of several robots (robots:), the name of the one it acts on; "" = the
    # first listed.
    robot: str = ""


def make_time_law(motion: TaskSpaceMotion) -> TimeLaw:
    """The time law the motion names."""
    if motion.profile == "trapezoidal":
        return TrapezoidalTimeLaw(
            duration=motion.duration, acceleration_time=motion.acceleration_time
        )
    if motion.profile == "cubic":
        return CubicTimeLaw(duration=motion.duration)
    if motion.profile == "quintic":
        return QuinticTimeLaw(duration=motion.duration)
    raise PathError(f"profile={motion.profile!r} must be one of {', '.join(TIME_LAWS)}")


def make_cartesian_trajectory(motion: TaskSpaceMotion, X_start: RigidTransform):
    """The motion from ``X_start`` (X_BE now) as a CartesianTrajectory."""
    start = X_start.translation()
    if motion.path == "linear":
        if motion.goal:
            goal = motion.goal
        else:
            if len(motion.offset) != 3:
                raise PathError(f"offset={motion.offset!r} must be three numbers")
            goal = start + np.asarray(motion.offset, dtype=float)
        path = LinearPath(start=start, goal=goal)
    elif motion.path == "circular":
        path = CircularPath(
            start=start,
            radius=motion.radius,
            normal=motion.normal,
            center_direction=motion.center_direction,
            angle=motion.angle,
        )
    else:
        raise PathError(f"path={motion.path!r} must be one of {', '.join(PATHS)}")
    rotation = np.asarray(motion.rotation, dtype=float)
    if rotation.shape != (3,) or not np.all(np.isfinite(rotation)):
        raise PathError(f"rotation={motion.rotation!r} must be three finite numbers [rad]")
    goal_rotation = None
    angle = float(np.linalg.norm(rotation))
    if angle > 0.0:
        turn = RotationMatrix(AngleAxis(angle, rotation / angle))
        goal_rotation = turn.multiply(X_start.rotation())
    return CartesianTrajectory(
        time_law=make_time_law(motion),
        path=path,
        orientation=OrientationPath(start=X_start.rotation(), goal=goal_rotation),
    )
