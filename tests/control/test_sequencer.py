"""CommandSequencer: what it publishes, when, and which configurations it rejects."""

import dataclasses
import math

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from armando_drake.control.sequencer import (
    SEED_TARGETS,
    CommandSequencer,
    JointTrajectoryTargets,
    MakeSequencer,
    PositionTargets,
    SequencerError,
    Sinusoid,
    SinusoidSequencer,
    validate,
)
from armando_drake.messages.types import Float64MultiArray, JointTrajectory, PublicationValue

JOINTS = ("j0", "j1", "j2", "j3")
LOWER = [-3.14, -1.57, -2.0, -1.0]
UPPER = [3.14, 1.57, 2.0, 1.0]
TARGETS = [[0.0, 0.0, 0.0, 0.0], [0.5, -0.3, 0.8, 0.1], [-0.5, 0.3, -0.8, -0.1]]


def run(config, end_time, *, controller_rate=100.0):
    """Simulates a bare sequencer to end_time; returns (sequencer, context, publications)."""
    published = []
    builder = DiagramBuilder()
    sequencer = builder.AddSystem(
        MakeSequencer(
            config=config,
            joint_names=JOINTS,
            controller_rate=controller_rate,
            on_publish=lambda time, topic, message: published.append((time, topic, message)),
        )
    )
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(end_time)
    sequencer.flush(simulator.get_context())  # a sinusoid hands on its samples in batches
    context = sequencer.GetMyContextFromRoot(simulator.get_context())
    return sequencer, context, published


def test_position_mode_publishes_each_target_once_per_period():
    config = PositionTargets(targets=TARGETS, period=3.0, start_delay=1.0)
    sequencer, context, published = run(config, 20.0)
    assert [time for time, _, _ in published] == pytest.approx([1.0, 4.0, 7.0])
    assert {topic for _, topic, _ in published} == {"commands"}
    assert [message.data for _, _, message in published] == [tuple(t) for t in TARGETS]
    commands = sequencer.GetOutputPort("commands").Eval(context)
    assert commands.count == 3
    assert commands.message == Float64MultiArray(data=tuple(TARGETS[-1]))
    assert commands.stamp == pytest.approx(7.0)
    assert sequencer.GetOutputPort("joint_trajectory").Eval(context).count == 0
    np.testing.assert_array_equal(sequencer.GetOutputPort("reference").Eval(context), TARGETS[-1])
    assert sequencer.step_times() == [(1.0, 0), (4.0, 1), (7.0, 2)]
    assert sequencer.step_times(end_time=20.0) == [(1.0, 0), (4.0, 1), (7.0, 2)]


def test_position_mode_before_start_delay_publishes_nothing():
    config = PositionTargets(targets=TARGETS, period=3.0, start_delay=2.0)
    sequencer, context, published = run(config, 1.9)
    assert published == []
    assert sequencer.GetOutputPort("commands").Eval(context).count == 0
    assert np.isnan(sequencer.GetOutputPort("reference").Eval(context)).all()


def test_cyclic_position_mode_wraps_around():
    config = PositionTargets(targets=TARGETS, period=3.0, cyclic=True)
    sequencer, context, published = run(config, 16.0)
    # t = 0, 3, 6, 9, 12, 15 -> targets 0, 1, 2, 0, 1, 2
    assert [time for time, _, _ in published] == pytest.approx([0, 3, 6, 9, 12, 15])
    expected = [tuple(TARGETS[k % 3]) for k in range(6)]
    assert [message.data for _, _, message in published] == expected
    assert sequencer.GetOutputPort("commands").Eval(context).count == 6
    assert sequencer.step_times(end_time=16.0) == [(3.0 * k, k % 3) for k in range(6)]


