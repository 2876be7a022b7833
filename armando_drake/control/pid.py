"""control_toolbox's PID, as ros2_controllers' Jazzy uses it (control_toolbox 4.x, ``jazzy``).

``compute_command`` is ``Pid::compute_command(error, error_dot, dt)`` for one or several
PIDs at once (numpy arrays, one entry per joint), written without the PID's hidden state:
the integral term and the last command go in and come out. :class:`Pid` keeps that state
for one PID, with upstream's methods (``compute_command(error, dt)`` differentiates the
error itself). What it computes, per anti-windup strategy (``i_term`` the integral term,
``u`` the output before its clamp ``[u_min, u_max]``):

- ``legacy`` (Jazzy's default): ``i_term += i dt e`` first (clamped into ``[i_min, i_max]``
  with ``legacy_antiwindup``), then ``u = p e + clamp(i_term, i_min, i_max) + d de``;
- ``none``: ``u = p e + i_term + d de``, then ``i_term += i dt e``;
- ``back_calculation``: as none, the integral also pulled by ``(u_sat - u) / T_t``
  (``tracking_time_constant``; 0 = ``sqrt(d / i)``, or ``p / i`` without ``d``);
- ``conditional_integration``: as none, but no integration while the output is
  saturated and the error pushes it further.

Every strategy leaves ``i_term`` clamped into ``[i_min, i_max]``; no integration while
``|e| <= error_deadband``. A non-finite error gives NaN; ``dt == 0`` repeats the last command.
"""

import dataclasses
import math

import numpy as np

from armando_drake.tools.schema import Refusal

ANTIWINDUP_STRATEGIES = ("back_calculation", "conditional_integration", "legacy", "none")

# control_toolbox's default error_deadband: std::numeric_limits<double>::epsilon().
DOUBLE_EPSILON = float(np.finfo(float).eps)


@dataclasses.dataclass(frozen=True)
class PidGains:
    """``Pid::Gains`` with its ``AntiWindupStrategy``: scalars, or arrays (one PID each)."""

    p: float = 0.0  # [command unit/error unit] proportional gain
    i: float = 0.0  # [command unit/(error unit s)] integral gain
    d: float = 0.0  # [command unit s/error unit] derivative gain
    u_max: float = math.inf  # [command unit] upper output clamp
    u_min: float = -math.inf  # [command unit] lower output clamp
    i_max: float = math.inf  # [command unit] upper integral clamp (>= 0)
    i_min: float = -math.inf  # [command unit] lower integral clamp (<= 0)
    antiwindup_strategy: str = "legacy"  # one of ANTIWINDUP_STRATEGIES
    # legacy only: clamp the integral itself (true) or only its contribution (false).
    legacy_antiwindup: bool = False
    # [s] back_calculation's tracking time constant; 0 = upstream's default from the gains.
    tracking_time_constant: float = 0.0
    # [error unit] no integration while |error| <= error_deadband.
    error_deadband: float = DOUBLE_EPSILON

    def validate(self) -> None:
        """``Gains::validate``: ValueError with upstream's message."""
        u_min, u_max = np.asarray(self.u_min, float), np.asarray(self.u_max, float)
        if np.any(u_min >= u_max):
            raise ValueError(f"Gains: u_min ({self.u_min}) must be less than u_max ({self.u_max})")
        if np.any(np.isnan(u_min)) or np.any(np.isnan(u_max)):
            raise ValueError("Gains: u_min and u_max must not be NaN")
        if self.antiwindup_strategy not in ANTIWINDUP_STRATEGIES:
            raise ValueError(
                f"AntiWindupStrategy: Unknown antiwindup strategy : '{self.antiwindup_strategy}'"
                ". Valid strategies are: 'back_calculation', 'conditional_integration', "
                "'legacy', 'none'."
            )
        tracking = np.asarray(self.tracking_time_constant, float)
        if self.antiwindup_strategy == "back_calculation" and np.any(
            (tracking < 0.0) | ~np.isfinite(tracking)
        ):
            raise ValueError(
                "AntiWindupStrategy 'back_calculation' requires a valid positive tracking time "
                "constant (tracking_time_constant)"
            )
        if np.any(np.asarray(self.i_min, float) > 0):
            raise ValueError(
                f"PID requires i_min to be smaller or equal to 0 (i_min: {self.i_min})"
            )
        if np.any(np.asarray(self.i_max, float) < 0):
            raise ValueError(
                f"PID requires i_max to be greater or equal to 0 (i_max: {self.i_max})"
            )

    def checked(self) -> "PidGains":
        """``Pid::set_gains``: validated, back_calculation's zero tracking time constant
        replaced by upstream's default (``sqrt(d / i)``, or ``p / i`` when d is zero)."""
        self.validate()
        if self.antiwindup_strategy != "back_calculation":
            return self
        p, i, d = (np.asarray(x, float) for x in (self.p, self.i, self.d))
        tracking = np.asarray(self.tracking_time_constant, float)
        unset = _is_zero(tracking) & ~_is_zero(i)
        with np.errstate(divide="ignore", invalid="ignore"):
            default = np.where(_is_zero(d), p / i, np.sqrt(d / i))
        tracking = np.where(unset, default, tracking)
        return dataclasses.replace(
            self, tracking_time_constant=tracking if tracking.ndim else float(tracking)
        )


