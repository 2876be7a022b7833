"""The world's Meshcat view: framed on the robot, waited for, kept after the run.

:class:`ViewFramer` points the Meshcat camera at the robot when the
simulation starts: it frames the robot's illustration geometry (at the initial
state) and the scenario's objects from the direction of the view preset
(``diagrams/display.yaml``, :class:`~armando_drake.description.viewer.ViewConfig`),
as every page does (:func:`~armando_drake.description.framing.frame_view`: the
content's larger extent fills 90 % of the view's height), and draws the ground
(:data:`GROUND_PATH`) as a square slab :data:`GROUND_MARGIN` times the scene's
largest extent (robot and objects, height included). The world, the replay
(which saves the camera and the ground with the scene) and the notebooks all
get it from the world builder.

:func:`wait_for_browser` holds the start of a run until a browser shows the
page (or a timeout); :func:`serve_until_interrupted` keeps the Meshcat
server, and its replay, up after the run until Ctrl-C.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import Box, Meshcat, QueryObject, Rgba
from pydrake.systems.framework import LeafSystem

from armando_drake.description.framing import (
    arm_frames,
    body_frames,
    content_frames,
    frame_view,
    scene_points,
)
from armando_drake.description.viewer import load_view_config
from armando_drake.sensors.objects import GROUND_COLOR

GROUND_PATH = "/ground"  # Meshcat path of the ground drawn to fit the scene
GROUND_THICKNESS = 0.01  # [m] of the drawn ground slab (its top face is z = 0)
GROUND_MARGIN = 1.5  # the drawn ground's side over the scene's largest extent
GROUND_MIN_SIDE = 0.5  # [m] smallest side of the drawn ground
FLOOR_HEIGHT = 0.02  # [m] a body no higher is a floor: an arena's framing leaves it out

__all__ = [
    "AddViewFramer",
    "ViewFramer",
    "arm_frames",
    "body_frames",
    "frame_scene",
    "scene_bounds",
    "scene_points",
    "serve_until_interrupted",
    "wait_for_browser",
]


def scene_bounds(query, frames) -> np.ndarray | None:
    """(2, 3) lowest and highest corner [m] of :func:`scene_points`; None without any."""
    points = scene_points(query, frames)
    if not len(points):
        return None
    return np.array([points.min(axis=0), points.max(axis=0)])


def frame_scene(
    meshcat: Meshcat, query, content_frames, scene_frames=None, *, view=None
) -> np.ndarray | None:
    """Frames the geometry on ``content_frames`` (at the poses of ``query``, a SceneGraph
    QueryObject) from the view preset's direction
    (:func:`~armando_drake.description.framing.frame_view`) and, given ``scene_frames``
    (the robot's and the objects'), draws the ground to fit them. Returns the content's
    bounds (2, 3) [m], None without geometry."""
    framed = _frame_scene(meshcat, query, content_frames, scene_frames, view=view)
    return None if framed is None else framed[0]


def _frame_scene(meshcat: Meshcat, query, content_frames, scene_frames=None, *, view=None):
    """:func:`frame_scene`'s work: (the content's bounds, (camera, target) [m]) or None."""
    from pydrake.math import RigidTransform

    view = view or load_view_config()
    points = scene_points(query, content_frames)
    if not len(points):
        return None
    pose = frame_view(meshcat, points, np.subtract(view.camera_position, view.camera_target))
    scene = None if scene_frames is None else scene_bounds(query, scene_frames)
    if scene is not None:
        center = (scene[0, :2] + scene[1, :2]) / 2
        # The scene's largest extent, its height included: an arm reaches about as far
        # as it stands tall.
        extent = (scene[1] - scene[0]).max()
        side = max(GROUND_MIN_SIDE, GROUND_MARGIN * extent)
        meshcat.SetObject(GROUND_PATH, Box(side, side, GROUND_THICKNESS), Rgba(*GROUND_COLOR))
        meshcat.SetTransform(
            GROUND_PATH, RigidTransform([center[0], center[1], -GROUND_THICKNESS / 2])
        )
    return np.array([points.min(axis=0), points.max(axis=0)]), pose


def _above_the_floor(query, frame) -> bool:
    """Whether the geometry on ``frame`` reaches higher than :data:`FLOOR_HEIGHT`."""
    points = scene_points(query, {frame})
    return bool(len(points)) and float(points[:, 2].max()) > FLOOR_HEIGHT


class ViewFramer(LeafSystem):
    """Frames the robot and the objects in Meshcat when the simulation starts
    (:func:`frame_scene`).

    Input ports:
      query: the SceneGraph's query object.

    ``content_frames``: geometry frames of what the view frames (the robot's bodies,
    the world's with the objects); ``arena_frames``: those framed too when they rise
    above the floor (an arena's walls and furniture); ``scene_frames``: those of
    everything the ground should fit (None: no ground drawn); ``view``: the preset whose
    direction the camera takes (default ``diagrams/display.yaml``).
    """

    def __init__(
        self, *, meshcat: Meshcat, content_frames, scene_frames=None, view=None, arena_frames=None
    ):
        super().__init__()
        self._meshcat = meshcat
        self._content_frames = set(content_frames)
        self._arena_frames = set(arena_frames or ())
        self._scene_frames = None if scene_frames is None else set(scene_frames)
        self._view = view
        self._query_port = self.DeclareAbstractInputPort("query", Value[QueryObject]())
        self.DeclareInitializationPublishEvent(self._Frame)
        self.content_bounds = None  # (2, 3) [m] once framed
        self.camera_pose = None  # (camera, target) [m] once framed

    def _Frame(self, context) -> None:
        query = self._query_port.Eval(context)
        content = self._content_frames | {
            frame for frame in self._arena_frames if _above_the_floor(query, frame)
        }
        framed = _frame_scene(self._meshcat, query, content, self._scene_frames, view=self._view)
        if framed is not None:
            self.content_bounds, self.camera_pose = framed


def AddViewFramer(
    builder,
    plant,
    scene_graph,
    meshcat: Meshcat,
    *,
    robot_instances,
    ground: bool,
    view=None,
    arena: bool = False,
) -> ViewFramer:
    """Adds a :class:`ViewFramer` of the arm of ``robot_instances`` and the objects
    (:func:`~armando_drake.description.framing.content_frames`: the robots' bodies but
    accessories fixed to the world, and the world's geometry); with ``arena`` (a world
    with a mobile robot) every body too, the world file's models with them: the arena
    the robot drives in, but a floor (geometry no higher than :data:`FLOOR_HEIGHT`: a
    world's ground plane may be 100 m wide); with ``ground`` it draws the ground to fit
    every body and the objects."""
    content = content_frames(plant, robot_instances)
    framer = builder.AddSystem(
        ViewFramer(
            meshcat=meshcat,
            content_frames=content,
            scene_frames=(body_frames(plant) | content) if ground else None,
            view=view,
            arena_frames=body_frames(plant) if arena else None,
        )
    )
    framer.set_name("view_framer")
    builder.Connect(scene_graph.get_query_output_port(), framer.get_input_port())
    return framer


def wait_for_browser(meshcat: Meshcat, timeout: float, stream: TextIO = sys.stdout) -> bool:
    """Waits until a browser has ``meshcat``'s page open, up to ``timeout`` [s]; says on
    ``stream`` that it waits, then that a browser connected (or none did). Returns whether
    one is connected. Ctrl-C raises KeyboardInterrupt (the run ends there, as it would
    during the simulation)."""
    if meshcat.GetNumActiveConnections() > 0 or timeout <= 0:
        return meshcat.GetNumActiveConnections() > 0
    print(
        f"waiting up to {timeout:g} s for a browser to open the Meshcat page "
        "(--no-wait starts at once) ...",
        file=stream,
        flush=True,
    )
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if meshcat.GetNumActiveConnections() > 0:
            print("browser connected", file=stream, flush=True)
            return True
        time.sleep(0.1)
    print("no browser connected: starting anyway", file=stream, flush=True)
    return False


def serve_until_interrupted(meshcat: Meshcat, stream: TextIO = sys.stdout) -> None:
    """Keeps the process (and so ``meshcat``'s server) up until Ctrl-C or SIGTERM."""
    print(
        "Meshcat keeps serving the run as a replay (Animations: play, scrub); Ctrl-C to exit",
        file=stream,
        flush=True,
    )
    try:
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
