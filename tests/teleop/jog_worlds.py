"""The jog scenario built in this process with a Meshcat, run as fast as possible."""

from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld, World
from armando_drake.simulation.scenario import load_scenario


@dataclass
class JogWorld:
    world: World
    meshcat: Meshcat
    simulator: Simulator

    @property
    def context(self):
        return self.simulator.get_context()

    @property
    def jog(self):
        return self.world.robot().jog

    def q(self) -> np.ndarray:
        """[rad] the measured joint positions, hardware order."""
        return self.world.joint_positions(self.context).copy()

    def end_effector(self) -> np.ndarray:
        """[m] the jogged end effector's position in the world, measured."""
        return self.jog.cartesian.pose(self.q()).translation().copy()

    def advance(self, seconds: float) -> None:
        self.simulator.AdvanceTo(self.context.get_time() + seconds)

    def notes(self) -> list[str]:
        return [n for n in self.meshcat.GetButtonNames() if n.startswith("note: ")]

    def close(self) -> None:
        self.world.close(self.context)


def jog_world(*overrides: str, meshcat: Meshcat | None = None) -> JogWorld:
    """diagrams/jog.yaml with ``overrides``, quiet, unpaced, initialized."""
    scenario = load_scenario("jog", "logging: {console_rate: 0}")
    from armando_drake.simulation.scenario import merge_overrides

    scenario = merge_overrides(
        scenario, ["simulator_config: {target_realtime_rate: 0}", *overrides]
    )
    meshcat = meshcat or Meshcat()
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True, source="jog.yaml")
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    return JogWorld(world=world, meshcat=meshcat, simulator=simulator)


class Pad:
    """Synthetic gamepad states for the jog (its ``gamepad_source``): a standard layout
    with 17 buttons and 4 axes."""

    def __init__(self):
        self.state = Meshcat.Gamepad()  # index None: no gamepad

    def __call__(self) -> Meshcat.Gamepad:
        return self.state

    def set(self, axes=(0.0, 0.0, 0.0, 0.0), pressed=()) -> None:
        state = Meshcat.Gamepad()
        state.index = 0
        buttons = [0.0] * 17
        for index in pressed:
            buttons[index] = 1.0
        state.button_values = buttons
        state.axes = list(axes)
        self.state = state
