"""Nav2's velocity smoother, case for case.

The cases are ported from navigation2's nav2_velocity_smoother/test/test_velocity_smoother.cpp
(their names kept, Nav2's numbers); the timer tests run :func:`smooth` at the default 20 Hz
for the 1.5 s they spin.
"""

import logging

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from armando_drake.messages.types import Odometry, Publication, Twist, TwistStamped
from armando_drake.navigation.bringup import not_run, warn_not_run
from armando_drake.navigation.nav2_params import read_nav2
from armando_drake.navigation.velocity_smoother import (
    SmootherState,
    VelocitySmoother,
    VelocitySmootherParameters,
    apply_constraints,
    find_eta_constraint,
    odom_twist,
    receive,
    smooth,
    velocity_smoother_parameters,
)
from armando_drake.tools.errors import ConfigError
from tests.navigation.test_nav_configs import FIXTURES

F = 20.0  # Nav2's default smoothing_frequency


def command(vx, stamp=0.0):
    return TwistStamped(stamp=stamp, twist=Twist(linear=(vx, 0.0, 0.0)))


def run_timer(params, vx=1.0, duration=1.5, closed_loop=False):
    """Upstream's timer tests: one command at 0, the timer spun for ``duration``; the
    linear velocities published (with CLOSED_LOOP, odometry echoing the last output)."""
    state = receive(SmootherState(), command(vx), 0.0)
    sent = []
    for k in range(int(round(duration * params.smoothing_frequency)) + 1):
        now = k / params.smoothing_frequency
        if closed_loop:
            odom = Odometry(stamp=now, linear=(sent[-1] if sent else 0.0, 0.0, 0.0))
            state = odom_twist(state, odom, params.odom_duration)
        state, message = smooth(params, state, now)
        if message is not None:
            sent.append(message.twist.linear[0])
    return sent


def check_timer_run(sent, deadband=0.0):
    assert 19 < len(sent) < 30
    assert sent[-1] == 0.0  # the command stream timed out: stopped
    first = next(v for v in sent if v != 0.0)
    assert first > deadband
    assert all(v <= 0.5 for v in sent)


