"""Command sequences: the publisher half of the course's arm controller node.

The ROS 2 node publishes a list of joint targets one after the other on a
timer (``Float64MultiArray`` on the position controller's ``commands`` topic),
or the same targets as one ``JointTrajectory``; another version drives the
joints with a slow sinusoid. :class:`CommandSequencer` does the same inside a
Drake diagram, configured by a :class:`SequencerConfig` loaded from YAML::

    mode: position          # position | trajectory | sinusoid
    targets: [[0, 0, 0, 0], [0.5, -0.3, 0.8, 0], [-0.5, 0.3, -0.8, 0]]
    period: 3.0
    cyclic: true
"""

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from armando_drake.control.messages import (
    Float64MultiArray,
    JointTrajectory,
    JointTrajectoryPoint,
    PublicationValue,
)

# No `from __future__ import annotations` here: yaml_load_typed reads the
# dataclass field types at run time and does not resolve string annotations.

MODES = ("position", "trajectory", "sinusoid")


@dataclasses.dataclass
class SequencerConfig:
    """What the command sequencer publishes, and when."""

    # position: each target in turn as a Float64MultiArray on `commands`;
    # trajectory: all targets as one JointTrajectory on `joint_trajectory`;
    # sinusoid: offset + amplitude sin(2 pi frequency t + phase) on `commands`.
    mode: str = "position"
    # [rad or m] joint targets, one list per target with one value per joint
    # (in the controller's joint order). Unused by the sinusoid.
    targets: list[list[float]] = dataclasses.field(default_factory=list)
    # [s] time between targets: position mode publishes target k at
    # start_delay + k period; trajectory mode reaches target k at
    # time_from_start = (k + 1) period.
    period: float = 3.0
    # After the last target, start again from the first (position mode), or
    # publish the trajectory again every len(targets) period (trajectory mode).
    cyclic: bool = False
    # [s] simulation time of the first publication.
    start_delay: float = 0.0
    # [rad or m] sinusoid amplitude per joint; empty = pi/2 for every joint.
    amplitude: list[float] = dataclasses.field(default_factory=list)
    # [Hz] sinusoid frequency.
    frequency: float = 0.05
    # [rad] sinusoid phase per joint; empty = 0 for every joint.
    phase: list[float] = dataclasses.field(default_factory=list)
    # [rad or m] sinusoid centre per joint; empty = 0 for every joint.
    offset: list[float] = dataclasses.field(default_factory=list)
    # [Hz] rate at which sinusoid commands are published; None = the
    # controller rate.
    rate: float | None = None


DEFAULT_AMPLITUDE = math.pi / 2  # [rad] the sinusoid seed's amplitude


class SequencerError(ValueError):
    """A sequencer configuration that cannot be run; the message is one line."""


@dataclasses.dataclass(frozen=True)
class Sinusoid:
    """The per-joint sinusoid parameters with defaults filled in."""

    amplitude: tuple[float, ...]  # [rad or m]
    phase: tuple[float, ...]  # [rad]
    offset: tuple[float, ...]  # [rad or m]
    frequency: float  # [Hz]

    def __call__(self, time_since_start: float) -> tuple[float, ...]:
        """The command [rad or m] at ``time_since_start`` [s] after the start delay."""
        angle = 2 * math.pi * self.frequency * time_since_start
        return tuple(
            o + a * math.sin(angle + p)
            for a, p, o in zip(self.amplitude, self.phase, self.offset, strict=True)
        )


def _per_joint(
    values: Sequence[float], default: float, what: str, joint_names: Sequence[str], prefix: str
) -> tuple[float, ...]:
    if not values:
        return (default,) * len(joint_names)
    if len(values) != len(joint_names):
        raise SequencerError(
            f"{prefix}{what} has {len(values)} values, expected {len(joint_names)} "
            f"({', '.join(joint_names)})"
        )
    for name, value in zip(joint_names, values, strict=True):
        if not math.isfinite(value):
            raise SequencerError(f"{prefix}{what}: {name}={value!r} is not finite")
    return tuple(float(v) for v in values)


