"""The robot's footprint as nav2_costmap_2d makes and checks it (``footprint.cpp``,
``footprint_collision_checker.cpp``).

- :func:`footprint_from_radius`: ``robot_radius`` as upstream's 16-point polygon
  (``makeFootprintFromRadius``), so its inscribed radius is ``cos(pi/16)`` of the radius
  before padding;
- :func:`pad_footprint`: ``footprint_padding`` added to each point's x and y away from the
  centre (``padFootprint``, 0.01 m by default);
- :func:`min_max_distances`: the inscribed and circumscribed radii
  (``calculateMinAndMaxDistances``: the nearest and farthest vertex or edge);
- :func:`parse_vvf`, :func:`footprint_from_string`: a footprint given as a string
  "[[x, y], ...]", read as nav2_util's ``parseVVF`` and ``makeFootprintFromString`` read
  it (numbers as a C++ stream reads them: ``.3``, ``-4e4``);
- :func:`footprint_cost`: the footprint collision checker (``footprintCostAtPose``): the
  footprint placed at a pose, the highest cost of the cells along its outline (nav2_util's
  LineIterator between consecutive vertices), lethal as soon as a vertex is off the map.
"""

from __future__ import annotations

import math
import re
import sys

import numpy as np

from armando_drake.navigation.cost_values import LETHAL_OBSTACLE

FOOTPRINT_POINTS = 16  # makeFootprintFromRadius's polygon
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def parse_vvf(text: str) -> tuple[list[list[float]], str]:
    """nav2_util's ``parseVVF``: a string of vectors of numbers "[[1, 2.2], [.3, -4e4]]"
    as (the vectors read, the error: "" when none)."""
    result: list[list[float]] = []
    current: list[float] = []
    depth, k = 0, 0
    while k < len(text):
        char = text[k]
        if char == "[":
            depth += 1
            if depth > 2:
                return result, "Array depth greater than 2"
            current, k = [], k + 1
        elif char == "]":
            depth -= 1
            if depth < 0:
                return result, "More close ] than open ["
            if depth == 1:
                result.append(current)
            k += 1
        elif char in ", \t":
            k += 1
        elif depth != 2:
            return result, f"Numbers at depth other than 2. Char was '{char}'."
        else:
            number = _NUMBER.match(text, k)
            if number is None:
                break  # the stream fails: what follows is not read
            current.append(float(number.group()))
            k = number.end()
    return result, ("Unterminated vector string." if depth != 0 else "")


def footprint_from_string(text: str) -> list[tuple[float, float]]:
    """``makeFootprintFromString``: the polygon of "[[x, y], ...]"; a ValueError with
    upstream's reason for a string that does not parse, fewer than three points, or a
    point that is not a pair."""
    vvf, error = parse_vvf(text)
    if error:
        raise ValueError(f"Error parsing footprint parameter: '{error}'")
    if len(vvf) < 3:
        raise ValueError("You must specify at least three points for the robot footprint")
    for point in vvf:
        if len(point) != 2:
            raise ValueError(
                "Points in the footprint specification must be pairs of numbers. "
                f"Found a point with {len(point)} numbers."
            )
    return [(p[0], p[1]) for p in vvf]


def footprint_from_radius(radius: float) -> list[tuple[float, float]]:
    """A circular robot's footprint: 16 points on the circle of ``radius``, from +x."""
    return [
        (math.cos(k * 2 * math.pi / FOOTPRINT_POINTS) * radius,
         math.sin(k * 2 * math.pi / FOOTPRINT_POINTS) * radius)
        for k in range(FOOTPRINT_POINTS)
    ]  # fmt: skip


def _sign0(v: float) -> float:
    return 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)


def pad_footprint(footprint, padding: float) -> list[tuple[float, float]]:
    """Each point moved ``padding`` [m] away from the centre along x and along y (a point on
    an axis only along the other)."""
    return [(x + _sign0(x) * padding, y + _sign0(y) * padding) for x, y in footprint]


def _distance_to_line(x0, y0, x1, y1) -> float:
    """The distance from the origin to the segment (x0, y0)-(x1, y1) (costmap_math's
    distanceToLine)."""
    c, d = x1 - x0, y1 - y0
    length = c * c + d * d
    t = (-x0 * c - y0 * d) / length if length != 0 else -1.0
    if t < 0:
        x, y = x0, y0
    elif t > 1:
        x, y = x1, y1
    else:
        x, y = x0 + t * c, y0 + t * d
    return math.hypot(x, y)


def min_max_distances(footprint) -> tuple[float, float]:
    """(inscribed, circumscribed) radius of a footprint polygon: the smallest and largest
    distance from the centre to a vertex or an edge; (the largest float, 0) for fewer than
    three points, as upstream."""
    if len(footprint) <= 2:
        return sys.float_info.max, 0.0
    low, high = sys.float_info.max, 0.0
    n = len(footprint)
    for k in range(n):
        (x0, y0), (x1, y1) = footprint[k], footprint[(k + 1) % n]
        vertex = math.hypot(x0, y0)
        edge = _distance_to_line(x0, y0, x1, y1)
        low = min(low, vertex, edge)
        high = max(high, vertex, edge)
    return low, high


def line_cells(x0: int, y0: int, x1: int, y1: int) -> list[tuple[int, int]]:
    """The cells (x, y) of nav2_util's LineIterator from (x0, y0) to (x1, y1), both ends in."""
    dx, dy = abs(x1 - x0), abs(y1 - y0)
    sx = 1 if x1 >= x0 else -1
    sy = 1 if y1 >= y0 else -1
    if dx >= dy:  # one x step each time, y when the numerator overflows
        inc1, inc2, den, num, add, pixels = (0, sy), (sx, 0), dx, dx // 2, dy, dx
    else:
        inc1, inc2, den, num, add, pixels = (sx, 0), (0, sy), dy, dy // 2, dx, dy
    x, y = x0, y0
    cells = [(x, y)]
    for _ in range(pixels):
        num += add
        if num >= den:
            num -= den
            x, y = x + inc1[0], y + inc1[1]
        x, y = x + inc2[0], y + inc2[1]
        cells.append((x, y))
    return cells


def _to_map(costmap, wx: float, wy: float):
    """Costmap2D::worldToMap: the cell (x, y) of a world point, None off the map."""
    if wx < costmap.origin[0] or wy < costmap.origin[1]:
        return None
    mx = int((wx - costmap.origin[0]) / costmap.resolution)
    my = int((wy - costmap.origin[1]) / costmap.resolution)
    rows, cols = costmap.costs.shape
    return (mx, my) if mx < cols and my < rows else None


def footprint_cost(costmap, pose, footprint) -> float:
    """FootprintCollisionChecker::footprintCostAtPose: ``footprint`` (the robot frame's
    polygon) at ``pose`` (x, y, yaw) on ``costmap``; the highest cost along its outline,
    LETHAL_OBSTACLE if a vertex is off the map or as soon as a lethal cell is met."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    corners = []
    for px, py in footprint:
        cell = _to_map(costmap, pose[0] + px * c - py * s, pose[1] + px * s + py * c)
        if cell is None:
            return float(LETHAL_OBSTACLE)
        corners.append(cell)
    cost = 0.0
    for k in range(len(corners)):
        (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % len(corners)]
        cells = np.array(line_cells(x0, y0, x1, y1))
        cost = max(cost, float(costmap.costs[cells[:, 1], cells[:, 0]].max()))
        if cost == LETHAL_OBSTACLE:
            return cost
    return cost
