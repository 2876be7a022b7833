"""Time laws of the curvilinear abscissa s(t) in [0, 1] with s' and s''.

A time law maps time t (seconds, 0 at the start of the motion) to the normalised
path coordinate s in [0, 1]; a path (:mod:`armando_drake.kinematics.paths`) maps s to a
position. Every law here is a piecewise polynomial in t, so each one also becomes
a Drake :class:`~pydrake.trajectories.PiecewisePolynomial` (:meth:`TimeLaw.as_trajectory`)
that C++ evaluates. Before t = 0 the law holds s = 0, after t = T it holds s = 1,
with zero derivatives.

- :class:`TrapezoidalTimeLaw`: constant acceleration s'' = 1 / (t_c (T - t_c)) for
  t_c, constant velocity, constant deceleration for t_c.
- :class:`CubicTimeLaw`: s(0) = 0, s'(0) = 0, s(T) = 1, s'(T) = 0.
- :class:`QuinticTimeLaw`: as the cubic, also s''(0) = s''(T) = 0.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from pydrake.polynomial import Polynomial
from pydrake.trajectories import PiecewisePolynomial


class TimeLawError(ValueError):
    """Time-law parameters that describe no valid motion."""


@dataclass(frozen=True)
class TimeLawSample:
    """s, s' and s'' at the given times (arrays of the times' shape)."""

    s: np.ndarray  # [-] path coordinate in [0, 1]
    s_dot: np.ndarray  # [1/s] ds/dt
    s_ddot: np.ndarray  # [1/s^2] d2s/dt2


class TimeLaw:
    """A piecewise-polynomial s(t) on [0, duration].

    Subclasses set ``duration`` and return their pieces from :meth:`pieces`:
    (start time, ascending coefficients in local time t - start).
    """

    duration: float  # [s] total duration T

    def pieces(self) -> list[tuple[float, np.ndarray]]:
        raise NotImplementedError

    @functools.cached_property
    def _table(self) -> tuple[np.ndarray, list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]]:
        """The pieces' start times, and per piece (start, coefficients of s, s', s''):
        computed once (a controller evaluates the law at every tick)."""
        polyder = np.polynomial.polynomial.polyder
        pieces = self.pieces()
        starts = np.array([start for start, _ in pieces])
        return starts, [(start, c, polyder(c), polyder(polyder(c))) for start, c in pieces]

    def __call__(self, t) -> TimeLawSample:
        """s, s', s'' at time(s) ``t`` [s] (scalar or array), clamped outside [0, T]."""
        polyval = np.polynomial.polynomial.polyval
        t = np.asarray(t, dtype=float)
        s = np.zeros_like(t)
        s_dot = np.zeros_like(t)
        s_ddot = np.zeros_like(t)
        starts, table = self._table
        inside = (t >= 0.0) & (t <= self.duration)
        index = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(table) - 1)
        for i, (start, coefficients, first, second) in enumerate(table):
            mask = inside & (index == i)
            if not np.any(mask):
                continue
            tau = t[mask] - start
            s[mask] = polyval(tau, coefficients)
            s_dot[mask] = polyval(tau, first)
            s_ddot[mask] = polyval(tau, second)
        s[t > self.duration] = 1.0
        return TimeLawSample(s=s, s_dot=s_dot, s_ddot=s_ddot)

    def as_trajectory(self) -> PiecewisePolynomial:
        """The law as a scalar Drake PiecewisePolynomial s(t) on [0, T] (1 x 1 values)."""
        pieces = self.pieces()
        breaks = [start for start, _ in pieces] + [self.duration]
        polynomials = [Polynomial(list(map(float, c))) for _, c in pieces]
        return PiecewisePolynomial(polynomials, breaks)


def _check_duration(duration: float) -> float:
    if not np.isfinite(duration) or duration <= 0.0:
        raise TimeLawError(f"duration={duration!r} s must be positive and finite")
    return float(duration)


@dataclass(frozen=True)
class TrapezoidalTimeLaw(TimeLaw):
    """Trapezoidal velocity profile: accelerate for t_c, cruise, decelerate for t_c."""

    duration: float  # [s] total duration T > 0
    acceleration_time: float  # [s] t_c, 0 < t_c <= T/2 (t_c = T/2: triangular profile)

    def __post_init__(self):
        T = _check_duration(self.duration)
        t_c = self.acceleration_time
        if not np.isfinite(t_c) or t_c <= 0.0 or t_c > T / 2:
            raise TimeLawError(
                f"acceleration_time={t_c!r} s must be in (0, duration/2 = {T / 2!r}] s"
            )

    @property
    def acceleration(self) -> float:
        """[1/s^2] the constant s'' = 1 / (t_c (T - t_c)) of the ramps."""
        t_c = self.acceleration_time
        return 1.0 / (t_c * (self.duration - t_c))

    def pieces(self) -> list[tuple[float, np.ndarray]]:
        T, t_c, a = self.duration, self.acceleration_time, self.acceleration
        cruise_start = a * t_c * t_c / 2.0  # s(t_c)
        pieces = [(0.0, np.array([0.0, 0.0, a / 2.0]))]
        if T - 2.0 * t_c > 0.0:
            pieces.append((t_c, np.array([cruise_start, a * t_c])))
        decel_start = 1.0 - a * t_c * t_c / 2.0  # s(T - t_c)
        pieces.append((T - t_c, np.array([decel_start, a * t_c, -a / 2.0])))
        return pieces


@dataclass(frozen=True)
class CubicTimeLaw(TimeLaw):
    """Cubic polynomial s = 3 (t/T)^2 - 2 (t/T)^3: rest to rest, jumps in s'' at 0 and T."""

    duration: float  # [s] total duration T > 0

    def __post_init__(self):
        _check_duration(self.duration)

    def pieces(self) -> list[tuple[float, np.ndarray]]:
        T = self.duration
        return [(0.0, np.array([0.0, 0.0, 3.0 / T**2, -2.0 / T**3]))]


@dataclass(frozen=True)
class QuinticTimeLaw(TimeLaw):
    """Quintic polynomial s = 10 (t/T)^3 - 15 (t/T)^4 + 6 (t/T)^5: also s''(0) = s''(T) = 0."""

    duration: float  # [s] total duration T > 0

    def __post_init__(self):
        _check_duration(self.duration)

    def pieces(self) -> list[tuple[float, np.ndarray]]:
        T = self.duration
        return [(0.0, np.array([0.0, 0.0, 0.0, 10.0 / T**3, -15.0 / T**4, 6.0 / T**5]))]
