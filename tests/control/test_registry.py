"""The controller registry: discovery of the package's modules, controller modules of other
distributions through entry points, queries by kind, and type strings kept in
``control/controllers/``."""

import logging
import pkgutil
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

import armando_drake
from armando_drake.control import controllers
from armando_drake.control.config import load_controller_config, parse_controller_config
from armando_drake.control.controllers import (
    ENTRY_POINT_GROUP,
    Controller,
    controller_kinds,
    controller_type_for,
    default_controller_config,
    find_controller,
    lookup,
    register,
    registered_types,
    unregister,
)
from armando_drake.messages.types import Float64MultiArray
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario

EXTENDING = Path(__file__).resolve().parents[2] / "docs" / "how-to" / "extending.md"
PACKAGE = Path(armando_drake.__file__).resolve().parent
CONTROLLERS = PACKAGE / "control" / "controllers"
# What a ROS controller type string looks like: <package>/<Type>, the package named
# *_controller, *_controllers or *_broadcaster (every type the registry ships is one).
TYPE_STRING = re.compile(r"\b[a-z][a-z0-9_]*_(?:controllers?|broadcaster)/[A-Z]\w*")


# ----------------------------------------------------------------------------------------
# Discovery of the package's modules


def _package_modules() -> list[str]:
    return [m.name for m in pkgutil.iter_modules(controllers.__path__) if m.name[0] != "_"]


def test_discovery_imports_every_module_of_the_package_and_registers_its_types():
    names = _package_modules()
    assert {"broadcaster", "forward_command", "joint_trajectory", "ros1"} <= set(names)
    modules = {f"{controllers.__name__}.{name}" for name in names}
    for module_name in modules:
        module = sys.modules[module_name]  # imported by the package itself
        classes = [
            cls
            for cls in vars(module).values()
            if isinstance(cls, type)
            and issubclass(cls, Controller)
            and cls.__module__ == module_name
            and "type_names" in cls.__dict__
        ]
        assert classes, f"{module_name} registers no controller type"
        for cls in classes:
            for type_name in cls.type_names:
                assert lookup(type_name, ros=cls.ros) is cls
    # And every registered type comes from one of them.
    for ros in (1, 2):
        for type_name in registered_types(ros=ros):
            assert lookup(type_name, ros=ros).__module__ in modules, type_name


def test_each_kind_is_one_registered_type_and_the_default_yaml_loads_them():
    assert controller_kinds() == ("broadcaster", "position", "trajectory")
    for kind in controller_kinds():
        assert controller_type_for(kind) in registered_types()
    assert lookup(controller_type_for("broadcaster")).broadcaster
    with pytest.raises(KeyError, match="no controller type of kind 'gripper'; kinds: broadcaster"):
        controller_type_for("gripper")
    data = default_controller_config(["j1", "j2"], update_rate=50)
    config = parse_controller_config(data, source="<default>")
    assert config.update_rate == 50
    assert {name: c.type for name, c in config.controllers.items()} == {
        name: controller_type_for(kind) for name, kind in controllers.DEFAULT_CONTROLLERS.items()
    }
    assert config.controllers["position_controller"].joints == ["j1", "j2"]
    assert config.controllers["trajectory_controller"].joints == ["j1", "j2"]
    assert config.controllers["joint_state_broadcaster"].joints == []  # every joint
    with pytest.raises(ValueError, match=r"joints=\[\] must name at least one joint"):
        default_controller_config([])


def test_a_kind_is_registered_once():
    with pytest.raises(ValueError, match="kind='position' of 'toy/Other' is already the kind of"):
        register("toy/Other", kind="position")(lookup(controller_type_for("trajectory")))
    assert "toy/Other" not in registered_types()


