"""Seed-style targets that stay clear of the floor and of the robot itself.

The default sequencer targets are the course's seed sized to the robot's joint limits
(:func:`~armando_drake.control.sequencer.seed_targets_for`); on a robot they were not
written for, a full excursion can fold an arm into the floor or into itself.
:func:`clear_targets` checks each target, and the straight joint-space path to it from
the one before (and back to home), sampled every :data:`PATH_STEP`, with SceneGraph's
collision queries, and scales a target's excursion from home back (in
:data:`SCALE_STEP` steps) until all of that is free.

What counts as a collision: the robot's geometry against anything anchored to the world
(the floor, fixed scene objects) and against itself, except pairs across a joint (the
links on its two sides, with everything welded to them), as Drake and the importer
filter them, and pairs already in contact at home that the driven joints cannot part
(the robot against itself; a mobile base's wheels on the floor). Free objects are not
obstacles.

A home where a link the driven joints move touches the world (a gripper pointing down
into the floor) is a problem of its own: the targets then start from the pose nearest
home, towards the targets, that is clear (said in one warning), and the path from the
start pose may leave the contacts it starts in.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet, Role, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import BodyIndex

_log = logging.getLogger("armando_drake.world")

# [rad or m] the largest joint step between two checked poses of a path.
PATH_STEP = 0.05
# The scale steps tried for a target's excursion: 1.0, 0.9, ..., 0.1, then home.
SCALE_STEP = 0.1


class _Checker:
    """Collision queries on the robot at joint positions, in a scene graph context of its own."""

    def __init__(self, plant: MultibodyPlant, scene_graph: SceneGraph, instance, joint_names):
        self.plant, self.scene_graph = plant, scene_graph
        self.plant_context = plant.CreateDefaultContext()
        self.context = scene_graph.CreateDefaultContext()
        self.pose_port = scene_graph.get_source_pose_port(plant.get_source_id())
        joints = [plant.GetJointByName(name, instance) for name in joint_names]
        self.starts = [joint.position_start() for joint in joints]
        self.q = plant.GetPositions(self.plant_context)
        inspector = scene_graph.model_inspector()
        robot_bodies = [plant.get_body(i) for i in plant.GetBodyIndices(instance)]
        self.robot = set(
            inspector.GetGeometryIds(
                plant.CollectRegisteredGeometries(robot_bodies), Role.kProximity
            )
        )
        joint_indices = [joint.index() for joint in joints]
        moved = plant.GetBodiesKinematicallyAffectedBy(joint_indices)
        self.moved = set(
            inspector.GetGeometryIds(
                plant.CollectRegisteredGeometries([plant.get_body(i) for i in moved]),
                Role.kProximity,
            )
        )
        self.names = {
            geometry: plant.GetBodyFromFrameId(inspector.GetFrameId(geometry)).name()
            for geometry in inspector.GetAllGeometryIds()
            if plant.GetBodyFromFrameId(inspector.GetFrameId(geometry)) is not None
        }
        self._filter(instance, robot_bodies)

    def _filter(self, instance, robot_bodies) -> None:
        """Self-collision on, but across joints and with free bodies off; then the pairs
        in contact at home off."""
        plant = self.plant
        manager = self.scene_graph.collision_filter_manager(self.context)
        robot_set = plant.CollectRegisteredGeometries(robot_bodies)
        declaration = CollisionFilterDeclaration().AllowWithin(robot_set)
        ids = {body.index() for body in robot_bodies}

        def cluster(body):  # the robot's bodies welded to ``body``
            return [b for b in plant.GetBodiesWeldedTo(body) if b.index() in ids]

        for index in plant.GetJointIndices(instance):
            joint = plant.get_joint(index)
            sides = cluster(joint.parent_body()) + cluster(joint.child_body())
            declaration.ExcludeWithin(plant.CollectRegisteredGeometries(sides))
        anchored = {b.index() for b in plant.GetBodiesWeldedTo(plant.world_body())}
        bodies = [plant.get_body(BodyIndex(i)) for i in range(plant.num_bodies())]
        free = [
            body
            for body in bodies
            if body.model_instance() != instance and body.index() not in anchored
        ]
        if free:
            declaration.ExcludeBetween(robot_set, plant.CollectRegisteredGeometries(free))
        manager.Apply(declaration)
        home = CollisionFilterDeclaration()
        self.home_contacts = []  # a moved link against the world, at home
        for a, b in self.pairs(None):
            if (a in self.moved) != (b in self.moved) and not ({a, b} <= self.robot):
                self.home_contacts.append((a, b))
                continue
            home.ExcludeBetween(GeometrySet(a), GeometrySet(b))
        manager.Apply(home)

    def _query(self, positions):
        if positions is not None:
            self.q[self.starts] = positions
        self.plant.SetPositions(self.plant_context, self.q)
        poses = self.plant.get_geometry_pose_output_port().Eval(self.plant_context)
        self.pose_port.FixValue(self.context, poses)
        return self.scene_graph.get_query_output_port().Eval(self.context)

    def pairs(self, positions) -> list[tuple]:
        """The (geometry, geometry) pairs of the robot in contact at ``positions`` (None:
        the plant's default positions)."""
        query = self._query(positions)
        return [
            (p.id_A, p.id_B)
            for p in query.ComputePointPairPenetration()
            if p.id_A in self.robot or p.id_B in self.robot
        ]

    def collides(self, positions, allowed: frozenset = frozenset()) -> bool:
        """Whether the robot collides at ``positions`` (other than in the pairs
        ``allowed``)."""
        if not allowed:
            return self._query(positions).HasCollisions()
        return any(pair not in allowed for pair in self.pairs(positions))

    def describe(self, pair) -> str:
        a, b = pair
        return f"{self.names.get(a, a)} with {self.names.get(b, b)}"

    def first_contact(self, path: np.ndarray, allowed: frozenset = frozenset()) -> str:
        """'<body> with <body>' of the first colliding pose of ``path`` (other than in
        the pairs ``allowed``)."""
        for positions in path:
            found = [pair for pair in self.pairs(positions) if pair not in allowed]
            if found:
                return self.describe(found[0])
        return ""


def _path(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Poses from ``start`` to ``end`` (both included), no joint stepping more than
    :data:`PATH_STEP`."""
    count = max(1, math.ceil(float(np.max(np.abs(end - start), initial=0.0)) / PATH_STEP))
    return start + np.linspace(0.0, 1.0, count + 1)[:, None] * (end - start)


def clear_targets(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    instance,
    joint_names: Sequence[str],
    targets: Sequence[Sequence[float]],
    start: Sequence[float],
    robot_name: str = "the robot",
) -> list[list[float]]:
    """``targets`` (the first one is home), each one's excursion from home scaled back
    until it, the path to it from the one before (from ``start`` for the first) and the
    path from it back home are free of collisions; logs each one scaled back."""
    try:
        checker = _Checker(plant, scene_graph, instance, joint_names)
        checker.collides(None)
    except RuntimeError as error:  # a scene whose geometry SceneGraph cannot query
        _log.info("seed targets of %s not checked for collisions: %s", robot_name, error)
        return [list(map(float, target)) for target in targets]
    targets_ = np.asarray(targets, dtype=float)
    home = targets_[0]
    previous = np.asarray(start, dtype=float)
    # The contacts the start pose is in, which the path from it may leave.
    allowed = frozenset(checker.pairs(previous))
    if checker.home_contacts:
        clear = _clear_home(checker, targets_)
        where = checker.describe(checker.home_contacts[0])
        if clear is None:
            _log.warning(
                "home of %s touches the world (%s) and no pose towards its seed targets "
                "is clear: the targets are not checked",
                robot_name,
                where,
            )
            return [list(map(float, target)) for target in targets]
        _log.warning(
            "home of %s touches the world (%s): its seed targets start from the nearest "
            "clear pose towards them instead, %s",
            robot_name,
            where,
            [round(float(v), 3) for v in clear],
        )
        targets_ = np.array([clear if np.array_equal(t, home) else t for t in targets_])
        home = clear
    result = []
    scales = [1.0 - k * SCALE_STEP for k in range(round(1 / SCALE_STEP))] + [0.0]
    for k, target in enumerate(targets_):
        chosen, blocked = target, ""
        for scale in scales:
            candidate = home + scale * (target - home)
            lead = _path(previous, candidate)
            if not (
                any(checker.collides(q, allowed) for q in lead)
                or any(checker.collides(q) for q in _path(candidate, home))
            ):
                chosen = candidate
                break
            if scale == 1.0:
                blocked = checker.first_contact(lead, allowed) or checker.first_contact(
                    _path(candidate, home)
                )
        else:
            chosen = home
            scale = 0.0
        if scale < 1.0:
            _log.warning(
                "seed target %d of %s scaled back to %d %% of its excursion from home: the "
                "full one collides (%s): %s",
                k,
                robot_name,
                round(100 * scale),
                blocked or "on the way",
                [round(float(v), 3) for v in chosen],
            )
        result.append([float(v) for v in chosen])
        previous = chosen
        allowed = frozenset()
    return result


def _clear_home(checker: _Checker, targets: np.ndarray) -> np.ndarray | None:
    """The pose nearest home (``targets[0]``) on the way to one of the other targets, in
    steps of :data:`SCALE_STEP` of the way, that is free of collisions; None if none is."""
    home = targets[0]
    for k in range(1, round(1 / SCALE_STEP) + 1):
        scale = k * SCALE_STEP
        for target in targets[1:]:
            candidate = home + scale * (target - home)
            if np.any(target != home) and not checker.collides(candidate):
                return candidate
    return None
