"""Learned inverse kinematics in one command: data set, training, export, inference check.

``python -m armando_drake.learn ik`` trains a small network from end-effector pose to
joint positions (the course's IK node, TensorFlow there) on a data set of ``python -m
armando_drake.dataset ik`` (``--data``), or on one it makes first (``--samples``):

1. the data set's rows on one branch of the inverse kinematics (the poses near
   singular configurations left out, see armando_drake/learning/training.py);
2. scikit-learn's MLPRegressor fitted on them (pose features in, the sine and cosine
   of each joint angle out), held-out rows kept aside;
3. exported as ONNX (skl2onnx) to OUTPUT/ik_network.onnx and loaded back in ONNX
   Runtime, whose answers are checked against scikit-learn's;
4. the table: position and orientation error percentiles on the held-out poses of
   the network alone, after a few Gauss-Newton steps, and of Drake's
   InverseKinematics, with the time of each per pose; printed and written to
   OUTPUT/accuracy.md and OUTPUT/accuracy.json.

The network runs in a diagram as armando_drake.learning.network.IkNetwork (see
diagrams/learned_ik.yaml and docs/learned-ik.md). BLAS runs on one thread.
``python -m armando_drake.learn ik-node`` runs a network as a DDS node: each pose on
target_pose answered on ik_solution (armando_drake/ros2/ik_node.py).

Examples:
  python -m armando_drake.learn ik --samples 40000 --output out/learned_ik
  python -m armando_drake.learn ik --data out/ik.parquet --output out/learned_ik
  python -m armando_drake.learn ik --robot models/iiwa_description --samples 40000 \\
      --hidden 128,128 --output out/iiwa_ik
  python -m armando_drake.learn ik-node --network out/learned_ik/ik_network.onnx
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from armando_drake import MODELS_DIR
from armando_drake.learning.network import (
    ALL_FEATURES,
    IkModel,
    LearnedIkError,
    angular_joints,
    encode_joints,
    robot_arm,
)
from armando_drake.learning.training import (
    Evaluation,
    IkData,
    TrainSettings,
    check_extras,
    evaluate,
    export,
    label_branch,
    read_dataset,
    train,
    varying_features,
)
from armando_drake.ros2.ik_node import LearnedIkNode
from armando_drake.sweeps.dataset import RobotSpec, make_ik_dataset
from armando_drake.sweeps.engines import make_engine
from armando_drake.sweeps.errors import SweepError, reported
from armando_drake.tools.cli import command_parser, package_folder, parse_xacro_args, user_errors
from armando_drake.tools.version import provenance

NETWORK_FILE = "ik_network.onnx"
# [-] the least share of the data set's poses a branch must hold to be trained on alone
MIN_BRANCH_SHARE = 0.05
DATASET_FILE = "ik.parquet"
# Limits of the options (each refused past it, the value named): work that grows with
# them (nearest neighbours, L-BFGS iterations, Drake's solves, Gauss-Newton steps).
MAX_NEIGHBOURS = 1000
MAX_ITERATIONS = 100_000
MAX_DRAKE_POSES = 100_000
MAX_REFINE_STEPS = 50
MAX_DOMAIN_ID = 232  # DDS's (ROS 2's) largest domain id
MAX_NODE_DURATION = 366 * 86400.0  # [s] a year
_NAMESPACE = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*){1,8}")


def _log(message: str, quiet: bool) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)


def _hidden(text: str) -> tuple[int, ...]:
    try:
        layers = tuple(int(part) for part in text.split(","))
    except ValueError:
        raise SweepError(f"--hidden {text!r}: give neurons per layer, e.g. 64,64") from None
    if not layers or min(layers) < 1 or max(layers) > 4096:
        raise SweepError(f"--hidden {text!r}: each layer needs 1 to 4096 neurons")
    return layers


def _check(settings: TrainSettings) -> None:
    if not 0 < settings.held_out < 1:
        raise SweepError(f"--held-out {settings.held_out} must be between 0 and 1")
    for option, value, most in (
        ("--max-iter", settings.max_iter, MAX_ITERATIONS),
        ("--neighbours", settings.neighbours, MAX_NEIGHBOURS),
        ("--drake-poses", settings.drake_poses, MAX_DRAKE_POSES),
    ):
        if not 1 <= value <= most:
            raise SweepError(f"{option} {value} must be between 1 and {most}")
    _check_refine_steps(settings.refine_steps)
    if not settings.min_dexterity >= 0:
        raise SweepError(f"--min-dexterity {settings.min_dexterity} must be >= 0")


def _check_refine_steps(steps: int) -> None:
    if not 0 <= steps <= MAX_REFINE_STEPS:
        raise SweepError(f"--refine-steps {steps} must be between 0 and {MAX_REFINE_STEPS}")


def _check_node(args) -> None:
    """The ik-node command's options: a DDS domain, a namespace, steps and a duration
    that can be used; a SweepError naming the option else."""
    if not 0 <= args.domain_id <= MAX_DOMAIN_ID:
        raise SweepError(f"--domain-id {args.domain_id} must be between 0 and {MAX_DOMAIN_ID}")
    if args.namespace and not _NAMESPACE.fullmatch(args.namespace):
        raise SweepError(f"--namespace {args.namespace!r} is not a namespace like /arm")
    _check_refine_steps(args.refine_steps)
    if not (math.isfinite(args.duration) and 0 <= args.duration <= MAX_NODE_DURATION):
        raise SweepError(
            f"--duration {args.duration} must be between 0 (until Ctrl-C) and "
            f"{MAX_NODE_DURATION:g} s"
        )


def portable_robot(robot: dict) -> dict:
    """The data set's robot with a description among the project's models/ as a
    ``package://`` URL (found wherever the project is installed)."""
    robot = dict(robot)
    path = Path(robot["description"])
    try:
        relative = path.resolve().relative_to(MODELS_DIR.resolve())
    except (ValueError, OSError):
        return robot
    robot["description"] = f"package://{relative.as_posix()}"
    return robot


