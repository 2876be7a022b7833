"""Perception in the world: the perception scenario's clusters are its objects, as seen."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
import trimesh
from conftest import make_mini_package
from pydrake.systems.analysis import Simulator

from armando_drake.perception.config import VoxelDownsample
from armando_drake.sensors.objects import Box, Cylinder
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario

QUIET = "logging: {console_rate: 0}"
# Worlds built here but never rendered use VTK: a RenderEngineGl made and never rendered
# with leaves a later first RenderEngineVtk of the process with wrong depth images
# (tests/sensors/test_camera.py's VTK depth checks then fail).
NO_GL = "camera: {renderer: vtk}"
VISIBLE_TOLERANCE = 0.003  # [m] a surface sample is visible where the depth agrees this well


def shape_yaml(shape) -> str:
    """The tagged YAML of a scene object's shape."""
    fields = ", ".join(f"{name}: {value}" for name, value in vars(shape).items())
    return f"!{type(shape).__name__} {{{fields}}}"


def objects_override(scenario, **moves) -> str:
    """A ``--set`` text with the scenario's objects, ``name=[dx, dy, dz]`` moved [m]."""
    entries = []
    for obj in scenario.objects:
        xyz = np.add(obj.xyz, moves.get(obj.name, [0.0, 0.0, 0.0])).tolist()
        entries.append(
            f"{{name: {obj.name}, shape: {shape_yaml(obj.shape)}, xyz: {xyz}, "
            f"color: {list(obj.color)}}}"
        )
    return "objects: [" + ", ".join(entries) + "]"


def run_world(overrides: str = "", seconds: float = 0.35):
    scenario = load_scenario("perception", f"{QUIET}\n{overrides}")
    world = MakeWorld(scenario, quiet=True, source="perception")
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(seconds)
    return scenario, world, simulator.get_context()


def object_mesh(obj) -> trimesh.Trimesh:
    shape = obj.shape
    if isinstance(shape, Box):
        mesh = trimesh.creation.box(extents=shape.size)
    elif isinstance(shape, Cylinder):
        mesh = trimesh.creation.cylinder(radius=shape.radius, height=shape.length, sections=128)
    else:
        mesh = trimesh.creation.icosphere(subdivisions=5, radius=shape.radius)
    mesh.apply_transform(obj.X_WO().GetAsMatrix4())
    return mesh


def visible_centroid(world, context, obj) -> tuple[np.ndarray, int]:
    """Centroid [m] of the part of ``obj``'s surface the camera sees, and how many of
    the uniform surface samples that is: each sample is projected into the rendered
    depth image and kept where its depth matches (not hidden, in view)."""
    added = world.robot().perception
    camera = world.robot().cameras[added.camera]
    X_WC = added.camera_pose.Eval(added.camera_pose.get_system().GetMyContextFromRoot(context))
    depth = world.diagram.GetOutputPort(f"{added.camera}.depth_image").Eval(context).data[..., 0]
    intrinsics = camera.sensor.default_depth_render_camera().core().intrinsics()
    samples, _ = trimesh.sample.sample_surface(object_mesh(obj), 200_000, seed=1)
    p_C = (X_WC.inverse().GetAsMatrix4() @ np.c_[samples, np.ones(len(samples))].T)[:3]
    z = p_C[2]
    u = np.round(intrinsics.focal_x() * p_C[0] / z + intrinsics.center_x()).astype(int)
    v = np.round(intrinsics.focal_y() * p_C[1] / z + intrinsics.center_y()).astype(int)
    inside = (z > 0) & (u >= 0) & (u < depth.shape[1]) & (v >= 0) & (v < depth.shape[0])
    seen = np.zeros(len(samples), bool)
    seen[inside] = np.abs(depth[v[inside], u[inside]] - z[inside]) < VISIBLE_TOLERANCE
    return samples[seen].mean(axis=0), int(seen.sum())


def match(clusters, centres) -> list[int]:
    """Index of the nearest cluster for each centre."""
    return [
        int(np.argmin([np.linalg.norm(c.centroid - centre) for c in clusters]))
        for centre in centres
    ]


