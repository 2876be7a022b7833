"""``pid_controller/PidController``: control_toolbox's PID per degree of freedom.

As upstream's (ros2_controllers ``jazzy``, not chained): a reference per dof
(``control_msgs/MultiDOFCommand`` on ``/<controller>/reference``: ``values`` for the first
of ``reference_and_state_interfaces``, ``values_dot`` for the second) is compared with the
joints' state interfaces of the same names (``position`` [rad], ``velocity`` [rad/s]); at
every update, for each dof whose reference and state are finite, it writes to
``command_interface``::

    command = feedforward_gain * reference (enable_feedforward; the second reference with two
              interfaces) + PID(error, error_dot, dt)

with ``error = reference - state`` (the shortest angle with ``angle_wraparound``) and
``error_dot`` the second interfaces' difference, or (one interface, or a second one not
finite) the PID's own derivative of the error. The PID is control_toolbox's
(:mod:`armando_drake.control.pid`). With ``set_current_state_as_first_setpoint`` the
reference starts at the state read at activation (the first update), else it is NaN and
nothing is written until one arrives. A reference's values are used once (upstream clears
them): a value left NaN keeps the previous reference.
"""

import dataclasses
import math
from typing import ClassVar

import numpy as np

from armando_drake.control.controllers import (
    COMMAND_INTERFACES,
    Controller,
    ControllerMemory,
    Rejected,
    register,
)
from armando_drake.control.controllers.joint_trajectory import shortest_angular_distance
from armando_drake.control.pid import (
    ANTIWINDUP_STRATEGIES,
    PidGains,
    check_gains,
    compute_command,
)
from armando_drake.messages.types import MultiDOFCommand
from armando_drake.tools.schema import Refusal, param

REFERENCE_INTERFACES = ("position", "velocity")  # the joints' state interfaces


@dataclasses.dataclass
class PidDofGains:
    """``gains.<dof>``: upstream's PID gains of one dof (pid_controller.yaml)."""

    # [command unit/state unit] proportional gain.
    p: float = 0.0
    # [command unit/(state unit s)] integral gain.
    i: float = 0.0
    # [command unit s/state unit] derivative gain.
    d: float = 0.0
    # [command unit] upper bound of the output.
    u_clamp_max: float = param(math.inf, infinite=True)
    # [command unit] lower bound of the output.
    u_clamp_min: float = param(-math.inf, infinite=True)
    # legacy strategy only: clamp the integral itself (true), or its contribution.
    antiwindup: bool = False
    # [command unit] upper bound of the integral term (>= 0).
    i_clamp_max: float = param(math.inf, infinite=True)
    # [command unit] lower bound of the integral term (<= 0).
    i_clamp_min: float = param(-math.inf, infinite=True)
    # legacy | none | back_calculation | conditional_integration (control_toolbox's).
    antiwindup_strategy: str = param("legacy", choices=ANTIWINDUP_STRATEGIES)
    # [s] back_calculation's tracking time constant; 0 = sqrt(d / i), or p / i.
    tracking_time_constant: float = 0.0
    # [state unit] no integration while |error| <= error_deadband.
    error_deadband: float = 1e-16
    # [command unit/reference unit] feed-forward gain (with enable_feedforward).
    feedforward_gain: float = 0.0
    # Wrap the error into [-pi, pi] (continuous joints).
    angle_wraparound: bool = False
    # Keep the integral term when the controller is reset (it is activated once here).
    save_i_term: bool = True
    # Publish the PID's state (not simulated: refused unless false).
    activate_state_publisher: bool = param(
        False, choices=(False,), why="not simulated: the PID state is not published"
    )

    def check(self) -> None:
        """control_toolbox's rules between the gains."""
        check_gains(self)

    def pid_gains(self) -> PidGains:
        return PidGains(
            p=self.p,
            i=self.i,
            d=self.d,
            u_max=self.u_clamp_max,
            u_min=self.u_clamp_min,
            i_max=self.i_clamp_max,
            i_min=self.i_clamp_min,
            antiwindup_strategy=self.antiwindup_strategy,
            legacy_antiwindup=self.antiwindup,
            tracking_time_constant=self.tracking_time_constant,
            error_deadband=self.error_deadband,
        )


@dataclasses.dataclass
class PidControllerParameters:
    """The parameters of ``pid_controller/PidController`` (upstream's schema)."""

    ROS_NAMES: ClassVar[dict[str, str]] = {"gains": "gains"}

    # The dofs (joints) commanded, in the order of the reference's values.
    dof_names: list[str] = param([], nonempty=True, unique=True)
    # The dofs whose state is read; empty or equal to dof_names (chaining other names is not
    # simulated).
    reference_and_state_dof_names: list[str] = dataclasses.field(default_factory=list)
    # The command interface written: position [rad], velocity [rad/s] or effort [N m].
    command_interface: str = param("", choices=COMMAND_INTERFACES)
    # The state (and reference) interfaces: [position], [velocity] or [position, velocity].
    reference_and_state_interfaces: list[str] = param(
        [],
        nonempty=True,
        unique=True,
        choices=REFERENCE_INTERFACES,
        why="the state interfaces of the simulated joints",
    )
    # Start from the state read at activation as the reference (else none until one comes).
    set_current_state_as_first_setpoint: bool = True
    # Read the state from ~/measured_state instead of the state interfaces (not simulated:
    # refused unless false).
    use_external_measured_states: bool = param(
        False,
        choices=(False,),
        why="not simulated: the state is read from the joints' state interfaces",
    )
    # Add feedforward_gain times the reference (the second one with two interfaces).
    enable_feedforward: bool = False
    # Per dof, the PID gains.
    gains: dict[str, PidDofGains] = dataclasses.field(default_factory=dict)

    def check(self) -> None:
        """The rules between fields (the fields' own are declared beside them)."""
        if self.reference_and_state_dof_names not in ([], self.dof_names):
            raise Refusal(
                "reference_and_state_dof_names",
                f"={self.reference_and_state_dof_names!r} differs from dof_names "
                f"{self.dof_names}; chained controllers are not simulated",
            )
        for dof in self.gains:
            if dof not in self.dof_names:
                raise Refusal(f"gains.{dof}", f": '{dof}' is not one of the dof_names")


