"""Would a C++ spline generator bring the trajectory scenario to the bare plant's speed?

Issue #12 item 6 asks the trajectory scenario for >= 0.9 of the bare plant's
real-time factor. Today the controller manager writes its state at every 100 Hz
tick of a running trajectory (sample the spline, copy and invalidate the desired
state), and any tick that writes costs 5-10 % of the run by itself. This script
measures the alternative before anyone builds it into the manager: busy ticks
made rare, the spline evaluated between knots by Drake's C++ systems.

A polynomial segment q(t + tau) = sum_i c_i tau^i sampled every h evolves
linearly: c -> Phi c, with Phi the binomial shift c'_j = sum_{i>=j} C(i, j) h^(i-j) c_i
(exact for degree <= 5). The generator built here (:func:`AddSplineGenerator`)
holds, per row of [q_d; v_d], 6 coefficients in a ``ZeroOrderHold`` that loads,
just before each tick, ``MatrixGain(Phi)`` of either its own coefficients or
(``PortSwitch``) those the Python side wrote at its latest event: a reset is a
load, not an additive jump, so no round-off carries across resets. The desired
state is their constant terms clamped into bounds the Python side writes: the
joint limits while the generator runs, the desired state itself (lower = upper)
at an event tick and while holding, so that the output is then bit-exact.

Timing (today's to the bit, and checked): Drake applies a time's unrestricted
updates (the manager's) before its discrete updates, but all discrete updates
of a time (the plant's, a ``ZeroOrderHold``'s) read the same context; so the
hold shifts ``ADVANCE`` before each tick (the plant's update at the tick reads
the new sample), and an event, which only the manager sees at the tick, pins
the output through the bounds. Cost: the output path uses only systems whose
output depends on their inputs alone (``MatrixGain``, ``Saturation``,
``Selector``): a ``PortSwitch``, ``Multiplexer`` or ``Adder`` output depends on
time too, and on the output path it made everything downstream (the plant's
desired state and the world's gravity feed-forward) re-evaluate at every plant
step, which cost what the design saved (measured: 1.00x today's trajectory world).

The Python side (:class:`EventTicks`) still runs at 100 Hz but returns
``DidNothing`` except at an event (start, knots, end) and at the tick after it
(to hand over to the generator): 2 writes per knot instead of one per tick.

Rows, each the median over interleaved runs of ``--duration`` simulated seconds,
as real-time factors by wall-clock time and by the process's CPU time:

- bare: the plant fed by a ``TrajectorySource`` (the suite's reference);
- position, trajectory: the two worlds as ``python -m armando_drake.bench`` runs them;
- generator: the bare plant fed by the generator and the event ticks, playing the
  trajectory controller's own spline (taken from a world run) -- the cost of the
  design without the world's other systems (sequencer, logger, feed-forward),
  which the position world pays as well;
- world+gen: the trajectory world itself with the design patched in
  (:func:`generator_in_world`): what the scenario would reach;

and each one's ratio to the bare-plant run just before it. ``--check`` instead
compares the generator's output at every tick with the controller's spline, and
the arm's motion in the world with the design against today's.

    python benchmarks/trajectory_generator.py [--duration 10] [--runs 5] [--check] [--advance 0]
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import math
import os
import statistics
import time

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import DiagramBuilder, EventStatus, InputPortIndex, LeafSystem
from pydrake.systems.primitives import (
    MatrixGain,
    PortSwitch,
    Saturation,
    Selector,
    SelectorParams,
    ZeroOrderHold,
)

DEGREE = 5  # highest segment degree (quintic)
# [s] the generator shifts its coefficients this long before each tick, so that the plant's
# discrete update at the tick (simultaneous with any other discrete update) reads them;
# less than any plant time step.
ADVANCE = 1e-6
RESET = InputPortIndex(1)  # both switches: input 1 = the Python side's values
PROPAGATE = InputPortIndex(2)  # both switches: input 2 = the generator


def shift_matrix(h: float) -> np.ndarray:
    """Phi: ascending coefficients about t -> about t + h [s], one row of [q_d; v_d]."""
    phi = np.zeros((DEGREE + 1, DEGREE + 1))
    for j in range(DEGREE + 1):
        for i in range(j, DEGREE + 1):
            phi[j, i] = math.comb(i, j) * h ** (i - j)
    return phi


def coefficients_about(trajectory, time: float) -> np.ndarray:
    """(2n, 6) coefficients about ``time`` of the controller's ``_ActiveTrajectory``
    segment active at ``time`` (the held goal after its end)."""
    rows = trajectory.coefficients.shape[1]
    if time >= trajectory.end_time:
        held = np.zeros((rows, DEGREE + 1))
        held[: len(trajectory.goal), 0] = trajectory.goal
        return held
    k = max(bisect.bisect_right(trajectory.breaks, time) - 1, 0)
    return trajectory.coefficients[k] @ shift_matrix(max(time - trajectory.breaks[k], 0.0)).T


class EventTicks(LeafSystem):
    """What the controller manager would do at 100 Hz: nothing, except at an event.

    .. pydrake_system::

        name: EventTicks
        output_ports:
        - coefficients
        - selector
        - bounds

    - ``coefficients``: per row of [q_d; v_d], the 6 coefficients about the latest
      event tick (12n), which the generator loads shifted just before the next tick.
    - ``selector``: ``RESET`` at an event tick (and while holding), ``PROPAGATE``
      from the tick after it while the generator runs the spline.
    - ``bounds``: [lower; upper] of the desired state (4n) [rad, rad/s]: both the
      desired state itself at an event tick and while holding (the output is
      pinned there, bit-exact), the joint limits (made finite) while the generator
      runs.
    """

    def __init__(
        self,
        *,
        trajectory,
        initial: np.ndarray,
        period: float,
        lower: np.ndarray,
        upper: np.ndarray,
    ):
        super().__init__()
        self._trajectory = trajectory
        self._period = period
        self._lower, self._upper = lower, upper
        # [s] start (the message's arrival), knots and end
        self._events = (*trajectory.breaks[:-1], trajectory.end_time)
        rows = trajectory.coefficients.shape[1]
        # A finite bound of every row over every segment (the clamp below needs finite
        # bounds): sum_i |c_i| T^i.
        durations = np.diff(trajectory.breaks)[:, None, None] ** np.arange(DEGREE + 1)
        bound = float(np.max(np.abs(trajectory.coefficients) * durations) * (DEGREE + 1)) + 1.0
        bound = max(bound, float(np.max(np.abs(initial))) + 1.0)
        self._open = np.concatenate([np.clip(lower, -bound, bound), np.clip(upper, -bound, bound)])
        # The manager's initial desired state, held until the start.
        held = np.zeros((rows, DEGREE + 1))
        held[:, 0] = initial
        self._coefficients = self.DeclareDiscreteState(held.reshape(-1))
        self._selector = self.DeclareAbstractState(AbstractValue.Make(RESET))
        self._bounds = self.DeclareDiscreteState(np.concatenate([initial, initial]))
        self.DeclareStateOutputPort("coefficients", self._coefficients)
        self.DeclareStateOutputPort("selector", self._selector)
        self.DeclareStateOutputPort("bounds", self._bounds)
        self.writes = 0  # ticks that changed the state
        self.rows = rows  # rows of [q_d; v_d] (2n)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._Update)

    def _Update(self, context, state) -> EventStatus:
        now = context.get_time()
        selector = context.get_abstract_state(self._selector).get_value()
        event = any(now - self._period < t <= now for t in self._events)
        running = self._trajectory.breaks[0] <= now < self._trajectory.end_time
        if event:
            # The tick of an event: the output pinned to the controller's own (clamped)
            # sample, as the manager writes it today; the segment's coefficients about
            # now for the generator.
            coefficients = coefficients_about(self._trajectory, now)
            x_d = self._trajectory.sample_state(now) if running else coefficients[:, 0]
            x_d = np.clip(x_d, self._lower, self._upper)
            state.get_mutable_discrete_state(self._coefficients).SetFromVector(
                coefficients.reshape(-1)
            )
            state.get_mutable_discrete_state(self._bounds).SetFromVector(np.concatenate([x_d, x_d]))
            state.get_mutable_abstract_state(self._selector).set_value(RESET)
        elif running and selector == RESET:
            # The tick after: the generator takes over within the joint limits.
            state.get_mutable_discrete_state(self._bounds).SetFromVector(self._open)
            state.get_mutable_abstract_state(self._selector).set_value(PROPAGATE)
        else:
            return EventStatus.DidNothing()
        self.writes += 1
        return EventStatus.Succeeded()


def _stack(builder: DiagramBuilder, ports) -> object:
    """``Selector`` concatenating ``ports`` (a Multiplexer's output depends on time
    too, a Selector's on its inputs only)."""
    P = SelectorParams
    inputs = [P.InputPortParams(name=f"in{k}", size=port.size()) for k, port in enumerate(ports)]
    selections = [
        P.OutputSelection(input_port_index=k, input_offset=i)
        for k, port in enumerate(ports)
        for i in range(port.size())
    ]
    stack = builder.AddSystem(
        Selector(P(inputs=inputs, outputs=[P.OutputPortParams(name="y", selections=selections)]))
    )
    for k, port in enumerate(ports):
        builder.Connect(port, stack.get_input_port(k))
    return stack.get_output_port()


def _relu_of(builder: DiagramBuilder, gain: np.ndarray, port) -> object:
    """max(gain @ port, 0): ``MatrixGain`` then ``Saturation`` [0, inf)."""
    linear = builder.AddSystem(MatrixGain(gain))
    builder.Connect(port, linear.get_input_port())
    size = gain.shape[0]
    relu = builder.AddSystem(Saturation(np.zeros(size), np.full(size, np.inf)))
    builder.Connect(linear.get_output_port(), relu.get_input_port())
    return relu.get_output_port()


def AddSplineGenerator(builder: DiagramBuilder, ticks: EventTicks, period: float):
    """The C++ side. A ``ZeroOrderHold`` (period h, offset h - ``ADVANCE``) loads, just
    before each tick, ``MatrixGain(Phi)`` of ``PortSwitch(selector: the event ticks'
    coefficients | its own)``, so it holds the coefficients about the coming tick;
    g, their constant terms, is clamped into the event ticks' [L, U] by
    y = L + max((U - L) - max(U - g, 0), 0), which is clamp(g, L, U) for L <= U and
    exactly L when L = U whatever g is (the second max sees a value <= 0 in any
    rounding). Every system on the output path depends on its inputs only
    (``MatrixGain``, ``Saturation``, ``Selector``): a ``PortSwitch``'s,
    ``Multiplexer``'s or ``Adder``'s output depends on time too, which would
    re-evaluate everything downstream (the plant's desired state, the world's
    gravity feed-forward) at every plant step; the ``PortSwitch`` sits where only
    the hold's update reads it. (Drake's ``Saturation`` with min/max input ports
    would do the clamp in one system, but pydrake 1.51 binds only its
    constant-limit constructor.) Returns (desired-state port, the ZeroOrderHold)."""
    rows = ticks.rows
    size = rows * (DEGREE + 1)
    load = builder.AddSystem(PortSwitch(size))
    builder.Connect(ticks.GetOutputPort("selector"), load.get_port_selector_input_port())
    builder.Connect(ticks.GetOutputPort("coefficients"), load.DeclareInputPort("reset"))
    hold = builder.AddSystem(ZeroOrderHold(period, size, period - ADVANCE))
    builder.Connect(hold.get_output_port(), load.DeclareInputPort("propagate"))
    shift = builder.AddSystem(MatrixGain(np.kron(np.eye(rows), shift_matrix(period))))
    builder.Connect(load.get_output_port(), shift.get_input_port())
    builder.Connect(shift.get_output_port(), hold.get_input_port())
    constant = builder.AddSystem(MatrixGain(np.kron(np.eye(rows), np.eye(1, DEGREE + 1))))
    builder.Connect(hold.get_output_port(), constant.get_input_port())
    identity, zero = np.eye(rows), np.zeros((rows, rows))
    # z = [g; L; U]
    z = _stack(builder, [constant.get_output_port(), ticks.GetOutputPort("bounds")])
    above = _relu_of(builder, np.hstack([-identity, zero, identity]), z)  # max(U - g, 0)
    za = _stack(builder, [z, above])  # [g; L; U; max(U - g, 0)]
    inside = _relu_of(builder, np.hstack([zero, -identity, identity, -identity]), za)
    zc = _stack(builder, [z, inside])  # [g; L; U; max(...)]
    output = builder.AddSystem(MatrixGain(np.hstack([zero, identity, zero, identity])))
    builder.Connect(zc, output.get_input_port())
    return output.get_output_port(), hold


def controller_spline():
    """The trajectory controller's ``_ActiveTrajectory`` in the trajectory scenario, its
    [q_d; v_d] bounds and initial value, and the manager's period [s]."""
    from pydrake.systems.analysis import Simulator

    from armando_drake.benchmarks.suite import NO_CONSOLE
    from armando_drake.simulation.builder import MakeWorld
    from armando_drake.simulation.scenario import load_scenario

    world = MakeWorld(load_scenario("trajectory", NO_CONSOLE), quiet=True)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.05)
    manager = world.controller_manager
    context = manager.GetMyContextFromRoot(simulator.get_context())
    memory = context.get_abstract_state(0).get_value().memories[0]
    logic = manager.controllers[0].logic
    period = 1.0 / world.update_rate
    world.close(simulator.get_context())
    limits = (logic._state_lower, logic._state_upper)
    return memory.trajectory, limits, logic.initial_memory().desired, period


