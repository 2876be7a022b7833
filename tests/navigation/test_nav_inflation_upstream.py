"""The inflation layer and the layered costmap, case for case with Nav2 (jazzy).

Ported from navigation2 (jazzy, f4108e5b1c2bce804a1aa0c7be6673a8eb4a1501)
nav2_costmap_2d/test/integration/inflation_tests.cpp and obstacle_tests.cpp (the cases
built there, and those kept under ``#if (0)`` that a planar obstacle layer can express),
with their helpers of testing_helper.hpp: ``addObservation`` is one point seen from the
sensor at (0, 0, MAX_Z) (here one beam of a scan to the point), ``setRadii`` a rectangular
footprint set on the LayeredCostmap unpadded, and the static map is test/map/TenByTen
(10 x 10 cells of 1 m, 20 lethal, two unknown). Costs are read as ``getCost(x, y)``:
``costs[y, x]``.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from armando_drake.navigation.cost_values import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
)
from armando_drake.navigation.costmap import Costmap, CostmapParameters, layered_costmap
from armando_drake.navigation.inflation_layer import inflate, inflation_cost
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.obstacle_layer import (
    ObservationSource,
    ObstacleParameters,
    empty_obstacles,
    observe,
)

MAX_Z = 1.0  # testing_helper.hpp's

# test/map/TenByTen.pgm as map_server loads it (row 0 is y = 0; -1 unknown)
TEN_BY_TEN = np.array(
    [
        [0, 0, 0, 0, 0, 0, 0, 100, 100, 100],
        [0, 0, 0, 0, 0, 0, 0, 100, 100, 100],
        [0, 0, 0, 100, 100, 100, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [-1, -1, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 100, 0, 0, 100, 100, 100],
        [0, 0, 0, 0, 100, 0, 0, 100, 100, 100],
        [0, 0, 0, 0, 0, 0, 0, 100, 100, 100],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    ],
    dtype=np.int8,
)


def set_radii(length: float, width: float) -> list[list[float]]:
    """inflation_tests.cpp's setRadii: the rectangle +-width x +-length."""
    return [[width, length], [width, -length], [-width, -length], [-width, length]]


class Layers:
    """A LayeredCostmap of ``size`` x ``size`` 1 m cells at (0, 0): the static layer (the
    TenByTen map) if ``static``, an obstacle layer fed by addObservation's static
    observations, an inflation layer (cost_scaling_factor 1.0, as initNode sets it)."""

    def __init__(self, size=10, *, static=False, inflation_radius=4.1, footprint=None, **kw):
        data = TEN_BY_TEN if static else np.zeros((size, size), dtype=np.int8)
        self.grid = OccupancyMap(data.copy(), 1.0, (0.0, 0.0, 0.0))
        self.params = CostmapParameters(
            footprint=footprint or set_radii(2.1, 2.3),
            footprint_padding=0.0,  # LayeredCostmap::setFootprint: the polygon as given
            inflation_radius=inflation_radius,
            cost_scaling_factor=1.0,
            static_layer=static,
            **kw,
        )
        self.params.obstacle_layer = ObstacleParameters()
        self.obstacles = empty_obstacles(data.shape, self.params)
        self.observations = []

    def add_observation(self, x, y, z=0.0, ox=0.0, oy=0.0, oz=MAX_Z, marking=True,
                        clearing=True, **ranges):  # fmt: skip
        """testing_helper.hpp's addObservation (addStaticObservation: kept for every
        update) of the point (x, y, z) from the sensor at (ox, oy, oz)."""
        ranges = dict(raytrace_max_range=100.0, obstacle_max_range=100.0) | ranges
        self.observations.append(((x, y, z), (ox, oy), marking, clearing, ranges))

    def update_map(self) -> np.ndarray:
        """LayeredCostmap::updateMap(0, 0, 0): the obstacle layer clears along every
        clearing observation, then marks every marking one (ObstacleLayer::updateBounds);
        the layers combined and inflated."""
        view = Costmap(self.obstacles, 1.0, (0.0, 0.0, 0.0))
        for point, origin, _, clearing, ranges in self.observations:
            if clearing:
                source = ObservationSource(clearing=True, marking=False, **ranges)
                self.obstacles = _observe(self.obstacles, view, point, origin, source)
        for point, origin, marking, _, ranges in self.observations:
            if marking:
                source = ObservationSource(clearing=False, marking=True, **ranges)
                self.obstacles = _observe(self.obstacles, view, point, origin, source)
        return layered_costmap(self.grid, self.params, self.obstacles).costs


