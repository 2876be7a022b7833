"""Showing a robot description in Meshcat: the RViz step of the bring-up.

:func:`run_display` is the ``robot_state_publisher`` + ``joint_state_publisher_gui``
+ ``rviz2`` of the course's ``display.launch``: Drake's ``ModelVisualizer``
draws the robot with one slider per joint, the visual geometry (the
``illustration`` layer) and the collision geometry (the ``proximity`` layer)
as separate entries the user can toggle in the Meshcat controls, and a
:class:`ViewConfig` read from ``diagrams/display.yaml`` plays the part of the
saved ``.rviz`` file.
"""

import contextlib
import dataclasses as dc
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from pydrake.common.yaml import yaml_load_typed
from pydrake.geometry import Meshcat
from pydrake.visualization import ModelVisualizer

from armando_drake import DIAGRAMS_DIR
from armando_drake.description.framing import content_frames, frame_view, scene_points
from armando_drake.description.loader import DescriptionError, LoadedRobot, load_robot

# Meshcat paths of the two geometry layers that ApplyVisualizationConfig draws.
VISUAL_LAYER = "/drake/illustration"
COLLISION_LAYER = "/drake/proximity"


@dc.dataclass
class ViewConfig:
    """A saved view of the robot, like an ``.rviz`` file.

    The camera looks from ``camera_position`` towards ``camera_target``: that direction
    is kept, and the camera is moved along and across it until the robot (and the
    objects) fill 90 % of the view's height
    (:func:`~armando_drake.description.framing.frame_view`)."""

    # A point on the camera's side of the robot, in world coordinates [m]: with
    # camera_target, the direction the camera looks from.
    camera_position: list[float] = dc.field(default_factory=lambda: [0.45, -0.45, 0.35])
    # A point the camera looks towards, in world coordinates [m].
    camera_target: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.12])
    # Whether the visual geometry layer is shown.
    show_visual: bool = True
    # Whether the collision geometry layer (one box per link) is shown.
    show_collision: bool = False
    # Whether every link frame is drawn as a triad.
    show_frames: bool = False
    # Length of the frame triads [m].
    triad_length: float = 0.05


def load_view_config(path: str | os.PathLike | None = None) -> ViewConfig:
    """Reads a view preset (default ``diagrams/display.yaml``)."""
    path = Path(path) if path is not None else DIAGRAMS_DIR / "display.yaml"
    try:
        return yaml_load_typed(schema=ViewConfig, filename=str(path))
    except FileNotFoundError:
        raise DescriptionError(f"{path}: view preset not found") from None
    except Exception as error:  # yaml_load_typed raises RuntimeError, KeyError, ...
        raise DescriptionError(f"{path}: {type(error).__name__}: {error}") from None


def check_positions(robot: LoadedRobot, position: Sequence[float]) -> np.ndarray:
    """``position`` as an array, checked against the count and limits of the joints."""
    names = [joint.name for joint in robot.joints]
    if len(position) != len(names):
        raise DescriptionError(
            f"--position has {len(position)} values, expected {len(names)} ({', '.join(names)})"
        )
    for joint, value in zip(robot.joints, position, strict=True):
        if not np.isfinite(value):
            raise DescriptionError(f"--position {joint.name}={value} is not a finite number")
        if not joint.lower <= value <= joint.upper:
            raise DescriptionError(
                f"--position {joint.name}={value:g} is outside its limits "
                f"[{joint.lower:g}, {joint.upper:g}]"
            )
    return np.asarray(position, dtype=float)


def apply_view(meshcat: Meshcat, view: ViewConfig, points=None) -> None:
    """Shows or hides the geometry layers; given ``points`` (n, 3) [m] of the robot,
    frames them from the view's direction
    (:func:`~armando_drake.description.framing.frame_view`)."""
    if points is not None:
        frame_view(meshcat, points, np.subtract(view.camera_position, view.camera_target))
    meshcat.SetProperty(VISUAL_LAYER, "visible", view.show_visual)
    meshcat.SetProperty(COLLISION_LAYER, "visible", view.show_collision)


def make_display(
    description: str | os.PathLike | None = None,
    *,
    xacro_args: Mapping[str, str] | None = None,
    package_paths: Sequence[str] = (),
    view: ViewConfig | None = None,
    position: Sequence[float] | None = None,
    meshcat: Meshcat | None = None,
) -> tuple[ModelVisualizer, LoadedRobot]:
    """A finalized ModelVisualizer showing the description, and its summary."""
    view = view or ViewConfig()
    visualizer = ModelVisualizer(
        meshcat=meshcat,
        visualize_frames=view.show_frames,
        triad_length=view.triad_length,
        triad_radius=view.triad_length / 40,
    )
    plant = visualizer.parser().plant()
    robot = load_robot(plant, description, xacro_args=xacro_args, package_paths=package_paths)
    if position is not None:
        q = check_positions(robot, position)
        for joint, value in zip(robot.joints, q, strict=True):
            plant.GetJointByName(joint.name, robot.model_instance).set_default_positions([value])
    # Its LCM messages (for Meldis) on an in-process bus unless the user names one: LCM's
    # default UDP multicast would join the machine's network interface.
    with _lcm_in_process():
        visualizer.Finalize()
    apply_view(visualizer.meshcat(), view, _robot_points(visualizer, robot))
    return visualizer, robot


def _robot_points(visualizer: ModelVisualizer, robot: LoadedRobot) -> np.ndarray:
    """(n, 3) points [m] of the robot's visual geometry at its initial pose in the
    finalized ``visualizer`` (:func:`~armando_drake.description.framing.scene_points`).
    ModelVisualizer keeps its diagram and context to itself (Drake 1.51): read there."""
    diagram, context = visualizer._diagram, visualizer._context
    scene_graph = diagram.scene_graph()
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    return scene_points(query, content_frames(diagram.plant(), [robot.model_instance]))


@contextlib.contextmanager
def _lcm_in_process():
    """LCM_DEFAULT_URL set to an in-process bus for the block, when the user set none."""
    if "LCM_DEFAULT_URL" in os.environ:
        yield
        return
    os.environ["LCM_DEFAULT_URL"] = "memq://"
    try:
        yield
    finally:
        os.environ.pop("LCM_DEFAULT_URL", None)
