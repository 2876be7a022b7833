"""Each pipeline step on synthetic clouds with known answers, and bad parameters."""

import math

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed

from armando_drake.perception.config import (
    Clustering,
    CropBox,
    EstimateNormals,
    PerceptionConfig,
    PerceptionError,
    PlaneSegmentation,
    StatisticalOutlierRemoval,
    VoxelDownsample,
)
from armando_drake.perception.pipeline import PointCloudPipeline, make_cloud, points_of
from armando_drake.tools.schema import check_config

RNG_SEED = 7
NOISE = 0.001  # [m] standard deviation of the plane points along the normal


def tilted_plane(points: int = 20000, outliers: int = 1000):
    """(cloud points, is_outlier, unit normal, point on the plane): a 1 m x 1 m patch of a
    tilted plane with Gaussian noise along the normal, plus uniform outliers around it."""
    rng = np.random.default_rng(RNG_SEED)
    normal = np.array([0.1, -0.2, 1.0])
    normal /= np.linalg.norm(normal)
    origin = np.array([0.3, -0.1, 0.05])
    u = np.cross(normal, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    s, t = rng.uniform(-0.5, 0.5, size=(2, points))
    on_plane = (
        origin + np.outer(s, u) + np.outer(t, v) + np.outer(rng.normal(0, NOISE, points), normal)
    )
    a, b = rng.uniform(-0.5, 0.5, size=(2, outliers))
    h = rng.uniform(0.02, 0.3, size=outliers) * rng.choice([-1, 1], size=outliers)
    off_plane = origin + np.outer(a, u) + np.outer(b, v) + np.outer(h, normal)
    cloud = np.vstack([on_plane, off_plane])
    is_outlier = np.r_[np.zeros(points, bool), np.ones(outliers, bool)]
    return cloud, is_outlier, normal, origin


def kept_rows(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """Mask over ``before`` of the rows found in ``after`` (the steps keep points as they are)."""
    keys = {row.tobytes() for row in after.astype(np.float32)}
    return np.array([row.tobytes() in keys for row in before.astype(np.float32)])


def test_statistical_outlier_removal_removes_the_outliers_and_keeps_the_plane():
    points, is_outlier, _, _ = tilted_plane()
    result = PointCloudPipeline([StatisticalOutlierRemoval(neighbours=20, std_ratio=1.0)]).run(
        make_cloud(points)
    )
    kept = kept_rows(points, points_of(result.output))
    removed_outliers = 1 - kept[is_outlier].mean()
    kept_plane = kept[~is_outlier].mean()
    assert removed_outliers >= 0.95, removed_outliers
    assert kept_plane >= 0.99, kept_plane


def test_ransac_plane_finds_the_plane_and_removes_its_inliers():
    points, is_outlier, normal, origin = tilted_plane()
    step = PlaneSegmentation(distance_threshold=4 * NOISE)
    viewpoint = origin + 2 * normal  # the camera is on the normal's side
    result = PointCloudPipeline([step]).run(make_cloud(points), viewpoint=viewpoint)
    (plane,) = result.planes
    angle = math.degrees(math.acos(min(1.0, plane.normal @ normal)))
    assert angle < 0.2, angle  # and turned towards the camera (else ~180)
    a, b, c, d = plane.coefficients
    assert np.linalg.norm([a, b, c]) == pytest.approx(1.0)
    assert abs(np.dot([a, b, c], origin) + d) < 0.5e-3  # the true plane's point lies on it
    remaining = kept_rows(points, points_of(result.output))
    inliers_found = 1 - remaining[~is_outlier].mean()
    assert inliers_found >= 0.99, inliers_found
    # Outliers are removed only where they happen to lie within the threshold.
    close = np.abs((points - origin) @ normal) <= step.distance_threshold
    assert remaining[is_outlier & ~close].all()
    assert plane.inliers == len(points) - result.output.size()


def test_plane_normal_is_turned_towards_the_viewpoint():
    points, _, normal, origin = tilted_plane(outliers=0)
    below = PointCloudPipeline([PlaneSegmentation()]).run(
        make_cloud(points), viewpoint=origin - normal
    )
    assert below.planes[0].normal @ normal < -0.999


def test_crop_box_keeps_exactly_the_points_inside():
    rng = np.random.default_rng(RNG_SEED)
    points = rng.uniform(-1, 1, size=(5000, 3)).astype(np.float32)
    points[:10] = np.nan  # out-of-range depth pixels
    lower, upper = [-0.2, -0.5, 0.0], [0.6, 0.1, 0.3]
    result = PointCloudPipeline([CropBox(lower=lower, upper=upper)]).run(make_cloud(points))
    inside = np.all((points >= lower) & (points <= upper), axis=1)
    np.testing.assert_array_equal(
        np.sort(points_of(result.output), axis=0), np.sort(points[inside], axis=0)
    )


def test_voxel_downsample_gives_one_mean_point_per_occupied_voxel():
    rng = np.random.default_rng(RNG_SEED)
    leaf = 0.05
    points = rng.uniform(0.0, 0.3, size=(20000, 3))
    colours = rng.integers(0, 255, size=(20000, 3))
    result = PointCloudPipeline([VoxelDownsample(leaf_size=leaf)]).run(make_cloud(points, colours))
    out = points_of(result.output)
    voxels = np.floor(points / leaf).astype(int)
    occupied, inverse = np.unique(voxels, axis=0, return_inverse=True)
    assert len(out) == len(occupied)
    means = np.zeros((len(occupied), 3))
    np.add.at(means, inverse.ravel(), points)
    means /= np.bincount(inverse.ravel())[:, None]
    order_out = np.lexsort(np.floor(out / leaf).astype(int).T)
    order_means = np.lexsort(occupied.T)
    np.testing.assert_allclose(out[order_out], means[order_means], atol=1e-5)
    assert result.output.has_rgbs()


def blobs(rng, centres, counts, radius=0.02):
    return np.vstack(
        [c + rng.normal(0, radius / 3, size=(n, 3)) for c, n in zip(centres, counts, strict=True)]
    )


def test_clustering_finds_each_blob_and_drops_those_outside_min_max():
    rng = np.random.default_rng(RNG_SEED)
    centres = np.array([[0.2, 0.0, 0.03], [0.4, 0.2, 0.05], [0.0, -0.3, 0.04]])
    small = np.array([[-0.3, 0.3, 0.0]])  # 10 points: below min_points
    large = np.array([[0.6, -0.4, 0.1]])  # 4000 points: above max_points
    points = np.vstack(
        [
            blobs(rng, centres, [500, 800, 300]),
            blobs(rng, small, [10]),
            blobs(rng, large, [4000], radius=0.05),
        ]
    )
    step = Clustering(tolerance=0.025, min_points=50, max_points=2000)
    result = PointCloudPipeline([step]).run(make_cloud(points))
    assert [c.count for c in result.clusters] == [800, 500, 300]  # largest first
    for cluster, centre in zip(result.clusters, centres[[1, 0, 2]], strict=True):
        assert np.linalg.norm(cluster.centroid - centre) < 0.002
        assert np.all(cluster.lower <= cluster.centroid) and np.all(
            cluster.centroid <= cluster.upper
        )
        assert np.all(cluster.upper - cluster.lower < 0.06)
    assert result.output.size() == 1600  # the cloud after the step: the kept clusters


def test_dbscan_core_points_split_what_euclidean_chains():
    rng = np.random.default_rng(RNG_SEED)
    points = blobs(rng, np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]), [400, 400], radius=0.01)
    bridge = np.column_stack([np.linspace(0.01, 0.09, 12), np.zeros(12), np.zeros(12)])
    points = np.vstack([points, bridge])  # a thin chain of single points joins the blobs
    euclidean = Clustering(tolerance=0.008, min_points=50, min_neighbours=1)
    dbscan = Clustering(tolerance=0.008, min_points=50, min_neighbours=5)
    assert len(PointCloudPipeline([euclidean]).run(make_cloud(points)).clusters) == 1
    assert len(PointCloudPipeline([dbscan]).run(make_cloud(points)).clusters) == 2