def check_gains(gains) -> None:
    """Raises :class:`~armando_drake.tools.schema.Refusal` for the gains of one joint (a
    parameters dataclass with ``pid_gains()``, its fields' own rules already checked)
    that control_toolbox refuses (``i_clamp_max`` below 0, ...): a rule between fields,
    called from the dataclass's ``check(self)``."""
    try:
        gains.pid_gains().validate()
    except ValueError as problem:
        raise Refusal("", f": {problem}") from None


def _is_zero(value, tolerance=DOUBLE_EPSILON):
    return np.abs(value) <= tolerance


def compute_command(gains: PidGains, error, error_dot, dt: float, i_term, command=0.0):
    """``Pid::compute_command(error, error_dot, dt)``: ``(command, i_term)`` after one step
    of ``dt`` [s] from the integral term ``i_term`` (``command`` is the last one, returned
    again when ``dt`` is 0). Arrays broadcast: one PID per entry."""
    if dt == 0.0:
        return command, i_term
    if dt < 0.0:
        raise ValueError("Pid is called with negative dt")
    error = np.asarray(error, float)
    error_dot = np.asarray(error_dot, float)
    i_term = previous = np.asarray(i_term, float)
    finite = np.isfinite(error) & np.isfinite(error_dot)
    p, i, d = gains.p, gains.i, gains.d
    strategy = gains.antiwindup_strategy
    integrate = ~_is_zero(error, gains.error_deadband)
    step = np.where(integrate, i * dt * error, 0.0)
    if strategy == "legacy":
        i_term = i_term + step
        if gains.legacy_antiwindup:
            i_term = np.clip(i_term, gains.i_min, gains.i_max)
            unsaturated = p * error + i_term + d * error_dot
        else:
            unsaturated = p * error + np.clip(i_term, gains.i_min, gains.i_max) + d * error_dot
    else:
        unsaturated = p * error + i_term + d * error_dot
    output = unsaturated
    if np.any(np.isfinite(gains.u_min)) or np.any(np.isfinite(gains.u_max)):
        output = np.clip(unsaturated, gains.u_min, gains.u_max)
    if strategy == "back_calculation":
        correction = (output - unsaturated) / np.where(
            gains.tracking_time_constant == 0, np.inf, gains.tracking_time_constant
        )
        pulled = i_term + dt * (i * error + correction)
        i_term = np.where(integrate & ~_is_zero(i), pulled, i_term)
    elif strategy == "conditional_integration":
        saturated = ~_is_zero(unsaturated - output) & (error * unsaturated > 0)
        i_term = np.where(integrate & ~saturated, i_term + dt * i * error, i_term)
    elif strategy == "none":
        i_term = i_term + step
    i_term = np.where(finite, np.clip(i_term, gains.i_min, gains.i_max), previous)
    output = np.where(finite, output, np.nan)
    if output.ndim == 0:
        return float(output), float(i_term)
    return output, i_term


class Pid:
    """One control_toolbox ``Pid`` with its state (for a controller that keeps one)."""

    def __init__(self, gains: PidGains):
        self.gains = gains.checked()
        self.reset()

    def reset(self, save_i_term: bool = False) -> None:
        """``Pid::reset(save_i_term)``: errors and command to zero, the integral term too
        unless ``save_i_term``."""
        self.p_error_last = 0.0
        self.p_error = 0.0
        self.d_error = 0.0
        self.command = 0.0
        if not save_i_term:
            self.i_term = 0.0

    def compute_command(self, error: float, *args: float) -> float:
        """``compute_command(error, dt)`` (the derivative from the last error) or
        ``compute_command(error, error_dot, dt)``."""
        if len(args) == 1:
            (dt,) = args
            if dt == 0.0:
                return self.command
            if dt < 0.0:
                raise ValueError("Pid is called with negative dt")
            if not math.isfinite(error):
                self.command = math.nan
                return self.command
            error_dot = (error - self.p_error_last) / dt
            self.p_error_last = error
        else:
            error_dot, dt = args
        if dt == 0.0:
            return self.command
        self.p_error, self.d_error = error, error_dot
        self.command, self.i_term = compute_command(
            self.gains, error, error_dot, dt, self.i_term, self.command
        )
        return self.command

    def get_current_pid_errors(self) -> tuple[float, float, float]:
        """``(p_error, i_term, d_error)``, as upstream's ``get_current_pid_errors``."""
        return self.p_error, self.i_term, self.d_error