def test_clusters_are_the_objects_in_view_at_their_visible_centroids():
    scenario, world, context = run_world()
    result = world.diagram.GetOutputPort("perception.result").Eval(context)
    assert result.time == pytest.approx(0.3) and result.frame == "world"
    (plane,) = result.planes
    angle = math.degrees(math.acos(min(1.0, plane.normal @ [0.0, 0.0, 1.0])))
    assert angle < 1.0, angle  # the ground's normal, turned up towards the camera
    assert abs(plane.coefficients[3]) < 0.002  # the ground is z = 0
    assert len(result.clusters) == len(scenario.objects) == 3
    truths = [visible_centroid(world, context, obj) for obj in scenario.objects]
    assert all(count > 2000 for _, count in truths)
    nearest = match(result.clusters, [centre for centre, _ in truths])
    assert sorted(nearest) == [0, 1, 2]  # one cluster per object
    errors = {
        obj.name: float(np.linalg.norm(result.clusters[k].centroid - centre))
        for obj, k, (centre, _) in zip(scenario.objects, nearest, truths, strict=True)
    }
    print("centroid errors [m]:", errors, "normal angle [deg]:", angle)
    assert max(errors.values()) < 0.01, errors
    for obj, k in zip(scenario.objects, nearest, strict=True):
        cluster = result.clusters[k]
        shape = obj.shape
        if isinstance(shape, Box):
            top = obj.xyz[2] + shape.size[2] / 2
        elif isinstance(shape, Cylinder):
            top = obj.xyz[2] + shape.length / 2
        else:
            top = obj.xyz[2] + shape.radius
        assert cluster.upper[2] == pytest.approx(top, abs=0.005), obj.name
    world.close()


def test_moving_an_object_with_set_moves_its_cluster():
    scenario = load_scenario("perception", QUIET)
    before = run_world()[1:]
    shift = [0.03, -0.06, 0.0]
    after = run_world(objects_override(scenario, red_box=shift))[1:]
    results = [w.diagram.GetOutputPort("perception.result").Eval(c) for w, c in (before, after)]
    box = next(o for o in scenario.objects if o.name == "red_box")
    moved = [
        results[0].clusters[match(results[0].clusters, [box.xyz])[0]].centroid,
        results[1].clusters[match(results[1].clusters, [np.add(box.xyz, shift)])[0]].centroid,
    ]
    assert len(results[1].clusters) == 3
    np.testing.assert_allclose(moved[1] - moved[0], shift, atol=0.01)
    for world, _ in (before, after):
        world.close()


def test_an_empty_scene_gives_no_cluster_and_no_error():
    _, world, context = run_world("objects: []")
    result = world.diagram.GetOutputPort("perception.result").Eval(context)
    assert result.computed and result.clusters == () and len(result.planes) == 1
    world.close()


def test_world_points_of_a_camera_on_a_moving_link_stay_put(tmp_path):
    camera = """
    <gazebo reference="tip"><sensor name="hand_camera" type="depth">
      <pose>0 0 0 0 1.5708 0</pose>
      <camera><horizontal_fov>1.0</horizontal_fov>
        <image><width>160</width><height>120</height></image>
        <clip><near>0.02</near><far>5</far></clip></camera>
      <update_rate>30</update_rate></sensor></gazebo>"""
    package = make_mini_package(tmp_path, camera)
    scenario = load_scenario(
        None,
        f"robot: {{description: {package}}}\n{QUIET}\ncamera: {{enabled: true}}\n"
        "perception: {steps: []}",
    )
    world = MakeWorld(scenario, quiet=True)
    context = world.diagram.CreateDefaultContext()
    plant_context = world.plant.GetMyMutableContextFromRoot(context)
    clouds = []
    for q1 in (0.0, 0.5):
        world.plant.SetPositions(plant_context, world.robot().robot.model_instance, [q1, 0.0])
        in_world = world.diagram.GetOutputPort("hand_camera.points_in_world").Eval(context)
        in_camera = world.diagram.GetOutputPort("hand_camera.points_in_camera").Eval(context)
        keep = np.isfinite(in_world.xyzs()).all(axis=0)
        assert keep.mean() > 0.9  # the ground fills the view
        clouds.append((in_world.xyzs()[:, keep], in_camera.xyzs()[:, keep]))
    for in_world, _ in clouds:
        # Most of what is seen is the ground, z = 0 (the rest: the robot's own links).
        on_ground = np.abs(in_world[2]) < 2e-3
        assert on_ground.mean() > 0.9, on_ground.mean()
    # In the camera frame the ground moved: square to the optical axis at first (one
    # depth), tilted once the link turned (depths over 0.1 m).
    (_, straight), (_, tilted) = clouds
    assert np.percentile(straight[2], 90) - np.percentile(straight[2], 10) < 0.005
    assert np.percentile(tilted[2], 90) - np.percentile(tilted[2], 10) > 0.1
    world.close()


