"""The mobile base's log: ground truth against wheel odometry, and what was commanded.

:func:`AddBaseLogger` samples, at each odometry message of the drive, the floating base's true
pose and twist (the plant's state: what Gazebo's ground-truth pose plugin would give),
the drive's odometry (``nav_msgs/Odometry``, odom -> base, integrated from the wheels)
and the commanded twist. The odometry's frame is where the base was at the start (its
spawn pose, projected on the ground), so the ground truth is also given in that frame
and the two compare directly: where the wheels slip, the odometry drifts.

With an output folder the samples are streamed to ``base.csv``: a row at each sample,
written to the file at least every :data:`FLUSH_WALL` seconds of wall time (whatever
the real-time rate), so a process killed outright loses at most the last of them, and
the rest at the end of the run (Ctrl-C and SIGTERM keep every row);
:meth:`BaseLogger.summary`
is ``summary.json``'s ``base`` section: distance travelled, final pose (world and
odometry), odometry drift (final and largest position error [m], final heading error
[rad]) and the contacts with obstacles (see :class:`ObstacleContacts`).
:func:`write_base_plots` draws ``base_path.png`` (x-y path, ground truth and
odometry) and ``base_velocity.png`` (commanded, measured and odometry twist).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from time import monotonic
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import ContactResults
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import EventStatus, LeafSystem

from armando_drake.control.manager import planar_base
from armando_drake.messages.types import Odometry
from armando_drake.tools.cli import stop_signals_held
from armando_drake.tools.errors import UserInputError
from armando_drake.tools.files import OutputFile

BASE_CSV = "base.csv"
FLUSH_WALL = 0.5  # [s] of wall time: the longest base.csv's rows wait to reach the file
COLUMNS = (
    "time",
    "x", "y", "z", "yaw",  # ground truth in the world [m, rad]
    "odom_frame_x", "odom_frame_y", "odom_frame_yaw",  # ground truth in the odometry frame
    "odom_x", "odom_y", "odom_yaw",  # the odometry (odometry frame)
    "linear", "angular",  # ground truth forward speed [m/s] and yaw rate [rad/s]
    "odom_linear", "odom_angular",  # the odometry's twist
    "cmd_linear", "cmd_angular",  # the commanded twist (NaN without a twist sequence)
    "axle_drift",  # [m] the odometry's error at the wheel axle's midpoint (see BaseLogger)
)  # fmt: skip


# A contact whose normal is within this of vertical (|n_z| above it) holds the robot up
# (the floor, a ramp): not an obstacle.
SUPPORT_NORMAL_Z = 0.7


class ObstacleContacts:
    """The robot's contacts with obstacles, from the plant's contact results.

    An obstacle contact is one between a body of the robot and a body of another model
    whose normal is more horizontal than :data:`SUPPORT_NORMAL_Z` (the floor under the
    wheels is not one). An episode is an obstacle body starting to be touched (sampled
    at the logger's rate): driving into a crate and resting against it is one episode.
    """

    def __init__(self, plant, robot_instance):
        self._plant, self._robot = plant, robot_instance
        self._geometry_body = {
            geometry: body
            for index in range(plant.num_bodies())
            for body in [plant.get_body(BodyIndex(index))]
            for geometry in plant.GetCollisionGeometriesForBody(body)
        }
        self.episodes = 0
        self.bodies: list[str] = []  # scoped names (model::body), in the order first touched
        self.time_in_contact = 0.0  # [s]
        self.first_time: float | None = None  # [s] of the first contact
        self._touching: set[str] = set()

    def _name(self, body) -> str | None:
        """The scoped name of an obstacle body (None for one of the robot's)."""
        if body.model_instance() == self._robot:
            return None
        return f"{self._plant.GetModelInstanceName(body.model_instance())}::{body.name()}"

    def _pairs(self, results: ContactResults):
        """(body, body, unit normal or force direction) of every contact."""
        plant = self._plant
        for k in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(k)
            yield (
                plant.get_body(info.bodyA_index()),
                plant.get_body(info.bodyB_index()),
                (info.point_pair().nhat_BA_W),
            )
        for k in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(k)
            surface = info.contact_surface()
            body_m = self._geometry_body.get(surface.id_M())
            body_n = self._geometry_body.get(surface.id_N())
            if body_m is not None and body_n is not None:
                yield body_m, body_n, info.F_Ac_W().translational()

    def sample(self, results: ContactResults, time: float, period: float) -> None:
        touching = set()
        for body_a, body_b, direction in self._pairs(results):
            names = (self._name(body_a), self._name(body_b))
            if (names[0] is None) == (names[1] is None):
                continue  # the robot's own, or between two other bodies
            norm = float(np.linalg.norm(direction))
            if norm > 0 and abs(direction[2]) / norm > SUPPORT_NORMAL_Z:
                continue  # what holds it up
            touching.add(names[0] or names[1])
        for name in sorted(touching - self._touching):
            self.episodes += 1
            if name not in self.bodies:
                self.bodies.append(name)
        if touching:
            self.time_in_contact += period
            self.first_time = time if self.first_time is None else self.first_time
        self._touching = touching

    def summary(self) -> dict[str, Any]:
        return {
            "episodes": self.episodes,
            "bodies": list(self.bodies),
            "time_in_contact": self.time_in_contact,
            "first_contact_time": self.first_time,
        }


def wrap(angle: float) -> float:
    """``angle`` [rad] in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


class BaseLogger(LeafSystem):
    """Samples the floating base, its odometry and its command.

    .. pydrake_system::

        name: BaseLogger
        input_ports:
        - state
        - odom
        - command

    - ``state``: the robot's model-instance state [q; v]; ``base_rows`` are its floating
      base's 7 position and 6 velocity rows;
    - ``odom``: the drive's Odometry;
    - ``command``: (linear [m/s], angular [rad/s]) commanded (optional);
    - ``contact_results``: the plant's ContactResults (optional): with ``contacts``, its
      contacts with obstacles are counted (:class:`ObstacleContacts`).

    A drive's odometry integrates the motion of the midpoint of its wheel axle; where the
    base frame is not there (fra2mo's base_footprint is 4 cm behind its wheels) the
    odometry of the base frame is off by the offset turned with the robot, slip or not.
    ``axle`` [m] is that midpoint in the base frame; ``axle_drift`` the odometry's error
    at it: the drift the wheels' slip makes.

    ``csv_path``: the ``base.csv`` the rows are streamed to (see the module's docstring);
    :meth:`close` writes the last ones and closes it.
    """

    def __init__(
        self,
        *,
        state_size: int,
        base_rows,
        rate: float,
        drive: str = "",
        axle=(0.0, 0.0),
        contacts: ObstacleContacts | None = None,
        csv_path: Path | None = None,
    ):
        super().__init__()
        self.drive = drive
        self.contacts = contacts
        self._period = 1.0 / rate
        self.axle = (float(axle[0]), float(axle[1]))
        self._q_rows, self._v_rows = (np.asarray(rows, dtype=int) for rows in base_rows)
        self._state = self.DeclareVectorInputPort("state", state_size)
        self._odom = self.DeclareAbstractInputPort("odom", AbstractValue.Make(Odometry()))
        self._command = self.DeclareVectorInputPort("command", 2)
        self._contact_results = self.DeclareAbstractInputPort(
            "contact_results", AbstractValue.Make(ContactResults())
        )
        self.rows: list[tuple[float, ...]] = []
        self._recent: list[tuple[float, tuple]] = []  # (time, ground truth) of the last ticks
        self._origin: tuple[float, float, float] | None = None
        self._file: OutputFile | None = None
        self._rows_written = 0  # of self.rows, in the file
        self._flushed_at = monotonic()  # [s] wall time of the last write
        if csv_path is not None:
            self._file = OutputFile(csv_path, "w", newline="")
            self._file.write(",".join(COLUMNS) + "\r\n")  # as csv.writer ends a line
            self._file.flush()
        self.DeclarePeriodicPublishEvent(1.0 / rate, 0.0, self._Sample)

    def _Sample(self, context) -> EventStatus:
        """Keeps the ground truth and command of this tick; adds a row for the odometry
        published since: the controller manager computed it at an earlier tick (its update
        runs as that tick's step begins, this sample as it ends), so the row pairs it with
        the ground truth kept at its stamp."""
        time = context.get_time()
        x = self._state.Eval(context)
        q, v = x[self._q_rows], x[self._v_rows]
        px, py, yaw, linear, angular = planar_base(q, v)
        if self._origin is None:
            self._origin = (px, py, yaw)
        x0, y0, yaw0 = self._origin
        c, s = math.cos(yaw0), math.sin(yaw0)
        dx, dy = px - x0, py - y0
        command = (
            self._command.Eval(context) if self._command.HasValue(context) else (math.nan,) * 2
        )
        truth = (px, py, float(q[6]), yaw, c * dx + s * dy, -s * dx + c * dy, wrap(yaw - yaw0),
                 linear, angular, float(command[0]), float(command[1]))  # fmt: skip
        self._recent = [*self._recent[-7:], (time, truth)]
        if self.contacts is not None and self._contact_results.HasValue(context):
            self.contacts.sample(self._contact_results.Eval(context), time, self._period)
        odom = self._odom.Eval(context) if self._odom.HasValue(context) else Odometry()
        if self.rows and odom.stamp <= self.rows[-1][0] + 1e-9:
            return EventStatus.DidNothing()
        stamp, truth = min(self._recent, key=lambda kept: abs(kept[0] - odom.stamp))
        px, py, pz, yaw, fx, fy, fyaw, linear, angular, cmd_linear, cmd_angular = truth
        ax, ay = self.axle
        true_axle = (fx + ax * math.cos(fyaw) - ay * math.sin(fyaw),
                     fy + ax * math.sin(fyaw) + ay * math.cos(fyaw))  # fmt: skip
        odom_axle = (odom.position[0] + ax, odom.position[1] + ay)
        self.rows.append(
            (
                stamp,
                px, py, pz, yaw,
                fx, fy, fyaw,
                odom.position[0], odom.position[1], odom.yaw,
                linear, angular,
                odom.linear[0], odom.angular[2],
                cmd_linear, cmd_angular,
                math.hypot(odom_axle[0] - true_axle[0], odom_axle[1] - true_axle[1]),
            )
        )  # fmt: skip
        if self._file is not None and monotonic() - self._flushed_at >= FLUSH_WALL:
            self._flush()
        return EventStatus.Succeeded()

    def array(self) -> np.ndarray:
        """The samples so far, one row each, :data:`COLUMNS`."""
        return np.array(self.rows, dtype=float).reshape(-1, len(COLUMNS))

    def _flush(self) -> None:
        """Writes the rows not yet in the file, whole lines, and pushes them to the system
        (a stop signal waits: a row is never written twice nor cut)."""
        with stop_signals_held():
            rows = self.rows[self._rows_written :]
            if rows:
                self._file.write(
                    "".join(",".join(f"{value:.9g}" for value in row) + "\r\n" for row in rows)
                )
                self._file.flush()
                self._rows_written += len(rows)
            self._flushed_at = monotonic()

    def close(self) -> None:
        """Writes the rows not yet in ``base.csv`` and closes it. Safe to call twice."""
        if self._file is not None:
            self._flush()
            self._file.close()
            self._file = None

    def summary(self) -> dict[str, Any] | None:
        """``summary.json``'s ``base`` section (None before any sample)."""
        summary = base_summary(self.array(), self.drive)
        if summary is not None and self.contacts is not None:
            summary["contacts"] = self.contacts.summary()
        return summary


def base_summary(rows: np.ndarray, drive: str = "") -> dict[str, Any] | None:
    """Distance travelled, final poses and the odometry's drift of :data:`COLUMNS` rows."""
    if not len(rows):
        return None
    col = {name: rows[:, k] for k, name in enumerate(COLUMNS)}
    steps = np.hypot(np.diff(col["x"]), np.diff(col["y"]))
    drift = np.hypot(col["odom_x"] - col["odom_frame_x"], col["odom_y"] - col["odom_frame_y"])
    heading = [wrap(a - b) for a, b in zip(col["odom_yaw"], col["odom_frame_yaw"], strict=True)]
    last = rows[-1]
    final = dict(zip(COLUMNS, last.tolist(), strict=True))
    return {
        "drive": drive,
        "distance_travelled": float(steps.sum()),
        "final_pose": {"x": final["x"], "y": final["y"], "z": final["z"], "yaw": final["yaw"]},
        "final_pose_odom_frame": {
            "x": final["odom_frame_x"],
            "y": final["odom_frame_y"],
            "yaw": final["odom_frame_yaw"],
        },
        "final_odometry": {"x": final["odom_x"], "y": final["odom_y"], "yaw": final["odom_yaw"]},
        "odometry_drift": {
            "final_position": float(drift[-1]),
            "max_position": float(drift.max()),
            "final_heading": float(abs(heading[-1])),
            "per_metre": float(drift[-1] / steps.sum()) if steps.sum() > 0.01 else None,
            # At the midpoint of the wheel axle, the point the odometry integrates: what
            # the wheels' slip made (the base frame's adds the axle's offset, turned).
            "final_position_at_axle": float(col["axle_drift"][-1]),
            "max_position_at_axle": float(col["axle_drift"].max()),
        },
    }


def AddBaseLogger(builder, stack, base, *, command=None, csv_path=None) -> BaseLogger | None:
    """The :class:`BaseLogger` of a floating base with an active drive (``base``: the
    world's :class:`~armando_drake.control.mobile.MobileBase`), a row per odometry message
    of that drive; ``command``: the twist sequencer's (linear, angular) output;
    ``csv_path``: the ``base.csv`` it streams to (close the logger at the end). None for
    a welded robot or one without an active drive."""
    if base is None or not base.floating:
        return None
    drives = [name for name in base.drives if name in stack.controllers]
    hardware = stack.hardware
    if not drives or not hardware.base_position_index:
        return None
    drive = drives[0]
    logic = next(c.logic for c in stack.manager.controllers if c.name == drive)
    rate = float(stack.update_rate)  # every tick: see BaseLogger._Sample
    axle = _axle_offset(stack.plant, stack.robot, base.base_link, logic.joint_names)
    logger = builder.AddSystem(
        BaseLogger(
            state_size=hardware.num_model_states,
            base_rows=(hardware.base_position_index, hardware.base_velocity_index),
            rate=rate,
            drive=drive,
            axle=axle,
            contacts=ObstacleContacts(stack.plant, stack.robot.model_instance),
            csv_path=csv_path,
        )
    )
    logger.set_name("base_logger")
    plant, instance = stack.plant, stack.robot.model_instance
    builder.Connect(plant.get_state_output_port(instance), logger.GetInputPort("state"))
    builder.Connect(plant.get_contact_results_output_port(), logger.GetInputPort("contact_results"))
    builder.Connect(stack.manager.GetOutputPort(f"{drive}.odom"), logger.GetInputPort("odom"))
    if command is not None:
        builder.Connect(command, logger.GetInputPort("command"))
    builder.ExportOutput(stack.manager.GetOutputPort(f"{drive}.odom"), stack.port_name("odom"))
    return logger


def _axle_offset(plant, robot, base_link: str, wheels) -> tuple[float, float]:
    """(x, y) [m] of the midpoint of the wheel joints' origins in the base frame."""
    context = plant.CreateDefaultContext()
    base = plant.GetFrameByName(base_link, robot.model_instance)
    points = [
        plant.CalcRelativeTransform(
            context, base, plant.GetJointByName(name, robot.model_instance).frame_on_child()
        ).translation()
        for name in wheels
    ]
    middle = np.mean(points, axis=0)
    return float(middle[0]), float(middle[1])


def read_base_csv(path: Path) -> np.ndarray:
    """The rows of a ``base.csv`` (:data:`COLUMNS`); :class:`UserInputError` naming the
    file and line of a row that is not :data:`COLUMNS` numbers (a garbled or cut file; a
    last line cut short, as a run killed while writing leaves it, is left out)."""
    rows = []
    with open(path, newline="") as stream:
        lines = list(enumerate(csv.reader(stream), start=1))
    for number, fields in lines[1:]:
        if not fields:
            continue
        last = number == lines[-1][0]
        if len(fields) != len(COLUMNS):
            if last:  # cut by a kill mid-write
                break
            raise UserInputError(
                f"{path}: line {number}: {len(fields)} values, expected {len(COLUMNS)}"
            )
        try:
            rows.append([float(v) for v in fields])
        except ValueError as error:
            raise UserInputError(f"{path}: line {number}: {error}") from None
    return np.array(rows, dtype=float).reshape(-1, len(COLUMNS))


def write_base_plots(folder: Path, title: str, dpi: int, size) -> list[Path]:
    """``base_path.png`` and ``base_velocity.png`` of the ``base.csv`` in ``folder``."""
    path = folder / BASE_CSV
    if not path.is_file():
        return []
    rows = read_base_csv(path)
    if not len(rows):
        return []
    from matplotlib.figure import Figure

    col = {name: rows[:, k] for k, name in enumerate(COLUMNS)}
    written = []
    fig = Figure(figsize=size, dpi=dpi)
    axis = fig.subplots()
    fig.suptitle(f"Base path in the odometry frame [m]: {title}")
    axis.plot(col["odom_frame_x"], col["odom_frame_y"], label="ground truth")
    axis.plot(col["odom_x"], col["odom_y"], "--", label="wheel odometry")
    axis.plot(col["odom_frame_x"][:1], col["odom_frame_y"][:1], "ko", label="start")
    axis.set_xlabel("x [m]")
    axis.set_ylabel("y [m]")
    axis.set_aspect("equal", adjustable="datalim")
    axis.grid(True, alpha=0.3)
    axis.legend(loc="best", fontsize="small")
    fig.savefig(folder / "base_path.png", dpi=dpi)
    written.append(folder / "base_path.png")

    fig = Figure(figsize=size, dpi=dpi)
    top, bottom = fig.subplots(2, 1, sharex=True)
    fig.suptitle(f"Base velocity, commanded and measured: {title}")
    for axis, key, unit in ((top, "linear", "m/s"), (bottom, "angular", "rad/s")):
        axis.plot(col["time"], col[f"cmd_{key}"], label="commanded", drawstyle="steps-post")
        axis.plot(col["time"], col[key], label="ground truth")
        axis.plot(col["time"], col[f"odom_{key}"], "--", label="odometry")
        axis.set_ylabel(f"{key} [{unit}]")
        axis.grid(True, alpha=0.3)
    bottom.set_xlabel("time [s]")
    top.legend(loc="best", fontsize="small")
    fig.savefig(folder / "base_velocity.png", dpi=dpi)
    written.append(folder / "base_velocity.png")
    return written
