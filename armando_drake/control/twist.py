"""Velocity commands for a mobile base: the cmd_vel a teleop or navigation node publishes.

A scenario's ``twist:`` section is a sequence of steps, each a twist held for a
duration::

    twist:
      steps:
        - {linear: 0.2, angular: 0.0, duration: 3.0}   # straight at 0.2 m/s
        - {linear: 0.0, angular: 0.5, duration: 3.14}  # turn in place
        - {linear: 0.2, angular: 0.0, duration: 3.0}

:class:`TwistSequencer` publishes the step's ``geometry_msgs/TwistStamped`` (stamped with
the time it is sent, as Nav2's controller server does) at ``rate`` [Hz] while the step
lasts, so a drive's ``cmd_vel_timeout`` never brakes it, then a zero twist at the same
rate until the run ends (the robot stops). A few Python events per second: nothing at
the plant's steps.
"""

import dataclasses
import math

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from armando_drake.messages.types import PublicationValue, Twist, TwistStamped
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.schema import param

# No `from __future__ import annotations` here: yaml_load_typed reads the dataclass
# field types at run time and does not resolve string annotations.


@dataclasses.dataclass
class TwistStep:
    """One step of a twist sequence: a twist held for ``duration``."""

    # [m/s] linear.x, forward.
    linear: float = param(0.0, unit="m/s")
    # [rad/s] angular.z, counter-clockwise seen from above.
    angular: float = param(0.0, unit="rad/s")
    # [s] how long it is published.
    duration: float = param(1.0, unit="s", gt=0)


@dataclasses.dataclass
class TwistSequence:
    """cmd_vel steps published to the mobile base's drive."""

    # The twists, one after the other.
    steps: list[TwistStep] = dataclasses.field(default_factory=list)
    # [Hz] how often the current twist is published (above 1 / cmd_vel_timeout).
    rate: float = param(20.0, unit="Hz", gt=0)
    # [s] simulation time of the first step.
    start_delay: float = param(0.0, unit="s", ge=0)
    # The drive controller it is published to, by name; "" = the first active one.
    controller: str = ""

    def one_pass(self) -> float:
        """[s] the end of the last step."""
        return self.start_delay + sum(step.duration for step in self.steps)

    def twist_at(self, time: float) -> tuple[float, float]:
        """(linear [m/s], angular [rad/s]) commanded at ``time`` [s] (0, 0 outside)."""
        start = self.start_delay
        for step in self.steps:
            if start <= time < start + step.duration - 1e-12:
                return step.linear, step.angular
            start += step.duration
        return 0.0, 0.0


class TwistSequencer(LeafSystem):
    """Publishes a :class:`TwistSequence` as TwistStamped messages.

    .. pydrake_system::

        name: TwistSequencer
        output_ports:
        - cmd_vel
        - command

    - ``cmd_vel``: a Publication of TwistStamped (``frame_id`` ``base_link``);
    - ``command``: vector (linear [m/s], angular [rad/s]) of the latest message, for logs.
    """

    def __init__(self, config: TwistSequence, frame_id: str = "base_link"):
        super().__init__()
        self._config = config
        self._frame_id = frame_id
        self._topic = self.DeclareAbstractState(PublicationValue())
        self._command = self.DeclareDiscreteState(BasicVector(np.zeros(2)))
        self.DeclareStateOutputPort("cmd_vel", self._topic)
        self.DeclareStateOutputPort("command", self._command)
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            1.0 / config.rate, config.start_delay, self._Publish
        )

    @property
    def config(self) -> TwistSequence:
        return self._config

    def _Publish(self, context, state) -> None:
        time = context.get_time()
        linear, angular = self._config.twist_at(time)
        message = TwistStamped(
            stamp=time,
            frame_id=self._frame_id,
            twist=Twist(linear=(linear, 0.0, 0.0), angular=(0.0, 0.0, angular)),
        )
        publication = context.get_abstract_state(self._topic).get_value()
        state.get_mutable_abstract_state(self._topic).set_value(publication.publish(message, time))
        state.get_mutable_discrete_state(self._command).set_value([linear, angular])


def check_twist(config: TwistSequence, where: str = "") -> None:
    """Every step finite; at least one."""
    if not config.steps:
        raise ScenarioError(f"{where}twist.steps: no step")
    for k, step in enumerate(config.steps):
        for name in ("linear", "angular", "duration"):
            value = getattr(step, name)
            if not math.isfinite(value):
                raise ScenarioError(f"{where}twist.steps.{k}.{name}={value!r} is not finite")


def AddTwistSequence(builder, config: TwistSequence, stack, *, where: str = ""):
    """The :class:`TwistSequencer` of ``config`` on the first active controller of
    ``stack`` that takes a twist (or ``config.controller``); exports ``twist_command``.
    Returns (the sequencer, the controller's name)."""
    check_twist(config, where)
    takers = stack.taking(TwistStamped)
    if config.controller:
        if config.controller not in takers:
            raise ScenarioError(
                f"{where}twist.controller={config.controller!r} is not an active drive "
                f"(active drives: {', '.join(takers) or 'none'})"
            )
        takers = [config.controller]
    if not takers:
        raise ScenarioError(
            f"{where}twist needs an active drive (a diff_drive_controller or the "
            f"description's drive plugin); active: {', '.join(stack.controllers) or 'none'}"
        )
    name = takers[0]
    sequencer = builder.AddSystem(TwistSequencer(config))
    sequencer.set_name("twist_sequencer")
    builder.Connect(sequencer.GetOutputPort("cmd_vel"), stack.command_input(name))
    builder.ExportOutput(sequencer.GetOutputPort("command"), stack.port_name("twist_command"))
    return sequencer, name
