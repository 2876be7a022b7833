"""The live jog: Meshcat controls that steer the running world through a controller's
command topic, as a ROS user steers a robot.

- **Joint sliders**, one per jogged joint within its limits: a moved slider commands
  that joint's position (joint_state_publisher_gui, rqt's controller GUI).
- **Cartesian jog buttons** with keys: each click (or key repeat) moves the end
  effector by ``linear_step`` along the world's +-x, +-y, +-z, or turns it by
  ``angular_step`` about one of its own axes that the arm can follow (all three on a
  6-joint arm; on Armando's 4 joints the pitch about its z axis), through Drake's
  differential inverse kinematics (``DoDifferentialInverseKinematics``) with the joint
  limits as constraints. The rotations the arm can follow are found once from the
  plant: the end effector's axes in the span of the angular velocities it reaches with
  its position held.
- **A gamepad** (the browser's first, as Meshcat forwards it), mapped by
  :func:`~armando_drake.teleop.gamepad.read_gamepad`: dead-man, sticks to joint or
  end-effector velocities, home.
- **Home** (a button, key H, or the gamepad's): back to the home posture at
  ``joint_speed``.

Commands are clamped to the joint limits; a clamped command or a jog that stops at a
limit leaves a note in the controls (``note: ...``, for ``note_time`` seconds) and in
the log. The controls are read in a periodic update at ``rate``; a command is
published (a Float64MultiArray of positions, or a one-point JointTrajectory for a
trajectory controller) only when it changes.

Meshcat's API must be called from the thread that created the Meshcat: the simulator
runs there.
"""

from __future__ import annotations

import copy
import logging
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import EventStatus, LeafSystem

from armando_drake.control.stack import ControlStack
from armando_drake.kinematics.arm import (
    ArmModel,
    TaskSpaceError,
    last_link_frame,
    orientation_error,
)
from armando_drake.messages.types import (
    Float64MultiArray,
    JointTrajectory,
    JointTrajectoryPoint,
    Publication,
)
from armando_drake.teleop.config import JogConfig, JogError
from armando_drake.teleop.gamepad import CARTESIAN, JOINT, read_gamepad
from armando_drake.tools.errors import ScenarioError

_log = logging.getLogger("armando_drake.world")

AXES = "xyz"
# The keys of the jog buttons (KeyboardEvent.code values): translations along the
# world's axes, rotations about the end effector's own axes, home.
TRANSLATION_KEYS = {
    ("x", +1): "KeyW",
    ("x", -1): "KeyS",
    ("y", +1): "KeyA",
    ("y", -1): "KeyD",
    ("z", +1): "KeyR",
    ("z", -1): "KeyF",
}
ROTATION_KEYS = {
    ("x", +1): "KeyU",
    ("x", -1): "KeyJ",
    ("y", +1): "KeyI",
    ("y", -1): "KeyK",
    ("z", +1): "KeyO",
    ("z", -1): "KeyL",
}
HOME_KEY = "KeyH"
HOME_BUTTON = "home (H)"
NOTE_PREFIX = "note: "
# A Cartesian jog that ends farther than this from its target stops there, with a note.
LINEAR_TOLERANCE = 5e-4  # [m]
ANGULAR_TOLERANCE = 5e-3  # [rad]
LIMIT_MARGIN = 1e-4  # [rad or m] a joint this close to a limit is at it
UNLIMITED_RANGE = 2 * np.pi  # [rad] slider half-range of a joint without limits


def translation_button(axis: str, sign: int) -> str:
    """The label of the jog button along the world's ``axis``."""
    return f"jog {'+' if sign > 0 else '-'}{axis} ({TRANSLATION_KEYS[axis, sign][-1]})"


def rotation_button(axis: str, sign: int) -> str:
    """The label of the jog button about the end effector's own ``axis``."""
    return f"jog {'+' if sign > 0 else '-'}rot {axis} ({ROTATION_KEYS[axis, sign][-1]})"


