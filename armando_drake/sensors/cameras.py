"""The world's cameras: the description's camera blocks and the scenario's cameras as
Drake ``RgbdSensor``s, their live view and their frame saver."""

from __future__ import annotations

import dataclasses as dc
import logging
from collections.abc import Sequence

from pydrake.geometry import Meshcat, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from armando_drake.description.camera_sensors import sensor_origin
from armando_drake.description.loader import LoadedRobot
from armando_drake.messages.publications import PublicationRegistry, register
from armando_drake.sensors.antialiasing import use_vtk_antialiasing
from armando_drake.sensors.camera import (
    AddCameraSensors,
    AddedCamera,
    CameraError,
    choose_renderer,
    describe,
)
from armando_drake.sensors.camera_topics import camera_topics
from armando_drake.sensors.config import CameraSettings
from armando_drake.sensors.image_view import AddFrameSaver, AddImageView, ImageViewServer
from armando_drake.tools.cli import warn_if_open
from armando_drake.tools.errors import ScenarioError

_log = logging.getLogger("armando_drake.world")

ENGINES = {"gl": "RenderEngineGl", "vtk": "RenderEngineVtk"}


def _of_robot(name: str, namespace: str, info):
    """The description camera ``info`` of the robot ``name``: in the root namespace as
    the description names it; under a namespace ``<name>_<camera>``, on
    ``/<namespace>/<topic>``."""
    space = namespace.strip("/")
    if not space:
        return dc.replace(info, robot=name)
    topic = f"/{space}/{(info.topic or info.name).strip('/')}"
    return dc.replace(info, robot=name, name=f"{name}_{info.name}", topic=topic)


def _on_robot(info, plant: MultibodyPlant, robots: dict[str, LoadedRobot]):
    """A scenario camera ``info`` whose link names no robot (``ROBOT::link`` does): on
    the first robot listed that has that link."""
    if info.robot:
        return info
    for name, robot in robots.items():
        if plant.HasBodyNamed(info.link, robot.model_instance):
            return dc.replace(info, robot=name)
    if len(robots) == 1:
        return dc.replace(info, robot=next(iter(robots)))  # its error names the model
    raise CameraError(
        f"{sensor_origin(info.source, info.sensor_name)}: no robot has a link "
        f"{info.link!r} (robots: {', '.join(robots)})"
    )


def capped(info, max_rate: float):
    """The camera ``info`` at no more than ``max_rate`` [Hz] (0: as it is), saying so."""
    if max_rate <= 0 or info.frame_rate <= max_rate:
        return info
    _log.warning(
        "camera.max_rate=%g (an interactive setting): camera %s renders at %g Hz instead "
        "of its %g Hz; its detections and figures are not the scenario's",
        max_rate,
        info.name,
        max_rate,
        info.frame_rate,
    )
    return dc.replace(info, update_rate=float(max_rate))


def _renderer(settings: CameraSettings) -> tuple[str, bool]:
    """(the renderer of ``settings``, whether its colour frames are antialiased): VTK's
    FXAA pass as ``settings.antialiasing`` asks (sensors.antialiasing); OpenGL has none."""
    renderer = choose_renderer(settings.renderer)
    if renderer == "vtk":
        return renderer, use_vtk_antialiasing(settings.antialiasing)
    if settings.antialiasing:
        _log.warning("camera.antialiasing: OpenGL cameras render without antialiasing")
    return renderer, False


def AddCameras(
    builder: DiagramBuilder,
    settings: CameraSettings,
    *,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    robots: dict[str, LoadedRobot],
    namespaces: dict[str, str] | None = None,
    extra: Sequence = (),
    meshcat: Meshcat | None = None,
    host: str = "127.0.0.1",
    where: str = "",
    source: str = "",
    publications: PublicationRegistry | None = None,
) -> tuple[dict[str, AddedCamera], ImageViewServer | None]:
    """RgbdSensors from the description camera blocks of every robot of ``robots`` (by
    name; when ``settings.enabled``: the scenario's ``camera:`` section) and ``extra``
    (the scenario's ``cameras:``, each with a ``sensor_info(origin)``, added either way,
    on ``ROBOT::link`` or on the first robot with that link), a live view on ``host``
    (with ``settings.live_view`` or a watched ``meshcat``) and a frame saver; with
    ``settings.max_rate`` every camera at most at that rate (:func:`capped`). Returns
    (the cameras by name, the live view's server or None). ``namespaces``: each robot's
    namespace; a namespaced robot's cameras are ``<robot>_<camera>`` on
    ``/<namespace>/<topic>``. ``where``/``source``: the origins named in errors.
    ``publications``: where each camera's ``image_raw`` and ``camera_info`` are
    registered."""
    namespaces = namespaces or {}
    sensors = []
    if settings.enabled:
        for name, robot in robots.items():
            sensors += [_of_robot(name, namespaces.get(name, ""), i) for i in robot.cameras]
    if settings.enabled and not sensors and not extra:
        described = ", ".join(str(robot.source) for robot in robots.values())
        _log.warning("camera enabled, but %s describes no camera sensor", described)
        return {}, None
    if not settings.enabled and not extra:
        return {}, None
    try:
        sensors += [_on_robot(c.sensor_info(source), plant, robots) for c in extra]
        sensors = [capped(info, settings.max_rate) for info in sensors]
        renderer, antialiased = _renderer(settings)
        cameras = AddCameraSensors(
            builder,
            plant,
            scene_graph,
            plant.world_body().model_instance(),  # every camera names its robot
            sensors,
            renderer=renderer,
            enable_depth=settings.depth,
            export=True,
            instances={name: robot.model_instance for name, robot in robots.items()},
        )
    except CameraError as error:  # a scenario camera's error names its origin already
        text = str(error)
        named = source and text.startswith(f"{source}: cameras")
        raise ScenarioError(text if named else f"{where}{text}") from None
    engine = ENGINES[renderer] + (" with FXAA" if antialiased else "")
    for name, camera in cameras.items():
        camera.antialiased = antialiased
        _log.info("camera %s, rendered by %s", describe(camera.info), engine)
        register(publications, *camera_topics(name, camera))
    # A Meshcat kept only to record a replay (recording_only) has no viewer to go with.
    watched = meshcat is not None and not getattr(meshcat, "recording_only", False)
    server = None
    if settings.live_view or watched:
        warn_if_open(host, "the camera view")
        server = AddImageView(builder, cameras, host=host, depth=settings.depth)
    if settings.save_frames:
        for camera in cameras.values():
            AddFrameSaver(
                builder,
                camera,
                settings.save_frames,
                rate=settings.save_rate or None,
                depth=settings.depth,
            )
    return cameras, server
