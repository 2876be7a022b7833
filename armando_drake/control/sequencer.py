"""Command sequences: the publisher half of the course's arm controller node.

The ROS 2 node publishes a list of joint targets one after the other on a
timer (``Float64MultiArray`` on the position controller's ``commands`` topic),
or the same targets as one ``JointTrajectory``; another version drives the
joints with a slow sinusoid. The three are a tagged union of dataclasses,
each with only its own fields, chosen in a scenario by a YAML tag::

    sequencer: !PositionTargets {period: 3.0}          # the seed targets, 3 s apart
    sequencer: !JointTrajectoryTargets {period: 3.0}   # the same as one JointTrajectory
    sequencer: !Sinusoid {frequency: 0.05}             # the seed's wave

The defaults are the course's seed: :data:`SEED_TARGETS` (Armando's four
joints) and the seed's wave (pi/2 at 0.05 Hz, j2 in antiphase with j1), so
they are written here once and a scenario states only what differs.

:class:`CommandSequencer` publishes targets and trajectories (a few Python
events per run); :class:`SinusoidSequencer` evaluates the wave with Drake's
``Sine`` and samples it at the controller rate with a ``ZeroOrderHold``, all
in C++, and turns the held sample into a message only when a subscriber
reads it. :func:`MakeSequencer` builds the one a configuration asks for.
"""

import dataclasses
import logging
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    Diagram,
    DiagramBuilder,
    LeafSystem,
    State,
)
from pydrake.systems.primitives import (
    AffineSystem,
    BusCreator,
    BusSelector,
    Multiplexer,
    Sine,
    TrajectorySource,
    ZeroOrderHold,
)
from pydrake.trajectories import PiecewisePolynomial

from armando_drake.control.clearance import clear_targets
from armando_drake.control.controllers import takes_stream
from armando_drake.control.velocity_limits import slowest_move, slowest_wave
from armando_drake.description.loader import is_builtin_armando
from armando_drake.messages.types import (
    Float64MultiArray,
    JointTrajectory,
    JointTrajectoryPoint,
    Publication,
    PublicationValue,
)
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.schema import ConfigError, check_config, param

_log = logging.getLogger("armando_drake.world")

# No `from __future__ import annotations` here: yaml_load_typed reads the
# dataclass field types at run time and does not resolve string annotations.

# [rad] j0 j1 j2 j3: the course's seed targets for Armando, the default of
# PositionTargets and JointTrajectoryTargets.
SEED_TARGETS = (
    (0.0, 0.0, 0.0, 0.0),
    (1.2, -1.0, 1.2, 0.6),
    (-1.2, 1.0, -1.2, -0.6),
    (0.6, 0.0, -0.6, 1.0),
    (0.0, 0.0, 0.0, 0.0),
)
# [rad] the seed wave's amplitude, every joint.
SEED_AMPLITUDE = math.pi / 2
# [rad] the seed wave's phases for Armando: j2 in antiphase with j1 keeps the
# forearm upright, so the arm never folds into the table (in phase, j1 = j2 =
# pi/2 would point it at the floor).
SEED_PHASE = (0.0, 0.0, math.pi, 0.0)


def _seed_targets() -> list[list[float]]:
    return [list(target) for target in SEED_TARGETS]


@dataclasses.dataclass
class PositionTargets:
    """Each target in turn as a Float64MultiArray on a position controller's ``commands``."""

    # [rad or m] joint targets, one list per target with one value per joint
    # (in the controller's joint order); default: SEED_TARGETS.
    targets: list[list[float]] = param(default_factory=_seed_targets, unit="rad or m")
    # [s] time between targets: target k is published at start_delay + k period.
    period: float = param(3.0, unit="s", gt=0)
    # After the last target, start again from the first.
    cyclic: bool = False
    # [s] simulation time of the first publication.
    start_delay: float = param(0.0, unit="s", ge=0)


@dataclasses.dataclass
class JointTrajectoryTargets:
    """All targets as one JointTrajectory on a trajectory controller's ``joint_trajectory``."""

    # [rad or m] the trajectory's points, one list per point with one value
    # per joint (in the controller's joint order); default: SEED_TARGETS.
    targets: list[list[float]] = param(default_factory=_seed_targets, unit="rad or m")
    # [s] point k is reached at time_from_start = (k + 1) period.
    period: float = param(3.0, unit="s", gt=0)
    # Publish the trajectory again every len(targets) period.
    cyclic: bool = False
    # [s] simulation time of the (first) publication.
    start_delay: float = param(0.0, unit="s", ge=0)


