"""A navigation's topics: what Nav2's servers and the course's launch files publish.

==================== ================================= =======================================
topic                type                              from
==================== ================================= =======================================
``/map``             ``nav_msgs/msg/OccupancyGrid``    the navigation's map, once (latched, as
                                                       map_server)
``/plan``            ``nav_msgs/msg/Path``             each new global plan (planner server)
``/tf_static``       ``tf2_msgs/msg/TFMessage``        ``map -> <goal name>`` for every goal,
                                                       as static_transform_publisher
``/tf``              ``tf2_msgs/msg/TFMessage``        ``map -> odom``: AMCL's estimate, or
                                                       the identity (ground truth)
==================== ================================= =======================================

(The ArUco marker on the map, ``map -> aruco_frame``, is the detectors' row:
:mod:`armando_drake.vision.topics`.)

:class:`NavigationTopics` reads the navigator's state at the controller manager's rate and
hands each new message to ``send(topic, type_name, message, stamp)``: the MCAP recorder's
``write`` or the live bridge's publish. ``map -> odom`` goes with each new odometry stamp.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import LeafSystem

from armando_drake.messages.definitions import (
    header,
    pose_stamped_message,
    seconds,
    transform_stamped,
)
from armando_drake.messages.publications import SUBSCRIBE, Send, Topic
from armando_drake.messages.types import Odometry
from armando_drake.navigation.config import NavigationGoal
from armando_drake.navigation.navigator import FramedGoal, NavState
from armando_drake.tools.rejections import RejectedMessage, require_finite, require_within

MAP_FRAME = "map"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"


def planar(x: float, y: float, yaw: float) -> RigidTransform:
    return RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0.0])


def occupancy_grid_message(grid, stamp: float, frame_id: str = MAP_FRAME) -> dict:
    """nav_msgs/OccupancyGrid of an :class:`~armando_drake.navigation.maps.OccupancyMap`
    (row-major from the cell at ``origin``, as map_server publishes it)."""
    origin = pose_stamped_message(stamp, frame_id, planar(*grid.origin))["pose"]
    return {
        "header": header(stamp, frame_id),
        "info": {
            "map_load_time": header(stamp)["stamp"],
            "resolution": float(grid.resolution),
            "width": grid.width,
            "height": grid.height,
            "origin": origin,
        },
        "data": np.asarray(grid.data, dtype=np.int8).ravel().tolist(),
    }


def path_message(path: np.ndarray, goal_yaw: float, stamp: float, frame_id: str = MAP_FRAME):
    """nav_msgs/Path of a plan ((n, 2) points): each pose heading to the next, the last
    the goal's heading."""
    path = np.asarray(path, dtype=float)
    steps = np.diff(path, axis=0)
    yaws = [*np.arctan2(steps[:, 1], steps[:, 0]), goal_yaw]
    return {
        "header": header(stamp, frame_id),
        "poses": [
            pose_stamped_message(stamp, frame_id, planar(x, y, yaw))
            for (x, y), yaw in zip(path, yaws, strict=True)
        ],
    }


def goal_frames(goals, stamp: float, frame_id: str = MAP_FRAME, prefix: str = "") -> dict:
    """tf2_msgs/TFMessage ``map -> <prefix><goal name>`` of each goal."""
    return {
        "transforms": [
            transform_stamped(
                stamp, frame_id, f"{prefix}{goal.name}", planar(goal.x, goal.y, goal.yaw)
            )
            for goal in goals
        ]
    }


class NavigationTopics(LeafSystem):
    """Sends a navigation's /map, /plan, goal frames and map -> odom. ``space``: the
    robot's namespace in a world of several: its ``/<space>/map`` and ``/<space>/plan``,
    its frames ``<space>/odom``, ``<space>/<goal>`` (``map`` and /tf are shared).

    Ports:
      - input ``nav_state`` (the Navigator's :class:`NavState`);
      - input ``odom`` (the drive's Odometry): map -> odom at each new stamp;
      - input ``map_to_odom`` (x, y, yaw; AMCL's), unconnected: the identity.
    """

    def __init__(self, grid, *, send: Send, rate: float, space: str = ""):
        super().__init__()
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate={rate!r} must be positive [Hz]")
        self._grid = grid
        self._send = send
        self._prefix = f"{space}/" if space else ""  # of its topics and frames
        self._nav = self.DeclareAbstractInputPort("nav_state", AbstractValue.Make(NavState()))
        self._odom = self.DeclareAbstractInputPort("odom", AbstractValue.Make(Odometry()))
        self._map_to_odom = self.DeclareVectorInputPort("map_to_odom", 3)
        self._planned_at = None
        self._goals: tuple = ()
        self._last_odom: float | None = None
        self.DeclareInitializationPublishEvent(self._PublishMap)
        self.DeclarePeriodicPublishEvent(1.0 / rate, 0.0, self._Publish)

    def _PublishMap(self, context, event=None) -> None:
        stamp = context.get_time()
        message = occupancy_grid_message(self._grid, stamp)
        self._send(f"/{self._prefix}map", "nav_msgs/msg/OccupancyGrid", message, stamp)
        self._PublishGoals(context)

    def _PublishGoals(self, context) -> None:
        nav = self._nav.Eval(context)
        if nav.goals and nav.goals != self._goals:
            new = [goal for goal in nav.goals if goal not in self._goals]
            self._goals = nav.goals
            stamp = context.get_time()
            frames = goal_frames(new, stamp, prefix=self._prefix)
            self._send("/tf_static", TF_MESSAGE, frames, stamp)

    def _Publish(self, context) -> None:
        self._PublishGoals(context)
        nav = self._nav.Eval(context)
        if nav.path is not None and nav.planned_at != self._planned_at:
            self._planned_at = nav.planned_at
            goal = nav.goals[nav.goal]
            message = path_message(nav.path, goal.yaw, nav.planned_at)
            self._send(f"/{self._prefix}plan", "nav_msgs/msg/Path", message, nav.planned_at)
        if not self._odom.HasValue(context):
            return
        odom = self._odom.Eval(context)
        if odom.stamp > 0 and odom.stamp != self._last_odom:
            self._last_odom = odom.stamp
            estimate = (
                self._map_to_odom.Eval(context)
                if self._map_to_odom.HasValue(context)
                else (0.0, 0.0, 0.0)
            )
            X = planar(*estimate)
            child = f"{self._prefix}{odom.frame_id}"
            tf = {"transforms": [transform_stamped(odom.stamp, MAP_FRAME, child, X)]}
            self._send("/tf", TF_MESSAGE, tf, odom.stamp)


