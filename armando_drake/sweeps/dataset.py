"""Data sets made from the robot model, sharded over the sweep engines.

``python -m armando_drake.dataset ik`` writes a data set for learning inverse
kinematics: random joint configurations within the joint limits (drawn from
one seeded generator, so the rows depend on the seed only, not on how the work
is sharded), the end-effector pose of each from Drake's MultibodyPlant, and
with ``--ik`` Drake's InverseKinematics solved back from each pose. Shards of
rows run on a local process pool (``--workers``) or Ray (``--ray``), as sweeps do.

The end effector is ``--frame`` (a link or frame of the robot), else the last
link of the chain: from the base, follow the links down to the child of the
last moving joint, then on through fixed joints while a link has exactly one
child (on Armando: ``crawer_base``, the gripper's base, where it splits into
the two fingers). A robot with moving joints on more than one branch needs
``--frame``.

Parquet schema, one row per sample (angles [rad], lengths [m]):

- ``sample`` (int64): the row's index, 0 to N-1;
- ``q_<joint>`` (float64): the configuration, one column per joint position in
  the plant's order, drawn uniformly between the joint's lower and upper limit
  ([-pi, pi] for an unlimited revolute joint);
- ``x``, ``y``, ``z`` (float64): the end-effector frame's origin in the world;
- ``qw``, ``qx``, ``qy``, ``qz`` (float64): its orientation in the world as a
  unit quaternion with ``qw >= 0``;
- ``r00`` ... ``r22`` (float64): the same orientation as the rotation matrix
  R_WE, row by row (``r01`` is row 0, column 1);
- with ``--ik``: ``ik_success`` (bool, the solver's verdict), ``ik_attempts``
  (int64, initial guesses tried, each drawn within the limits from a generator
  seeded by (seed, sample)), ``ik_q_<joint>`` (float64, the solution),
  ``ik_position_error`` (float64, |p_WE(ik_q) - p_WE(q)| [m]) and
  ``ik_orientation_error`` (float64, the angle of R_WE(q)^T R_WE(ik_q) [rad]).

The file's metadata key ``armando_drake`` holds JSON: the robot's description
and name (with the xacro arguments and package folders it was read with), the
frame, joint names and the limits drawn from, seed, sample count, the IK
settings, Drake's version and armando-drake's (``armando_drake``: version, and
git commit from a checkout).

Examples:
  python -m armando_drake.dataset ik --samples 10000 --seed 1 --output out/ik.parquet
  python -m armando_drake.dataset ik --samples 1000 --ik --workers 2 --output out/ik_solved.parquet
  python -m armando_drake.dataset ik --robot ../shared/upstream/arm_description --frame link_4 \\
      --samples 500 --output out/arm.parquet
  python -m armando_drake.dataset ik --samples 100000 --ray auto --output out/big.parquet
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from armando_drake.description.loader import load_robot
from armando_drake.sweeps.engines import make_engine
from armando_drake.sweeps.errors import SweepError, reported
from armando_drake.tools.cli import command_parser, package_folder, parse_xacro_args, user_errors
from armando_drake.tools.version import provenance

METADATA_KEY = b"armando_drake"
POSE_COLUMNS = ["x", "y", "z", "qw", "qx", "qy", "qz"] + [
    f"r{i}{j}" for i in range(3) for j in range(3)
]


@dataclass
class RobotSpec:
    """Which robot, and which of its frames is the end effector."""

    description: str = ""  # .urdf/.xacro file, package dir or package://; "" = Armando
    xacro_args: dict[str, str] = field(default_factory=dict)  # xacro:arg values
    package_paths: list[str] = field(default_factory=list)  # extra ROS package folders
    frame: str = ""  # end-effector frame; "" = the last link of the chain


@dataclass
class IkSettings:
    """The inverse kinematics solved back from each pose."""

    enabled: bool = False  # whether to solve at all
    position_tolerance: float = 1e-6  # [m] box half-width around the pose's position
    orientation_tolerance: float = 1e-4  # [rad] largest angle from the pose's orientation
    attempts: int = 10  # initial guesses tried before a row is reported unsolved


@dataclass
class IkShard:
    """One task: rows ``start`` .. ``start + len(q) - 1``."""

    robot: RobotSpec
    ik: IkSettings
    seed: int  # the data set's seed (IK initial guesses are drawn from (seed, sample))
    start: int  # index of the first row
    q: list[list[float]]  # the rows' configurations


class _Model:
    """The robot alone in a MultibodyPlant, with its end-effector frame."""

    def __init__(self, robot: RobotSpec):
        from pydrake.multibody.plant import MultibodyPlant

        self.plant = MultibodyPlant(time_step=0.0)
        self.robot = load_robot(
            self.plant,
            robot.description or None,
            xacro_args=robot.xacro_args,
            package_paths=robot.package_paths,
        )
        self.plant.Finalize()
        self.frame_name = robot.frame or end_effector_link(self.robot.urdf, self.robot.base_link)
        if not self.plant.HasFrameNamed(self.frame_name, self.robot.model_instance):
            raise SweepError(
                f"--frame {self.frame_name!r} is not a frame of {self.robot.name!r} "
                f"({self.robot.source})"
            )
        self.frame = self.plant.GetFrameByName(self.frame_name, self.robot.model_instance)
        self.context = self.plant.CreateDefaultContext()
        self.joint_names = list(
            self.plant.GetPositionNames(
                self.robot.model_instance, add_model_instance_prefix=False, always_add_suffix=False
            )
        )
        lower = self.plant.GetPositionLowerLimits()
        upper = self.plant.GetPositionUpperLimits()
        if self.plant.num_positions() != len(self.joint_names):
            raise SweepError(f"{self.robot.source}: the robot must be the plant's only model")
        self.lower = np.where(np.isfinite(lower), lower, -math.pi)
        self.upper = np.where(np.isfinite(upper), upper, math.pi)

    def pose(self, q: np.ndarray):
        """X_WE at ``q``."""
        self.plant.SetPositions(self.context, q)
        return self.frame.CalcPoseInWorld(self.context)


def end_effector_link(urdf: str, base_link: str) -> str:
    """The last link of the chain of a URDF (see the module docstring)."""
    root = ET.fromstring(urdf)
    children: dict[str, list[tuple[str, bool]]] = {}
    for joint in root.findall("joint"):
        parent = joint.find("parent").get("link")
        child = joint.find("child").get("link")
        children.setdefault(parent, []).append((child, joint.get("type") != "fixed"))

    def moving_below(link: str) -> int:
        return sum(moving + moving_below(child) for child, moving in children.get(link, []))

    link = base_link
    while moving_below(link):
        branches = [
            (child, moving) for child, moving in children[link] if moving or moving_below(child)
        ]
        if len(branches) > 1:
            names = ", ".join(child for child, _ in branches)
            raise SweepError(
                f"the robot's moving joints branch at {link!r} (into {names}); "
                "choose the end effector with --frame"
            )
        link = branches[0][0]
    while len(children.get(link, [])) == 1:
        link = children[link][0][0]
    return link


def sample_configurations(lower, upper, samples: int, seed: int) -> np.ndarray:
    """``samples`` rows drawn uniformly within [lower, upper] from ``default_rng(seed)``."""
    rng = np.random.default_rng(seed)
    return rng.uniform(lower, upper, size=(samples, len(lower)))


def _pose_columns(X) -> list[float]:
    quaternion = X.rotation().ToQuaternion()
    wxyz = np.array([quaternion.w(), quaternion.x(), quaternion.y(), quaternion.z()])
    if wxyz[0] < 0:
        wxyz = -wxyz
    return [*X.translation(), *wxyz, *X.rotation().matrix().reshape(-1)]


def compute_shard(shard: IkShard) -> dict[str, Any]:
    """The rows of one shard: ``{"start": ..., "columns": {name: list}}``."""
    from pydrake.math import RotationMatrix
    from pydrake.multibody.inverse_kinematics import InverseKinematics
    from pydrake.solvers import Solve

    model = _Model(shard.robot)
    q_all = np.asarray(shard.q, dtype=float).reshape(len(shard.q), len(model.joint_names))
    columns: dict[str, list] = {"sample": list(range(shard.start, shard.start + len(q_all)))}
    for i, name in enumerate(model.joint_names):
        columns[f"q_{name}"] = q_all[:, i].tolist()
    poses = [model.pose(q) for q in q_all]
    pose_rows = np.array([_pose_columns(X) for X in poses])
    for i, name in enumerate(POSE_COLUMNS):
        columns[name] = pose_rows[:, i].tolist()
    if not shard.ik.enabled:
        return {"start": shard.start, "columns": columns}
    world = model.plant.world_frame()
    success, attempts, solutions, position_errors, angle_errors = [], [], [], [], []
    for row, X_WE in enumerate(poses):
        rng = np.random.default_rng([shard.seed, shard.start + row])
        tolerance = shard.ik.position_tolerance
        attempt = 0
        while attempt < shard.ik.attempts:
            attempt += 1
            ik = InverseKinematics(model.plant, with_joint_limits=True)
            ik.AddPositionConstraint(
                frameB=model.frame,
                p_BQ=np.zeros(3),
                frameA=world,
                p_AQ_lower=X_WE.translation() - tolerance,
                p_AQ_upper=X_WE.translation() + tolerance,
            )
            ik.AddOrientationConstraint(
                frameAbar=world,
                R_AbarA=X_WE.rotation(),
                frameBbar=model.frame,
                R_BbarB=RotationMatrix(),
                theta_bound=shard.ik.orientation_tolerance,
            )
            guess = rng.uniform(model.lower, model.upper)
            result = Solve(ik.prog(), guess)
            if result.is_success():
                break
        solution = result.GetSolution(ik.q())
        X_ik = model.pose(solution)
        success.append(bool(result.is_success()))
        attempts.append(attempt)
        solutions.append(solution)
        position_errors.append(float(np.linalg.norm(X_ik.translation() - X_WE.translation())))
        relative = X_WE.rotation().inverse().multiply(X_ik.rotation())
        angle_errors.append(float(relative.ToAngleAxis().angle()))
    columns["ik_success"] = success
    columns["ik_attempts"] = attempts
    solutions = np.array(solutions).reshape(len(q_all), len(model.joint_names))
    for i, name in enumerate(model.joint_names):
        columns[f"ik_q_{name}"] = solutions[:, i].tolist()
    columns["ik_position_error"] = position_errors
    columns["ik_orientation_error"] = angle_errors
    return {"start": shard.start, "columns": columns}


# The most rows a data set may have: its configurations and poses are held in memory
# (about BYTES_PER_ROW each, joints, pose and errors as doubles) before the file is written.
MAX_SAMPLES = 10_000_000
BYTES_PER_ROW = 200


def make_shards(
    robot: RobotSpec, ik: IkSettings, samples: int, seed: int, shards: int
) -> tuple[list[IkShard], dict[str, Any]]:
    """The data set's rows drawn and cut into ``shards`` tasks; and the file's metadata."""
    if samples < 1:
        raise SweepError(f"--samples {samples} must be at least 1")
    if samples > MAX_SAMPLES:
        gigabytes = samples * BYTES_PER_ROW / 2**30
        raise SweepError(
            f"--samples {samples:,}: over {MAX_SAMPLES:,} rows (about {gigabytes:,.0f} GiB in "
            "memory before it is written); make several data sets"
        )
    if shards < 1:
        raise SweepError(f"--shards {shards} must be at least 1")
    if ik.position_tolerance <= 0 or ik.orientation_tolerance <= 0 or ik.attempts < 1:
        raise SweepError(
            f"--ik-tolerance {ik.position_tolerance} m / {ik.orientation_tolerance} rad must "
            f"be positive and --ik-attempts {ik.attempts} at least 1"
        )
    from importlib import metadata as package_metadata

    model = _Model(robot)
    q = sample_configurations(model.lower, model.upper, samples, seed)
    bounds = np.linspace(0, samples, min(shards, samples) + 1).round().astype(int)
    tasks = [
        IkShard(robot=robot, ik=ik, seed=seed, start=int(a), q=q[a:b].tolist())
        for a, b in zip(bounds[:-1], bounds[1:], strict=True)
    ]
    metadata = {
        "kind": "ik",
        "robot": {
            "description": str(model.robot.source),
            "name": model.robot.name,
            "xacro_args": dict(robot.xacro_args),
            "package_paths": [str(Path(path).resolve()) for path in robot.package_paths],
        },
        "frame": model.frame_name,
        "base_link": model.robot.base_link,
        "joint_names": model.joint_names,
        "lower": model.lower.tolist(),
        "upper": model.upper.tolist(),
        "seed": seed,
        "samples": samples,
        "ik": asdict(ik),
        "drake": package_metadata.version("drake"),
        "armando_drake": provenance(),
    }
    return tasks, metadata


def write_dataset(results: Sequence[dict[str, Any]], metadata: dict, output: str | Path) -> Path:
    """The shards' rows in order, as one Parquet file with the metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    ordered = sorted(results, key=lambda r: r["start"])
    names = list(ordered[0]["columns"])
    data = {name: [v for r in ordered for v in r["columns"][name]] for name in names}
    table = pa.table(data)
    table = table.replace_schema_metadata({METADATA_KEY: json.dumps(metadata).encode()})
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, output)
    return output