def test_normals_of_a_plane_point_to_the_camera():
    points, _, normal, origin = tilted_plane(points=3000, outliers=0)
    result = PointCloudPipeline([EstimateNormals(radius=0.05, neighbours=20)]).run(
        make_cloud(points), viewpoint=origin + normal
    )
    normals = result.output.normals().T
    assert np.median(normals @ normal) > 0.99


def test_whole_pipeline_on_an_empty_or_planar_cloud_finds_no_cluster():
    steps = [
        CropBox(lower=[-1, -1, -1], upper=[1, 1, 1]),
        VoxelDownsample(leaf_size=0.01),
        StatisticalOutlierRemoval(),
        PlaneSegmentation(),
        Clustering(),
    ]
    pipeline = PointCloudPipeline(steps)
    empty = pipeline.run(make_cloud(np.zeros((0, 3))))
    assert empty.clusters == () and empty.planes == ()
    plane_only, _, _, _ = tilted_plane(outliers=0)
    flat = pipeline.run(make_cloud(plane_only))
    assert len(flat.planes) == 1 and flat.clusters == ()
    assert [stage.name for stage in flat.stages] == [
        "input",
        "steps[0] CropBox",
        "steps[1] VoxelDownsample",
        "steps[2] StatisticalOutlierRemoval",
        "steps[3] PlaneSegmentation",
        "steps[4] Clustering",
    ]