@dataclasses.dataclass
class Sinusoid:
    """q_i(t) = offset_i + amplitude_i sin(2 pi frequency (t - start_delay) + phase_i) on
    a position controller's ``commands``, sampled at ``rate``."""

    # [rad or m] amplitude per joint; empty = SEED_AMPLITUDE (pi/2) for every joint.
    amplitude: list[float] = param([], unit="rad or m")
    # [Hz] frequency of the wave.
    frequency: float = param(0.05, unit="Hz", gt=0)
    # [rad] phase per joint; default: SEED_PHASE (Armando's four joints);
    # empty = 0 for every joint.
    phase: list[float] = param(list(SEED_PHASE), unit="rad")
    # [rad or m] centre per joint; empty = 0 for every joint.
    offset: list[float] = param([], unit="rad or m")
    # [Hz] rate at which commands are published; None = the controller rate.
    rate: float | None = param(None, unit="Hz", gt=0)
    # [s] simulation time of the first publication (the wave's t = 0).
    start_delay: float = param(0.0, unit="s", ge=0)


# What drives the controllers; a YAML tag chooses (!PositionTargets, ...).
SequencerConfig = PositionTargets | JointTrajectoryTargets | Sinusoid
# The kind of controller a sequencer feeds, by configuration type: "position" (the
# commands of a group position controller) or "trajectory" (a JointTrajectory); the
# controller registry's kinds (armando_drake.control.controllers.controller_type_for).
CONTROLLER_KIND = {
    PositionTargets: "position",
    JointTrajectoryTargets: "trajectory",
    Sinusoid: "position",
}
# What ``--controller`` calls each configuration.
MODE_NAMES = {
    PositionTargets: "position",
    JointTrajectoryTargets: "trajectory",
    Sinusoid: "sinusoid",
}


def mode_of(config: SequencerConfig) -> str:
    """position | trajectory | sinusoid: the name of ``config``'s mode."""
    return MODE_NAMES[type(config)]


class SequencerError(ConfigError):
    """A sequencer configuration that cannot be run; the message is one line."""


@dataclasses.dataclass(frozen=True)
class Wave:
    """A :class:`Sinusoid` with its per-joint defaults filled in, as arrays."""

    amplitude: np.ndarray  # [rad or m] per joint
    phase: np.ndarray  # [rad] per joint
    offset: np.ndarray  # [rad or m] per joint
    frequency: float  # [Hz]
    start_delay: float  # [s]

    def __call__(self, times) -> np.ndarray:
        """The commands [rad or m] at ``times`` [s] (one row per time), the wave
        itself, not its samples; for checking a run against it."""
        t = np.asarray(times, dtype=float).reshape(-1, 1) - self.start_delay
        return self.offset + self.amplitude * np.sin(2 * np.pi * self.frequency * t + self.phase)


def _per_joint(
    values: Sequence[float], default: float, what: str, joint_names: Sequence[str], prefix: str
) -> np.ndarray:
    if not values:
        return np.full(len(joint_names), default)
    if len(values) != len(joint_names):
        raise SequencerError(
            f"{prefix}{what} has {len(values)} values, expected {len(joint_names)} "
            f"({', '.join(joint_names)})"
        )
    for name, value in zip(joint_names, values, strict=True):
        if not math.isfinite(value):
            raise SequencerError(f"{prefix}{what}: {name}={value!r} is not finite")
    return np.array(values, dtype=float)


def wave_of(config: Sinusoid, joint_names: Sequence[str], source: str = "") -> Wave:
    """The wave of ``config`` with per-joint defaults filled in."""
    prefix = f"{source}: " if source else ""
    return Wave(
        amplitude=_per_joint(config.amplitude, SEED_AMPLITUDE, "amplitude", joint_names, prefix),
        phase=_per_joint(config.phase, 0.0, "phase", joint_names, prefix),
        offset=_per_joint(config.offset, 0.0, "offset", joint_names, prefix),
        frequency=config.frequency,
        start_delay=config.start_delay,
    )


def validate(
    config: SequencerConfig,
    joint_names: Sequence[str],
    lower: Sequence[float],
    upper: Sequence[float],
    source: str = "",
) -> None:
    """Raises :class:`SequencerError` naming the first thing wrong with ``config``: the
    targets or the wave against the joints, then its fields' own rules (declared
    beside them).

    ``lower``/``upper`` [rad or m] are the joint limits in ``joint_names``
    order (+-inf where unlimited). ``source`` (e.g. a file name) prefixes
    every message.
    """
    prefix = f"{source}: " if source else ""
    joint_names = tuple(joint_names)
    n = len(joint_names)
    if len(lower) != n or len(upper) != n:
        raise ValueError(f"{n} joint names but {len(lower)} lower and {len(upper)} upper limits")
    if not isinstance(config, (PositionTargets, JointTrajectoryTargets, Sinusoid)):
        raise SequencerError(
            f"{prefix}sequencer={config!r} is not one of PositionTargets, "
            "JointTrajectoryTargets, Sinusoid"
        )
    if isinstance(config, Sinusoid):
        _check_wave(config, joint_names, lower, upper, source)
    else:
        _check_targets(config, joint_names, lower, upper, prefix)
    check_config(config, origin=lambda _key: source, error=SequencerError)


