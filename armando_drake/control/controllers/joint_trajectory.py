"""``joint_trajectory_controller/JointTrajectoryController``.

Reads ``trajectory_msgs/JointTrajectory`` on ``/<controller>/joint_trajectory``
and drives its joints along it, as upstream's
controller (ros2_controllers' ``jazzy`` branch, commit ed360c97) does at every update
``t`` of period ``dt``:

- A message is validated as upstream does, in upstream's order, and then more
  strictly: a joint named twice, a negative ``time_from_start`` and NaN/Inf
  anywhere are rejected too. An accepted trajectory replaces the running one.
  Joints a partial goal leaves out get the last commanded position at every
  point (zero velocity and acceleration where the points give them), the
  message's joint order is mapped onto the controller's.
- The first update that sees it takes "the state before the trajectory": the
  measured positions (and velocities with a ``velocity`` state interface);
  with ``interpolate_from_desired_state`` (or ``open_loop_control``) the last
  command instead. Where that state lacks velocities or accelerations that the
  first point has, they are zero, so the first segment has the trajectory's
  degree (``set_point_before_trajectory_msg``).
- Each segment is linear (positions only at either end), cubic (velocities at
  both ends) or quintic (accelerations too); ``interpolation_method: none``
  commands the *next* point's values from one point to the next (the state
  before the trajectory until the first point). After the last point it
  commands the last point, its velocities included (zero where not given).
- The command written at ``t`` is the trajectory sampled at ``t + dt``, the
  end of the control period (with a velocity-only or effort command interface,
  ``ff_velocity_scale v_d(t + dt)``, plus with the effort interface the points'
  ``effort`` sampled at ``t + dt`` (linear between points, zero where a point gives
  none; the state before the trajectory has the last effort command), plus a PID per
  joint on the error at ``t``; points with efforts are rejected with any other command
  interface); the tolerances compare the measured state with the sample at ``t``.
  The goal is checked once ``t + dt`` is past the last point: every joint
  within its ``goal`` tolerance (and, with a velocity or effort command
  interface, within ``stopped_velocity_tolerance`` of the desired velocity) ->
  ``succeeded``, the last point held; still outside ``goal_time`` after the
  end -> ``aborted`` ("goal tolerance violated"). While running (and on the
  first sample), a joint further than its ``trajectory`` tolerance from the
  desired position aborts with "path tolerance violated". An abort (and
  ``cmd_timeout``) keeps the update's command and holds the measured position
  from the next update on (with ``decelerate_on_cancel``: ramps each joint from its
  measured velocity to a stop at its ``max_deceleration_on_cancel``).
- Activation holds the position command interface's values (PR #2356), or with
  velocity or effort alone the measured position. ``[position, effort]`` commands the
  positions and feeds the desired effort (sampled at ``t``) forward, without a PID.
- ``speed_scaling.initial_scaling_factor`` (position commands alone): the trajectory's
  time advances by ``factor * dt`` per update; ``t`` above is that time.
"""

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from armando_drake.control.controllers import (
    Controller,
    ControllerMemory,
    ParameterError,
    Rejected,
    register,
)
from armando_drake.control.controllers._trajectory import (  # the trajectory's API, here too
    Point,
    SampledTrajectory,
    TrajectorySample,  # noqa: F401
    interpolate_between_points,  # noqa: F401
    last_command_point,
    message_points,
    shortest_angular_distance,  # noqa: F401
    stop_trajectory,
    wraparound_joint,  # noqa: F401
)
from armando_drake.control.controllers._trajectory_checks import Tolerances, validate_trajectory
from armando_drake.control.pid import ANTIWINDUP_STRATEGIES, PidGains, check_gains, compute_command
from armando_drake.messages.types import (
    JointTrajectory,
    SpeedScalingFactor,
)
from armando_drake.tools.schema import Refusal, param

COMMAND_INTERFACES = ("position", "velocity", "acceleration", "effort")
STATE_INTERFACES = ("position", "velocity", "acceleration")
INTERPOLATION_METHODS = ("splines", "none")


