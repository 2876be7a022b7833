"""A top-heavy base: Armando on fra2mo driving four goals with Nav2's velocity smoother.

diagrams/fra2mo_armando_goals.yaml: the Nav2 file has the lidar's scans in the costmaps and
a velocity_smoother (0.5 m/s^2, 2 rad/s^2) between Regulated Pure Pursuit and the base.
All four goals are reached, with no recovery and no "collision ahead" (the lidar of a
pitching base would see the floor, which the obstacle layer would mark).
"""

import logging

import numpy as np
from pydrake.systems.analysis import Simulator

from armando_drake.navigation.velocity_smoother import VelocitySmoother
from armando_drake.outputs.navigation import navigation_summary
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides

QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]


def test_armando_on_fra2mo_reaches_four_goals_without_recoveries(caplog):
    scenario = merge_overrides(load_scenario("fra2mo_armando_goals"), QUIET)
    with caplog.at_level(logging.WARNING, logger="armando_drake.navigation"):
        world = MakeWorld(scenario, quiet=True)
        smoothers = [s for s in world.diagram.GetSystems() if isinstance(s, VelocitySmoother)]
        assert len(smoothers) == 1  # between the navigator and fra2mo's drive
        assert smoothers[0].params.max_accel == [0.5, 0.0, 2.0]
        simulator = Simulator(world.diagram)
        simulator.Initialize()
        context = simulator.get_context()
        for end in np.arange(25.0, scenario.simulation.duration + 0.5, 1.0):
            simulator.AdvanceTo(min(end, scenario.simulation.duration))
            summary = navigation_summary(world, context)
            if all(goal["reason"] != "not reached" for goal in summary["goals"]):
                break
    goals = summary["goals"]
    assert [g["status"] for g in goals] == ["succeeded"] * 4, goals
    assert all(g["recoveries"] == [] for g in goals), [g["recoveries"] for g in goals]
    assert all(g["position_error"] < 0.1 and g["yaw_error"] < 0.2 for g in goals)
    assert max(g["reached_at"] for g in goals) < 37.0  # about 35 s for the four
    messages = [r.getMessage() for r in caplog.records]
    assert not [m for m in messages if "collision ahead" in m or "recovery" in m]
