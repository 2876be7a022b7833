"""Two Armandos loaded with the xacro prefixes left_ / right_ run the package's controller
YAML, which names the unprefixed joints j0..j3 (read as the prefixed ones, as a launch
file substitutes the prefix); a joint matching neither is a one-line error."""

import io
import json
from pathlib import Path

import pytest

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.run import run
from armando_drake.simulation.scenario import load_scenario
from armando_drake.tools.errors import UserInputError

QUIET = "logging: {console_rate: 0}\nsimulator_config: {target_realtime_rate: 0}"
TOLERANCE = 0.01  # [rad]
DUAL = Path(__file__).parents[2] / "diagrams" / "dual_armando.yaml"


def _prefixed(folder: Path, extra: str = "") -> Path:
    """dual_armando.yaml with the robots' prefixes left_ and right_ (and ``extra`` keys in
    the right robot's entry)."""
    text = DUAL.read_text()
    text = text.replace("  - name: left\n", "  - name: left\n    prefix: left_\n")
    text = text.replace("  - name: right\n", f"  - name: right\n    prefix: right_\n{extra}")
    path = folder / "prefixed.yaml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def prefixed(tmp_path_factory):
    out = tmp_path_factory.mktemp("prefixed")
    scenario = load_scenario(_prefixed(out), QUIET)
    result = run(
        scenario,
        scenario_name="prefixed.yaml",
        output_dir=out,
        quiet=True,
        stream=io.StringIO(),
        replay=False,
        plots=False,
    )
    return json.loads((out / "summary.json").read_text()), result, scenario


def test_prefixed_armandos_reach_their_targets_with_the_unprefixed_yaml(prefixed):
    summary, _, scenario = prefixed
    for name, entry in scenario.robots.items():
        section = summary["robots"][name]
        assert section["joint_names"] == [f"{entry.prefix}j{i}" for i in range(4)]
        assert [step["target"] for step in section["steps"]] == entry.sequencer.targets
        assert section["max_final_error"] <= TOLERANCE, section["max_final_error"]


def test_the_prefix_mapping_is_one_info_line(tmp_path, caplog):
    caplog.set_level("INFO")
    MakeWorld(load_scenario(_prefixed(tmp_path), QUIET), quiet=True)
    lines = [r.getMessage() for r in caplog.records if "without their prefix" in r.getMessage()]
    assert len(lines) == 2, lines
    reading = "without their prefix 'right_': read as right_j0, right_j1, right_j2, right_j3"
    assert lines[1].endswith(reading), lines[1]


def test_a_joint_of_neither_name_is_one_line(tmp_path):
    """The right robot's YAML names j0, j1, j2 (read as right_j0, ...) and k3, neither a
    joint nor a prefixed one: one line naming k3 and the prefixed joints."""
    yaml = tmp_path / "controllers.yaml"
    yaml.write_text(
        "controller_manager:\n  ros__parameters:\n    update_rate: 100\n"
        "    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}\n"
        "    position_controller: {type: position_controllers/JointGroupPositionController}\n"
        "position_controller:\n  ros__parameters:\n    joints: [j0, j1, j2, k3]\n"
    )
    head, activate, tail = _prefixed(tmp_path).read_text().rpartition("      activate:")
    path = tmp_path / "wrong.yaml"
    path.write_text(f"{head}      config: [{yaml}]\n{activate}{tail}")
    with pytest.raises(UserInputError) as error:
        MakeWorld(load_scenario(path, QUIET), quiet=True)
    message = str(error.value)
    assert "\n" not in message, message
    assert "unknown joint 'k3' of controller 'position_controller'" in message, message
    assert "right_j0, right_j1, right_j2, right_j3" in message, message
