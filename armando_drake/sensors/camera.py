"""Camera sensors described in the URDF, as Drake ``RgbdSensor`` systems.

A ROS description declares its camera the Gazebo way, next to the links::

    <gazebo reference="camera_link">
      <sensor type="camera" name="camera">
        <update_rate>30</update_rate>
        <topic>camera</topic>
        <pose>0 0 0 0 0 0</pose>           <!-- optional, in camera_link -->
        <camera>
          <horizontal_fov>1.047</horizontal_fov>
          <image><width>320</width><height>240</height></image>
          <clip><near>0.1</near><far>100</far></clip>
          <noise><type>gaussian</type><mean>0</mean><stddev>0.007</stddev></noise>
        </camera>
      </sensor>
    </gazebo>

:func:`parse_camera_sensors` reads every such block (sensor types ``camera``,
``depth``, ``depth_camera``, ``rgbd_camera``, ``rgbd``) into a
:class:`CameraSensorInfo`, with SDFormat's defaults for what is left out, and
:func:`AddCameraSensors` turns them into Drake cameras through Drake's own
``CameraConfig`` + ``ApplyCameraConfig``.

Frames
------
Gazebo's camera looks along the +x axis of its sensor frame S (the link frame
moved by the sensor ``<pose>``), with +y to the left of the image and +z up.
Drake's camera frame C looks along +z, with +x to the right of the image and
+y down. The sensor frame becomes ``CameraConfig.X_PB`` (P = the link frame)
and the fixed rotation between the conventions becomes ``X_BC`` = ``X_BD``::

    R_SC = [[ 0,  0, 1],     C's x = -S's y   (image right = -left)
            [-1,  0, 0],     C's y = -S's z   (image down  = -up)
            [ 0, -1, 0]]     C's z =  S's x   (optical axis = forward)

(the columns are C's axes expressed in S). A ROS ``*_optical_frame`` link, if
the description has one, already follows Drake's convention; the Gazebo block
is on the body link in the usual descriptions, so the rotation is always
applied.

Intrinsics
----------
Like Gazebo, the focal length comes from the horizontal field of view with
square pixels: ``fx = fy = width / (2 tan(horizontal_fov / 2))``; the
principal point is the image centre. ``<clip>`` is both the colour clipping
range and the depth range (the depth range's far end is capped at 65.5 m,
about the most Drake's 16-bit depth image can hold; farther points read as
"too far", i.e. +inf in the 32-bit depth image).

Rate
----
The colour image is sampled and held at ``<update_rate>`` (a
:class:`~armando_drake.sensors.frame_hold.FrameHold`, which also adds the noise)
so that every reader sees Gazebo's frame timing: the frame of ``k / rate`` in the
period after it. Drake renders only when a port is evaluated, and the hold
samples only the frames its readers read (each reader says its rate with
:meth:`AddedCamera.read_color`: a detector at the camera rate, the point-cloud
pipeline at its own, the frame saver at its save rate, the live view and the
recorded topics at the camera rate while they are on), so a camera whose colour
nobody reads renders no colour, and a 10 Hz reader of a 30 Hz camera costs 10
renders a second, not 30. Depth is rendered on demand, when a reader evaluates
it (the frame saver at its rate, the point-cloud pipeline at its rate, the live
view only while a page shows depth); labels are not rendered. SDFormat's default
rate of 0 means "every physics step", which has no meaning for Drake's
variable-step simulation: :data:`DEFAULT_FRAME_RATE` (30 Hz) is used instead.

Renderer
--------
Drake has two renderers; :func:`choose_renderer` picks one per world (the
scenario's ``camera.renderer``, ``auto`` by default). ``RenderEngineGl``
(OpenGL) needs an X display: the user's ``DISPLAY``, or a private ``Xvfb``
that :mod:`armando_drake.tools.xdisplay` starts for the process. On our 2-core
CPU-only machines it renders the 640 x 480 scene of ``diagrams/camera.yaml``
at about 95 frames/s, colour or colour + depth. ``RenderEngineVtk`` renders
headless through EGL with no display at all; ``auto`` falls back to it,
saying so, when no display can be had.
VTK cameras render from a scene graph of their own
(:mod:`~armando_drake.sensors.camera_scene`, the same images): a VTK engine on the
world's scene graph would cost at every plant step, rendering or not. Drake's VTK
engine antialiases every colour frame with VTK's FXAA pass, about 43 ms of CPU at
640 x 480 whatever the scene; unless the scenario asks for it
(``camera.antialiasing``), the pass copies the frame as rendered instead
(:mod:`~armando_drake.sensors.antialiasing`), so VTK's frames have OpenGL's hard
edges and cost about a fifth. A camera whose scene has not moved since its last
frame holds that frame again instead of rendering it (the same poses give the same
pixels; OpenGL cameras watch the poses of the world's scene graph they render from).

Noise
-----
Gazebo's camera ``<noise>`` (type ``gaussian``) adds N(mean, stddev) to every
colour channel in [0, 1] units, clamped; the colour hold does the same on
each 8-bit frame it samples (alpha untouched; :class:`CameraColorNoise` is such
a hold on its own, of every frame). Depth images are noise-free.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.common.schema import Transform
from pydrake.geometry import (
    MakeRenderEngineVtk,
    RenderEngineGlParams,
    RenderEngineVtkParams,
    Rgba,
    SceneGraph,
)
from pydrake.lcm import DrakeLcm
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.sensors import (
    ApplyCameraConfig,
    CameraConfig,
    ImageRgba8U,
    RgbdSensor,
)

from armando_drake.description.camera_sensors import (
    MAX_DEPTH_RANGE,
    R_SC,
    RENDERERS,
    CameraError,
    CameraSensorInfo,
    sensor_origin,
)
from armando_drake.sensors.camera_scene import (
    CameraScene,
    CameraSceneOf,
    SceneFor,
    WorldPosesOf,
)
from armando_drake.sensors.frame_hold import FrameHold
from armando_drake.tools.xdisplay import DisplayError, ensure_display

_logger = logging.getLogger(__name__)


class CameraColorNoise(FrameHold):
    """Adds Gazebo-style Gaussian noise to a colour image at the camera rate.

    Samples its input every ``1 / frame_rate`` seconds, adds ``mean + stddev *
    N(0, 1)`` (in [0, 1] colour units, i.e. times 255) to R, G and B, clamps,
    and holds the result (so reading the output costs nothing): a
    :class:`~armando_drake.sensors.frame_hold.FrameHold` of every frame.

    Ports:
      - input ``image`` (ImageRgba8U)
      - output ``image`` (ImageRgba8U)
    """

    def __init__(
        self,
        *,
        width: int,
        height: int,
        frame_rate: float,
        mean: float = 0.0,
        stddev: float = 0.0,
        seed: int = 0,
    ):
        super().__init__(
            ImageRgba8U(width, height), frame_rate=frame_rate, mean=mean, stddev=stddev, seed=seed
        )


@dataclass
class AddedCamera:
    """What :func:`AddCameraSensors` added for one camera."""

    info: CameraSensorInfo  # the parsed sensor block
    config: CameraConfig  # the Drake camera configuration that was applied
    sensor: RgbdSensor  # Drake's sensor system (renders on demand)
    color_image: OutputPort  # ImageRgba8U, held at the camera rate (noise applied)
    depth_image: OutputPort | None  # ImageDepth32F [m], rendered when read; None if off
    hold: FrameHold | None = None  # what holds color_image (None: not held)
    # Whether its colour frames are antialiased (VTK's FXAA pass: sensors.antialiasing).
    antialiased: bool = False

    def summary(self) -> dict:
        """What ``summary.json``'s ``cameras`` says of it: its renderer, antialiasing,
        size and rate."""
        gl = isinstance(self.config.renderer_class, RenderEngineGlParams)
        return {
            "renderer": "RenderEngineGl" if gl else "RenderEngineVtk",
            "antialiasing": "FXAA" if self.antialiased else "none",
            "width": self.info.width,
            "height": self.info.height,
            "rate": self.info.frame_rate,
        }

    def read_color(
        self, rate: float, offset: float = 0.0, active: Callable[[], bool] | None = None
    ) -> None:
        """Says that a system reads ``color_image`` at ``rate`` [Hz] from ``offset`` [s]
        (while ``active()``, if given): only the frames read are rendered."""
        if self.hold is not None:
            self.hold.add_reader(rate, offset, active)


def read_color(camera, rate: float, offset: float = 0.0) -> None:
    """:meth:`AddedCamera.read_color` of ``camera``, if it is one (a view of an image
    that is not a camera's holds nothing)."""
    if isinstance(camera, AddedCamera):
        camera.read_color(rate, offset)


def choose_renderer(wanted: str) -> str:
    """The renderer for the camera setting ``wanted``: ``"gl"`` or ``"vtk"``.

    ``"auto"`` takes Drake's OpenGL renderer when an X display is there or a
    private Xvfb can be started (:func:`~armando_drake.tools.xdisplay.ensure_display`),
    else VTK through EGL; ``"gl"`` insists on OpenGL; ``"vtk"`` is VTK.
    """
    if wanted not in RENDERERS:
        raise CameraError(f"camera.renderer={wanted!r} must be one of {', '.join(RENDERERS)}")
    if wanted == "vtk":
        return "vtk"

    try:
        ensure_display()
        return "gl"
    except DisplayError as error:
        if wanted == "gl":
            raise CameraError(f"camera.renderer='gl' needs an X display: {error}") from None
        _logger.info(
            "cameras render with VTK through EGL (%s; with it, OpenGL renders about 2.5 "
            "times faster)",
            error,
        )
        return "vtk"


def camera_config(
    info: CameraSensorInfo,
    base_frame: str,
    *,
    renderer: str = "vtk",
    renderer_name: str | None = None,
    enable_depth: bool = True,
    background: tuple[float, float, float] | None = None,
) -> CameraConfig:
    """The Drake ``CameraConfig`` equivalent to a Gazebo camera on ``base_frame``.

    ``base_frame`` is a scoped frame name (``model::link``). ``renderer``:
    ``"vtk"`` (``RenderEngineVtk``, headless through EGL) or ``"gl"``
    (``RenderEngineGl``, needs an X display); ``renderer_name`` (default: the
    same) names it in the SceneGraph.
    """
    if renderer == "vtk":
        params = RenderEngineVtkParams()  # backend "" = EGL on Linux: no display needed
    elif renderer == "gl":
        params = RenderEngineGlParams()
    else:
        raise CameraError(f"renderer={renderer!r} must be 'vtk' or 'gl'")
    config = CameraConfig(
        name=info.name,
        width=info.width,
        height=info.height,
        focal=CameraConfig.FocalLength(x=info.focal_length, y=info.focal_length),
        clipping_near=info.near,
        clipping_far=info.far,
        z_near=info.near,
        z_far=min(info.far, MAX_DEPTH_RANGE),
        fps=info.frame_rate,
        renderer_name=renderer_name or renderer,
        rgb=True,
        depth=enable_depth,
        label=False,
        show_rgb=False,
    )
    if background is not None:
        config.background = Rgba(*background, 1.0)
    rgba = config.background
    if renderer == "vtk":
        params.default_clear_color = np.array([rgba.r(), rgba.g(), rgba.b()])
    else:
        params.default_clear_color = rgba
    config.renderer_class = params
    X_PB = Transform(info.X_LS())
    X_PB.base_frame = base_frame
    config.X_PB = X_PB
    config.X_BC = Transform(RigidTransform(R_SC))
    config.X_BD = Transform(RigidTransform(R_SC))
    return config


def _check_sensor(
    plant: MultibodyPlant,
    model_instance: ModelInstanceIndex,
    info: CameraSensorInfo,
    added: dict[str, AddedCamera],
) -> None:
    """Raises when the camera's name is taken or its link is not a body of the model."""
    model_name = plant.GetModelInstanceName(model_instance)
    origin = sensor_origin(info.source, info.sensor_name)
    if info.name in added:
        raise CameraError(f"{origin}: name {info.name!r} twice")
    if not plant.HasBodyNamed(info.link, model_instance):
        raise CameraError(
            f"{origin}: link {info.link!r} is not a body of "
            f"model {model_name!r} (Drake merges no links; is it the right model?)"
        )


def _instance_of(info: CameraSensorInfo, default, instances: dict):
    """The model instance of the robot the camera ``info`` is on."""
    if not info.robot:
        return default
    if info.robot not in instances:
        raise CameraError(
            f"{sensor_origin(info.source, info.sensor_name)}: link "
            f"'{info.robot}::{info.link}': no robot {info.robot!r} (robots: "
            f"{', '.join(instances) or 'none'})"
        )
    return instances[info.robot]


def _apply_camera(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    config: CameraConfig,
    info: CameraSensorInfo,
) -> RgbdSensor:
    """Adds the camera of ``config`` with Drake's ``ApplyCameraConfig`` (its LCM publishing
    off); returns its sensor."""
    no_lcm = DrakeLcm("memq://null")  # ApplyCameraConfig's opt-out of LCM publishing
    try:
        ApplyCameraConfig(
            config=config, builder=builder, plant=plant, scene_graph=scene_graph, lcm=no_lcm
        )
    except RuntimeError as error:
        raise CameraError(f"{sensor_origin(info.source, info.sensor_name)}: {error}") from None
    return builder.GetMutableSubsystemByName(f"rgbd_sensor_{info.name}")


def _scene_of(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    info: CameraSensorInfo,
    instance: ModelInstanceIndex,
) -> CameraScene:
    """The mirror a VTK camera renders from (:func:`~.camera_scene.SceneFor`: its own
    when it sits inside convex visuals of its link)."""
    if not plant.HasBodyNamed(info.link, instance):  # _add_scene_camera says so
        return CameraSceneOf(builder, scene_graph)
    frame = plant.GetBodyFrameIdOrThrow(plant.GetBodyByName(info.link, instance).index())
    p_F = info.X_LS().translation()
    return SceneFor(builder, scene_graph, frame, p_F, info.near, ("camera", info.name))


def _add_scene_camera(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene: CameraScene,
    config: CameraConfig,
    info: CameraSensorInfo,
    instance: ModelInstanceIndex,
) -> RgbdSensor:
    """Adds the camera of ``config`` on the cameras' own scene graph ``scene`` (what
    ``ApplyCameraConfig`` does, on the mirror of the link's frame); returns its sensor."""
    name = config.renderer_name
    try:
        if not scene.scene_graph.HasRenderer(name):
            scene.scene_graph.AddRenderer(name, MakeRenderEngineVtk(config.renderer_class))
        color, depth = config.MakeCameras()
    except RuntimeError as error:
        raise CameraError(f"{sensor_origin(info.source, info.sensor_name)}: {error}") from None
    body = plant.GetBodyByName(info.link, instance)
    parent = scene.frame(plant.GetBodyFrameIdOrThrow(body.index()))
    sensor = builder.AddNamedSystem(
        f"rgbd_sensor_{info.name}",
        RgbdSensor(parent, config.X_PB.GetDeterministicValue(), color, depth),
    )
    builder.Connect(scene.scene_graph.get_query_output_port(), sensor.query_object_input_port())
    return sensor


def _color_output(
    builder: DiagramBuilder,
    sensor: RgbdSensor,
    info: CameraSensorInfo,
    *,
    hold: bool,
    noise_seed: int,
    poses=None,
) -> tuple[OutputPort, FrameHold | None]:
    """The camera's colour image and what holds it: sampled at its rate (``hold``), only
    for the frames its readers read, with the block's noise (held either way), and
    rendered only when one of the ``poses`` of its scene (a MirroredPoses) changed."""
    color = sensor.GetOutputPort("color_image")
    noise = info.noise if info.noise is not None and info.noise.stddev > 0 else None
    if not hold and noise is None:
        return color, None
    frame_hold = builder.AddNamedSystem(
        f"camera_{'noise' if noise else 'hold_color'}_{info.name}",
        FrameHold(
            ImageRgba8U(info.width, info.height),
            frame_rate=info.frame_rate,
            on_demand=True,
            mean=noise.mean if noise else 0.0,
            stddev=noise.stddev if noise else 0.0,
            seed=noise_seed,
            watch_scene=poses is not None,
        ),
    )
    builder.Connect(color, frame_hold.get_input_port(0))
    if poses is not None:
        builder.Connect(poses.get_output_port(), frame_hold.GetInputPort("scene_poses"))
    return frame_hold.get_output_port(), frame_hold


def AddCameraSensors(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    model_instance: ModelInstanceIndex,
    sensors: list[CameraSensorInfo],
    *,
    renderer: str = "vtk",
    renderer_name: str | None = None,
    enable_depth: bool = True,
    hold: bool = True,
    export: bool = False,
    noise_seed: int = 0,
    background: tuple[float, float, float] | None = None,
    instances: dict[str, ModelInstanceIndex] | None = None,
    own_scene: bool = True,
) -> dict[str, AddedCamera]:
    """Adds one Drake RGB-D camera per sensor block, attached to its link.

    Uses ``CameraConfig`` + ``ApplyCameraConfig`` (LCM publishing switched off)
    with one renderer shared by all cameras: ``renderer`` ``"vtk"`` (headless
    through EGL) or ``"gl"`` (OpenGL, needs an X display: see
    :func:`choose_renderer`), named ``renderer_name`` (default: the same).
    With ``hold`` the colour image is sampled and held at each camera's rate, only
    for the frames its readers read (:meth:`AddedCamera.read_color`; set it False
    only to render on every evaluation); depth is rendered when read; Gaussian
    colour noise, if the block has some, is added to the frames held.
    With ``export`` the diagram exports ``<camera>.color_image`` and
    ``<camera>.depth_image``. ``instances``: the model instance of each robot of a world
    of several, by name: a camera whose ``robot`` names one is on that robot's link
    (else on ``model_instance``'s). With ``own_scene`` VTK cameras render from a scene
    graph of their own (:mod:`~armando_drake.sensors.camera_scene`: the same images,
    without VTK's cost at every plant step); call after the last geometry is
    registered (``plant.Finalize()``, the scene objects).
    """
    if not hold and any(info.noise is not None and info.noise.stddev > 0 for info in sensors):
        _logger.warning("hold=False: camera noise is applied at the camera rate anyway")
    added: dict[str, AddedCamera] = {}
    for info in sensors:
        instance = _instance_of(info, model_instance, instances or {})
        model_name = plant.GetModelInstanceName(instance)
        _check_sensor(plant, instance, info, added)
        config = camera_config(
            info,
            f"{model_name}::{info.link}",
            renderer=renderer,
            renderer_name=renderer_name,
            enable_depth=enable_depth,
            background=background,
        )
        if renderer == "vtk" and own_scene:
            renders = _scene_of(builder, plant, scene_graph, info, instance)
            sensor = _add_scene_camera(builder, plant, renders, config, info, instance)
            poses = renders.poses  # every pose of the scene it renders
        else:
            sensor = _apply_camera(builder, plant, scene_graph, config, info)
            poses = WorldPosesOf(builder, scene_graph)
        color, frame_hold = _color_output(
            builder, sensor, info, hold=hold, noise_seed=noise_seed, poses=poses
        )
        # Depth is not held: rendered when a consumer reads it (the frame saver, a page
        # showing it, a test), so a camera whose depth nobody reads costs its colour only.
        depth = sensor.GetOutputPort("depth_image_32f") if enable_depth else None
        if export:
            builder.ExportOutput(color, f"{info.name}.color_image")
            if depth is not None:
                builder.ExportOutput(depth, f"{info.name}.depth_image")
        added[info.name] = AddedCamera(
            info=info,
            config=config,
            sensor=sensor,
            color_image=color,
            depth_image=depth,
            hold=frame_hold,
        )
        _logger.debug("camera %r on %s::%s", info.name, model_name, info.link)
    return added


def describe(info: CameraSensorInfo) -> str:
    """One line about a camera, for logs and the command line."""
    depth = " + depth" if info.has_depth else ""
    noise = f", noise sigma {info.noise.stddev:g}" if info.noise else ""
    return (
        f"{info.name}: {info.width}x{info.height}{depth}, fov {info.horizontal_fov:.3f} rad, "
        f"{info.frame_rate:g} Hz, clip [{info.near:g}, {info.far:g}] m, "
        f"on {info.link}{noise} ({os.path.basename(info.source) or 'urdf'})"
    )
