"""Perception added to a world (:func:`AddPerception`): the depth camera's point cloud, the
pipeline on it, its Meshcat view and clusters log, its topics registered."""

from __future__ import annotations

import dataclasses
import logging
import os
from pathlib import Path

from pydrake.geometry import Meshcat
from pydrake.perception import BaseField, DepthImageToPointCloud
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.sensors import PixelType

from armando_drake.messages.publications import PublicationRegistry
from armando_drake.perception.config import (
    PerceptionConfig,
    PerceptionError,
)
from armando_drake.perception.systems import (
    SKLEARN_STEPS,
    UPDATE_OFFSET_FRACTION,
    AddedPerception,
    CameraPoseInWorld,
    ClustersLog,
    PerceptionVisualizer,
    PointCloudPerception,
)
from armando_drake.perception.topics import PerceptionSource
from armando_drake.sensors.camera import read_color
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.extras import extra_hint, missing_modules
from armando_drake.tools.schema import check_config

_log = logging.getLogger("armando_drake.perception")


def _error(where: str, message: str):
    prefix = "perception." if message.startswith("steps[") else ""
    return ScenarioError(f"{where}{prefix}{message}")


def AddPerception(
    builder: DiagramBuilder,
    config: PerceptionConfig | None,
    *,
    cameras: dict,
    robot_source: str = "",
    meshcat: Meshcat | None = None,
    output_dir: str | os.PathLike | None = None,
    source: str = "",
    publications: PublicationRegistry | None = None,
) -> AddedPerception | None:
    """Adds point clouds and the pipeline of ``config`` to a world being built.

    Needs a camera with depth among ``cameras`` (by name, as
    :func:`~armando_drake.sensors.cameras.AddCameras` returns them; ``robot_source``,
    the description, is named when there is none). Exports
    ``<camera>.points_in_camera``, ``<camera>.points_in_world``,
    ``<camera>.camera_pose`` and ``perception.result``. With a ``meshcat``
    that has a viewer (and ``config.meshcat``), draws the layers; with
    ``output_dir``, writes ``clusters.json`` there when the world closes.
    ``None`` (no ``perception:`` block) adds nothing. A bad block is a
    :class:`~armando_drake.tools.errors.ScenarioError` naming ``source``
    and the step. ``publications``: where its topics are registered
    (:mod:`armando_drake.perception.topics`).
    """
    if config is None:
        return None
    where = f"{source}: " if source else ""
    try:
        check_config(config, key="perception", error=PerceptionError)
    except PerceptionError as error:
        raise _error(where, str(error)) from None
    if any(isinstance(step, SKLEARN_STEPS) for step in config.steps):
        if missing_modules(("sklearn", "scipy")):
            raise _error(
                where,
                "perception: the outlier, plane and clustering steps need scikit-learn and SciPy "
                f"({extra_hint('perception')})",
            )
    if not cameras:
        raise _error(
            where,
            "perception needs a camera with depth: set camera: {enabled: true, depth: true} "
            f"and a description with a camera sensor ({robot_source})",
        )
    name = config.camera or next(iter(cameras))
    if name not in cameras:
        raise _error(
            where,
            f"perception: camera={config.camera!r} is not a camera of the world "
            f"(cameras: {', '.join(cameras)})",
        )
    camera = cameras[name]
    if camera.depth_image is None:
        raise _error(where, "perception needs depth images: camera.depth is false")
    added = _add_pipeline(builder, config, name, camera)
    _add_views_and_log(builder, config, added, meshcat, output_dir)
    _log.info(
        "perception on camera %r at %g Hz in the %s frame: %s",
        name,
        config.rate,
        config.frame,
        ", ".join(type(step).__name__ for step in config.steps) or "no steps",
    )
    if publications is not None:
        publications.add(*PerceptionSource(added, camera).table())
    return added