def _check_wave(config: Sinusoid, joint_names, lower, upper, source: str) -> None:
    prefix = f"{source}: " if source else ""
    wave = wave_of(config, joint_names, source)
    for i, name in enumerate(joint_names):
        reach = abs(float(wave.amplitude[i]))
        centre = float(wave.offset[i])
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


def _check_targets(config, joint_names, lower, upper, prefix: str) -> None:
    n = len(joint_names)
    if not config.targets:
        raise SequencerError(f"{prefix}{type(config).__name__} needs at least one target")
    for k, target in enumerate(config.targets):
        if len(target) != n:
            raise SequencerError(
                f"{prefix}target {k} has {len(target)} values, expected {n} "
                f"({', '.join(joint_names)})"
            )
        for i, (name, value) in enumerate(zip(joint_names, target, strict=True)):
            if not math.isfinite(value):
                raise SequencerError(f"{prefix}target {k}: {name}={value!r} is not finite")
            if value > upper[i]:
                raise SequencerError(
                    f"{prefix}target {k}: {name}={value!r} is above its upper limit {upper[i]!r}"
                )
            if value < lower[i]:
                raise SequencerError(
                    f"{prefix}target {k}: {name}={value!r} is below its lower limit {lower[i]!r}"
                )


def step_times(config: SequencerConfig, end_time: float | None = None) -> list[tuple[float, int]]:
    """(time [s], target index) at which each target becomes the reference.

    Position targets: the time target k is published. Trajectory: the time
    the trajectory starts heading to point k, which it reaches one ``period``
    later. Without ``end_time``, one pass over the targets; with it, every
    step at or before ``end_time`` (cyclic sequences repeat). Empty for the
    sinusoid.
    """
    if isinstance(config, Sinusoid):
        return []
    n = len(config.targets)
    if end_time is None:
        count = n
    else:
        steps = math.floor((end_time - config.start_delay) / config.period + 1e-9) + 1
        count = max(0, steps if config.cyclic else min(steps, n))
    return [(config.start_delay + k * config.period, k % n) for k in range(count)]


def one_pass(config: SequencerConfig) -> float:
    """[s] the end of one pass of the sequence: the last target's period, or one
    period of the wave."""
    if isinstance(config, Sinusoid):
        return config.start_delay + 1.0 / config.frequency
    return config.start_delay + len(config.targets) * config.period


class CommandSequencer(LeafSystem):
    """Publishes a configured sequence of joint targets.

    .. pydrake_system::

        name: CommandSequencer
        output_ports:
        - commands
        - joint_trajectory
        - reference

    - ``commands``: a :class:`~armando_drake.messages.types.Publication` of
      :class:`~armando_drake.messages.types.Float64MultiArray`
      (:class:`PositionTargets`) for a position controller;
    - ``joint_trajectory``: a Publication of
      :class:`~armando_drake.messages.types.JointTrajectory`
      (:class:`JointTrajectoryTargets`) for a joint trajectory controller;
    - ``reference``: vector [rad or m], the target currently commanded, for
      logging and plots; NaN before the first publication. For a trajectory
      it is the point the trajectory is heading to.

    The topic port of the other mode stays at count 0. All three are state
    output ports changed only by a periodic unrestricted update, so reading
    them costs nothing.

    Publication times (``start_delay`` = s, ``period`` = T, n targets):

    - position targets: target k at s + k T, k = 0..n-1; then, if cyclic,
      target k mod n at s + k T for every k; otherwise nothing more;
    - trajectory: one JointTrajectory at s (stamp 0: "start when received")
      whose point k is target k with zero velocities and time_from_start
      (k + 1) T; if cyclic, the same message again every n T.

    ``on_publish(time, topic, message)``, when given, is called once per
    publication (``topic`` is "commands" or "joint_trajectory"), e.g. to
    stream a commands.csv.
    """

    def __init__(
        self,
        *,
        config: PositionTargets | JointTrajectoryTargets,
        joint_names: Sequence[str],
        on_publish: Callable[[float, str, Any], None] | None = None,
    ):
        super().__init__()
        joint_names = tuple(joint_names)
        n = len(joint_names)
        if n == 0:
            raise ValueError("joint_names=() must name at least one joint")
        if isinstance(config, Sinusoid):
            raise ValueError("a Sinusoid is run by SinusoidSequencer (see MakeSequencer)")
        validate(config, joint_names, [-math.inf] * n, [math.inf] * n)
        self._config = dataclasses.replace(
            config, targets=[list(map(float, target)) for target in config.targets]
        )
        self._joint_names = joint_names
        self._on_publish = on_publish

        self._commands_state = self.DeclareAbstractState(PublicationValue())
        self._trajectory_state = self.DeclareAbstractState(PublicationValue())
        self._reference_state = self.DeclareDiscreteState(BasicVector(np.full(n, np.nan)))
        self.DeclareStateOutputPort("commands", self._commands_state)
        self.DeclareStateOutputPort("joint_trajectory", self._trajectory_state)
        self.DeclareStateOutputPort("reference", self._reference_state)

        s, period = config.start_delay, config.period
        if isinstance(config, PositionTargets):
            self.DeclarePeriodicUnrestrictedUpdateEvent(period, s, self._UpdatePosition)
        else:
            cycle = period * len(config.targets)
            self.DeclarePeriodicUnrestrictedUpdateEvent(cycle, s, self._UpdateTrajectory)
            self.DeclarePeriodicUnrestrictedUpdateEvent(period, s, self._UpdateReference)

    @property
    def config(self) -> PositionTargets | JointTrajectoryTargets:
        return self._config

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._joint_names

    def trajectory_message(self) -> JointTrajectory:
        """The JointTrajectory that a JointTrajectoryTargets sequencer publishes."""
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
        """:func:`step_times` of this sequencer's configuration."""
        return step_times(self._config, end_time)

    def flush(self, root_context: Context) -> None:
        """Nothing to do: every publication reached ``on_publish`` when it happened."""

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


