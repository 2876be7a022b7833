"""Every scenario in diagrams/ and every model in models/ loads and simulates briefly, and
every scenario runs from a clone with nothing beside it (no ../shared)."""

import json
import os
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from conftest import REPO
from pydrake.systems.analysis import Simulator

from armando_drake import DIAGRAMS_DIR, MODELS_DIR
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

SCENARIOS = sorted(p for p in DIAGRAMS_DIR.glob("*.yaml") if p.stem != "display")
MODELS = sorted(p.parent for p in MODELS_DIR.glob("*/package.xml"))


@pytest.mark.parametrize("package", MODELS, ids=[p.name for p in MODELS])
def test_model_holds_its_initial_pose_under_position_control(package):
    # Welded, as an arm is: a mobile robot's wheels then hold their positions too.
    scenario = load_scenario(
        "position",
        f"robot: {{description: {package}, base: fixed}}\nsequencer: null\n"
        "logging: {console_rate: 0}",
    )
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    q0 = world.joint_positions(simulator.get_context()).copy()
    simulator.AdvanceTo(1.0)
    drift = np.abs(world.joint_positions(simulator.get_context()) - q0).max()
    assert drift <= 0.01, f"{package.name} drifts {drift:.4f} rad while holding"
    world.close()


# Runs in a clone: every scenario of its diagrams/ from the command line as a student types
# it without a viewer (`python -m armando_drake.world --scenario NAME --no-meshcat`), in one
# process, each for half a simulated second: past initialisation and the first publish of
# every system.
_RUN_EVERY_SCENARIO = textwrap.dedent(
    """
    import contextlib
    import gc
    import io
    import sys

    from armando_drake import DIAGRAMS_DIR
    from armando_drake.world import main

    for path in sorted(DIAGRAMS_DIR.glob("*.yaml")):
        if path.stem == "display":
            continue
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            code = main(["--scenario", path.stem, "--no-meshcat", "--duration", "0.5"])
        text = printed.getvalue()
        if code != 0 or "0.50 s simulated" not in text:
            print(f"failed {path.stem} (exit {code}):\\n{text}", flush=True)
            sys.exit(1)
        # Freed before the next is built: a world rendering with VTK (EGL) still alive,
        # Drake's OpenGL engine cannot make its context current (an X error ends the run).
        gc.collect()
        print("ran", path.stem, flush=True)
    """
)


def test_every_scenario_runs_from_a_clone_without_shared(tmp_path):
    for path in SCENARIOS:
        text = path.read_text()
        assert "../shared" not in text and "shared/upstream" not in text, path.name
    # A clone of the project's files with no ../shared beside it and no ROS package path:
    # every description and controller file a scenario names is found in the clone.
    clone = tmp_path / "armando-drake"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("armando_drake", "models", "diagrams"):
        shutil.copytree(REPO / name, clone / name, ignore=ignore)
    shutil.copy(REPO / "pyproject.toml", clone)
    assert not (clone.parent / "shared").exists()
    env = {
        k: v for k, v in os.environ.items() if k not in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH")
    }
    env["PYTHONPATH"] = str(clone)
    result = subprocess.run(
        [sys.executable, "-c", _RUN_EVERY_SCENARIO],
        cwd=clone,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    ran = [line.split()[1] for line in result.stdout.splitlines() if line.startswith("ran ")]
    assert ran == [p.stem for p in SCENARIOS]


# The other way a scenario is run from the command line (the first, with neither a viewer
# nor outputs, is the clone's run above): with the live viewer (started at once, exiting at
# the end) and the outputs both on, as a student runs a chapter and keeps what it made. The
# outputs without a viewer (whose replay.html has its own Meshcat) are the README's batch
# command, run by tests/test_docs.py. Each for half a simulated second.
@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_scenario_runs_with_a_viewer_and_with_outputs(path, tmp_path):
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--scenario", path.stem]
        + ["--duration", "0.5", "--no-wait", "--exit-when-done", "--output", str(out)],
        cwd=REPO,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, f"{path.stem}:\n{result.stdout}{result.stderr}"
    assert "0.50 s simulated" in result.stdout, f"{path.stem}:\n{result.stdout}"
    assert (out / "summary.json").is_file() and (out / "replay.html").is_file()
    assert json.loads((out / "summary.json").read_text())
