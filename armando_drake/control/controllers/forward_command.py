"""Forward-command controllers: ``forward_command_controller/ForwardCommandController``
and its fixed-interface forms ``position_controllers/JointGroupPositionController``,
``velocity_controllers/JointGroupVelocityController`` and
``effort_controllers/JointGroupEffortController``.

Each reads ``std_msgs/Float64MultiArray`` on ``/<controller>/commands``, one value
per joint in the controller's order, and writes it to the joints' command
interface: positions [rad] become the desired state of Drake's PD actuators
(v_d = 0), velocities [rad/s] the desired velocity of a damping-only servo,
efforts [N m] torques on the plant's actuation input.

Before any command arrives it writes nothing: the joints hold their initial
positions (velocity joints hold still, effort joints get no torque). A message
with a NaN/Inf element ("Non-finite value received. Dropping message") or with
the wrong size, empty included ("command size (N) does not match number of
interfaces (M)"), is dropped and the previous command kept; the controller
stays active (upstream Jazzy deactivates it). A value outside the joint's limit
(position limits, URDF velocity limit, URDF effort limit) is clamped and the
command accepted, with the warning in ``status.detail["warning"]``.
"""

import dataclasses
from typing import Any

import numpy as np

from armando_drake.control.controllers import (
    COMMAND_INTERFACES,
    CommandStream,
    Controller,
    ControllerMemory,
    ParameterError,
    Rejected,
    register,
)
from armando_drake.messages.types import Float64MultiArray
from armando_drake.tools.schema import param


@dataclasses.dataclass
class JointGroupParameters:
    """The parameters of the JointGroup*Controller types."""

    # The joints commanded, in the order of the command's values.
    joints: list[str] = param([], required=True, nonempty=True, unique=True)


@dataclasses.dataclass
class ForwardCommandParameters(JointGroupParameters):
    """The parameters of ``forward_command_controller/ForwardCommandController``."""

    # The command interface written: position [rad], velocity [rad/s] or effort [N m].
    interface_name: str = param(
        "", required=True, choices=COMMAND_INTERFACES, why="the interfaces simulated"
    )


@register("forward_command_controller/ForwardCommandController")
class ForwardCommandController(CommandStream, Controller):
    """Writes each Float64MultiArray command to its joints' ``interface_name``."""

    parameters = ForwardCommandParameters
    message = Float64MultiArray
    topic = "commands"
    initial_state = "holding"

    @classmethod
    def command_interface(cls, params) -> str:
        return cls.fixed_interface or params.interface_name

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(joints=list(joints.names), interface_name="position")

    @classmethod
    def accepts_stream(cls, params) -> bool:
        return cls.command_interface(params) == "position"

    def stream_status(self, status, count):
        # Every sample is finite, of the right size and within the limits (checked when
        # the world is built), so each one is accepted as it is, without a warning.
        if count <= 0:
            return status
        return dataclasses.replace(
            status, state="active", accepted=status.accepted + count, detail={}
        )

    def _Limits(self) -> tuple[np.ndarray, np.ndarray]:
        if self.interface == "position":
            return self.lower, self.upper
        limit = self.joints.velocity if self.interface == "velocity" else self.joints.effort
        return -limit, limit

    def _Validate(self, message) -> tuple[np.ndarray, str]:
        """The command to write and a clamping warning ("" if none)."""
        if not isinstance(message, Float64MultiArray):
            raise Rejected(f"expected a Float64MultiArray message, got {type(message).__name__}")
        data = np.asarray(message.data, dtype=float).reshape(-1)
        if not np.all(np.isfinite(data)):
            raise Rejected("Non-finite value received. Dropping message")
        if data.size != self.n:
            raise Rejected(
                f"command size ({data.size}) does not match number of interfaces ({self.n})"
            )
        lower, upper = self._Limits()
        command = np.clip(data, lower, upper)
        if np.array_equal(command, data):
            return command, ""
        warnings = [
            f"command {value!r} for joint '{name}' is outside its limits [{lo!r}, {hi!r}]; "
            f"clamped to {clamped!r}"
            for name, value, clamped, lo, hi in zip(
                self.joint_names,
                data.tolist(),
                command.tolist(),
                lower.tolist(),
                upper.tolist(),
                strict=True,
            )
            if value != clamped
        ]
        return command, "; ".join(warnings)

    def update(self, now, message, memory, measure):
        if message is None:
            return memory
        try:
            command, warning = self._Validate(message)
        except Rejected as rejection:
            return dataclasses.replace(memory, status=self.reject(memory.status, str(rejection)))
        if warning:
            self.log_warning(self.name, warning)
        status = self.accept(memory.status, "active", {"warning": warning} if warning else {})
        n = self.n
        if self.interface == "position":
            return ControllerMemory(np.concatenate([command, np.zeros(n)]), status)
        if self.interface == "velocity":
            # A damping-only servo: q_d is not used (kp = 0), v_d is the command.
            return ControllerMemory(np.concatenate([memory.desired[:n], command]), status)
        return ControllerMemory(memory.desired, status, effort=command)


@register("position_controllers/JointGroupPositionController", kind="position")
class JointGroupPositionController(ForwardCommandController):
    """A ForwardCommandController on the position interface [rad]."""

    parameters = JointGroupParameters
    fixed_interface = "position"

    @classmethod
    def known_parameters(cls) -> frozenset[str]:
        return super().known_parameters() | {"interface_name"}

    @classmethod
    def ros_layout(cls, raw: dict[str, Any], *, undeclared: list[str]) -> dict[str, Any]:
        """Upstream's schema has ``interface_name`` here too, and the type overrides it
        with its own interface; a different one is refused rather than overridden."""
        given = raw.pop("interface_name", None)
        if given is not None and given != cls.fixed_interface:
            raise ParameterError(
                "interface_name",
                f"interface_name={given!r}: {cls.type_name()} commands the "
                f"{cls.fixed_interface!r} interface (upstream overrides the parameter)",
            )
        return raw

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(joints=list(joints.names))


@register("velocity_controllers/JointGroupVelocityController")
class JointGroupVelocityController(JointGroupPositionController):
    """A ForwardCommandController on the velocity interface [rad/s]."""

    fixed_interface = "velocity"


@register("effort_controllers/JointGroupEffortController")
class JointGroupEffortController(JointGroupPositionController):
    """A ForwardCommandController on the effort interface [N m]."""

    fixed_interface = "effort"
