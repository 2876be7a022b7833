"""A scenario's robots are a map from the start: the one robot's top-level keys, a
``robots:`` map and a ``robots:`` list with names all load to the same map of entries,
in the order given; building a world leaves the scenario as it was."""

import dataclasses as dc
import textwrap

import pytest
from pydrake.common.yaml import yaml_dump_typed

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.command import scenario_from_arguments, world_parser
from armando_drake.simulation.scenario import (
    ONE_ROBOT,
    RobotEntry,
    dump_scenario,
    expand_robots,
    load_scenario,
    merge_overrides,
    scenario_robots,
    sources_of,
)
from armando_drake.simulation.validation import check_scenario
from armando_drake.tools.errors import ConfigError, ScenarioError

QUIET = "logging: {console_rate: 0}\nsimulator_config: {target_realtime_rate: 0}"

# One Armando: as the top-level keys, as the robots map's entry and as a list's.
ONE_ROBOT_KEYS = """
robot: {description: "", xacro_args: {use_camera: "false"}}
actuators: {gravity_feedforward: true}
controllers: {activate: [joint_state_broadcaster, position_controller]}
sequencer: !PositionTargets {targets: [[0.1, 0.2, 0.3, 0.4]], period: 1.0}
"""
ENTRY = """    namespace: /
    robot: {description: "", xacro_args: {use_camera: "false"}}
    actuators: {gravity_feedforward: true}
    controllers: {activate: [joint_state_broadcaster, position_controller]}
    sequencer: !PositionTargets {targets: [[0.1, 0.2, 0.3, 0.4]], period: 1.0}
"""


def _load(tmp_path, name: str, text: str):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return load_scenario(path, QUIET)


def test_the_one_robots_keys_a_map_and_a_list_expand_to_the_same_map(tmp_path):
    keys = _load(tmp_path, "keys", ONE_ROBOT_KEYS)
    as_map = _load(tmp_path, "map", f"robots:\n  {ONE_ROBOT}:\n{ENTRY}")
    as_list = _load(tmp_path, "list", f"robots:\n  - name: {ONE_ROBOT}\n{ENTRY}")
    # The loader expands them: right after load, the one robot is the map's only entry.
    expanded = keys.robots
    assert list(expanded) == [ONE_ROBOT] and expanded[ONE_ROBOT].namespace == "/"
    assert expanded == as_map.robots == as_list.robots
    assert expanded[ONE_ROBOT].sequencer.targets == [[0.1, 0.2, 0.3, 0.4]]
    # The one-robot keys are back to their defaults there.
    assert keys.sequencer is None and keys.actuators == RobotEntry().actuators
    assert expand_robots(keys).robots == expanded  # once is enough
    # A scenario's dump keeps the form it was given in, and loads back equal.
    assert dump_scenario(keys).startswith("robot:\n") and "name: robot" not in dump_scenario(keys)
    again = tmp_path / "again.yaml"
    again.write_text(dump_scenario(keys))
    assert load_scenario(again).robots == expanded


def test_an_override_of_the_one_robots_keys_lands_in_its_entry():
    """--set 'actuators: {kp: 4}' on a scenario of the top-level keys sets the entry of
    its one robot (the map is all the code below the loader reads); its origin is the
    --set, under the key the file names."""
    scenario = merge_overrides(
        load_scenario("position"), ["actuators: {kp: 4.0}", "sequencer: {period: 5}"]
    )
    entry = scenario.robots[ONE_ROBOT]
    assert (entry.actuators.kp, entry.sequencer.period) == (4.0, 5.0)
    assert scenario.actuators.kp is None and scenario.sequencer is None
    assert sources_of(scenario).of("actuators.kp").startswith("--set")


def test_a_command_line_option_lands_in_the_robots_map():
    """--controller, --param-file and --description set the entry of the only robot;
    on a scenario of several robots they are an error naming the option."""
    args = world_parser("").parse_args(
        ["--controller", "trajectory", "--param-file", "a.yaml", "--description", "b.urdf"]
    )
    scenario = scenario_from_arguments(load_scenario("position", QUIET), args)
    entry = scenario.robots[ONE_ROBOT]
    assert type(entry.sequencer).__name__ == "JointTrajectoryTargets"
    assert entry.controllers.config == ["a.yaml"] and entry.robot.description == "b.urdf"
    assert scenario.sequencer is None and scenario.controllers.config == []
    for option in (["--controller", "position"], ["--param-file", "a.yaml"]):
        with pytest.raises(ScenarioError, match=f"^{option[0]}: the scenario has 2 robots"):
            scenario_from_arguments(
                load_scenario("dual_armando"), world_parser("").parse_args(option)
            )


