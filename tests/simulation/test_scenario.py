"""Scenario files: the tagged unions (sequencer modes, object shapes), overrides, errors."""

import math
from pathlib import Path

import pytest

from armando_drake import DIAGRAMS_DIR
from armando_drake.control.sequencer import (
    SEED_TARGETS,
    JointTrajectoryTargets,
    PositionTargets,
    Sinusoid,
)
from armando_drake.sensors.objects import Box, Cylinder, Sphere
from armando_drake.simulation.scenario import (
    ONE_ROBOT,
    ScenarioError,
    load_scenario,
    merge_overrides,
)

SEED = [list(target) for target in SEED_TARGETS]


@pytest.mark.parametrize(
    "name, kind",
    [
        ("position", PositionTargets),
        ("trajectory", JointTrajectoryTargets),
        ("sinusoid", Sinusoid),
        ("camera", PositionTargets),
        ("world", type(None)),
    ],
)
def test_each_scenario_file_loads_its_sequencer_variant(name, kind):
    sequencer = load_scenario(name).robots[ONE_ROBOT].sequencer
    assert type(sequencer) is kind
    if kind in (PositionTargets, JointTrajectoryTargets):
        assert sequencer.targets == SEED and sequencer.period == 3.0


def test_the_seed_is_written_once():
    # No scenario file repeats the seed targets or the wave: they are the defaults.
    for path in DIAGRAMS_DIR.glob("*.yaml"):
        text = path.read_text()
        assert "1.2, -1.0, 1.2, 0.6" not in text, path
        assert "1.5707963267948966" not in text and "3.14159" not in text, path
    wave = load_scenario("sinusoid").robots[ONE_ROBOT].sequencer
    assert (wave.amplitude, wave.frequency, wave.offset) == ([], 0.05, [])
    assert wave.phase == [0.0, 0.0, math.pi, 0.0]


def test_a_tagged_override_chooses_a_variant_from_its_defaults():
    scenario = load_scenario("position", "sequencer: !Sinusoid {frequency: 0.1}")
    assert scenario.robots[ONE_ROBOT].sequencer == Sinusoid(frequency=0.1)
    scenario = load_scenario("sinusoid", "sequencer: !JointTrajectoryTargets {period: 2}")
    assert scenario.robots[ONE_ROBOT].sequencer == JointTrajectoryTargets(period=2.0)


def test_an_untagged_override_merges_into_the_variant_there():
    scenario = load_scenario("trajectory", "sequencer: {period: 0.5, cyclic: true}")
    assert scenario.robots[ONE_ROBOT].sequencer == JointTrajectoryTargets(period=0.5, cyclic=True)
    scenario = merge_overrides(load_scenario("sinusoid"), ["sequencer: {frequency: 0.2}"])
    assert scenario.robots[ONE_ROBOT].sequencer == Sinusoid(frequency=0.2)
    # Overrides apply in turn; null removes the sequencer.
    scenario = merge_overrides(
        load_scenario("position"), ["sequencer: {period: 5}", "sequencer: {cyclic: true}"]
    )
    assert scenario.robots[ONE_ROBOT].sequencer == PositionTargets(period=5.0, cyclic=True)
    assert load_scenario("position", "sequencer: null").robots[ONE_ROBOT].sequencer is None


def test_object_shapes_load_by_tag_with_the_common_fields():
    scenario = load_scenario(
        "world",
        "objects:\n"
        "- {name: disc, shape: !Cylinder {radius: 0.1, length: 0.02}, xyz: [0.3, 0, 0.01]}\n"
        "- {name: cube, shape: !Box {size: [0.1, 0.2, 0.3]}, collision: false}\n"
        "- {name: ball, shape: !Sphere {radius: 0.03}, color: [0, 1, 0, 1]}\n",
    )
    disc, cube, ball = scenario.objects
    assert disc.shape == Cylinder(radius=0.1, length=0.02) and disc.xyz == [0.3, 0.0, 0.01]
    assert cube.shape == Box(size=[0.1, 0.2, 0.3]) and cube.collision is False
    assert ball.shape == Sphere(radius=0.03) and ball.color == [0.0, 1.0, 0.0, 1.0]
    camera = load_scenario("camera").objects
    assert [type(obj.shape) for obj in camera] == [Cylinder, Box]


def test_simulator_config_and_duration():
    scenario = load_scenario("position")
    assert scenario.simulator_config.target_realtime_rate == 1.0
    assert scenario.simulation.duration == 0.0
    scenario = load_scenario(
        "position", "simulator_config: {target_realtime_rate: 0}\nsimulation: {duration: 4}"
    )
    assert scenario.simulator_config.target_realtime_rate == 0.0
    assert scenario.simulation.duration == 4.0


def one_line_error(tmp_path, text: str) -> str:
    path = tmp_path / "mine.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: "), message
    return message