class CartesianJog:
    """Differential inverse kinematics of an end effector for jogging.

    The task: the end effector's position (3 rows, world frame) and its rotation about
    each of its own axes in ``rotations`` (the ones the arm can follow, see
    :func:`followable_rotations`); the other rotations are left free. The jogged joints
    are ``joints`` (the arm's others stay where they are), limited to [lower, upper]
    and to their velocity limits.
    """

    def __init__(
        self,
        *,
        plant,
        model_instance,
        end_effector,
        joints: list[str],
        lower,
        upper,
        velocity,
        time_step: float,
        iterations: int = 4,
    ):
        from pydrake.multibody.inverse_kinematics import (
            DifferentialInverseKinematicsParameters,
        )

        self.arm = ArmModel(
            plant=plant, end_effector_frame=end_effector, model_instance=model_instance
        )
        missing = [name for name in joints if name not in self.arm.joint_names]
        if missing:
            raise JogError(f"joints {missing} are not moving joints of the robot")
        self.columns = np.array([self.arm.joint_names.index(name) for name in joints])
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        self.time_step = time_step
        self.iterations = iterations
        self.rotations = followable_rotations(self.arm, self.columns, self.lower, self.upper)
        n = len(joints)
        params = DifferentialInverseKinematicsParameters(n, n)
        params.set_time_step(time_step)
        params.set_joint_position_limits((self.lower, self.upper))
        speed = np.where(np.isfinite(velocity), np.asarray(velocity, dtype=float), 10.0)
        params.set_joint_velocity_limits((-speed, speed))
        params.set_joint_centering_gain(np.zeros((n, n)))
        self.parameters = params

    def pose(self, q_arm: np.ndarray) -> RigidTransform:
        """X_WE at the arm's joint positions ``q_arm`` (the arm's order)."""
        self.arm.set_state(q_arm)
        return self.arm.pose()

    def _task(self, X_target: RigidTransform):
        """(J, error) of the task rows at the arm's current state."""
        X = self.arm.pose()
        R = X.rotation().matrix()
        J = self.arm.jacobian()[:, self.columns]
        rows = [J[3:]]
        error = [X_target.translation() - X.translation()]
        if self.rotations:
            angular = R.T @ orientation_error(X_target.rotation(), X.rotation())
            rows.append((R.T @ J[:3])[self.rotations])
            error.append(angular[self.rotations])
        return np.vstack(rows), np.concatenate(error)

    def solve(self, q_arm: np.ndarray, X_target: RigidTransform) -> tuple[np.ndarray, bool]:
        """The arm's joint positions that bring the end effector to ``X_target`` (its
        followed parts) from ``q_arm``, within the limits; and whether it got there."""
        from pydrake.multibody.inverse_kinematics import (
            DifferentialInverseKinematicsStatus,
            DoDifferentialInverseKinematics,
        )

        q = np.array(q_arm, dtype=float)
        jogged = q[self.columns]
        for _ in range(self.iterations):
            self.arm.set_state(q)
            J, error = self._task(X_target)
            if self._reached(error):
                return q, True
            result = DoDifferentialInverseKinematics(
                jogged, np.zeros(len(jogged)), error / self.time_step, J, self.parameters
            )
            if result.status != DifferentialInverseKinematicsStatus.kSolutionFound:
                break
            jogged = np.clip(
                jogged + result.joint_velocities * self.time_step, self.lower, self.upper
            )
            q[self.columns] = jogged
        self.arm.set_state(q)
        return q, self._reached(self._task(X_target)[1])

    def blocking(self, q_arm: np.ndarray, X_target: RigidTransform) -> list[int]:
        """The jogged joints (indices into ``joints``) at a limit that the way to
        ``X_target`` (the least-squares joint velocity of the task) pushes past it, by
        more than 5 % of its largest joint speed."""
        self.arm.set_state(q_arm)
        J, error = self._task(X_target)
        velocity = np.linalg.pinv(J, rcond=1e-6) @ error
        significant = 0.05 * np.abs(velocity).max(initial=0.0)  # not numerical noise
        q = q_arm[self.columns]
        return [
            k
            for k in range(len(q))
            if (q[k] - self.lower[k] < LIMIT_MARGIN and velocity[k] < -significant)
            or (self.upper[k] - q[k] < LIMIT_MARGIN and velocity[k] > significant)
        ]

    @staticmethod
    def _reached(error: np.ndarray) -> bool:
        linear, angular = error[:3], error[3:]
        return bool(
            np.linalg.norm(linear) <= LINEAR_TOLERANCE
            and (angular.size == 0 or np.abs(angular).max() <= ANGULAR_TOLERANCE)
        )