def test_trajectory_mode_publishes_one_trajectory():
    config = JointTrajectoryTargets(targets=TARGETS, period=5.0, start_delay=0.5)
    sequencer, context, published = run(config, 40.0)
    assert len(published) == 1
    time, topic, message = published[0]
    assert (time, topic) == (0.5, "joint_trajectory")
    assert isinstance(message, JointTrajectory)
    assert message.stamp == 0.0
    assert message.joint_names == JOINTS
    assert [p.positions for p in message.points] == [tuple(t) for t in TARGETS]
    assert [p.velocities for p in message.points] == [(0.0,) * 4] * 3
    assert [p.time_from_start for p in message.points] == [5.0, 10.0, 15.0]
    trajectory = sequencer.GetOutputPort("joint_trajectory").Eval(context)
    assert trajectory.count == 1 and trajectory.message == message
    assert sequencer.GetOutputPort("commands").Eval(context).count == 0
    # The reference holds the last target once the trajectory is over.
    np.testing.assert_array_equal(sequencer.GetOutputPort("reference").Eval(context), TARGETS[-1])
    assert sequencer.step_times() == [(0.5, 0), (5.5, 1), (10.5, 2)]


def test_trajectory_reference_follows_the_segment_being_driven():
    config = JointTrajectoryTargets(targets=TARGETS, period=5.0)
    sequencer, context, _ = run(config, 6.0)
    # Between 5 s and 10 s the trajectory heads to target 1.
    np.testing.assert_array_equal(sequencer.GetOutputPort("reference").Eval(context), TARGETS[1])


def test_cyclic_trajectory_mode_republishes_every_cycle():
    config = JointTrajectoryTargets(targets=TARGETS, period=5.0, cyclic=True)
    sequencer, context, published = run(config, 31.0)
    assert [time for time, _, _ in published] == pytest.approx([0.0, 15.0, 30.0])
    assert published[0][2] == published[2][2]
    assert sequencer.GetOutputPort("joint_trajectory").Eval(context).count == 3


def test_sinusoid_mode_publishes_at_the_controller_rate():
    config = Sinusoid(phase=[], start_delay=1.0)
    sequencer, context, published = run(config, 3.0, controller_rate=50.0)
    # 1.00, 1.02, ..., 2.98: the update due at the end time runs in the next step.
    assert len(published) == 100
    times = np.array([time for time, _, _ in published])
    np.testing.assert_allclose(np.diff(times), 0.02, atol=1e-12)
    assert times[0] == pytest.approx(1.0)
    for time, topic, message in published:
        expected = (math.pi / 2) * math.sin(2 * math.pi * 0.05 * (time - 1.0))
        assert topic == "commands"
        np.testing.assert_allclose(message.data, [expected] * 4, atol=1e-12)
    np.testing.assert_allclose(
        sequencer.GetOutputPort("reference").Eval(context), published[-1][2].data
    )
    assert sequencer.step_times() == []


def test_sinusoid_uses_its_own_rate_amplitude_phase_and_offset():
    config = Sinusoid(
        rate=10.0,
        frequency=0.5,
        amplitude=[0.1, 0.2, 0.3, 0.4],
        phase=[0.0, math.pi / 2, 0.0, 0.0],
        offset=[0.0, 0.0, 1.0, -0.5],
    )
    _, _, published = run(config, 0.55, controller_rate=100.0)
    assert len(published) == 6  # 0, 0.1, ..., 0.5
    time, _, message = published[5]
    angle = 2 * math.pi * 0.5 * time  # pi / 2
    np.testing.assert_allclose(
        message.data,
        [0.1 * math.sin(angle), 0.2 * math.sin(angle + math.pi / 2), 1.3, -0.5 + 0.4],
        atol=1e-12,
    )


def test_each_variant_loads_from_yaml_with_its_tag():
    @dataclasses.dataclass
    class Holder:
        sequencer: PositionTargets | JointTrajectoryTargets | Sinusoid | None = None

    def load(text):
        return yaml_load_typed(schema=Holder, data=text).sequencer

    config = load(
        "sequencer: !JointTrajectoryTargets\n"
        "  targets: [[0, 0, 0, 0], [1, 0.5, 0, 0]]\n  period: 5\n  cyclic: true\n"
    )
    assert isinstance(config, JointTrajectoryTargets)
    assert config.targets == [[0.0, 0.0, 0.0, 0.0], [1.0, 0.5, 0.0, 0.0]]
    assert (config.period, config.cyclic, config.start_delay) == (5.0, True, 0.0)
    config = load("sequencer: !PositionTargets {period: 2}")
    assert isinstance(config, PositionTargets)
    assert config.targets == [list(t) for t in SEED_TARGETS] and config.period == 2.0
    config = load("sequencer: !Sinusoid {frequency: 0.1, rate: 50}")
    assert isinstance(config, Sinusoid)
    assert (config.frequency, config.rate) == (0.1, 50.0)
    assert config.phase == [0.0, 0.0, math.pi, 0.0]  # the seed's wave
    assert load("sequencer: null") is None
    # Each variant has only its own fields: a sinusoid's key in targets is an error.
    with pytest.raises(RuntimeError, match="frequency"):
        load("sequencer: !PositionTargets {frequency: 0.1}")
    with pytest.raises(RuntimeError, match="perod"):
        load("sequencer: !PositionTargets {perod: 5}")
    with pytest.raises(RuntimeError, match="'Velocity' did not match"):
        load("sequencer: !Velocity {period: 5}")


