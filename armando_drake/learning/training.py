"""Training the learned inverse kinematics: one branch, a small network, its figures.

A data set of ``python -m armando_drake.dataset ik`` holds random configurations q and
the end-effector pose of each. Pose to q is not a function as it stands: Armando reaches
most poses with the elbow either way, a 6-joint arm has up to 8 solutions and a 7-joint
arm a continuum; a network fitted to all the rows learns their average, which is no
solution. So the rows of one branch are chosen (:func:`label_branch`): each pose is
linked to its nearest poses in feature space when the pair is consistent to first
order, i.e. its joint change dq (angles wrapped) matches J^+ dx, the pseudo-inverse of
the Jacobian (the mean of both ends') times its pose change, and both ends are away from
singular configurations (the smallest singular value of the Jacobian, rotation rows
scaled by :data:`~armando_drake.learning.network.ORIENTATION_WEIGHT`, at least
``min_dexterity`` of the data's median). Two branches meet only at singular
configurations, so no link joins them; the largest linked set is the branch (on
Armando: one elbow sign, about three quarters of its rows; the poses near the
stretched or folded arm are left out). For a redundant arm, the links also leave out
pairs that differ by a self-motion (J^+ dx has none).

The network (:func:`train`) is scikit-learn's ``MLPRegressor`` (tanh, L-BFGS) behind a
``StandardScaler`` of the pose features (:mod:`armando_drake.learning.network`); it
outputs the sine and cosine of each joint angle. It is exported with skl2onnx
(:func:`export`). :func:`evaluate` measures, on held-out poses of the branch, the
position and orientation error of the network alone, after
:func:`~armando_drake.learning.network.refine`, and of Drake's IK
(:func:`~armando_drake.kinematics.inverse_kinematics.solve_ik`, the whole pose as a
constraint), and the time each takes per pose.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.tree import JacobianWrtVariable

from armando_drake.kinematics.arm import ArmModel
from armando_drake.kinematics.inverse_kinematics import solve_ik
from armando_drake.learning.network import (
    ALL_FEATURES,
    METADATA_KEY,
    ORIENTATION_WEIGHT,
    IkModel,
    LearnedIkError,
    checked_metadata,
    pose_errors,
    refine,
    regular_file,
)
from armando_drake.tools.extras import require_extra

# [-] a rotation entry whose standard deviation over the data is below this is constant
CONSTANT_FEATURE = 1e-6
# The largest data set read (100,000 rows of 16 columns are about 13 MB).
MAX_DATASET_BYTES = 2 * 2**30
# A neighbour pair is on one branch when its joint change dq matches the first-order
# change J^+ dx of its pose change within CONSISTENCY[0] + CONSISTENCY[1] * |dq| [rad].
CONSISTENCY = (0.05, 0.2)


@dataclass
class TrainSettings:
    """How the network is trained and checked (``python -m armando_drake.learn ik``)."""

    hidden: tuple[int, ...] = (64, 64)  # neurons of each hidden layer
    max_iter: int = 1500  # L-BFGS iterations at most
    held_out: float = 0.1  # [-] share of the rows kept out of training, for the table
    seed: int = 0  # the split, the network's initial weights
    neighbours: int = 8  # poses each continuation step reaches from a labelled one
    max_step: float = 1.0  # [rad or m] largest joint change of a continuation step
    min_dexterity: float = 0.5  # [-] of the data's median smallest singular value
    refine_steps: int = 3  # Gauss-Newton steps after the network, for the table
    drake_poses: int = 50  # held-out poses Drake's IK solves for the table
    timing_poses: int = 500  # held-out poses the network is timed on, one at a time


@dataclass
class IkData:
    """A data set's poses and configurations, and its metadata."""

    features: np.ndarray  # (N, 12) ALL_FEATURES
    q: np.ndarray  # (N, n) configurations (data set joint order)
    metadata: dict
    path: Path

    @property
    def joint_names(self) -> list[str]:
        return list(self.metadata["joint_names"])

    def pose(self, row: int) -> RigidTransform:
        """X_DE of ``row``."""
        f = self.features[row]
        return RigidTransform(RotationMatrix(f[3:].reshape(3, 3)), f[:3])