@pytest.mark.parametrize(
    "steps, message",
    [
        (
            "[!VoxelDownsample {leaf_size: 0.0}]",
            "steps[0] VoxelDownsample: leaf_size=0.0 must be positive [m]",
        ),
        (
            "[!VoxelDownsample {}, !Clustering {min_points: 50, max_points: 10}]",
            "steps[1] Clustering: min_points=50 must not exceed max_points=10",
        ),
        (
            "[!CropBox {lower: [0, 0, 1], upper: [1, 1, 0]}]",
            "steps[0] CropBox: lower=[0.0, 0.0, 1.0] must not exceed upper=[1.0, 1.0, 0.0]",
        ),
        (
            "[!StatisticalOutlierRemoval {neighbours: 0}]",
            "steps[0] StatisticalOutlierRemoval: neighbours=0 must be a whole number >= 1",
        ),
        (
            "[!PlaneSegmentation {distance_threshold: -1}]",
            "steps[0] PlaneSegmentation: distance_threshold=-1.0 must be positive [m]",
        ),
    ],
)
def test_bad_parameters_are_one_line_errors_naming_the_step(steps, message):
    config = yaml_load_typed(data=f"steps: {steps}", defaults=PerceptionConfig())
    with pytest.raises(PerceptionError) as error:
        check_config(config, error=PerceptionError)
    assert str(error.value) == message
    with pytest.raises(PerceptionError, match=r"^steps\["):
        PointCloudPipeline(config.steps)


def test_an_unknown_step_is_refused_by_its_tag():
    with pytest.raises(RuntimeError, match="'MedianFilter' did not match"):
        yaml_load_typed(data="steps: [!MedianFilter {size: 3}]", defaults=PerceptionConfig())
    with pytest.raises(PerceptionError, match=r"^steps\[0\]: str is not a perception step"):
        PointCloudPipeline(["median"])


def test_the_system_reuses_its_result_for_a_cloud_equal_to_the_last_one():
    from pydrake.systems.analysis import Simulator

    from armando_drake.perception.systems import PointCloudPerception

    rng = np.random.default_rng(RNG_SEED)
    centres = np.array([[0.2, 0.0, 0.03], [0.4, 0.2, 0.05]])
    points = blobs(rng, centres, [300, 200])
    points[0] = np.nan  # out of range, as a depth image gives: equal to itself here
    step = Clustering(tolerance=0.025, min_points=50, max_points=2000)
    system = PointCloudPerception(steps=[step], rate=10.0)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    system.GetInputPort("point_cloud").FixValue(context, make_cloud(points))
    simulator.AdvanceTo(0.25)  # runs at 0, 0.1, 0.2
    result = system.GetOutputPort("result").Eval(context)
    assert system.reuses == 2 and result.time == pytest.approx(0.2)
    fresh = PointCloudPipeline([step]).run(make_cloud(points))
    assert [c.count for c in result.clusters] == [c.count for c in fresh.clusters] == [299, 200]
    for reused, computed in zip(result.clusters, fresh.clusters, strict=True):
        np.testing.assert_array_equal(reused.centroid, computed.centroid)
    points[1] += 1e-6  # another cloud: run again
    system.GetInputPort("point_cloud").FixValue(context, make_cloud(points))
    simulator.AdvanceTo(0.35)
    assert system.reuses == 2
    assert system.GetOutputPort("result").Eval(context).time == pytest.approx(0.3)
