"""The detectors added to a world (:func:`AddDetectors`): on the scenario's cameras, feeding
the look-at controllers of the robot they act on and its navigation's marker goal, their
topics registered."""

from __future__ import annotations

import logging
import math
from types import SimpleNamespace
from typing import Any

from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from armando_drake.control.stack import ControlStack
from armando_drake.messages.publications import PublicationRegistry
from armando_drake.messages.types import MarkerPose
from armando_drake.sensors.camera import read_color
from armando_drake.sensors.image_view import AddImageView, ImageViewServer
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.extras import require_extra
from armando_drake.vision.config import VisionConfig
from armando_drake.vision.detectors import (
    FRAME_DELAY,
    AddedDetectors,
    ArucoDetector,
    BlobDetection,
    BlobDetector,
    BlobTarget,
    DetectorError,
    intrinsic_matrix,
)
from armando_drake.vision.marker_goal import AddMarkerGoal
from armando_drake.vision.topics import MarkerFrameSource, VisionSource

_log = logging.getLogger("armando_drake.vision")


class _KeypointPrinter:
    """Prints a frame's keypoints once a second of simulated time."""

    def __init__(self, camera: str):
        self._camera, self._next = camera, 0.0

    def __call__(self, detection: BlobDetection) -> None:
        if detection.stamp + 1e-9 < self._next:
            return
        self._next = detection.stamp + 1.0
        found = ", ".join(
            f"({k.u:.1f}, {k.v:.1f}) px, diameter {k.diameter:.1f} px" for k in detection.keypoints
        )
        print(f"t={detection.stamp:.2f} s {self._camera} keypoints: {found or 'none'}", flush=True)


def _camera(cameras, name: str, key: str, where: str):
    if name in cameras:
        return cameras[name]
    known = ", ".join(cameras) or "none: is camera.enabled on, or a cameras: entry there?"
    raise DetectorError(
        f"{where}vision.{key}.camera={name!r} is not a camera of the world ({known})"
    )


def _set_start_positions(stack: ControlStack, positions, where: str) -> None:
    """The hardware joints start at ``positions`` [rad] (hardware order); velocity and
    effort joints only (position servos hold their description's initial positions)."""
    hardware = stack.hardware
    if len(positions) != len(hardware.joints):
        raise DetectorError(
            f"{where}vision.start_positions={positions!r} must have {len(hardware.joints)} "
            f"values ({', '.join(hardware.joint_names)})"
        )
    for joint, value in zip(hardware.joints, positions, strict=True):
        if joint.command_interface == "position":
            # Its controllers were built holding the description's initial position.
            raise DetectorError(
                f"{where}vision.start_positions: joint {joint.name!r} takes position commands, "
                "which hold the description's initial positions: set those instead (e.g. "
                "robot.xacro_args initial_j0..)"
            )
        if not joint.lower <= value <= joint.upper:
            raise DetectorError(
                f"{where}vision.start_positions: {value!r} of joint {joint.name!r} is outside "
                f"its limits [{joint.lower:.4g}, {joint.upper:.4g}]"
            )
        plant_joint = stack.plant.GetJointByName(joint.name, stack.robot.model_instance)
        plant_joint.set_default_positions([value])


def _feed_look_at(builder, stack: ControlStack, added: AddedDetectors, port, info) -> None:
    """Connects ``port`` (a Publication of :class:`MarkerPose`) to every active
    controller that reads one (the look-at-point controllers); their commands are
    logged (C++ VectorLogSink) at the camera rate for vision.csv: the joint velocities
    (desired state) of the kinematic ones, the torques of the dynamic ones (effort)."""
    for name in stack.taking(MarkerPose):
        entry, manager = stack.entry(name), stack.controllers[name]
        builder.Connect(port, stack.command_input(name))
        added.driven.append(name)
        if added.commands is None:
            effort = entry.controller_class.command_interface(entry.params) == "effort"
            source = "effort_command" if effort else "desired_state"
            added.commands = LogVectorOutput(
                manager.GetOutputPort(source), builder, 1.0 / info.frame_rate
            )
            added.commands.set_name("vision_command_log")
            added.command_joints = list(stack.hardware.joint_names)
            added.command_kind = "effort" if effort else "velocity"


