"""The scenario's ``jog:`` block: live jogging from the Meshcat page.

Every field has its unit and meaning beside it. Gamepad buttons and axes are
indices in the browser's *standard* gamepad layout
(https://w3c.github.io/gamepad/#remapping), which Meshcat forwards as it gets them:
buttons 0 A, 1 B, 2 X, 3 Y, 4 LB, 5 RB, 6 LT, 7 RT, 8 Back, 9 Start, 10/11 stick
presses, 12-15 D-pad up/down/left/right, 16 Home; axes 0/1 the left stick (x right,
y down), 2/3 the right stick. (No ``from __future__ import annotations`` here:
``yaml_load_typed`` needs the field types as types.)
"""

import dataclasses as dc


class JogError(ValueError):
    """A jog block that cannot be used; the message names the field and the value."""


@dc.dataclass
class GamepadMapping:
    """How a gamepad steers the arm (like a ROS joy teleop node)."""

    # Button that must be held for the gamepad to move the arm (the dead-man switch);
    # released, the arm holds its command. 4 = LB.
    deadman_button: int = 4
    # Button that sends the arm home at joint_speed, while the dead-man is held. 1 = B.
    home_button: int = 1
    # Button that switches the sticks to joint velocities. 2 = X.
    joint_mode_button: int = 2
    # Button that switches the sticks to end-effector velocities (the start mode). 3 = Y.
    cartesian_mode_button: int = 3
    # Button that, held in joint mode, moves the sticks to the next bank of joints (the
    # joints after the first len(joint_axes)). 5 = RB.
    shift_button: int = 5
    # Joint mode: the axis that drives each joint, in the jogged controller's joint
    # order (a joint beyond the list: none), and its sign (+1 or -1; -1 makes "stick up"
    # positive on the y axes).
    joint_axes: list[int] = dc.field(default_factory=lambda: [0, 1, 3, 2])
    joint_signs: list[float] = dc.field(default_factory=lambda: [-1.0, -1.0, -1.0, 1.0])
    # Cartesian mode: the axes of the world's x, y and z velocity of the end effector,
    # and their signs: left stick up = +x, left stick left = +y, right stick up = +z.
    linear_axes: list[int] = dc.field(default_factory=lambda: [1, 0, 3])
    linear_signs: list[float] = dc.field(default_factory=lambda: [-1.0, -1.0, -1.0])
    # Cartesian mode: the axes of the rotations the arm can follow (the end effector's
    # own axes, see README "Live jog"), in order, and their signs; a rotation beyond
    # this list takes the next pair of angular_buttons.
    angular_axes: list[int] = dc.field(default_factory=lambda: [2])
    angular_signs: list[float] = dc.field(default_factory=lambda: [1.0])
    # Cartesian mode: pairs [positive, negative] of buttons for the further rotations
    # (analog values: the triggers give a speed). Default: RT/LT, then D-pad right/left.
    angular_buttons: list[list[int]] = dc.field(default_factory=lambda: [[7, 6], [15, 14]])
    # Axis values of magnitude below this are zero; above, they are rescaled so the
    # speed rises from 0 at the dead zone to full at 1 [-].
    dead_zone: float = 0.15
    # A button counts as pressed above this value [-] (analog triggers give 0..1).
    press_threshold: float = 0.5