@dataclasses.dataclass(frozen=True)
class _PidControllerState:
    """What the controller keeps between updates."""

    reference: np.ndarray  # the reference interfaces: values, then values_dot (k n)
    i_term: np.ndarray  # [command unit] the PIDs' integral terms (n)
    p_error_last: np.ndarray  # the PIDs' last errors, for their own derivative (n)
    command: np.ndarray  # [command unit] the last commands (n)


@register("pid_controller/PidController")
class PidController(Controller):
    """control_toolbox's PID per dof on the reference (see the module docstring)."""

    parameters = PidControllerParameters
    message = MultiDOFCommand
    topic = "reference"
    initial_state = "active"

    @classmethod
    def command_interface(cls, params) -> str:
        return params.command_interface

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return list(params.dof_names)

    @classmethod
    def position_targets(cls, params) -> bool:
        return False

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(
            dof_names=list(joints.names),
            command_interface="effort",
            reference_and_state_interfaces=["position"],
        )

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        params = self.params
        gains = [params.gains.get(dof, PidDofGains()) for dof in self.joint_names]
        self._pids = [g.pid_gains().checked() for g in gains]
        self._feedforward = np.array([g.feedforward_gain for g in gains])
        self._wrap = np.array([g.angle_wraparound for g in gains])
        self._interfaces = list(params.reference_and_state_interfaces)
        self._period = 0.0  # [s] the update period

    def configure(self, *, update_rate: int) -> None:
        self._period = 1.0 / update_rate

    def initial_memory(self) -> ControllerMemory:
        return dataclasses.replace(super().initial_memory(), running=True)

    def _State(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The state interfaces' values: the first interface's, then the second's."""
        return np.concatenate([q if name == "position" else v for name in self._interfaces])

    def _Reference(self, message, reference: np.ndarray) -> np.ndarray:
        """Upstream's reference_callback and update_reference_from_subscribers."""
        if not isinstance(message, MultiDOFCommand):
            raise Rejected(f"expected a MultiDOFCommand message, got {type(message).__name__}")
        n, names = self.n, list(self.joint_names)
        values, dots = list(message.values), list(message.values_dot)
        given = list(message.dof_names)
        if not given and len(values) == n:
            given = names
        elif len(given) != n or len(values) != n:
            raise Rejected(
                f"Size of input data names ({len(given)}) is not matching the expected size ({n})."
            )
        for name in given:
            if name not in names:
                raise Rejected(f"DoF name '{name}' not found in the defined list of state DoFs.")
        reference = reference.copy()
        for k, name in enumerate(given):
            i = names.index(name)
            if not math.isnan(values[k]):
                reference[i] = values[k]
                if len(self._interfaces) == 2 and k < len(dots) and not math.isnan(dots[k]):
                    reference[n + i] = dots[k]
        return reference

    def update(self, now, message, memory, measure):
        n, dt = self.n, self._period
        q, v = measure(memory.desired)
        state_values = self._State(q, v)
        internal, status = memory.internal, memory.status
        if internal is None:  # activation: the first setpoint, the PIDs reset
            first = self.params.set_current_state_as_first_setpoint
            reference = state_values.copy() if first else np.full(len(state_values), np.nan)
            zeros = np.zeros(n)
            internal = _PidControllerState(reference, zeros, zeros, zeros)
        reference = internal.reference
        if message is not None:
            try:
                reference = self._Reference(message, reference)
            except Rejected as rejection:
                status = self.reject(status, str(rejection))
            else:
                status = self.accept(status, "active", {})
        i_term, p_error_last = internal.i_term.copy(), internal.p_error_last.copy()
        command = internal.command.copy()
        written = np.zeros(n, dtype=bool)
        two = len(self._interfaces) == 2
        for i in range(n):
            if not (math.isfinite(reference[i]) and math.isfinite(state_values[i])):
                continue
            feedforward = 0.0
            if self.params.enable_feedforward:
                ref_ff = reference[n + i] if two else reference[i]
                if math.isfinite(ref_ff):
                    feedforward = ref_ff * self._feedforward[i]
            error = reference[i] - state_values[i]
            if self._wrap[i]:
                error = float(shortest_angular_distance(state_values[i], reference[i]))
            if two and math.isfinite(reference[n + i]) and math.isfinite(state_values[n + i]):
                error_dot = reference[n + i] - state_values[n + i]
            else:  # compute_command(error, dt): the PID's own derivative
                error_dot = (error - p_error_last[i]) / dt if dt > 0 else 0.0
                p_error_last[i] = error
            output, i_term[i] = compute_command(
                self._pids[i], error, error_dot, dt, i_term[i], command[i]
            )
            command[i] = feedforward + output
            written[i] = True
        new = _PidControllerState(reference, i_term, p_error_last, command)
        desired, effort = memory.desired.copy(), memory.effort
        if self.interface == "effort":
            effort = np.where(written, command, effort)
        elif self.interface == "velocity":
            desired[n:] = np.where(written, command, desired[n:])
        else:
            desired[:n] = np.where(written, command, desired[:n])
        return ControllerMemory(desired, status, effort=effort, internal=new, running=True)