def _add_pipeline(builder, config: PerceptionConfig, name: str, camera) -> AddedPerception:
    """Point clouds of ``camera`` (in its frame and the world's) and the pipeline."""
    # Depth to point cloud, coloured, in the camera frame and in the world frame.
    depth_camera = camera.sensor.default_depth_render_camera().core()
    fields = BaseField.kXYZs | BaseField.kRGBs
    converters = {}
    for frame in ("camera", "world"):
        converter = builder.AddNamedSystem(
            f"{name}_points_in_{frame}",
            DepthImageToPointCloud(
                camera_info=depth_camera.intrinsics(),
                pixel_type=PixelType.kDepth32F,
                scale=1.0,
                fields=fields,
            ),
        )
        builder.Connect(camera.depth_image, converter.GetInputPort("depth_image"))
        builder.Connect(camera.color_image, converter.GetInputPort("color_image"))
        converters[frame] = converter
    pose = builder.AddNamedSystem(
        f"{name}_pose_in_world", CameraPoseInWorld(X_BC=depth_camera.sensor_pose_in_camera_body())
    )
    builder.Connect(
        camera.sensor.GetOutputPort("body_pose_in_world"), pose.GetInputPort("body_pose_in_world")
    )
    camera_pose = pose.GetOutputPort("camera_pose")
    builder.Connect(camera_pose, converters["world"].GetInputPort("camera_pose"))

    # The pipeline at its rate, just after a camera frame.
    offset = UPDATE_OFFSET_FRACTION / camera.info.frame_rate
    pipeline = builder.AddNamedSystem(
        "perception",
        PointCloudPerception(
            steps=config.steps, rate=config.rate, offset=offset, frame=config.frame
        ),
    )
    builder.Connect(
        converters[config.frame].GetOutputPort("point_cloud"), pipeline.GetInputPort("point_cloud")
    )
    if config.frame == "world":
        builder.Connect(camera_pose, pipeline.GetInputPort("camera_pose"))
    read_color(camera, config.rate, offset)  # the cloud's colour, at the pipeline's rate
    added = AddedPerception(
        config=config,
        camera=name,
        points_in_camera=converters["camera"].GetOutputPort("point_cloud"),
        points_in_world=converters["world"].GetOutputPort("point_cloud"),
        camera_pose=camera_pose,
        pipeline=pipeline,
        offset=offset,
    )
    builder.ExportOutput(added.points_in_camera, f"{name}.points_in_camera")
    builder.ExportOutput(added.points_in_world, f"{name}.points_in_world")
    builder.ExportOutput(camera_pose, f"{name}.camera_pose")
    builder.ExportOutput(added.result, "perception.result")
    return added


def _add_views_and_log(builder, config, added: AddedPerception, meshcat, output_dir) -> None:
    """The Meshcat layers (when someone watches) and ``clusters.json`` (``output_dir``)."""
    camera_pose, offset, name = added.camera_pose, added.offset, added.camera
    # Meshcat layers, when someone watches (a Meshcat kept only for a replay is not).
    watched = meshcat is not None and not getattr(meshcat, "recording_only", False)
    if watched and config.meshcat:
        added.visualizer = builder.AddNamedSystem(
            "perception_visualizer",
            PerceptionVisualizer(
                meshcat=meshcat, rate=config.rate, offset=2 * offset, point_size=config.point_size
            ),
        )
        builder.Connect(added.result, added.visualizer.GetInputPort("result"))
        if config.frame == "camera":
            builder.Connect(camera_pose, added.visualizer.GetInputPort("camera_pose"))
    if output_dir is not None:
        steps = [dict(type=type(s).__name__, **dataclasses.asdict(s)) for s in config.steps]
        added.log = builder.AddNamedSystem(
            "clusters_log",
            ClustersLog(
                path=Path(output_dir) / "clusters.json",
                rate=config.rate,
                offset=2 * offset,
                header={"camera": name, "frame": config.frame, "rate": config.rate, "steps": steps},
            ),
        )
        builder.Connect(added.result, added.log.GetInputPort("result"))
