"""The scenario's ``perception:`` block: which camera, how often, and the ordered steps.

A pipeline is a list of steps, each a YAML-tagged dataclass (Drake's
``yaml_load_typed`` picks the type from the tag)::

    perception:
      camera: camera
      rate: 10.0
      steps:
      - !CropBox {lower: [0.1, -0.3, -0.05], upper: [0.45, 0.3, 0.25]}
      - !VoxelDownsample {leaf_size: 0.005}
      - !StatisticalOutlierRemoval {neighbours: 20, std_ratio: 2.0}
      - !PlaneSegmentation {distance_threshold: 0.004}
      - !Clustering {tolerance: 0.01, min_points: 30, max_points: 20000}

:func:`validate_perception` checks every parameter and raises
:class:`PerceptionError` naming the step (``steps[1] VoxelDownsample``) and the
bad value. (No ``from __future__ import annotations`` here: ``yaml_load_typed``
needs the field types as types, not strings.)
"""

import dataclasses as dc
import math
from typing import Union


class PerceptionError(ValueError):
    """A perception block or step with a bad parameter; the message names the step."""


class _StepType(type):
    """Metaclass of the steps: a step type prints as its YAML tag, so that Drake's
    message for an unknown tag lists the known ones as ``!CropBox, !VoxelDownsample, ...``."""

    def __repr__(cls) -> str:
        return f"!{cls.__name__}"


@dc.dataclass
class CropBox(metaclass=_StepType):
    """Keeps the points inside an axis-aligned box, faces included."""

    # [m] lowest corner x y z, in the pipeline's frame (see PerceptionConfig.frame).
    lower: list[float] = dc.field(default_factory=lambda: [-1.0, -1.0, -1.0])
    # [m] highest corner x y z, same frame; every value >= its lower one.
    upper: list[float] = dc.field(default_factory=lambda: [1.0, 1.0, 1.0])


@dc.dataclass
class VoxelDownsample(metaclass=_StepType):
    """One point per occupied voxel, the mean of its points (Drake's
    ``PointCloud.VoxelizedDownSample``; colours are averaged too)."""

    # [m] edge of the cubic voxels; > 0.
    leaf_size: float = 0.005


@dc.dataclass
class StatisticalOutlierRemoval(metaclass=_StepType):
    """Removes points whose mean distance to their nearest neighbours is more than
    ``std_ratio`` standard deviations above the cloud's mean of that distance
    (PCL's and Open3D's filter; neighbours from SciPy's KD-tree)."""

    # [-] neighbours per point the mean distance is taken over; >= 1.
    neighbours: int = 20
    # [-] threshold in standard deviations above the mean; > 0.
    std_ratio: float = 2.0


@dc.dataclass
class EstimateNormals(metaclass=_StepType):
    """Adds a normal per point, turned towards the camera (Drake's
    ``PointCloud.EstimateNormals`` and ``FlipNormalsTowardPoint``)."""

    # [m] neighbours are searched within this radius; > 0.
    radius: float = 0.02
    # [-] at most this many nearest neighbours in the fit; >= 3.
    neighbours: int = 30


@dc.dataclass
class PlaneSegmentation(metaclass=_StepType):
    """Finds the dominant plane with RANSAC (scikit-learn's ``RANSACRegressor`` driving a
    total-least-squares plane), reports its coefficients and removes its inliers."""

    # [m] a point within this distance of the plane is an inlier; > 0.
    distance_threshold: float = 0.004
    # [-] RANSAC draws at most this many 3-point samples; >= 1.
    max_iterations: int = 1000
    # [-] a plane with fewer inliers is not reported (nothing removed); >= 3.
    min_inliers: int = 100


@dc.dataclass
class Clustering(metaclass=_StepType):
    """Groups the points into clusters: with ``min_neighbours: 1`` PCL's Euclidean
    cluster extraction (points closer than ``tolerance`` chain into one cluster;
    SciPy's KD-tree and graph components), with more scikit-learn's ``DBSCAN``
    (only points with that many neighbours grow a cluster). The cloud after this
    step holds the points of the clusters kept."""

    # [m] neighbourhood radius (DBSCAN's eps); > 0.
    tolerance: float = 0.01
    # [-] clusters with fewer points are dropped; >= 1.
    min_points: int = 30
    # [-] clusters with more points are dropped; >= min_points.
    max_points: int = 100000
    # [-] neighbours (counting the point) that make a core point (DBSCAN's
    # min_samples); 1 = Euclidean clustering.
    min_neighbours: int = 1


# The step types, in the order yaml_load_typed tries them: an untagged step is a CropBox.
PerceptionStep = Union[  # noqa: UP007 (yaml_load_typed reads typing.Union, not "|")
    CropBox,
    VoxelDownsample,
    StatisticalOutlierRemoval,
    EstimateNormals,
    PlaneSegmentation,
    Clustering,
]
STEP_TYPES = PerceptionStep.__args__
FRAMES = ("world", "camera")