def test_valid_configs_pass():
    validate(PositionTargets(targets=TARGETS), JOINTS, LOWER, UPPER)
    validate(Sinusoid(phase=[], amplitude=[1.0] * 4), JOINTS, LOWER, UPPER)


@pytest.mark.parametrize(
    "config, message",
    [
        (
            PositionTargets(targets=[[0, 0, 0, 0], [0, 0, 0, 0], [0, 3.5, 0, 0]]),
            "arm.yaml: target 2: j1=3.5 is above its upper limit 1.57",
        ),
        (
            PositionTargets(targets=[[0, 0, -2.5, 0]]),
            "arm.yaml: target 0: j2=-2.5 is below its lower limit -2.0",
        ),
        (
            PositionTargets(targets=[[0, 0, 0, 0], [0, 0, 0]]),
            "arm.yaml: target 1 has 3 values, expected 4 (j0, j1, j2, j3)",
        ),
        (
            PositionTargets(targets=[[0, math.nan, 0, 0]]),
            "arm.yaml: target 0: j1=nan is not finite",
        ),
        (PositionTargets(targets=TARGETS, period=0.0), "arm.yaml: period=0.0 must be positive"),
        (PositionTargets(targets=TARGETS, period=-3.0), "arm.yaml: period=-3.0 must be positive"),
        (
            JointTrajectoryTargets(targets=[]),
            "arm.yaml: JointTrajectoryTargets needs at least one target",
        ),
        (
            PositionTargets(targets=TARGETS, start_delay=-1.0),
            "arm.yaml: start_delay=-1.0 must be zero or positive",
        ),
        (
            # The default amplitude pi/2 exceeds j1's +-1.57.
            Sinusoid(),
            "arm.yaml: sinusoid: j1 reaches 1.5707963267948966 (offset 0.0 +- amplitude "
            "1.5707963267948966), above its upper limit 1.57",
        ),
        (
            Sinusoid(phase=[], amplitude=[0.5] * 4, offset=[0, 0, 0, -0.7]),
            "arm.yaml: sinusoid: j3 reaches -1.2 (offset -0.7 +- amplitude 0.5), "
            "below its lower limit -1.0",
        ),
        (
            Sinusoid(phase=[], amplitude=[0.5] * 3),
            "arm.yaml: amplitude has 3 values, expected 4 (j0, j1, j2, j3)",
        ),
        (
            Sinusoid(phase=[], amplitude=[0.5] * 4, frequency=0.0),
            "arm.yaml: frequency=0.0 must be positive",
        ),
        (
            Sinusoid(phase=[], amplitude=[0.5] * 4, rate=-10.0),
            "arm.yaml: rate=-10.0 must be positive",
        ),
    ],
)
def test_bad_configs_are_rejected_with_one_line(config, message):
    with pytest.raises(SequencerError) as error:
        validate(config, JOINTS, LOWER, UPPER, source="arm.yaml")
    assert str(error.value).startswith(message)
    assert "\n" not in str(error.value)


def test_make_sequencer_builds_the_system_of_the_variant():
    assert isinstance(
        MakeSequencer(config=Sinusoid(phase=[]), joint_names=JOINTS), SinusoidSequencer
    )
    assert isinstance(
        MakeSequencer(config=JointTrajectoryTargets(targets=TARGETS), joint_names=JOINTS),
        CommandSequencer,
    )
    with pytest.raises(ValueError, match="SinusoidSequencer"):
        CommandSequencer(config=Sinusoid(), joint_names=JOINTS)