@dc.dataclass
class JogConfig:
    """Meshcat controls that steer the running world."""

    # The controller jogged: an active controller taking joint positions (a
    # JointGroupPositionController or ForwardCommandController on position, whose
    # Float64MultiArray `commands` the jog publishes, or a JointTrajectoryController,
    # sent one-point trajectories as rqt's GUI does); "" = the first such.
    controller: str = ""
    # How often the Meshcat controls are read and a command published when it changed
    # [Hz]; > 0.
    rate: float = 30.0
    # The frame the Cartesian jog moves (a frame of the robot); "" = the body of the
    # last moving joint.
    end_effector: str = ""
    # Where the arm starts and where "home" returns it [rad or m], one value per joint
    # of the robot (hardware order, as task.start_positions); empty = the joints'
    # initial positions (their <ros2_control> initial_value, else 0).
    home_positions: list[float] = dc.field(default_factory=list)
    # One slider per jogged joint, as joint_state_publisher_gui and rqt's
    # JointTrajectoryController GUI have.
    sliders: bool = True
    # The sliders' increment [rad or m].
    slider_step: float = 0.001
    # Cartesian jog buttons (with their keys) for +/- x, y, z and the rotations the arm
    # can follow.
    cartesian: bool = True
    # End-effector displacement of one click (or key repeat) of a translation button [m].
    linear_step: float = 0.005
    # End-effector rotation of one click of a rotation button [rad].
    angular_step: float = 0.05
    # Joint speed at full stick in joint mode, and of the return home [rad/s or m/s].
    joint_speed: float = 0.5
    # End-effector speed at full stick in Cartesian mode [m/s].
    linear_speed: float = 0.05
    # End-effector angular speed at full stick in Cartesian mode [rad/s].
    angular_speed: float = 0.5
    # Whether the gamepad (the first one the page sees) steers the arm.
    gamepad: bool = True
    # The gamepad's buttons and axes.
    gamepad_mapping: GamepadMapping = dc.field(default_factory=GamepadMapping)
    # How long a note (a clamped command, a jog stopped at a limit) stays in the
    # viewer's controls [s of simulated time].
    note_time: float = 5.0


def check_jog(config: JogConfig, where: str = "") -> None:
    """Raises :class:`JogError` naming the first bad field of ``config``."""
    prefix = f"{where}jog."
    positive = ("rate", "slider_step", "linear_step", "angular_step", "joint_speed")
    positive += ("linear_speed", "angular_speed", "note_time")
    for name in positive:
        value = getattr(config, name)
        if not value > 0:
            raise JogError(f"{prefix}{name}={value!r} must be positive")
    mapping = config.gamepad_mapping
    if not 0 <= mapping.dead_zone < 1:
        raise JogError(f"{prefix}gamepad_mapping.dead_zone={mapping.dead_zone!r} must be in [0, 1)")
    if not 0 < mapping.press_threshold <= 1:
        raise JogError(
            f"{prefix}gamepad_mapping.press_threshold={mapping.press_threshold!r} must be in (0, 1]"
        )
    for axes, signs in (
        ("joint_axes", "joint_signs"),
        ("linear_axes", "linear_signs"),
        ("angular_axes", "angular_signs"),
    ):
        a, s = getattr(mapping, axes), getattr(mapping, signs)
        if len(a) != len(s):
            raise JogError(
                f"{prefix}gamepad_mapping.{signs}={s!r} must have one sign per entry of "
                f"{axes}={a!r}"
            )
        if any(value not in (-1.0, 1.0) for value in s):
            raise JogError(f"{prefix}gamepad_mapping.{signs}={s!r}: each sign is +1 or -1")
        if any(index < 0 for index in a):
            raise JogError(f"{prefix}gamepad_mapping.{axes}={a!r}: axis indices are >= 0")
    if len(mapping.linear_axes) != 3:
        raise JogError(
            f"{prefix}gamepad_mapping.linear_axes={mapping.linear_axes!r} must name 3 axes "
            "(x, y, z)"
        )
    for pair in mapping.angular_buttons:
        if len(pair) != 2 or any(index < 0 for index in pair):
            raise JogError(
                f"{prefix}gamepad_mapping.angular_buttons: {pair!r} must be a pair "
                "[positive, negative] of button indices"
            )
    buttons = ("deadman_button", "home_button", "joint_mode_button", "cartesian_mode_button")
    for name in (*buttons, "shift_button"):
        if getattr(mapping, name) < 0:
            raise JogError(
                f"{prefix}gamepad_mapping.{name}={getattr(mapping, name)!r}: button indices "
                "are >= 0"
            )