# [s] how far the sample clock of a SinusoidSequencer runs; far beyond any run.
_CLOCK_HORIZON = 1e9


def _Affine(gain, offset) -> AffineSystem:
    """The stateless system y = gain u + offset (Drake's AffineSystem, C++)."""
    gain = np.asarray(gain, dtype=float)
    rows, columns = gain.shape
    return AffineSystem(
        A=np.zeros((0, 0)),
        B=np.zeros((0, columns)),
        f0=np.zeros(0),
        C=np.zeros((rows, 0)),
        D=gain,
        y0=np.asarray(offset, dtype=float),
    )


class _SinusoidTopic(LeafSystem):
    """The held sample of a SinusoidSequencer as topics, computed only when read.

    Input ``sample``: [wave - initial (n); count] from the ZeroOrderHold, count =
    the number of samples taken so far (0 before the first).
    """

    def __init__(self, *, n: int, start_delay: float, rate: float, initial: np.ndarray):
        super().__init__()
        self._n = n
        self._initial = np.asarray(initial, dtype=float)
        self._start_delay = start_delay
        self._rate = rate
        self._sample = self.DeclareVectorInputPort("sample", n + 1)
        self.DeclareAbstractOutputPort(
            "commands", PublicationValue, self._CalcCommands, {self._sample.ticket()}
        )
        self.DeclareAbstractOutputPort(
            "joint_trajectory",
            PublicationValue,
            lambda context, output: output.set_value(Publication()),
            {self.nothing_ticket()},
        )
        self.DeclareVectorOutputPort("reference", n, self._CalcReference, {self._sample.ticket()})

    def publication(self, sample: np.ndarray) -> Publication:
        """The Publication of a held ``sample`` [wave; count]."""
        count = round(float(sample[self._n]))
        if count <= 0:
            return Publication()
        stamp = self._start_delay + (count - 1) / self._rate
        data = tuple((sample[: self._n] + self._initial).tolist())
        return Publication(count, Float64MultiArray(data=data), stamp)

    def _CalcCommands(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self.publication(self._sample.Eval(context)))

    def _CalcReference(self, context: Context, output: BasicVector) -> None:
        sample = self._sample.Eval(context)
        if sample[self._n] < 0.5:
            output.SetFromVector(np.full(self._n, np.nan))
        else:
            output.SetFromVector(sample[: self._n] + self._initial)


