"""Task-space tracking of a run: the end effector's logged pose against the desired one.

In a run with a ``task:`` section, :class:`TaskSpaceTracker` listens to the joint-state
logger (the rows of ``joint_states.csv``, one per controller tick, in memory at each
flush, so once a simulated second and never per step), computes the end effector's
pose at each row by forward kinematics on the world's plant (its own context,
:class:`~armando_drake.kinematics.arm.ArmModel`) and compares it with the desired pose of
the task's Cartesian trajectory at the same time (held at the goal after the end):
:func:`task_space_errors`. :func:`write_task_space_csv` keeps the result as
``task_space.csv`` (time, desired and actual position, both error norms), which
:mod:`armando_drake.outputs.plots` draws as ``task_error.png`` and
``task_path.png``.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armando_drake.kinematics.arm import rotation_matrix_from_quaternion, rotation_vector_error

TASK_SPACE_CSV = "task_space.csv"
_COLUMNS = (
    "time",
    "desired_x", "desired_y", "desired_z",
    "actual_x", "actual_y", "actual_z",
    "position_error", "orientation_error",
)  # fmt: skip


@dataclass
class TaskSpaceErrors:
    """The end effector's tracking over a run, one row per logged sample."""

    times: np.ndarray  # [s] (N,)
    desired: np.ndarray  # [m] (N, 3) desired position of E in the world
    actual: np.ndarray  # [m] (N, 3) measured position of E in the world
    position_error: np.ndarray  # [m] (N,) |p_desired - p|
    orientation_error: np.ndarray  # [rad] (N,) angle of R_desired R^T

    def summary(self) -> dict[str, float]:
        """``summary.json``'s ``task_space``: max and RMS position error [m], max
        orientation error [rad] over the whole run."""
        if not len(self.times):
            return {"max_position_error": None, "rms_position_error": None,
                    "max_orientation_error": None}  # fmt: skip
        return {
            "max_position_error": float(self.position_error.max()),
            "rms_position_error": float(np.sqrt(np.mean(self.position_error**2))),
            "max_orientation_error": float(self.orientation_error.max()),
        }


class TaskSpaceTracker:
    """Collects :func:`task_space_errors` of the rows a joint-state logger flushes."""

    def __init__(self, task, joint_names):
        self._task = task
        self._joint_names = list(joint_names)
        self._parts: list[TaskSpaceErrors] = []

    def add(self, times: np.ndarray, positions: np.ndarray) -> None:
        """A logger listener: rows of ``times`` [s] and ``positions`` [rad]."""
        if len(times):
            self._parts.append(task_space_errors(self._task, times, positions, self._joint_names))

    def errors(self) -> TaskSpaceErrors:
        """Every row so far."""
        if not self._parts:
            empty = np.zeros(0)
            return TaskSpaceErrors(empty, np.zeros((0, 3)), np.zeros((0, 3)), empty, empty)
        return TaskSpaceErrors(
            *(np.concatenate([getattr(part, name) for part in self._parts])
              for name in ("times", "desired", "actual", "position_error",
                           "orientation_error"))
        )  # fmt: skip


def task_space_errors(
    task, times: np.ndarray, positions: np.ndarray, joint_names
) -> TaskSpaceErrors:
    """The tracking of ``task`` (a :class:`~armando_drake.simulation.builder.TaskReference`)
    from logged ``positions`` [rad] (N, len(joint_names)) at ``times`` [s]."""
    arm = task.arm
    columns = [list(joint_names).index(name) for name in arm.joint_names]
    q_all = np.asarray(positions, dtype=float)[:, columns]
    references = task.trajectory.reference(np.minimum(times, task.trajectory.duration))
    actual = np.zeros((len(times), 3))
    rotation = np.zeros(len(times))
    for k in range(len(times)):
        arm.set_state(q_all[k])
        X = arm.pose()
        actual[k] = X.translation()
        R_desired = rotation_matrix_from_quaternion(references[k, :4])
        rotation[k] = np.linalg.norm(rotation_vector_error(R_desired, X.rotation().matrix()))
    desired = references[:, 4:7]
    return TaskSpaceErrors(
        times=np.asarray(times, dtype=float),
        desired=desired,
        actual=actual,
        position_error=np.linalg.norm(desired - actual, axis=1),
        orientation_error=rotation,
    )


def write_task_space_csv(errors: TaskSpaceErrors, path: str | Path) -> Path:
    """Writes ``errors`` as CSV (the columns of :data:`_COLUMNS`); returns the path."""
    path = Path(path)
    table = np.column_stack(
        [errors.times, errors.desired, errors.actual, errors.position_error,
         errors.orientation_error]
    )  # fmt: skip
    with open(path, "w", newline="", encoding="utf-8") as file:
        writer = csv.writer(file)
        writer.writerow(_COLUMNS)
        writer.writerows([f"{value:.10g}" for value in row] for row in table)
    return path
