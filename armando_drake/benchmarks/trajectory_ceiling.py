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
stops: its replay is the ceiling of the sinusoid's ratio). The pipeline section
of the benchmark suite reports the same replays for every scenario (with the
position replay as the reference that holds still); this script runs one
scenario alone, against the bench's bare plant.

    python -m armando_drake.benchmarks.trajectory_ceiling [--duration 10] [--runs 5] \
        [--scenario sinusoid]
"""

from __future__ import annotations

import argparse
import statistics

from armando_drake.benchmarks.suite import (
    bare_plant_rtf,
    pipeline_rtf,
    recorded_plant_inputs,
    replay_rtf,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s]")
    parser.add_argument("--runs", type=int, default=5, help="interleaved runs of each")
    parser.add_argument(
        "--scenario", default="trajectory", help="the world replayed (e.g. sinusoid)"
    )
    args = parser.parse_args()
    name = args.scenario

    inputs = recorded_plant_inputs(name, args.duration + 0.5)
    rows = {"bare": [], "replay": [], name: []}
    for _ in range(args.runs):
        rows["bare"].append(bare_plant_rtf(args.duration))
        rows["replay"].append(replay_rtf(inputs, args.duration))
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