class _CommandLog(LeafSystem):
    """Hands every sample of a SinusoidSequencer to ``on_publish``, in batches once a
    simulated second: reads the sample count (input ``sample``, as _SinusoidTopic)
    and evaluates ``wave`` at the times of the samples taken since the last batch."""

    def __init__(self, *, n: int, wave: Wave, rate: float, on_publish):
        super().__init__()
        self._n = n
        self._wave = wave
        self._rate = rate
        self._on_publish = on_publish
        self._handled = 0  # samples handed on so far
        self._sample = self.DeclareVectorInputPort("sample", n + 1)
        self.DeclarePeriodicPublishEvent(1.0, 0.0, self.flush)

    def flush(self, context: Context) -> None:
        """Hands the samples taken since the last flush to ``on_publish``."""
        count = round(float(self._sample.Eval(context)[self._n]))
        if count <= self._handled:
            return
        stamps = self._wave.start_delay + np.arange(self._handled, count) / self._rate
        for stamp, values in zip(stamps.tolist(), self._wave(stamps).tolist(), strict=True):
            self._on_publish(stamp, "commands", Float64MultiArray(data=tuple(values)))
        self._handled = count


class SinusoidSequencer(Diagram):
    """Publishes a :class:`Sinusoid`, evaluated and sampled in C++.

    .. pydrake_system::

        name: SinusoidSequencer
        output_ports:
        - commands
        - joint_trajectory
        - reference
        - position_command
        - command_count
        - tick_command
        - tick_count

    Drake's ``Sine`` (plus the offsets) evaluates the wave, a
    ``ZeroOrderHold`` samples it at ``rate`` from ``start_delay`` on, as the
    seed node publishes it on a timer; no Python runs per sample.

    - ``position_command``: vector [rad or m], the latest sample, held until
      the next, and ``initial_positions`` before the first: the command
      stream as a vector, for a consumer that evaluates it in C++ (wired to
      a plant's desired state, it holds the initial pose until the start);
    - ``command_count``: vector of one, the number of samples so far (0
      before the first; sample k, taken at start_delay + k / rate, makes it
      k + 1, to rounding: it is a clock sampled with the wave, so round it);
    - ``commands``: the same sample as a Publication of Float64MultiArray
      (count = ``command_count``, stamp = the sample's time), made in Python
      only when a subscriber reads it;
    - ``joint_trajectory``: always count 0 (the interface of CommandSequencer);
    - ``reference``: the latest sample, NaN before the first;
    - ``tick_command``, ``tick_count`` (only with ``controller_ticks``): the
      same as ``position_command`` and ``command_count``, latched at the
      updates of a controller running at ``controller_rate`` from t = 0 as that
      controller applies them: the sample it reads at an update (the one taken
      before it) from that update on, and what a plant's step at the update's
      time sees. In C++, so a position controller can take the wave as a
      stream (see ControllerManager) bit for bit as it would take the messages.

    Samples are discrete updates: a subscriber updating at a sample's time
    sees the sample before it, as it sees a CommandSequencer's publication
    of that time.

    ``on_publish(time, "commands", message)``, when given, receives every
    sample, in batches once a simulated second and at :meth:`flush`: the
    wave evaluated (in numpy) at the times of the samples taken since the
    last batch, equal to the published samples to rounding.
    """

    def __init__(
        self,
        *,
        config: Sinusoid,
        joint_names: Sequence[str],
        controller_rate: float = 100.0,
        initial_positions: Sequence[float] | None = None,
        on_publish: Callable[[float, str, Any], None] | None = None,
        controller_ticks: bool = False,
    ):
        super().__init__()
        joint_names = tuple(joint_names)
        n = len(joint_names)
        if n == 0:
            raise ValueError("joint_names=() must name at least one joint")
        if not (math.isfinite(controller_rate) and controller_rate > 0):
            raise ValueError(f"controller_rate={controller_rate!r} must be positive [Hz]")
        initial = np.zeros(n) if initial_positions is None else np.asarray(initial_positions, float)
        if initial.shape != (n,) or not np.all(np.isfinite(initial)):
            raise ValueError(f"initial_positions={initial_positions!r} must be {n} finite numbers")
        if not isinstance(config, Sinusoid):
            raise ValueError(f"config={config!r} is not a Sinusoid")
        validate(config, joint_names, [-math.inf] * n, [math.inf] * n)
        self._config = config
        self._joint_names = joint_names
        self._wave = wave_of(config, joint_names)
        self._rate = controller_rate if config.rate is None else config.rate
        s, rate, wave = config.start_delay, self._rate, self._wave

        builder = DiagramBuilder()
        omega = 2 * math.pi * wave.frequency  # [rad/s]
        sine = builder.AddNamedSystem(
            "sine",
            Sine(
                amplitudes=wave.amplitude,
                frequencies=np.full(n, omega),
                phases=wave.phase - omega * s,  # the wave's t = 0 is start_delay
                is_time_based=True,
            ),
        )
        # The hold samples [wave - initial; count], so that its default (zeros, before
        # the first sample) reads as the initial positions and count 0 once the
        # initial positions are added back. The count is a clock sampled with the
        # wave: (t - s) rate + 1, so sample k holds k + 1. Few systems on purpose:
        # each costs the simulator a little at every plant step.
        clock = builder.AddNamedSystem(
            "sample_clock",
            TrajectorySource(
                PiecewisePolynomial.FirstOrderHold(
                    [0.0, _CLOCK_HORIZON], [[1.0 - s * rate, 1.0 + (_CLOCK_HORIZON - s) * rate]]
                )
            ),
        )
        stack = builder.AddNamedSystem("stack", Multiplexer([n, 1]))
        builder.Connect(sine.GetOutputPort("y0"), stack.get_input_port(0))
        builder.Connect(clock.get_output_port(), stack.get_input_port(1))
        shift = builder.AddNamedSystem(
            "offset", _Affine(np.eye(n + 1), np.append(wave.offset - initial, 0.0))
        )
        builder.Connect(stack.get_output_port(), shift.get_input_port())
        hold = builder.AddNamedSystem("sample", ZeroOrderHold(1.0 / rate, n + 1, s))
        builder.Connect(shift.get_output_port(), hold.get_input_port())
        command = builder.AddNamedSystem("position_command", _Affine(np.eye(n, n + 1), initial))
        builder.Connect(hold.get_output_port(), command.get_input_port())
        count = builder.AddNamedSystem("command_count", _Affine(np.eye(1, n + 1, n), [0.0]))
        builder.Connect(hold.get_output_port(), count.get_input_port())
        topic = builder.AddNamedSystem(
            "topic", _SinusoidTopic(n=n, start_delay=s, rate=rate, initial=initial)
        )
        builder.Connect(hold.get_output_port(), topic.GetInputPort("sample"))
        for name in ("commands", "joint_trajectory", "reference"):
            builder.ExportOutput(topic.GetOutputPort(name), name)
        builder.ExportOutput(command.get_output_port(), "position_command")
        builder.ExportOutput(count.get_output_port(), "command_count")
        if controller_ticks:
            # The command as a controller updating at controller_rate from t = 0 applies
            # it: at each update it reads the sample held before the update (as it reads
            # a CommandSequencer's publication) and its command holds until the next
            # update. Drake runs a time's unrestricted updates before its discrete ones
            # (the plant's step, the sample hold's), and an abstract-valued
            # ZeroOrderHold latches with an unrestricted update: so the sample, carried
            # on a bus, is latched at the controller's update times as the controller
            # manager's own update would latch it, and the plant's step at that time
            # sees it, in C++.
            bus = BusCreator()
            bus.DeclareVectorInputPort("sample", n + 1)
            bus_context = bus.CreateDefaultContext()
            bus.get_input_port().FixValue(bus_context, np.zeros(n + 1))
            initial_bus = AbstractValue.Make(bus.get_output_port().Eval(bus_context))
            bus = builder.AddNamedSystem("sample_bus", bus)
            builder.Connect(hold.get_output_port(), bus.get_input_port())
            ticked = builder.AddNamedSystem(
                "tick_sample", ZeroOrderHold(1.0 / controller_rate, initial_bus, 0.0)
            )
            builder.Connect(bus.get_output_port(), ticked.get_input_port())
            unpack = BusSelector()
            unpack.DeclareVectorOutputPort("sample", n + 1)
            unpack = builder.AddNamedSystem("tick_unpack", unpack)
            builder.Connect(ticked.get_output_port(), unpack.get_input_port())
            tick_command = builder.AddNamedSystem(
                "tick_command", _Affine(np.eye(n, n + 1), initial)
            )
            builder.Connect(unpack.get_output_port(), tick_command.get_input_port())
            tick_count = builder.AddNamedSystem("tick_count", _Affine(np.eye(1, n + 1, n), [0.0]))
            builder.Connect(unpack.get_output_port(), tick_count.get_input_port())
            builder.ExportOutput(tick_command.get_output_port(), "tick_command")
            builder.ExportOutput(tick_count.get_output_port(), "tick_count")
        self._log = None
        if on_publish is not None:
            self._log = builder.AddNamedSystem(
                "command_log", _CommandLog(n=n, wave=wave, rate=rate, on_publish=on_publish)
            )
            builder.Connect(hold.get_output_port(), self._log.GetInputPort("sample"))
        builder.BuildInto(self)

    @property
    def config(self) -> Sinusoid:
        return self._config

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._joint_names

    @property
    def rate(self) -> float:
        """[Hz] the sample (publication) rate."""
        return self._rate

    @property
    def wave(self) -> Wave:
        """The wave being sampled."""
        return self._wave

    def step_times(self, end_time: float | None = None) -> list[tuple[float, int]]:
        """Empty: a sinusoid has no steps."""
        return []

    def flush(self, root_context: Context) -> None:
        """Hands the samples recorded since the last flush to ``on_publish``."""
        if self._log is not None:
            self._log.flush(self._log.GetMyContextFromRoot(root_context))


