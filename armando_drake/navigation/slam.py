"""Mapping as slam_toolbox does it online: an occupancy grid from the lidar's scans and the
drive's odometry, the odometry's drift corrected by matching each scan against the map.

:func:`slam_parameters` reads ``slam_toolbox.ros__parameters`` (or ``slam.ros__parameters``)
of a slam_toolbox YAML; the parameters it applies:

- ``resolution`` of the grid, ``max_laser_range`` (beams beyond it clear the free space up
  to it and mark nothing), ``throttle_scans`` (one scan in so many), ``minimum_time_interval``
  and ``minimum_travel_distance`` / ``minimum_travel_heading`` (a scan is used only after
  the odometry moved that much since the last one used, but for the first);
- ``use_scan_matching``: the scan is matched against the map so far (a correlative scan
  matcher, as Karto's): the map's occupied cells smeared into a likelihood field with
  ``correlation_search_space_smear_deviation`` (on a grid SUB times finer, made of the
  sub-cells the end points fell in, so that a wall on a cell's edge does not pull the
  matches half a cell), each candidate pose scored by the field
  at its beams' end points (bilinear), searched over ``correlation_search_space_dimension``
  (x and y) around the odometry's prediction, first at the map's resolution with headings
  within ``coarse_search_angle_offset`` at ``coarse_angle_resolution``, then at
  ``correlation_search_space_resolution`` with headings within ``coarse_angle_resolution``
  at ``fine_search_angle_offset``; the response is penalized away from the prediction as
  Karto's (``distance_variance_penalty`` / ``minimum_distance_penalty``,
  ``angle_variance_penalty`` / ``minimum_angle_penalty``);
- ``map_update_interval``: how often the map is published (the exploration plans on it);
  ``transform_publish_period``: map -> odom is published at each scan used.

The grid holds log-odds: a beam's cells before its end are free (-0.7), its end cell
occupied (+0.9), clamped to +-4, each cell counted once a scan (rays sampled every cell,
numpy over all beams at once). The robot's footprint is free (it stands there). The
published map: occupied above +0.5, free below -0.5, unknown between and where unseen.

Not applied, warned by name: the pose graph and its solver (``solver_plugin``,
``ceres_*``), loop closure (``do_loop_closing``, ``loop_*``), the scan buffer
(``scan_buffer_*``, ``link_*``): the scans are matched against the whole map built so far.
The map's canvas is fixed (the world's extent and a margin) where slam_toolbox grows it.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from pathlib import Path

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, LeafSystem

from armando_drake.messages.types import PublicationValue
from armando_drake.navigation.follower import wrap
from armando_drake.navigation.maps import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from armando_drake.navigation.nav2_params import fill, read_yaml
from armando_drake.navigation.pose_buffer import RobotPoses, compose, inverse
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import param

NODES = ("slam_toolbox", "slam")  # the node's name in the YAML: upstream's, the course's
L_FREE, L_OCCUPIED, L_CLAMP = -0.7, 0.9, 4.0
OCCUPIED_ABOVE, FREE_BELOW = 0.5, -0.5
SUB = 4  # the likelihood field's cells per map cell, each way
FIELD_EVERY = 3  # the likelihood field is recomputed every so many scans used

_log = logging.getLogger("armando_drake.navigation")


@dc.dataclass
class SlamParameters:
    """slam_toolbox's parameters applied here (defaults: upstream's), each declared with
    its unit, range and meaning (checked by the schema's rules: :func:`.nav2_params.fill`)."""

    mode: str = param(
        "mapping", choices=("mapping",), why="only mapping is known", doc="mapping only"
    )
    resolution: float = param(
        0.05,
        unit="m",
        gt=0,
        under=(1e-3, "a grid that fine is too large to build"),
        over=(10.0, "a grid that coarse maps nothing"),
        doc="the map's cell size",
    )
    max_laser_range: float = param(20.0, unit="m", gt=0, doc="ranges used for the map")
    map_update_interval: float = param(5.0, unit="s", gt=0, doc="between published maps")
    transform_publish_period: float = param(
        0.02, unit="s", ge=0, doc="between map -> odom transforms"
    )
    throttle_scans: float = param(1, unit="-", gt=0, doc="every n-th scan is used")
    minimum_time_interval: float = param(0.5, unit="s", ge=0, doc="between scans used")
    minimum_travel_distance: float = param(0.5, unit="m", ge=0, doc="travel between scans used")
    minimum_travel_heading: float = param(0.5, unit="rad", ge=0, doc="turn between scans used")
    use_scan_matching: bool = param(True, doc="correct the odometry by correlative scan matching")
    correlation_search_space_dimension: float = param(
        0.5, unit="m", gt=0, doc="the matcher's search window"
    )
    correlation_search_space_resolution: float = param(
        0.01, unit="m", gt=0, doc="the search window's step"
    )
    correlation_search_space_smear_deviation: float = param(
        0.1, unit="m", gt=0, doc="the response's smearing"
    )
    distance_variance_penalty: float = param(
        0.5, unit="-", gt=0, doc="penalty of a match far from the odometry"
    )
    angle_variance_penalty: float = param(
        1.0, unit="-", gt=0, doc="penalty of a match turned from the odometry"
    )
    coarse_search_angle_offset: float = param(
        0.349, unit="rad", ge=0, doc="the coarse angular window"
    )
    coarse_angle_resolution: float = param(0.0349, unit="rad", gt=0, doc="the coarse window's step")
    fine_search_angle_offset: float = param(0.00349, unit="rad", gt=0, doc="the fine angular step")
    minimum_angle_penalty: float = param(0.9, unit="-", ge=0, doc="the angle penalty's floor")
    minimum_distance_penalty: float = param(0.5, unit="-", ge=0, doc="the distance penalty's floor")
    ignored: list[str] = dc.field(default_factory=list)


_KNOWN = {
    "use_sim_time", "odom_frame", "map_frame", "base_frame", "scan_topic", "debug_logging",
    "transform_timeout", "tf_buffer_duration", "stack_size_to_use", "enable_interactive_mode",
    "scan_queue_size", "map_name", "use_map_saver",
}  # fmt: skip
_NOT_APPLIED = {
    "solver_plugin": "no pose graph: each scan is matched against the map so far",
    "do_loop_closing": "no loop closure",
    "use_scan_barycenter": "the scan's pose is the laser's",
    "use_response_expansion": "the search window is fixed",
    "map_file_name": "mapping starts from an empty map",
    "map_start_pose": "mapping starts at the odometry's origin",
    "map_start_at_dock": "mapping starts at the odometry's origin",
}
_PREFIXES = {
    "ceres_": "no pose graph, no solver",
    "loop_": "no loop closure",
    "scan_buffer_": "matched against the whole map, not a scan buffer",
    "link_": "matched against the whole map, not a scan buffer",
}


def _fields(cls) -> list[str]:
    """The parameters of a parameter dataclass (its fields but ``ignored``)."""
    return [f.name for f in dc.fields(cls) if f.name != "ignored"]


def slam_parameters(path: str | Path) -> SlamParameters:
    """The slam_toolbox node's parameters of a YAML; keys not applied are warned about by
    name (and listed in ``ignored``); a bad value is a one-line ConfigError."""
    path = Path(path)
    doc = read_yaml(path)
    node = next((n for n in NODES if isinstance(doc.get(n), dict)), None)
    ros = doc[node].get("ros__parameters") if node else None
    if not isinstance(ros, dict):
        raise ConfigError(f"{path}: slam_toolbox.ros__parameters: missing (no slam_toolbox node)")
    where = f"{path}: {node}.ros__parameters"
    params = SlamParameters()
    ignored = []
    for key in fill(params, ros, where, _fields(SlamParameters)):
        if key not in _KNOWN:
            ignored.append(key)
            prefix = next((p for p in _PREFIXES if key.startswith(p)), None)
            why = _NOT_APPLIED.get(key) or (_PREFIXES[prefix] if prefix else "not used here")
            _log.warning("%s.%s: %s", where, key, why)
    params.ignored = [f"{where}.{k}" for k in ignored]
    return params


# ------------------------------------------------------------------------------ the grid


def canvas(extent: OccupancyMap, resolution: float, margin: float = 1.0) -> OccupancyMap:
    """An unknown map covering ``extent``'s area and ``margin`` around, at ``resolution``,
    its cells aligned with ``extent``'s when the resolutions agree."""
    x0, y0, _ = extent.origin
    w, h = extent.size_m
    pad = math.ceil(margin / resolution) * resolution
    cols = math.ceil((w + 2 * pad) / resolution)
    rows = math.ceil((h + 2 * pad) / resolution)
    data = np.full((rows, cols), UNKNOWN, dtype=np.int8)
    return OccupancyMap(data, resolution, (x0 - pad, y0 - pad, 0.0), source="slam")


def occupancy(logodds: np.ndarray, like: OccupancyMap) -> OccupancyMap:
    """The published map of a log-odds grid: 100 occupied, 0 free, -1 unknown."""
    data = np.full(logodds.shape, UNKNOWN, dtype=np.int8)
    data[logodds < FREE_BELOW] = FREE
    data[logodds > OCCUPIED_ABOVE] = OCCUPIED
    return OccupancyMap(data, like.resolution, like.origin, source="slam")


def beams(scan, max_range: float, every: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(angles, ranges, hit) of a scan's usable beams: those with a return (finite, from
    ``range_min``); those beyond ``max_range`` cut to it (``hit`` False). A beam with no
    return is not used."""
    ranges = np.asarray(scan.ranges, dtype=float)[::every]
    angles = (scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges)))[::every]
    limit = min(max_range, scan.range_max)
    keep = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges > 0)
    ranges, angles = ranges[keep], angles[keep]
    hit = np.isfinite(ranges) & (ranges < limit)
    return angles, np.where(hit, ranges, limit), hit


def insert_scan(
    logodds, grid: OccupancyMap, pose, laser, scan, max_range, footprint=0.0, hits=None
):
    """``logodds`` (a new array) with the scan taken at base ``pose`` (x, y, yaw) added; the
    laser at ``laser`` (x, y, yaw) in the base frame. With ``hits`` (SUB height, SUB
    width): the end points' count in each sub-cell, updated in place."""
    angles, ranges, hit = beams(scan, max_range)
    sx, sy, syaw = compose(pose, laser)
    res = grid.resolution
    step = res
    count = int(math.ceil(ranges.max() / step)) if len(ranges) else 0
    t = np.arange(count) * step
    heading = syaw + angles
    along = t[None, :] < (ranges - res)[:, None]  # free: up to a cell before the end
    px = sx + np.cos(heading)[:, None] * t[None, :]
    py = sy + np.sin(heading)[:, None] * t[None, :]
    free = np.zeros(logodds.shape, dtype=bool)
    _mark(free, grid, px[along], py[along])
    if footprint > 0:
        r = np.arange(-footprint, footprint + step, step)
        fx, fy = np.meshgrid(r, r)
        inside = fx**2 + fy**2 <= footprint**2
        _mark(free, grid, pose[0] + fx[inside], pose[1] + fy[inside])
    occupied = np.zeros(logodds.shape, dtype=bool)
    ex = sx + np.cos(heading[hit]) * ranges[hit]
    ey = sy + np.sin(heading[hit]) * ranges[hit]
    _mark(occupied, grid, ex, ey)
    if hits is not None:
        _accumulate(hits, grid, ex, ey)
    out = logodds + np.where(occupied, L_OCCUPIED, np.where(free, L_FREE, 0.0))
    return np.clip(out, -L_CLAMP, L_CLAMP, out=out)


def _accumulate(hits: np.ndarray, grid: OccupancyMap, x: np.ndarray, y: np.ndarray) -> None:
    """Counts the end points in ``hits``' cells (``grid``'s split in SUB x SUB)."""
    h, w = hits.shape
    step = grid.resolution / SUB
    col = np.floor((x - grid.origin[0]) / step).astype(np.int64)
    row = np.floor((y - grid.origin[1]) / step).astype(np.int64)
    inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
    hits += np.bincount(row[inside] * w + col[inside], minlength=h * w).reshape(h, w)


def _mark(mask: np.ndarray, grid: OccupancyMap, x: np.ndarray, y: np.ndarray) -> None:
    col = np.floor((x - grid.origin[0]) / grid.resolution).astype(np.int64)
    row = np.floor((y - grid.origin[1]) / grid.resolution).astype(np.int64)
    inside = (row >= 0) & (row < mask.shape[0]) & (col >= 0) & (col < mask.shape[1])
    mask[row[inside], col[inside]] = True


# ------------------------------------------------------------------------- scan matching


def likelihood(logodds: np.ndarray, grid: OccupancyMap, smear: float, hits=None) -> np.ndarray:
    """The occupied cells smeared: ``exp(-d^2 / (2 smear^2))`` of each cell's distance to
    the nearest occupied one; with ``hits`` (end point counts on the grid split SUB x SUB),
    on that finer grid: the distance to the nearest sub-cell an end point fell in, within
    an occupied cell (a wall on a cell's edge does not pull the matches half a cell)."""
    from scipy import ndimage  # the navigation extra: imported where used

    occupied = logodds > OCCUPIED_ABOVE
    if hits is not None:
        occupied = np.repeat(np.repeat(occupied, SUB, axis=0), SUB, axis=1) & (hits > 0)
    field = np.zeros(occupied.shape, dtype=np.float32)
    if not occupied.any():
        return field
    step = grid.resolution / (SUB if hits is not None else 1)
    # Only around the occupied cells (beyond 4 smears the field is nought).
    rows, cols = np.nonzero(occupied.any(axis=1))[0], np.nonzero(occupied.any(axis=0))[0]
    pad = int(math.ceil(4 * smear / step))
    r0, r1 = max(rows[0] - pad, 0), rows[-1] + pad + 1
    c0, c1 = max(cols[0] - pad, 0), cols[-1] + pad + 1
    d = ndimage.distance_transform_edt(~occupied[r0:r1, c0:c1]) * step
    field[r0:r1, c0:c1] = np.exp(-(d * d) / (2 * smear * smear))
    return field


def match(field, grid: OccupancyMap, predicted, laser, scan, p: SlamParameters, every=8):
    """The base pose (x, y, yaw) near ``predicted`` that best fits the scan to ``field``
    (coarse then fine correlative search), and its response (0..1)."""
    angles, ranges, hit = beams(scan, p.max_laser_range, every)
    angles, ranges = angles[hit], ranges[hit]
    if len(ranges) < 10:
        return tuple(predicted), 0.0
    # The end points in the base frame (half of them for the coarse search).
    lx, ly, lyaw = laser
    bx = lx + np.cos(lyaw + angles) * ranges
    by = ly + np.sin(lyaw + angles) * ranges
    half = p.correlation_search_space_dimension / 2
    coarse = _search(
        field, grid, (bx[::2], by[::2]), predicted, predicted, half, grid.resolution,
        p.coarse_search_angle_offset, p.coarse_angle_resolution, p, nearest=True,
    )  # fmt: skip
    fine = _search(
        field, grid, (bx, by), coarse[0], predicted, grid.resolution / 2,
        p.correlation_search_space_resolution, p.coarse_angle_resolution / 2,
        p.fine_search_angle_offset, p,
    )  # fmt: skip
    return fine


def _search(
    field, grid, points, centre, predicted, half, step, angle_half, angle_step, p, nearest=False
):
    """The best of the poses around ``centre``: x and y within ``half`` at ``step``, the
    heading within ``angle_half`` at ``angle_step``; the field read bilinearly (or at the
    nearest cell, for the coarse search at the map's resolution)."""
    bx, by = points
    n = int(round(half / step))
    offsets = np.arange(-n, n + 1) * step
    m = int(round(angle_half / angle_step))
    yaws = centre[2] + np.arange(-m, m + 1) * angle_step
    c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
    rx, ry = c * bx - s * by, s * bx + c * by  # (angles, beams)
    dx, dy = np.meshgrid(offsets, offsets, indexing="ij")
    tx, ty = centre[0] + dx.ravel(), centre[1] + dy.ravel()  # (translations,)
    # In cells (float32: a cell's hundredth is well within its precision).
    cell = grid.resolution * grid.height / field.shape[0]  # the field's cells: maybe finer
    rc = ((rx - grid.origin[0]) / cell - 0.5).astype(np.float32)
    rr = ((ry - grid.origin[1]) / cell - 0.5).astype(np.float32)
    col = rc[:, None, :] + (tx / cell).astype(np.float32)[None, :, None]
    row = rr[:, None, :] + (ty / cell).astype(np.float32)[None, :, None]
    values = _nearest(field, row + 0.5, col + 0.5) if nearest else _bilinear(field, row, col)
    response = values.mean(axis=2)  # (angles, translations)
    # Karto's penalties away from the prediction.
    d2 = (tx - predicted[0]) ** 2 + (ty - predicted[1]) ** 2
    dist_penalty = np.maximum(
        1 - 0.2 * d2 / p.distance_variance_penalty, p.minimum_distance_penalty
    )
    da = np.angle(np.exp(1j * (yaws - predicted[2])))
    angle_penalty = np.maximum(1 - 0.2 * da**2 / p.angle_variance_penalty, p.minimum_angle_penalty)
    response = response * dist_penalty[None, :] * angle_penalty[:, None]
    a, t = np.unravel_index(int(np.argmax(response)), response.shape)
    return (float(tx[t]), float(ty[t]), wrap(float(yaws[a]))), float(response[a, t])


def _nearest(field: np.ndarray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """``field`` at the cells holding fractional (row, col) (cell units), 0 outside."""
    h, w = field.shape
    r, c = row.astype(np.int64), col.astype(np.int64)  # positive inside: truncation floors
    inside = (row >= 0) & (r < h) & (col >= 0) & (c < w)
    return np.where(inside, field.ravel().take(np.where(inside, r * w + c, 0)), 0.0)


def _bilinear(field: np.ndarray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """``field`` at fractional (row, col), 0 outside."""
    h, w = field.shape
    r0, c0 = np.floor(row), np.floor(col)
    fr, fc = (row - r0).astype(np.float32), (col - c0).astype(np.float32)
    r0, c0 = r0.astype(np.int64), c0.astype(np.int64)
    inside = (r0 >= 0) & (r0 < h - 1) & (c0 >= 0) & (c0 < w - 1)
    flat = np.where(inside, r0 * w + c0, 0)
    f = field.ravel()
    v00, v01 = f.take(flat), f.take(flat + 1)
    v10, v11 = f.take(flat + w), f.take(flat + w + 1)
    top = v00 + (v01 - v00) * fc
    bottom = v10 + (v11 - v10) * fc
    return np.where(inside, top + (bottom - top) * fr, 0.0)


# ---------------------------------------------------------------------------- the system


@dc.dataclass(frozen=True)
class SlamState:
    """The mapper's state; never mutated (a new one at each scan used)."""

    logodds: np.ndarray
    hits: np.ndarray  # the end points' count in each sub-cell (SUB x SUB a cell)
    field: np.ndarray | None = None  # the likelihood field matched against
    pose: tuple | None = None  # the base's corrected pose at the last scan used
    odom: tuple | None = None  # the odometry's pose then
    stamp: float = -math.inf  # that scan's stamp
    scan_count: int = 0  # the scan publication last seen
    seen: int = 0  # scans seen (for throttle_scans)
    used: int = 0  # scans used
    response: float = 0.0  # the last match's response
    published: float = -math.inf  # when the map was last published

    def __deepcopy__(self, memo):
        return self


class SlamMapper(LeafSystem):
    """slam_toolbox's online mapping (see the module docstring).

    .. pydrake_system::

        name: SlamMapper
        input_ports:
        - poses
        - scan
        output_ports:
        - map_to_odom
        - estimate
        - map

    - ``poses``: the robot's :class:`~.pose_buffer.RobotPoses` (the odometry at a scan's
      stamp); ``scan``: a Publication of LaserScan;
    - ``map_to_odom``: (x, y, yaw) of the odometry frame in the map;
    - ``estimate``: (x, y, yaw) of the base in the map at the last scan used;
    - ``map``: the OccupancyMap published every ``map_update_interval``.
    """

    def __init__(self, params: SlamParameters, blank: OccupancyMap, laser, *, rate,
                 footprint: float = 0.0, start=(0.0, 0.0, 0.0)):  # fmt: skip
        super().__init__()
        self.params = params
        self.blank = blank
        self.laser = tuple(float(v) for v in laser)
        self._footprint = footprint
        self._start = tuple(float(v) for v in start)
        self._poses = self.DeclareAbstractInputPort("poses", AbstractValue.Make(RobotPoses()))
        self._scan = self.DeclareAbstractInputPort("scan", PublicationValue())
        shape = blank.data.shape
        hits = np.zeros((SUB * shape[0], SUB * shape[1]), dtype=np.int32)
        initial = SlamState(np.zeros(shape, dtype=np.float32), hits)
        self._state = self.DeclareAbstractState(AbstractValue.Make(initial))
        self._map = self.DeclareAbstractState(AbstractValue.Make(blank))
        self._map_to_odom = self.DeclareDiscreteState(BasicVector(np.array(self._start)))
        self._estimate = self.DeclareDiscreteState(BasicVector(np.array(self._start)))
        self.DeclareStateOutputPort("map_to_odom", self._map_to_odom)
        self.DeclareStateOutputPort("estimate", self._estimate)
        self.DeclareStateOutputPort("map", self._map)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._Update)

    def _Update(self, context, state) -> None:
        odometry = self._poses.Eval(context).odom
        s = context.get_abstract_state(self._state).get_value()
        scan = self._scan.Eval(context) if self._scan.HasValue(context) else None
        if scan is not None and scan.count != s.scan_count and scan.message is not None:
            s = dc.replace(s, scan_count=scan.count, seen=s.seen + 1)
            if (s.seen - 1) % max(1, int(self.params.throttle_scans)) == 0:
                s = self._use(s, scan.message, odometry.at(scan.message.stamp), state)
        now = context.get_time()
        if now - s.published >= self.params.map_update_interval - 1e-9 and s.used:
            state.get_mutable_abstract_state(self._map).set_value(occupancy(s.logodds, self.blank))
            s = dc.replace(s, published=now)
        state.get_mutable_abstract_state(self._state).set_value(s)

    def _use(self, s: SlamState, scan, odom, state) -> SlamState:
        """The scan matched and inserted, when the robot moved enough since the last one
        (``odom``: the odometry's pose at the scan's stamp)."""
        p = self.params
        if s.pose is None:
            predicted = compose(self._start, odom)  # map -> odom starts at the spawn pose
        else:
            if scan.stamp - s.stamp < p.minimum_time_interval - 1e-9:
                return s
            delta = compose(inverse(s.odom), odom)
            moved = math.hypot(delta[0], delta[1]) >= p.minimum_travel_distance
            if not (moved or abs(delta[2]) >= p.minimum_travel_heading):
                return s
            predicted = compose(s.pose, delta)
        pose, response, field = tuple(predicted), 0.0, s.field
        if p.use_scan_matching and s.used:
            smear = p.correlation_search_space_smear_deviation
            field = s.field
            if field is None or s.used % FIELD_EVERY == 0:
                field = likelihood(s.logodds, self.blank, smear, s.hits)
            pose, response = match(field, self.blank, predicted, self.laser, scan, p)
        hits = s.hits.copy()  # the state's own is never changed
        logodds = insert_scan(
            s.logodds, self.blank, pose, self.laser, scan, p.max_laser_range, self._footprint,
            hits,
        ).astype(np.float32)  # fmt: skip
        state.get_mutable_discrete_state(self._estimate).set_value(pose)
        state.get_mutable_discrete_state(self._map_to_odom).set_value(compose(pose, inverse(odom)))
        return dc.replace(
            s, logodds=logodds, hits=hits, field=field, pose=pose, odom=odom, stamp=scan.stamp,
            used=s.used + 1, response=response,
        )  # fmt: skip

    @property
    def start(self) -> tuple:
        """The base's pose where the map starts (the map frame's odometry origin)."""
        return self._start

    def scans_used(self, context) -> int:
        return context.get_abstract_state(self._state).get_value().used

    def poses(self, context) -> tuple[tuple, tuple]:
        """The base's pose (x, y, yaw) in the map by the odometry alone, and corrected
        (map -> odom, then the odometry), now."""
        odom = self._poses.Eval(context).odom.latest
        map_to_odom = context.get_discrete_state(self._map_to_odom).get_value()
        return compose(self._start, odom), compose(map_to_odom, odom)

    def current_map(self, context) -> OccupancyMap:
        """The map as built so far (not only as last published)."""
        s = context.get_abstract_state(self._state).get_value()
        return occupancy(s.logodds, self.blank)


# ---------------------------------------------------------------------------- accuracy


def map_accuracy(built: OccupancyMap, truth: OccupancyMap, start, robot_radius: float) -> dict:
    """The built map against the world's true occupancy, at the built map's resolution:

    - ``precision``: the built map's occupied cells within one cell of a true one;
    - ``recall``: the true occupied cells bordering the free space around ``start`` (x, y)
      (those a lidar there can see) within one cell of a built occupied one;
    - ``coverage``: the free cells the robot's centre can reach from ``start`` (farther than
      ``robot_radius`` from any obstacle) known as free in the built map;
    - ``free_known``: the same of all the free space around ``start``;
    - ``explored_area`` [m^2]: the cells known (free or occupied)."""
    from scipy import ndimage  # the navigation extra: imported where used

    res = built.resolution
    rows, cols = np.indices(built.data.shape)
    x = built.origin[0] + (cols + 0.5) * res
    y = built.origin[1] + (rows + 0.5) * res
    tc = np.floor((x - truth.origin[0]) / truth.resolution).astype(int)
    tr = np.floor((y - truth.origin[1]) / truth.resolution).astype(int)
    inside = (tr >= 0) & (tr < truth.height) & (tc >= 0) & (tc < truth.width)
    t = np.full(built.data.shape, UNKNOWN, dtype=np.int16)
    t[inside] = truth.data[tr[inside], tc[inside]]
    t_occ, t_free = t >= 65, t == FREE
    srow = int((start[1] - built.origin[1]) // res)
    scol = int((start[0] - built.origin[0]) // res)

    def around_start(mask):
        labels, _ = ndimage.label(mask)
        return labels == labels[srow, scol] if labels[srow, scol] else np.zeros_like(mask)

    free_space = around_start(t_free)
    clearance = ndimage.distance_transform_edt(~t_occ) * res
    reachable = around_start(t_free & (clearance > robot_radius))
    square = np.ones((3, 3), dtype=bool)
    visible = t_occ & ndimage.binary_dilation(free_space, structure=square)
    b_occ, b_free = built.data >= OCCUPIED, built.data == FREE

    def ratio(a, b):
        return float(a.sum() / b.sum()) if b.any() else 0.0

    return {
        "precision": ratio(b_occ & ndimage.binary_dilation(t_occ, structure=square), b_occ),
        "recall": ratio(visible & ndimage.binary_dilation(b_occ, structure=square), visible),
        "coverage": ratio(reachable & b_free, reachable),
        "free_known": ratio(free_space & b_free, free_space),
        "explored_area": float((b_occ | b_free).sum() * res * res),
        "free_area": float(free_space.sum() * res * res),
        "occupied_cells": int(b_occ.sum()),
        "true_occupied_cells": int(visible.sum()),
        "tolerance_cells": 1,
    }
