"""ROS 1 (``ros_control``) controller types, mapped onto the ROS 2 ones.

The course's first year runs ROS 1 with ``gazebo_ros_control``; its controller
YAML names these types (registered with ``ros=1``, looked up only for a ROS 1
file, see :mod:`armando_drake.control.config`):

- ``joint_state_controller/JointStateController``: the joint state
  broadcaster on every joint, sampled at ``publish_rate`` [Hz];
- ``position_controllers/JointPositionController``,
  ``velocity_controllers/JointVelocityController``,
  ``effort_controllers/JointEffortController``: forward commands on one
  ``joint``'s position, velocity or effort;
- ``position_controllers/JointGroupPositionController`` (and the velocity and
  effort ones): the JointGroup controllers (``joints``);
- ``position_controllers/JointTrajectoryController``: the trajectory controller
  on positions;
- ``effort_controllers/JointPositionController``: a PID on one joint's position
  error whose output is its effort (``pid: {p, i, d, ...}``);
- ``effort_controllers/JointTrajectoryController``: the trajectory controller,
  its desired state turned into efforts by a PID per joint (``gains: {<joint>:
  {p, i, d, ...}}``).

The group and trajectory types read the same messages and claim the same
command interfaces as their ROS 2 counterparts; ROS 1 puts every command on
``/<namespace>/<controller>/command`` (the single-joint ones a
``std_msgs/Float64``), so their command input is ``<controller>.command``.
ROS 1's trajectory controller has no ``command_interfaces``/``state_interfaces``
parameters (position, and position + velocity) and does not reject a last
point with non-zero velocities. Other ROS 1 types
(``velocity_controllers/JointTrajectoryController``, ``GripperActionController``,
...) are not simulated: a file may name them, and activating one is an error.
"""

import dataclasses
import math
from typing import Any

import numpy as np

from armando_drake.control.controllers import (
    Controller,
    ControllerMemory,
    Rejected,
    register,
)
from armando_drake.control.controllers.broadcaster import JointStateBroadcaster
from armando_drake.control.controllers.forward_command import (
    JointGroupEffortController,
    JointGroupPositionController,
    JointGroupVelocityController,
)
from armando_drake.control.controllers.joint_trajectory import (
    JointTrajectoryController,
    JointTrajectoryControllerParams,
)
from armando_drake.messages.types import Float64, Float64MultiArray
from armando_drake.tools.schema import Refusal, param

ROS1_TOPIC = "command"  # every ROS 1 command topic: /<namespace>/<controller>/command
NO_JOINT = "No joint given; expected a joint name"  # ROS 1's error, a joint missing
NO_P_GAIN = "No p gain specified for pid"  # ROS 1's error, a PID's p missing


# --------------------------------------------------------------------------------------
# joint_state_controller


@dataclasses.dataclass
class JointStateControllerParameters:
    """The parameters of ``joint_state_controller/JointStateController``."""

    # [Hz] rate at which joint states are published; required, as in ROS 1.
    publish_rate: float = param(0.0, unit="Hz", gt=0, required="Parameter 'publish_rate' not set")


@register("joint_state_controller/JointStateController", ros=1)
class JointStateController(JointStateBroadcaster):
    """ROS 1's joint state publisher: every joint of the hardware interface."""

    parameters = JointStateControllerParameters
    ignored_parameters = frozenset({"extra_joints"})

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return []  # every hardware joint

    @classmethod
    def publish_rate(cls, params) -> float | None:
        return params.publish_rate

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(publish_rate=50.0)


# --------------------------------------------------------------------------------------
# One joint, forwarded


@dataclasses.dataclass
class SingleJointParameters:
    """The parameters of ROS 1's single-joint forward-command controllers."""

    # The joint commanded.
    joint: str = param("", nonempty=True, required=NO_JOINT)


def _as_array(message: Any) -> Any:
    """A Float64 command as the one-element Float64MultiArray the forward logic reads."""
    if isinstance(message, Float64):
        return Float64MultiArray(data=(float(message.data),))
    return message


