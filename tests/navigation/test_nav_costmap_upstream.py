"""Cases ported from nav2_costmap_2d's own tests (ros-navigation/navigation2), with their
numbers: the footprint (16 points from a radius, padding, inscribed radius), the obstacle
layer's raytracing and marking (one point of a cloud here is one beam of a scan from the
sensor's origin), the combination methods and the footprint collision checker. Each case
names the upstream test it comes from."""

from __future__ import annotations

import math
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from armando_drake.navigation.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from armando_drake.navigation.costmap import Costmap, CostmapParameters, layered_costmap
from armando_drake.navigation.footprint import (
    footprint_cost,
    footprint_from_radius,
    min_max_distances,
    pad_footprint,
)
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.obstacle_layer import (
    ObservationSource,
    ObstacleParameters,
    observe,
)

MAX_Z = 1.0  # testing_helper.hpp's


# -- nav2_costmap_2d/test/integration/footprint_tests.cpp


def test_footprint_empty_is_the_default_radius_padded():
    # footprint_tests.cpp TEST_F(TestNode, footprint_empty): robot_radius 0.1 + padding 0.01
    footprint = CostmapParameters().polygon
    assert len(footprint) == 16
    assert footprint[0][0] == pytest.approx(0.11, abs=1e-4)
    assert footprint[0][1] == pytest.approx(0.0, abs=1e-4)


def test_unpadded_footprint_from_string_param():
    # footprint_tests.cpp TEST_F(TestNode, unpadded_footprint_from_string_param)
    params = CostmapParameters(footprint=[[1, 1], [-1, 1], [-1, -1]], footprint_padding=0.0)
    assert params.polygon == [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0)]


def test_padded_footprint_from_string_param():
    # footprint_tests.cpp TEST_F(TestNode, padded_footprint_from_string_param)
    params = CostmapParameters(footprint=[[1, 1], [-1, 1], [-1, -1]], footprint_padding=0.5)
    assert params.polygon == [(1.5, 1.5), (-1.5, 1.5), (-1.5, -1.5)]


def test_radius_param():
    # footprint_tests.cpp TEST_F(TestNode, radius_param): 16 points, the 4th a quarter turn on
    footprint = pad_footprint(footprint_from_radius(10.0), 0.0)
    assert len(footprint) == 16
    assert footprint[0] == (10.0, 0.0)
    assert footprint[4] == pytest.approx((0.0, 10.0), abs=1e-4)


def test_footprint_from_same_level_param():
    # footprint_tests.cpp TEST_F(TestNode, footprint_from_same_level_param)
    params = CostmapParameters(footprint=[[1, 2], [3, 4], [5, 6]], footprint_padding=0.0)
    assert params.polygon == [(1.0, 2.0), (3.0, 4.0), (5.0, 6.0)]


def test_the_inscribed_radius_of_a_padded_radius_is_the_polygons():
    # footprint.cpp calculateMinAndMaxDistances on makeFootprintFromRadius(0.2) padded by
    # Costmap2DROS's default footprint_padding (0.01): LayeredCostmap's inscribed radius.
    params = CostmapParameters(robot_radius=0.2)
    assert params.footprint_padding == 0.01
    assert params.nav2_inscribed_radius == pytest.approx(0.2059, abs=1e-4)
    unpadded = CostmapParameters(robot_radius=0.2, footprint_padding=0.0)
    assert unpadded.nav2_inscribed_radius == pytest.approx(0.2 * math.cos(math.pi / 16))


def test_the_inflation_uses_the_padded_16_gons_inscribed_radius():
    # layered_costmap.cpp setFootprint -> InflationLayer::onFootprintChanged
    assert CostmapParameters(robot_radius=0.2).inscribed_radius == pytest.approx(0.2059, abs=1e-4)


# -- nav2_costmap_2d/test/unit/footprint_collision_checker_test.cpp


def _costmap(size: int, resolution: float, value: int, origin=(0.0, 0.0)) -> Costmap:
    return Costmap(np.full((size, size), value, dtype=np.uint8), resolution, (*origin, 0.0))


DIAMOND = [(-0.5, 0.0), (0.0, 0.5), (0.5, 0.0), (0.0, -0.5)]
SQUARE = [(-1.0, 1.0), (1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)]


def test_collision_footprint_basic():
    # footprint_collision_checker_test.cpp TEST(collision_footprint, test_basic)
    assert footprint_cost(_costmap(100, 0.1, 0), (5.0, 5.0, 0.0), DIAMOND) == pytest.approx(0.0)