@dataclasses.dataclass
class JointGains:
    """Upstream's PID gains of one joint (``gains.<joint>``), as Jazzy's schema has them,
    for control_toolbox's PID (:mod:`armando_drake.control.pid`). Used only with a
    velocity-only or an effort command interface."""

    # [command unit/rad] proportional gain.
    p: float = 0.0
    # [command unit/(rad s)] integral gain.
    i: float = 0.0
    # [command unit s/rad] derivative gain.
    d: float = 0.0
    # [command unit] symmetric bound of the integral term (deprecated upstream); used
    # where i_clamp_max / i_clamp_min are infinite.
    i_clamp: float = param(math.inf, infinite=True)
    # [command unit] upper bound of the integral term (>= 0).
    i_clamp_max: float = param(math.inf, infinite=True)
    # [command unit] lower bound of the integral term (<= 0).
    i_clamp_min: float = param(-math.inf, infinite=True)
    # Feed-forward scale of the desired velocity.
    ff_velocity_scale: float = 0.0
    # [command unit] upper bound of the output.
    u_clamp_max: float = param(math.inf, infinite=True)
    # [command unit] lower bound of the output.
    u_clamp_min: float = param(-math.inf, infinite=True)
    # legacy | none | back_calculation | conditional_integration (control_toolbox's).
    antiwindup_strategy: str = param("legacy", choices=ANTIWINDUP_STRATEGIES)
    # [s] back_calculation's tracking time constant; 0 = sqrt(d / i), or p / i.
    tracking_time_constant: float = 0.0
    # [rad] no integration while |error| <= error_deadband.
    error_deadband: float = 0.0

    def check(self) -> None:
        """control_toolbox's rules between the gains."""
        check_gains(self)

    def pid_gains(self) -> PidGains:
        """The gains of control_toolbox's PID, as upstream's ``update_pids``: i_clamp_max /
        i_clamp_min where finite, else +-i_clamp."""
        return PidGains(
            p=self.p,
            i=self.i,
            d=self.d,
            u_max=self.u_clamp_max,
            u_min=self.u_clamp_min,
            i_max=self.i_clamp_max if math.isfinite(self.i_clamp_max) else self.i_clamp,
            i_min=self.i_clamp_min if math.isfinite(self.i_clamp_min) else -self.i_clamp,
            antiwindup_strategy=self.antiwindup_strategy,
            tracking_time_constant=self.tracking_time_constant,
            error_deadband=self.error_deadband,
        )


@dataclasses.dataclass
class SpeedScaling:
    """Upstream's ``speed_scaling`` parameters (Jazzy, backport #2105)."""

    # [-] the trajectory's time advances by this factor times the update period (>= 0;
    # 0.5 runs it at half speed); used with command_interfaces [position] only, else 1.0.
    initial_scaling_factor: float = param(1.0, unit="-", ge=0)
    # The hardware's speed-scaling state interface ("<component>/<interface>"); "" = none.
    # Activation fails unless the robot's <ros2_control> declares it; its value is not
    # simulated (the factor stays initial_scaling_factor).
    state_interface: str = ""
    # The hardware's speed-scaling command interface, as state_interface; "" = none.
    command_interface: str = ""