def _timed(diagram, duration: float, prepare=None) -> tuple[float, float]:
    """(wall, CPU) real-time factors of ``duration`` simulated seconds."""
    from pydrake.systems.analysis import Simulator

    simulator = Simulator(diagram)
    if prepare is not None:
        prepare(simulator.get_mutable_context())
    wall, cpu = time.perf_counter(), time.process_time()
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return duration / (time.perf_counter() - wall), duration / (time.process_time() - cpu)


def _plant(builder):
    """The bare plant of the benchmark suite: (plant, robot)."""
    from armando_drake.benchmarks.suite import add_bare_plant

    plant, robot, _ = add_bare_plant(builder, "trajectory")
    return plant, robot


def generator_diagram(spline, limits, initial, period):
    """(diagram, EventTicks, generator's ZeroOrderHold, desired-state port)."""
    builder = DiagramBuilder()
    plant, robot = _plant(builder)
    ticks = builder.AddSystem(
        EventTicks(
            trajectory=spline,
            initial=initial,
            period=period,
            lower=limits[0],
            upper=limits[1],
        )
    )
    desired, hold = AddSplineGenerator(builder, ticks, period)
    builder.Connect(desired, plant.get_desired_state_input_port(robot.model_instance))
    builder.ExportOutput(desired, "desired_state")
    diagram = builder.Build()
    return diagram, ticks, hold, diagram.GetOutputPort("desired_state")