def test_collision_footprint_at_pose_with_movement():
    # footprint_collision_checker_test.cpp TEST(collision_footprint,
    # test_footprint_at_pose_with_movement)
    costmap = _costmap(100, 0.1, 254)
    costmap.costs[40:61, 40:61] = 0
    assert footprint_cost(costmap, (5.0, 5.0, 0.0), SQUARE) == pytest.approx(0.0)
    assert footprint_cost(costmap, (5.0, 4.9, 0.0), SQUARE) == pytest.approx(254.0)
    assert footprint_cost(costmap, (5.0, 5.2, 0.0), SQUARE) == pytest.approx(254.0)


def test_collision_footprint_point_and_line_cost():
    # footprint_collision_checker_test.cpp TEST(collision_footprint, test_point_and_line_cost)
    costmap = _costmap(100, 0.1, 0)
    costmap.costs[50, 62] = 254  # setCost(62, 50): x 62, y 50
    costmap.costs[60, 39] = 254
    assert footprint_cost(costmap, (5.0, 5.0, 0.0), SQUARE) == pytest.approx(0.0)
    assert footprint_cost(costmap, (4.9, 5.0, 0.0), SQUARE) == pytest.approx(254.0)
    assert footprint_cost(costmap, (5.2, 5.0, 0.0), SQUARE) == pytest.approx(254.0)


def test_collision_footprint_not_enough_points():
    # footprint_collision_checker_test.cpp TEST(collision_footprint, not_enough_points)
    assert min_max_distances([(2.0, 2.0), (-2.0, -2.0)]) == (sys.float_info.max, 0.0)


def test_a_footprint_off_the_map_is_lethal():
    # footprint_collision_checker.cpp footprintCost: a vertex off the map is LETHAL_OBSTACLE
    assert footprint_cost(_costmap(100, 0.1, 0), (0.2, 5.0, 0.0), SQUARE) == LETHAL_OBSTACLE


# -- nav2_costmap_2d/test/unit/obstacle_layer_test.cpp (20 x 20 cells of 0.1 m at (0, 0))


def _observe(layer, x, y, origin=(0.0, 0.0), resolution=0.1, **ranges):
    """ObstacleLayerTest's addObservation of the point (x, y) from the sensor at
    ``origin`` then update(): one beam of a scan at the point's bearing."""
    source = ObservationSource(clearing=True, marking=True, **ranges)
    dx, dy = x - origin[0], y - origin[1]
    scan = SimpleNamespace(ranges=[math.hypot(dx, dy)], angle_min=math.atan2(dy, dx),
                           angle_increment=0.0, range_min=0.0, range_max=1000.0)  # fmt: skip
    costmap = Costmap(layer, resolution, (0.0, 0.0, 0.0))
    return observe(layer, costmap, (*origin, 0.0), MAX_Z / 2, scan, source)


def _cell(x: float, y: float, resolution: float = 0.1) -> tuple[int, int]:
    """(row, col) of worldToMap(x, y)."""
    return int(y / resolution), int(x / resolution)


def _empty(resolution: float = 0.1) -> np.ndarray:
    return np.zeros((20, 20), dtype=np.uint8)


@pytest.mark.parametrize(
    ("case", "x", "y", "ranges", "lethal"),
    [
        ("testPointWithinCellMaxRange", 0.55, 0.0, dict(obstacle_max_range=1.0), True),
        ("testPointBeyondCellMaxRange", 1.55, 0.0, dict(obstacle_max_range=1.0), False),
        ("testPointWithinCellMinRange", 0.35, 0.0,
         dict(obstacle_max_range=10.0, obstacle_min_range=0.5), False),
        ("testDiagonalDistanceWithinRange", 0.701, 0.701, dict(obstacle_max_range=1.0), True),
        ("testPointBeyondObstacleMaxRangeNotMarkedWhenSameMapCell", 0.79, 0.0,
         dict(obstacle_max_range=0.72), False),
        ("testDiagonalDistanceBeyondRange", 1.0, 1.0, dict(obstacle_max_range=1.2), False),
        ("testPointAtCellMaxRangeBoundary", 1.0, 0.0, dict(obstacle_max_range=1.0), True),
        ("testPointAtCellMinRangeBoundary", 0.5, 0.0,
         dict(obstacle_max_range=10.0, obstacle_min_range=0.5), True),
    ],
)  # fmt: skip
def test_obstacle_layer_marking(case, x, y, ranges, lethal):
    # obstacle_layer_test.cpp TEST_F(ObstacleLayerTest, <case>) (raytrace_max_range 100)
    layer = _observe(_empty(), x, y, raytrace_max_range=100.0, **ranges)
    assert (layer[_cell(x, y)] == LETHAL_OBSTACLE) == lethal, case