class _SingleJoint:
    """Mixin: one ``joint`` parameter, std_msgs/Float64 on ``command``."""

    parameters = SingleJointParameters
    message = Float64
    topic = ROS1_TOPIC

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return [params.joint]

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(joint=joints.names[0])

    def _Validate(self, message):
        if not isinstance(message, Float64):
            raise Rejected(f"expected a Float64 message, got {type(message).__name__}")
        return super()._Validate(_as_array(message))


@register("position_controllers/JointPositionController", ros=1)
class JointPositionController(_SingleJoint, JointGroupPositionController):
    """The position [rad] of one joint, forwarded."""


@register("velocity_controllers/JointVelocityController", ros=1)
class JointVelocityController(_SingleJoint, JointGroupVelocityController):
    """The velocity [rad/s] of one joint, forwarded."""


@register("effort_controllers/JointEffortController", ros=1)
class JointEffortController(_SingleJoint, JointGroupEffortController):
    """The effort [N m] of one joint, forwarded."""


# --------------------------------------------------------------------------------------
# Groups and trajectories: the ROS 2 logic on ROS 1's topic


@register("position_controllers/JointGroupPositionController", ros=1)
class Ros1JointGroupPositionController(JointGroupPositionController):
    """JointGroupPositionController reading ``command``."""

    topic = ROS1_TOPIC


@register("velocity_controllers/JointGroupVelocityController", ros=1)
class Ros1JointGroupVelocityController(JointGroupVelocityController):
    """JointGroupVelocityController reading ``command``."""

    topic = ROS1_TOPIC


@register("effort_controllers/JointGroupEffortController", ros=1)
class Ros1JointGroupEffortController(JointGroupEffortController):
    """JointGroupEffortController reading ``command``."""

    topic = ROS1_TOPIC


@register("position_controllers/JointTrajectoryController", ros=1)
class Ros1JointTrajectoryController(JointTrajectoryController):
    """JointTrajectoryController on positions reading ``command``, with ROS 1's
    parameters (no interface lists; any velocity at the last point accepted)."""

    topic = ROS1_TOPIC
    # ROS 1's own parameters that do not change the motion here.
    ignored_parameters = frozenset(
        {
            "stop_trajectory_duration",
            "hold_trajectory_duration",
            "velocity_ff",
            "state_publish_rate",
            "action_monitor_rate",
        }
    )
    refused_parameters = {}

    @classmethod
    def known_parameters(cls) -> frozenset[str]:
        return frozenset({"joints", "constraints", "allow_partial_joints_goal"})

    @classmethod
    def ros_layout(cls, raw: dict[str, Any], *, undeclared: list[str]) -> dict[str, Any]:
        raw["command_interfaces"] = ["position"]
        raw["state_interfaces"] = ["position", "velocity"]
        raw["allow_nonzero_velocity_at_trajectory_end"] = True
        return super().ros_layout(raw, undeclared=undeclared)

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        self.extra_topics = {}  # ROS 1's controller has no speed scaling input


# --------------------------------------------------------------------------------------
# effort_controllers/JointPositionController: a PID to effort


@dataclasses.dataclass
class PidGains:
    """control_toolbox's ``Pid`` gains, as ROS 1 reads them under ``pid:``."""

    # [N m/rad] proportional gain; required. (control_toolbox takes any gain, negative
    # ones too; a non-finite one is refused.)
    p: float = param(0.0, required=NO_P_GAIN)
    # [N m/(rad s)] integral gain.
    i: float = 0.0
    # [N m s/rad] derivative gain (on the change of the error between updates).
    d: float = 0.0
    # [N m] the integral term stays within +-i_clamp (0: no integral action, as upstream).
    i_clamp: float = 0.0
    # [N m] lower bound of the integral term; None = -i_clamp.
    i_clamp_min: float | None = None
    # [N m] upper bound of the integral term; None = i_clamp.
    i_clamp_max: float | None = None
    # Clamp the integrated error itself (to i_clamp / i), not only the term.
    antiwindup: bool = False
    # Publish the PID's internal state (not simulated; accepted).
    publish_state: bool = False

    @property
    def i_min(self) -> float:
        """[N m] the integral term's lower bound (<= 0)."""
        return -abs(self.i_clamp if self.i_clamp_min is None else self.i_clamp_min)

    @property
    def i_max(self) -> float:
        """[N m] the integral term's upper bound (>= 0)."""
        return abs(self.i_clamp if self.i_clamp_max is None else self.i_clamp_max)


