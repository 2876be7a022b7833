"""The world's cameras: the description's camera blocks and the scenario's cameras as
Drake ``RgbdSensor``s, their live view and their frame saver."""

from __future__ import annotations

import dataclasses as dc
import logging
from collections.abc import Sequence

from pydrake.geometry import Meshcat, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from armando_drake.description.loader import LoadedRobot
from armando_drake.messages.publications import PublicationRegistry, register
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


def _of_robot(name: str, info):
    """The description camera ``info`` of the robot ``name`` (not the first of several):
    named ``<name>_<camera>``, on ``/<name>/<topic>``."""
    topic = f"/{name}/{(info.topic or info.name).strip('/')}"
    return dc.replace(info, robot=name, name=f"{name}_{info.name}", topic=topic)


def AddCameras(
    builder: DiagramBuilder,
    settings: CameraSettings,
    *,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    robot: LoadedRobot,
    extra: Sequence = (),
    meshcat: Meshcat | None = None,
    host: str = "127.0.0.1",
    where: str = "",
    source: str = "",
    robots: dict[str, LoadedRobot] | None = None,
    publications: PublicationRegistry | None = None,
) -> tuple[dict[str, AddedCamera], ImageViewServer | None]:
    """RgbdSensors from the description's camera blocks (when ``settings.enabled``:
    the scenario's ``camera:`` section) and ``extra`` (the scenario's ``cameras:``,
    each with a ``sensor_info(origin)``, added either way), a live view on ``host``
    (with ``settings.live_view`` or a watched ``meshcat``) and a frame saver. Returns
    (the cameras by name, the live view's server or None). ``where``/``source``: the
    origins named in errors. ``robots``: every robot of a world of several, by name
    (``robot`` the first): the others' description cameras too, each
    ``<robot>_<camera>`` on ``/<robot>/<topic>``, and a scenario camera on
    ``ROBOT::link``. ``publications``: where each camera's ``image_raw`` and
    ``camera_info`` are registered."""
    robots = robots or {}
    sensors = list(robot.cameras) if settings.enabled else []
    for name, other in robots.items():
        if other is not robot and settings.enabled:
            sensors += [_of_robot(name, info) for info in other.cameras]
    if settings.enabled and not sensors and not extra:
        _log.warning("camera enabled, but %s describes no camera sensor", robot.source)
        return {}, None
    if not settings.enabled and not extra:
        return {}, None
    try:
        sensors += [camera.sensor_info(source) for camera in extra]
        renderer = choose_renderer(settings.renderer)
        cameras = AddCameraSensors(
            builder,
            plant,
            scene_graph,
            robot.model_instance,
            sensors,
            renderer=renderer,
            enable_depth=settings.depth,
            export=True,
            instances={name: other.model_instance for name, other in robots.items()},
        )
    except CameraError as error:  # a scenario camera's error names its origin already
        text = str(error)
        named = source and text.startswith(f"{source}: cameras")
        raise ScenarioError(text if named else f"{where}{text}") from None
    for name, camera in cameras.items():
        _log.info("camera %s, rendered by %s", describe(camera.info), ENGINES[renderer])
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
