"""The task-space motion of a scenario, published once at t = 0.

:func:`AddTask` turns the scenario's ``task:`` section
(:class:`~armando_drake.kinematics.motion.TaskSpaceMotion`) into a Cartesian
trajectory of the end effector and publishes it, from a Drake
``ConstantValueSource`` (no per-step cost), to the active controller that takes a
``CartesianTrajectory`` or else a ``JointTrajectory`` (planned by closed-loop
inverse kinematics).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Meshcat, Rgba
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from armando_drake.control.controllers.task_space import check_within_reach
from armando_drake.control.stack import ControlStack
from armando_drake.kinematics.arm import ArmModel, TaskSpaceError, last_link_frame
from armando_drake.kinematics.inverse_kinematics import plan_joint_reference
from armando_drake.kinematics.motion import TaskSpaceMotion, make_cartesian_trajectory
from armando_drake.kinematics.paths import PathError
from armando_drake.kinematics.time_laws import TimeLawError
from armando_drake.messages.types import (
    CartesianTrajectory,
    CartesianTrajectoryPoint,
    JointTrajectory,
    JointTrajectoryPoint,
    Publication,
)
from armando_drake.tools.errors import ScenarioError

_log = logging.getLogger("armando_drake.world")


@dataclass
class TaskReference:
    """The scenario's task-space motion as the world publishes it."""

    controller: str  # the controller it is published to
    topic: str  # on its input "<controller>.<topic>"
    trajectory: Any  # the CartesianTrajectory of the end effector (in the world frame)
    arm: Any  # the ArmModel of the end effector (FK of logged joint states)
    source: Any  # the system that publishes it (output: the Publication)


def AddTask(
    builder: DiagramBuilder,
    motion: TaskSpaceMotion,
    stack: ControlStack,
    *,
    meshcat: Meshcat | None = None,
    where: str = "",
) -> TaskReference:
    """Publishes ``motion`` to the first active controller of ``stack`` that takes a
    CartesianTrajectory, else a JointTrajectory; draws the path in ``meshcat``."""
    targets = stack.taking(CartesianTrajectory) + stack.taking(JointTrajectory)
    if not targets:
        raise ScenarioError(
            f"{where}task needs an active controller that takes a CartesianTrajectory or a "
            f"JointTrajectory; active: {', '.join(stack.controllers) or 'none'}"
        )
    name = targets[0]
    entry = stack.entry(name)
    plant, instance = stack.plant, stack.robot.model_instance
    try:
        frame = motion.end_effector or last_link_frame(plant, instance)
        arm = ArmModel(plant=plant, end_effector_frame=frame, model_instance=instance)
        arm.set_state(arm.default_positions())
        trajectory = make_cartesian_trajectory(motion, arm.pose())
        check_within_reach(arm, trajectory)
        period = 1.0 / stack.update_rate
        if entry.controller_class.message is CartesianTrajectory:
            message = cartesian_trajectory_message(trajectory, period, arm.frame_E.name())
        else:
            plan = plan_joint_reference(arm, trajectory, arm.default_positions(), period=period)
            message = joint_trajectory_message(plan, arm.joint_names)
    except (TaskSpaceError, PathError, TimeLawError) as error:
        raise ScenarioError(f"{where}task: {error}") from None
    source = builder.AddNamedSystem(
        "task_reference",
        ConstantValueSource(AbstractValue.Make(Publication(1, message, 0.0))),
    )
    builder.Connect(source.get_output_port(), stack.command_input(name))
    _log.info(
        "task: %s path, %s profile, %.3g s, end effector %s, to %s (%s)",
        motion.path,
        motion.profile,
        trajectory.duration,
        arm.frame_E.name(),
        name,
        type(message).__name__,
    )
    if meshcat is not None:
        times = np.linspace(0.0, trajectory.duration, 400)
        path = trajectory.reference(times)[:, 4:7].T
        meshcat.SetLine("task/desired_path", path, 3.0, Rgba(0.1, 0.4, 1.0, 1.0))
    return TaskReference(
        controller=name,
        topic=entry.controller_class.topic,
        trajectory=trajectory,
        arm=arm,
        source=source,
    )


def cartesian_trajectory_message(trajectory, period: float, frame: str) -> CartesianTrajectory:
    """The CartesianTrajectory message of ``trajectory`` sampled every ``period`` [s]."""
    count = int(np.ceil(trajectory.duration / period - 1e-9)) + 1
    times = np.arange(count) * period
    references = trajectory.reference(times)
    points = tuple(
        CartesianTrajectoryPoint(
            time_from_start=float(t),
            position=tuple(row[4:7].tolist()),
            orientation=tuple(row[0:4].tolist()),
            twist=tuple(row[7:13].tolist()),
            acceleration=tuple(row[13:19].tolist()),
        )
        for t, row in zip(times, references, strict=True)
    )
    return CartesianTrajectory(stamp=0.0, frame_id="world", controlled_frame=frame, points=points)


def joint_trajectory_message(plan, joint_names) -> JointTrajectory:
    """The JointTrajectory message of a planned joint reference. Its last point is at
    rest (the plan's residual velocity there is tiny; a trajectory controller
    rejects a last point that is not)."""
    last = len(plan.times) - 1
    points = tuple(
        JointTrajectoryPoint(
            positions=tuple(plan.q[k].tolist()),
            velocities=tuple(0.0 * plan.v[k] if k == last else plan.v[k]),
            accelerations=tuple(0.0 * plan.a[k] if k == last else plan.a[k]),
            time_from_start=float(t),
        )
        for k, t in enumerate(plan.times)
    )
    return JointTrajectory(stamp=0.0, joint_names=tuple(joint_names), points=points)