@dataclasses.dataclass
class JointPositionPidParameters:
    """The parameters of ``effort_controllers/JointPositionController``."""

    # The joint controlled.
    joint: str = param("", nonempty=True, required=NO_JOINT)
    # Its PID gains.
    pid: PidGains = param(default_factory=PidGains, required=NO_P_GAIN)


@dataclasses.dataclass(frozen=True)
class _PidState:
    """What the PID keeps between updates."""

    target: float  # [rad] the commanded position
    integral: float  # [rad s] integrated position error
    last_error: float  # [rad] the error at the previous update
    last_time: float  # [s] time of the previous update


@register("effort_controllers/JointPositionController", ros=1)
class JointPositionPidController(Controller):
    """A PID on one joint's position error, writing the joint's effort [N m].

    As ROS 1's controller with control_toolbox's ``Pid``: at each update
    ``effort = p e + clamp(i integral(e dt), i_min, i_max) + d (e - e_prev) / dt``
    with ``e = target - q``, clamped to the joint's effort limit. Until a
    command arrives the target is the position measured at the first update
    (upstream's ``starting()``: hold where it is). A command outside the
    joint's position limits is clamped (with a warning); a NaN/Inf one is
    dropped. It runs at every update of the controller manager, so the loop
    closes at ``update_rate``.
    """

    parameters = JointPositionPidParameters
    message = Float64
    topic = ROS1_TOPIC
    fixed_interface = "effort"
    initial_state = "holding"

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return [params.joint]

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(joint=joints.names[0], pid=PidGains(p=1.0))

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        self._period = 0.0  # [s] the controller manager's update period

    def configure(self, *, update_rate: int) -> None:
        self._period = 1.0 / update_rate

    def initial_memory(self) -> ControllerMemory:
        return dataclasses.replace(super().initial_memory(), running=True)

    def update(self, now, message, memory, measure):
        state, status = memory.internal, memory.status
        q, _ = measure(memory.desired)
        position = float(q[0])
        first = state is None
        if first:  # the first update: hold the measured position
            state = _PidState(position, 0.0, 0.0, now - self._period)
        target = state.target
        if message is not None:
            try:
                if not isinstance(message, Float64):
                    raise Rejected(f"expected a Float64 message, got {type(message).__name__}")
                if not math.isfinite(message.data):
                    raise Rejected("Non-finite value received. Dropping message")
            except Rejected as rejection:
                status = self.reject(status, str(rejection))
            else:
                low, high = float(self.lower[0]), float(self.upper[0])
                target = min(max(float(message.data), low), high)
                detail = {}
                if target != message.data:
                    detail["warning"] = (
                        f"command {message.data!r} for joint '{self.joint_names[0]}' is outside "
                        f"its limits [{low!r}, {high!r}]; clamped to {target!r}"
                    )
                    self.log_warning(self.name, detail["warning"])
                status = self.accept(status, "active", detail)
        error = target - position
        dt = now - state.last_time
        # Pid::computeCommand(error, dt): no derivative before a previous error exists.
        derivative = (error - state.last_error) / dt if dt > 0 and not first else 0.0
        effort, integral = pid_command(self.params.pid, error, derivative, state.integral, dt)
        limit = float(self.joints.effort[0])
        return dataclasses.replace(
            memory,
            status=status,
            effort=np.array([min(max(effort, -limit), limit)]),
            internal=_PidState(target, integral, error, now),
        )


