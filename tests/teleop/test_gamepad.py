"""The gamepad mapping on synthetic gamepad states (Meshcat.Gamepad objects, as Meshcat
hands them to the jog), and the jog system steered by them."""

import numpy as np
import pytest
from pydrake.geometry import Meshcat

from armando_drake.teleop.config import GamepadMapping
from armando_drake.teleop.gamepad import CARTESIAN, JOINT, dead_zone, read_gamepad

MAPPING = GamepadMapping()


def pad(axes=(0.0, 0.0, 0.0, 0.0), pressed=(), values=None) -> Meshcat.Gamepad:
    """A standard-layout gamepad state: 17 buttons, ``pressed`` at 1 (or ``values``)."""
    gamepad = Meshcat.Gamepad()
    gamepad.index = 0
    buttons = [0.0] * 17
    for index in pressed:
        buttons[index] = 1.0
    for index, value in (values or {}).items():
        buttons[index] = value
    gamepad.button_values = buttons
    gamepad.axes = list(axes)
    return gamepad


def read(gamepad, *, joints=4, rotations=1, mode=CARTESIAN, mapping=MAPPING):
    return read_gamepad(gamepad, mapping, num_joints=joints, num_rotations=rotations, mode=mode)


DEADMAN = MAPPING.deadman_button


def test_no_gamepad_asks_for_nothing():
    command = read(Meshcat.Gamepad())  # index None: no gamepad connected
    assert not command.active and not command.moving and not command.home
    assert command.joint.shape == (4,) and command.angular.shape == (1,)


def test_sticks_do_nothing_without_the_deadman():
    command = read(pad(axes=(1.0, -1.0, 1.0, -1.0), pressed=[MAPPING.home_button]))
    assert not command.active and not command.moving and not command.home


def test_cartesian_mode_sticks_give_end_effector_velocities():
    # Left stick up and half left, right stick fully down, right stick x at 0.6.
    command = read(pad(axes=(-0.5, -1.0, 0.6, 1.0), pressed=[DEADMAN]))
    assert command.active and command.mode == CARTESIAN
    half = (0.5 - MAPPING.dead_zone) / (1 - MAPPING.dead_zone)
    np.testing.assert_allclose(command.linear, [1.0, half, -1.0])
    np.testing.assert_allclose(command.angular, [(0.6 - MAPPING.dead_zone) / 0.85])
    assert not command.joint.any()


def test_dead_zone_zeroes_small_deflections_and_rescales_the_rest():
    assert dead_zone(0.1, 0.15) == 0.0 and dead_zone(-0.149, 0.15) == 0.0
    assert dead_zone(0.15, 0.15) == 0.0
    assert dead_zone(1.0, 0.15) == 1.0 and dead_zone(-1.0, 0.15) == -1.0
    assert dead_zone(0.575, 0.15) == pytest.approx(0.5)
    assert dead_zone(3.0, 0.15) == 1.0  # out-of-range values are clipped first
    command = read(pad(axes=(0.1, -0.1, 0.14, 0.05), pressed=[DEADMAN]))
    assert command.active and not command.moving


def test_mode_buttons_switch_and_the_mode_stays():
    joint = read(pad(pressed=[MAPPING.joint_mode_button]))
    assert joint.mode == JOINT and not joint.active  # switching needs no dead-man
    assert read(pad(pressed=[DEADMAN]), mode=JOINT).mode == JOINT  # released: stays
    assert read(pad(pressed=[MAPPING.cartesian_mode_button]), mode=JOINT).mode == CARTESIAN


def test_joint_mode_axes_drive_the_joints_with_their_signs():
    command = read(pad(axes=(1.0, -1.0, 0.0, 0.575), pressed=[DEADMAN]), mode=JOINT)
    # joint_axes [0, 1, 3, 2], signs [-1, -1, -1, 1]
    np.testing.assert_allclose(command.joint, [-1.0, 1.0, -0.5, 0.0])
    assert not command.linear.any() and not command.angular.any()


def test_shift_moves_the_sticks_to_the_next_bank_of_joints():
    axes = (0.0, -1.0, 0.0, 0.0)  # left stick up: joint 1 of the bank
    plain = read(pad(axes=axes, pressed=[DEADMAN]), joints=7, mode=JOINT)
    shifted = read(pad(axes=axes, pressed=[DEADMAN, MAPPING.shift_button]), joints=7, mode=JOINT)
    np.testing.assert_allclose(plain.joint, [0, 1, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(shifted.joint, [0, 0, 0, 0, 0, 1, 0])


def test_further_rotations_take_the_trigger_and_dpad_pairs():
    # RX 1 -> rotation 0; RT 0.8, LT 0.3 -> rotation 1 = 0.5 (after the dead zone);
    # D-pad left -> rotation 2 = -1.
    command = read(
        pad(axes=(0.0, 0.0, 1.0, 0.0), pressed=[DEADMAN, 14], values={7: 0.8, 6: 0.3}),
        rotations=3,
    )
    np.testing.assert_allclose(command.angular, [1.0, (0.5 - 0.15) / 0.85, -1.0])


def test_home_needs_the_deadman_and_asks_for_no_motion():
    home = read(pad(axes=(1.0, 1.0, 1.0, 1.0), pressed=[DEADMAN, MAPPING.home_button]))
    assert home.active and home.home and not home.moving


def test_a_short_gamepad_is_read_as_zeros_where_it_has_nothing():
    gamepad = Meshcat.Gamepad()
    gamepad.index = 1
    gamepad.button_values = [0.0, 0.0, 0.0, 0.0, 1.0]  # up to the dead-man (4) only
    gamepad.axes = [0.0, -1.0]  # no right stick
    command = read(gamepad)
    np.testing.assert_allclose(command.linear, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(command.angular, [0.0])