def sinusoid_of(config: SequencerConfig, joint_names: Sequence[str], source: str = "") -> Sinusoid:
    """The sinusoid of ``config`` with per-joint defaults filled in."""
    prefix = f"{source}: " if source else ""
    return Sinusoid(
        amplitude=_per_joint(config.amplitude, DEFAULT_AMPLITUDE, "amplitude", joint_names, prefix),
        phase=_per_joint(config.phase, 0.0, "phase", joint_names, prefix),
        offset=_per_joint(config.offset, 0.0, "offset", joint_names, prefix),
        frequency=config.frequency,
    )


def validate(
    config: SequencerConfig,
    joint_names: Sequence[str],
    lower: Sequence[float],
    upper: Sequence[float],
    source: str = "",
) -> None:
    """Raises :class:`SequencerError` naming the first thing wrong with ``config``.

    ``lower``/``upper`` [rad or m] are the joint limits in ``joint_names``
    order (+-inf where unlimited). ``source`` (e.g. a file name) prefixes
    every message.
    """
    prefix = f"{source}: " if source else ""
    joint_names = tuple(joint_names)
    n = len(joint_names)
    if len(lower) != n or len(upper) != n:
        raise ValueError(f"{n} joint names but {len(lower)} lower and {len(upper)} upper limits")
    if config.mode not in MODES:
        raise SequencerError(
            f"{prefix}mode={config.mode!r} is not one of {', '.join(map(repr, MODES))}"
        )
    if not (math.isfinite(config.start_delay) and config.start_delay >= 0):
        raise SequencerError(
            f"{prefix}start_delay={config.start_delay!r} must be zero or positive [s]"
        )

    def check_limits(what: str, name: str, value: float, low: float, high: float) -> None:
        if value > high:
            raise SequencerError(
                f"{prefix}{what}: {name}={value!r} is above its upper limit {high!r}"
            )
        if value < low:
            raise SequencerError(
                f"{prefix}{what}: {name}={value!r} is below its lower limit {low!r}"
            )

    if config.mode == "sinusoid":
        if not (math.isfinite(config.frequency) and config.frequency > 0):
            raise SequencerError(f"{prefix}frequency={config.frequency!r} must be positive [Hz]")
        if config.rate is not None and not (math.isfinite(config.rate) and config.rate > 0):
            raise SequencerError(f"{prefix}rate={config.rate!r} must be positive [Hz]")
        sinusoid = sinusoid_of(config, joint_names, source)
        for i, name in enumerate(joint_names):
            reach = abs(sinusoid.amplitude[i])
            centre = sinusoid.offset[i]
            swing = f"offset {centre!r} +- amplitude {reach!r}"
            if centre + reach > upper[i]:
                raise SequencerError(
                    f"{prefix}sinusoid: {name} reaches {centre + reach!r} ({swing}), "
                    f"above its upper limit {upper[i]!r}"
                )
            if centre - reach < lower[i]:
                raise SequencerError(
                    f"{prefix}sinusoid: {name} reaches {centre - reach!r} ({swing}), "
                    f"below its lower limit {lower[i]!r}"
                )
        return

    if not (math.isfinite(config.period) and config.period > 0):
        raise SequencerError(f"{prefix}period={config.period!r} must be positive [s]")
    if not config.targets:
        raise SequencerError(f"{prefix}mode {config.mode!r} needs at least one target")
    for k, target in enumerate(config.targets):
        if len(target) != n:
            raise SequencerError(
                f"{prefix}target {k} has {len(target)} values, expected {n} "
                f"({', '.join(joint_names)})"
            )
        for i, (name, value) in enumerate(zip(joint_names, target, strict=True)):
            if not math.isfinite(value):
                raise SequencerError(f"{prefix}target {k}: {name}={value!r} is not finite")
            check_limits(f"target {k}", name, value, lower[i], upper[i])


