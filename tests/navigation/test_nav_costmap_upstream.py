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
from armando_drake.navigation.costmap import (
    Costmap,
    CostmapParameters,
    costmap_parameters,
    layered_costmap,
)
from armando_drake.navigation.footprint import (
    footprint_cost,
    footprint_from_radius,
    footprint_from_string,
    min_max_distances,
    pad_footprint,
    parse_vvf,
)
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.obstacle_layer import (
    ObservationSource,
    ObstacleParameters,
    observe,
    raytrace,
)
from armando_drake.tools.errors import ConfigError

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


def test_collision_footprint_point_cost():
    # footprint_collision_checker_test.cpp TEST(collision_footprint, test_point_cost)
    assert _costmap(100, 0.1, 0).costs[50, 50] == pytest.approx(0.0, abs=0.001)


def test_collision_footprint_world_to_map():
    # footprint_collision_checker_test.cpp TEST(collision_footprint, test_world_to_map)
    costmap = _costmap(100, 0.1, 0)
    assert costmap.costs[costmap.world_to_cell(1.0, 1.0)] == pytest.approx(0.0, abs=0.001)
    costmap.costs[50, 50] = 200  # setCost(50, 50, 200)
    assert costmap.world_to_cell(5.0, 5.0) == (50, 50)
    assert costmap.costs[costmap.world_to_cell(5.0, 5.0)] == pytest.approx(200.0, abs=0.001)


def test_make_footprint_from_string():
    # footprint_collision_checker_test.cpp TEST(collision_footprint, make_footprint_from_string)
    footprint = footprint_from_string("[[1, 2.2], [.3, -4e4], [-.3, -4e4], [-1, 2.2]]")
    assert len(footprint) == 4
    expected = [(1.0, 2.2), (0.3, -4e4), (-0.3, -4e4), (-1.0, 2.2)]
    for point, (x, y) in zip(footprint, expected, strict=True):
        assert point == pytest.approx((x, y), abs=1e-5)


@pytest.mark.parametrize(
    ("case", "text"),
    [
        ("make_footprint_from_string_parse_error", "[[bad_string"),
        ("make_footprint_from_string_two_points_error", "[[1, 2.2], [.3, -4e4]"),
        ("make_footprint_from_string_not_pairs",
         "[[1, 2.2], [.3, -4e4], [-.3, -4e4], [-1, 2.2, 5.6]]"),
    ],
)  # fmt: skip
def test_make_footprint_from_string_errors(case, text):
    # footprint_collision_checker_test.cpp TEST(collision_footprint, <case>): false
    with pytest.raises(ValueError):
        footprint_from_string(text)


def test_a_footprint_string_in_a_nav2_file_is_read_as_nav2_reads_it(tmp_path):
    # Costmap2DROS's footprint parameter, through makeFootprintFromString
    path = tmp_path / "nav2.yaml"
    path.write_text(
        "local_costmap:\n  local_costmap:\n    ros__parameters:\n"
        '      footprint: "[[.3, .2], [-.3, .2], [-.3, -.2], [.3, -.2]]"\n'
        "      plugins: []\n"
    )
    params = costmap_parameters(path, "local_costmap")
    assert params.footprint == [(0.3, 0.2), (-0.3, 0.2), (-0.3, -0.2), (0.3, -0.2)]
    path.write_text(path.read_text().replace("[.3, -.2]]", "[.3, -.2, 1]]"))
    with pytest.raises(ConfigError, match="must be pairs of numbers"):
        costmap_parameters(path, "local_costmap")


# -- nav2_util/test/test_array_parser.cpp (parseVVF, which reads a footprint string)


def test_array_parser_basic_operation():
    # test_array_parser.cpp TEST(array_parser, basic_operation)
    vvf, error = parse_vvf("[[1, 2.2], [.3, -4e4]]")
    assert len(vvf) == 2 and len(vvf[0]) == 2 and len(vvf[1]) == 2
    assert np.float32(vvf[0][0]) == np.float32(1.0)
    assert np.float32(vvf[0][1]) == np.float32(2.2)
    assert np.float32(vvf[1][0]) == np.float32(0.3)
    assert np.float32(vvf[1][1]) == np.float32(-40000.0)
    assert error == ""


@pytest.mark.parametrize(
    ("case", "text"),
    [
        ("missing_open", "[1, 2.2], [.3, -4e4]]"),
        ("missing_close", "[[1, 2.2], [.3, -4e4]"),
        ("wrong_depth", "[1, 2.2], [.3, -4e4]"),
    ],
)
def test_array_parser_errors(case, text):
    # test_array_parser.cpp TEST(array_parser, <case>): an error
    assert parse_vvf(text)[1] != "", case