def _check_onnx(pipeline, model: IkModel, features: np.ndarray, quiet: bool) -> None:
    """ONNX Runtime's outputs for ``features`` are scikit-learn's (float32 round-off)."""
    expected = pipeline.predict(features)
    got = model.session.run(None, {model.session.get_inputs()[0].name: features.astype(np.float32)})
    mismatch = float(np.max(np.abs(expected - np.asarray(got[0]).reshape(expected.shape))))
    _log(f"ONNX Runtime answers scikit-learn's outputs within {mismatch:.1e}", quiet)
    if mismatch > 1e-3:
        raise LearnedIkError(
            f"{model.path}: ONNX Runtime differs from scikit-learn by {mismatch:.3g}"
        )


def learn_ik(data: IkData, output: Path, settings: TrainSettings, quiet: bool = True):
    """Trains, exports and checks the network of ``data`` (see the module doc); the
    network file and the :class:`Evaluation`."""
    arm = robot_arm(data.metadata)
    if sorted(arm.joint_names) != sorted(data.joint_names):
        raise LearnedIkError(
            f"--data {data.path}: its joints {data.joint_names} are not the robot's "
            f"{arm.joint_names}"
        )
    angular = np.array(angular_joints(arm))[[arm.joint_names.index(n) for n in data.joint_names]]
    branch = label_branch(arm, data, np.arange(len(data.q)), angular, settings)
    _log(f"{len(branch.rows)} of {len(data.q)} poses on one IK branch", quiet)
    chosen = branch.rows
    if len(chosen) < MIN_BRANCH_SHARE * len(data.q):
        # Too few samples for this arm to link its poses (e.g. 7 joints): every row, and
        # the network answers an average of the solutions for the refinement to finish.
        chosen = np.arange(len(data.q))
        _log(
            f"under {MIN_BRANCH_SHARE:.0%} of the poses on one branch: training on all "
            f"{len(chosen)} rows (the network alone is coarse; refine its answers)",
            quiet,
        )
    rows = np.random.default_rng(settings.seed).permutation(chosen)
    held_out = max(1, round(settings.held_out * len(rows)))
    if len(rows) - held_out < 10:
        raise SweepError(
            f"--data {data.path}: only {len(rows)} poses on one IK branch; give more "
            "--samples (or a lower --min-dexterity)"
        )
    test, fit = rows[:held_out], rows[held_out:]
    features = varying_features(data.features)
    columns = [ALL_FEATURES.index(name) for name in features]
    started = time.perf_counter()
    pipeline = train(
        data.features[np.ix_(fit, columns)], encode_joints(data.q[fit], angular), settings
    )
    train_seconds = time.perf_counter() - started
    _log(f"trained on {len(fit)} poses in {train_seconds:.1f} s", quiet)
    metadata = {
        "kind": "ik_network",
        "robot": portable_robot(data.metadata["robot"]),
        "frame": data.metadata["frame"],
        "base_link": data.metadata.get("base_link", ""),
        "joint_names": data.joint_names,
        "lower": data.metadata["lower"],
        "upper": data.metadata["upper"],
        "angular": [bool(a) for a in angular],
        "dataset": {"file": data.path.name, "seed": data.metadata.get("seed")},
        "training": {**{k: v for k, v in vars(settings).items()}, "rows": len(fit)},
        "branch": {
            "rows": len(branch.rows),
            "min_dexterity_m": branch.threshold,
            "all_rows": len(chosen) == len(data.q) and len(branch.rows) < len(data.q),
        },
        "armando_drake": provenance(),
    }
    path = export(pipeline, features, metadata, output / NETWORK_FILE)
    model = IkModel(path)
    _check_onnx(pipeline, model, data.features[np.ix_(test, columns)], quiet)
    evaluation = Evaluation(
        robot=data.metadata["robot"]["name"],
        frame=data.metadata["frame"],
        joints=len(data.joint_names),
        features=features,
        rows={
            "in the data set": len(data.q),
            "on the branch": len(branch.rows),
            "trained from": len(chosen),
            "trained on": len(fit),
            "held out": len(test),
        },
        train_seconds=train_seconds,
    )
    evaluation.methods = evaluate(model, arm, data, test, settings)
    return path, evaluation


