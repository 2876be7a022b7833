"""Vision-based navigation: the ArUco marker's pose on the map, and a goal in front of it.

:class:`MarkerGoal` takes each pose of the marker the ArUco detector estimates in its
camera's frame, and puts it on the map as the TF tree would: map -> base (the
navigation's localization: the ground truth's, or AMCL's map -> odom -> base) -> camera
(its mount on the robot) -> marker. Their mean (positions averaged, orientations by the
mean of their quaternions) is the marker's pose on the map (``marker_in_map``, published
as the TF frame ``aruco_frame``). Once the marker was seen ``after`` times, the goal
``distance`` in front of its face, facing it, is sent to the navigator (``goal_pose``),
preempting its task; as the robot comes nearer and the mean moves that goal by more than
1 cm or 0.01 rad, the goal is refined (``goal_update``: the same task, replanned; Nav2's
``GoalUpdater``), at most ``MAX_SENDS - 1`` times.
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import Any

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.systems.framework import EventStatus, LeafSystem

from armando_drake.messages.types import MarkerPose, PublicationValue
from armando_drake.navigation.config import NavigationGoal
from armando_drake.navigation.navigator import NavState

GOAL_NAME = "aruco_front"
MAX_SENDS = 5
MOVED = (0.01, 0.01)  # [m, rad] a goal moved by more is refined


def planar(x: float, y: float, yaw: float) -> RigidTransform:
    return RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0.0])


@dc.dataclass(frozen=True)
class MarkerEstimate:
    """The running mean of the marker's poses on the map, one per viewpoint: a detection
    from the camera pose of the previous one is the same measurement again (a rendered
    frame has no noise; PnP's error is the viewpoint's), counted but not averaged again."""

    count: int = 0
    views: int = 0  # the detections averaged
    viewpoint: tuple = ()  # the camera's pose on the map (x, y, z, qw, qx, qy, qz), last
    position_sum: tuple = (0.0, 0.0, 0.0)
    quaternion_sum: tuple = (0.0, 0.0, 0.0, 0.0)  # (w, x, y, z), signs aligned to the first
    sent: tuple = ()  # the goals sent, (x, y, yaw) each
    first_seen: float = math.nan

    def __deepcopy__(self, memo):
        return self

    def pose(self) -> RigidTransform | None:
        if not self.count:
            return None
        q = np.asarray(self.quaternion_sum) / np.linalg.norm(self.quaternion_sum)
        position = np.asarray(self.position_sum) / self.views
        return RigidTransform(Quaternion(q), position)

    def add(
        self, X_map_marker: RigidTransform, now: float, X_map_camera: RigidTransform
    ) -> MarkerEstimate:
        viewpoint = (
            *X_map_camera.translation(),
            *X_map_camera.rotation().ToQuaternion().wxyz(),
        )
        if self.viewpoint and np.allclose(viewpoint, self.viewpoint, rtol=0.0, atol=1e-4):
            return dc.replace(self, count=self.count + 1)
        q = X_map_marker.rotation().ToQuaternion().wxyz()
        if self.count and np.dot(q, self.quaternion_sum) < 0:
            q = -q
        return dc.replace(
            self,
            count=self.count + 1,
            views=self.views + 1,
            viewpoint=viewpoint,
            position_sum=tuple(np.add(self.position_sum, X_map_marker.translation())),
            quaternion_sum=tuple(np.add(self.quaternion_sum, q)),
            first_seen=now if not self.count else self.first_seen,
        )


def front_goal(X_map_marker: RigidTransform, distance: float) -> tuple[float, float, float]:
    """(x, y, yaw) ``distance`` in front of the marker's face (its z axis, on the floor's
    plane), facing it."""
    normal = X_map_marker.rotation().matrix()[:, 2]
    heading = math.atan2(normal[1], normal[0])
    p = X_map_marker.translation()
    return (
        float(p[0] + distance * math.cos(heading)),
        float(p[1] + distance * math.sin(heading)),
        math.remainder(heading + math.pi, 2 * math.pi),
    )


class MarkerGoal(LeafSystem):
    """The marker on the map, and the navigation goal in front of it.

    .. pydrake_system::

        name: MarkerGoal
        input_ports:
        - cam_T_marker
        - nav_state
        - body_poses
        output_ports:
        - marker_in_map
        - goal_pose
        - goal_update

    Runs at the camera's ``frame_rate``, just after the detector (its new detection, the
    robot where the frame was taken).
    """

    def __init__(
        self,
        *,
        frame_rate: float,
        offset: float,
        link_body_index: int,
        distance: float,
        after: int,
    ):
        super().__init__()
        self._link = int(link_body_index)
        self.distance, self.after = float(distance), int(after)
        self._detections = self.DeclareAbstractInputPort("cam_T_marker", PublicationValue())
        self._nav = self.DeclareAbstractInputPort("nav_state", AbstractValue.Make(NavState()))
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", AbstractValue.Make([RigidTransform()])
        )
        self._seen = self.DeclareDiscreteState(1)  # detections taken
        self._estimate = self.DeclareAbstractState(AbstractValue.Make(MarkerEstimate()))
        self._marker = self.DeclareAbstractState(PublicationValue())
        self._goal = self.DeclareAbstractState(PublicationValue())
        self._update = self.DeclareAbstractState(PublicationValue())
        self.DeclareStateOutputPort("marker_in_map", self._marker)
        self.DeclareStateOutputPort("goal_pose", self._goal)
        self.DeclareStateOutputPort("goal_update", self._update)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / frame_rate, offset, self._Update)

    def X_map_world(self, nav: NavState) -> RigidTransform:
        """The localization's map frame in the world: map -> base (its estimate) composed
        with base -> world (the truth), on the floor's plane."""
        if not nav.estimate or not nav.last_pose:
            return RigidTransform()
        return planar(*nav.estimate) @ planar(*nav.last_pose).inverse()

    def _Update(self, context, state) -> EventStatus:
        publication = self._detections.Eval(context)
        seen = int(context.get_discrete_state(self._seen).get_value()[0])
        if publication.count <= seen:
            return EventStatus.DidNothing()
        state.get_mutable_discrete_state(self._seen).set_value([publication.count])
        detection: MarkerPose = publication.message
        now = context.get_time()
        X_W_link = self._poses.Eval(context)[self._link]
        X_map_camera = self.X_map_world(self._nav.Eval(context)) @ X_W_link @ detection.X_LC
        X_map_marker = X_map_camera @ detection.pose
        estimate = context.get_abstract_state(self._estimate).get_value()
        estimate = estimate.add(X_map_marker, now, X_map_camera)
        mean = estimate.pose()
        marker = MarkerPose(
            stamp=now,
            frame_id="map",
            marker_id=detection.marker_id,
            pose=mean,
            link=detection.link,
            X_LC=detection.X_LC,
        )
        previous = context.get_abstract_state(self._marker).get_value()
        state.get_mutable_abstract_state(self._marker).set_value(previous.publish(marker, now))
        if self.distance > 0 and estimate.count >= self.after and len(estimate.sent) < MAX_SENDS:
            goal = front_goal(mean, self.distance)
            last = estimate.sent[-1] if estimate.sent else None
            if last is None or (
                math.hypot(goal[0] - last[0], goal[1] - last[1]) > MOVED[0]
                or abs(math.remainder(goal[2] - last[2], 2 * math.pi)) > MOVED[1]
            ):
                estimate = dc.replace(estimate, sent=(*estimate.sent, goal))
                message = NavigationGoal(name=GOAL_NAME, x=goal[0], y=goal[1], yaw=goal[2])
                port = self._goal if last is None else self._update  # new, or refined
                sent = context.get_abstract_state(port).get_value()
                task = (message,) if last is None else message
                state.get_mutable_abstract_state(port).set_value(sent.publish(task, now))
        state.get_mutable_abstract_state(self._estimate).set_value(estimate)
        return EventStatus.Succeeded()

    def summary(self, context) -> dict[str, Any] | None:
        """summary.json's ``aruco``: the marker's pose on the map, the goals sent."""
        estimate = context.get_abstract_state(self._estimate).get_value()
        pose = estimate.pose()
        if pose is None:
            return {"detections": 0, "pose": None, "goals_sent": []}
        rpy = RollPitchYaw(pose.rotation()).vector()
        return {
            "detections": estimate.count,
            "first_seen": estimate.first_seen,
            "frame": "aruco_frame",
            "position": [float(v) for v in pose.translation()],
            "rpy": [float(v) for v in rpy],
            "distance": self.distance,
            "goals_sent": [list(goal) for goal in estimate.sent],
        }


def AddMarkerGoal(builder, detector, *, navigation, plant, link_body, rate, offset, config):
    """A :class:`MarkerGoal` on ``detector``'s detections (at ``rate``, ``offset`` after
    the frames), sending ``navigation``'s navigator to ``config.approach_distance`` in
    front of the marker."""
    system = builder.AddNamedSystem(
        "marker_goal",
        MarkerGoal(
            frame_rate=rate,
            offset=offset,
            link_body_index=int(link_body.index()),
            distance=config.approach_distance,
            after=config.approach_after,
        ),
    )
    builder.Connect(detector.GetOutputPort("cam_T_marker"), system.GetInputPort("cam_T_marker"))
    builder.Connect(plant.get_body_poses_output_port(), system.GetInputPort("body_poses"))
    navigator = navigation.navigator
    builder.Connect(navigator.GetOutputPort("nav_state"), system.GetInputPort("nav_state"))
    if config.approach_distance > 0:
        builder.Connect(system.GetOutputPort("goal_pose"), navigator.GetInputPort("goal_pose"))
        builder.Connect(system.GetOutputPort("goal_update"), navigator.GetInputPort("goal_update"))
    return system