def read_dataset(path: str | Path) -> IkData:
    """The rows of a data set of ``python -m armando_drake.dataset ik``."""
    import pyarrow.parquet as pq

    path = Path(path)
    if not path.exists():
        raise LearnedIkError(f"--data {path}: no such file")
    regular_file(path, "--data (a data set)", MAX_DATASET_BYTES)
    try:
        schema = pq.read_schema(path)
    except FileNotFoundError:
        raise LearnedIkError(f"--data {path}: no such file") from None
    except Exception as error:  # pyarrow's ArrowInvalid, IsADirectoryError, ...
        raise LearnedIkError(f"--data {path}: not a Parquet data set ({error})") from None
    raw = (schema.metadata or {}).get(METADATA_KEY.encode())
    metadata = json.loads(raw) if raw and _is_json_object(raw) else {}
    if metadata.get("kind") != "ik":
        raise LearnedIkError(
            f"--data {path}: not a data set of python -m armando_drake.dataset ik "
            f"(no {METADATA_KEY!r} metadata of kind 'ik')"
        )
    metadata = checked_metadata(raw, f"--data {path}: metadata {METADATA_KEY!r}")
    names = metadata["joint_names"]
    wanted = [*ALL_FEATURES, *(f"q_{name}" for name in names)]
    missing = [name for name in wanted if name not in schema.names]
    if missing:
        raise LearnedIkError(f"--data {path}: no column {', '.join(missing)}")
    try:
        table = pq.read_table(path, columns=wanted)
        columns = {name: table[name].to_numpy().astype(float) for name in table.column_names}
    except Exception as error:  # pyarrow's ArrowInvalid, a column that is not numbers
        reason = " ".join(str(error).split())[:200]
        raise LearnedIkError(f"--data {path}: the columns cannot be read ({reason})") from None
    features = np.column_stack([columns[name] for name in ALL_FEATURES])
    q = np.column_stack([columns[f"q_{name}"] for name in names])
    if len(q) == 0:
        raise LearnedIkError(f"--data {path}: no rows")
    bad = ~(np.isfinite(features).all(axis=1) & np.isfinite(q).all(axis=1))
    if bad.any():
        raise LearnedIkError(
            f"--data {path}: {int(bad.sum())} rows with a NaN or infinite value "
            f"(the first: row {int(np.argmax(bad))})"
        )
    return IkData(features=features, q=q, metadata=metadata, path=path)


def _is_json_object(raw: bytes) -> bool:
    try:
        return isinstance(json.loads(raw), dict)
    except (ValueError, TypeError):
        return False


def varying_features(features: np.ndarray) -> list[str]:
    """The names of :data:`ALL_FEATURES` that vary over ``features`` (the position always)."""
    spread = features.std(axis=0)
    return [name for k, name in enumerate(ALL_FEATURES) if k < 3 or spread[k] > CONSTANT_FEATURE]


def jacobians(arm: ArmModel, q: np.ndarray) -> np.ndarray:
    """(N, 6, n) the Jacobians of ``arm`` (rows [w; v], in its base frame) at each row of
    ``q`` (N, n)."""
    plant, context = arm.plant, arm.context
    positions = plant.GetPositions(context).copy()
    frame_E, frame_B = arm.frame_E, arm.frame_B
    columns = arm.velocity_indices
    out = np.empty((len(q), 6, arm.num_joints))
    zero = np.zeros(3)
    for r in range(len(q)):
        positions[arm.position_indices] = q[r]
        plant.SetPositions(context, positions)
        out[r] = plant.CalcJacobianSpatialVelocity(
            context, JacobianWrtVariable.kV, frame_E, zero, frame_B, frame_B
        )[:, columns]
    return out


def rotation_logs(R_from: np.ndarray, R_to: np.ndarray) -> np.ndarray:
    """(N, 3) rotation vectors [rad] (in the base frame) taking each R_from to R_to."""
    R = R_to @ np.swapaxes(R_from, 1, 2)
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)
    angle = np.arccos(cos)
    vee = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], 1)
    sin = np.sin(angle)
    scale = np.where(sin > 1e-9, angle / (2 * np.where(sin > 1e-9, sin, 1)), 0.5)
    return vee * scale[:, None]