def test_openLoopTestTimer6dof():
    p = VelocitySmootherParameters(
        scale_velocities=True,
        deadband_velocity=[0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
        min_velocity=[-0.5, -0.5, -0.5, -2.5, -2.5, -2.5],
        max_velocity=[0.5, 0.5, 0.5, 2.5, 2.5, 2.5],
        max_decel=[-2.5, -2.5, -2.5, -3.2, -3.2, -3.2],
        max_accel=[2.5, 2.5, 2.5, 3.2, 3.2, 3.2],
    )
    p.check("test")
    check_timer_run(run_timer(p), deadband=0.2)


def test_openLoopTestTimer():
    p = VelocitySmootherParameters(scale_velocities=True, deadband_velocity=[0.2, 0.0, 0.0])
    sent = run_timer(p)
    check_timer_run(sent, deadband=0.2)


def test_a_step_command_ramps_at_max_accel_and_back_to_zero_after_the_timeout():
    """The smoother's output for a step 0 -> 1.0 m/s (Nav2's defaults: max 0.5 m/s,
    2.5 m/s^2 at 20 Hz): 0.125 m/s more each cycle to 0.5, then, the command 1 s old,
    0.125 m/s less each cycle to 0, then nothing."""
    sent = run_timer(VelocitySmootherParameters())
    assert sent[:5] == pytest.approx([0.125, 0.25, 0.375, 0.5, 0.5])
    assert sent[-5:] == pytest.approx([0.5, 0.375, 0.25, 0.125, 0.0])
    assert len(sent) == 25  # t = 0 .. 1.2 s; stopped from 1.25 s


def test_approxClosedLoopTestTimer():
    sent = run_timer(VelocitySmootherParameters(feedback="CLOSED_LOOP"), closed_loop=True)
    assert 19 < len(sent) < 30
    assert sent[-1] == 0.0
    assert all(b - a < 0.126 for a, b in zip(sent[:-1], sent[1:], strict=True))  # 2.5 m/s^2 / 20 Hz
    assert all(v <= 0.5 for v in sent)


def test_testfindEtaConstraint():
    accel, decel = 0.1, -1.0  # dv 0.005, 0.05 per cycle

    def eta(v, c):
        return find_eta_constraint(v, c, accel, decel, F)

    in_range = [(1.0, 1.0), (-1.0, -1.0), (0.5, 0.504), (0.5, 0.46), (0.0, 0.004), (0.04, 0.0),
                (-0.5, -0.504), (-0.5, -0.46), (0.0, -0.004), (-0.04, 0.0), (-0.02, 0.02),
                (0.02, -0.02)]  # fmt: skip
    for v, c in in_range:
        assert eta(v, c) == -1, (v, c)
    faster = [((0.5, 1.5), 0.005), ((1.5, 0.5), 0.05), ((0.0, 1.0), 0.005), ((1.0, 0.0), 0.05),
              ((-0.5, -1.5), 0.005), ((-1.5, -0.5), 0.05), ((0.0, -1.0), 0.005),
              ((-1.0, 0.0), 0.05), ((-0.2, 0.8), 0.05), ((0.2, -0.8), 0.05)]  # fmt: skip
    for (v, c), expected in faster:
        assert eta(v, c) == pytest.approx(expected), (v, c)


def test_testapplyConstraints():
    def apply(v, c, a, d, eta):
        return apply_constraints(v, c, a, d, eta, F)

    assert apply(1.0, 1.0, 1.5, -2.0, 1.0) == 1.0
    assert apply(0.5, 0.55, 1.5, -2.0, 1.0) == 0.55
    assert apply(0.5, 0.45, 1.5, -2.0, 1.0) == 0.45
    assert apply(1.0, 2.0, 1.5, -2.0, 1.0) == pytest.approx(1.075, abs=0.01)
    assert apply(1.0, 2.0, 1.5, -2.0, 0.075) == pytest.approx(1.075, abs=0.01)
    assert apply(0.5, 0.55, 1.5, -2.0, 0.075) == pytest.approx(0.503, abs=0.01)
    assert apply(0.8, 1.0, 3.2, -3.2, 0.75) == pytest.approx(1.075, abs=0.95)


ACCEL, DECEL = 0.1, -1.0
DV_ACCEL, DV_DECEL = ACCEL / F, -DECEL / F


def ramp(init, target, expected, steps):
    v = init
    for i in range(1, steps + 1):
        v = apply_constraints(v, target, ACCEL, DECEL, 1.0, F)
        assert v == pytest.approx(expected(i), abs=0.001), i
    assert v == pytest.approx(target, abs=0.001)
    v = apply_constraints(v, target, ACCEL, DECEL, 1.0, F)
    assert v == pytest.approx(target, abs=0.001)


@pytest.mark.parametrize(
    ("init", "target"),
    [(1.0, 2.0), (0.0, 2.0), (-1.0, -2.0), (0.0, -2.0)],
    ids=["PositiveToPositiveAccel", "ZeroToPositiveAccel", "NegativeToNegativeAccel",
         "ZeroToNegativeAccel"],
)  # fmt: skip
def test_testapplyConstraints_accel(init, target):
    sign = 1.0 if target > init else -1.0
    steps = round(abs(target - init) / DV_ACCEL)
    ramp(init, target, lambda i: init + sign * i * DV_ACCEL, steps)


@pytest.mark.parametrize(
    ("init", "target"),
    [(2.0, 1.0), (2.0, 0.0), (-2.0, -1.0), (-2.0, 0.0)],
    ids=["PositiveToPositiveDecel", "PositiveToZeroDecel", "NegativeToNegativeDecel",
         "NegativeToZeroDecel"],
)  # fmt: skip
def test_testapplyConstraints_decel(init, target):
    sign = 1.0 if target > init else -1.0
    steps = round(abs(target - init) / DV_DECEL)
    ramp(init, target, lambda i: init + sign * i * DV_DECEL, steps)


def test_testapplyConstraintsNegativeToPositiveDecelAccel():
    below, above = round(1.0 / DV_DECEL), round(2.0 / DV_ACCEL)
    ramp(-1.0, 2.0,
         lambda i: (i - below) * DV_ACCEL if i > below else -1.0 + i * DV_DECEL,
         below + above)  # fmt: skip


def test_testapplyConstraintsPositiveToNegativeDecelAccel():
    above, below = round(1.0 / DV_DECEL), round(2.0 / DV_ACCEL)
    ramp(1.0, -2.0,
         lambda i: -(i - above) * DV_ACCEL if i > above else 1.0 - i * DV_DECEL,
         below + above)  # fmt: skip


def test_testCommandCallback():
    state = receive(SmootherState(), command(100.0), 0.3)
    assert state.command[0] == 100.0  # kept as received; clamped when smoothed
    assert state.command_time == 0.3  # a zero stamp: its arrival
    nan = receive(state, command(float("nan")), 0.4)
    assert nan is state  # NaN or inf: ignored


def smoother_file(tmp_path, body: str):
    path = tmp_path / "nav2.yaml"
    path.write_text("velocity_smoother:\n  ros__parameters:\n" + body)
    return path


def test_testClosedLoopSub(tmp_path):
    path = smoother_file(tmp_path, "    feedback: CLOSED_LOOP\n")
    assert velocity_smoother_parameters(path).feedback == "CLOSED_LOOP"


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("    max_velocity: [0.0, 0.0]\n", "must be of size 3"),  # testInvalidParams
        ("    feedback: LAWLS\n", "is not one of"),
        ("    max_velocity: [-10.0, -10.0, -10.0]\n    min_velocity: [10.0, 10.0, 10.0]\n",
         "positive minimum velocity"),  # testInvalidParamsAccelDecel
        ("    max_accel: [-10.0, -10.0, -10.0]\n", "negative acceleration"),
        ("    max_decel: [10.0, 10.0, 10.0]\n", "positive deceleration"),
        ("    max_velocity: [0.5, 0.5, 0.5, 2.5, 2.5, 2.5]\n"  # testDifferentParamsSize
         "    min_velocity: [0.0, 0.0, 0.5, 2.5]\n"
         "    max_accel: [2.5, 2.5, 2.5, 5.0, 5.0, 5.0]\n"
         "    min_decel: [-2.5, -2.5, -2.5, -5.0, -5.0, -5.0]\n"
         "    deadband_velocity: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]\n", "must be of size 3"),
        ("    max_velocity: [0.5, 0.5, 0.5, 2.5]\n    min_velocity: [0, 5, 0.5]\n",
         "must be of size 3"),  # testInvalidParamsSize
        ("    smoothing_frequency: 0.0\n", "smoothing_frequency=0.0"),  # testDynamicParameter
        ("    smoothing_frequency: -1.0\n", "smoothing_frequency=-1.0"),
        ("    odom_duration: -1.0\n", "odom_duration=-1.0"),
    ],
)  # fmt: skip
def test_invalid_parameters_are_refused_naming_the_key(tmp_path, body, message):
    path = smoother_file(tmp_path, body)
    with pytest.raises(ConfigError, match=message) as error:
        velocity_smoother_parameters(path)
    assert str(path) in str(error.value)


