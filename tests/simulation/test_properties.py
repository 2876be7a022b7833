"""Property-based tests of every input of a run (Hypothesis).

Generated scenario overrides (NaN, inf, huge, negative, wrong types, unknown keys,
tags), generated controller YAML, mutated robot descriptions and generated command
and trajectory messages into running controllers. The properties:

- an input is accepted or refused with an input error (one line, exit 2 on the
  command line), never another exception, a traceback or a hang;
- an accepted input does what it says: the effective scenario holds the values asked
  for, it round-trips through ``scenario.yaml``, and a run writes no NaN;
- a controller takes or drops each message (counted), and never drives a joint out of
  its limits or to NaN.

Most properties are checked in this process; :func:`test_the_command_line_property` runs
the command itself on a few examples. Profiles (tests/conftest.py): the default one is
derandomized and small; ``pytest --hypothesis-profile long`` draws many more.
"""

import csv
import dataclasses as dc
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import MINI_URDF
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from armando_drake.simulation.scenario import (
    ONE_ROBOT,
    ROBOT_KEYS,
    Scenario,
    ScenarioError,
    load_scenario,
    merge_overrides,
)
from armando_drake.simulation.validation import check_scenario
from armando_drake.tools.errors import UserInputError
from armando_drake.tools.schema import leaves as _walk
from armando_drake.tools.schema import rule_at

