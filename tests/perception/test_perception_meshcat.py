"""The perception layers in Meshcat: raw, filtered, plane, one per cluster with its box."""

import math

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from armando_drake.perception.pipeline import Cluster, PerceptionResult, Stage, make_cloud
from armando_drake.perception.systems import PerceptionVisualizer, _box_edges
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario


def test_world_draws_each_layer():
    meshcat = Meshcat()
    scenario = load_scenario("perception", "logging: {console_rate: 0}")
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True)
    Simulator(world.diagram).AdvanceTo(0.15)
    for path in ("raw", "filtered", "plane", "clusters/0", "clusters/0/box", "clusters/2/box"):
        assert meshcat.HasPath(f"/perception/{path}"), path
    assert not meshcat.HasPath("/perception/clusters/3")
    world.close()


def result_with(clusters: int, time: float) -> PerceptionResult:
    cloud = make_cloud(np.zeros((4, 3)))
    members = np.array([[0, 0, 0], [0.1, 0.2, 0.3]], dtype=np.float32)
    cluster = Cluster(
        centroid=members.mean(axis=0),
        lower=members.min(axis=0),
        upper=members.max(axis=0),
        count=2,
        points=members,
    )
    return PerceptionResult(
        time=time,
        frame="world",
        stages=(Stage("input", cloud, 0.0),),
        clusters=(cluster,) * clusters,
    )


def test_clusters_that_disappear_are_deleted():
    meshcat = Meshcat()
    builder = DiagramBuilder()
    visualizer = builder.AddSystem(PerceptionVisualizer(meshcat=meshcat, rate=10.0))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    port = visualizer.GetInputPort("result")
    visualizer_context = visualizer.GetMyContextFromRoot(context)
    for count, time in ((3, 0.0), (1, 0.1)):
        port.FixValue(visualizer_context, result_with(count, time))
        diagram.ForcedPublish(context)
        drawn = [meshcat.HasPath(f"/perception/clusters/{k}") for k in range(4)]
        assert drawn == [k < count for k in range(4)]
    assert not meshcat.HasPath("/perception/plane")


def test_box_edges_are_the_twelve_edges_of_the_box():
    lower, upper = np.array([0.0, 0.0, 0.0]), np.array([1.0, 2.0, 3.0])
    start, end = _box_edges(lower, upper)
    assert start.shape == end.shape == (3, 12)
    lengths = sorted(np.linalg.norm(end - start, axis=0).round(9))
    assert lengths == [1.0] * 4 + [2.0] * 4 + [3.0] * 4
    for points in (start, end):
        assert all(
            math.isclose(v, lo) or math.isclose(v, hi)
            for lo, hi, row in zip(lower, upper, points, strict=True)
            for v in row
        )
