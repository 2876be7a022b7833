"""The gamepad mapping: one gamepad state in, one jog command out.

A pure function, so it is tested with synthetic states (``Meshcat.Gamepad`` objects
or anything with ``index``, ``button_values`` and ``axes``). The mapping follows the
ROS joy teleop nodes: nothing moves unless the dead-man button is held; the sticks
give joint velocities (joint mode) or end-effector velocities (Cartesian mode), each
axis with a dead zone; a button sends the arm home.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from armando_drake.teleop.config import GamepadMapping

JOINT, CARTESIAN = "joint", "cartesian"


@dataclass(frozen=True)
class GamepadCommand:
    """What one gamepad state asks for."""

    active: bool = False  # a gamepad is connected and its dead-man button is held
    mode: str = CARTESIAN  # JOINT or CARTESIAN, after this state's mode buttons
    home: bool = False  # the home button is pressed (with the dead-man held)
    # [-] per jogged joint, in [-1, 1]: the fraction of the joint speed (joint mode)
    joint: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # [-] x, y, z in [-1, 1]: the fraction of the linear speed (Cartesian mode)
    linear: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # [-] per followed rotation in [-1, 1]: the fraction of the angular speed
    angular: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def moving(self) -> bool:
        """Whether it asks for any motion (a non-zero speed)."""
        return bool(np.any(self.joint) or np.any(self.linear) or np.any(self.angular))


def dead_zone(value: float, zone: float) -> float:
    """``value`` in [-1, 1] with |value| < ``zone`` set to 0 and the rest rescaled to
    run from 0 at the zone's edge to +-1."""
    value = float(np.clip(value, -1.0, 1.0))
    if abs(value) < zone or zone >= 1.0:
        return 0.0
    return float(np.sign(value) * (abs(value) - zone) / (1.0 - zone))


def _axis(gamepad, index: int) -> float:
    axes = gamepad.axes
    return float(axes[index]) if 0 <= index < len(axes) else 0.0


def _button(gamepad, index: int) -> float:
    values = gamepad.button_values
    return float(values[index]) if 0 <= index < len(values) else 0.0


def read_gamepad(
    gamepad,
    mapping: GamepadMapping,
    *,
    num_joints: int,
    num_rotations: int,
    mode: str = CARTESIAN,
) -> GamepadCommand:
    """The command of one gamepad state (``gamepad.index`` None: no gamepad).

    ``num_joints``: the jogged joints; ``num_rotations``: the rotations the arm can
    follow (the angular entries); ``mode``: the mode before this state.
    """
    joint = np.zeros(num_joints)
    angular = np.zeros(num_rotations)
    if gamepad is None or gamepad.index is None:
        return GamepadCommand(mode=mode, joint=joint, angular=angular)

    def pressed(index: int) -> bool:
        return _button(gamepad, index) > mapping.press_threshold

    if pressed(mapping.joint_mode_button):
        mode = JOINT
    elif pressed(mapping.cartesian_mode_button):
        mode = CARTESIAN
    if not pressed(mapping.deadman_button):
        return GamepadCommand(mode=mode, joint=joint, angular=angular)
    if pressed(mapping.home_button):
        return GamepadCommand(active=True, mode=mode, home=True, joint=joint, angular=angular)
    zone = mapping.dead_zone
    linear = np.zeros(3)
    if mode == JOINT:
        bank = len(mapping.joint_axes)
        first = bank if pressed(mapping.shift_button) else 0
        for k, (axis, sign) in enumerate(zip(mapping.joint_axes, mapping.joint_signs, strict=True)):
            if first + k < num_joints:
                joint[first + k] = sign * dead_zone(_axis(gamepad, axis), zone)
    else:
        for k, (axis, sign) in enumerate(
            zip(mapping.linear_axes, mapping.linear_signs, strict=True)
        ):
            linear[k] = sign * dead_zone(_axis(gamepad, axis), zone)
        sticks = list(zip(mapping.angular_axes, mapping.angular_signs, strict=True))
        for k in range(num_rotations):
            if k < len(sticks):
                axis, sign = sticks[k]
                angular[k] = sign * dead_zone(_axis(gamepad, axis), zone)
            elif k - len(sticks) < len(mapping.angular_buttons):
                plus, minus = mapping.angular_buttons[k - len(sticks)]
                value = _button(gamepad, plus) - _button(gamepad, minus)
                angular[k] = dead_zone(value, zone)
    return GamepadCommand(active=True, mode=mode, joint=joint, linear=linear, angular=angular)
