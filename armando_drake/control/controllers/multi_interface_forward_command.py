"""``forward_command_controller/MultiInterfaceForwardCommandController``.

Upstream's forward command controller on several command interfaces of one ``joint``: it
reads ``std_msgs/Float64MultiArray`` on ``/<controller>/commands``, one value per name of
``interface_names`` in that order, and writes each to that interface. The simulated joint
has one actuator, which takes them all: it is claimed on its position interface when
``position`` is listed (the position is the PD actuator's desired position, a ``velocity``
its desired velocity, an ``effort`` a torque fed forward on top), else on velocity (the
velocity servo's desired velocity, an effort fed forward), else on effort (the torque).

As the other forward command controllers: nothing is written before a command; a command
of another size, or with a NaN/Inf value, is dropped and the last one kept (upstream
returns an error from update()); values outside the joint's limits are clamped with a
warning.
"""

import dataclasses

import numpy as np

from armando_drake.control.controllers import (
    COMMAND_INTERFACES,
    Controller,
    ControllerMemory,
    Rejected,
    register,
)
from armando_drake.messages.types import Float64MultiArray
from armando_drake.tools.schema import param


@dataclasses.dataclass
class MultiInterfaceForwardCommandParameters:
    """The parameters of ``MultiInterfaceForwardCommandController`` (upstream's schema)."""

    # The joint commanded.
    joint: str = param("", nonempty=True)
    # The command interfaces written, in the order of the command's values: position
    # [rad], velocity [rad/s], effort [N m].
    interface_names: list[str] = param(
        [],
        nonempty=True,
        unique=True,
        choices=COMMAND_INTERFACES,
        why="the command interfaces simulated",
    )


@register("forward_command_controller/MultiInterfaceForwardCommandController")
class MultiInterfaceForwardCommandController(Controller):
    """Writes each Float64MultiArray command to the listed interfaces of one joint."""

    parameters = MultiInterfaceForwardCommandParameters
    message = Float64MultiArray
    topic = "commands"
    initial_state = "holding"

    @classmethod
    def command_interface(cls, params) -> str:
        for interface in COMMAND_INTERFACES:  # position, velocity, effort
            if interface in params.interface_names:
                return interface
        return params.interface_names[0]

    @classmethod
    def commands_effort(cls, params) -> bool:
        return "effort" in params.interface_names

    @classmethod
    def joints_of(cls, params) -> list[str]:
        return [params.joint]

    @classmethod
    def default_parameters(cls, joints):
        return cls.parameters(joint=joints.names[0], interface_names=["position"])

    def _Limits(self, interface: str) -> tuple[float, float]:
        if interface == "position":
            return float(self.lower[0]), float(self.upper[0])
        limit = self.joints.velocity if interface == "velocity" else self.joints.effort
        return -float(limit[0]), float(limit[0])

    def _Validate(self, message) -> dict[str, float]:
        if not isinstance(message, Float64MultiArray):
            raise Rejected(f"expected a Float64MultiArray message, got {type(message).__name__}")
        data = np.asarray(message.data, dtype=float).reshape(-1)
        if not np.all(np.isfinite(data)):
            raise Rejected("Non-finite value received. Dropping message")
        names = self.params.interface_names
        if data.size != len(names):
            raise Rejected(
                f"command size ({data.size}) does not match number of interfaces ({len(names)})"
            )
        return dict(zip(names, data.tolist(), strict=True))

    def update(self, now, message, memory, measure):
        if message is None:
            return memory
        try:
            values = self._Validate(message)
        except Rejected as rejection:
            return dataclasses.replace(memory, status=self.reject(memory.status, str(rejection)))
        warnings = []
        for interface, value in values.items():
            low, high = self._Limits(interface)
            clamped = min(max(value, low), high)
            if clamped != value:
                warnings.append(
                    f"command {value!r} for the {interface} of joint '{self.joint_names[0]}' "
                    f"is outside its limits [{low!r}, {high!r}]; clamped to {clamped!r}"
                )
            values[interface] = clamped
        warning = "; ".join(warnings)
        if warning:
            self.log_warning(self.name, warning)
        status = self.accept(memory.status, "active", {"warning": warning} if warning else {})
        desired = memory.desired.copy()
        if "position" in values:
            desired[0] = values["position"]
        if "velocity" in values:
            desired[1] = values["velocity"]
        effort = np.array([values["effort"]]) if "effort" in values else memory.effort
        return ControllerMemory(desired, status, effort=effort)