def AddNavigationTopics(builder, source: NavigationSource, send: Send, *, name: str):
    """A :class:`NavigationTopics` on ``source``'s navigation."""
    navigation, stack = source.navigation, source.stack
    space = stack.namespace.strip("/")
    system = builder.AddNamedSystem(
        name, NavigationTopics(navigation.grid, send=send, rate=stack.update_rate, space=space)
    )
    navigator = navigation.navigator
    builder.Connect(navigator.GetOutputPort("nav_state"), system.GetInputPort("nav_state"))
    odom = stack.manager.GetOutputPort(f"{navigation.drive}.odom")
    builder.Connect(odom, system.GetInputPort("odom"))
    if navigation.amcl is not None:
        builder.Connect(
            navigation.amcl.GetOutputPort("map_to_odom"), system.GetInputPort("map_to_odom")
        )
    return system


# [m] the largest goal coordinate taken from /goal_pose (a larger one is a garbled message).
GOAL_RANGE = 1e6


def goal_pose_of(message: Any) -> FramedGoal:
    """The navigation goal of a received geometry_msgs/PoseStamped (RViz's 2D goal), in
    its header's frame (map when none) at its header's stamp (0 when none: the latest);
    :class:`~armando_drake.tools.rejections.RejectedMessage` for a position that is not
    finite or beyond GOAL_RANGE, an orientation that is not finite or a zero quaternion."""
    pose = message["pose"]
    p, q = pose["position"], pose["orientation"]
    require_within(((f"pose.position.{k}", p[k]) for k in "xyz"), GOAL_RANGE, " m")
    require_finite((f"pose.orientation.{k}", q[k]) for k in "xyzw")
    qx, qy, qz, qw = (float(q[k]) for k in "xyzw")
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not (math.isfinite(norm) and norm > 0.0):
        raise RejectedMessage(f"pose.orientation=({qx}, {qy}, {qz}, {qw}) is not a rotation")
    if abs(norm - 1.0) > 1e-9:
        qx, qy, qz, qw = (v / norm for v in (qx, qy, qz, qw))
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy**2 + qz**2))
    goal = NavigationGoal(name="goal_pose", x=float(p["x"]), y=float(p["y"]), yaw=yaw)
    head = message.get("header") or {}
    frame_id = str(head.get("frame_id", "") or "map")
    stamp = seconds(head["stamp"]) if head.get("stamp") is not None else 0.0
    require_finite([("header.stamp", stamp)])
    return FramedGoal(goal, frame_id, stamp)  # the navigator takes it to the map at its stamp


@dataclass(frozen=True, eq=False)
class NavigationSource:
    """The :class:`NavigationTopics` of a robot's ``navigation`` (a Navigation), on the
    controllers of ``stack`` (a ControlStack): a
    :class:`~armando_drake.messages.publications.TopicSource`. In a world of several
    robots its topics are under the robot's namespace."""

    stack: Any
    navigation: Any

    def table(self) -> list[Topic]:
        """Its topics, and the subscription of RViz's 2D goal ``/goal_pose`` (it preempts
        the goals as NavigateToPose would)."""
        rate = self.stack.update_rate
        space = self.stack.namespace.strip("/")
        mine = f"/{space}" if space else ""  # its topics, under its namespace
        navigator = self.navigation.navigator
        return [
            Topic(f"{mine}/map", "nav_msgs/msg/OccupancyGrid", source=self,
                  frame_id=MAP_FRAME, qos="latched"),
            Topic("/tf_static", TF_MESSAGE, source=self, qos="latched"),
            Topic(f"{mine}/plan", "nav_msgs/msg/Path", source=self, rate=rate,
                  frame_id=MAP_FRAME),
            Topic("/tf", TF_MESSAGE, source=self, rate=rate),
            Topic("/goal_pose", "geometry_msgs/msg/PoseStamped", SUBSCRIBE,
                  port=navigator.GetInputPort("goal_pose"), receive=goal_pose_of,
                  frame_id=MAP_FRAME, namespace=space, key="navigator.goal_pose",
                  recorded=False),
        ]  # fmt: skip

    def attach(self, builder, send: Send, consumer: str) -> NavigationTopics | None:
        space = self.stack.namespace.strip("/")
        name = f"{space}/navigation_{consumer}" if space else f"navigation_{consumer}"
        return AddNavigationTopics(builder, self, send, name=name)