INPUT_ERRORS = (ScenarioError,)  # InputError, SequencerError... are ValueErrors too
EXAMPLES = settings().max_examples  # the profile's
FEW = max(2, EXAMPLES // 10)  # for the slow properties


def _input_errors():
    """What the commands report as a mistake in the input (one line, exit 2)."""
    return (UserInputError,)


# ---------------------------------------------------------------- YAML of generated values


def yaml_text(value) -> str:
    """``value`` as YAML flow text (NaN as .nan, strings quoted)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, float):
        if math.isnan(value):
            return ".nan"
        if math.isinf(value):
            return ".inf" if value > 0 else "-.inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(yaml_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {yaml_text(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def nested(key: str, value) -> dict:
    """``{"a": {"b": value}}`` for ``key`` "a.b"."""
    *parents, leaf = key.split(".")
    data = {leaf: value}
    for parent in reversed(parents):
        data = {parent: data}
    return data


# ---------------------------------------------------------------- strategies

NASTY_FLOATS = st.sampled_from([math.nan, math.inf, -math.inf, 1e300, -1e300, 0.0, -1.0, 1e-12])
FLOATS = st.one_of(NASTY_FLOATS, st.floats(-1e4, 1e4), st.floats(allow_nan=True))
ANY_SCALAR = st.one_of(
    FLOATS, st.integers(-(10**6), 10**6), st.booleans(), st.none(), st.text(max_size=8)
)


def _keys(scenario: Scenario) -> dict[str, object]:
    """The scenario's leaves that an override sets: scalars and whole lists, by key."""
    return {
        key: value
        for key, value in _walk(scenario, "")
        if key
        and not any(part.isdigit() for part in key.split("."))
        and (value is None or isinstance(value, (bool, int, float, str, list, tuple)))
    }


def _as_file(scenario: Scenario) -> Scenario:
    """``scenario`` with its one robot's keys at the top level, as its file gives them."""
    entry = scenario.robots[ONE_ROBOT]
    return dc.replace(scenario, robots={}, **{key: getattr(entry, key) for key in ROBOT_KEYS})


BASE_KEYS = _keys(_as_file(load_scenario("position")))
# Names with a fixed set of choices (declared beside their fields): key -> the choices.
CHOICES = {
    key: rule.choice_list()
    for key in BASE_KEYS
    if (rule := rule_at(_as_file(load_scenario("position")), key)) is not None
    and rule.choices is not None
    and not callable(rule.choices)
}
# Keys that open servers, render, or read other files: left to their own tests.
SIDE_EFFECTS = (
    "camera.enabled",
    "camera.live_view",
    "camera.save_frames",
    "ros2.",
    "visualization.",
    "robot.description",
    "robot.package_paths",
    "robot.xacro_args",
    "controllers.config",
)


def plausible(key: str, current):
    """Values a user would mean for the field ``key`` that now holds ``current``: near it,
    of its type, one of its choices."""
    if key in CHOICES:
        return st.sampled_from(CHOICES[key])
    if isinstance(current, bool):
        return st.booleans()
    if isinstance(current, int):
        return st.integers(0, 2 * max(current, 1))
    if isinstance(current, float):
        scale = abs(current) or 1.0
        return st.floats(0.5 * scale, 2.0 * scale) if current >= 0 else st.floats(-scale, scale)
    if isinstance(current, (list, tuple)) and current and isinstance(current[0], float):
        return st.lists(st.floats(-0.1, 0.1), min_size=len(current), max_size=len(current))
    return st.just(current)


def value_like(key: str, current):
    """Values for the field ``key``: plausible ones, of its type but nasty, or of another type."""
    if isinstance(current, bool):
        typed = st.booleans()
    elif isinstance(current, (int, float)):
        typed = st.one_of(FLOATS, st.integers(-(10**9), 10**9))
    elif isinstance(current, str):
        typed = st.one_of(
            st.sampled_from(["", "lagged", "sap", "auto", "vtk"]), st.text(max_size=6)
        )
    elif isinstance(current, (list, tuple)):
        typed = st.lists(st.one_of(FLOATS, st.lists(FLOATS, max_size=5)), max_size=6)
    else:
        typed = ANY_SCALAR
    return st.one_of(plausible(key, current), typed, ANY_SCALAR, st.lists(ANY_SCALAR, max_size=3))


@st.composite
def overrides(draw, keys=tuple(BASE_KEYS), allow_unknown=True) -> str:
    """One ``--set`` text: a few keys of the scenario with generated values, sometimes an
    unknown key or a tagged sequencer."""
    parts = []
    for key in draw(st.lists(st.sampled_from(sorted(keys)), min_size=1, max_size=3, unique=True)):
        parts.append(nested(key, draw(value_like(key, BASE_KEYS[key]))))
    text = "\n".join(yaml_text(part)[1:-1] for part in parts)
    choice = draw(st.integers(0, 9))
    if allow_unknown and choice == 8:
        text += f"\nactuators: {{{draw(st.sampled_from(['kq', 'gain', 'kp_']))}: 1}}"
    elif choice == 9:
        tag = draw(st.sampled_from(["Sinusoid", "PositionTargets", "JointTrajectoryTargets"]))
        field = draw(st.sampled_from(["frequency", "period", "rate", "start_delay", "amplitude"]))
        text += f"\nsequencer: !{tag} {{{field}: {yaml_text(draw(FLOATS))}}}"
    return text


def value_at(scenario, key: str):
    """The value at the dotted ``key`` as the file names it (the one robot's keys are its
    entry's in the robots map)."""
    value = scenario
    if key.split(".")[0] in ROBOT_KEYS:
        value = scenario.robots[ONE_ROBOT]
    for part in key.split("."):
        value = value[part] if isinstance(value, dict) else getattr(value, part)
    return value


def same(asked, got) -> bool:
    if isinstance(asked, (list, tuple)):
        return len(asked) == len(got) and all(same(a, g) for a, g in zip(asked, got, strict=True))
    if isinstance(asked, float) and math.isnan(asked):
        return isinstance(got, float) and math.isnan(got)
    return asked == got


# ---------------------------------------------------------------- scenario overrides


@given(text=overrides())
def test_an_override_is_checked_or_refused_with_an_input_error(text):
    """Every generated override: merged and checked, or refused by a ScenarioError naming
    the override; once accepted, every number is finite and the values are those asked."""
    try:
        scenario = merge_overrides(load_scenario("position"), [text])
        check_scenario(scenario)
    except INPUT_ERRORS as error:
        message = str(error)
        assert "\n" not in message
        assert f"--set {text!r}" in message, message
        return
    for key, value in _walk(scenario, ""):
        if isinstance(value, float):
            assert math.isfinite(value), (key, value)
    # What was asked is what the scenario holds.
    from pydrake.common.yaml import yaml_load

    for key in _leaves(yaml_load(data=text)):
        asked = _get(yaml_load(data=text), key)
        assert same(_typed(asked, value_at(scenario, key)), value_at(scenario, key)), key


def _leaves(data, prefix=""):
    if not isinstance(data, dict) or "_tag" in data:
        return [prefix]
    keys = []
    for name, value in data.items():
        keys += _leaves(value, f"{prefix}.{name}" if prefix else name)
    return keys


def _get(data, key):
    for part in key.split("."):
        data = data[part]
    return data


def _typed(asked, got):
    """``asked`` as the field's type made it (an int written for a float field; a
    scalar ``yaml_load`` left as text, as ``1e+300``)."""
    if isinstance(asked, str) and isinstance(got, bool):  # "false" for a bool: Drake's YAML
        return {"true": True, "false": False}.get(asked.lower(), asked)
    if isinstance(asked, str) and isinstance(got, (int, float)) and not isinstance(got, bool):
        return type(got)(float(asked)) if isinstance(got, float) else type(got)(asked)
    if isinstance(got, float) and isinstance(asked, int) and not isinstance(asked, bool):
        return float(asked)
    if isinstance(got, list) and isinstance(asked, list):
        return [_typed(a, g) for a, g in zip(asked, got, strict=False)]
    if isinstance(asked, dict):  # a tagged sequencer: compared through its fields
        return got
    return asked


@given(text=overrides())
def test_the_effective_scenario_round_trips_through_scenario_yaml(text, tmp_path_factory):
    """The scenario.yaml of a run loads back to the same scenario."""
    from pydrake.common.yaml import yaml_dump_typed

    from armando_drake.simulation.run import write_scenario

    try:
        scenario = merge_overrides(load_scenario("position"), [text])
        check_scenario(scenario)
    except INPUT_ERRORS:
        return
    path = tmp_path_factory.mktemp("effective") / "scenario.yaml"
    write_scenario(scenario, path)
    assert yaml_dump_typed(load_scenario(path)) == yaml_dump_typed(scenario)


@settings(max_examples=FEW * 3)
@given(text=overrides(keys=tuple(k for k in BASE_KEYS if not k.startswith(SIDE_EFFECTS))))
def test_an_accepted_override_builds_and_runs_without_nan(text):
    """Past the checks, the world builds (or refuses with an input error, e.g. a rate
    against the controller's) and 0.05 s run writes finite joint states."""
    from pydrake.systems.analysis import Simulator

    from armando_drake.simulation.builder import MakeWorld

    try:
        scenario = merge_overrides(load_scenario("position"), [text, "logging: {console_rate: 0}"])
        world = MakeWorld(scenario, quiet=True)
    except _input_errors() as error:
        assert "\n" not in str(error)
        return
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    simulator.AdvanceTo(0.05)
    assert np.all(np.isfinite(world.joint_positions(simulator.get_context())))
    world.close(simulator.get_context())


# ---------------------------------------------------------------- controller YAML

CONTROLLER_TYPES = [
    "joint_state_broadcaster/JointStateBroadcaster",
    "position_controllers/JointGroupPositionController",
    "joint_trajectory_controller/JointTrajectoryController",
    "forward_command_controller/ForwardCommandController",
    "velocity_controllers/JointGroupVelocityController",
    "effort_controllers/JointGroupEffortController",
    "unknown/Type",
]
JOINT_NAMES = st.sampled_from(["j0", "j1", "j2", "j3", "j9", ""])
PARAMETER_VALUES = st.one_of(
    ANY_SCALAR,
    st.lists(JOINT_NAMES, max_size=5),
    st.lists(ANY_SCALAR, max_size=3),
    st.dictionaries(st.sampled_from(["goal_time", "j0", "p"]), ANY_SCALAR, max_size=2),
)
PARAMETER_NAMES = st.sampled_from(
    [
        "joints",
        "joint",
        "interface_name",
        "command_interfaces",
        "state_interfaces",
        "constraints",
        "constraints.goal_time",
        "allow_partial_joints_goal",
        "publish_rate",
        "gains",
        "bogus",
    ]
)


@st.composite
def controller_yaml(draw) -> dict:
    names = draw(
        st.lists(st.sampled_from(["a", "b", "jsb", "pc"]), min_size=1, max_size=3, unique=True)
    )
    manager = {"update_rate": draw(st.one_of(st.integers(-10, 5000), ANY_SCALAR))}
    data = {"controller_manager": {"ros__parameters": manager}}
    for name in names:
        manager[name] = {"type": draw(st.one_of(st.sampled_from(CONTROLLER_TYPES), ANY_SCALAR))}
        params = draw(st.dictionaries(PARAMETER_NAMES, PARAMETER_VALUES, max_size=3))
        if draw(st.booleans()):
            params["joints"] = draw(st.lists(JOINT_NAMES, max_size=5))
        data[name] = {"ros__parameters": params}
    if draw(st.integers(0, 5)) == 0:  # a broken layout
        data = draw(st.sampled_from([[1, 2], "text", {"x": 1}, {"controller_manager": 3}]))
    return data


@given(data=controller_yaml())
def test_a_controller_yaml_is_read_or_refused_with_its_file_named(data):
    from armando_drake.control.config import ControllerConfigError, parse_controller_config

    try:
        config = parse_controller_config(data, "generated.yaml")
    except ControllerConfigError as error:
        assert str(error).startswith("generated.yaml"), error
        assert "\n" not in str(error)
        return
    assert isinstance(config.update_rate, int) and config.update_rate > 0
    for controller in config.controllers.values():
        assert all(isinstance(joint, str) for joint in controller.joints)


@settings(max_examples=FEW * 2)
@given(data=controller_yaml())
def test_a_generated_controller_yaml_builds_a_world_or_is_an_input_error(data, tmp_path_factory):
    import yaml

    from armando_drake.simulation.builder import MakeWorld

    path = tmp_path_factory.mktemp("controllers") / "controllers.yaml"
    path.write_text(yaml.safe_dump(data))
    names = (
        list(data.get("controller_manager", {}).get("ros__parameters", {}))[1:]
        if isinstance(data, dict) and isinstance(data.get("controller_manager"), dict)
        else []
    )
    override = yaml_text(
        {"controllers": {"config": str(path), "activate": [n for n in names if n != "update_rate"]}}
    )[1:-1]
    try:
        scenario = merge_overrides(load_scenario("position"), [override, "sequencer: null"])
        MakeWorld(scenario, quiet=True)
    except _input_errors() as error:
        assert "\n" not in str(error)


# ---------------------------------------------------------------- mutated descriptions

MUTATIONS = [
    ("remove", '<parent link="upper"/>'),
    ("remove", '<limit lower="-2" upper="2" effort="10" velocity="3"/>'),
    ("remove", "<inertial>"),
    ("swap", ('lower="-2" upper="2"', 'lower="2" upper="-2"')),
    ("number", 'lower="-2"'),
    ("number", 'effort="10"'),
    ("number", '<mass value="0.1"/>'),
    ("number", 'xyz="0 0 0.2"'),
    ("mesh", '<box size="0.03 0.03 0.2"/>'),
    ("loop", "</robot>"),
    ("duplicate", "</robot>"),
]
BAD_NUMBERS = st.sampled_from(["nan", "inf", "-inf", "-1", "0", "1e300", "abc", "", "1 2"])
BAD_MESHES = st.sampled_from(
    ["package://nowhere/a.stl", "file:///nonexistent.dae", "a.obj", "", "package://"]
)


@st.composite
def mutated_urdf(draw) -> str:
    text = MINI_URDF
    for kind, where in draw(st.lists(st.sampled_from(MUTATIONS), min_size=1, max_size=3)):
        if kind == "remove":
            text = text.replace(where, "", 1)
        elif kind == "swap":
            text = text.replace(*where, 1)
        elif kind == "number":
            number = draw(BAD_NUMBERS)
            if "=" in where:
                attribute = where.split("=")[0].lstrip("<").split()[-1]
                text = text.replace(where, where.replace(where.split('"')[1], number), 1)
                del attribute
        elif kind == "mesh":
            text = text.replace(where, f'<mesh filename="{draw(BAD_MESHES)}"/>', 1)
        elif kind == "loop":
            text = text.replace(
                where,
                '<joint name="q3" type="revolute"><parent link="lower"/><child link="upper"/>'
                '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
                "</joint></robot>",
                1,
            )
        elif kind == "duplicate":
            text = text.replace(
                where,
                '<joint name="q2" type="fixed"><parent link="base_link"/><child link="lower"/>'
                "</joint></robot>",
                1,
            )
    return text


@settings(max_examples=FEW * 3)
@given(urdf=mutated_urdf())
def test_a_mutated_description_loads_or_is_one_line_naming_the_file(urdf, tmp_path_factory):
    from pydrake.systems.analysis import Simulator

    from armando_drake.simulation.builder import MakeWorld

    path = tmp_path_factory.mktemp("robot") / "mini.urdf"
    path.write_text(urdf)
    try:
        scenario = merge_overrides(
            load_scenario("position"),
            [f"robot: {{description: {json.dumps(str(path))}}}", "logging: {console_rate: 0}"],
        )
        world = MakeWorld(scenario, quiet=True)
    except _input_errors() as error:
        message = str(error)
        assert "\n" not in message
        assert str(path) in message or "mini" in message, message
        return
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    simulator.AdvanceTo(0.05)
    assert np.all(np.isfinite(world.joint_positions(simulator.get_context())))


# ---------------------------------------------------------------- messages into controllers


@pytest.fixture(scope="module")
def running_world():
    """The position world without a sequencer: position_controller and
    trajectory_controller inputs free (two worlds, one per controller)."""
    from armando_drake.simulation.builder import MakeWorld

    worlds = {}
    for controller in ("position_controller", "trajectory_controller"):
        scenario = merge_overrides(
            load_scenario("position"),
            [
                "sequencer: null",
                "logging: {console_rate: 0}",
                f"controllers: {{activate: [joint_state_broadcaster, {controller}]}}",
            ],
        )
        worlds[controller] = MakeWorld(scenario, quiet=True)
    return worlds


MESSAGE_FLOATS = st.one_of(NASTY_FLOATS, st.floats(-4, 4))


@st.composite
def trajectories(draw):
    from armando_drake.messages.types import JointTrajectory, JointTrajectoryPoint

    names = draw(
        st.one_of(
            st.permutations(["j0", "j1", "j2", "j3"]),
            st.lists(st.sampled_from(["j0", "j1", "j2", "j3", "j9"]), max_size=5),
        )
    )
    points = []
    for _ in range(draw(st.integers(0, 3))):
        size = draw(st.sampled_from([len(names), len(names), 0, 2]))
        points.append(
            JointTrajectoryPoint(
                positions=tuple(draw(st.lists(MESSAGE_FLOATS, min_size=size, max_size=size))),
                velocities=tuple(draw(st.lists(MESSAGE_FLOATS, max_size=size))),
                time_from_start=draw(st.one_of(st.floats(0.01, 0.3), NASTY_FLOATS)),
            )
        )
    return JointTrajectory(
        stamp=draw(st.sampled_from([0.0, 0.0, -1.0, math.nan, 1e9])),
        joint_names=tuple(names),
        points=tuple(points),
    )


@settings(max_examples=FEW * 3)
@given(
    messages=st.lists(
        st.one_of(
            st.lists(MESSAGE_FLOATS, max_size=6).map(lambda d: ("position_controller", d)),
            trajectories().map(lambda m: ("trajectory_controller", m)),
        ),
        min_size=1,
        max_size=4,
    )
)
def test_messages_into_running_controllers_are_taken_or_dropped(running_world, messages):
    """Each message is accepted or rejected (counted once); the joints stay finite and
    within their limits; an accepted position command is the actuators' target, clamped."""
    from pydrake.systems.analysis import Simulator

    from armando_drake.messages.types import Float64MultiArray

    contexts = {}
    for controller, message in messages:
        world = running_world[controller]
        if controller not in contexts:
            simulator = Simulator(world.diagram)
            simulator.Initialize()
            contexts[controller] = (simulator, 0)
        simulator, published = contexts[controller]
        context = simulator.get_mutable_context()
        if controller == "position_controller":
            message = Float64MultiArray(data=tuple(message))
        before = world.status(context, controller)
        world.publish(context, controller, message)
        simulator.AdvanceTo(context.get_time() + 0.05)
        contexts[controller] = (simulator, published + 1)
        status = world.status(context, controller)
        assert status.accepted + status.rejected == before.accepted + before.rejected + 1
        q = world.joint_positions(context)
        assert np.all(np.isfinite(q)), q
        lower = np.array([j.lower for j in world.robot().stack.hardware.joints])
        upper = np.array([j.upper for j in world.robot().stack.hardware.joints])
        assert np.all(q >= lower - 0.05) and np.all(q <= upper + 0.05), q
        if controller == "position_controller" and status.accepted > before.accepted:
            desired = world.diagram.GetOutputPort("desired_state").Eval(context)[: len(q)]
            np.testing.assert_allclose(desired, np.clip(message.data, lower, upper))


# ---------------------------------------------------------------- the command itself

CLI_KEYS = tuple(
    k
    for k in BASE_KEYS
    if k.startswith(("actuators.", "plant_config.", "sequencer.", "controllers.update_rate"))
)


@settings(max_examples=max(2, EXAMPLES // 8))
@given(text=overrides(keys=CLI_KEYS, allow_unknown=True))
def test_the_command_line_property(text, tmp_path_factory):
    """``python -m armando_drake.world --set TEXT --output DIR``: ends within a bounded
    time with 0 or 2, prints no traceback; exit 0 writes finite logs and a scenario.yaml
    that holds what was asked."""
    out = tmp_path_factory.mktemp("run")
    command = [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--realtime-rate"]
    command += ["0", "--duration", "0.2", "--quiet", "--no-replay", "--output", str(out)]
    start = time.monotonic()
    result = subprocess.run(
        [*command, "--set", text], capture_output=True, text=True, timeout=180, env=os.environ
    )
    assert time.monotonic() - start < 180
    assert result.returncode in (0, 2), result.stderr
    for noise in ("Traceback", "Failure at"):
        assert noise not in result.stderr + result.stdout, result.stderr
    if result.returncode == 2:
        errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
        assert len(errors) == 1, result.stderr
        return
    asked = merge_overrides(load_scenario("position"), [text])
    ran = load_scenario(out / "scenario.yaml")
    from pydrake.common.yaml import yaml_load

    for key in _leaves(yaml_load(data=text)):
        assert same(_typed(_get(yaml_load(data=text), key), value_at(ran, key)), value_at(ran, key))
        assert same(value_at(asked, key), value_at(ran, key)), key
    with open(out / "joint_states.csv", newline="") as file:
        values = [float(v) for row in list(csv.reader(file))[1:] for v in row]
    assert values and all(math.isfinite(v) for v in values)
    assume(True)