def test_find_controller_by_name_by_type_and_by_fall_back():
    config = parse_controller_config(default_controller_config(["j0"]), source="default.yaml")
    assert find_controller("position_controller", config) == "position_controller"
    trajectory = controller_type_for("trajectory")
    assert find_controller(f"type:{trajectory}", config) == "trajectory_controller"
    # No group position controller in the file: a ForwardCommandController on position
    # reads the same message on the same interface.
    forward = {
        "controller_manager": {
            "ros__parameters": {
                "fwd": {"type": "forward_command_controller/ForwardCommandController"}
            }
        },
        "fwd": {"ros__parameters": {"joints": ["j0"], "interface_name": "position"}},
    }
    forward = parse_controller_config(forward, source="forward.yaml")
    assert find_controller(f"type:{controller_type_for('position')}", forward) == "fwd"
    with pytest.raises(LookupError) as error:
        find_controller("type:x/Y", config, "s.yaml: ")
    assert str(error.value).startswith("s.yaml: controllers.activate: unknown controller type")
    look_at = next(t for t in registered_types() if lookup(t).topic == "marker_pose")
    with pytest.raises(LookupError) as error:
        find_controller(f"type:{look_at}", config, "s.yaml: ")
    assert str(error.value) == (
        f"s.yaml: controllers.activate asks for a {look_at} controller; default.yaml defines "
        "none (defined: joint_state_broadcaster, position_controller, trajectory_controller)"
    )


def test_the_cli_choices_are_the_sequencer_modes_whose_kind_is_registered(monkeypatch):
    from armando_drake.world import _parser

    def controller_option():
        parser = _parser()
        action = next(a for a in parser._actions if a.dest == "controller")
        return action.choices, " ".join(parser.format_help().split())

    choices, help_text = controller_option()
    assert choices == ["position", "trajectory", "sinusoid", "none"]
    assert controller_type_for("position") in help_text
    assert controller_type_for("trajectory") in help_text
    # Without a trajectory type, no trajectory mode.
    kinds = {k: t for k, t in controllers._KINDS[2].items() if k != "trajectory"}
    monkeypatch.setitem(controllers._KINDS, 2, kinds)
    choices, help_text = controller_option()
    assert choices == ["position", "sinusoid", "none"]
    assert "JointTrajectory" not in help_text


# ----------------------------------------------------------------------------------------
# Type strings stay in control/controllers/


def test_no_file_of_the_package_outside_the_controllers_names_a_type_string():
    known = set(registered_types()) | set(registered_types(ros=1))
    assert all(TYPE_STRING.fullmatch(name) for name in known)  # the pattern sees them all
    offenders = []
    for path in sorted(PACKAGE.rglob("*")):
        if not path.is_file() or "__pycache__" in path.parts or CONTROLLERS in path.parents:
            continue
        text = path.read_bytes().decode("utf-8", errors="replace")
        for number, line in enumerate(text.splitlines(), 1):
            if TYPE_STRING.search(line) or any(name in line for name in known):
                offenders.append(f"{path.relative_to(PACKAGE)}:{number}: {line.strip()}")
    assert offenders == []


# ----------------------------------------------------------------------------------------
# A controller module of another distribution, through an entry point


def _extending_example() -> tuple[str, dict[str, str]]:
    """The Extending guide's "A new controller type": the module's text and its entry points."""
    section = EXTENDING.read_text().split("\n## A new controller type\n", 1)[1]
    section = section.split("\n## ", 1)[0]
    blocks = dict(re.findall(r"```(python|toml)\n(.*?)```", section, re.S))
    header = f'[project.entry-points."{ENTRY_POINT_GROUP}"]'
    assert blocks["toml"].startswith(header + "\n")
    entry_points = dict(re.findall(r'^(\S+) = "(\S+)"$', blocks["toml"], re.M))
    return blocks["python"], entry_points


@pytest.fixture
def install(tmp_path, monkeypatch):
    """Installs a distribution of one module with its ``armando_drake.controllers`` entry
    points in a folder on sys.path, as pip would (``install(module, text, entry_points)``),
    for a registry that has loaded no entry point yet; removes what it registered after."""
    before = {ros: set(registered_types(ros=ros)) for ros in (1, 2)}
    modules = []

    def install(module: str, text: str, entry_points: dict[str, str]) -> None:
        (tmp_path / f"{module}.py").write_text(text)
        dist_info = tmp_path / f"{module}-0.1.dist-info"
        dist_info.mkdir()
        (dist_info / "METADATA").write_text(
            f"Metadata-Version: 2.1\nName: {module}\nVersion: 0.1\n"
        )
        lines = [f"[{ENTRY_POINT_GROUP}]"] + [f"{k} = {v}" for k, v in entry_points.items()]
        (dist_info / "entry_points.txt").write_text("\n".join(lines) + "\n")
        modules.append(module)

    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(controllers, "_entry_points_loaded", False)
    monkeypatch.setattr(controllers, "_loaded_entry_points", set())
    yield install
    monkeypatch.setattr(controllers, "_entry_points_loaded", True)
    for ros, types in before.items():
        for type_name in set(registered_types(ros=ros)) - types:
            unregister(type_name, ros=ros)
    for module in modules:
        sys.modules.pop(module, None)