# -- nav2_costmap_2d/test/regression/costmap_bresenham_2d.cpp (Costmap2D::raytraceLine, as
# the obstacle layer's raytrace runs it between two cells of a 60 x 60 map of 0.1 m)


def _raytrace_cells(x0, y0, x1, y1, max_length, min_length):
    grid = Costmap(np.zeros((60, 60), dtype=np.uint8), 0.1, (0.0, 0.0, 0.0))
    source = ObservationSource(raytrace_max_range=max_length * 0.1,
                               raytrace_min_range=min_length * 0.1)  # fmt: skip
    centre = lambda v: (v + 0.5) * 0.1  # noqa: E731
    return raytrace(grid, (centre(x0), centre(y0)), ([centre(x1)], [centre(y1)]), source)


def test_bresenham2DBoundariesCheck():
    # costmap_bresenham_2d.cpp TEST(costmap_2d, bresenham2DBoundariesCheck): every cell the
    # line from (2, 4) to a cell of the map's edges passes is on the map
    ends = [(x, 0) for x in range(60)] + [(x, 59) for x in range(60)]
    ends += [(0, y) for y in range(60)] + [(59, y) for y in range(60)]
    for x1, y1 in ends:
        rows, cols = _raytrace_cells(2, 4, x1, y1, 60, 6)
        assert ((rows >= 0) & (rows < 60) & (cols >= 0) & (cols < 60)).all()


def test_bresenham2DSamePoint():
    # costmap_bresenham_2d.cpp TEST(costmap_2d, bresenham2DSamePoint): the line from a cell
    # to itself marks that cell
    rows, cols = _raytrace_cells(2, 4, 2, 4, 60, 0)
    assert list(zip(rows, cols, strict=True)) == [(4, 2)]


def test_GetCostService_without_and_with_footprint():
    # costmap_cost_service_test.cpp TEST_F(GetCostServiceTest, TestWithoutFootprint) and
    # TestWithFootprint: the cost at (0.5, 1.0), and of the footprint at (1.0, 1.0, 0.5), on
    # Costmap2DROS's default costmap (5 m x 5 m of 0.1 m), within 0..255
    params = CostmapParameters(resolution=0.1)
    costmap = _costmap(50, 0.1, 0)
    cost = float(costmap.costs[costmap.world_to_cell(0.5, 1.0)])
    assert 0.0 <= cost <= 255.0
    cost = footprint_cost(costmap, (1.0, 1.0, 0.5), params.polygon)
    assert 0.0 <= cost <= 255.0


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


# -- footprint_tests.cpp's parameters as a Nav2 file gives them (a footprint string)


def _file_costmap(tmp_path, body: str) -> CostmapParameters:
    path = tmp_path / "nav2.yaml"
    path.write_text(
        "local_costmap:\n  local_costmap:\n    ros__parameters:\n      plugins: []\n" + body
    )
    return costmap_parameters(path, "local_costmap")


@pytest.mark.parametrize(
    ("padding", "expected"),
    [
        (0.0, [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0)]),  # unpadded_footprint_from_string_param
        (0.5, [(1.5, 1.5), (-1.5, 1.5), (-1.5, -1.5)]),  # padded_footprint_from_string_param
    ],
)
def test_footprint_from_string_param_in_a_file(tmp_path, padding, expected):
    params = _file_costmap(
        tmp_path,
        f'      footprint: "[[1, 1], [-1, 1], [-1, -1]]"\n      footprint_padding: {padding}\n',
    )
    assert params.polygon == expected


def test_radius_param_in_a_file(tmp_path):
    # footprint_tests.cpp TEST_F(TestNode, radius_param): robot_radius 10, padding 0
    params = _file_costmap(tmp_path, "      robot_radius: 10.0\n      footprint_padding: 0.0\n")
    assert len(params.polygon) == 16
    assert params.polygon[0] == (10.0, 0.0)
    assert params.polygon[4] == pytest.approx((0.0, 10.0), abs=1e-4)


def test_footprint_from_same_level_param_in_a_file_is_refused(tmp_path):
    # footprint_tests.cpp TEST_F(TestNode, footprint_from_same_level_param) takes the three
    # collinear points [[1, 2], [3, 4], [5, 6]]; a Nav2 file's footprint here must have an
    # area (docs/navigation.md, the limits on the Nav2 parameters): refused, naming the key
    with pytest.raises(ConfigError, match=r"footprint: .* has no area"):
        _file_costmap(tmp_path, '      footprint: "[[1, 2], [3, 4], [5, 6]]"\n')
