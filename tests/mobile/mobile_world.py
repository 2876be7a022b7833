"""Building and running a mobile robot's world for the tests (short simulated runs)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator

from armando_drake.outputs.base import COLUMNS
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides

FIXTURES = Path(__file__).resolve().parent / "fixtures"
MINIBOT = FIXTURES / "minibot_description"
CLASSIC_BOT = FIXTURES / "classic_bot_description"


@dataclass
class Run:
    world: object
    simulator: Simulator
    rows: np.ndarray  # the base logger's samples (COLUMNS)

    def column(self, name: str) -> np.ndarray:
        return self.rows[:, COLUMNS.index(name)]

    def between(self, name: str, start: float, end: float) -> np.ndarray:
        time = self.column("time")
        return self.column(name)[(time >= start - 1e-9) & (time <= end + 1e-9)]

    def at(self, name: str, time: float) -> float:
        times = self.column("time")
        return float(self.column(name)[np.argmin(np.abs(times - time))])


def scenario(*overrides: str, base: str = "fra2mo"):
    """The scenario ``base`` with the YAML ``overrides`` merged, quiet."""
    loaded = load_scenario(base)
    return merge_overrides(loaded, ["logging: {console_rate: 0}", *overrides])


def run(loaded, duration: float, *, before=None, at: float = 0.0) -> Run:
    """Builds ``loaded`` and simulates it for ``duration`` [s]; ``before(world, context)``
    is called at ``at`` [s]."""
    world = MakeWorld(loaded, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    if before is not None:
        simulator.AdvanceTo(at)
        before(world, simulator.get_mutable_context())
    simulator.AdvanceTo(duration)
    return Run(world, simulator, world.robot().base_log.array())