def wrapped(dq: np.ndarray, angular: np.ndarray) -> np.ndarray:
    """Joint differences, the angular ones wrapped into [-pi, pi)."""
    return np.where(angular, (dq + np.pi) % (2 * np.pi) - np.pi, dq)


@dataclass
class Branch:
    """The rows of one branch (see :func:`label_branch`)."""

    rows: np.ndarray  # indices into the rows given, on the branch
    threshold: float  # [m] the least dexterity accepted
    edges: int  # neighbour pairs that passed the test


def label_branch(
    arm: ArmModel, data: IkData, rows: np.ndarray, angular: np.ndarray, settings: TrainSettings
) -> Branch:
    """The rows of ``rows`` on one branch: the largest set linked by consistent
    neighbour pairs (see the module doc)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from sklearn.neighbors import NearestNeighbors

    used = varying_features(data.features)
    columns = [ALL_FEATURES.index(name) for name in used]
    F = data.features[np.ix_(rows, columns)]
    F = (F - F.mean(axis=0)) / np.maximum(F.std(axis=0), CONSTANT_FEATURE)
    k = min(settings.neighbours + 1, len(rows))
    neighbours = NearestNeighbors(n_neighbors=k).fit(F).kneighbors(F, return_distance=False)
    q = data.q[rows]
    J = jacobians(arm, q)
    J[:, :3] *= ORIENTATION_WEIGHT
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    sigma = S[:, -1]
    inverse = np.where(S > 1e-9 * S[:, :1], 1 / np.where(S > 0, S, 1), 0)
    pinv = np.swapaxes(Vt, 1, 2) @ (inverse[:, :, None] * np.swapaxes(U, 1, 2))
    threshold = settings.min_dexterity * float(np.median(sigma))
    a = np.repeat(np.arange(len(rows)), k - 1)
    b = neighbours[:, 1:].reshape(-1)
    poses = data.features[rows]
    R = poses[:, 3:].reshape(-1, 3, 3)
    dx = np.hstack([ORIENTATION_WEIGHT * rotation_logs(R[a], R[b]), poses[b, :3] - poses[a, :3]])
    dq = wrapped(q[b] - q[a], angular)
    predicted = 0.5 * np.einsum("eij,ej->ei", pinv[a] + pinv[b], dx)
    miss = np.max(np.abs(dq - predicted), axis=1)
    step = np.max(np.abs(dq), axis=1)
    ok = (miss <= CONSISTENCY[0] + CONSISTENCY[1] * step) & (step <= settings.max_step)
    ok &= (sigma[a] >= threshold) & (sigma[b] >= threshold)
    graph = coo_matrix((np.ones(ok.sum()), (a[ok], b[ok])), shape=(len(rows), len(rows)))
    _, component = connected_components(graph, directed=False)
    largest = np.bincount(component).argmax()
    on_branch = np.flatnonzero(component == largest)
    return Branch(rows=rows[on_branch], threshold=threshold, edges=int(ok.sum()))


def train(features: np.ndarray, labels: np.ndarray, settings: TrainSettings):
    """The fitted scikit-learn pipeline (scaler, MLPRegressor) from features to labels."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    network = MLPRegressor(
        hidden_layer_sizes=tuple(settings.hidden),
        activation="tanh",
        solver="lbfgs",
        max_iter=settings.max_iter,
        max_fun=4 * settings.max_iter,
        tol=1e-10,
        random_state=settings.seed,
    )
    pipeline = make_pipeline(StandardScaler(), network)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)  # max_iter is the budget
        pipeline.fit(features, labels)
    return pipeline


def export(pipeline, features: list[str], metadata: dict, path: str | Path) -> Path:
    """``pipeline`` as an ONNX file at ``path`` with the network's metadata
    (:class:`~armando_drake.learning.network.IkModel` reads it)."""
    from skl2onnx import to_onnx

    example = np.zeros((1, len(features)), dtype=np.float32)
    onnx_model = to_onnx(pipeline, example)
    entry = onnx_model.metadata_props.add()
    entry.key = METADATA_KEY
    entry.value = json.dumps({**metadata, "features": features})
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(onnx_model.SerializeToString())
    return path