def _parser():
    parser = command_parser("armando_drake.learn", __doc__)
    kinds = parser.add_subparsers(dest="kind", required=True, metavar="KIND")
    ik = kinds.add_parser(
        "ik",
        help="a network from end-effector pose to joint positions",
        description="Trains, exports (ONNX) and checks a network from end-effector pose to "
        "joint positions (see python -m armando_drake.learn --help).",
    )
    source = ik.add_mutually_exclusive_group(required=True)
    source.add_argument("--data", metavar="FILE.parquet", help="a data set of dataset ik")
    source.add_argument(
        "--samples",
        type=int,
        metavar="N",
        help=f"make a data set of N rows first (OUTPUT/{DATASET_FILE})",
    )
    ik.add_argument("--output", required=True, metavar="DIR", help="folder of the results")
    ik.add_argument("--robot", default="", metavar="PATH", help="with --samples: robot (Armando)")
    ik.add_argument(
        "--xacro-arg", action="append", default=[], metavar="NAME:=VALUE", help="xacro argument"
    )
    ik.add_argument(
        "--package-path", action="append", type=package_folder, default=[], metavar="DIR",
        help="ROS package folder",
    )  # fmt: skip
    ik.add_argument("--frame", default="", help="end-effector frame (the last link of the chain)")
    ik.add_argument("--seed", type=int, default=0, metavar="S", help="data set and split seed (0)")
    ik.add_argument("--workers", type=int, default=2, metavar="N", help="data set processes (2)")
    defaults = TrainSettings()
    ik.add_argument(
        "--hidden", type=_hidden, default=defaults.hidden, metavar="N,N",
        help="neurons of each hidden layer (default: 64,64)",
    )  # fmt: skip
    ik.add_argument(
        "--max-iter", type=int, default=defaults.max_iter, metavar="N",
        help=f"L-BFGS iterations at most ({defaults.max_iter})",
    )  # fmt: skip
    ik.add_argument(
        "--held-out", type=float, default=defaults.held_out, metavar="SHARE",
        help=f"share of the branch's poses kept for the table ({defaults.held_out})",
    )  # fmt: skip
    ik.add_argument(
        "--neighbours", type=int, default=defaults.neighbours, metavar="K",
        help=f"nearest poses linked when the branch is chosen ({defaults.neighbours})",
    )  # fmt: skip
    ik.add_argument(
        "--min-dexterity",
        type=float,
        default=defaults.min_dexterity,
        metavar="SHARE",
        help="leave out poses whose Jacobian's smallest singular value is below SHARE of "
        f"the data's median ({defaults.min_dexterity})",
    )
    ik.add_argument(
        "--refine-steps", type=int, default=defaults.refine_steps, metavar="N",
        help=f"Gauss-Newton steps after the network in the table ({defaults.refine_steps})",
    )  # fmt: skip
    ik.add_argument(
        "--drake-poses", type=int, default=defaults.drake_poses, metavar="N",
        help=f"held-out poses Drake's IK solves for the table ({defaults.drake_poses})",
    )  # fmt: skip
    ik.add_argument("--quiet", action="store_true", help="no progress lines")
    _node_parser(kinds, defaults)
    return parser


