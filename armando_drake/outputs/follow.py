"""The Meshcat camera following a mobile robot, as RViz's or Gazebo's "follow" views do.

:class:`FollowCamera` keeps the offset from the camera to its target that the first
framing gave (the arena, the robot and its goals in view: :mod:`armando_drake.outputs.view`)
and moves both with the mobile bases: the target goes towards the bases' centre with a
first-order lag of :data:`TIME_CONSTANT` (a smooth pan, not a jerk at each step), redrawn
:data:`RATE` times a simulated second. The viewer's *Follow the robot* button (key ``f``)
switches it off and on again; while off the camera is the user's.

It reads only its own input port (the plant's body poses) and writes only the camera: no
Python runs at the plant's steps.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform
from pydrake.systems.framework import LeafSystem

from armando_drake.description.framing import FIELD_OF_VIEW, view_axes

RATE = 10.0  # [Hz] of the camera's moves
TIME_CONSTANT = 0.5  # [s] of the target's lag behind the bases
BUTTON = "Follow the robot"
KEY = "KeyF"


def in_view(point, camera, target, *, field_of_view: float = FIELD_OF_VIEW, aspect=1.0) -> bool:
    """Whether ``point`` [m] lies inside the view of a camera at ``camera`` looking at
    ``target`` (``field_of_view`` [deg] vertical; ``aspect``: width over height)."""
    right, up, back = view_axes(np.subtract(camera, target))
    relative = np.subtract(point, camera)
    depth = -relative @ back
    if depth <= 0:
        return False
    slope = math.tan(math.radians(field_of_view) / 2)
    return abs(relative @ up) <= slope * depth and abs(relative @ right) <= aspect * slope * depth


class FollowCamera(LeafSystem):
    """Moves ``meshcat``'s camera with the mobile bases ``bodies`` (BodyIndex of each
    free base) of ``plant``.

    Ports:
      - input ``body_poses`` (the plant's body poses).

    ``hidden``: Meshcat paths it hides at its first move, after the visualizers' own
    initialisation (which redraws them visible): the wheels' contact forces.
    ``framer``: the :class:`~armando_drake.outputs.view.ViewFramer` whose first framing
    (its ``camera_pose``: camera and target [m]) it starts from, keeping their offset.
    After each move, :attr:`camera` and :attr:`target` hold where the camera is and
    looks (None before the first framing).
    """

    def __init__(self, meshcat: Meshcat, bodies, *, framer, button: bool = True, hidden=()):
        super().__init__()
        self._meshcat = meshcat
        self._hidden = list(hidden)  # Meshcat paths hidden once the run has started
        self._bodies = list(bodies)
        self._framer = framer
        self.camera = self.target = None
        self._button = button
        if button:
            meshcat.AddButton(BUTTON, KEY)
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", AbstractValue.Make([RigidTransform()])
        )
        self._last = None  # the time of the last move
        self.moves = 0  # camera moves made
        self.DeclarePeriodicPublishEvent(1.0 / RATE, 0.0, self._Move)

    @property
    def following(self) -> bool:
        """Whether the camera follows (the button switches it: every other click)."""
        return not self._button or self._meshcat.GetButtonClicks(BUTTON) % 2 == 0

    def bases(self, context) -> np.ndarray:
        """The bases' centre [m] at ``context``."""
        poses = self._poses.Eval(context)
        return np.mean([poses[int(i)].translation() for i in self._bodies], axis=0)

    def _Move(self, context) -> None:
        now = context.get_time()
        for path in self._hidden:
            self._meshcat.SetProperty(path, "visible", False)
        self._hidden = []
        if self._last is None:  # the first framing stays where it is: it shows the bases
            if self._framer.camera_pose is None:
                return
            camera, target = self._framer.camera_pose
            self._offset = np.subtract(camera, target)
            self.camera, self.target = np.array(camera), np.array(target)
            self._height = self.target[2]  # the target stays at the framing's height
            self._last = now
            return
        centre = self.bases(context)
        goal = np.array([centre[0], centre[1], self._height])
        step, self._last = now - self._last, now
        if not self.following:
            return
        self.target = self.target + (1.0 - math.exp(-step / TIME_CONSTANT)) * (goal - self.target)
        self.camera = self.target + self._offset
        self._meshcat.SetCameraPose(camera_in_world=self.camera, target_in_world=self.target)
        self.moves += 1

    def delete_controls(self) -> None:
        """Removes its button from the viewer."""
        if self._button:
            self._meshcat.DeleteButton(BUTTON)


def AddFollowCamera(builder, plant, meshcat: Meshcat, bodies, *, framer, hidden=()) -> FollowCamera:
    """A :class:`FollowCamera` of the free bases ``bodies`` (Body of each) on ``plant``'s
    body poses, from ``framer``'s first framing (a ViewFramer); ``hidden``: paths it
    hides once the run has started."""
    indices = [body.index() for body in bodies]
    follow = builder.AddNamedSystem(
        "follow_camera", FollowCamera(meshcat, indices, framer=framer, hidden=hidden)
    )
    builder.Connect(plant.get_body_poses_output_port(), follow.get_input_port())
    return follow
