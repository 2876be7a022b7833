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

from armando_drake.tools.schema import ConfigError, Refusal, param


class JogError(ConfigError):
    """A jog block that cannot be used; the message names the field and the value."""


@dc.dataclass
class GamepadMapping:
    """How a gamepad steers the arm (like a ROS joy teleop node)."""

    # Button that must be held for the gamepad to move the arm (the dead-man switch);
    # released, the arm holds its command. 4 = LB.
    deadman_button: int = param(4, unit="-", ge=0)
    # Button that sends the arm home at joint_speed, while the dead-man is held. 1 = B.
    home_button: int = param(1, unit="-", ge=0)
    # Button that switches the sticks to joint velocities. 2 = X.
    joint_mode_button: int = param(2, unit="-", ge=0)
    # Button that switches the sticks to end-effector velocities (the start mode). 3 = Y.
    cartesian_mode_button: int = param(3, unit="-", ge=0)
    # Button that, held in joint mode, moves the sticks to the next bank of joints (the
    # joints after the first len(joint_axes)). 5 = RB.
    shift_button: int = param(5, unit="-", ge=0)
    # Joint mode: the axis that drives each joint, in the jogged controller's joint
    # order (a joint beyond the list: none), and its sign (+1 or -1; -1 makes "stick up"
    # positive on the y axes).
    joint_axes: list[int] = param([0, 1, 3, 2], unit="-", ge=0)
    joint_signs: list[float] = param([-1.0, -1.0, -1.0, 1.0], unit="-", choices=(-1.0, 1.0))
    # Cartesian mode: the axes of the world's x, y and z velocity of the end effector,
    # and their signs: left stick up = +x, left stick left = +y, right stick up = +z.
    linear_axes: list[int] = param([1, 0, 3], unit="-", ge=0, length=3)
    linear_signs: list[float] = param([-1.0, -1.0, -1.0], unit="-", choices=(-1.0, 1.0))
    # Cartesian mode: the axes of the rotations the arm can follow (the end effector's
    # own axes, see the docs' "Live jog"), in order, and their signs; a rotation beyond
    # this list takes the next pair of angular_buttons.
    angular_axes: list[int] = param([2], unit="-", ge=0)
    angular_signs: list[float] = param([1.0], unit="-", choices=(-1.0, 1.0))
    # Cartesian mode: pairs [positive, negative] of buttons for the further rotations
    # (analog values: the triggers give a speed). Default: RT/LT, then D-pad right/left.
    angular_buttons: list[list[int]] = param([[7, 6], [15, 14]], unit="-", ge=0)
    # Axis values of magnitude below this are zero; above, they are rescaled so the
    # speed rises from 0 at the dead zone to full at 1 [-].
    dead_zone: float = param(0.15, unit="-", ge=0, lt=1)
    # A button counts as pressed above this value [-] (analog triggers give 0..1).
    press_threshold: float = param(0.5, unit="-", gt=0, le=1)

    def check(self) -> None:
        """One sign per axis; each further rotation a pair of buttons."""
        for axes, signs in (
            ("joint_axes", "joint_signs"),
            ("linear_axes", "linear_signs"),
            ("angular_axes", "angular_signs"),
        ):
            a, s = getattr(self, axes), getattr(self, signs)
            if len(a) != len(s):
                raise Refusal(signs, f"={s!r} must have one sign per entry of {axes}={a!r}")
        for pair in self.angular_buttons:
            if len(pair) != 2:
                raise Refusal(
                    "angular_buttons", f": {pair!r} must be a pair [positive, negative] of buttons"
                )


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
    rate: float = param(30.0, unit="Hz", gt=0)
    # The frame the Cartesian jog moves (a frame of the robot); "" = the body of the
    # last moving joint.
    end_effector: str = ""
    # Where the arm starts and where "home" returns it [rad or m], one value per joint
    # of the robot (hardware order, as task.start_positions); empty = the joints'
    # initial positions (their <ros2_control> initial_value, else 0).
    home_positions: list[float] = param([], unit="rad or m")
    # One slider per jogged joint, as joint_state_publisher_gui and rqt's
    # JointTrajectoryController GUI have.
    sliders: bool = True
    # The sliders' increment [rad or m].
    slider_step: float = param(0.001, unit="rad or m", gt=0)
    # Cartesian jog buttons (with their keys) for +/- x, y, z and the rotations the arm
    # can follow.
    cartesian: bool = True
    # End-effector displacement of one click (or key repeat) of a translation button [m].
    linear_step: float = param(0.005, unit="m", gt=0)
    # End-effector rotation of one click of a rotation button [rad].
    angular_step: float = param(0.05, unit="rad", gt=0)
    # Joint speed at full stick in joint mode, and of the return home [rad/s or m/s].
    joint_speed: float = param(0.5, unit="rad/s or m/s", gt=0)
    # End-effector speed at full stick in Cartesian mode [m/s].
    linear_speed: float = param(0.05, unit="m/s", gt=0)
    # End-effector angular speed at full stick in Cartesian mode [rad/s].
    angular_speed: float = param(0.5, unit="rad/s", gt=0)
    # Whether the gamepad (the first one the page sees) steers the arm.
    gamepad: bool = True
    # The gamepad's buttons and axes.
    gamepad_mapping: GamepadMapping = dc.field(default_factory=GamepadMapping)
    # How long a note (a clamped command, a jog stopped at a limit) stays in the
    # viewer's controls [s of simulated time].
    note_time: float = param(5.0, unit="s", gt=0)
    # In a world of several robots (robots:), the name of the one it acts on; "" = the
    # first listed.
    robot: str = ""