@dataclass
class MethodFigures:
    """Errors and time of one way of solving, over the held-out poses."""

    method: str
    poses: int
    position_mm: dict[str, float]  # percentile name -> [mm]
    orientation_deg: dict[str, float]  # percentile name -> [deg]
    ms_per_pose: float  # [ms] median time of one pose


@dataclass
class Evaluation:
    """The table of ``python -m armando_drake.learn ik``."""

    robot: str
    frame: str
    joints: int
    features: list[str]
    rows: dict[str, int]  # data set, labelled, training, held out
    train_seconds: float
    methods: list[MethodFigures] = field(default_factory=list)

    def markdown(self) -> str:
        head = (
            "| method | poses | position error p50 / p90 / p99 / max [mm] "
            "| orientation error p50 / p90 / p99 / max [deg] | time per pose [ms] |"
        )
        lines = [
            f"Learned IK of {self.robot} (end effector {self.frame}, {self.joints} joints; "
            f"features {', '.join(self.features)}); rows: "
            + ", ".join(f"{value} {key}" for key, value in self.rows.items())
            + f"; trained in {self.train_seconds:.1f} s.",
            "",
            head,
            "| --- | ---: | ---: | ---: | ---: |",
        ]
        for m in self.methods:
            p = " / ".join(_short(v) for v in m.position_mm.values())
            o = " / ".join(_short(v) for v in m.orientation_deg.values())
            lines.append(f"| {m.method} | {m.poses} | {p} | {o} | {m.ms_per_pose:.3g} |")
        return "\n".join(lines) + "\n"

    def as_dict(self) -> dict:
        return asdict(self)


def _short(value: float) -> str:
    return f"{value:.3g}" if value >= 1e-3 or value == 0 else f"{value:.1e}"


PERCENTILES = {"p50": 50, "p90": 90, "p99": 99, "max": 100}


def _figures(method: str, errors: np.ndarray, times: np.ndarray) -> MethodFigures:
    errors = np.asarray(errors).reshape(-1, 2)
    return MethodFigures(
        method=method,
        poses=len(errors),
        position_mm={
            k: float(np.percentile(errors[:, 0], p)) * 1e3 for k, p in PERCENTILES.items()
        },
        orientation_deg={
            k: float(np.degrees(np.percentile(errors[:, 1], p))) for k, p in PERCENTILES.items()
        },
        ms_per_pose=float(np.median(times)) * 1e3,
    )


def evaluate(
    model: IkModel, arm: ArmModel, data: IkData, rows: np.ndarray, settings: TrainSettings
) -> list[MethodFigures]:
    """The network alone, refined, and Drake's IK on the held-out ``rows``."""
    targets = [data.pose(r) for r in rows]
    raw = model.predict_features(data.features[rows])  # all at once: the errors
    errors_raw = np.array([pose_errors(arm, q, X) for q, X in zip(raw, targets, strict=True)])
    timed = rows[: settings.timing_poses]
    times_raw = []
    for r in timed:  # one pose at a time, as a node answers a target
        started = time.perf_counter()
        model.predict_features(data.features[r])
        times_raw.append(time.perf_counter() - started)
    refined, times_refined = [], []
    for q, X in zip(raw, targets, strict=True):
        started = time.perf_counter()
        q = refine(arm, q, X, settings.refine_steps)
        times_refined.append(time.perf_counter() - started)
        refined.append(pose_errors(arm, q, X))
    times_refined = np.array(times_refined[: len(timed)]) + np.array(times_raw)
    drake, times_drake = [], []
    for X in targets[: settings.drake_poses]:
        started = time.perf_counter()
        result = solve_ik(arm, X, orientation="constraint")
        times_drake.append(time.perf_counter() - started)
        drake.append(pose_errors(arm, result.q, X))
    steps = settings.refine_steps
    return [
        _figures("network (ONNX Runtime)", errors_raw, np.array(times_raw)),
        _figures(f"network + {steps} Gauss-Newton steps", np.array(refined), times_refined),
        _figures("Drake InverseKinematics (solve_ik)", np.array(drake), np.array(times_drake)),
    ]


def check_extras() -> None:
    """The learn extra, before any work."""
    require_extra("learn", "python -m armando_drake.learn ik")