def _node_parser(kinds, defaults: TrainSettings) -> None:
    """The ik-node command's options."""
    node = kinds.add_parser(
        "ik-node",
        help="a network as a DDS node: target_pose in, ik_solution out",
        description="Answers each geometry_msgs/Pose on target_pose (the end effector in "
        "the robot's base frame) with the joints on ik_solution (sensor_msgs/JointState).",
    )
    node.add_argument(
        "--network", default=str(MODELS_DIR / "learned_ik" / "armando_ik_network.onnx"),
        metavar="FILE.onnx", help="the network (default: Armando's shipped one)",
    )  # fmt: skip
    node.add_argument("--domain-id", type=int, default=0, metavar="N", help="DDS domain (0)")
    node.add_argument("--namespace", default="", metavar="/NS", help="the topics' namespace")
    node.add_argument(
        "--refine-steps", type=int, default=defaults.refine_steps, metavar="N",
        help=f"Gauss-Newton steps after the network ({defaults.refine_steps})",
    )  # fmt: skip
    node.add_argument(
        "--duration", type=float, default=0.0, metavar="S", help="seconds to run (0: Ctrl-C)"
    )


def _run_node(args) -> int:
    """The ik-node command: the node until Ctrl-C or ``--duration``."""
    node = LearnedIkNode(
        args.network,
        domain_id=args.domain_id,
        namespace=args.namespace,
        refine_steps=args.refine_steps,
    )
    print(
        f"learned IK node: {node.node.resolve('target_pose')} -> "
        f"{node.node.resolve('ik_solution')}; Ctrl-C ends it"
    )
    end = time.monotonic() + args.duration if args.duration > 0 else float("inf")
    try:
        while time.monotonic() < end:
            time.sleep(0.1)
    except KeyboardInterrupt:
        pass
    finally:
        node.close()
    print(f"answered {node.solved} poses")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.kind == "ik-node":
        with user_errors(), reported():
            _check_node(args)
            return _run_node(args)
    with user_errors(), reported():
        check_extras()
        from threadpoolctl import threadpool_limits

        started = time.perf_counter()
        output = Path(args.output)
        if output.exists() and not output.is_dir():
            raise SweepError(f"--output {args.output}: a file; name a folder")
        try:
            output.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise SweepError(
                f"--output {args.output}: cannot write there: {error.strerror}"
            ) from None
        if not os.access(output, os.W_OK | os.X_OK):
            raise SweepError(f"--output {args.output}: cannot write there: a read-only folder")
        settings = TrainSettings(
            hidden=args.hidden,
            max_iter=args.max_iter,
            held_out=args.held_out,
            seed=args.seed,
            neighbours=args.neighbours,
            min_dexterity=args.min_dexterity,
            refine_steps=args.refine_steps,
            drake_poses=args.drake_poses,
        )
        _check(settings)
        data_path = Path(args.data) if args.data else output / DATASET_FILE
        if args.samples is not None:
            robot = RobotSpec(
                description=args.robot,
                xacro_args=parse_xacro_args(args.xacro_arg),
                package_paths=list(args.package_path),
                frame=args.frame,
            )
            with make_engine(None, args.workers) as engine:
                make_ik_dataset(
                    robot, args.samples, args.seed, data_path, engine, shards=engine.workers
                )
            _log(f"data set of {args.samples} rows: {data_path}", args.quiet)
        with threadpool_limits(1):
            data = read_dataset(data_path)
            path, evaluation = learn_ik(data, output, settings, quiet=args.quiet)
        table = evaluation.markdown()
        (output / "accuracy.md").write_text(table)
        (output / "accuracy.json").write_text(json.dumps(evaluation.as_dict(), indent=2) + "\n")
        print(table)
        elapsed = time.perf_counter() - started
        print(f"network: {path}; table: {output / 'accuracy.md'}; {elapsed:.0f} s in all")
    return 0
