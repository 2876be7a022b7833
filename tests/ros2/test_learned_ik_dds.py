"""The learned IK's DDS node: a participant of the test sends end-effector poses on
target_pose (geometry_msgs/Pose) and reads each joint solution on ik_solution
(sensor_msgs/JointState); the solution's forward kinematics is within 5 mm."""

import time

import numpy as np
import pytest
from ros2_support import new_domain_id

from armando_drake import MODELS_DIR

pytest.importorskip("cyclonedds")
pytest.importorskip("onnxruntime")

NETWORK = MODELS_DIR / "learned_ik" / "armando_ik_network.onnx"
# [rad] j0..j3 of reachable poses (their forward kinematics are the targets sent)
JOINTS = [[0.4, 0.5, 0.8, 0.3], [-0.6, 0.3, 1.0, -0.4], [1.2, -0.4, 0.6, 0.5]]


def test_each_pose_sent_is_answered_within_5_mm():
    from armando_drake.learning.network import IkModel
    from armando_drake.ros2.dds import DdsNode
    from armando_drake.ros2.ik_node import JOINT_STATE, POSE, LearnedIkNode

    domain_id = new_domain_id()
    ik = LearnedIkNode(NETWORK, domain_id=domain_id, namespace="/armando")
    arm = IkModel(NETWORK).make_arm()  # the test's own forward kinematics
    client = DdsNode(domain_id=domain_id)
    answers: list[dict] = []
    try:
        client.subscribe("/armando/ik_solution", JOINT_STATE, answers.append)
        client.advertise("/armando/target_pose", POSE)
        writer = client.writer("/armando/target_pose")
        deadline = time.monotonic() + 10
        while writer.get_publication_matched_status().current_count == 0:
            assert time.monotonic() < deadline, "the node's subscription was not found"
            time.sleep(0.02)
        targets = []
        for q in JOINTS:
            arm.set_state(np.array(q))
            X = arm.pose()
            targets.append(X)
            w, x, y, z = X.rotation().ToQuaternion().wxyz()
            p = X.translation()
            pose = {
                "position": {"x": p[0], "y": p[1], "z": p[2]},
                "orientation": {"x": x, "y": y, "z": z, "w": w},
            }
            count = len(answers)
            client.publish("/armando/target_pose", POSE, pose)
            deadline = time.monotonic() + 10
            while len(answers) == count:
                assert time.monotonic() < deadline, "no answer on /armando/ik_solution"
                time.sleep(0.01)
    finally:
        client.close()
        ik.close()
    assert len(answers) == len(JOINTS) and ik.solved == len(JOINTS)
    for answer, X in zip(answers, targets, strict=True):
        assert list(answer["name"]) == ["j0", "j1", "j2", "j3"]
        arm.set_state(np.array(answer["position"]))
        error = np.linalg.norm(arm.pose().translation() - X.translation())
        assert error < 0.005, (error, answer["position"])


def test_a_pose_without_a_quaternion_is_not_answered():
    from armando_drake.ros2.ik_node import pose_of

    zero = {"position": {"x": 0, "y": 0, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 0}}
    assert pose_of(zero) is None
    half = {"position": {"x": 1, "y": 2, "z": 3}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 2}}
    assert np.allclose(pose_of(half).GetAsMatrix4()[:3, 3], [1, 2, 3])