def check(spline, limits, initial, period, duration: float) -> None:
    """Largest |generator - controller spline| over the ticks."""
    from pydrake.systems.analysis import Simulator

    diagram, ticks, _, desired = generator_diagram(spline, limits, initial, period)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    worst, worst_exact = 0.0, 0.0
    for k in range(int(round(duration / period))):
        now = k * period
        simulator.AdvanceTo(now + period / 2)
        q_d, v_d, _ = spline.sample(now)
        expected = np.clip(np.concatenate([q_d, v_d]), *limits)
        error = np.abs(np.asarray(desired.Eval(context)) - expected).max()
        worst = max(worst, error)
        if now >= spline.end_time:  # the held goal must be exact
            worst_exact = max(worst_exact, error)
    print(f"generator vs controller spline over {duration:g} s: max |error| {worst:.3g}")
    print(f"  after the end (held goal): max |error| {worst_exact:.3g}")
    print(f"  ticks that wrote state: {ticks.writes} of {int(round(duration / period))}")


def compare_worlds(spline, limits, initial, period, times=(1.0, 3.5, 6.5, 10.0)) -> None:
    """Largest |q today - q with the generator| of the trajectory world's arm at ``times``."""
    from pydrake.systems.analysis import Simulator

    from armando_drake.benchmarks.suite import NO_CONSOLE
    from armando_drake.simulation.builder import MakeWorld
    from armando_drake.simulation.scenario import load_scenario

    def positions(patch) -> np.ndarray:
        rows = []
        with patch():
            world = MakeWorld(load_scenario("trajectory", NO_CONSOLE), quiet=True)
            simulator = Simulator(world.diagram)
            for time_ in times:
                simulator.AdvanceTo(time_)
                rows.append(np.array(world.joint_positions(simulator.get_context())))
        world.close(simulator.get_context())
        return np.array(rows)

    today = positions(contextlib.nullcontext)
    generated = positions(lambda: generator_in_world(spline, limits, initial, period))
    for time_, error in zip(times, np.abs(today - generated).max(axis=1), strict=True):
        print(f"world at {time_:g} s: max |q today - q with the generator| {error:.3g} rad")