def MakeSequencer(
    *,
    config: SequencerConfig,
    joint_names: Sequence[str],
    controller_rate: float = 100.0,
    initial_positions: Sequence[float] | None = None,
    on_publish: Callable[[float, str, Any], None] | None = None,
    controller_ticks: bool = False,
) -> CommandSequencer | SinusoidSequencer:
    """The sequencer system of ``config``: a :class:`CommandSequencer` for targets and
    trajectories, a :class:`SinusoidSequencer` for a :class:`Sinusoid`.

    ``controller_rate`` [Hz]: the sinusoid's sample rate when its ``rate`` is None;
    ``initial_positions`` [rad or m]: its ``position_command`` before the first sample.
    """
    if isinstance(config, Sinusoid):
        return SinusoidSequencer(
            config=config,
            joint_names=joint_names,
            controller_rate=controller_rate,
            initial_positions=initial_positions,
            on_publish=on_publish,
            controller_ticks=controller_ticks,
        )
    return CommandSequencer(config=config, joint_names=joint_names, on_publish=on_publish)


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


def seed_wave_for(
    lower: Sequence[float], upper: Sequence[float]
) -> tuple[list[float], list[float], list[float]]:
    """(amplitude, phase, offset) [rad or m, rad, rad or m] of the seed's wave sized to
    a robot whose joints have these limits: joint j takes the seed phase of joint
    j mod 4 and the seed amplitude (pi/2), reduced to 40 % of its range if that is
    less; the wave is centred on home (0) unless that would take it within 10 % of
    the range of a limit, then as near home as it can be. Armando (and the iiwa)
    get the seed's wave itself."""
    if len(lower) != len(upper):
        raise ValueError(f"lower={lower!r} and upper={upper!r} differ in length")
    amplitude, phase, offset = [], [], []
    for j, (low, high) in enumerate(zip(lower, upper, strict=True)):
        span = high - low
        reach = min(SEED_AMPLITUDE, 0.4 * span)
        margin = 0.1 * span if math.isfinite(span) else 0.0
        amplitude.append(reach)
        phase.append(SEED_PHASE[j % len(SEED_PHASE)])
        offset.append(min(max(0.0, low + margin + reach), high - margin - reach))
    return amplitude, phase, offset


