"""The learned IK as a DDS node: a pose in, the joint solution out.

:class:`LearnedIkNode` is one DDS participant (:class:`~armando_drake.ros2.dds.DdsNode`,
a ROS 2 node on the wire) that subscribes ``target_pose`` (``geometry_msgs/msg/Pose``,
the end effector's pose in the robot's base frame, as the network's data set had it)
and answers each pose on ``ik_solution`` (``sensor_msgs/msg/JointState``: the network's
joint names and positions), as a ROS 2 IK node does. The answer is the network's
(:class:`~armando_drake.learning.network.IkModel`), then ``refine_steps`` Gauss-Newton
steps on the robot's forward kinematics (as the world's learned IK runs it). Both
topics are in the node's namespace.

A ROS 2 node sends it a pose with::

    ros2 topic pub --once /target_pose geometry_msgs/msg/Pose \
      "{position: {x: 0.1, y: 0.1, z: 0.25}, orientation: {w: 1.0}}"
"""

from __future__ import annotations

import logging
import math
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix

from armando_drake.learning.network import IkModel, pose_errors, refine
from armando_drake.messages.definitions import header
from armando_drake.ros2.dds import DdsNode
from armando_drake.tools.rejections import RejectedMessage, Rejections, require_within

_log = logging.getLogger("armando_drake.ros2")

POSE = "geometry_msgs/msg/Pose"
JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_TOPIC = "target_pose"
SOLUTION_TOPIC = "ik_solution"


# [m] the largest target coordinate taken (a larger one is a garbled message).
POSE_RANGE = 1e3


def pose_of(message: dict[str, Any]) -> RigidTransform | None:
    """The RigidTransform of a ``geometry_msgs/Pose`` message; None for a quaternion
    that is not one (zero or not finite);
    :class:`~armando_drake.tools.rejections.RejectedMessage` for a position that is not
    finite or beyond POSE_RANGE."""
    p, o = message["position"], message["orientation"]
    require_within(((f"position.{k}", p[k]) for k in "xyz"), POSE_RANGE, " m")
    wxyz = np.array([o["w"], o["x"], o["y"], o["z"]], dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):  # 1e308: no rotation, not a warning
        norm = float(np.linalg.norm(wxyz))
    if not math.isfinite(norm) or norm < 1e-9:
        return None
    rotation = RotationMatrix(Quaternion(wxyz / norm))
    return RigidTransform(rotation, [float(p["x"]), float(p["y"]), float(p["z"])])


class LearnedIkNode:
    """Answers each ``target_pose`` on ``ik_solution`` with the learned IK's joints.

    ``network``: the ONNX file of ``python -m armando_drake.learn ik``. ``solved``
    counts the answers; ``last``: the last (pose, joint positions, position error [m]);
    ``rejections``: the poses dropped (not finite, out of range, no rotation), each with
    one log line.
    """

    def __init__(
        self,
        network: str | Path,
        *,
        domain_id: int = 0,
        namespace: str = "",
        interface: str = "",
        refine_steps: int = 3,
    ):
        self.model = IkModel(network)
        self.arm = self.model.make_arm()
        self.refine_steps = refine_steps
        self.solved = 0
        self.rejections = Rejections("learned IK node")
        self.last: tuple[RigidTransform, np.ndarray, float] | None = None
        self._lock = threading.Lock()
        self._start = time.monotonic()
        self.node = DdsNode(domain_id=domain_id, namespace=namespace, interface=interface)
        self.node.advertise(SOLUTION_TOPIC, JOINT_STATE)
        self.node.subscribe(POSE_TOPIC, POSE, self._on_pose)
        _log.info(
            "learned IK node: %s on %s -> %s (%s)",
            network,
            self.node.resolve(POSE_TOPIC),
            self.node.resolve(SOLUTION_TOPIC),
            ", ".join(self.model.joint_names),
        )

    def solve(self, X_DE: RigidTransform) -> np.ndarray:
        """The joint positions for the end-effector pose ``X_DE`` (in the base frame)."""
        q = self.model.predict(X_DE)
        return refine(self.arm, q, X_DE, self.refine_steps)

    def _on_pose(self, message: dict[str, Any]) -> None:
        try:
            X_DE = pose_of(message)
        except (RejectedMessage, KeyError, TypeError, ValueError) as error:
            self.rejections.reject(POSE_TOPIC, str(error))
            return
        if X_DE is None:
            self.rejections.reject(POSE_TOPIC, "the orientation is no quaternion")
            return
        with self._lock:  # the arm's context is shared
            q = self.solve(X_DE)
            finite = bool(np.all(np.isfinite(q)))
            if finite:
                error, _ = pose_errors(self.arm, q, X_DE)
                self.last = (X_DE, q, error)
                self.solved += 1
        if not finite:
            self.rejections.reject(POSE_TOPIC, "the learned IK gave no finite solution")
            return
        answer = {
            "header": header(time.monotonic() - self._start),
            "name": list(self.model.joint_names),
            "position": [float(v) for v in q],
            "velocity": [],
            "effort": [],
        }
        self.node.publish(SOLUTION_TOPIC, JOINT_STATE, answer)

    def close(self) -> None:
        self.node.close()
