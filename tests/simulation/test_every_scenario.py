"""Every scenario in diagrams/ and every model in models/ loads and simulates briefly."""

import numpy as np
import pytest
from conftest import REPO, SHARED, skip_or_fail
from pydrake.systems.analysis import Simulator

from armando_drake import DIAGRAMS_DIR, MODELS_DIR
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

SCENARIOS = sorted(p for p in DIAGRAMS_DIR.glob("*.yaml") if p.stem != "display")
MODELS = sorted(p.parent for p in MODELS_DIR.glob("*/package.xml"))


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_scenario_builds_and_simulates(path, monkeypatch):
    # The iiwa scenarios name ../shared/upstream/iiwa_description and our controller
    # YAML relative to the repository, which is where they run from.
    if "../shared/" in path.read_text():
        if not SHARED.is_dir():
            skip_or_fail(f"{path.name} needs {SHARED} (the course's iiwa description)")
        monkeypatch.chdir(REPO)
    scenario = load_scenario(path, "logging: {console_rate: 0}\ncamera: {live_view: false}")
    world = MakeWorld(scenario, quiet=True, source=str(path))
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.2)
    q = world.joint_positions(simulator.get_context())
    assert np.all(np.isfinite(q))
    assert len(q) == len(world.hardware.joints) > 0
    world.close()


@pytest.mark.parametrize("package", MODELS, ids=[p.name for p in MODELS])
def test_model_holds_its_initial_pose_under_position_control(package):
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}}}\nsequencer: null\nlogging: {{console_rate: 0}}",
    )
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    q0 = world.joint_positions(simulator.get_context()).copy()
    simulator.AdvanceTo(1.0)
    drift = np.abs(world.joint_positions(simulator.get_context()) - q0).max()
    assert drift <= 0.01, f"{package.name} drifts {drift:.4f} rad while holding"
    world.close()