# --------------------------------------------------------------------------------------
# In a world


def sized_seed(config: SequencerConfig, joints: Sequence, robot_name: str) -> SequencerConfig:
    """``config`` with the seed targets (the default) sized to ``joints`` (hardware
    joints with ``lower``/``upper``; :func:`seed_targets_for`), or the seed's wave
    (:func:`seed_wave_for`); other targets and waves as written."""
    lower, upper = [j.lower for j in joints], [j.upper for j in joints]
    if isinstance(config, Sinusoid):
        if config.amplitude or config.offset or list(config.phase) != list(SEED_PHASE):
            return config
        amplitude, phase, offset = seed_wave_for(lower, upper)
        seed = [SEED_AMPLITUDE] * len(SEED_PHASE), list(SEED_PHASE), [0.0] * len(SEED_PHASE)
        if (amplitude, phase, offset) == seed:
            return config  # the seed's wave itself (Armando)
        _log.info("seed wave sized to the %d joints of %s", len(joints), robot_name)
        return dataclasses.replace(config, amplitude=amplitude, phase=phase, offset=offset)
    targets = getattr(config, "targets", None)
    if not targets or not is_seed(targets):
        return config
    sized = seed_targets_for(lower, upper)
    if not is_seed(sized):
        _log.info(
            "seed targets sized to the %d joints of %s: %s",
            len(joints),
            robot_name,
            " ".join(str([round(v, 3) for v in target]) for target in sized),
        )
    return dataclasses.replace(config, targets=sized)