def test_the_one_robots_values_are_refused_under_the_files_keys():
    """A bad value of the one robot is named by its top-level key, not robots.robot..."""
    with pytest.raises(ScenarioError) as error:
        check_scenario(load_scenario("position", "actuators: {kp: -1.0}"))
    assert "override 'actuators: {kp: -1.0}': actuators.kp=-1.0" in str(error.value)


def test_the_one_robot_keeps_plain_names_and_its_keys_origins():
    """The one robot of the top-level keys: root namespace, no output subfolder, the
    description's own model instance name, its keys' origins as given (the --set)."""
    scenario = merge_overrides(load_scenario("position"), ["sequencer: {period: 3.0}"])
    (robot,) = scenario_robots(scenario).values()
    assert (robot.name, robot.namespace, robot.folder, robot.model_name) == (
        ONE_ROBOT,
        "",
        "",
        None,
    )
    assert robot.top_level and robot.where("sequencer.period").startswith("--set")
    assert robot.where("actuators.kp") == f"{sources_of(scenario).file}: "


def test_a_robots_list_and_map_load_to_the_same_map_in_their_order(tmp_path):
    """diagrams/fra2mo_armando.yaml's list (fra2mo, then armando mounted on it) and the same
    robots as a map: equal maps, fra2mo first (the loader's own dump sorts a mapping)."""
    listed = load_scenario("fra2mo_armando", QUIET)
    assert list(listed.robots) == ["fra2mo", "armando"]
    entries = "".join(
        f"  {name}:\n" + textwrap.indent(yaml_dump_typed(entry), "    ")
        for name, entry in listed.robots.items()
    )
    path = tmp_path / "as_map.yaml"
    path.write_text(
        dump_scenario(dc.replace(listed, robots={})).replace("robots: []\n", f"robots:\n{entries}")
    )
    as_map = load_scenario(path)
    assert list(as_map.robots) == ["fra2mo", "armando"]
    assert as_map.robots == listed.robots
    # The effective scenario's dump keeps the order too, and loads back equal.
    again = tmp_path / "again.yaml"
    again.write_text(dump_scenario(listed))
    assert load_scenario(again).robots == listed.robots


def test_an_override_of_one_robot_merges_into_its_entry():
    """--set 'robots: {right: {sequencer: {period: 3}}}' changes the right arm's period
    only, keeping its targets and its kind; a list replaces every robot."""
    scenario = load_scenario("dual_armando")
    before = scenario.robots["right"].sequencer
    merged = merge_overrides(scenario, ["robots: {right: {sequencer: {period: 3.0}}}"])
    assert list(merged.robots) == ["left", "right"]
    after = merged.robots["right"].sequencer
    assert type(after) is type(before) and after.targets == before.targets
    assert after.period == 3.0 and merged.robots["left"] == scenario.robots["left"]
    replaced = merge_overrides(scenario, ["robots: [{name: b}, {name: a}]"])
    assert list(replaced.robots) == ["b", "a"] and replaced.robots["a"] == RobotEntry()


@pytest.mark.parametrize(
    ("override", "reason"),
    [
        ("robots: {'1a': {}}", "robots.1a: give a name"),
        ("robots: [{namespace: /a}]", "robots.0.name='': give a name"),
        ("robots: {left: {namespace: 'a b'}}", "robots.left.namespace='a b' is not a namespace"),
        (
            "robots: {left: {namespace: /}, right: {namespace: /}}",
            "robots.right.namespace='/' is another robot's too",
        ),
    ],
)
def test_a_wrong_robots_map_is_one_line_naming_the_key(override, reason):
    with pytest.raises(ConfigError) as error:
        MakeWorld(load_scenario("dual_armando", f"{QUIET}\n{override}"), quiet=True)
    message = str(error.value)
    assert "\n" not in message and reason in message, message


@pytest.mark.parametrize("name", ["position", "fra2mo", "dual_armando", "fra2mo_armando"])
def test_building_a_world_leaves_the_scenario_as_it_was(name):
    """MakeWorld reads the scenario and changes none of its values (the controllers its
    controller file chose are the world's, not written back), one robot or several."""
    scenario = load_scenario(name, QUIET)
    before = dump_scenario(scenario)
    world = MakeWorld(scenario, quiet=True)
    assert dump_scenario(scenario) == before
    assert list(world.robots) == list(scenario_robots(scenario))
    world.close()


def test_a_navigation_beside_the_twist_of_its_robot_is_refused():
    """navigation: and the twist: of the robot it drives would both publish its cmd_vel."""
    with pytest.raises(ScenarioError, match="navigation: both it and twist would publish"):
        check_scenario(load_scenario("fra2mo", "navigation: {params_file: nav2.yaml}"))