@dataclasses.dataclass
class JointTrajectoryControllerParams:
    """The parameters of ``joint_trajectory_controller/JointTrajectoryController``.

    In the YAML the tolerances sit under ``constraints`` as upstream has them
    (``constraints.goal_time``, ``constraints.stopped_velocity_tolerance``,
    ``constraints.<joint>.trajectory`` / ``.goal``) and the PID gains under
    ``gains.<joint>``; they are read into the flat fields below
    (:attr:`ROS_NAMES`).
    """

    # The ROS parameter name of each field whose name differs (for errors and the README).
    ROS_NAMES: ClassVar[dict[str, str]] = {
        "goal_time": "constraints.goal_time",
        "stopped_velocity_tolerance": "constraints.stopped_velocity_tolerance",
        "trajectory_tolerance": "constraints.<joint>.trajectory",
        "goal_tolerance": "constraints.<joint>.goal",
        "decelerate_on_cancel": "constraints.decelerate_on_cancel",
        "max_deceleration_on_cancel": "constraints.<joint>.max_deceleration_on_cancel",
        "gains": "gains",
    }

    # Controller joints, in the controller's order.
    joints: list[str] = param([], required=True, nonempty=True, unique=True)
    # Joints commanded; empty or equal to joints (other command joints are not simulated).
    command_joints: list[str] = dataclasses.field(default_factory=list)
    # Command interfaces: position [, velocity [, acceleration]] (the desired state's
    # positions and velocities drive the position actuators); [position, effort] (the
    # desired effort fed forward as torque on the position actuators); [velocity] or
    # [effort]: a PID per joint on the tracking error (gains).
    command_interfaces: list[str] = param(
        ["position"], required=True, nonempty=True, unique=True, choices=COMMAND_INTERFACES
    )
    # State interfaces read: position [, velocity [, acceleration]]; the first segment
    # starts from the measured velocity only with velocity (acceleration reads 0 rad/s^2).
    state_interfaces: list[str] = param(
        ["position", "velocity"],
        required=True,
        nonempty=True,
        unique=True,
        choices=STATE_INTERFACES,
    )
    # Accept goals naming only some joints (the others get their last command).
    allow_partial_joints_goal: bool = False
    # Start each trajectory from the last command instead of the measured state.
    interpolate_from_desired_state: bool = False
    # The older name of interpolate_from_desired_state (either one turns it on).
    open_loop_control: bool = False
    # Accept points without positions (or velocities) and integrate them from the
    # velocities and accelerations given.
    allow_integration_in_goal_trajectories: bool = False
    # Hold the last command at activation (true) or the measured position (false). As
    # upstream (PR #2356), true takes the position command interface's values whatever the
    # state interfaces; without a position command interface, the measured position.
    set_last_command_interface_value_as_state_on_activation: bool = True
    # [Hz] upstream's action-status polling rate (>= 0.1); the status output here
    # changes at the update that decides it, so this rate moves nothing.
    action_monitor_rate: float = param(20.0, unit="Hz", ge=0.1)
    # The speed scaling of the trajectory's time (upstream's speed_scaling.*).
    speed_scaling: SpeedScaling = dataclasses.field(default_factory=lambda: SpeedScaling())
    # splines (linear / cubic / quintic per segment) | none (the next point's values).
    interpolation_method: str = param("splines", choices=INTERPOLATION_METHODS)
    # Accept a last point with non-zero velocities (commanded after the end).
    allow_nonzero_velocity_at_trajectory_end: bool = False
    # [s] after the end, hold the measured position if the goal is not reached; 0 = off,
    # and off unless greater than goal_time (as upstream).
    cmd_timeout: float = param(0.0, unit="s")
    # [s] after the end to reach the goal; 0 = wait forever.
    goal_time: float = param(0.0, unit="s", ge=0)
    # [rad/s] allowed |desired - measured| velocity at the goal; 0 = unchecked. Upstream
    # compares velocities only with a velocity or effort command interface; so do we.
    stopped_velocity_tolerance: float = param(0.01, unit="rad/s", ge=0)
    # [rad] per joint: allowed |measured - desired| while running; absent or 0 = unchecked.
    trajectory_tolerance: dict[str, float] = param({}, unit="rad", ge=0)
    # [rad] per joint: allowed |measured - desired| after the end; absent or 0 = unchecked.
    goal_tolerance: dict[str, float] = param({}, unit="rad", ge=0)
    # On an abort (path or goal tolerance, cmd_timeout) stop at each joint's
    # max_deceleration_on_cancel from the measured velocity instead of holding the measured
    # position; needs a velocity state interface, every joint's deceleration > 0 and a URDF
    # velocity limit > 0 (else, as upstream, it holds the position).
    decelerate_on_cancel: bool = False
    # [rad/s^2] per joint: the deceleration of decelerate_on_cancel; absent or 0 = none.
    max_deceleration_on_cancel: dict[str, float] = param({}, unit="rad/s^2", ge=0)
    # Per joint, the PID gains of a velocity-only or effort command interface
    # (u = ff_velocity_scale v_d + control_toolbox's PID on the tracking error);
    # upstream uses none with position commands, neither do we.
    gains: dict[str, JointGains] = dataclasses.field(default_factory=dict)

    @property
    def from_desired_state(self) -> bool:
        """Whether trajectories start from the last command (open loop)."""
        return self.interpolate_from_desired_state or self.open_loop_control

    def check(self) -> None:
        """Upstream's interface combination rules (the fields' own rules are declared
        beside them)."""
        _check_combinations(self.command_interfaces, self.state_interfaces)


def _check_combinations(command: list[str], state: list[str]) -> None:
    """Upstream's interface combination rules (``validate_jtc_parameters``: effort,
    velocity, position [velocity [acceleration]], position + effort) and on_configure's
    state requirements, in upstream's order and words."""
    if "velocity" in command and len(command) > 1 and "position" not in command:
        raise Refusal(
            "command_interfaces",
            ": 'velocity' command interface can be used either alone or 'position' command "
            "interface has to be present",
        )
    if "acceleration" in command and not ("velocity" in command or "position" in command):
        raise Refusal(
            "command_interfaces",
            ": 'acceleration' command interface can only be used if 'velocity' and 'position' "
            "command interfaces are present",
        )
    if "effort" in command and not (
        len(command) == 1 or (len(command) == 2 and "position" in command)
    ):
        raise Refusal(
            "command_interfaces",
            ": 'effort' command interface has to be used alone or with a 'position' interface",
        )
    if "position" not in state:
        raise Refusal("state_interfaces", f"={state!r} has no 'position' state interface")
    if "acceleration" in state and "velocity" not in state:
        raise Refusal(
            "state_interfaces",
            ": 'acceleration' state interface cannot be used if 'position' and 'velocity' "
            "interfaces are not present",
        )
    has_both = "velocity" in state and "position" in state
    if command == ["velocity"] and not has_both:
        raise Refusal(
            "state_interfaces",
            ": 'velocity' command interface can only be used alone if 'velocity' and "
            "'position' state interfaces are present",
        )
    if "effort" in command and not has_both:
        raise Refusal(
            "state_interfaces",
            ": 'effort' command interface can only be used alone or with 'position' command "
            "interface if 'velocity' and 'position' state interfaces are present",
        )