def pid_command(
    gains: PidGains, error: float, error_dot: float, integral: float, dt: float
) -> tuple[float, float]:
    """control_toolbox's ``Pid::computeCommand(error, error_dot, dt)``: the command
    ``p error + i integral + d error_dot`` [N m] and the new integrated error [rad s]
    (integrated over ``dt`` [s]; with ``antiwindup`` the integrated error is bounded
    to ``minmax(i_min / i, i_max / i)``, else the integral term to [i_min, i_max]); 0 and
    the integral unchanged when ``dt`` is 0 or an error is not finite, as ROS 1's."""
    if dt == 0 or not (math.isfinite(error) and math.isfinite(error_dot)):
        return 0.0, integral  # upstream returns 0 and integrates nothing
    integral += dt * error
    if gains.antiwindup and gains.i != 0:
        # boost::minmax(i_min / i, i_max / i): a negative i swaps the bounds.
        low, high = sorted((gains.i_min / gains.i, gains.i_max / gains.i))
        integral = min(max(integral, low), high)
    integral_term = gains.i * integral
    if not gains.antiwindup:
        integral_term = min(max(integral_term, gains.i_min), gains.i_max)
    return gains.p * error + integral_term + gains.d * error_dot, integral


@dataclasses.dataclass
class EffortTrajectoryParameters(JointTrajectoryControllerParams):
    """``effort_controllers/JointTrajectoryController``: the trajectory controller's
    parameters and a PID per joint."""

    # PID gains per joint, as ``gains: {<joint>: {p: .., i: .., d: .., i_clamp: ..}}``;
    # every joint needs its p.
    gains: dict[str, PidGains] = dataclasses.field(default_factory=dict)

    def check(self) -> None:
        """The trajectory controller's rules, and a PID for each joint (whose p the
        file gives: ``required``), none for another name."""
        super().check()
        for joint in self.gains:
            if joint not in self.joints:
                raise Refusal(
                    f"gains.{joint}", f": '{joint}' is not one of the controller's joints"
                )
        for joint in self.joints:
            if joint not in self.gains:
                raise Refusal(f"gains.{joint}.p", f": {NO_P_GAIN}")


@dataclasses.dataclass(frozen=True)
class _TrajectoryPidState:
    """What the effort trajectory controller's PIDs keep between updates."""

    integral: np.ndarray  # [rad s] integrated position error per joint
    last_time: float  # [s] time of the previous update


@register("effort_controllers/JointTrajectoryController", ros=1)
class EffortJointTrajectoryController(Ros1JointTrajectoryController):
    """The trajectory controller whose desired state [q_d; v_d] a PID per joint turns
    into efforts: ``effort_j = pid_j(q_d - q, v_d - v)`` at every update (ROS 1's
    effort HardwareInterfaceAdapter), clamped to the effort limits. Before any
    trajectory it holds the initial positions."""

    parameters = EffortTrajectoryParameters
    fixed_interface = "effort"

    @classmethod
    def command_interface(cls, params) -> str:
        return "effort"  # its own PIDs (ROS 1's adapter), not the ROS 2 closed loop

    @classmethod
    def commands_effort(cls, params) -> bool:
        return True

    @classmethod
    def known_parameters(cls) -> frozenset[str]:
        return super().known_parameters() | {"gains"}

    @classmethod
    def position_targets(cls, params) -> bool:
        return True  # its trajectories are positions; the PIDs turn them into efforts

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(
            joints=list(joints.names),
            gains={joint: PidGains(p=1.0) for joint in joints.names},
        )

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        self._gains = [self.params.gains[joint] for joint in self.joint_names]

    def initial_memory(self) -> ControllerMemory:
        return dataclasses.replace(super().initial_memory(), running=True)

    def update(self, now, message, memory, measure):
        # The trajectory logic sees its own state (busy only while executing).
        own = dataclasses.replace(memory, running=False)
        tracked = super().update(now, message, own, measure)
        n = self.n
        q, v = measure(tracked.desired)
        error = tracked.desired[:n] - q
        error_dot = tracked.desired[n:] - v
        state = memory.internal or _TrajectoryPidState(np.zeros(n), now - self.update_period)
        dt = now - state.last_time
        effort, integral = np.zeros(n), np.zeros(n)
        for j, gains in enumerate(self._gains):
            effort[j], integral[j] = pid_command(
                gains, float(error[j]), float(error_dot[j]), float(state.integral[j]), dt
            )
        limit = self.joints.effort
        return dataclasses.replace(
            tracked,
            effort=np.clip(effort, -limit, limit),
            internal=_TrajectoryPidState(integral, now),
            running=True,
        )