def stream_controller(config: SequencerConfig | None, managed: Sequence, stack) -> str:
    """The controller that takes the sinusoid ``config`` as a C++ stream, or "".

    A stream needs no Python per sample: the wave is evaluated and sampled in C++
    and checked against the joint limits now, so each sample is accepted as it is,
    and it drives the hardware directly, latched at the manager's ticks. That takes
    a position controller commanding every joint alone (``managed``: the manager's
    controllers; ``stack``: the :class:`~armando_drake.control.stack.ControlStack`
    being built), and samples no faster than the manager's ticks (each one handled
    at one tick); otherwise the samples go through the manager as messages."""
    if not isinstance(config, Sinusoid) or len(managed) != 1:
        return ""
    controller = managed[0]
    logic = controller.logic
    entry = stack.config.controllers[controller.name]
    hardware = stack.hardware
    if not (
        entry.controller_class.message is Float64MultiArray
        and entry.position_targets
        and takes_stream(logic)
        and sorted(logic.joint_names) == sorted(hardware.joint_names)
    ):
        return ""
    if config.rate is not None and not config.rate <= stack.update_rate:
        return ""  # the manager would take only the latest of several samples per tick
    joints = list(logic.joint_names)
    rows = [hardware.joints[i] for i in hardware.find(joints)]
    config = sized_seed(config, rows, stack.robot.name)
    lower = np.array([joint.lower for joint in rows])
    upper = np.array([joint.upper for joint in rows])
    try:
        validate(config, joints, lower, upper)
    except SequencerError:
        return ""  # the sequencer reports it
    # Inside the limits with room for the rounding of the samples, so that the
    # controller would never clamp one.
    wave = wave_of(config, joints)
    reach = np.abs(wave.amplitude)
    room = 1e-9 * (1.0 + np.abs(wave.offset) + reach)
    if np.any(wave.offset + reach > upper - room) or np.any(wave.offset - reach < lower + room):
        return ""
    return controller.name


def _too_fast(config: SequencerConfig, joints: Sequence[str], rows: Sequence) -> str:
    """What the joints' velocity limits keep ``config`` from doing in time, or ""."""
    if isinstance(config, Sinusoid):
        return slowest_wave(rows, wave_of(config, joints).amplitude, config.frequency)
    start = [joint.initial_position for joint in rows]
    return slowest_move(rows, config.targets, start, config.period)


def AddSequencer(
    builder,
    config: SequencerConfig,
    stack,
    *,
    commands_log: Callable[[list[str]], Callable] | None = None,
    where: str = "",
    velocity_limits: bool = False,
):
    """The command sequencer of ``config`` on the first active controller of
    ``stack`` (a :class:`~armando_drake.control.stack.ControlStack`) of the kind its
    configuration feeds (a position or a trajectory controller). ``commands_log``,
    given the joints driven, returns what is called with each command published (the
    commands log). Exports ``reference``;
    returns (the sequencer, the controller it drives). With ``velocity_limits`` (the
    joints capped at their URDF velocity limits) a target or wave the limits keep a
    joint from following in time is said in one warning."""
    kind = CONTROLLER_KIND[type(config)]
    message = JointTrajectory if kind == "trajectory" else Float64MultiArray
    targets = stack.taking(message, position_targets=True)
    if not targets:
        raise ScenarioError(
            f"{where}sequencer !{type(config).__name__} needs an active {kind} controller; "
            f"active: {', '.join(stack.controllers) or 'none'}"
        )
    name = targets[0]
    joints = stack.controller_joints[name]
    rows = stack.joints_of(joints)
    seed = is_seed(getattr(config, "targets", None) or [])
    config = sized_seed(config, rows, stack.robot.name)
    # Seed-style targets clear of collisions; the seed itself was written for the built-in
    # Armando (tests/description/test_physics.py checks it is clear).
    if seed and stack.scene_graph is not None and not is_builtin_armando(stack.robot):
        clear = clear_targets(
            stack.plant,
            stack.scene_graph,
            stack.robot.model_instance,
            joints,
            config.targets,
            [joint.initial_position for joint in rows],
            stack.robot.name,
        )
        config = dataclasses.replace(config, targets=clear)
    validate(
        config,
        joints,
        [joint.lower for joint in rows],
        [joint.upper for joint in rows],
        source=where.rstrip(": "),
    )
    if velocity_limits:
        late = _too_fast(config, joints, rows)
        if late:
            _log.warning("%ssequencer of %s: %s", where, stack.robot.name, late)
    stream = name == stack.stream_controller
    sequencer = builder.AddSystem(
        MakeSequencer(
            config=config,
            joint_names=joints,
            controller_rate=stack.update_rate,
            initial_positions=[joint.initial_position for joint in rows],
            on_publish=commands_log(joints) if commands_log is not None else None,
            controller_ticks=stream,  # the stream as the manager's ticks apply it
        )
    )
    sequencer.set_name("command_sequencer")
    port = "joint_trajectory" if kind == "trajectory" else "commands"
    builder.Connect(sequencer.GetOutputPort(port), stack.command_input(name))
    if stream:
        builder.Connect(
            sequencer.GetOutputPort("tick_count"),
            stack.controllers[name].GetInputPort(f"{name}.command_count"),
        )
    builder.ExportOutput(sequencer.GetOutputPort("reference"), stack.port_name("reference"))
    return sequencer, name