def AddDetectors(
    builder: DiagramBuilder,
    config: VisionConfig,
    stack: ControlStack,
    *,
    cameras: dict,
    image_view: ImageViewServer | None = None,
    where: str = "",
    console: bool = True,
    navigation: Any = None,
    publications: PublicationRegistry | None = None,
) -> AddedDetectors:
    """The scenario's detectors (``config``) on ``cameras`` (by name, as
    :func:`~armando_drake.sensors.cameras.AddCameras` returns them); exports
    ``<camera>.keypoints``, ``<camera>.cam_T_marker``, ``<camera>.marker_in_world`` and
    ``<camera>.annotated_image``, and feeds ``cam_T_marker`` to every active controller
    of ``stack`` that reads :class:`MarkerPose`; the annotated images join the live view
    ``image_view``. Without ``console`` the blob keypoints are not printed whatever
    ``print_keypoints`` says. With a ``navigation``, the ArUco marker is put on its map
    and the robot sent in front of it (:mod:`armando_drake.vision.marker_goal`).
    ``publications``: where their topics are registered (:mod:`armando_drake.vision.topics`).
    Errors: :class:`ScenarioError` naming ``where``; without OpenCV,
    :class:`~armando_drake.tools.extras.MissingExtraError` naming the extra."""
    for key in ("blob", "aruco"):
        if getattr(config, key) is not None:
            require_extra("vision", f"{where}vision.{key}")
    try:
        added = AddedDetectors()
        if config.start_positions:
            _set_start_positions(stack, config.start_positions, where)
        if config.blob is not None:
            _add_blob(builder, config, stack, cameras, added, where, console)
        if config.aruco is not None:
            _add_aruco(builder, config.aruco, stack, cameras, added, where)
            if navigation is not None:
                added.marker_goal = AddMarkerGoal(
                    builder,
                    added.aruco,
                    navigation=navigation,
                    plant=stack.plant,
                    link_body=stack.plant.GetBodyByName(
                        cameras[added.aruco_camera].info.link, stack.robot.model_instance
                    ),
                    rate=cameras[added.aruco_camera].info.frame_rate,
                    offset=2 * FRAME_DELAY,
                    config=config.aruco,
                )
    except DetectorError as error:
        raise ScenarioError(str(error)) from None
    for name, port in added.annotated.items():
        builder.ExportOutput(port, f"{name}.annotated_image")
    if image_view is not None:
        # The live camera view shows each annotated image beside its camera's raw one.
        views = {
            f"{name}_annotated": SimpleNamespace(
                info=cameras[name].info, color_image=port, depth_image=None
            )
            for name, port in added.annotated.items()
        }
        AddImageView(builder, views, server=image_view, depth=False)
    if publications is not None:
        publications.add(*VisionSource(added, cameras).table())
        if added.marker_goal is not None:
            rate = cameras[added.aruco_camera].info.frame_rate
            space = stack.namespace.strip("/")
            publications.add(*MarkerFrameSource(added.marker_goal, rate, space).table())
    return added


def _add_blob(builder, config, stack, cameras, added: AddedDetectors, where, console) -> None:
    """The blob detector of ``config.blob`` (and its look-at target, if it has one)."""
    blob = config.blob
    camera = _camera(cameras, blob.camera, "blob", where)
    info = camera.info
    target = None
    if blob.target_diameter < 0 or not math.isfinite(blob.target_diameter):
        raise DetectorError(
            f"{where}vision.blob.target_diameter={blob.target_diameter!r} must be >= 0 [m]"
        )
    if blob.target_diameter > 0:
        if config.aruco is not None:
            raise DetectorError(
                f"{where}vision: blob.target_diameter={blob.target_diameter!r} and an "
                "aruco detector both give the look-at-point controllers a target; keep one"
            )
        target = BlobTarget(
            K=intrinsic_matrix(camera),
            diameter=blob.target_diameter,
            camera=info.name,
            link=info.link,
            X_LC=info.X_LC(),
        )
    added.blob = builder.AddNamedSystem(
        f"blob_detector_{info.name}",
        BlobDetector(
            width=info.width,
            height=info.height,
            frame_rate=info.frame_rate,
            min_threshold=blob.min_threshold,
            max_threshold=blob.max_threshold,
            threshold_step=blob.threshold_step,
            min_area=blob.min_area,
            min_circularity=blob.min_circularity,
            skip_repeated_thresholds=blob.skip_repeated_thresholds,
            target=target,
            on_detection=(
                _KeypointPrinter(info.name) if blob.print_keypoints and console else None
            ),
        ),
    )
    added.blob_camera = info.name
    builder.Connect(camera.color_image, added.blob.GetInputPort("color_image"))
    read_color(camera, info.frame_rate, FRAME_DELAY)
    builder.ExportOutput(added.blob.GetOutputPort("keypoints"), f"{info.name}.keypoints")
    added.annotated[info.name] = added.blob.GetOutputPort("annotated_image")
    if target is not None:
        port = added.blob.GetOutputPort("cam_T_target")
        builder.ExportOutput(port, f"{info.name}.cam_T_target")
        _feed_look_at(builder, stack, added, port, info)


def _add_aruco(builder, aruco, stack, cameras, added: AddedDetectors, where) -> None:
    """The ArUco detector of ``aruco`` (its marker's pose feeds the look-at controllers)."""
    camera = _camera(cameras, aruco.camera, "aruco", where)
    info = camera.info
    plant = stack.plant
    body = plant.GetBodyByName(info.link, stack.robot.model_instance)
    try:
        detector = ArucoDetector(
            width=info.width,
            height=info.height,
            frame_rate=info.frame_rate,
            K=intrinsic_matrix(camera),
            dictionary=aruco.dictionary,
            marker_id=aruco.marker_id,
            side_length=aruco.side_length,
            camera=info.name,
            link=info.link,
            link_body_index=int(body.index()),
            X_LC=info.X_LC(),
        )
    except DetectorError as error:
        raise DetectorError(f"{where}vision.aruco: {error}") from None
    added.aruco = builder.AddNamedSystem(f"aruco_detector_{info.name}", detector)
    added.aruco_camera = info.name
    builder.Connect(camera.color_image, detector.GetInputPort("color_image"))
    read_color(camera, info.frame_rate, FRAME_DELAY)
    builder.Connect(plant.get_body_poses_output_port(), detector.GetInputPort("body_poses"))
    builder.ExportOutput(detector.GetOutputPort("cam_T_marker"), f"{info.name}.cam_T_marker")
    builder.ExportOutput(detector.GetOutputPort("marker_in_world"), f"{info.name}.marker_in_world")
    if info.name in added.annotated:
        raise DetectorError(
            f"{where}vision: blob and aruco detectors both on camera {info.name!r}; "
            "give them different cameras"
        )
    added.annotated[info.name] = detector.GetOutputPort("annotated_image")
    _feed_look_at(builder, stack, added, detector.GetOutputPort("cam_T_marker"), info)
