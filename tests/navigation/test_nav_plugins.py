"""Nav2 plugins by name: a new planner is one class registered under its Nav2 name, in its
own module (here, this test's), with its parameters declared beside it; a Nav2 file that
names it runs it, its parameters read and checked, and the reference lists it."""

from __future__ import annotations

import dataclasses as dc
import logging
from pathlib import Path

import numpy as np
import pytest
import yaml
from pydrake.systems.analysis import Simulator

from armando_drake.navigation import reference
from armando_drake.navigation.planner import planner_plugin
from armando_drake.navigation.registry import PLANNERS, SMOOTHERS
from armando_drake.navigation.smoother import smoother_plugins
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import param

NAV2 = Path(__file__).parents[2] / "models/fra2mo_description/config/navigation.yaml"
QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]
NAME = "test_planners::StraightLine"


@dc.dataclass
class StraightLineParameters:
    """The straight-line planner's parameters."""

    spacing: float = param(0.05, unit="m", gt=0, doc="the distance between the plan's points")


class StraightLine:
    """A planner that ignores the costmap: the segment from the start to the goal."""

    Parameters = StraightLineParameters
    plans = 0  # how many plans it made (all instances)

    def __init__(self, params: StraightLineParameters):
        self.params = params

    def plan(self, costmap, start, goal) -> np.ndarray:
        type(self).plans += 1
        length = float(np.hypot(goal[0] - start[0], goal[1] - start[1]))
        t = np.linspace(0.0, 1.0, max(2, int(length / self.params.spacing) + 1))
        return (
            np.asarray(start)[None, :] * (1 - t[:, None]) + np.asarray(goal)[None, :] * t[:, None]
        )


@pytest.fixture
def registered():
    """The planner registered (as its module's decorator would) for one test."""
    PLANNERS.register(NAME, instead="the straight line plans instead")(StraightLine)
    StraightLine.plans = 0
    yield StraightLine
    PLANNERS.unregister(NAME)


def _nav2_file(tmp_path: Path, node: dict) -> Path:
    doc = yaml.safe_load(NAV2.read_text())
    doc["planner_server"]["ros__parameters"]["GridBased"] = node
    path = tmp_path / "navigation.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_registered_planner_is_loaded_by_its_name_with_its_parameters(registered, tmp_path):
    path = _nav2_file(tmp_path, {"plugin": "test_planners/StraightLine", "spacing": 0.1})
    planner = planner_plugin(path)
    assert isinstance(planner, StraightLine) and planner.params.spacing == 0.1
    bad = _nav2_file(tmp_path, {"plugin": NAME, "spacing": -1.0})
    with pytest.raises(ConfigError) as error:
        planner_plugin(bad)
    assert str(bad) in str(error.value)
    assert "GridBased.spacing=-1.0 must be positive [m]" in str(error.value)
    page = reference.render()
    assert f"## GridBased ({NAME})" in page
    assert (
        "| `spacing` | honoured | [m] the distance between the plan's points (positive) |" in page
    )


def test_an_unregistered_planner_is_refused_naming_the_known_ones(tmp_path):
    path = _nav2_file(tmp_path, {"plugin": NAME})
    with pytest.raises(ConfigError, match=r"GridBased.plugin: unknown planner .*known: nav2_navfn"):
        planner_plugin(path)


def test_fra2mo_drives_to_a_goal_on_the_new_planner(registered, tmp_path, caplog):
    path = _nav2_file(tmp_path, {"plugin": NAME, "spacing": 0.05})
    scenario = merge_overrides(
        load_scenario("fra2mo_goals"),
        [
            *QUIET,
            f"navigation: {{params_file: {path}, "
            "goals: [{name: ahead, x: 0.6, y: -0.4, yaw: 0.0}], order: []}",
        ],
    )
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        world = MakeWorld(scenario, quiet=True)
    assert "spacing" not in caplog.text  # read, not warned about
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    navigator = world.robot().navigation.navigator
    assert isinstance(navigator.planner, StraightLine)
    context = navigator.GetMyContextFromRoot(simulator.get_context())
    t = 0.0
    while t < 15.0 and not navigator.nav_state(context).results:
        t += 0.5
        simulator.AdvanceTo(t)
    result = navigator.nav_state(context).results[0]
    assert result.reached, result
    assert StraightLine.plans >= 1
    first = result.first_plan  # the straight line: every point on the segment
    direction = (first[-1] - first[0]) / np.linalg.norm(first[-1] - first[0])
    offsets = (first - first[0]) @ np.array([-direction[1], direction[0]])
    assert np.abs(offsets).max() < 1e-9


@dc.dataclass
class KeepParameters:
    """The test smoother's parameters."""

    passes: int = param(1, unit="-", ge=0, doc="how many passes")


class Keep:
    """A smoother that keeps the plan as it is."""

    Parameters = KeepParameters

    def __init__(self, params: KeepParameters):
        self.params = params


def test_the_smoother_servers_slot_loads_registered_smoothers_only(tmp_path):
    fixture = Path(__file__).parent / "fixtures" / "nav2_params.yaml"
    assert smoother_plugins(fixture) == {}  # nav2_smoother::SimpleSmoother: not run here
    SMOOTHERS.register("test_smoothers::Keep")(Keep)
    try:
        path = tmp_path / "nav.yaml"
        path.write_text(
            "smoother_server:\n  ros__parameters:\n    smoother_plugins: [keep, simple]\n"
            "    keep: {plugin: test_smoothers/Keep, passes: 3}\n"
            "    simple: {plugin: nav2_smoother::SimpleSmoother}\n"
        )
        smoothers = smoother_plugins(path)
        assert list(smoothers) == ["keep"] and smoothers["keep"].params.passes == 3
        path.write_text(path.read_text().replace("passes: 3", "passes: -1"))
        with pytest.raises(ConfigError, match=r"smoother_server.ros__parameters.keep.passes=-1"):
            smoother_plugins(path)
    finally:
        SMOOTHERS.unregister("test_smoothers::Keep")