@contextlib.contextmanager
def generator_in_world(spline, limits, initial, period):
    """While active, a world built by ``MakeWorld`` is the trajectory world as the
    design would make it, by patching (this experiment only):

    - the trajectory controller returns its memory unchanged on a tick inside a
      segment (no path tolerance is set in the scenario), and the manager treats an
      unchanged memory as no change, so such a tick returns ``DidNothing``;
    - the actuators' desired state (and the gravity feed-forward) come from the
      generator and :class:`EventTicks` playing the controller's spline.

    Everything else (sequencer, logger, broadcaster, feed-forward chain) is the world's.
    """
    from armando_drake.control import manager as manager_module
    from armando_drake.control.controllers import joint_trajectory
    from armando_drake.simulation import builder as builder_module

    manager_class = manager_module.ControllerManager
    controller_class = joint_trajectory.JointTrajectoryController
    saved = (
        manager_class._Update,
        controller_class.update,
        builder_module.ConnectHardwareInterface,
    )
    original_update, original_connect = saved[1], saved[2]

    def update(self, now, message, memory, measure):
        trajectory = memory.trajectory
        if message is None and memory.busy and trajectory.breaks and now < trajectory.end_time:
            return memory  # the generator plays the segment
        return original_update(self, now, message, memory, measure)

    def manager_update(self, context, state):
        memories = context.get_abstract_state(self._memory_index).get_value()
        items = memories.memories
        changed = False
        for k, controller in enumerate(self._controllers):
            port = self._command_ports[k]
            if port.HasValue(context) and port.Eval(context).count > memories.handled[k]:
                changed = True
            elif items[k].busy:
                x = self._state.Eval(context) if self._state.HasValue(context) else None
                measure = manager_module._Measure(x, *self._measured_rows[k])
                changed |= (
                    controller.logic.update(context.get_time(), None, items[k], measure)
                    is not items[k]
                )
        if not changed:
            return EventStatus.DidNothing()
        return saved[0](self, context, state)

    def connect(builder, plant, robot, hardware, *, desired_state, **kwargs):
        ticks = builder.AddSystem(
            EventTicks(
                trajectory=spline,
                initial=initial,
                period=period,
                lower=limits[0],
                upper=limits[1],
            )
        )
        generated, _ = AddSplineGenerator(builder, ticks, period)
        return original_connect(builder, plant, robot, hardware, desired_state=generated, **kwargs)

    manager_class._Update = manager_update
    controller_class.update = update
    builder_module.ConnectHardwareInterface = connect
    try:
        yield
    finally:
        manager_class._Update, controller_class.update = saved[0], saved[1]
        builder_module.ConnectHardwareInterface = saved[2]