def _ros_layout(raw: dict[str, Any], undeclared: list[str]) -> dict[str, Any]:
    """ROS's ``constraints`` and ``gains`` mappings as the flat fields of the
    parameters; what they hold for a name that is not one of the joints (Jazzy's
    ``__map_joints``) is not declared."""
    joints = raw.get("joints")
    joints = joints if isinstance(joints, list) else []
    command_joints = raw.get("command_joints")
    if command_joints not in (None, [], joints):
        raise ParameterError(
            "command_joints",
            f"{command_joints!r} differs from joints {joints}; command joints other than "
            "the joints (controller chains, passive joints) are not simulated",
        )
    constraints = raw.pop("constraints", None) or {}
    if not isinstance(constraints, dict):
        raise ParameterError("constraints", f"expected a mapping, got {constraints!r}")
    trajectory_tolerance, goal_tolerance, deceleration = {}, {}, {}
    per_joint = {
        "trajectory": trajectory_tolerance,
        "goal": goal_tolerance,
        "max_deceleration_on_cancel": deceleration,
    }
    for name, value in constraints.items():
        where = f"constraints.{name}"
        if name in ("goal_time", "stopped_velocity_tolerance", "decelerate_on_cancel"):
            raw[name] = value
        elif name in joints:
            if not isinstance(value, dict):
                raise ParameterError(
                    where,
                    f"expected 'trajectory', 'goal' and 'max_deceleration_on_cancel', "
                    f"got {value!r}",
                )
            for key, number in value.items():
                if key not in per_joint:
                    undeclared.append(f"{where}.{key}")
                    continue
                per_joint[key][name] = number
        else:
            undeclared.append(where)
    raw["trajectory_tolerance"] = trajectory_tolerance
    raw["goal_tolerance"] = goal_tolerance
    raw["max_deceleration_on_cancel"] = deceleration
    gains = raw.get("gains")
    if gains is not None:
        if not isinstance(gains, dict):
            raise ParameterError("gains", f"expected a mapping of joints, got {gains!r}")
        for joint, values in list(gains.items()):
            if joint not in joints:
                undeclared.append(f"gains.{joint}")
                del gains[joint]
            elif not isinstance(values, dict):
                raise ParameterError(f"gains.{joint}", f"expected a mapping, got {values!r}")
    return raw


def _deceleration_on_cancel(controller, params, joints) -> np.ndarray | None:
    """[rad/s^2] upstream's should_decelerate_on_cancel_ and max_decel_ of ``controller``
    (its parameters ``params``, its ``joints``): upstream's on_configure check of
    decelerate_on_cancel, every joint needs a max_deceleration_on_cancel > 0 and a URDF
    velocity limit > 0, and the controller a velocity state interface; else it logs why
    and holds the position on an abort (None)."""
    if not params.decelerate_on_cancel:
        return None
    deceleration = np.array(
        [params.max_deceleration_on_cancel.get(name, 0.0) for name in controller.joint_names]
    )
    for name, decel, limit in zip(
        controller.joint_names, deceleration, joints.velocity, strict=True
    ):
        if decel <= 0.0:
            problem = f"invalid max_deceleration_on_cancel [{decel:.1f}]"
        elif not 0.0 < limit < math.inf:
            problem = f"has invalid joint velocity defined in URDF [{limit:.1f}]"
        else:
            continue
        controller.log_warning(
            controller.name,
            f"Joint [{name}] {problem}. Falling back to hold position on cancel.",
        )
        return None
    if "velocity" not in params.state_interfaces:
        controller.log_warning(
            controller.name,
            "Decelerate on cancel is enabled but hardware does not support velocity state "
            "interface. Falling back to hold position on cancel.",
        )
        return None
    return deceleration


def _pid_arrays(gains: list[JointGains]) -> dict[str, Any]:
    """The joints' PIDs as arrays: ``ff`` the feed-forward scales, ``pids`` per
    anti-windup strategy the joints' indices and their gains (one PID per joint)."""
    pids = []
    for strategy in ANTIWINDUP_STRATEGIES:
        joints = [j for j, g in enumerate(gains) if g.antiwindup_strategy == strategy]
        if not joints:
            continue
        each = [gains[j].pid_gains() for j in joints]
        arrays = {
            field.name: np.array([getattr(g, field.name) for g in each], dtype=float)
            for field in dataclasses.fields(PidGains)
            if field.name not in ("antiwindup_strategy", "legacy_antiwindup")
        }
        pid = PidGains(**arrays, antiwindup_strategy=strategy).checked()
        pids.append((np.array(joints), pid))
    return {"ff": np.array([g.ff_velocity_scale for g in gains]), "pids": pids}


