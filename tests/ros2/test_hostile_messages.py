"""Hostile messages over DDS on loopback: NaN, inf and 1e308 in every field of
/goal_pose, /cmd_vel and the learned IK node's target_pose. The world keeps running and
exits 0, the plant state and the logs stay finite, each refused message is counted in
summary.json's ``rejected_messages``; a cmd_vel of 1e308 is clamped to what the wheels
can give."""

import json
import math
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from ros2_support import new_domain_id, python, subprocess_env

from armando_drake import MODELS_DIR

pytest.importorskip("cyclonedds")

HOSTILE = (math.nan, math.inf, 1e308)


def _poses(good: dict) -> list[dict]:
    """``good`` (a geometry_msgs/Pose dictionary) with each field in turn NaN, inf, 1e308."""
    poses = []
    for part in ("position", "orientation"):
        for axis in good[part]:
            for value in HOSTILE:
                pose = {k: dict(v) for k, v in good.items()}
                pose[part][axis] = value
                poses.append(pose)
    return poses


def _twists() -> list[tuple[dict, bool]]:
    """(a geometry_msgs/Twist with one field NaN, inf or 1e308, whether it is refused)."""
    twists = []
    for part in ("linear", "angular"):
        for axis in "xyz":
            for value in HOSTILE:
                twist = {p: {a: 0.0 for a in "xyz"} for p in ("linear", "angular")}
                twist[part][axis] = value
                twists.append((twist, not math.isfinite(value)))
    return twists


class _World:
    """``python -m armando_drake.world`` with --ros2 on its own domain, in a subprocess."""

    def __init__(self, scenario: str, output: Path, duration: float, *settings: str):
        self.domain_id = new_domain_id()
        self.output = output
        sets = [f"ros2: {{domain_id: {self.domain_id}}}", "logging: {console_rate: 0}", *settings]
        command = [python(), "-m", "armando_drake.world", "--scenario", scenario, "--ros2",
                   "--no-meshcat", "--exit-when-done", "--duration", str(duration),
                   "--output", str(output)]  # fmt: skip
        for setting in sets:
            command += ["--set", setting]
        self.process = subprocess.Popen(
            command,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=subprocess_env(),
        )

    def finish(self) -> tuple[int, str, dict]:
        output, _ = self.process.communicate(timeout=300)
        summary_file = self.output / "summary.json"
        summary = json.loads(summary_file.read_text()) if summary_file.is_file() else {}
        return self.process.returncode, output, summary


def _send(node, world: _World, topic: str, type_name: str, messages) -> None:
    """Publishes ``messages`` on ``topic`` once the running world subscribes it."""
    node.advertise(topic, type_name)
    writer = node.writer(topic)
    deadline = time.monotonic() + 180
    while writer.get_publication_matched_status().current_count == 0:
        assert world.process.poll() is None, world.process.communicate()[0]
        assert time.monotonic() < deadline, f"the world's {topic} subscription was not found"
        time.sleep(0.05)
    time.sleep(0.5)  # the world is stepping
    for message in messages:
        node.publish(topic, type_name, message)
        time.sleep(0.01)


def _base_rows(folder: Path) -> np.ndarray:
    """base.csv's rows but the commanded twist (NaN without a twist sequence)."""
    rows = np.genfromtxt(folder / "base.csv", delimiter=",", names=True)
    return np.array([rows[n] for n in rows.dtype.names if not n.startswith("cmd_")]).T


def test_hostile_goal_poses_and_twists_are_refused_and_the_worlds_run_on(tmp_path):
    from armando_drake.ros2.dds import DdsNode

    goals = _World("fra2mo_goals", tmp_path / "goals", 6.0)
    twists = _World("fra2mo", tmp_path / "twist", 6.0, "twist: null")
    good_pose = {"position": {"x": 0.7, "y": -0.6, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}  # fmt: skip
    poses = _poses(good_pose)
    hostile_twists = _twists()
    nodes = [DdsNode(domain_id=goals.domain_id), DdsNode(domain_id=twists.domain_id)]
    try:
        header = {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "map"}
        _send(nodes[0], goals, "/goal_pose", "geometry_msgs/msg/PoseStamped",
              [{"header": header, "pose": pose} for pose in poses])  # fmt: skip
        _send(nodes[1], twists, "/cmd_vel", "geometry_msgs/msg/Twist",
              [twist for twist, _ in hostile_twists])  # fmt: skip
        results = [goals.finish(), twists.finish()]
    finally:
        for node in nodes:
            node.close()
        for world in (goals, twists):
            if world.process.poll() is None:
                world.process.kill()
    for code, output, summary in results:
        assert code == 0, output
        assert "Traceback" not in output, output
        base = summary["base"]
        assert all(math.isfinite(v) for v in base["final_pose"].values()), base
        assert summary["sim_time"] == pytest.approx(6.0, abs=0.01)
    (_, goal_output, goal_summary), (_, twist_output, twist_summary) = results
    # Every hostile goal refused, each with a logged reason (the first few) and counted.
    assert goal_summary["rejected_messages"] == {"/goal_pose": len(poses)}, goal_output
    assert "pose.position.x=nan is not finite" in goal_output
    assert "pose.position.x=1e+308 is out of range" in goal_output
    assert [g["name"] for g in goal_summary["navigation"]["goals"]][0] == "north_east"
    assert "goal_pose" not in [g["name"] for g in goal_summary["navigation"]["goals"]]
    # NaN and inf twists refused; 1e308 clamped to the wheels' limits, never NaN.
    refused = sum(1 for _, bad in hostile_twists if bad)
    assert twist_summary["rejected_messages"] == {"/cmd_vel": refused}, twist_output
    for folder in (tmp_path / "goals", tmp_path / "twist"):
        rows = _base_rows(folder)
        assert len(rows) > 100 and np.isfinite(rows).all(), folder
    # The 1e308 turn clamped to the wheels' limits: a finite, bounded spin.
    assert np.abs(_base_rows(tmp_path / "twist")[:, 11:13]).max() < 100.0  # linear, angular


def test_hostile_target_poses_are_refused_by_the_ik_node():
    pytest.importorskip("onnxruntime")
    from armando_drake.ros2.dds import DdsNode
    from armando_drake.ros2.ik_node import JOINT_STATE, POSE, LearnedIkNode

    network = MODELS_DIR / "learned_ik" / "armando_ik_network.onnx"
    domain_id = new_domain_id()
    ik = LearnedIkNode(network, domain_id=domain_id)
    client = DdsNode(domain_id=domain_id)
    answers: list[dict] = []
    good = {"position": {"x": 0.1, "y": 0.1, "z": 0.25},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}  # fmt: skip
    poses = _poses(good)
    try:
        client.subscribe("/ik_solution", JOINT_STATE, answers.append)
        client.advertise("/target_pose", POSE)
        writer = client.writer("/target_pose")
        deadline = time.monotonic() + 10
        while writer.get_publication_matched_status().current_count == 0:
            assert time.monotonic() < deadline, "the node's subscription was not found"
            time.sleep(0.02)
        for pose in [*poses, good]:
            client.publish("/target_pose", POSE, pose)
        deadline = time.monotonic() + 10
        while not answers and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.2)
    finally:
        client.close()
        ik.close()
    assert ik.rejections.counts == {"target_pose": len(poses)}
    assert ik.solved == 1 and len(answers) == 1
    assert all(math.isfinite(v) for v in answers[0]["position"])
