"""AMCL as nav2_amcl localizes: a particle filter on the map, the drive's odometry and the
lidar's scans.

:func:`amcl_parameters` reads ``amcl.ros__parameters`` of a Nav2 YAML. The filter
(:class:`ParticleFilter`, numpy over all particles at once):

- **motion** (``nav2_amcl::DifferentialMotionModel``): the odometry's change since the
  last filter update as (rot1, trans, rot2), each particle's drawn with the noise of
  ``alpha1`` (rotation from rotation), ``alpha2`` (rotation from translation), ``alpha3``
  (translation from translation) and ``alpha4`` (translation from rotation), as
  upstream's ``odometryUpdate``; with ``robot_model_type: nav2_amcl::OmniMotionModel``
  the omni model's (``OmniMotionModel::odometryUpdate``: the translation along the
  odometry's bearing, a rotation and a strafe across it, ``alpha5`` the strafe's noise from
  translation; under the differential model ``alpha5`` is warned about);
- **sensor** (``likelihood_field``): every step-th beam of the scan from the first, step
  ``(beams - 1) // (max_beams - 1)`` (at least 1), those over ``laser_min_range`` and
  under ``laser_max_range`` (upstream takes a reading at or under the minimum as the
  maximum, which the model ignores); each beam's end point in the map, ``z`` its
  distance to the nearest occupied cell (a distance transform, capped at
  ``laser_likelihood_max_dist``), ``pz = z_hit exp(-z^2 / (2 sigma_hit^2)) + z_rand /
  range_max``, and a particle's weight multiplied by ``1 + sum pz^3`` (upstream's). An end
  point falls in the cell that contains it (map_server's convention); upstream's
  ``MAP_GXWX`` rounds instead, taking cell ``i`` as centred at ``origin + i *
  resolution``, half a cell off the map it loaded: not reproduced (on the fra2mo_amcl
  scenario it shifts the estimate by half a cell, 2.5 cm in x and in y);
- an update only when ``|dx|`` or ``|dy|`` of the odometry (each alone, in its frame) is
  over ``update_min_d`` or ``|dyaw|`` over ``update_min_a`` since the last one (and at the
  first scan), as ``AmclNode::shouldUpdateFilter``; resampling every
  ``resample_interval`` updates by upstream's sampler (each particle drawn independently
  by the cumulative weights);
- ``max_particles`` particles, drawn at the start around the initial pose (``initial_pose``
  with ``set_initial_pose``, else the scenario's) with upstream's initial covariance
  (0.5 m, 0.5 m, pi/12 rad standard deviations);
- the estimate: the particles' weighted mean (circular for the heading); it is published as
  ``map -> odom`` (the estimate composed with the odometry's inverse), so between
  updates the pose follows the odometry, as Nav2's TF tree does.

KLD-adaptive sampling (``min_particles``, ``pf_err``, ``pf_z``), the recovery
(``recovery_alpha_slow``/``fast``) and beam skipping are not applied: warned by name.
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
from armando_drake.navigation.maps import OCCUPIED, OccupancyMap
from armando_drake.navigation.nav2_params import Nav2Params, as_nav2, fill
from armando_drake.navigation.pose_buffer import RobotPoses, compose, inverse
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.schema import field_rules, param

DIFFERENTIAL = "nav2_amcl::DifferentialMotionModel"
OMNI = "nav2_amcl::OmniMotionModel"
INITIAL_STD = (0.5, 0.5, math.pi / 12)  # nav2_amcl's initial covariance, as deviations

_log = logging.getLogger("armando_drake.navigation")


def _noise(doc: str):
    return param(0.2, unit="-", ge=0, doc=doc)


@dc.dataclass
class AmclParameters:
    """nav2_amcl's parameters (defaults: upstream's)."""

    alpha1: float = _noise("rotation noise from rotation (odometry model)")
    alpha2: float = _noise("rotation noise from translation")
    alpha3: float = _noise("translation noise from translation")
    alpha4: float = _noise("translation noise from rotation")
    alpha5: float = _noise("strafe noise from translation (omni model)")
    laser_likelihood_max_dist: float = param(
        2.0, unit="m", ge=0, doc="the likelihood field's distance cap"
    )
    laser_max_range: float = param(
        100.0, unit="m", ge=0, doc="ranges from it on are dropped (0: the scan's range_max)"
    )
    laser_min_range: float = param(
        -1.0, unit="m", doc="ranges up to it are dropped (-1: the scan's range_min)"
    )
    max_beams: float = param(
        60.0, unit="-", ge=2, doc="every (n - 1) // (max_beams - 1)-th of a scan's n beams used"
    )
    max_particles: float = param(
        2000.0,
        unit="-",
        ge=1,
        le=100_000,
        doc="the particle count (fixed: no KLD sampling; each scan weighs them all)",
    )
    sigma_hit: float = param(0.2, unit="m", ge=0, doc="the hit model's deviation")
    z_hit: float = param(0.5, unit="-", ge=0, doc="weight of the hit model")
    z_rand: float = param(0.5, unit="-", ge=0, doc="weight of the random model")
    update_min_a: float = param(0.2, unit="rad", ge=0, doc="|dyaw| over it: a filter update")
    update_min_d: float = param(
        0.25, unit="m", ge=0, doc="|dx| or |dy| (each alone) over it: a filter update"
    )
    resample_interval: float = param(1.0, unit="-", ge=0, doc="filter updates between resamplings")
    set_initial_pose: bool = param(False, doc="start from initial_pose")
    robot_model_type: str = DIFFERENTIAL  # or OMNI
    initial_pose: tuple | None = None  # (x, y, yaw)
    ignored: list[str] = dc.field(default_factory=list)


_KNOWN = {
    "use_sim_time", "base_frame_id", "global_frame_id", "odom_frame_id", "scan_topic",
    "map_topic", "tf_broadcast", "transform_tolerance", "save_pose_rate",
    "always_reset_initial_pose", "first_map_only", "laser_model_type", "robot_model_type",
}  # fmt: skip
_NOT_APPLIED = {
    "min_particles": "KLD sampling is not applied: max_particles particles",
    "pf_err": "KLD sampling is not applied",
    "pf_z": "KLD sampling is not applied",
    "recovery_alpha_fast": "no recovery by random particles",
    "recovery_alpha_slow": "no recovery by random particles",
    "do_beamskip": "no beam skipping",
    "beam_skip_distance": "no beam skipping",
    "beam_skip_error_threshold": "no beam skipping",
    "beam_skip_threshold": "no beam skipping",
    "lambda_short": "the beam model's",
    "z_max": "the beam model's",
    "z_short": "the beam model's",
}


def amcl_parameters(source: Nav2Params | str | Path) -> AmclParameters:
    """``amcl.ros__parameters`` of a Nav2 file; keys not applied are warned about."""
    nav2 = as_nav2(source)
    ros = nav2.required("amcl")
    where = nav2.where("amcl")
    params = AmclParameters()
    model = ros.get("laser_model_type", "likelihood_field")
    if model != "likelihood_field":
        raise ConfigError(f"{where}.laser_model_type {model!r}: only likelihood_field is known")
    motion = ros.get("robot_model_type", DIFFERENTIAL)
    if motion not in (DIFFERENTIAL, OMNI):
        raise ConfigError(f"{where}.robot_model_type {motion!r}: known: {DIFFERENTIAL}, {OMNI}")
    params.robot_model_type = motion
    ignored = []
    keys = set(field_rules(AmclParameters)) - {"initial_pose", "ignored", "robot_model_type"}
    if motion == DIFFERENTIAL:
        keys -= {"alpha5"}
    for key in fill(params, ros, where, keys):
        if key == "alpha5":
            ignored.append(key)
            _log.warning("%s.%s: the omni motion model's", where, key)
        elif key == "initial_pose":
            pose = ros[key] if isinstance(ros[key], dict) else {}
            params.initial_pose = tuple(float(pose.get(k, 0.0)) for k in ("x", "y", "yaw"))
        elif key not in _KNOWN:
            ignored.append(key)
            why = _NOT_APPLIED.get(key, "not used here")
            _log.warning("%s.%s: %s", where, key, why)
    params.ignored = [f"{where}.{k}" for k in ignored]
    return params


def likelihood_field(grid: OccupancyMap, max_dist: float) -> np.ndarray:
    """[m] each cell's distance to the nearest occupied cell, capped at ``max_dist``."""
    from scipy import ndimage  # the navigation extra: imported where used

    occupied = grid.data >= OCCUPIED
    if not occupied.any():
        return np.full(grid.data.shape, max_dist)
    distance = ndimage.distance_transform_edt(~occupied) * grid.resolution
    return np.minimum(distance, max_dist)