class CommandSequencer(LeafSystem):
    """Publishes a configured sequence of joint commands.

    .. pydrake_system::

        name: CommandSequencer
        output_ports:
        - commands
        - joint_trajectory
        - reference

    - ``commands``: a :class:`~armando_drake.control.messages.Publication` of
      :class:`~armando_drake.control.messages.Float64MultiArray` (position and
      sinusoid modes) for a position controller;
    - ``joint_trajectory``: a Publication of
      :class:`~armando_drake.control.messages.JointTrajectory` (trajectory mode) for a
      joint trajectory controller;
    - ``reference``: vector [rad or m], the target currently commanded, for
      logging and plots; NaN before the first publication. In trajectory mode
      it is the target the trajectory is heading to.

    The topic ports of the other modes stay at count 0. All three are state
    output ports changed only by a periodic unrestricted update, so reading
    them costs nothing, and a controller that reads them in a discrete update
    of the same time already sees the new message (Drake runs the
    unrestricted updates of a time before its discrete updates).

    Publication times (``start_delay`` = s, ``period`` = T, n targets):

    - position: target k at s + k T, k = 0..n-1; then, if cyclic, target
      k mod n at s + k T for every k; otherwise nothing more;
    - trajectory: one JointTrajectory at s (stamp 0: "start when received")
      whose point k is target k with zero velocities and time_from_start
      (k + 1) T; if cyclic, the same message again every n T;
    - sinusoid: q_i = offset_i + A_i sin(2 pi f (t - s) + phase_i) at
      t = s, s + 1/rate, ...

    ``on_publish(time, topic, message)``, when given, is called once per
    publication (``topic`` is "commands" or "joint_trajectory"), e.g. to
    stream a commands.csv.
    """

    def __init__(
        self,
        *,
        config: SequencerConfig,
        joint_names: Sequence[str],
        controller_rate: float = 100.0,
        on_publish: Callable[[float, str, Any], None] | None = None,
    ):
        super().__init__()
        joint_names = tuple(joint_names)
        n = len(joint_names)
        if n == 0:
            raise ValueError("joint_names=() must name at least one joint")
        if not (math.isfinite(controller_rate) and controller_rate > 0):
            raise ValueError(f"controller_rate={controller_rate!r} must be positive [Hz]")
        validate(config, joint_names, [-math.inf] * n, [math.inf] * n)
        self._config = dataclasses.replace(
            config, targets=[list(map(float, target)) for target in config.targets]
        )
        self._joint_names = joint_names
        self._on_publish = on_publish
        self._sinusoid = sinusoid_of(config, joint_names) if config.mode == "sinusoid" else None
        self._rate = controller_rate if config.rate is None else config.rate

        self._commands_state = self.DeclareAbstractState(PublicationValue())
        self._trajectory_state = self.DeclareAbstractState(PublicationValue())
        self._reference_state = self.DeclareDiscreteState(BasicVector(np.full(n, np.nan)))
        self.DeclareStateOutputPort("commands", self._commands_state)
        self.DeclareStateOutputPort("joint_trajectory", self._trajectory_state)
        self.DeclareStateOutputPort("reference", self._reference_state)

        s, period = config.start_delay, config.period
        if config.mode == "position":
            self.DeclarePeriodicUnrestrictedUpdateEvent(period, s, self._UpdatePosition)
        elif config.mode == "trajectory":
            cycle = period * len(config.targets)
            self.DeclarePeriodicUnrestrictedUpdateEvent(cycle, s, self._UpdateTrajectory)
            self.DeclarePeriodicUnrestrictedUpdateEvent(period, s, self._UpdateReference)
        else:
            self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / self._rate, s, self._UpdateSinusoid)

    @property
    def config(self) -> SequencerConfig:
        return self._config

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._joint_names

    @property
    def rate(self) -> float:
        """[Hz] the sinusoid publication rate."""
        return self._rate

    def trajectory_message(self) -> JointTrajectory:
        """The JointTrajectory that trajectory mode publishes."""
        period = self._config.period
        zeros = (0.0,) * len(self._joint_names)
        return JointTrajectory(
            stamp=0.0,
            joint_names=self._joint_names,
            points=tuple(
                JointTrajectoryPoint(
                    positions=tuple(target), velocities=zeros, time_from_start=(k + 1) * period
                )
                for k, target in enumerate(self._config.targets)
            ),
        )

    def step_times(self, end_time: float | None = None) -> list[tuple[float, int]]:
        """(time [s], target index) at which each target becomes the reference.

        Position mode: the time target k is published. Trajectory mode: the
        time the trajectory starts heading to target k, which it reaches one
        ``period`` later. Without ``end_time``, one pass over the targets;
        with it, every step at or before ``end_time`` (cyclic sequences
        repeat). Empty for the sinusoid.
        """
        config = self._config
        if config.mode == "sinusoid":
            return []
        n = len(config.targets)
        if end_time is None:
            count = n
        else:
            steps = math.floor((end_time - config.start_delay) / config.period + 1e-9) + 1
            count = max(0, steps if config.cyclic else min(steps, n))
        return [(config.start_delay + k * config.period, k % n) for k in range(count)]

    def _Index(self, context: Context) -> int | None:
        """Which target is due at this periodic tick, None when the sequence is over."""
        config = self._config
        k = round((context.get_time() - config.start_delay) / config.period)
        if k < 0:
            return None
        n = len(config.targets)
        if k >= n and not config.cyclic:
            return None
        return k % n

    def _PublishOn(self, context: Context, state: State, index: int, topic: str, message) -> None:
        time = context.get_time()
        publication = context.get_abstract_state(index).get_value()
        state.get_mutable_abstract_state(index).set_value(publication.publish(message, time))
        if self._on_publish is not None:
            self._on_publish(time, topic, message)

    def _UpdatePosition(self, context: Context, state: State) -> None:
        k = self._Index(context)
        if k is None:
            return
        target = tuple(self._config.targets[k])
        state.get_mutable_discrete_state(self._reference_state).set_value(target)
        self._PublishOn(
            context, state, self._commands_state, "commands", Float64MultiArray(data=target)
        )

    def _UpdateTrajectory(self, context: Context, state: State) -> None:
        if not self._config.cyclic and self._Index(context) != 0:
            return
        message = self.trajectory_message()
        self._PublishOn(context, state, self._trajectory_state, "joint_trajectory", message)

    def _UpdateReference(self, context: Context, state: State) -> None:
        k = self._Index(context)
        if k is None:
            return
        state.get_mutable_discrete_state(self._reference_state).set_value(self._config.targets[k])

    def _UpdateSinusoid(self, context: Context, state: State) -> None:
        command = self._sinusoid(context.get_time() - self._config.start_delay)
        state.get_mutable_discrete_state(self._reference_state).set_value(command)
        self._PublishOn(
            context, state, self._commands_state, "commands", Float64MultiArray(data=command)
        )