def _observe(layer, view, point, origin, source):
    """The point (x, y, z) seen from the sensor at ``origin`` (x, y): one beam, to a micron
    past the point in x and y (still the point's cell: the beam's range and bearing give
    it back within rounding, which on a cell's edge could be the cell below)."""
    dx, dy = point[0] + 1e-6 - origin[0], point[1] + 1e-6 - origin[1]
    beam = SimpleNamespace(ranges=[math.hypot(dx, dy)], angle_min=math.atan2(dy, dx),
                           angle_increment=0.0, range_min=0.0, range_max=1000.0)  # fmt: skip
    return observe(layer, view, (*origin, 0.0), point[2], beam, source)


def compute_cost(distance: float, inscribed_radius: float) -> int:
    """InflationLayer::computeCost at ``distance`` cells of 1 m, cost_scaling_factor 1."""
    return int(inflation_cost([distance], 1.0, inscribed_radius, 1.0)[0])


def validate_point_inflation(mx, my, costs, inscribed_radius, inflation_radius):
    """inflation_tests.cpp's validatePointInflation: from (mx, my), cells by increasing
    distance (4-neighbours); each at most ``inflation_radius`` away costs at least
    computeCost of its distance."""
    rows, cols = costs.shape
    seen = np.zeros(costs.shape, dtype=bool)
    bins = {0.0: [(mx, my)]}
    while bins:
        first = min(bins)
        for x, y in bins.pop(first):
            if seen[y, x]:
                continue
            seen[y, x] = True
            dist = math.hypot(x - mx, y - my)
            assert costs[y, x] >= compute_cost(dist, inscribed_radius), (x, y)
            if dist > inflation_radius:
                continue
            if dist == first:
                dist += 0.001
            for nx, ny in ((x - 1, y), (x, y - 1), (x + 1, y), (x, y + 1)):
                if 0 <= nx < cols and 0 <= ny < rows:
                    bins.setdefault(dist, []).append((nx, ny))


def count(costs, value) -> int:
    """testing_helper.hpp's countValues."""
    return int((costs == value).sum())


# -- inflation_tests.cpp


def test_testAdjacentToObstacleCanStillMove():
    layers = Layers(inflation_radius=4.1)  # inscribed radius 2.1, circumscribed 3.1
    layers.add_observation(0, 0, MAX_Z)
    costs = layers.update_map()
    assert costs[0, 0] == LETHAL_OBSTACLE
    assert costs[0, 1] == INSCRIBED_INFLATED_OBSTACLE
    assert costs[0, 2] == INSCRIBED_INFLATED_OBSTACLE
    assert INSCRIBED_INFLATED_OBSTACLE > costs[0, 3]
    assert INSCRIBED_INFLATED_OBSTACLE > costs[1, 2]
    assert costs[1, 1] == INSCRIBED_INFLATED_OBSTACLE


def test_testInflationShouldNotCreateUnknowns():
    layers = Layers(inflation_radius=4.1)
    layers.add_observation(0, 0, MAX_Z)
    assert count(layers.update_map(), NO_INFORMATION) == 0


def test_testInflationInUnkown():
    layers = Layers(9, inflation_radius=4.1, inflate_unknown=True, track_unknown_space=True)
    layers.add_observation(4, 4, MAX_Z, marking=True, clearing=False)
    # Only the 4 corners of the map should remain unknown
    assert count(layers.update_map(), NO_INFORMATION) == 4


