"""The learned inverse kinematics at run time: an ONNX network, its features, refinement.

:class:`IkModel` loads a network written by ``python -m armando_drake.learn ik`` (an
ONNX file whose metadata key ``armando_drake`` holds JSON: the robot's description,
end-effector frame, joint names and limits, and the pose features the network reads)
and runs it with ONNX Runtime, the portable counterpart of TensorFlow Lite.

The network reads pose features (:data:`ALL_FEATURES`): the end effector's position
``x, y, z`` [m] in the robot's frame D (the frame its base is welded in, as the data
set has it) and the entries ``r00`` ... ``r22`` of its rotation matrix R_DE that vary
over the data set. The rotation entries are continuous where angles wrap, and the
constant ones are left out: on Armando (yaw by j0, then a pitch by j1 + j2 + j3) 8 of
the 9 vary, ``r20`` is always 0. The network answers one branch of the inverse
kinematics (see :mod:`armando_drake.learning.training`).

:func:`refine` polishes an answer with a few Gauss-Newton steps on the pose error
(Jacobian from the plant, inside the joint limits): from the network's few
millimetres, two or three steps reach round-off.

:class:`IkNetwork` is the Drake system: a pose in, joint positions out.
"""

from __future__ import annotations

import functools
import json
import math
import os
import stat
from pathlib import Path

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from armando_drake.description.loader import load_robot
from armando_drake.kinematics.arm import ArmModel, orientation_error
from armando_drake.tools.errors import UserInputError
from armando_drake.tools.extras import require_extra

METADATA_KEY = "armando_drake"
ALL_FEATURES = ("x", "y", "z") + tuple(f"r{i}{j}" for i in range(3) for j in range(3))
# [m/rad] how much a radian of orientation error weighs against a metre of position
# error in the refinement's least squares (matters only for a pose the arm cannot take).
ORIENTATION_WEIGHT = 0.1
POSE_INPUTS = ("vector", "rigid_transform")


class LearnedIkError(UserInputError):
    """A network file that cannot be used: not ONNX, not ours, not this robot's."""


