"""Time laws s(t): closed forms, continuity, Drake trajectories, bad parameters."""

import numpy as np
import pytest

from armando_drake.kinematics.time_laws import (
    CubicTimeLaw,
    QuinticTimeLaw,
    TimeLawError,
    TrapezoidalTimeLaw,
)


def trapezoid_closed_form(t, T, t_c):
    """The textbook trapezoidal profile, written independently of the implementation."""
    a = 1.0 / (t_c * (T - t_c))
    if t <= t_c:
        return 0.5 * a * t**2, a * t, a
    if t <= T - t_c:
        return a * t_c * (t - t_c / 2), a * t_c, 0.0
    return 1.0 - 0.5 * a * (T - t) ** 2, a * (T - t), -a


@pytest.mark.parametrize("T, t_c", [(2.0, 0.5), (3.0, 1.5), (1.7, 0.1)])
def test_trapezoid_matches_closed_form(T, t_c):
    law = TrapezoidalTimeLaw(duration=T, acceleration_time=t_c)
    times = np.array([0.0, 0.3 * t_c, 0.99 * t_c, 0.5 * T, T - 0.5 * t_c, 0.999 * T, T])
    sample = law(times)
    for k, t in enumerate(times):
        s, s_dot, s_ddot = trapezoid_closed_form(t, T, t_c)
        assert sample.s[k] == pytest.approx(s, abs=1e-12)
        assert sample.s_dot[k] == pytest.approx(s_dot, abs=1e-12)
        if t not in (t_c, T - t_c, T):  # s'' jumps at the switching times
            assert sample.s_ddot[k] == pytest.approx(s_ddot, abs=1e-12)
    assert law.acceleration == pytest.approx(1.0 / (t_c * (T - t_c)), rel=1e-15)
    assert sample.s[-1] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("T, t_c", [(2.0, 0.5), (3.0, 1.5)])
def test_trapezoid_continuous_at_the_switching_times(T, t_c):
    law = TrapezoidalTimeLaw(duration=T, acceleration_time=t_c)
    eps = 1e-9
    for switch in (t_c, T - t_c):
        around = law(np.array([switch - eps, switch, switch + eps]))
        assert np.ptp(around.s) < 1e-8  # s and s' continuous; s'' may jump
        assert np.ptp(around.s_dot) < 1e-8
    # Cruise speed: the area under s' is 1.
    assert law(np.array([T / 2])).s_dot[0] == pytest.approx(1.0 / (T - t_c), abs=1e-12)


def test_cubic_and_quintic_match_closed_form():
    T = 2.5
    times = np.linspace(0.0, T, 11)
    tau = times / T
    cubic = CubicTimeLaw(duration=T)(times)
    np.testing.assert_allclose(cubic.s, 3 * tau**2 - 2 * tau**3, atol=1e-12)
    np.testing.assert_allclose(cubic.s_dot, (6 * tau - 6 * tau**2) / T, atol=1e-12)
    np.testing.assert_allclose(cubic.s_ddot, (6 - 12 * tau) / T**2, atol=1e-12)
    assert (
        cubic.s[0] == 0 and cubic.s_dot[0] == 0 and cubic.s_dot[-1] == pytest.approx(0, abs=1e-12)
    )
    quintic = QuinticTimeLaw(duration=T)(times)
    np.testing.assert_allclose(quintic.s, 10 * tau**3 - 15 * tau**4 + 6 * tau**5, atol=1e-12)
    np.testing.assert_allclose(
        quintic.s_dot, (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / T, atol=1e-12
    )
    np.testing.assert_allclose(
        quintic.s_ddot, (60 * tau - 180 * tau**2 + 120 * tau**3) / T**2, atol=1e-12
    )
    assert quintic.s[-1] == pytest.approx(1.0, abs=1e-12)


def test_law_holds_outside_its_interval():
    law = CubicTimeLaw(duration=1.0)
    sample = law(np.array([-1.0, 2.0]))
    np.testing.assert_array_equal(sample.s, [0.0, 1.0])
    np.testing.assert_array_equal(sample.s_dot, [0.0, 0.0])
    np.testing.assert_array_equal(sample.s_ddot, [0.0, 0.0])


@pytest.mark.parametrize(
    "law",
    [
        TrapezoidalTimeLaw(duration=2.0, acceleration_time=0.4),
        TrapezoidalTimeLaw(duration=2.0, acceleration_time=1.0),
        CubicTimeLaw(duration=1.3),
        QuinticTimeLaw(duration=0.7),
    ],
)
def test_drake_trajectory_equals_the_law(law):
    trajectory = law.as_trajectory()
    first, second = trajectory.MakeDerivative(1), trajectory.MakeDerivative(2)
    times = np.linspace(0.0, law.duration, 23)[1:-1]
    sample = law(times)
    for k, t in enumerate(times):
        assert trajectory.value(t)[0, 0] == pytest.approx(sample.s[k], abs=1e-12)
        assert first.value(t)[0, 0] == pytest.approx(sample.s_dot[k], abs=1e-12)
        assert second.value(t)[0, 0] == pytest.approx(sample.s_ddot[k], abs=1e-12)
    assert trajectory.end_time() == law.duration


@pytest.mark.parametrize(
    "make, text",
    [
        (lambda: TrapezoidalTimeLaw(duration=2.0, acceleration_time=1.2), "acceleration_time=1.2"),
        (lambda: TrapezoidalTimeLaw(duration=2.0, acceleration_time=0.0), "acceleration_time=0.0"),
        (lambda: TrapezoidalTimeLaw(duration=0.0, acceleration_time=0.1), "duration=0.0"),
        (lambda: CubicTimeLaw(duration=-1.0), "duration=-1.0"),
        (lambda: QuinticTimeLaw(duration=float("nan")), "duration=nan"),
    ],
)
def test_bad_parameters_are_one_line_errors(make, text):
    with pytest.raises(TimeLawError) as error:
        make()
    assert text in str(error.value)
    assert "\n" not in str(error.value)
