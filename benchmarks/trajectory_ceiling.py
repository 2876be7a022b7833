"""How much of the trajectory scenario's cost is physics, how much is the controllers.

The pipeline benchmark (``python -m armando_drake.bench --only pipeline``) divides
the trajectory scenario's real-time factor by that of the bare plant whose PD
actuators hold each seed target for 3 s (a ``TrajectorySource`` with zero-order
holds). But a plant that follows a smooth trajectory costs more to step than one
that sits still between jumps (the discrete solver works harder while the arm
moves). This script adds the missing row: the bare plant driven by C++
``TrajectorySource``s that play back the trajectory controller's own desired
state and the world's gravity feed-forward (sampled at its 100 Hz ticks from a
world run, so the arm moves as in the world), with no Python at all. The
figures, each the median over interleaved runs:

- replay / bare: what the physics of the motion costs (the ceiling of the
  trajectory scenario's ratio);
- trajectory / replay: what the controllers, the gravity feed-forward, the
  sequencer and the logger cost on top.

``--scenario sinusoid`` does the same for the sinusoid world (whose arm never
stops: its replay is the ceiling of the sinusoid's ratio).

    python benchmarks/trajectory_ceiling.py [--duration 10] [--runs 5] [--scenario sinusoid]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def replayed_desired_state(
    duration: float, scenario: str = "trajectory"
) -> tuple[list[float], np.ndarray, np.ndarray | None]:
    """(tick times [s], desired states (2n x ticks), gravity feed-forward torques (n x
    ticks) or None without one) of the scenario: the plant's inputs, which change only
    at the ticks."""
    from pydrake.systems.analysis import Simulator

    from armando_drake.benchmarks.suite import NO_CONSOLE
    from armando_drake.simulation.builder import MakeWorld
    from armando_drake.simulation.scenario import load_scenario

    world = MakeWorld(load_scenario(scenario, NO_CONSOLE), quiet=True)
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    port = world.diagram.GetOutputPort("desired_state")
    feedforward = world.gravity_feedforward
    period = 1.0 / world.update_rate
    times, samples, torques = [], [], []
    for k in range(int(round(duration / period)) + 1):
        simulator.AdvanceTo(k * period + period / 2)
        times.append(k * period)
        samples.append(np.array(port.Eval(context)))
        if feedforward is not None:
            owner = feedforward.get_system().GetMyContextFromRoot(context)
            torques.append(np.array(feedforward.Eval(owner)))
    world.close(context)
    return times, np.stack(samples, axis=1), np.stack(torques, axis=1) if torques else None


def replay_rtf(
    times: list[float],
    samples: np.ndarray,
    duration: float,
    scenario: str = "trajectory",
    feedforward: np.ndarray | None = None,
) -> float:
    """Real-time factor of the bare plant following the replayed desired state (and the
    replayed feed-forward on its actuation input, when given: the world's motion)."""
    from pydrake.multibody.plant import AddMultibodyPlant, ApplyMultibodyPlantConfig
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    from armando_drake.control.hardware import AddHardwareInterface, FinishHardwareInterface
    from armando_drake.description.loader import load_robot
    from armando_drake.simulation.builder import _add_ground
    from armando_drake.simulation.scenario import load_scenario

    scenario = load_scenario(scenario)
    config = scenario.plant_config
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(config, builder)
    ApplyMultibodyPlantConfig(config, plant)
    robot = load_robot(plant)
    _add_ground(plant)
    actuators = scenario.actuators
    hardware = AddHardwareInterface(plant, robot, kp=actuators.kp, kd=actuators.kd)
    plant.Finalize()
    FinishHardwareInterface(plant, robot, hardware)
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, samples)))
    builder.Connect(
        source.get_output_port(), plant.get_desired_state_input_port(robot.model_instance)
    )
    if feedforward is not None:
        torque = builder.AddSystem(
            TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, feedforward))
        )
        builder.Connect(
            torque.get_output_port(), plant.get_actuation_input_port(robot.model_instance)
        )
    simulator = Simulator(builder.Build())
    start = time.perf_counter()
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return duration / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s]")
    parser.add_argument("--runs", type=int, default=5, help="interleaved runs of each")
    parser.add_argument(
        "--scenario", default="trajectory", help="the world replayed (e.g. sinusoid)"
    )
    args = parser.parse_args()
    name = args.scenario

    from armando_drake.benchmarks.suite import bare_plant_rtf, pipeline_rtf

    times, samples, feedforward = replayed_desired_state(args.duration + 0.5, name)
    rows = {"bare": [], "replay": [], name: []}
    for _ in range(args.runs):
        rows["bare"].append(bare_plant_rtf(args.duration))
        rows["replay"].append(replay_rtf(times, samples, args.duration, name, feedforward))
        rows[name].append(pipeline_rtf(name, args.duration))
    for row, values in rows.items():
        print(f"{row:>10}: {statistics.median(values):6.2f} x real time")
    for a, b in (("replay", "bare"), (name, "replay"), (name, "bare")):
        ratios = [x / y for x, y in zip(rows[a], rows[b], strict=True)]
        print(
            f"{a} / {b}: {statistics.median(ratios):.3f} "
            f"(min {min(ratios):.3f}, max {max(ratios):.3f})"
        )


if __name__ == "__main__":
    main()