def feature_rows(positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(N, 12) :data:`ALL_FEATURES` of N poses: positions (N, 3) [m], rotations (N, 3, 3)."""
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    rotations = np.asarray(rotations, dtype=float).reshape(-1, 9)
    return np.hstack([positions, rotations])


def encode_joints(q: np.ndarray, angular) -> np.ndarray:
    """The network's outputs for joint positions ``q`` (N, n): for each joint, the sine
    and cosine of an angle (no jump where it wraps at +-pi), a length as it is."""
    q = np.asarray(q, dtype=float).reshape(-1, len(angular))
    columns = []
    for k, is_angle in enumerate(angular):
        columns += [np.sin(q[:, k]), np.cos(q[:, k])] if is_angle else [q[:, k]]
    return np.column_stack(columns)


def decode_joints(outputs: np.ndarray, angular) -> np.ndarray:
    """Joint positions (N, n) [rad or m] from the network's outputs (:func:`encode_joints`)."""
    outputs = np.asarray(outputs, dtype=float)
    angular = tuple(bool(a) for a in angular)
    if all(angular):  # the usual arm: sine, cosine, sine, cosine, ...
        return np.arctan2(outputs[:, 0::2], outputs[:, 1::2])
    angles, sines, lengths, length_columns = _output_columns(angular)
    q = np.empty((len(outputs), len(angular)))
    q[:, angles] = np.arctan2(outputs[:, sines], outputs[:, sines + 1])
    q[:, lengths] = outputs[:, length_columns]
    return q


@functools.lru_cache(maxsize=16)
def _output_columns(angular: tuple[bool, ...]) -> tuple[np.ndarray, ...]:
    """(angular joints, their sine columns, prismatic joints, their columns)."""
    angles, sines, lengths, length_columns, k = [], [], [], [], 0
    for joint, is_angle in enumerate(angular):
        if is_angle:
            angles.append(joint)
            sines.append(k)
            k += 2
        else:
            lengths.append(joint)
            length_columns.append(k)
            k += 1
    return tuple(np.array(v, dtype=int) for v in (angles, sines, lengths, length_columns))


# The largest network file read (the shipped one is a few tens of kB).
MAX_NETWORK_BYTES = 256 * 2**20
_METADATA_LISTS = ("features", "joint_names", "lower", "upper", "angular")


def regular_file(path: Path, what: str, max_bytes: int) -> None:
    """A LearnedIkError unless ``path`` is a regular file of at most ``max_bytes`` (no
    FIFO, device or directory: reading one would block or never end)."""
    try:
        info = os.stat(path)
    except OSError as error:
        raise LearnedIkError(f"{path}: {what} cannot be read ({error.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        raise LearnedIkError(f"{path}: not a regular file: {what} must be one")
    if info.st_size > max_bytes:
        raise LearnedIkError(
            f"{path}: {info.st_size:,} bytes, over the limit of {max_bytes:,} for {what}"
        )


def checked_metadata(text: str | bytes, where: str) -> dict:
    """The JSON metadata of a network or data set, checked: its lists present, of equal
    lengths per joint, bounds finite numbers; a LearnedIkError naming the key else."""
    try:
        metadata = json.loads(text)
    except (ValueError, TypeError):
        raise LearnedIkError(f"{where}: not JSON") from None
    if not isinstance(metadata, dict):
        raise LearnedIkError(f"{where}: not a JSON object")
    keys = [k for k in ("joint_names", "lower", "upper", "angular") if k in metadata]
    for key in keys + (["features"] if "features" in metadata else []):
        if not isinstance(metadata[key], list):
            raise LearnedIkError(f"{where}: key {key!r} must be a list, not {metadata[key]!r}")
    names = metadata.get("joint_names")
    if not names or not all(isinstance(n, str) and n for n in names):
        raise LearnedIkError(f"{where}: key 'joint_names' must list the joints, not {names!r}")
    for key in ("lower", "upper", "angular"):
        if key in metadata and len(metadata[key]) != len(names):
            raise LearnedIkError(
                f"{where}: key {key!r} has {len(metadata[key])} values for {len(names)} joints"
            )
    for key in ("lower", "upper"):
        values = metadata.get(key, [])
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
            raise LearnedIkError(f"{where}: key {key!r} must hold finite numbers, not {values!r}")
    return metadata


def require_keys(metadata: dict, keys, where: str) -> None:
    """A LearnedIkError naming the first of ``keys`` that ``metadata`` lacks."""
    for key in keys:
        if key not in metadata:
            raise LearnedIkError(f"{where}: key {key!r} is missing")


def angular_joints(arm: ArmModel) -> list[bool]:
    """Whether each joint of ``arm`` is revolute (an angle) rather than prismatic."""
    return [
        arm.plant.GetJointByName(name, arm.model_instance).type_name() == "revolute"
        for name in arm.joint_names
    ]


def pose_features(X: RigidTransform) -> np.ndarray:
    """(12,) :data:`ALL_FEATURES` of one pose."""
    return np.concatenate([X.translation(), X.rotation().matrix().reshape(-1)])


def pose_from_vector(xyz_rpy) -> RigidTransform:
    """The pose of ``[x, y, z, roll, pitch, yaw]`` [m, rad]."""
    values = np.asarray(xyz_rpy, dtype=float).reshape(-1)
    return RigidTransform(RollPitchYaw(values[3:6]), values[:3])


class IkModel:
    """An exported network and its metadata, run by ONNX Runtime on one thread."""

    def __init__(self, path: str | Path, *, threads: int = 1):
        require_extra("learned_ik", f"the learned IK network {path}")
        import onnxruntime

        self.path = Path(path)
        regular_file(self.path, "the network", MAX_NETWORK_BYTES)
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        try:
            self.session = onnxruntime.InferenceSession(
                str(self.path), options, providers=["CPUExecutionProvider"]
            )
        except Exception as error:  # onnxruntime raises its own Fail / InvalidProtobuf
            reason = " ".join(str(error).split())[:300]
            raise LearnedIkError(f"{self.path}: not an ONNX network ({reason})") from None
        text = self.session.get_modelmeta().custom_metadata_map.get(METADATA_KEY)
        if text is None:
            raise LearnedIkError(
                f"{self.path}: no {METADATA_KEY!r} metadata (not written by "
                "python -m armando_drake.learn ik)"
            )
        where = f"{self.path}: metadata {METADATA_KEY!r}"
        self.metadata = checked_metadata(text, where)
        require_keys(self.metadata, (*_METADATA_LISTS, "robot", "frame"), where)
        self.features = list(self.metadata["features"])
        unknown = [name for name in self.features if name not in ALL_FEATURES]
        if unknown or not self.features:
            raise LearnedIkError(f"{self.path}: unknown pose features {unknown or '[]'}")
        self._columns = np.array([ALL_FEATURES.index(name) for name in self.features])
        self.joint_names = list(self.metadata["joint_names"])
        self.lower = np.array(self.metadata["lower"], dtype=float)
        self.upper = np.array(self.metadata["upper"], dtype=float)
        self.angular = tuple(bool(a) for a in self.metadata["angular"])
        inputs, outputs = self.session.get_inputs(), self.session.get_outputs()
        if len(inputs) != 1 or not outputs:
            raise LearnedIkError(
                f"{self.path}: {len(inputs)} inputs and {len(outputs)} outputs; a network of "
                "python -m armando_drake.learn ik has one of each"
            )
        self._input = inputs[0].name
        self._output = [outputs[0].name]
        self._check_shapes()

    def _check_shapes(self) -> None:
        """One row through the network: its input takes the metadata's features, its
        output has a column per sine, cosine or length of the metadata's joints."""
        width = len(self.features)
        expected = sum(2 if a else 1 for a in self.angular)
        try:
            rows = np.zeros((1, width), dtype=np.float32)
            out = self.session.run(self._output, {self._input: rows})[0]
        except Exception as error:  # onnxruntime's InvalidArgument / Fail
            reason = " ".join(str(error).split())[:200]
            raise LearnedIkError(
                f"{self.path}: the network does not take {width} pose features "
                f"({', '.join(self.features)}) as its metadata says ({reason})"
            ) from None
        got = int(np.asarray(out).size)
        if got != expected:
            raise LearnedIkError(
                f"{self.path}: the network answers {got} numbers per pose; its metadata's "
                f"{len(self.joint_names)} joints need {expected}"
            )

    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    def predict_features(self, features: np.ndarray) -> np.ndarray:
        """(N, n) joint positions [rad or m] from (N, 12) :data:`ALL_FEATURES` rows."""
        rows = np.asarray(features, dtype=np.float32).reshape(-1, len(ALL_FEATURES))
        outputs = self.session.run(self._output, {self._input: rows[:, self._columns]})[0]
        q = decode_joints(outputs.reshape(len(rows), -1), self.angular)
        return np.clip(q, self.lower, self.upper)

    def predict(self, X_DE: RigidTransform) -> np.ndarray:
        """(n,) joint positions for the end-effector pose ``X_DE`` (in the robot's frame)."""
        return self.predict_features(pose_features(X_DE))[0]

    def make_arm(self, X_WD: RigidTransform | None = None) -> ArmModel:
        """The robot alone in a plant of its own, its base at ``X_WD``: the arm the
        refinement and the accuracy checks use."""
        return robot_arm(self.metadata, X_WD)


def robot_arm(metadata: dict, X_WD: RigidTransform | None = None) -> ArmModel:
    """The robot of a data set's (or network's) ``metadata`` alone in a plant of its own,
    its base at ``X_WD``, with the end-effector frame the metadata names."""
    robot = metadata["robot"]
    plant = MultibodyPlant(time_step=0.0)
    loaded = load_robot(
        plant,
        robot["description"],
        xacro_args=robot.get("xacro_args", {}),
        package_paths=robot.get("package_paths", []),
        X_WB=X_WD,
    )
    plant.Finalize()
    return ArmModel(
        plant=plant, end_effector_frame=metadata["frame"], model_instance=loaded.model_instance
    )


def refine(
    arm: ArmModel,
    q: np.ndarray,
    X_target: RigidTransform,
    steps: int,
    *,
    orientation_weight: float = ORIENTATION_WEIGHT,
) -> np.ndarray:
    """``q`` after up to ``steps`` Gauss-Newton steps on the pose error of ``arm``'s end
    effector to ``X_target`` (X_BE, in the arm's base frame B), clipped to the joint
    limits; the orientation rows weigh ``orientation_weight`` [m/rad]."""
    q = np.asarray(q, dtype=float).copy()
    for _ in range(steps):
        arm.set_state(q)
        X = arm.pose()
        error = np.concatenate(
            [
                orientation_weight * orientation_error(X_target.rotation(), X.rotation()),
                X_target.translation() - X.translation(),
            ]
        )
        if np.linalg.norm(error) < 1e-13:
            break
        J = arm.jacobian()
        J[:3] *= orientation_weight
        q = np.clip(q + np.linalg.lstsq(J, error, rcond=1e-10)[0], arm.lower, arm.upper)
    return q


def pose_errors(arm: ArmModel, q: np.ndarray, X_target: RigidTransform) -> tuple[float, float]:
    """([m] position error, [rad] orientation error) of ``arm`` at ``q`` to ``X_target``."""
    arm.set_state(q)
    X = arm.pose()
    position = float(np.linalg.norm(X.translation() - X_target.translation()))
    angle = float(np.linalg.norm(orientation_error(X_target.rotation(), X.rotation())))
    return position, angle


class IkNetwork(LeafSystem):
    """Joint positions for an end-effector pose, from a learned network.

    .. pydrake_system::

        name: IkNetwork
        input_ports:
        - pose
        output_ports:
        - positions

    ``pose``: the end effector's target in the world W, a vector ``[x, y, z, roll,
    pitch, yaw]`` [m, rad] (``pose_input="vector"``) or a ``RigidTransform``
    (``"rigid_transform"``). ``positions``: the joint positions [rad or m] in the
    network's joint order (``model.joint_names``).

    ``X_WD``: where the robot's frame D (its base, as the data set had it) is in W.
    ``refine_steps``: Gauss-Newton steps of :func:`refine` after the network (0: the
    network alone), on ``arm`` (an :class:`ArmModel` whose base frame is W; default:
    the robot alone at ``X_WD``). ``period`` > 0: the answer is computed every
    ``period`` seconds (and at initialization) and held as state; 0: whenever the
    output is read.
    """

    def __init__(
        self,
        model: IkModel,
        *,
        X_WD: RigidTransform | None = None,
        arm: ArmModel | None = None,
        refine_steps: int = 0,
        pose_input: str = "vector",
        period: float = 0.0,
    ):
        super().__init__()
        if pose_input not in POSE_INPUTS:
            raise LearnedIkError(f"pose_input={pose_input!r}: choose {' or '.join(POSE_INPUTS)}")
        if not (math.isfinite(period) and period >= 0):
            raise LearnedIkError(f"period={period!r} s must be >= 0")
        if refine_steps < 0:
            raise LearnedIkError(f"refine_steps={refine_steps!r} must be >= 0")
        self.model = model
        self.X_DW = (X_WD if X_WD is not None else RigidTransform()).inverse()
        self.refine_steps = int(refine_steps)
        self.arm = arm if arm is not None or not refine_steps else model.make_arm(X_WD)
        if self.arm is not None:
            missing = [name for name in model.joint_names if name not in self.arm.joint_names]
            if missing:
                raise LearnedIkError(
                    f"{model.path}: joints {missing} of the network are not joints of the arm "
                    f"({', '.join(self.arm.joint_names)})"
                )
            self._arm_index = np.array([self.arm.joint_names.index(n) for n in model.joint_names])
        if pose_input == "vector":
            self._pose = self.DeclareVectorInputPort("pose", 6)
        else:
            self._pose = self.DeclareAbstractInputPort("pose", AbstractValue.Make(RigidTransform()))
        self._vector_input = pose_input == "vector"
        n = model.num_joints
        if period > 0:
            self._state = self.DeclareDiscreteState(n)
            self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._Update)
            self.DeclareInitializationDiscreteUpdateEvent(self._Update)
            self.DeclareStateOutputPort("positions", self._state)
        else:
            self.DeclareVectorOutputPort("positions", BasicVector(n), self._Calc)

    def solve(self, X_WE: RigidTransform) -> np.ndarray:
        """The joint positions (network joint order) for the world pose ``X_WE``."""
        q = self.model.predict(self.X_DW @ X_WE)
        if self.refine_steps and self.arm is not None:
            q_arm = self.arm.default_positions()
            q_arm[self._arm_index] = q
            q_arm = refine(self.arm, q_arm, X_WE, self.refine_steps)
            q = q_arm[self._arm_index]
        return q

    def _target(self, context) -> RigidTransform:
        value = self._pose.Eval(context)
        return pose_from_vector(value) if self._vector_input else value

    def _Calc(self, context, output) -> None:
        output.SetFromVector(self.solve(self._target(context)))

    def _Update(self, context, discrete_state) -> EventStatus:
        discrete_state.set_value(self._state, self.solve(self._target(context)))
        return EventStatus.Succeeded()