@pytest.mark.parametrize(
    "text, names",
    [
        ("sequencer: !PositionTargets {perod: 3}\n", ["perod"]),
        ("sequencer: !Sinusoid {targets: [[0, 0, 0, 0]]}\n", ["targets"]),
        ("sequencer: !Velocity {period: 3}\n", ["!Velocity", "!PositionTargets", "!Sinusoid"]),
        (
            "objects: [{name: a, shape: !Cone {radius: 1}}]\n",
            ["!Cone", "!Box", "!Cylinder", "!Sphere"],
        ),
        ("objects: [{name: a, shape: !Sphere {size: [1]}}]\n", ["size"]),
        ("simulation: {realtime_rate: 0}\n", ["realtime_rate"]),
    ],
    ids=["key", "other-variant-key", "tag", "shape-tag", "shape-key", "old-key"],
)
def test_wrong_keys_and_tags_are_one_line_naming_the_file(tmp_path, text, names):
    message = one_line_error(tmp_path, text)
    for name in names:
        assert name in message, message


def test_wrong_tag_in_an_override_names_the_override():
    with pytest.raises(ScenarioError) as error:
        merge_overrides(load_scenario("position"), ["sequencer: !Sine {frequency: 1}"])
    assert str(error.value) == (
        "--set 'sequencer: !Sine {frequency: 1}': sequencer: unknown tag !Sine "
        "(choose !PositionTargets, !JointTrajectoryTargets, !Sinusoid)"
    )


def test_a_bad_object_dimension_is_one_line_naming_the_file_and_object():
    from armando_drake.simulation.builder import MakeWorld

    scenario = load_scenario("world", "objects: [{name: ball, shape: !Sphere {radius: -0.1}}]")
    with pytest.raises(ScenarioError) as error:
        MakeWorld(scenario, quiet=True, source="mine.yaml")
    assert str(error.value) == (
        "override 'objects: [{name: ball, shape: !Sphere {radius: -0.1}}]': objects.0: "
        "object 'ball': Sphere radius=-0.1 must be positive [m]"
    )
    # Written in the file, the file is named (as the caller names it).
    scenario = load_scenario("world")
    scenario.objects = load_scenario(
        "world", "objects: [{name: ball, shape: !Sphere {radius: -0.1}}]"
    ).objects
    with pytest.raises(ScenarioError) as error:
        MakeWorld(scenario, quiet=True, source="mine.yaml")
    assert str(error.value).startswith("mine.yaml: objects.0: object 'ball'")


def test_drakes_unknown_tag_message_is_parsed():
    """The loader reads one message of Drake's: that of an unknown tag. Drake's own words
    are parsed here, so that an upgrade that changes them fails this test."""
    from pydrake.common.yaml import yaml_load_typed

    from armando_drake.simulation.scenario import Scenario, parse_unknown_tag

    with pytest.raises(Exception) as error:  # noqa: PT011 (whatever Drake raises)
        yaml_load_typed(data="sequencer: !Sine {frequency: 1}", defaults=Scenario())
    tag, field, options = parse_unknown_tag(str(error.value))
    assert (tag, field) == ("Sine", "sequencer")
    assert "PositionTargets" in options and "Sinusoid" in options
    with pytest.raises(Exception) as error:  # noqa: PT011
        yaml_load_typed(data="perception: {steps: [!Median {}]}", defaults=Scenario())
    tag, field, options = parse_unknown_tag(str(error.value))
    assert (tag, options.split(", ")[:2]) == ("Median", ["!CropBox", "!VoxelDownsample"])
    assert parse_unknown_tag("Unknown key 'perod'") is None


def test_a_scenario_names_its_controller_yaml_relative_to_itself_from_any_folder(
    tmp_path, monkeypatch
):
    """A relative path in a scenario file: from the working folder where it exists there,
    else from the scenario's folder, else (for diagrams/) from the project's root."""
    monkeypatch.chdir(tmp_path)
    bundled = load_scenario("task_js")
    (config,) = bundled.robots[ONE_ROBOT].controllers.config
    assert Path(config).is_file() and Path(config).name == "iiwa_controllers.yaml", config

    own = tmp_path / "mine"
    (own / "config").mkdir(parents=True)
    (own / "config" / "c.yaml").write_text("controller_manager: {}\n")
    (own / "s.yaml").write_text("controllers: {config: config/c.yaml}\n")
    assert load_scenario(own / "s.yaml").robots[ONE_ROBOT].controllers.config == [
        str(own / "config" / "c.yaml")
    ]
    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "c.yaml").write_text("controller_manager: {}\n")
    assert load_scenario(own / "s.yaml").robots[ONE_ROBOT].controllers.config == [
        "config/c.yaml"
    ]  # cwd first
    (own / "s.yaml").write_text("controllers: {config: [missing.yaml, config/c.yaml]}\n")
    assert load_scenario(own / "s.yaml").robots[ONE_ROBOT].controllers.config == [
        "missing.yaml",
        "config/c.yaml",
    ]  # named as given
