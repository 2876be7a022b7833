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

:func:`~armando_drake.tools.schema.check_config` checks every parameter against
the unit and range declared beside it (and each step's ``check()``) and, given
``error=PerceptionError``, raises :class:`PerceptionError` naming the step
(``steps[1] VoxelDownsample``) and the bad value. (No ``from __future__ import
annotations`` here: ``yaml_load_typed`` needs the field types as types, not strings.)
"""

import dataclasses as dc
from typing import Union

from armando_drake.tools.schema import ConfigError, Refusal, param


class PerceptionError(ConfigError):
    """A perception block or step with a bad parameter; the message names the step."""


class _StepType(type):
    """Metaclass of the steps: a step type prints as its YAML tag, so that Drake's
    message for an unknown tag lists the known ones as ``!CropBox, !VoxelDownsample, ...``."""

    def __repr__(cls) -> str:
        return f"!{cls.__name__}"


class _Step:
    """What the steps share: how messages name them (``steps[1] VoxelDownsample: ``)."""

    def message_prefix(self, parent: str, name: str) -> str:
        where = f"{parent.removesuffix('.')}[{name}] " if name else ""
        return f"{where}{type(self).__name__}: "


@dc.dataclass
class CropBox(_Step, metaclass=_StepType):
    """Keeps the points inside an axis-aligned box, faces included."""

    # [m] lowest corner x y z, in the pipeline's frame (see PerceptionConfig.frame).
    lower: list[float] = param([-1.0, -1.0, -1.0], unit="m", length=3)
    # [m] highest corner x y z, same frame; every value >= its lower one.
    upper: list[float] = param([1.0, 1.0, 1.0], unit="m", length=3)

    def check(self) -> None:
        if any(lo > hi for lo, hi in zip(self.lower, self.upper, strict=True)):
            raise Refusal("lower", f"={self.lower!r} must not exceed upper={self.upper!r}")


@dc.dataclass
class VoxelDownsample(_Step, metaclass=_StepType):
    """One point per occupied voxel, the mean of its points (Drake's
    ``PointCloud.VoxelizedDownSample``; colours are averaged too)."""

    # [m] edge of the cubic voxels; > 0.
    leaf_size: float = param(0.005, unit="m", gt=0)


@dc.dataclass
class StatisticalOutlierRemoval(_Step, metaclass=_StepType):
    """Removes points whose mean distance to their nearest neighbours is more than
    ``std_ratio`` standard deviations above the cloud's mean of that distance
    (PCL's and Open3D's filter; neighbours from SciPy's KD-tree)."""

    # [-] neighbours per point the mean distance is taken over; >= 1.
    neighbours: int = param(20, unit="-", ge=1)
    # [-] threshold in standard deviations above the mean; > 0.
    std_ratio: float = param(2.0, unit="-", gt=0)


@dc.dataclass
class EstimateNormals(_Step, metaclass=_StepType):
    """Adds a normal per point, turned towards the camera (Drake's
    ``PointCloud.EstimateNormals`` and ``FlipNormalsTowardPoint``)."""

    # [m] neighbours are searched within this radius; > 0.
    radius: float = param(0.02, unit="m", gt=0)
    # [-] at most this many nearest neighbours in the fit; >= 3.
    neighbours: int = param(30, unit="-", ge=3)


@dc.dataclass
class PlaneSegmentation(_Step, metaclass=_StepType):
    """Finds the dominant plane with RANSAC (scikit-learn's ``RANSACRegressor`` driving a
    total-least-squares plane), reports its coefficients and removes its inliers."""

    # [m] a point within this distance of the plane is an inlier; > 0.
    distance_threshold: float = param(0.004, unit="m", gt=0)
    # [-] RANSAC draws at most this many 3-point samples; >= 1.
    max_iterations: int = param(1000, unit="-", ge=1)
    # [-] a plane with fewer inliers is not reported (nothing removed); >= 3.
    min_inliers: int = param(100, unit="-", ge=3)


@dc.dataclass
class Clustering(_Step, metaclass=_StepType):
    """Groups the points into clusters: with ``min_neighbours: 1`` PCL's Euclidean
    cluster extraction (points closer than ``tolerance`` chain into one cluster;
    SciPy's KD-tree and graph components), with more scikit-learn's ``DBSCAN``
    (only points with that many neighbours grow a cluster). The cloud after this
    step holds the points of the clusters kept."""

    # [m] neighbourhood radius (DBSCAN's eps); > 0.
    tolerance: float = param(0.01, unit="m", gt=0)
    # [-] clusters with fewer points are dropped; >= 1.
    min_points: int = param(30, unit="-", ge=1)
    # [-] clusters with more points are dropped; >= min_points.
    max_points: int = param(100000, unit="-", ge=1)
    # [-] neighbours (counting the point) that make a core point (DBSCAN's
    # min_samples); 1 = Euclidean clustering.
    min_neighbours: int = param(1, unit="-", ge=1)

    def check(self) -> None:
        if self.min_points > self.max_points:
            raise Refusal(
                "min_points",
                f"={self.min_points!r} must not exceed max_points={self.max_points!r}",
            )


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
    rate: float = param(10.0, unit="Hz", gt=0)
    # Frame the pipeline works in and its results are given in: "world" (the
    # camera pose from the plant, so a camera on a moving link works) or
    # "camera" (Drake's camera frame: x right, y down, z along the optical axis).
    frame: str = param("world", choices=FRAMES)
    # The ordered steps (YAML tags: !CropBox, !VoxelDownsample,
    # !StatisticalOutlierRemoval, !EstimateNormals, !PlaneSegmentation, !Clustering).
    steps: list[PerceptionStep] = dc.field(default_factory=list)
    # Draw the clouds and cluster boxes in Meshcat (when the run has a viewer).
    meshcat: bool = True
    # [m] size of the points drawn in Meshcat.
    point_size: float = param(0.003, unit="m", gt=0)
    # [Hz] how often --record writes the raw cloud on /camera/points (a 640 x 480
    # cloud is 4.9 MB a message); 0 = not recorded. /perception/clusters is
    # recorded at every pipeline run.
    points_record_rate: float = param(1.0, unit="Hz", ge=0)
    # In a world of several robots (robots:), the name of the one it acts on; "" = the
    # first listed.
    robot: str = ""


def step_label(index: int, step) -> str:
    """``steps[1] VoxelDownsample``: how messages name a step."""
    return f"steps[{index}] {type(step).__name__}"