@dc.dataclass
class TwistJogConfig:
    """Keys of the Meshcat page that drive a mobile base, as ROS's teleop_twist_keyboard:
    u i o / j k l / m , . move (i forward, "," backward, j / l turn left / right, k
    stop, u o m . the diagonals), q / z scale both speeds by +-10 %, w / x the linear
    speed only, e / c the angular speed only."""

    # The drive it publishes cmd_vel to: an active diff_drive_controller or drive
    # plugin; "" = the first active one.
    controller: str = ""
    # The linear speed of i and "," at the start [m/s] (teleop_twist_keyboard's
    # `speed`).
    speed: float = param(0.5, unit="m/s", gt=0)
    # The angular speed of j and l at the start [rad/s] (teleop_twist_keyboard's
    # `turn`).
    turn: float = param(1.0, unit="rad/s", gt=0)
    # How often the current twist is published [Hz]: above 1 / the drive's
    # cmd_vel_timeout, so a held command is not braked.
    rate: float = param(10.0, unit="Hz", gt=0)
    # [s of simulated time] without a key for this long the twist goes to zero (as
    # ROS 1's teleop_twist_keyboard's `key_timeout`; a held key repeats); 0 = the last
    # command holds until k or another key (as ROS 2's).
    key_timeout: float = param(0.0, unit="s", ge=0)
    # header.frame_id of the TwistStamped messages.
    frame_id: str = ""
    # The browser's first gamepad, as ROS's teleop_twist_joy maps a joystick: while
    # the enable button is held, the left stick's forward axis gives the linear speed
    # and its sideways axis the turn (left turns left); releasing it stops the base.
    gamepad: bool = True
    # The enable (dead-man) button's index in the Gamepad API's standard mapping
    # (0 = A / cross), teleop_twist_joy's `enable_button`.
    gamepad_enable_button: int = param(0, unit="-", ge=0)
    # [m/s] at full forward stick (teleop_twist_joy's `scale_linear.x`).
    gamepad_scale_linear: float = param(0.5, unit="m/s", gt=0)
    # [rad/s] at full sideways stick (teleop_twist_joy's `scale_angular.yaw`).
    gamepad_scale_angular: float = param(0.5, unit="rad/s", gt=0)
    # In a world of several robots (robots:), the name of the one it acts on; "" = the
    # first listed.
    robot: str = ""