def main() -> None:
    global ADVANCE  # noqa: PLW0603 -- the experiment's one knob
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s]")
    parser.add_argument("--runs", type=int, default=5, help="interleaved runs of each")
    parser.add_argument("--check", action="store_true", help="compare with the spline only")
    parser.add_argument(
        "--advance",
        type=float,
        default=ADVANCE,
        help="[s] how long before each tick the generator shifts; 0 = at the tick, "
        "which saves a simulator stop per tick but is WRONG (the plant reads the hold's "
        "previous value for one step after each tick): for the cost comparison only",
    )
    args = parser.parse_args()
    ADVANCE = args.advance

    from armando_drake.benchmarks.suite import NO_CONSOLE
    from armando_drake.simulation.builder import MakeWorld
    from armando_drake.simulation.scenario import load_scenario

    spline, limits, initial, period = controller_spline()
    if args.check:
        check(spline, limits, initial, period, 15.0)
        compare_worlds(spline, limits, initial, period)
        return

    def world(name, patch=contextlib.nullcontext):
        with patch():
            made = MakeWorld(load_scenario(name, NO_CONSOLE), quiet=True)
            result = _timed(made.diagram, args.duration)
        made.close()
        return result

    def world_generator():
        return world("trajectory", lambda: generator_in_world(spline, limits, initial, period))

    def bare():
        from pydrake.systems.primitives import TrajectorySource
        from pydrake.trajectories import PiecewisePolynomial

        from armando_drake.benchmarks.suite import TARGET_PERIOD, TARGETS

        builder = DiagramBuilder()
        plant, robot = _plant(builder)
        n = len(TARGETS[0])
        columns = [np.concatenate([target, np.zeros(n)]) for target in TARGETS]
        times = [k * TARGET_PERIOD for k in range(len(TARGETS) + 1)]
        columns.append(columns[-1])
        source = builder.AddSystem(
            TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, np.stack(columns, axis=1)))
        )
        builder.Connect(
            source.get_output_port(), plant.get_desired_state_input_port(robot.model_instance)
        )
        return _timed(builder.Build(), args.duration)

    def generator():
        diagram, _, _, _ = generator_diagram(spline, limits, initial, period)
        return _timed(diagram, args.duration)

    rows = {"bare": [], "position": [], "trajectory": [], "generator": [], "world+gen": []}
    for _ in range(args.runs):
        rows["bare"].append(bare())
        rows["position"].append(world("position"))
        rows["trajectory"].append(world("trajectory"))
        rows["generator"].append(generator())
        rows["world+gen"].append(world_generator())
    print(f"load average {os.getloadavg()[0]:.2f}, {args.runs} interleaved runs")
    for name, values in rows.items():
        wall = statistics.median(v[0] for v in values)
        cpu = statistics.median(v[1] for v in values)
        print(f"{name:>11}: {wall:6.2f} x real time (wall), {cpu:6.2f} (CPU)")
    for name in ("position", "trajectory", "generator", "world+gen"):
        for column, label in ((0, "wall"), (1, "CPU")):
            ratios = [a[column] / b[column] for a, b in zip(rows[name], rows["bare"], strict=True)]
            print(
                f"{name} / bare, {label}: {statistics.median(ratios):.3f} "
                f"(min {min(ratios):.3f}, max {max(ratios):.3f})"
            )


if __name__ == "__main__":
    main()