def followable_rotations(
    arm: ArmModel, columns, lower, upper, *, samples: int = 16, seed: int = 0
) -> list[int]:
    """The end effector's own axes (0 x, 1 y, 2 z) about which the jogged joints can
    turn it with its position held: an axis is followable where it lies in the span of
    the angular velocities of the null space of the position Jacobian, at most of
    ``samples`` configurations drawn within the limits (from ``seed``; a singular one
    counts for nothing)."""
    rng = np.random.default_rng(seed)
    low = np.where(np.isfinite(lower), lower, -np.pi)
    high = np.where(np.isfinite(upper), upper, np.pi)
    counts = np.zeros(3)
    q = arm.default_positions()
    for _ in range(samples):
        q[columns] = rng.uniform(low, high)
        arm.set_state(q)
        J = arm.jacobian()[:, columns]
        R = arm.pose().rotation().matrix()
        _, s, vt = np.linalg.svd(J[3:])
        rank = int(np.sum(s > 1e-6 * max(s.max(initial=0.0), 1e-12)))
        null = vt[rank:].T
        if null.shape[1] == 0:
            continue
        u, sw, _ = np.linalg.svd(R.T @ J[:3] @ null)
        basis = u[:, : int(np.sum(sw > 1e-6))]
        counts += np.linalg.norm(basis.T, axis=0) > 0.99  # |projection of each axis|
    return [k for k in range(3) if counts[k] > samples / 2]


@dataclass
class JogState:
    """The jog's memory between two readings of the controls."""

    command: np.ndarray  # [rad or m] the commanded positions, jogged joints
    sliders: np.ndarray  # [rad or m] the slider values last read or set
    clicks: dict[str, int] = field(default_factory=dict)  # per jog button
    anchor: RigidTransform | None = None  # the Cartesian jog's target pose (None: unset)
    homing: str = ""  # "" | "button" | "gamepad": returning home, started by
    mode: str = CARTESIAN  # the gamepad's mode
    note: str = ""  # the note shown ("" = none)
    note_until: float = 0.0  # [s] when the note goes