# [rad] j0 j1 j2 j3: the course's seed targets for Armando.
SEED_TARGETS = (
    (0.0, 0.0, 0.0, 0.0),
    (1.2, -1.0, 1.2, 0.6),
    (-1.2, 1.0, -1.2, -0.6),
    (0.6, 0.0, -0.6, 1.0),
    (0.0, 0.0, 0.0, 0.0),
)
SEED_ROOM = 0.8  # the share of a joint's range on each side of home the seed may use


def is_seed(targets: Sequence[Sequence[float]]) -> bool:
    """Whether ``targets`` are the seed targets themselves (the default)."""
    return [list(map(float, t)) for t in targets] == [list(t) for t in SEED_TARGETS]


def seed_targets_for(lower: Sequence[float], upper: Sequence[float]) -> list[list[float]]:
    """The seed targets sized to a robot whose joints have these limits [rad or m].

    Joint j follows the seed's column j mod 4 about its home (0, clamped into
    its limits). Each side is scaled down only if the seed's largest excursion
    on that side (1.2) exceeds :data:`SEED_ROOM` of the room the limits leave
    there, so a joint with room (every Armando joint, the iiwa's) gets the seed
    itself, and a short one (a 4 cm gripper finger) the same pattern within
    its range. Unlimited joints get the seed unscaled.
    """
    if len(lower) != len(upper):
        raise ValueError(f"lower={lower!r} and upper={upper!r} differ in length")
    columns = len(SEED_TARGETS[0])
    reach_up = max(max(t) for t in SEED_TARGETS)  # [rad] 1.2
    reach_down = -min(min(t) for t in SEED_TARGETS)  # [rad] 1.2
    targets = [[0.0] * len(lower) for _ in SEED_TARGETS]
    for j, (low, high) in enumerate(zip(lower, upper, strict=True)):
        home = min(max(0.0, low), high)
        up = min(1.0, SEED_ROOM * (high - home) / reach_up)
        down = min(1.0, SEED_ROOM * (home - low) / reach_down)
        for k, seed in enumerate(SEED_TARGETS):
            value = seed[j % columns]
            targets[k][j] = home + value * (up if value > 0 else down)
    return targets