def test_testInflationAroundUnkown():
    params = CostmapParameters(
        footprint=set_radii(2.1, 2.3), footprint_padding=0.0, inflation_radius=4.1,
        cost_scaling_factor=1.0, inflate_around_unknown=True,
    )  # fmt: skip
    costs = np.zeros((10, 10), dtype=np.uint8)
    costs[4, 4] = NO_INFORMATION  # setCost(4, 4, NO_INFORMATION), then updateCosts
    costs = inflate(costs, 1.0, params)
    validate_point_inflation(4, 4, costs, 2.1, 4.1)


def test_testCostFunctionCorrectness():
    layers = Layers(100, inflation_radius=10.5, footprint=set_radii(5.0, 6.25))
    layers.add_observation(50, 50, MAX_Z)
    costs = layers.update_map()
    for i in range(0, math.ceil(5.0) + 1):
        assert costs[50, 50 + i] >= INSCRIBED_INFLATED_OBSTACLE  # to the right
        assert costs[50, 50 - i] >= INSCRIBED_INFLATED_OBSTACLE  # to the left
        assert costs[50 + i, 50] >= INSCRIBED_INFLATED_OBSTACLE  # down
        assert costs[50 - i, 50] >= INSCRIBED_INFLATED_OBSTACLE  # up
    for i in range(math.ceil(5.0) + 1, math.ceil(10.5) + 1):
        assert costs[50, 50 + i] == compute_cost(i / 1.0, 5.0), i


def test_testInflationOrderCorrectness():
    layers = Layers(inflation_radius=4.1)
    layers.add_observation(4, 4, MAX_Z)
    layers.add_observation(5, 5, MAX_Z)
    costs = layers.update_map()
    validate_point_inflation(4, 4, costs, 2.1, 4.1)
    validate_point_inflation(5, 5, costs, 2.1, 4.1)


def test_testInflation():
    layers = Layers(static=True, inflation_radius=1.0, footprint=set_radii(1, 1))
    costs = layers.update_map()
    assert count(costs, LETHAL_OBSTACLE) == 20
    assert count(costs, INSCRIBED_INFLATED_OBSTACLE) == 28

    layers.add_observation(0, 0, 0.4)
    costs = layers.update_map()
    # It and its 2 neighbors makes 3 obstacles
    assert count(costs, LETHAL_OBSTACLE) + count(costs, INSCRIBED_INFLATED_OBSTACLE) == 51

    layers.add_observation(2, 0)
    costs = layers.update_map()
    assert count(costs, LETHAL_OBSTACLE) + count(costs, INSCRIBED_INFLATED_OBSTACLE) == 54

    layers.add_observation(1, 9)
    costs = layers.update_map()
    assert costs[9, 1] == LETHAL_OBSTACLE
    assert costs[9, 0] == INSCRIBED_INFLATED_OBSTACLE
    assert costs[9, 2] == INSCRIBED_INFLATED_OBSTACLE

    layers.add_observation(0, 9)
    costs = layers.update_map()
    assert costs[9, 0] == LETHAL_OBSTACLE


def test_testInflation2():
    layers = Layers(static=True, inflation_radius=1.0, footprint=set_radii(1, 1))
    for x, y in ((1, 1), (2, 1), (2, 2)):  # a small L-shape all at once
        layers.add_observation(x, y, MAX_Z)
    costs = layers.update_map()
    assert costs[3, 2] == INSCRIBED_INFLATED_OBSTACLE
    assert costs[3, 3] == INSCRIBED_INFLATED_OBSTACLE


def test_testInflation3():
    layers = Layers(inflation_radius=3.0, footprint=set_radii(1, 1.75))
    costs = layers.update_map()
    assert count(costs, LETHAL_OBSTACLE) == 0
    assert count(costs, INSCRIBED_INFLATED_OBSTACLE) == 0
    layers.add_observation(5, 5, MAX_Z)
    for _ in range(2):  # update again: no change
        costs = layers.update_map()
        assert (costs != FREE_SPACE).sum() == 29
        assert count(costs, LETHAL_OBSTACLE) == 1
        assert count(costs, INSCRIBED_INFLATED_OBSTACLE) == 4


# -- obstacle_tests.cpp (the static layer with TenByTen, no inflation layer)


