"""Manual check: public Gazebo worlds and mobile robots, as published, load and behave.

Not a test (the packages are not in the repository, nor in CI): run it by hand with
local clones or snapshots of the repositories below, e.g.

    python tools/check_public_models.py --repo turtlebot3=PATH/turtlebot3_simulations \\
        --repo gz-sim=PATH/gz-sim [--out /tmp/public_check]

A PATH is a working tree or a bare git directory (files are then read from HEAD; files a
snapshot lacks, such as large meshes, are counted and skipped). For each world and each
robot (a Gazebo model folder, spawned on the world's floor at a free spot):

- the world loads and the robot rests on its floor: its base within 5 mm of its spawn
  height after 5 s;
- it drives a cmd_vel sequence (ahead, a turn, ahead) and stops;
- its lidar's last scan is compared with an analytic ray cast (trimesh) against the
  world's geometry (every visual of the world's bodies, at their poses in the plant) from
  the lidar's pose: the share of the beams both see within 2 cm, and the median error.

Prints one line per check and a table; exits 1 if a check fails.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
from pydrake.geometry import Box, Convex, Cylinder, Mesh, Role, Sphere
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides

SETTLE = 5.0  # [s] resting on the floor before driving
TWIST = [  # (linear [m/s], angular [rad/s], duration [s])
    (0.15, 0.0, 1.5),
    (0.0, 0.6, 1.5),
    (0.15, 0.0, 1.0),
]


@dataclass
class Case:
    world: str  # repo-relative path of the world file
    repo: str  # the repository holding it
    spawn: tuple[float, float, float]  # [m] x, y, yaw of a free spot on the floor
    floor: float = 0.0  # [m] the floor's height there


# Worlds: a free spot each (the spawn spot of the package's launch file, or looked up in
# the world file).
WORLDS = [
    Case("turtlebot3_gazebo/worlds/turtlebot3_world.world", "turtlebot3", (-2.0, -0.5, 0.0)),
    Case("turtlebot3_gazebo/worlds/turtlebot3_dqn_stage1.world", "turtlebot3", (0.0, 0.0, 0.0)),
    Case("examples/worlds/shapes.sdf", "gz-sim", (-2.0, 0.0, 0.0)),
    # Its floor: GroundB_01's collision slab, 12.43 cm thick (a centimetre DAE) at z -0.0901.
    Case("worlds/no_roof_small_warehouse.world", "aws-warehouse", (1.5, -2.0, 0.0), floor=0.0342),
]
# Robots: a Gazebo model folder, or a robot written inside a world file
# ("WORLD#MODEL": the <model> named MODEL of that world, spawned as its own folder).
ROBOTS = [
    ("turtlebot3", "turtlebot3_gazebo/models/turtlebot3_burger"),
    ("turtlebot3", "turtlebot3_gazebo/models/turtlebot3_waffle"),
    ("gz-sim", "examples/worlds/visualize_lidar.sdf#vehicle_blue"),
]


# The folders of a snapshot written out (worlds and models; not docs or images of docs).
SNAPSHOT_FOLDERS = ("turtlebot3_gazebo/", "examples/worlds/", "test/worlds/", "models/", "worlds/")


def materialize(repo: Path, out: Path) -> tuple[Path, str, int]:
    """(a folder holding the repository's files, its commit, files missing): a working
    tree as it is; a git directory's HEAD written out under ``out``."""
    commit = subprocess.run(
        ["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    if (repo / ".git").exists() or not (repo / "HEAD").is_file():
        return repo, commit, 0
    files = subprocess.run(
        ["git", "-C", str(repo), "ls-tree", "-r", "--name-only", "HEAD"],
        capture_output=True,
        text=True,
    ).stdout.split("\n")
    missing = 0
    for name in filter(None, files):
        if not name.startswith(SNAPSHOT_FOLDERS):
            continue
        shown = subprocess.run(
            ["git", "-C", str(repo), "show", f"HEAD:{name}"], capture_output=True
        )
        if shown.returncode:
            missing += 1
            continue
        path = out / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(shown.stdout)
    return out, commit, missing


def _trimesh(shape) -> trimesh.Trimesh | None:
    if isinstance(shape, Box):
        return trimesh.creation.box((shape.width(), shape.depth(), shape.height()))
    if isinstance(shape, Cylinder):
        return trimesh.creation.cylinder(shape.radius(), shape.length(), sections=64)
    if isinstance(shape, Sphere):
        return trimesh.creation.icosphere(radius=shape.radius())
    if isinstance(shape, Mesh | Convex):
        mesh = trimesh.load(str(shape.source().path()), force="mesh")
        mesh.apply_scale(shape.scale3())
        return mesh
    return None


def world_scene(world, context, robot_instances) -> trimesh.Trimesh:
    """Every perception geometry of the bodies that are not a robot's, posed in the world."""
    plant, scene_graph = world.plant, world.scene_graph
    inspector = scene_graph.model_inspector()
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    pieces = []
    for geometry in inspector.GetAllGeometryIds(Role.kPerception):
        body = plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
        if body is not None and body.model_instance() in robot_instances:
            continue
        mesh = _trimesh(inspector.GetShape(geometry))
        if mesh is None:
            continue
        mesh.apply_transform(query.GetPoseInWorld(geometry).GetAsMatrix4())
        pieces.append(mesh)
    return trimesh.util.concatenate(pieces)


def lowest_point(world, context, instance) -> float:
    """The lowest z [m] of the robot's collision geometry."""
    plant, scene_graph = world.plant, world.scene_graph
    inspector = scene_graph.model_inspector()
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    lowest = np.inf
    for geometry in inspector.GetAllGeometryIds(Role.kProximity):
        body = plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
        if body is None or body.model_instance() != instance:
            continue
        mesh = _trimesh(inspector.GetShape(geometry))
        if mesh is None:
            continue
        mesh.apply_transform(query.GetPoseInWorld(geometry).GetAsMatrix4())
        lowest = min(lowest, float(mesh.vertices[:, 2].min()))
    return lowest


def model_folder(root: Path, robot: str, out: Path) -> Path:
    """The model folder of ``robot`` under ``root``: the folder itself, or for
    "WORLD#MODEL" a folder written under ``out`` with the world's ``<model>`` named MODEL
    as its ``model.sdf`` (its pose dropped: the check spawns it) and a ``model.config``."""
    path, _, name = robot.partition("#")
    if not name:
        return root / path
    tree = ET.parse(root / path)
    found = [m for m in tree.getroot().iter("model") if m.get("name") == name]
    if not found:
        raise ValueError(f"{root / path}: no <model name='{name}'>")
    model = found[0]
    for pose in model.findall("pose"):
        model.remove(pose)
    folder = out / "extracted" / name
    folder.mkdir(parents=True, exist_ok=True)
    version = tree.getroot().get("version", "1.9")
    sdf = ET.Element("sdf", version=version)
    sdf.append(model)
    ET.ElementTree(sdf).write(folder / "model.sdf", encoding="unicode", xml_declaration=True)
    (folder / "model.config").write_text(
        f"<?xml version='1.0'?>\n<model><name>{name}</name>"
        f"<sdf version='{version}'>model.sdf</sdf></model>\n"
    )
    return folder


def without_noise(robot_dir: Path, out: Path) -> Path:
    """A copy of the model folder whose sensors have no ``<noise>`` (the scan is compared
    with an exact ray cast)."""
    copy = out / "noiseless" / robot_dir.name
    if copy.exists():
        shutil.rmtree(copy)
    shutil.copytree(robot_dir, copy)
    for sdf in copy.glob("*.sdf"):
        tree = ET.parse(sdf)
        for parent in tree.getroot().iter():
            for noise in parent.findall("noise"):
                if parent.tag in ("lidar", "ray"):
                    parent.remove(noise)
        tree.write(sdf)
    return copy


def ray_cast(scene: trimesh.Trimesh, X_WS, angles: np.ndarray, range_max: float) -> np.ndarray:
    """The distance along each beam (in the sensor's xy plane) to the scene's triangles
    (Moller-Trumbore, exact); inf: none within ``range_max``."""
    R = X_WS.rotation().matrix()
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1) @ R.T
    origin = X_WS.translation()
    triangles = scene.triangles  # (T, 3, 3)
    v0, e1, e2 = (
        triangles[:, 0],
        triangles[:, 1] - triangles[:, 0],
        triangles[:, 2] - triangles[:, 0],
    )
    truth = np.full(len(angles), np.inf)
    s = origin - v0  # (T, 3)
    q = np.cross(s, e1)  # (T, 3)
    for k, d in enumerate(directions):
        p = np.cross(d, e2)  # (T, 3)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        u = np.einsum("ij,ij->i", s, p) * inv
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
        if hit.any():
            truth[k] = t[hit].min()
    truth[truth > range_max] = np.inf
    return truth


def run_case(case: Case, robot_dir: Path, root: Path, out: Path) -> dict:
    """Spawns the robot in the world, settles, drives; returns the figures."""
    x, y, yaw = case.spawn
    steps = ", ".join(f"{{linear: {v}, angular: {w}, duration: {t}}}" for v, w, t in TWIST)
    world_file = root / case.world
    loaded = merge_overrides(
        load_scenario("fra2mo"),
        [
            "logging: {console_rate: 0}",
            f"robot: {{description: {robot_dir}, base_xyz: [{x}, {y}, {case.floor}], "
            f"base_rpy: [0, 0, {yaw}]}}",
            f"world_file: {world_file}",
            f"world_resource_paths: [{world_file.parent.parent / 'models'}]",
            f"twist: {{start_delay: {SETTLE}, rate: 20.0, steps: [{steps}]}}",
        ],
    )
    world = MakeWorld(loaded, quiet=True)
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    plant = world.plant
    robot = world.robot()
    instance = robot.robot.model_instance
    base = plant.GetBodyByName(robot.robot.base_link, instance)
    plant_context = plant.GetMyContextFromRoot(context)
    # Spawned with its lowest collision point on the floor (as a spawn at its resting
    # height): the base's height then is the spawn height.
    X_WB = base.EvalPoseInWorld(plant_context)
    lowest = lowest_point(world, context, instance)
    X_WB.set_translation(X_WB.translation() + [0, 0, case.floor - lowest])
    plant.SetFreeBodyPose(plant_context, base, X_WB)
    z_spawn = X_WB.translation()[2]
    simulator.Initialize()
    simulator.AdvanceTo(SETTLE)
    z_rest = base.EvalPoseInWorld(plant_context).translation()[2]
    start = base.EvalPoseInWorld(plant_context).translation()[:2]
    end_time = SETTLE + sum(t for _, _, t in TWIST) + 1.0
    simulator.AdvanceTo(end_time)
    end = base.EvalPoseInWorld(plant_context).translation()[:2]
    figures = {
        "z_spawn": z_spawn - case.floor,
        "z_rest": z_rest - z_spawn,
        "moved": float(np.linalg.norm(end - start)),
    }
    lidar = next(s for s in robot.robot.sensors if s.type in ("gpu_lidar", "lidar", "ray"))
    port = robot.sensors[lidar.name]["scan"]
    scan = port.Eval(port.get_system().GetMyContextFromRoot(context)).message
    link = plant.GetBodyByName(lidar.link, instance)
    X_WS = link.EvalPoseInWorld(plant_context) @ lidar.X_LS
    robots = {r.robot.model_instance for r in world.robots.values()}
    truth = ray_cast(world_scene(world, context, robots), X_WS, scan.angles(), scan.range_max)
    ranges = np.asarray(scan.ranges)
    both = np.isfinite(ranges) & np.isfinite(truth)
    errors = np.abs(ranges[both] - truth[both])
    figures.update(
        beams=len(ranges),
        both=int(both.sum()),
        within_2cm=float((errors <= 0.02).mean()) if both.any() else float("nan"),
        median_error=float(np.median(errors)) if both.any() else float("nan"),
        only_lidar=int((np.isfinite(ranges) & ~np.isfinite(truth)).sum()),
        only_cast=int((~np.isfinite(ranges) & np.isfinite(truth)).sum()),
    )
    world.close()
    return figures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repo", action="append", default=[], help="NAME=PATH")
    parser.add_argument("--out", default=None, help="where git snapshots are written out")
    parser.add_argument("--only", default="", help="run the worlds whose path contains this")
    parser.add_argument("--robot", default="", help="run the robots whose path contains this")
    args = parser.parse_args(argv)
    out = Path(args.out or tempfile.mkdtemp(prefix="public_check_"))
    roots = {}
    for entry in args.repo:
        name, _, path = entry.partition("=")
        root, commit, missing = materialize(Path(path), out / name)
        roots[name] = root
        print(f"{name}: {path} at {commit} ({missing} files absent from the snapshot)")
    failed = 0
    for case in WORLDS:
        if case.repo not in roots or args.only not in case.world:
            continue
        for repo, model in ROBOTS:
            if repo not in roots or args.robot not in model:
                continue
            label = f"{case.world} + {Path(model).name}"
            try:
                robot_dir = without_noise(model_folder(roots[repo], model, out), out)
                f = run_case(case, robot_dir, roots[case.repo], out)
            except Exception as error:  # a check's failure is a line, the others go on
                print(f"FAIL {label}: {type(error).__name__}: {error}")
                failed += 1
                continue
            ok = abs(f["z_rest"]) <= 0.005 and f["moved"] > 0.2 and f["within_2cm"] >= 0.9
            failed += not ok
            print(
                f"{'ok  ' if ok else 'FAIL'} {label}: spawned {f['z_spawn'] * 1000:.1f} mm up, "
                f"after {SETTLE:g} s at {f['z_rest'] * 1000:+.1f} mm of it, "
                f"moved {f['moved']:.2f} m; lidar {f['both']}/{f['beams']} beams hit in both, "
                f"{f['within_2cm'] * 100:.1f} % within 2 cm (median {f['median_error'] * 1000:.1f}"
                f" mm), {f['only_lidar']} only in the scan, {f['only_cast']} only in the cast"
            )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