@dc.dataclass(frozen=True)
class FilterState:
    """The particles and what the filter last used; never mutated."""

    particles: np.ndarray  # (n, 3) x, y, yaw in the map
    weights: np.ndarray  # (n,) summing to 1
    odom: tuple  # the odometry pose (x, y, yaw) of the last update
    updates: int = 0

    def __deepcopy__(self, memo):
        return self


class ParticleFilter:
    """AMCL's filter over a map (see the module docstring)."""

    def __init__(self, params: AmclParameters, grid: OccupancyMap, laser_pose, seed: int = 0):
        self.params = params
        self.grid = grid
        self.field = likelihood_field(grid, params.laser_likelihood_max_dist)
        self.laser = tuple(float(v) for v in laser_pose)  # (x, y, yaw) in the base frame
        self.rng = np.random.default_rng(seed)

    def start(self, pose, odom) -> FilterState:
        """Particles around ``pose`` (x, y, yaw) with upstream's initial covariance."""
        n = int(self.params.max_particles)
        particles = np.asarray(pose, dtype=float) + self.rng.normal(size=(n, 3)) * INITIAL_STD
        return FilterState(particles, np.full(n, 1.0 / n), tuple(odom))

    def moved(self, state: FilterState, odom) -> bool:
        """Whether the odometry moved enough since the last update for a new one, as
        ``AmclNode::shouldUpdateFilter`` tests it: ``|dx|`` or ``|dy|`` (in the odometry
        frame, each alone) over ``update_min_d``, or ``|dyaw|`` over ``update_min_a``."""
        dx, dy = odom[0] - state.odom[0], odom[1] - state.odom[1]
        turned = abs(wrap(odom[2] - state.odom[2]))
        d, a = self.params.update_min_d, self.params.update_min_a
        return abs(dx) > d or abs(dy) > d or turned > a

    def motion(self, particles: np.ndarray, old, new) -> np.ndarray:
        """The motion model's odometryUpdate from odometry pose ``old`` to ``new``."""
        if self.params.robot_model_type == OMNI:
            return self.omni_motion(particles, old, new)
        return self.differential_motion(particles, old, new)

    def omni_motion(self, particles: np.ndarray, old, new) -> np.ndarray:
        """OmniMotionModel::odometryUpdate: the odometry's change ``delta`` (x, y in the
        odom frame, the heading's shortest difference); each particle moves ``trans`` along
        its own heading plus the bearing of the motion in the old odometry frame, with a
        strafe across it, and turns ``rot``; each drawn with its deviation (``alpha3``,
        ``alpha4``: translation; ``alpha1``, ``alpha2``: rotation; ``alpha4``, ``alpha5``:
        strafe)."""
        p = self.params
        dx, dy = new[0] - old[0], new[1] - old[1]
        rot = wrap(new[2] - old[2])
        trans = math.hypot(dx, dy)
        trans_std = math.sqrt(p.alpha3 * trans**2 + p.alpha4 * rot**2)
        rot_std = math.sqrt(p.alpha1 * rot**2 + p.alpha2 * trans**2)
        strafe_std = math.sqrt(p.alpha4 * rot**2 + p.alpha5 * trans**2)
        n = len(particles)
        bearing = wrap(math.atan2(dy, dx) - old[2]) + particles[:, 2]
        normal = self.rng.normal(size=(3, n))
        trans_hat = trans + normal[0] * trans_std
        rot_hat = rot + normal[1] * rot_std
        strafe_hat = normal[2] * strafe_std
        cs, sn = np.cos(bearing), np.sin(bearing)
        out = particles.copy()
        out[:, 0] += trans_hat * cs + strafe_hat * sn
        out[:, 1] += trans_hat * sn - strafe_hat * cs
        out[:, 2] = np.arctan2(np.sin(particles[:, 2] + rot_hat), np.cos(particles[:, 2] + rot_hat))
        return out

    def differential_motion(self, particles: np.ndarray, old, new) -> np.ndarray:
        """DifferentialMotionModel::odometryUpdate from odometry pose ``old`` to ``new``."""
        p = self.params
        dx, dy = new[0] - old[0], new[1] - old[1]
        trans = math.hypot(dx, dy)
        rot1 = 0.0 if trans < 0.01 else wrap(math.atan2(dy, dx) - old[2])
        rot2 = wrap(wrap(new[2] - old[2]) - rot1)
        rot1_noise = min(abs(wrap(rot1)), abs(wrap(rot1 - math.pi)))
        rot2_noise = min(abs(wrap(rot2)), abs(wrap(rot2 - math.pi)))
        n = len(particles)
        normal = self.rng.normal(size=(3, n))
        rot1_hat = rot1 - normal[0] * math.sqrt(p.alpha1 * rot1_noise**2 + p.alpha2 * trans**2)
        trans_hat = trans - normal[1] * math.sqrt(
            p.alpha3 * trans**2 + p.alpha4 * (rot1_noise**2 + rot2_noise**2)
        )
        rot2_hat = rot2 - normal[2] * math.sqrt(p.alpha1 * rot2_noise**2 + p.alpha2 * trans**2)
        out = particles.copy()
        out[:, 0] += trans_hat * np.cos(particles[:, 2] + rot1_hat)
        out[:, 1] += trans_hat * np.sin(particles[:, 2] + rot1_hat)
        out[:, 2] = np.arctan2(
            np.sin(particles[:, 2] + rot1_hat + rot2_hat),
            np.cos(particles[:, 2] + rot1_hat + rot2_hat),
        )
        return out

    def likelihood(self, particles: np.ndarray, scan) -> np.ndarray:
        """LikelihoodFieldModel: ``1 + sum pz^3`` of each particle over the used beams."""
        p = self.params
        ranges = np.asarray(scan.ranges, dtype=float)
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
        # Every step-th beam from the first, step = (count - 1) // (max_beams - 1) at least 1
        # (LikelihoodFieldModel::sensorFunction): 64 of 640 beams at max_beams 60.
        step = max(1, (len(ranges) - 1) // max(1, int(p.max_beams) - 1))
        ranges, angles = ranges[::step], angles[::step]
        range_max, range_min = scan.range_max, scan.range_min  # the YAML's where positive
        if p.laser_max_range > 0:
            range_max = min(range_max, p.laser_max_range)
        if p.laser_min_range > 0:
            range_min = max(range_min, p.laser_min_range)
        # A reading at or under range_min is taken as range_max, which the model ignores
        # (AmclNode::updateFilter); so are NaN readings.
        keep = np.isfinite(ranges) & (ranges < range_max) & (ranges > range_min)
        ranges, angles = ranges[keep], angles[keep]
        total = np.ones(len(particles))
        if not len(ranges):
            return total
        x, y, yaw = particles[:, 0:1], particles[:, 1:2], particles[:, 2:3]
        lx, ly, lyaw = self.laser
        sx = x + lx * np.cos(yaw) - ly * np.sin(yaw)
        sy = y + lx * np.sin(yaw) + ly * np.cos(yaw)
        heading = yaw + lyaw + angles[None, :]
        ex = sx + ranges[None, :] * np.cos(heading)
        ey = sy + ranges[None, :] * np.sin(heading)
        grid = self.grid
        col = np.floor((ex - grid.origin[0]) / grid.resolution).astype(int)
        row = np.floor((ey - grid.origin[1]) / grid.resolution).astype(int)
        inside = (row >= 0) & (row < grid.height) & (col >= 0) & (col < grid.width)
        z = np.full(ex.shape, p.laser_likelihood_max_dist)
        z[inside] = self.field[row[inside], col[inside]]
        pz = p.z_hit * np.exp(-(z * z) / (2 * p.sigma_hit**2)) + p.z_rand / range_max
        return total + np.sum(pz**3, axis=1)

    def update(self, state: FilterState, odom, scan) -> FilterState:
        """Motion to ``odom``, the scan's weights, resampling when due."""
        particles = self.motion(state.particles, state.odom, odom)
        weights = state.weights * self.likelihood(particles, scan)
        weights = (
            weights / weights.sum()
            if weights.sum() > 0
            else np.full(len(weights), 1 / len(weights))
        )
        updates = state.updates + 1
        if updates % max(1, int(self.params.resample_interval)) == 0:
            particles, weights = self.resample(particles, weights)
        return FilterState(particles, weights, tuple(odom), updates)

    def resample(self, particles: np.ndarray, weights: np.ndarray):
        """(particles, uniform weights) drawn as ``pf_update_resample``'s naive discrete
        event sampler: each new particle independently by the cumulative weights (upstream
        leaves its low-variance sampler commented out)."""
        n = len(particles)
        draws = self.rng.random(n)
        index = np.minimum(np.searchsorted(np.cumsum(weights), draws, side="right"), n - 1)
        return particles[index], np.full(n, 1.0 / n)

    @staticmethod
    def estimate(state: FilterState) -> tuple[float, float, float]:
        """The weighted mean pose (circular mean of the headings)."""
        w = state.weights
        x, y = float(w @ state.particles[:, 0]), float(w @ state.particles[:, 1])
        yaw = math.atan2(
            float(w @ np.sin(state.particles[:, 2])), float(w @ np.cos(state.particles[:, 2]))
        )
        return x, y, yaw


@dc.dataclass(frozen=True)
class _Memory:
    filter: FilterState | None = None
    scan_count: int = 0

    def __deepcopy__(self, memo):
        return self


class AmclLocalizer(LeafSystem):
    """AMCL on the drive's odometry and a lidar's scans (:class:`ParticleFilter`).

    .. pydrake_system::

        name: AmclLocalizer
        input_ports:
        - poses
        - scan
        output_ports:
        - map_to_odom
        - estimate

    - ``poses``: the robot's :class:`~.pose_buffer.RobotPoses` (the odometry at a scan's
      stamp); ``scan``: a Publication of LaserScan;
    - ``map_to_odom``: (x, y, yaw) of the odometry frame in the map;
    - ``estimate``: (x, y, yaw) of the base in the map at the latest filter update.
    """

    def __init__(self, pf: ParticleFilter, initial_pose, *, rate: float):
        super().__init__()
        self.filter = pf
        self._initial = tuple(float(v) for v in initial_pose)
        self._poses = self.DeclareAbstractInputPort("poses", AbstractValue.Make(RobotPoses()))
        self._scan = self.DeclareAbstractInputPort("scan", PublicationValue())
        self._memory = self.DeclareAbstractState(AbstractValue.Make(_Memory()))
        self._map_to_odom = self.DeclareDiscreteState(BasicVector(np.array(self._initial)))
        self._estimate = self.DeclareDiscreteState(BasicVector(np.array(self._initial)))
        self.DeclareStateOutputPort("map_to_odom", self._map_to_odom)
        self.DeclareStateOutputPort("estimate", self._estimate)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._Update)

    def _Update(self, context, state) -> None:
        odometry = self._poses.Eval(context).odom
        memory = context.get_abstract_state(self._memory).get_value()
        scan = self._scan.Eval(context) if self._scan.HasValue(context) else None
        if memory.filter is None:
            memory = _Memory(self.filter.start(self._initial, odometry.latest), 0)
        elif scan is not None and scan.count != memory.scan_count and scan.message is not None:
            # The odometry when the scan was taken (as Nav2 looks its TF up at the stamp).
            odom = odometry.at(scan.message.stamp)
            current = memory.filter
            if current.updates == 0 or self.filter.moved(current, odom):
                current = self.filter.update(current, odom, scan.message)
                estimate = self.filter.estimate(current)
                state.get_mutable_discrete_state(self._estimate).set_value(estimate)
                map_to_odom = compose(estimate, inverse(odom))
                state.get_mutable_discrete_state(self._map_to_odom).set_value(map_to_odom)
            memory = _Memory(current, scan.count)
        state.get_mutable_abstract_state(self._memory).set_value(memory)