class MeshcatJog(LeafSystem):
    """Reads the jog controls of a Meshcat page and publishes position commands.

    Input ports:
        - ``state``: the robot's model-instance state [q; v] (the arm's joints that
          are not jogged, for the Cartesian jog).

    Output ports:
        - ``commands``: a Publication of the commands (Float64MultiArray of positions
          in ``joints`` order, or a one-point JointTrajectory with ``trajectory``).
    """

    def __init__(
        self,
        *,
        meshcat,
        config: JogConfig,
        joints: list[str],
        lower,
        upper,
        home,
        cartesian: CartesianJog | None = None,
        num_instance_states: int,
        trajectory: bool = False,
        controller: str = "",
    ):
        super().__init__()
        self.controller = controller  # the jogged controller's name, for the run's summary
        self._meshcat = meshcat
        self._config = config
        self._joints = list(joints)
        self._lower = np.asarray(lower, dtype=float)
        self._upper = np.asarray(upper, dtype=float)
        self._home = np.clip(np.asarray(home, dtype=float), self._lower, self._upper)
        self._cartesian = cartesian
        self._period = 1.0 / config.rate
        self._trajectory = trajectory
        # Where the gamepad state comes from (a callable returning a Meshcat.Gamepad):
        # the page's first gamepad; a test may feed synthetic states instead.
        self.gamepad_source = meshcat.GetGamepad
        self._buttons: dict[str, tuple[str, int, str]] = {}  # name -> (kind, sign, axis)
        self._sliders: list[str] = []
        sliders = self._add_controls()
        self._state = self.DeclareAbstractState(
            AbstractValue.Make(JogState(command=self._home.copy(), sliders=sliders))
        )
        self._publication = self.DeclareAbstractState(AbstractValue.Make(Publication()))
        self.DeclareVectorInputPort("state", num_instance_states)
        self.DeclareStateOutputPort("commands", self._publication)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._Update)

    # ------------------------------------------------------------------ controls
    @property
    def joints(self) -> list[str]:
        return list(self._joints)

    @property
    def rotations(self) -> list[str]:
        """The end effector's own axes the rotation buttons turn about ("x", "y", "z")."""
        return [] if self._cartesian is None else [AXES[k] for k in self._cartesian.rotations]

    @property
    def buttons(self) -> list[str]:
        """The jog buttons' labels (translations, rotations, home)."""
        return list(self._buttons)

    @property
    def sliders(self) -> list[str]:
        return list(self._sliders)

    @property
    def sends_trajectories(self) -> bool:
        """Whether ``commands`` carries JointTrajectory messages (else Float64MultiArray)."""
        return self._trajectory

    @property
    def cartesian(self) -> CartesianJog | None:
        return self._cartesian

    def _add_controls(self) -> np.ndarray:
        meshcat, config = self._meshcat, self._config
        values = self._home.copy()
        if config.sliders:
            for k, name in enumerate(self._joints):
                low = self._lower[k] if np.isfinite(self._lower[k]) else -UNLIMITED_RANGE
                high = self._upper[k] if np.isfinite(self._upper[k]) else UNLIMITED_RANGE
                values[k] = meshcat.AddSlider(name, low, high, config.slider_step, values[k])
                self._sliders.append(name)
        if config.cartesian and self._cartesian is not None:
            for axis in AXES:
                for sign in (+1, -1):
                    name = translation_button(axis, sign)
                    meshcat.AddButton(name, TRANSLATION_KEYS[axis, sign])
                    self._buttons[name] = ("translation", sign, axis)
            for k in self._cartesian.rotations:
                for sign in (+1, -1):
                    name = rotation_button(AXES[k], sign)
                    meshcat.AddButton(name, ROTATION_KEYS[AXES[k], sign])
                    self._buttons[name] = ("rotation", sign, AXES[k])
        meshcat.AddButton(HOME_BUTTON, HOME_KEY)
        self._buttons[HOME_BUTTON] = ("home", 0, "")
        return values

    def delete_controls(self) -> None:
        """Removes the jog's sliders and buttons (and its note) from the page."""
        for name in self._sliders:
            self._meshcat.DeleteSlider(name)
        for name in list(self._buttons) + [
            n for n in self._meshcat.GetButtonNames() if n.startswith(NOTE_PREFIX)
        ]:
            if name in self._meshcat.GetButtonNames():
                self._meshcat.DeleteButton(name)

    def command(self, context) -> np.ndarray:
        """[rad or m] the positions last commanded, jogged joints' order."""
        return self._jog_state(context).command.copy()

    def note(self, context) -> str:
        """The note shown in the viewer ("" = none)."""
        return self._jog_state(context).note

    def _jog_state(self, context) -> JogState:
        return self.GetMyContextFromRoot(context).get_abstract_state(self._state).get_value()

    # ------------------------------------------------------------------ the update
    def _Update(self, context, state) -> EventStatus:
        jog = copy.deepcopy(context.get_abstract_state(self._state).get_value())
        before = jog.command.copy()
        now = context.get_time()
        notes: list[str] = []
        moved_by_slider = self._read_sliders(jog, notes)
        self._read_buttons(context, jog, notes)
        self._read_gamepad(context, jog, notes)
        if jog.homing:
            step = self._config.joint_speed * self._period
            jog.command = jog.command + np.clip(self._home - jog.command, -step, step)
            if np.allclose(jog.command, self._home, atol=1e-12):
                jog.homing = ""
        changed = not np.array_equal(jog.command, before)
        if changed and self._sliders:
            for k, name in enumerate(self._sliders):
                if not moved_by_slider[k]:
                    jog.sliders[k] = self._meshcat.SetSliderValue(name, jog.command[k])
        self._show_note(jog, notes, now)
        state.get_mutable_abstract_state(self._state).set_value(jog)
        if changed:
            publication = context.get_abstract_state(self._publication).get_value()
            state.get_mutable_abstract_state(self._publication).set_value(
                publication.publish(self._message(jog.command, before), stamp=now)
            )
        return EventStatus.Succeeded()

    def _message(self, command: np.ndarray, before: np.ndarray):
        """The command as the jogged controller reads it: a Float64MultiArray, or a
        one-point JointTrajectory reached at joint_speed (at least one jog period)."""
        if not self._trajectory:
            return Float64MultiArray(data=tuple(float(v) for v in command))
        duration = np.abs(command - before).max() / self._config.joint_speed
        point = JointTrajectoryPoint(
            positions=tuple(float(v) for v in command),
            velocities=(0.0,) * len(command),
            time_from_start=max(self._period, float(duration)),
        )
        return JointTrajectory(stamp=0.0, joint_names=tuple(self._joints), points=(point,))

    def _clamp(self, jog: JogState, wanted: np.ndarray, notes: list[str], why: str) -> None:
        """Sets the command to ``wanted`` within the limits, with a note per clamped joint."""
        clamped = np.clip(wanted, self._lower, self._upper)
        for k in np.flatnonzero(np.abs(clamped - wanted) > 1e-12):
            side = "upper" if wanted[k] > self._upper[k] else "lower"
            notes.append(f"{why}: {self._joints[k]} clamped to its {side} limit {clamped[k]:.3f}")
        jog.command = clamped

    def _read_sliders(self, jog: JogState, notes: list[str]) -> np.ndarray:
        moved = np.zeros(len(self._joints), dtype=bool)
        if not self._sliders:
            return moved
        values = np.array([self._meshcat.GetSliderValue(name) for name in self._sliders])
        moved = np.abs(values - jog.sliders) > 1e-12
        if moved.any():
            jog.sliders = values
            wanted = jog.command.copy()
            wanted[moved] = values[moved]
            self._clamp(jog, wanted, notes, "slider")
            jog.homing, jog.anchor = "", None
        return moved

    def _read_buttons(self, context, jog: JogState, notes: list[str]) -> None:
        clicks = {name: self._meshcat.GetButtonClicks(name) for name in self._buttons}
        new = {name: n - jog.clicks.get(name, 0) for name, n in clicks.items()}
        jog.clicks = clicks
        if new.get(HOME_BUTTON, 0) > 0:
            jog.homing, jog.anchor = "button", None
        linear, angular = np.zeros(3), np.zeros(3)
        for name, count in new.items():
            kind, sign, axis = self._buttons[name]
            if count <= 0 or kind == "home":
                continue
            if kind == "translation":
                linear[AXES.index(axis)] += sign * count * self._config.linear_step
            else:
                angular[AXES.index(axis)] += sign * count * self._config.angular_step
        if linear.any() or angular.any():
            jog.homing = ""
            self._move_end_effector(context, jog, linear, angular, notes, "jog")

    def _read_gamepad(self, context, jog: JogState, notes: list[str]) -> None:
        if not self._config.gamepad:
            return
        rotations = [] if self._cartesian is None else self._cartesian.rotations
        command = read_gamepad(
            self.gamepad_source(),
            self._config.gamepad_mapping,
            num_joints=len(self._joints),
            num_rotations=len(rotations),
            mode=jog.mode,
        )
        jog.mode = command.mode
        if not command.active:
            if jog.homing == "gamepad":
                jog.homing = ""  # the dead-man was released
            return
        if command.home:
            jog.homing, jog.anchor = "gamepad", None
            return
        if not command.moving:
            return
        jog.homing = ""
        if command.mode == JOINT:
            step = command.joint * self._config.joint_speed * self._period
            self._clamp(jog, jog.command + step, notes, "gamepad")
            jog.anchor = None
        elif self._cartesian is not None:
            linear = command.linear * self._config.linear_speed * self._period
            angular = np.zeros(3)
            angular[rotations] = command.angular * self._config.angular_speed * self._period
            self._move_end_effector(context, jog, linear, angular, notes, "gamepad")

    def _move_end_effector(self, context, jog, linear, angular, notes, why) -> None:
        """Moves the Cartesian target by ``linear`` [m] (world axes) and ``angular``
        [rad] (rotation vector about the end effector's own axes) and the command after
        it, as far as the limits let it."""
        cartesian = self._cartesian
        if cartesian is None:
            return
        q_arm = cartesian.arm.default_positions()
        state = self.get_input_port().Eval(context)
        q_arm = cartesian.arm.split_instance_state(state)[0] if state.size else q_arm
        q_arm[cartesian.columns] = jog.command
        X = jog.anchor if jog.anchor is not None else cartesian.pose(q_arm)
        rotation = RotationMatrix(_rotation_vector(angular))
        X_target = RigidTransform(X.rotation().multiply(rotation), X.translation() + linear)
        solution, reached = cartesian.solve(q_arm, X_target)
        jog.command = solution[cartesian.columns]
        if reached:
            jog.anchor = X_target
            return
        jog.anchor = None  # start again from where it stopped
        at_limit = [self._joints[k] for k in cartesian.blocking(solution, X_target)]
        where = (
            f"{', '.join(at_limit)} at {'its limit' if len(at_limit) == 1 else 'their limits'}"
            if at_limit
            else "out of reach or at a singular posture"
        )
        notes.append(f"{why}: end effector stopped, {where}")

    def _show_note(self, jog: JogState, notes: list[str], now: float) -> None:
        if notes:
            text = NOTE_PREFIX + "; ".join(dict.fromkeys(notes))
            if text != jog.note:
                self._delete_note(jog)
                self._meshcat.AddButton(text)
                _log.warning("jog: %s", text[len(NOTE_PREFIX) :])
                jog.note = text
            jog.note_until = now + self._config.note_time
        elif jog.note and now >= jog.note_until:
            self._delete_note(jog)

    def _delete_note(self, jog: JogState) -> None:
        if jog.note and jog.note in self._meshcat.GetButtonNames():
            self._meshcat.DeleteButton(jog.note)
        jog.note = ""