@dc.dataclass
class PerceptionConfig:
    """Point clouds from a camera's depth image, and the pipeline run on them."""

    # The camera whose depth image is used (its name in the world: the sensor's
    # <topic>); "" = the first camera.
    camera: str = ""
    # [Hz] how often the pipeline runs (a periodic event, not every step); > 0.
    rate: float = 10.0
    # Frame the pipeline works in and its results are given in: "world" (the
    # camera pose from the plant, so a camera on a moving link works) or
    # "camera" (Drake's camera frame: x right, y down, z along the optical axis).
    frame: str = "world"
    # The ordered steps (YAML tags: !CropBox, !VoxelDownsample,
    # !StatisticalOutlierRemoval, !EstimateNormals, !PlaneSegmentation, !Clustering).
    steps: list[PerceptionStep] = dc.field(default_factory=list)
    # Draw the clouds and cluster boxes in Meshcat (when the run has a viewer).
    meshcat: bool = True
    # [m] size of the points drawn in Meshcat.
    point_size: float = 0.003
    # [Hz] how often --record writes the raw cloud on /camera/points (a 640 x 480
    # cloud is 4.9 MB a message); 0 = not recorded. /perception/clusters is
    # recorded at every pipeline run.
    points_record_rate: float = 1.0


def step_label(index: int, step) -> str:
    """``steps[1] VoxelDownsample``: how messages name a step."""
    return f"steps[{index}] {type(step).__name__}"


def _numbers(label: str, name: str, values, count: int) -> list[float]:
    try:
        numbers = [float(v) for v in values]
    except (TypeError, ValueError):
        raise PerceptionError(f"{label}: {name}={values!r} must be {count} numbers") from None
    if len(numbers) != count or not all(math.isfinite(v) for v in numbers):
        raise PerceptionError(f"{label}: {name}={values!r} must be {count} finite numbers")
    return numbers


def _positive(label: str, name: str, value, unit: str = "") -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise PerceptionError(f"{label}: {name}={value!r} must be positive{unit}")


def _at_least(label: str, name: str, value, minimum: int) -> None:
    if not (isinstance(value, int) and value >= minimum):
        raise PerceptionError(f"{label}: {name}={value!r} must be a whole number >= {minimum}")


def validate_step(index: int, step) -> None:
    """Raises :class:`PerceptionError` naming the step and the bad value."""
    label = step_label(index, step)
    if isinstance(step, CropBox):
        lower = _numbers(label, "lower", step.lower, 3)
        upper = _numbers(label, "upper", step.upper, 3)
        if any(lo > hi for lo, hi in zip(lower, upper, strict=True)):
            raise PerceptionError(
                f"{label}: lower={step.lower!r} must not exceed upper={step.upper!r}"
            )
    elif isinstance(step, VoxelDownsample):
        _positive(label, "leaf_size", step.leaf_size, " [m]")
    elif isinstance(step, StatisticalOutlierRemoval):
        _at_least(label, "neighbours", step.neighbours, 1)
        _positive(label, "std_ratio", step.std_ratio)
    elif isinstance(step, EstimateNormals):
        _positive(label, "radius", step.radius, " [m]")
        _at_least(label, "neighbours", step.neighbours, 3)
    elif isinstance(step, PlaneSegmentation):
        _positive(label, "distance_threshold", step.distance_threshold, " [m]")
        _at_least(label, "max_iterations", step.max_iterations, 1)
        _at_least(label, "min_inliers", step.min_inliers, 3)
    elif isinstance(step, Clustering):
        _positive(label, "tolerance", step.tolerance, " [m]")
        _at_least(label, "min_points", step.min_points, 1)
        _at_least(label, "max_points", step.max_points, 1)
        _at_least(label, "min_neighbours", step.min_neighbours, 1)
        if step.min_points > step.max_points:
            raise PerceptionError(
                f"{label}: min_points={step.min_points!r} must not exceed "
                f"max_points={step.max_points!r}"
            )
    else:
        names = ", ".join(t.__name__ for t in STEP_TYPES)
        raise PerceptionError(
            f"steps[{index}]: {type(step).__name__} is not a perception step (steps: {names})"
        )


def validate_perception(config: PerceptionConfig) -> None:
    """Checks the block and every step; :class:`PerceptionError` names the first bad one."""
    _positive("perception", "rate", config.rate, " [Hz]")
    if config.frame not in FRAMES:
        raise PerceptionError(f"perception: frame={config.frame!r} must be one of {FRAMES}")
    _positive("perception", "point_size", config.point_size, " [m]")
    if not (math.isfinite(config.points_record_rate) and config.points_record_rate >= 0):
        raise PerceptionError(
            f"perception: points_record_rate={config.points_record_rate!r} must be >= 0 [Hz]"
        )
    for index, step in enumerate(config.steps):
        validate_step(index, step)