def test_a_bad_step_is_one_line_naming_the_file_and_the_step():
    # The bad step as the file would give it (an override would be named instead).
    scenario = load_scenario("perception", f"{QUIET}\n{NO_GL}")
    scenario.perception.steps = [VoxelDownsample(leaf_size=0.0)]
    with pytest.raises(ScenarioError) as error:
        MakeWorld(scenario, quiet=True, source="diagrams/perception.yaml")
    assert str(error.value) == (
        "diagrams/perception.yaml: perception.steps[0] VoxelDownsample: "
        "leaf_size=0.0 must be positive [m]"
    )


def test_an_unknown_step_on_the_command_line_is_one_line():
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "armando_drake.world",
            "--scenario",
            "perception",
            "--no-meshcat",
            "--set",
            "perception: {steps: [!MedianFilter {size: 3}]}",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "unknown tag !MedianFilter" in lines[0] and "perception" in lines[0]
    assert "(choose !CropBox, !VoxelDownsample, !StatisticalOutlierRemoval" in lines[0]  # known


def test_output_folder_gets_clusters_json(tmp_path):
    from armando_drake.simulation.run import run

    scenario = load_scenario(
        "perception",
        f"{QUIET}\nsimulation: {{duration: 0.35}}\nsimulator_config: {{target_realtime_rate: 0}}",
    )
    run(scenario, scenario_name="perception", output_dir=tmp_path, quiet=True, replay=False)
    document = json.loads((tmp_path / "clusters.json").read_text())
    assert document["camera"] == "camera" and document["frame"] == "world"
    assert [step["type"] for step in document["steps"]][-1] == "Clustering"
    frames = document["frames"]
    assert [frame["time"] for frame in frames] == pytest.approx([0.0, 0.1, 0.2, 0.3])
    for frame in frames:
        (plane,) = frame["planes"]
        assert plane["coefficients"][2] > 0.9998 and plane["inliers"] > 1000
        assert len(frame["clusters"]) == 3
        for cluster in frame["clusters"]:
            low, high = np.array(cluster["box"]["min"]), np.array(cluster["box"]["max"])
            assert np.all(low <= cluster["centroid"]) and np.all(cluster["centroid"] <= high)
            assert cluster["count"] >= 50


def test_pipeline_in_the_camera_frame_finds_the_ground_seen_from_the_camera():
    steps = "[!VoxelDownsample {leaf_size: 0.01}, !PlaneSegmentation {distance_threshold: 0.005}]"
    _, world, context = run_world(f"perception: {{frame: camera, steps: {steps}}}", seconds=0.05)
    result = world.diagram.GetOutputPort("perception.result").Eval(context)
    assert result.frame == "camera"
    (plane,) = result.planes
    X_WC = world.diagram.GetOutputPort("camera.camera_pose").Eval(context)
    normal_W = X_WC.rotation() @ plane.normal
    assert normal_W @ [0.0, 0.0, 1.0] > math.cos(math.radians(1.0))  # up, towards the camera
    height = plane.coefficients[3]  # signed distance of the camera (the origin) [m]
    assert height == pytest.approx(X_WC.translation()[2], abs=0.003)
    world.close()


def test_without_scikit_learn_the_hint_names_the_extra(monkeypatch):
    import armando_drake.perception.add as systems

    monkeypatch.setattr(systems, "missing_modules", lambda names: list(names))
    scenario = load_scenario("perception", f"{QUIET}\n{NO_GL}")
    with pytest.raises(ScenarioError, match=r"pip install 'armando-drake\[perception\]'"):
        MakeWorld(scenario, quiet=True)