# Upstream parameters the simulation cannot honour: refused with the reason.
_REFUSED: dict[str, str] = {}


@dataclasses.dataclass(frozen=True)
class _PidState:
    """What the closed-loop adapter keeps between updates."""

    integral: np.ndarray  # [command unit] the PIDs' integral terms, unclamped (n)
    tracked: np.ndarray  # [rad, rad/s] the tracked desired state [q_d; v_d] (2n)
    # Whether the tracking has work at the next update whatever arrives: an abort's hold,
    # or reading the measured position at activation.
    pending: bool = False


@register("joint_trajectory_controller/JointTrajectoryController", kind="trajectory")
class JointTrajectoryController(Controller):
    """The logic of ``joint_trajectory_controller/JointTrajectoryController`` (see the
    module docstring); the controller manager runs it."""

    parameters = JointTrajectoryControllerParams
    refused_parameters = _REFUSED
    message = JointTrajectory
    topic = "joint_trajectory"
    fixed_interface = "position"
    initial_state = "idle"

    @classmethod
    def hardware_interfaces(cls, params) -> dict[str, str]:
        """The speed-scaling interfaces it reads or writes (``speed_scaling.state_interface``,
        ``.command_interface``): upstream fails activation when the hardware lacks one.
        The simulated hardware holds such an interface at its value, so the factor stays
        ``initial_scaling_factor`` (the hardware at full speed)."""
        scaling = getattr(params, "speed_scaling", None)
        if scaling is None:
            return {}
        return {
            f"speed_scaling.{name}": getattr(scaling, name)
            for name in ("state_interface", "command_interface")
            if getattr(scaling, name)
        }

    @classmethod
    def known_parameters(cls) -> frozenset[str]:
        names = {f.name for f in dataclasses.fields(cls.parameters)}
        names -= {"goal_time", "stopped_velocity_tolerance", "trajectory_tolerance"}
        names -= {"goal_tolerance", "decelerate_on_cancel", "max_deceleration_on_cancel"}
        return frozenset(names | {"constraints"})

    @classmethod
    def ros_layout(cls, raw: dict[str, Any], *, undeclared: list[str]) -> dict[str, Any]:
        """ROS's ``constraints`` and ``gains`` mappings as the flat fields of the
        parameters (:func:`_ros_layout`)."""
        return _ros_layout(raw, undeclared)

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        params = self.params
        names = self.joint_names
        if tuple(params.joints) != names:
            raise ValueError(f"params.joints={params.joints!r} differs from joint_names={names!r}")
        if params.interpolation_method not in INTERPOLATION_METHODS:
            raise ValueError(
                f"interpolation_method={params.interpolation_method!r} must be splines or none"
            )
        self._params = params
        self._interpolate = params.interpolation_method == "splines"
        # Upstream's joints_angle_wraparound_: the continuous joints (from the robot
        # description), whose position errors are wrapped into (-pi, pi] and whose
        # trajectories start from the nearest representation of the state before.
        self._wraparound = joints.wraparound
        self._wraps = bool(self._wraparound.any())
        commands, states = params.command_interfaces, params.state_interfaces
        self._measured_velocity = "velocity" in states
        # Upstream's has_effort_command_interface_: points may give efforts, fed forward.
        self._has_effort = "effort" in commands
        self._measured_acceleration = "acceleration" in states
        # [s] cmd_timeout, 0 when off (upstream: only when greater than goal_time).
        cmd_timeout = params.cmd_timeout if params.cmd_timeout > params.goal_time else 0.0
        self._cmd_timeout = cmd_timeout  # upstream's get_cmd_timeout()
        # The path and goal tolerances, the timeout, the position error.
        self._tolerances = Tolerances(params, names, self._wraparound, cmd_timeout)
        if params.cmd_timeout > 0 and not cmd_timeout:
            self.log_warning(
                name,
                f"Command timeout must be higher than goal_time tolerance "
                f"({params.cmd_timeout:f} vs. {params.goal_time:f})",
            )
        # [-] upstream's scaling_factor_: with position commands alone the initial scaling
        # factor, else 1.0 (with a warning when another was given).
        self._scaling = 1.0
        # Upstream subscribes ~/speed_scaling_input with position commands alone.
        self.extra_topics = {}
        if commands == ["position"]:
            self._scaling = params.speed_scaling.initial_scaling_factor
            self.extra_topics = {"speed_scaling_input": SpeedScalingFactor}
        elif params.speed_scaling.initial_scaling_factor != 1.0:
            self.log_warning(
                name,
                "Speed scaling is currently only supported for position interfaces. If you want "
                "to make use of speed scaling, please only use a position interface when "
                "configuring this controller.",
            )
        # [rad/s^2] upstream's should_decelerate_on_cancel_ and max_decel_: per joint the
        # deceleration of the stop after an abort, or None to hold the measured position.
        self._deceleration = _deceleration_on_cancel(self, params, joints)
        # [rad, rad/s] bounds of [q_d; v_d]: the position limits, velocities unbounded.
        self._state_lower = np.concatenate([self.lower, np.full(self.n, -np.inf)])
        self._state_upper = np.concatenate([self.upper, np.full(self.n, np.inf)])
        # [s] the update period, set by the controller manager (upstream's update_period_).
        self.update_period = 0.0
        # The PID gains per joint (arrays) with a velocity-only or effort command
        # interface, else None.
        self._pid = None
        # (upstream's use_closed_loop_pid_adapter_: velocity alone and not open_loop_control,
        # or effort; velocity alone with open_loop_control writes the desired velocity).
        if (commands == ["velocity"] and not params.open_loop_control) or commands == ["effort"]:
            self._pid = _pid_arrays([params.gains.get(joint, JointGains()) for joint in names])

    @classmethod
    def command_interface(cls, params) -> str:
        """The joints' command interface: position (with velocity and acceleration
        commands as the desired state's, an effort command as a feed-forward torque), or
        velocity or effort alone (a PID per joint on the tracking error, upstream's
        closed-loop adapter)."""
        if params.command_interfaces in (["velocity"], ["effort"]):
            return params.command_interfaces[0]
        return "position"

    @classmethod
    def commands_effort(cls, params) -> bool:
        return "effort" in params.command_interfaces

    @classmethod
    def position_targets(cls, params) -> bool:
        return True  # its trajectories are positions, whatever interface it commands

    @classmethod
    def minimal_ros_parameters(cls, joints: list[str]) -> dict[str, Any]:
        # Upstream has no default for the interfaces: a YAML names them.
        return {
            "joints": list(joints),
            "command_interfaces": ["position"],
            "state_interfaces": ["position", "velocity"],
        }

    def configure(self, *, update_rate: int) -> None:
        """The controller manager's rate: the trajectory is sampled one period ahead."""
        self.update_period = 1.0 / update_rate

    def _holds_command_values(self) -> bool:
        """Whether activation holds the command interfaces' values (upstream's on_activate,
        ``update_state_from_command_interfaces``, ros2_controllers PR #2356): with
        ``set_last_command_interface_value_as_state_on_activation``, the positions come from
        the position command interface whenever it holds values (here it always does: the
        hardware starts it at the initial positions), whatever the state interfaces; without
        a position command interface, from the state interfaces."""
        return (
            self._params.set_last_command_interface_value_as_state_on_activation
            and "position" in self._params.command_interfaces
        )

    def initial_memory(self) -> ControllerMemory:
        memory = super().initial_memory()
        if self._scaling != 1.0:
            memory = dataclasses.replace(memory, speed_scaling=self._scaling)
        if self._pid is not None:
            # The PID runs at every update, from activation on (holding the measured
            # position read at activation: no position command interface to read).
            state = _PidState(np.zeros(self.n), memory.desired, pending=True)
            return dataclasses.replace(memory, running=True, internal=state)
        if self._holds_command_values():
            return memory  # the hardware's command interfaces hold their initial values
        # Hold the measured position read at activation (the first update).
        return dataclasses.replace(memory, running=True)

    def _Scaled(self, now, message, memory, measure):
        """Speed scaling (upstream's traj_time_): a trajectory is first sampled at the
        update that accepts it, then its time advances by ``factor * dt`` per update while
        the command is still sampled one (unscaled) period ahead; the tolerances and the
        timeout count in that time too."""
        rejected = None
        if message is not None:
            try:
                validate_trajectory(message, now, self.joint_names, self._params, self._has_effort)
            except Rejected as rejection:
                rejected, message = str(rejection), None
        if message is not None or memory.clock is None or not memory.busy:
            clock = now
        else:
            clock = memory.clock + self.update_period * memory.speed_scaling
        tracked = self._Track(clock, message, memory, measure)
        if rejected is not None:
            tracked = dataclasses.replace(tracked, status=self.reject(tracked.status, rejected))
        if tracked.busy and tracked.clock != clock:
            tracked = dataclasses.replace(tracked, clock=clock)
        if tracked.speed_scaling != memory.speed_scaling:
            tracked = dataclasses.replace(tracked, speed_scaling=memory.speed_scaling)
        return tracked

    def receive(self, topic, message, memory):
        """``~/speed_scaling_input`` (upstream's set_scaling_factor): a factor >= 0 from the
        next update on; a negative one is ignored with upstream's warning."""
        if not isinstance(message, SpeedScalingFactor) or not math.isfinite(message.factor):
            return dataclasses.replace(
                memory, status=self.reject(memory.status, f"invalid speed scaling {message!r}")
            )
        if message.factor < 0:
            self.log_warning(
                self.name, "Scaling factor has to be greater or equal to 0.0 - Ignoring input!"
            )
            return memory
        return dataclasses.replace(memory, speed_scaling=float(message.factor))

    def update(self, now, message, memory, measure):
        if memory.speed_scaling != 1.0 or memory.clock is not None:
            return self._Scaled(now, message, memory, measure)
        if self._pid is None:
            tracked = self._Track(now, message, memory, measure)
            if not self._has_effort or tracked is memory:
                return tracked
            # command_interfaces [position, effort]: positions as with position alone, the
            # effort command the desired state's effort at t (state_desired_.effort, no
            # PID); the aborting update writes nothing.
            effort = memory.effort
            if tracked.trajectory is not None and not (
                tracked.running and tracked.status.state == "aborted"
            ):
                effort = tracked.trajectory.effort(now)
            return dataclasses.replace(tracked, effort=effort)
        # Upstream's closed-loop adapter: the trajectory tracked as with position commands,
        # then u = ff_velocity_scale v_d(t + dt) + PID(q_d(t) - q, v_d(t) - v) per joint.
        state = memory.internal
        # _Track's own "work at the next update": an abort's hold, the activation's read.
        own = dataclasses.replace(
            memory, desired=state.tracked, running=state.pending, internal=None
        )
        tracked = self._Track(now, message, own, measure)
        n = self.n
        if tracked.status.state == "aborted" and tracked.running:
            # The aborting update writes nothing: the previous command stays.
            return dataclasses.replace(
                memory,
                status=tracked.status,
                trajectory=tracked.trajectory,
                running=True,
                reference=tracked.reference,
                internal=_PidState(state.integral, tracked.desired, pending=True),
            )
        q, v = measure(tracked.desired)
        if tracked.trajectory is None:
            reference = tracked.desired
        elif tracked.status.state == "executing":
            reference = tracked.trajectory.state(now)
        else:  # a hold (final from the start) or decelerate_on_cancel's stop
            reference = tracked.trajectory.state(now)
        gains = self._pid
        error, error_dot = self._tolerances.error(reference[:n], q), reference[n:] - v
        pid_output, integral = np.zeros(n), state.integral.copy()
        for joints, pid in gains["pids"]:
            pid_output[joints], integral[joints] = compute_command(
                pid, error[joints], error_dot[joints], self.update_period, state.integral[joints]
            )
        # The effort sampled at t + dt (command_next_.effort), fed forward only with the
        # effort command interface.
        effort_next = np.zeros(n)
        if self._has_effort and tracked.trajectory is not None:
            effort_next = tracked.trajectory.effort(now + self.update_period)
        command = gains["ff"] * tracked.desired[n:] + effort_next + pid_output
        internal = _PidState(integral, tracked.desired)
        if self.interface == "effort":
            limit = self.joints.effort
            return dataclasses.replace(
                tracked, effort=np.clip(command, -limit, limit), internal=internal, running=True
            )
        limit = self.joints.velocity
        desired = np.concatenate([tracked.desired[:n], np.clip(command, -limit, limit)])
        return dataclasses.replace(tracked, desired=desired, internal=internal, running=True)

    def _Before(self, now, memory, q, v) -> Point:
        """The state before the trajectory: measured, or the last command (open loop)."""
        n = self.n
        # With the effort command interface upstream's state has an effort: the effort
        # command interface's value (read_state_from_state_interfaces, and
        # read_state_from_command_interfaces at activation), or the last sampled one
        # (open loop's last_commanded_state_).
        effort = None
        if self._has_effort:
            effort = np.zeros(n) if memory.effort is None else memory.effort.copy()
        if self._params.from_desired_state:
            return last_command_point(now, memory, n, self._has_effort, effort)
        velocities = v.copy() if self._measured_velocity else None
        # No acceleration is measured: an acceleration state interface reads zero.
        accelerations = np.zeros(n) if self._measured_acceleration else None
        return Point(now, q.copy(), velocities, accelerations, effort)

    def _Command(self, x: np.ndarray) -> np.ndarray:
        """[q_d; v_d] written to the hardware: positions clamped into the joint limits; a
        clamped joint's (and a non-finite) desired velocity is 0: a spline through a point
        far outside the limits (1e300 rad in 1e-12 s) would otherwise send inf or NaN to
        the plant."""
        clamped = np.minimum(np.maximum(x, self._state_lower), self._state_upper)
        n = self.n
        hold = (clamped[:n] != x[:n]) | ~np.isfinite(clamped[n:])
        clamped[n:][hold] = 0.0
        return clamped

    def _Track(self, now, message, memory, measure):
        """The update of the trajectory tracking (upstream's, position commands)."""
        if message is None and not memory.busy:
            return memory  # nothing new and nothing running: the commands hold
        ahead = now + self.update_period
        trajectory = memory.trajectory
        tolerances = self._tolerances
        if message is None and memory.status.state == "executing":
            # The common tick: the command at t + dt, the path check against the sample
            # at t (the previous tick's command, kept unclamped), nothing else.
            reference = memory.reference
            if not trajectory.ended(ahead):
                x_d = reference[1] if abs(reference[0] - now) < 1e-9 else trajectory.state(now)
                q, _ = measure(memory.desired)
                if not (np.abs(tolerances.error(x_d[: self.n], q)) > tolerances.path_limit).any():
                    x_next = trajectory.state(ahead)
                    return ControllerMemory(
                        self._Command(x_next), memory.status, trajectory, reference=(ahead, x_next)
                    )
        n = self.n
        desired, status = memory.desired, memory.status
        q, v = measure(desired)
        first_sample = False
        if message is not None:
            trajectory, status, first_sample = self._Accept(now, message, memory, q, v)
            if not first_sample:
                message = None  # rejected
        if status.state != "executing":
            if memory.running and trajectory is not None:
                # An abort's hold (or decelerate_on_cancel's stop), from the update after it.
                hold = self._Command(trajectory.state(ahead))
                running = not trajectory.ended(ahead)
                return ControllerMemory(hold, status, trajectory, running=running)
            if memory.running:  # activation without the command interfaces' values
                return ControllerMemory(np.concatenate([q, np.zeros(n)]), status)
            return ControllerMemory(desired, status, trajectory, reference=memory.reference)
        reference = memory.reference if message is None else None
        x_now = (
            reference[1]
            if reference is not None and abs(reference[0] - now) < 1e-9
            else trajectory.state(now)
        )
        ended = trajectory.ended(ahead)
        x_next = trajectory.state(ahead)
        error = np.abs(tolerances.error(x_now[:n], q))
        outcome = None
        if not ended or first_sample:
            outcome = tolerances.path_violation(error, x_now)
        if outcome is None and ended:
            succeeded, outcome = tolerances.goal_outcome(now - trajectory.end_time, error, x_now, v)
            if succeeded:
                status = dataclasses.replace(status, state="succeeded", detail=dict(status.detail))
                # set_success_trajectory_point: the last point, its effort included.
                hold = SampledTrajectory.hold(
                    trajectory.final[:n], trajectory.final[n : 2 * n], trajectory.final_effort
                )
                return ControllerMemory(self._Command(x_next), status, hold)
        if outcome is not None:
            # Upstream writes nothing at this update and holds the measured position
            # from the next one on.
            self.log_warning(self.name, outcome)
            status = dataclasses.replace(
                status, state="aborted", last_error=outcome, detail=dict(status.detail)
            )
            stop = (
                SampledTrajectory.hold(q.copy())
                if self._deceleration is None
                else stop_trajectory(now, q, v, self._deceleration, self.update_period)
            )
            return ControllerMemory(desired, status, stop, running=True)
        command = self._Command(x_next)
        return ControllerMemory(command, status, trajectory, reference=(ahead, x_next))

    def _Accept(self, now, message, memory, q, v):
        """A message received at ``now``: (the trajectory, the status, whether accepted):
        validated, its points in the controller's order from the state before it (the
        measured ``q``, ``v`` or the last command), a warning where they leave the
        joint limits; rejected, the running trajectory and the rejection."""
        status = memory.status
        try:
            indices = validate_trajectory(
                message, now, self.joint_names, self._params, self._has_effort
            )
        except Rejected as rejection:
            return memory.trajectory, self.reject(status, str(rejection)), False
        points = message_points(message, indices, now, memory.desired, self.n)
        before = self._Before(now, memory, q, v)
        trajectory = SampledTrajectory.build(
            before,
            points,
            interpolate=self._interpolate,
            wraparound=self._wraparound if self._wraps else None,
        )
        detail = {"start_time": trajectory.breaks[0], "end_time": trajectory.end_time}
        outside = [
            f"point positions of joint '{name}' leave its limits [{lo!r}, {hi!r}]; "
            f"the desired position is clamped"
            for j, (name, lo, hi) in enumerate(
                zip(self.joint_names, self.lower.tolist(), self.upper.tolist(), strict=True)
            )
            if any(p.positions is not None and not lo <= p.positions[j] <= hi for p in points)
        ]
        if outside:
            detail["warning"] = "; ".join(outside)
            self.log_warning(self.name, detail["warning"])
        return trajectory, self.accept(status, "executing", detail), True
