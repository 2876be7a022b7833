"""How well the vision loop does, against the truth the simulation knows.

- pointing error: the angle [rad] between the camera's optical axis (z of its frame
  C) and the direction from the camera to the marker (or a disc), from the plant's
  true poses;
- marker position error: the detector's latest estimate of the marker's position in
  the world minus the true one [m].
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.math import RigidTransform

from armando_drake.sensors.marker import ArucoMarker
from armando_drake.sensors.objects import Cylinder


def camera_pose(topics, context, camera: str) -> RigidTransform:
    """X_WC: the camera's true pose in the world (``topics``: the robot the scene's
    cameras report with, :class:`~armando_drake.simulation.robots.AddedRobot`, with its
    ``cameras``, ``plant`` and ``robot``; ``context``: the root context)."""
    info = topics.cameras[camera].info
    plant = topics.plant
    body = plant.GetBodyByName(info.link, topics.robot.model_instance)
    X_WL = body.EvalPoseInWorld(plant.GetMyContextFromRoot(context))
    return X_WL @ info.X_LC()


def marker_object(scenario):
    """The scenario's first ArUco marker object, or None."""

    for obj in scenario.objects:
        if isinstance(obj.shape, ArucoMarker):
            return obj
    return None


def true_marker_position(scenario) -> np.ndarray | None:
    """p_WM [m]: the centre of the first marker's face, or None without a marker."""
    obj = marker_object(scenario)
    if obj is None:
        return None
    return (obj.X_WO() @ obj.shape.X_OM()).translation()


def true_disc_position(scenario) -> np.ndarray | None:
    """p_WD [m]: the centre of the top face (+z) of the first cylinder object (the
    disc a blob target points at), or None without one."""

    for obj in scenario.objects:
        if isinstance(obj.shape, Cylinder):
            return obj.X_WO() @ np.array([0.0, 0.0, obj.shape.length / 2])
    return None


def pointing_error(topics, context, camera: str, p_W) -> float:
    """The angle [rad] between the camera's optical axis and the direction to ``p_W``
    (``topics``: as for :func:`camera_pose`)."""
    X_WC = camera_pose(topics, context, camera)
    direction = np.asarray(p_W, dtype=float) - X_WC.translation()
    direction /= np.linalg.norm(direction)
    axis = X_WC.rotation().matrix()[:, 2]
    return float(math.acos(np.clip(axis @ direction, -1.0, 1.0)))


def vision_summary(topics, diagram, context, scenario) -> dict | None:
    """summary.json's ``vision``: frames and detections of the detectors, the final
    pointing error at the marker (or, with a blob target, at the first disc) [rad] and
    the marker's estimated minus true position [m] (None where there is no marker or no
    estimate); with a dynamic look-at controller also ``max_path_error``, the camera's
    largest distance from its linear path [m]; None without detectors. ``topics``: the
    robot the scene reports with (:class:`~armando_drake.simulation.robots.AddedRobot`),
    ``diagram`` the world's diagram, ``context`` its root context."""
    detectors = topics.detectors
    if detectors is None:
        return None
    systems = [s for s in (detectors.blob, detectors.aruco) if s is not None]
    summary = {
        "frames": sum(s.frames for s in systems),
        "detections": sum(s.detections for s in systems),
        "detector_seconds_per_frame": (
            sum(s.seconds for s in systems) / max(1, sum(s.frames for s in systems))
        ),
        "final_pointing_error": None,
        "marker_position_error": None,
    }
    if detectors.aruco is None:
        # A blob target for the look-at-point controllers: the pointing error at the disc.
        p_WD = true_disc_position(scenario)
        if detectors.blob is not None and detectors.blob.target is not None and p_WD is not None:
            camera = detectors.blob_camera
            summary["final_pointing_error"] = pointing_error(topics, context, camera, p_WD)
        return summary
    for name in topics.stack.controllers:
        # A dynamic look-at controller: how far the camera strayed from its linear path.
        detail = diagram.GetOutputPort(f"{name}.status").Eval(context).detail
        if "max_path_error" in detail:
            summary["max_path_error"] = float(detail["max_path_error"])
    p_WM = true_marker_position(scenario)
    if p_WM is None:
        return summary
    camera = detectors.aruco_camera
    summary["final_pointing_error"] = pointing_error(topics, context, camera, p_WM)
    published = diagram.GetOutputPort(f"{camera}.marker_in_world").Eval(context)
    if published.count:
        error = published.message.pose.translation() - p_WM
        summary["marker_position_error"] = [float(e) for e in error]
    return summary