def test_testDynamicParameter_values_are_read(tmp_path):
    """testDynamicParameter's set of values (set at configure time here)."""
    path = smoother_file(
        tmp_path,
        "    smoothing_frequency: 100.0\n    feedback: CLOSED_LOOP\n    scale_velocities: true\n"
        "    max_velocity: [10.0, 10.0, 10.0]\n    min_velocity: [0.0, 0.0, 0.0]\n"
        "    max_accel: [10.0, 10.0, 10.0]\n    max_decel: [0.0, 0.0, 0.0]\n"
        "    odom_duration: 2.0\n    velocity_timeout: 4.0\n"
        "    deadband_velocity: [0.0, 0.0, 0.0]\n",
    )
    p = velocity_smoother_parameters(path)
    assert (p.smoothing_frequency, p.feedback, p.scale_velocities) == (100.0, "CLOSED_LOOP", True)
    assert (p.max_velocity, p.min_velocity, p.max_accel, p.max_decel) == (
        [10.0] * 3, [0.0] * 3, [10.0] * 3, [0.0] * 3)  # fmt: skip
    assert (p.odom_duration, p.velocity_timeout) == (2.0, 4.0)


def test_the_smoother_as_a_drake_system_sends_the_step_ramp():
    """The system at 20 Hz on a command published once: the same ramp, then stopped."""
    builder = DiagramBuilder()
    p = VelocitySmootherParameters()
    smoother = builder.AddSystem(VelocitySmoother(p))
    published_once = AbstractValue.Make(Publication().publish(command(1.0), 0.0))
    source = builder.AddSystem(ConstantValueSource(published_once))
    builder.Connect(source.get_output_port(), smoother.GetInputPort("cmd_vel"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = smoother.GetMyContextFromRoot(simulator.get_mutable_context())
    port = smoother.GetOutputPort("cmd_vel_smoothed")
    seen = []
    for k in range(8):
        simulator.AdvanceTo(k * 0.05 + 1e-6)
        seen.append(port.Eval(context).message.twist.linear[0])
    assert seen[:5] == pytest.approx([0.125, 0.25, 0.375, 0.5, 0.5])
    simulator.AdvanceTo(1.5)
    published = port.Eval(context)
    assert published.message.twist.linear[0] == 0.0
    assert published.count == 25


def test_the_course_file_and_the_nav2_default_file_name_what_does_not_run(caplog):
    nav2 = read_nav2(FIXTURES / "nav2_params.yaml")
    names = not_run(nav2, localization="amcl", map_given=True)
    for name in ("bt_navigator", "waypoint_follower", "smoother_server", "collision_monitor"):
        assert name in names
    assert any("DriveOnHeading" in n for n in names)
    assert any("AssistedTeleop" in n for n in names)
    assert not {"velocity_smoother", "controller_server", "planner_server", "amcl"} & set(names)
    with caplog.at_level(logging.WARNING, logger="armando_drake.navigation"):
        warn_not_run(nav2, localization="amcl", map_given=True)
    lines = [r.getMessage() for r in caplog.records if "not run here" in r.getMessage()]
    assert len(lines) == 1 and "bt_navigator" in lines[0] and "AssistedTeleop" in lines[0]
    p = velocity_smoother_parameters(nav2)
    assert (p.max_velocity, p.max_accel, p.feedback) == ([0.5, 0.0, 2.0], [3.0, 0.0, 3.5],
                                                         "OPEN_LOOP")  # fmt: skip
    assert np.isclose(p.smoothing_frequency, 20.0)