def make_ik_dataset(
    robot: RobotSpec,
    samples: int,
    seed: int,
    output: str | Path,
    engine,
    *,
    ik: IkSettings | None = None,
    shards: int | None = None,
    progress: bool = False,
) -> Path:
    """Draws, computes (on ``engine``) and writes the inverse-kinematics data set."""
    from tqdm import tqdm

    ik = ik or IkSettings()
    tasks, metadata = make_shards(robot, ik, samples, seed, shards or 4 * engine.workers)
    results = []
    with tqdm(total=samples, unit="row", file=sys.stderr, disable=not progress) as bar:
        for result in engine.map_unordered(compute_shard, tasks):
            results.append(result)
            bar.update(len(result["columns"]["sample"]))
    return write_dataset(results, metadata, output)


def read_metadata(path: str | Path) -> dict:
    """The ``armando_drake`` metadata of a data set file."""
    import pyarrow.parquet as pq

    return json.loads(pq.read_schema(path).metadata[METADATA_KEY])


def _parser() -> argparse.ArgumentParser:

    parser = command_parser("armando_drake.dataset", __doc__)
    kinds = parser.add_subparsers(dest="kind", required=True, metavar="KIND")
    ik = kinds.add_parser(
        "ik",
        help="joint configurations, end-effector poses, optional IK solutions",
        description="Random joint configurations, their end-effector poses and optionally "
        "the inverse kinematics solved back (the schema is in python -m "
        "armando_drake.dataset --help).",
    )
    ik.add_argument("--robot", default="", metavar="PATH", help="robot description (Armando)")
    ik.add_argument(
        "--xacro-arg", action="append", default=[], metavar="NAME:=VALUE", help="xacro argument"
    )
    ik.add_argument(
        "--package-path",
        action="append",
        type=package_folder,
        default=[],
        metavar="DIR",
        help="ROS package folder",
    )
    ik.add_argument("--frame", default="", help="end-effector frame (the last link of the chain)")
    ik.add_argument("--samples", type=int, required=True, metavar="N", help="rows")
    ik.add_argument("--seed", type=int, default=0, metavar="S", help="seed (default: 0)")
    ik.add_argument("--output", required=True, metavar="FILE.parquet", help="the data set")
    ik.add_argument("--ik", action="store_true", help="solve the inverse kinematics back")
    ik.add_argument(
        "--ik-tolerance",
        type=float,
        nargs=2,
        default=[1e-6, 1e-4],
        metavar=("METRES", "RADIANS"),
        help="position and orientation tolerance of the IK (default: 1e-6 m, 1e-4 rad)",
    )
    ik.add_argument(
        "--ik-attempts", type=int, default=10, metavar="N", help="initial guesses per row (10)"
    )
    ik.add_argument("--shards", type=int, metavar="K", help="tasks (default: 4 per worker)")
    ik.add_argument("--workers", type=int, metavar="N", help="processes (default: CPUs)")
    ik.add_argument("--ray", metavar="ADDRESS", help="run the shards on Ray: auto, local, ADDR")
    ik.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)

    with user_errors(), reported():
        _check_output_file(args.output)
        robot = RobotSpec(
            description=args.robot,
            xacro_args=parse_xacro_args(args.xacro_arg),
            package_paths=list(args.package_path),
            frame=args.frame,
        )
        ik = IkSettings(
            enabled=args.ik,
            position_tolerance=args.ik_tolerance[0],
            orientation_tolerance=args.ik_tolerance[1],
            attempts=args.ik_attempts,
        )
        with make_engine(args.ray, args.workers) as engine:
            path = make_ik_dataset(
                robot,
                args.samples,
                args.seed,
                args.output,
                engine,
                ik=ik,
                shards=args.shards,
                progress=not args.quiet,
            )
        metadata = read_metadata(path)
        print(f"{args.samples} rows, end effector {metadata['frame']!r}: {path}")
        if args.ik:
            import pyarrow.parquet as pq

            solved = sum(pq.read_table(path, columns=["ik_success"])["ik_success"].to_pylist())
            print(f"inverse kinematics solved for {solved} of {args.samples} rows")
    return 0


def _check_output_file(output: str) -> None:
    """``--output`` names a file, not a folder (checked before the rows are drawn and
    solved; its folder is made when missing)."""
    path = Path(output)
    if path.is_dir():
        example = path / "ik.parquet"
        raise SweepError(f"--output {output}: a folder; name the data set's file, e.g. {example}")