def test_sinusoid_vector_ports_hold_the_latest_sample_and_its_count():
    config = Sinusoid(start_delay=0.5, amplitude=[0.2] * 4, phase=[], offset=[0.1, 0, 0, 0])
    sequencer, context, published = run(config, 0.555, controller_rate=100.0)
    count = sequencer.GetOutputPort("command_count").Eval(context)[0]
    command = sequencer.GetOutputPort("position_command").Eval(context)
    assert round(count) == 6 == len(published)  # 0.50, 0.51, ..., 0.55
    assert count == pytest.approx(6, abs=1e-9)
    expected = 0.2 * math.sin(2 * math.pi * 0.05 * 0.05)
    np.testing.assert_allclose(command, [0.1 + expected, expected, expected, expected], atol=1e-12)
    np.testing.assert_allclose(command, published[-1][2].data, atol=1e-12)
    assert sequencer.GetOutputPort("commands").Eval(context).stamp == pytest.approx(0.55)
    assert sequencer.GetOutputPort("joint_trajectory").Eval(context).count == 0
    sequencer, context, _ = run(config, 0.49)
    assert sequencer.GetOutputPort("command_count").Eval(context)[0] == 0
    assert sequencer.GetOutputPort("commands").Eval(context).count == 0
    assert np.isnan(sequencer.GetOutputPort("reference").Eval(context)).all()
    # Before the first sample the vector stream holds the initial positions.
    np.testing.assert_array_equal(sequencer.GetOutputPort("position_command").Eval(context), 0)
    held = SinusoidSequencer(
        config=config, joint_names=JOINTS, initial_positions=[0.1, 0.2, 0.3, 0.4]
    )
    context = held.CreateDefaultContext()
    np.testing.assert_array_equal(
        held.GetOutputPort("position_command").Eval(context), [0.1, 0.2, 0.3, 0.4]
    )
    simulator = Simulator(held, context)
    simulator.AdvanceTo(0.515)  # samples at 0.50 and 0.51: the wave, not the initial pose
    np.testing.assert_allclose(
        held.GetOutputPort("position_command").Eval(context),
        [0.1 + 0.2 * math.sin(2 * math.pi * 0.05 * 0.01)]
        + [0.2 * math.sin(2 * math.pi * 0.05 * 0.01)] * 3,
        atol=1e-12,
    )


def test_sequencer_rejects_structural_errors_without_limits():
    with pytest.raises(SequencerError, match="target 1 has 3 values"):
        CommandSequencer(config=PositionTargets(targets=[[0] * 4, [0] * 3]), joint_names=JOINTS)
    with pytest.raises(SequencerError, match="period=0"):
        CommandSequencer(config=PositionTargets(targets=TARGETS, period=0), joint_names=JOINTS)


class CountReader(LeafSystem):
    """A subscriber like a controller: reads `commands` in a discrete update at 100 Hz."""

    def __init__(self):
        super().__init__()
        self.commands = self.DeclareAbstractInputPort("commands", PublicationValue())
        self.seen = []  # (time [s], publication count) at each update
        self.DeclarePeriodicDiscreteUpdateEvent(0.01, 0.0, self._UpdateSeen)

    def _UpdateSeen(self, context, discrete_state):
        self.seen.append((context.get_time(), self.commands.Eval(context).count))


def test_a_discrete_subscriber_sees_a_command_at_its_publication_time():
    builder = DiagramBuilder()
    config = PositionTargets(targets=TARGETS, period=0.05, start_delay=0.02)
    sequencer = builder.AddSystem(CommandSequencer(config=config, joint_names=JOINTS))
    reader = builder.AddSystem(CountReader())
    builder.Connect(sequencer.GetOutputPort("commands"), reader.commands)
    Simulator(builder.Build()).AdvanceTo(0.1)
    seen = {round(time, 6): count for time, count in reader.seen}
    assert seen[0.01] == 0
    assert seen[0.02] == 1  # published at 0.02, seen at 0.02
    assert seen[0.06] == 1
    assert seen[0.07] == 2