TOY_TYPE = "toy_controllers/ScaledPositionController"
TOY_YAML = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {{type: joint_state_broadcaster/JointStateBroadcaster}}
    toy: {{type: {type}}}
toy:
  ros__parameters:
    joints: [j0, j1, j2, j3]
    scale: 0.5
"""


def test_the_readme_example_installed_by_entry_point_moves_the_arm(tmp_path, install, caplog):
    text, entry_points = _extending_example()
    assert entry_points == {"toy_controllers": "toy_controllers"}
    install("toy_controllers", text, entry_points)
    assert "toy_controllers" not in sys.modules
    path = tmp_path / "toy.yaml"
    path.write_text(TOY_YAML.format(type=TOY_TYPE))
    config = load_controller_config(path)  # the first lookup imports the entry point
    assert "toy_controllers" in sys.modules
    assert config.controllers["toy"].controller_class is lookup(TOY_TYPE)
    assert config.controllers["toy"].params.scale == 0.5
    assert controllers.load_entry_points() == ()  # once
    scenario = load_scenario(
        "position",
        f"sequencer: null\nlogging: {{console_rate: 0}}\n"
        f"controllers: {{config: {path}, activate: [joint_state_broadcaster, 'type:{TOY_TYPE}']}}",
    )
    world = MakeWorld(scenario, quiet=True)
    assert list(world.robot().stack.controllers) == ["toy"]
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    world.publish(context, "toy", Float64MultiArray(data=(0.8, -1.0, 1.2, 0.4)))
    simulator.AdvanceTo(3.0)
    np.testing.assert_allclose(world.joint_positions(context), [0.4, -0.5, 0.6, 0.2], atol=1e-4)
    with caplog.at_level(logging.ERROR, logger="armando_drake.control.controllers"):
        world.publish(context, "toy", Float64MultiArray(data=(0.1,)))
        simulator.AdvanceTo(3.1)
    assert world.status(context, "toy").last_error == "expected 4 values, got 1"
    world.close()


def test_a_toy_type_not_installed_is_unknown_to_the_world(tmp_path):
    path = tmp_path / "toy.yaml"
    path.write_text(TOY_YAML.format(type=TOY_TYPE))
    scenario = load_scenario(
        "position",
        f"sequencer: null\nlogging: {{console_rate: 0}}\n"
        f"controllers: {{config: {path}, activate: ['type:{TOY_TYPE}']}}",
    )
    with pytest.raises(ScenarioError, match=f"unknown controller type '{TOY_TYPE}'"):
        MakeWorld(scenario, quiet=True)


def test_an_entry_point_that_fails_to_import_is_an_error_naming_it(install):
    install(
        "broken_controllers",
        "raise RuntimeError('no such hardware')\n",
        {"broken": "broken_controllers"},
    )
    with pytest.raises(ImportError) as error:
        lookup(controller_type_for("position"))
    message = str(error.value)
    assert message.startswith("controller module 'broken_controllers' (entry point 'broken' ")
    assert message.endswith("failed to import: RuntimeError: no such hardware")
    assert error.value.name == "broken_controllers"
    with pytest.raises(ImportError, match="'broken_controllers'"):  # at every lookup
        registered_types()


def test_an_entry_point_naming_a_missing_object_is_an_error(install):
    install("empty_controllers", "", {"empty": "empty_controllers:Missing"})
    with pytest.raises(ImportError, match="module 'empty_controllers' has no 'Missing'"):
        controllers.load_entry_points()