def _rotation_vector(angular: np.ndarray):
    """The AngleAxis of a rotation vector [rad]."""
    from pydrake.common.eigen_geometry import AngleAxis

    angle = float(np.linalg.norm(angular))
    if angle == 0.0:
        return AngleAxis(0.0, [0.0, 0.0, 1.0])
    return AngleAxis(angle, np.asarray(angular) / angle)


def AddJog(
    builder, config: JogConfig, stack: ControlStack, *, meshcat=None, where: str = ""
) -> MeshcatJog | None:
    """The jog of ``config`` on ``meshcat``, publishing on the command input of the
    jogged controller of ``stack`` (``config.controller`` or the first active
    controller that takes joint positions and that nothing drives yet); None without
    a Meshcat to read. Errors: :class:`ScenarioError` naming ``where``."""
    try:
        return _add_jog(builder, config, stack, meshcat, where)
    except JogError as error:
        raise ScenarioError(str(error)) from None


def _add_jog(builder, config: JogConfig, stack: ControlStack, meshcat, where: str):
    controllers = stack.config.controllers

    def driven(name: str) -> bool:  # by the sequencer or the task
        return builder.IsConnectedOrExported(stack.command_input(name))

    candidates = [
        name
        for name in stack.controllers
        if controllers[name].position_targets
        and controllers[name].controller_class.message in (Float64MultiArray, JointTrajectory)
    ]
    free = [name for name in candidates if not driven(name)]
    name = config.controller or (free[0] if free else "")
    wanted = f"jog.controller={config.controller!r}" if config.controller else "jog"
    if name in candidates and name not in free:
        raise JogError(
            f"{where}{wanted}: {name} already takes its commands from the scenario's "
            "sequencer or task; jog a controller nothing else drives (sequencer: null)"
        )
    if name not in free:
        raise JogError(
            f"{where}{wanted} needs an active controller that takes joint positions "
            f"(Float64MultiArray or JointTrajectory) and that nothing else drives; such "
            f"controllers: {', '.join(free) or 'none'}"
        )
    if meshcat is None or getattr(meshcat, "recording_only", False):
        _log.warning("jog: no Meshcat to read (--no-meshcat?): the arm holds its home posture")
        return None
    joints = stack.controller_joints[name]
    rows = stack.joints_of(joints)
    plant, instance = stack.plant, stack.robot.model_instance
    cartesian = None
    if config.cartesian:
        try:
            frame = config.end_effector or last_link_frame(plant, instance)
            cartesian = CartesianJog(
                plant=plant,
                model_instance=instance,
                end_effector=frame,
                joints=joints,
                lower=[j.lower for j in rows],
                upper=[j.upper for j in rows],
                velocity=[j.velocity for j in rows],
                time_step=1.0 / config.rate,
            )
        except (TaskSpaceError, JogError) as error:
            raise JogError(f"{where}jog: {error}") from None
    trajectory = controllers[name].controller_class.message is JointTrajectory
    jog = builder.AddSystem(
        MeshcatJog(
            meshcat=meshcat,
            config=config,
            joints=joints,
            lower=[j.lower for j in rows],
            upper=[j.upper for j in rows],
            home=[j.initial_position for j in rows],
            cartesian=cartesian,
            num_instance_states=plant.num_multibody_states(instance),
            trajectory=trajectory,
            controller=name,
        )
    )
    jog.set_name("jog")
    builder.Connect(plant.get_state_output_port(instance), jog.get_input_port())
    builder.Connect(jog.GetOutputPort("commands"), stack.command_input(name))
    parts = ["sliders"] if config.sliders else []
    if cartesian is not None:
        axes = ", ".join(jog.rotations) or "none"
        parts.append(
            f"Cartesian buttons (end effector {cartesian.arm.frame_E.name()}, rotations "
            f"about its own axes: {axes})"
        )
    parts += ["gamepad"] if config.gamepad else []
    parts.append("home")
    _log.info("jog: %s on %s (%s) at %g Hz", ", ".join(parts), name, ", ".join(joints), config.rate)
    return jog