def _obstacle_layers(size=10, **kw) -> Layers:
    layers = Layers(size, **kw)
    layers.params.inflation_layer = False
    return layers


def test_testRaytracing():
    # obstacle_tests.cpp TEST_F(TestNode, testRaytracing) (the one built; its static layer
    # has no map: an empty 10 x 10 grid)
    layers = _obstacle_layers()
    layers.add_observation(0.0, 0.0, MAX_Z / 2, 0, 0, MAX_Z / 2)
    assert count(layers.update_map(), LETHAL_OBSTACLE) == 1
    layers.add_observation(1.0, 1.0, MAX_Z / 2, 0, 0, MAX_Z / 2, True, True,
                           raytrace_min_range=5.0, obstacle_min_range=5.0)  # fmt: skip
    # the new observation is not recorded: its range is below obstacle_min_range
    assert count(layers.update_map(), LETHAL_OBSTACLE) == 1


def test_testRaytracing2_static_map_not_cleared():
    # obstacle_tests.cpp (#if 0) testRaytracing2
    layers = _obstacle_layers(static=True)
    obs_before = count(layers.update_map(), LETHAL_OBSTACLE)
    assert obs_before == 20
    # from <0.5, 0.5> to <9.5, 9.5>: the static map is not cleared by the obstacle layer
    layers.add_observation(9.5, 9.5, MAX_Z / 2, 0.5, 0.5, MAX_Z / 2)
    obs_after = count(layers.update_map(), LETHAL_OBSTACLE)
    assert obs_after == obs_before + 1
    for i in range(10):  # fill in the diagonal, then updateBounds raytraces it out again
        layers.obstacles[i, i] = LETHAL_OBSTACLE
    costs = layers.update_map()
    assert count(costs, LETHAL_OBSTACLE) == obs_after


def test_testWaveInterference():
    # obstacle_tests.cpp (#if 0) testWaveInterference: tracking unknown, 3 obstacles on
    # the diagonal separated by a cell
    layers = _obstacle_layers(track_unknown_space=True, static=False)
    for v in (3.0, 5.0, 7.0):
        layers.add_observation(v, v, MAX_Z)
    costs = layers.update_map()
    assert count(costs, LETHAL_OBSTACLE) == 3
    assert count(costs, NO_INFORMATION) == 92
    assert count(costs, FREE_SPACE) == 5


def test_testDynamicObstacles():
    # obstacle_tests.cpp (#if 0) testDynamicObstacles: the same point three times
    layers = _obstacle_layers(static=True)
    for _ in range(3):
        layers.add_observation(0.0, 0.0)
    assert count(layers.update_map(), LETHAL_OBSTACLE) == 21
    assert count(layers.update_map(), LETHAL_OBSTACLE) == 21


def test_testMultipleAdditions():
    # obstacle_tests.cpp (#if 0) testMultipleAdditions: a point in a static obstacle
    layers = _obstacle_layers(static=True)
    layers.add_observation(9.5, 0.0)
    assert count(layers.update_map(), LETHAL_OBSTACLE) == 20


def test_inflation_distances_are_exact_as_jazzys_cached_distances():
    # inflation_layer.cpp (jazzy) computeCaches: cached_distances_ = hypot(i, j), not
    # quantized to 1/100 cell: at hypot(1, 1) 166 (1.41 cells would give 167), at
    # hypot(1, 2) 73 (2.24 cells: 72), cost_scaling_factor 1, inscribed radius 1
    costs = np.zeros((10, 10), dtype=np.uint8)
    costs[0, 0] = LETHAL_OBSTACLE
    params = CostmapParameters(footprint=set_radii(1.0, 1.0), footprint_padding=0.0,
                               inflation_radius=5.0, cost_scaling_factor=1.0)  # fmt: skip
    inflated = inflate(costs, 1.0, params)
    assert inflated[1, 1] == compute_cost(math.hypot(1, 1), 1.0) == 166
    assert inflated[2, 1] == inflated[1, 2] == compute_cost(math.hypot(1, 2), 1.0) == 73