def test_different_resolution():
    # obstacle_layer_test.cpp TEST_F(ObstacleLayerFineResolutionTest, testDifferentResolution)
    layer = _observe(_empty(), 0.52, 0.28, resolution=0.05, raytrace_max_range=100.0,
                     obstacle_max_range=1.0)  # fmt: skip
    assert layer[5, 10] == LETHAL_OBSTACLE


def test_origin_offset():
    # obstacle_layer_test.cpp TEST_F(ObstacleLayerTest, testOriginOffset)
    layer = _observe(_empty(), 1.75, 1.85, origin=(0.5, 1.5), raytrace_max_range=100.0,
                     obstacle_max_range=2.0)  # fmt: skip
    assert layer[_cell(1.75, 1.85)] == LETHAL_OBSTACLE


def test_raytrace_clears_path_and_marks_endpoint():
    # obstacle_layer_test.cpp TEST_F(ObstacleLayerTest, testRaytraceClearsPathAndMarksEndpoint)
    layer = _empty()
    layer[0, 0:4] = LETHAL_OBSTACLE
    layer = _observe(layer, 0.85, 0.0, raytrace_max_range=2.0, obstacle_max_range=2.0)
    row, col = _cell(0.85, 0.0)
    assert (layer[0, :col] == FREE_SPACE).all()
    assert layer[row, col] == LETHAL_OBSTACLE


def test_diagonal_raytrace_does_not_clear_endpoint():
    # obstacle_layer_test.cpp TEST_F(ObstacleLayerTest, testDiagonalRaytraceDoesNotClearEndpoint)
    layer = _empty()
    layer[_cell(0.75, 0.75)] = LETHAL_OBSTACLE
    layer[_cell(0.45, 0.45)] = LETHAL_OBSTACLE
    layer = _observe(layer, 0.75, 0.75, raytrace_max_range=2.0, obstacle_max_range=100.0)
    assert layer[_cell(0.75, 0.75)] == LETHAL_OBSTACLE
    assert layer[_cell(0.45, 0.45)] == FREE_SPACE


def test_clear_diagonal_distance_clears_the_clip_cell():
    # obstacle_layer_test.cpp TEST_F(ObstacleLayerTest, testClearDiagonalDistance): a ray to
    # (1.55, 1.55) clipped at raytrace_max_range 1.0 clears cells (0, 0) to (7, 7): 8 cells,
    # the clip cell (7, 7) included
    layer = np.full((20, 20), LETHAL_OBSTACLE, dtype=np.uint8)
    source = ObservationSource(clearing=True, marking=False, raytrace_max_range=1.0)
    scan = SimpleNamespace(ranges=[math.hypot(1.55, 1.55)], angle_min=math.pi / 4,
                           angle_increment=0.0, range_min=0.0, range_max=1000.0)  # fmt: skip
    layer = observe(layer, Costmap(layer, 0.1, (0.0, 0.0, 0.0)), (0.0, 0.0, 0.0), 0.5, scan,
                    source)  # fmt: skip
    for i in range(8):
        assert layer[i, i] == FREE_SPACE
    assert (layer == FREE_SPACE).sum() == 8
    assert (layer == LETHAL_OBSTACLE).sum() == 20 * 20 - 8


# -- nav2_costmap_2d/test/integration/obstacle_tests.cpp: combination methods


def _unknown_master(method: int) -> np.ndarray:
    """A 10 x 10 costmap of 1 m cells, all unknown (track_unknown_space), an obstacle
    layer with the point (0, 0) observed."""
    params = CostmapParameters(track_unknown_space=True, inflation_layer=False)
    params.obstacle_layer = ObstacleParameters(combination_method=method)
    grid = OccupancyMap(np.full((10, 10), -1, dtype=np.int8), 1.0, (0.0, 0.0, 0.0))
    obstacles = np.full((10, 10), NO_INFORMATION, dtype=np.uint8)
    obstacles[0, 0] = LETHAL_OBSTACLE  # addObservation(olayer, 0.0, 0.0, ...)
    return layered_costmap(grid, params, obstacles).costs


def test_max_combination_method_overwrites_unknown():
    # obstacle_tests.cpp TEST_F(TestNode, testMaxCombinationMethod)
    assert (_unknown_master(1) == NO_INFORMATION).sum() == 99


def test_max_without_unknown_overwrite_combination_method():
    # obstacle_tests.cpp TEST_F(TestNodeWithoutUnknownOverwrite,
    # testMaxWithoutUnknownOverwriteCombinationMethod)
    assert (_unknown_master(2) == NO_INFORMATION).sum() == 100
