"""The seed targets a robot gets, checked from its home pose and from target to target
along the whole path (control/clearance.py), on arms written for these tests."""

import logging
import math
import sys
from pathlib import Path

import numpy as np
from pydrake.geometry import Box
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, CoulombFriction
from pydrake.systems.framework import DiagramBuilder

from armando_drake.control.clearance import clear_targets
from armando_drake.control.sequencer import seed_targets_for
from armando_drake.description.loader import load_robot
from armando_drake.sensors.objects import AddGround

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "description"))
from fixture_packages import chain_urdf  # noqa: E402


def flat_arm(tmp_path, pitch: float) -> Path:
    """A 1 m arm on a 25 cm post: joint_1 yaws, joint_2 pitches link_2, which at home
    points ``pitch`` [rad] below the horizontal (its tip 1 m out, 0.3 m up when level)."""
    arm = chain_urdf(
        "flat", width=0.06, lengths=[0.05, 1.0], masses=[1.0, 2.0], efforts=[200, 200],
        base=(0.04, 0.25, 3.0), axes=("0 0 1", "0 1 0"),
    )  # fmt: skip
    tilted = f'<origin xyz="0 0 0.05" rpy="0 {math.pi / 2 + pitch!r} 0"/>'
    path = tmp_path / "flat.urdf"
    path.write_text(arm.replace('<origin xyz="0 0 0.05"/>', tilted))
    return path


def checked(urdf, targets, obstacle: RigidTransform | None = None):
    """clear_targets on the arm in a world with the ground (and a 10 cm box at
    ``obstacle``), from home."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    robot = load_robot(plant, urdf)
    AddGround(plant, scene_graph)
    if obstacle is not None:
        box = Box(0.1, 0.1, 0.1)
        plant.RegisterCollisionGeometry(
            plant.world_body(), obstacle, box, "obstacle", CoulombFriction(1.0, 1.0)
        )
    plant.Finalize()
    builder.Build()
    names = ["joint_1", "joint_2"]
    return clear_targets(
        plant, scene_graph, robot.model_instance, names, targets, [0.0, 0.0], "flat"
    )


def test_a_home_pose_in_ground_contact_moves_the_targets_to_a_clear_pose(tmp_path, caplog):
    # link_2 points 0.5 rad below the horizontal: its tip is 0.18 m into the floor at home.
    urdf = flat_arm(tmp_path, pitch=0.5)
    seed = seed_targets_for([-2.9, -2.9], [2.9, 2.9])
    with caplog.at_level(logging.WARNING, logger="armando_drake.world"):
        targets = checked(urdf, seed)
    homes = [r.getMessage() for r in caplog.records if "home of flat" in r.getMessage()]
    assert len(homes) == 1, homes
    assert "touches the world (link_2 with ground" in homes[0] or "ground with link_2" in (homes[0])
    # The targets start and end at a pose that lifts link_2 clear of the floor (a
    # negative joint_2 raises the tip), and none of them is in the floor.
    assert targets[0] == targets[-1] and targets[0] != seed[0]
    assert targets[0][1] < 0
    assert all(1.0 * math.sin(0.5 + t[1]) < 0.3 - 0.03 for t in targets)


def test_a_target_whose_path_from_the_one_before_is_blocked_is_changed(tmp_path, caplog):
    # Two targets at yaw 1.2 rad, 0.2 rad below and above level: each is clear, and so
    # is the way back home, but the path between them sweeps the tip through a box.
    urdf = flat_arm(tmp_path, pitch=0.0)
    tip = 0.9 * np.array([math.cos(1.2), math.sin(1.2)])
    box = RigidTransform([tip[0], tip[1], 0.3])
    targets = [[0.0, 0.0], [1.2, -0.2], [1.2, 0.2], [0.0, 0.0]]
    with caplog.at_level(logging.WARNING, logger="armando_drake.world"):
        assert checked(urdf, targets[:2], box) == targets[:2]  # each alone is clear
        result = checked(urdf, targets, box)
    scaled = [r.getMessage() for r in caplog.records if "scaled back" in r.getMessage()]
    assert len(scaled) == 1 and "seed target 2 of flat" in scaled[0], scaled
    assert "link_2 with world" in scaled[0] or "world with link_2" in scaled[0]
    assert result[:2] == targets[:2] and result[3] == targets[3]
    assert result[2] != targets[2]
