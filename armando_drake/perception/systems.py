"""Perception in the world diagram: depth to point cloud, the pipeline at its rate, outputs.

:func:`AddPerception` adds, for the scenario's ``perception:`` block and one
camera of the world::

    depth_image, color_image ──> DepthImageToPointCloud ──> <camera>.points_in_camera
    sensor's body_pose_in_world ──> CameraPoseInWorld ──> <camera>.camera_pose (X_WC)
    depth_image, color_image, X_WC ──> DepthImageToPointCloud ──> <camera>.points_in_world
    points (world or camera frame) ──> PointCloudPerception ──> perception.result
    perception.result ──> PerceptionVisualizer (Meshcat layers), ClustersLog (clusters.json)

Both conversions are Drake's C++ ``DepthImageToPointCloud`` (coloured from the
camera's colour image); they run only when something reads them. The camera
pose comes from the plant at the time of the frame, so a camera on a moving
link gives world points that stay put. The pipeline is a periodic unrestricted
update at ``perception.rate`` (10 Hz by default), a thousandth of a camera
period after a frame is taken, so it sees the colour frame of that instant;
its result is the system's state, read by the Meshcat layers and the
``clusters.json`` log at publish events just after it, and by the MCAP
recorder (:mod:`armando_drake.outputs.recording`).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Meshcat, Rgba
from pydrake.math import RigidTransform
from pydrake.perception import PointCloud
from pydrake.systems.framework import Context, LeafSystem, OutputPort

from armando_drake.perception.config import (
    Clustering,
    PerceptionConfig,
    PlaneSegmentation,
    StatisticalOutlierRemoval,
)
from armando_drake.perception.pipeline import (
    NO_RESULT,
    PerceptionResult,
    PointCloudPipeline,
    finite,
    make_cloud,
)
from armando_drake.tools.memo import LastResult

_log = logging.getLogger("armando_drake.perception")

# The pipeline runs this fraction of a camera period after a frame is taken (the
# colour image is held at the camera rate: the frame of that instant is then held);
# its readers publish twice as late, after the update.
UPDATE_OFFSET_FRACTION = 1e-3
# The steps that need scikit-learn or SciPy (the "perception" extra).
SKLEARN_STEPS = (StatisticalOutlierRemoval, PlaneSegmentation, Clustering)
# Meshcat colours of the clusters, in order (Tableau 10), and of the plane's inliers.
CLUSTER_COLOURS = [
    (0.12, 0.47, 0.71),
    (1.00, 0.50, 0.05),
    (0.17, 0.63, 0.17),
    (0.84, 0.15, 0.16),
    (0.58, 0.40, 0.74),
    (0.55, 0.34, 0.29),
    (0.89, 0.47, 0.76),
    (0.50, 0.50, 0.50),
    (0.74, 0.74, 0.13),
    (0.09, 0.75, 0.81),
]
PLANE_COLOUR = Rgba(0.6, 0.6, 0.6, 1.0)
MESHCAT_PATH = "/perception"


def _result_value() -> AbstractValue:
    return AbstractValue.Make(NO_RESULT)


class CameraPoseInWorld(LeafSystem):
    """The pose of a camera's depth frame in the world, from its sensor body's pose.

    Computed when read (the world-frame conversion reads it once per frame).

    Ports:
      - input ``body_pose_in_world`` (RigidTransform X_WB): an ``RgbdSensor``'s
        sensor body pose in the world;
      - output ``camera_pose`` (RigidTransform X_WC = X_WB X_BC): the depth camera's
        frame C (x right, y down, z along the optical axis) in the world.
    """

    def __init__(self, *, X_BC: RigidTransform):
        super().__init__()
        self._X_BC = RigidTransform(X_BC)
        self._body = self.DeclareAbstractInputPort(
            "body_pose_in_world", AbstractValue.Make(RigidTransform())
        )
        self.DeclareAbstractOutputPort(
            "camera_pose", lambda: AbstractValue.Make(RigidTransform()), self._CalcPose
        )

    def _CalcPose(self, context: Context, output) -> None:
        output.set_value(self._body.Eval(context) @ self._X_BC)


def _cloud_key(cloud: PointCloud, viewpoint) -> list[np.ndarray]:
    """What a pipeline's result depends on: the cloud's fields and the viewpoint."""
    key = [cloud.xyzs(), np.asarray(viewpoint, dtype=np.float64)]
    if cloud.has_rgbs():
        key.append(cloud.rgbs())
    if cloud.has_normals():
        key.append(cloud.normals())
    return key


class PointCloudPerception(LeafSystem):
    """Runs a :class:`~armando_drake.perception.pipeline.PointCloudPipeline` at its own rate.

    Ports:
      - input ``point_cloud`` (PointCloud) in the pipeline's frame F;
      - input ``camera_pose`` (RigidTransform X_FC, optional): where the camera
        is, for the direction of plane and point normals; unconnected = F's
        origin (right for the camera frame);
      - output ``result`` (:class:`~armando_drake.perception.pipeline.PerceptionResult`,
        state): the last run's clouds, planes and clusters; ``result.time`` is
        NaN before the first run;
      - output ``filtered_point_cloud`` (PointCloud): the cloud the clustering
        step saw (the last one without clustering), from the state.

    A periodic unrestricted update every ``1 / rate`` seconds from ``offset``
    runs the steps; ``result.time`` is the frame's time, ``k / rate``. A frame whose
    cloud and camera position equal the last frame's, bit for bit, gets the last result
    (with its own time) without running the steps again: they are deterministic
    (RANSAC is seeded).
    """

    def __init__(self, *, steps, rate: float, offset: float = 0.0, frame: str = "world"):
        super().__init__()
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate={rate!r} must be positive [Hz]")
        self._pipeline = PointCloudPipeline(steps)
        self._pipeline.load_libraries()
        # The last cloud's key and result: a frame whose cloud is the same, bit for bit,
        # reuses it (a camera on a still scene); ``reuses`` counts those frames.
        self._last = LastResult()
        self._rate = rate
        self._frame = frame
        self._cloud = self.DeclareAbstractInputPort("point_cloud", AbstractValue.Make(PointCloud()))
        self._pose = self.DeclareAbstractInputPort(
            "camera_pose", AbstractValue.Make(RigidTransform())
        )
        self._state = self.DeclareAbstractState(_result_value())
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, offset, self._Update)
        self.DeclareStateOutputPort("result", self._state)
        self.DeclareAbstractOutputPort(
            "filtered_point_cloud",
            lambda: AbstractValue.Make(PointCloud()),
            self._CalcFiltered,
            prerequisites_of_calc={self.abstract_state_ticket(self._state)},
        )

    @property
    def reuses(self) -> int:
        """The frames answered with the last result (the same cloud, bit for bit)."""
        return self._last.hits

    @property
    def pipeline(self) -> PointCloudPipeline:
        return self._pipeline

    def _Update(self, context: Context, state) -> None:
        source = self._cloud.Eval(context)
        viewpoint = (
            self._pose.Eval(context).translation() if self._pose.HasValue(context) else np.zeros(3)
        )
        frame_time = math.floor(context.get_time() * self._rate + 1e-6) / self._rate
        key = _cloud_key(source, viewpoint)
        last = self._last.get(*key)
        if last is not None:
            # The same cloud from the same viewpoint: the steps (seeded) find the same.
            result = dataclasses.replace(last, time=float(frame_time))
        else:
            cloud = PointCloud(source)  # the stages keep it: a copy
            result = self._pipeline.run(
                cloud, viewpoint=viewpoint, time=frame_time, frame=self._frame
            )
            self._last.put(result, *key)
        state.get_mutable_abstract_state(self._state).set_value(result)

    def _CalcFiltered(self, context: Context, output) -> None:
        result = context.get_abstract_state(self._state).get_value()
        output.set_value(result.filtered if result.computed else PointCloud())


def _box_edges(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(start, end), each 3 x 12: the edges of the axis-aligned box."""
    corners = np.array(
        [[(upper if (k >> i) & 1 else lower)[i] for i in range(3)] for k in range(8)]
    )
    pairs = [(a, a | (1 << i)) for a in range(8) for i in range(3) if not (a >> i) & 1]
    start = np.array([corners[a] for a, _ in pairs]).T
    end = np.array([corners[b] for _, b in pairs]).T
    return np.asfortranarray(start, dtype=float), np.asfortranarray(end, dtype=float)


class PerceptionVisualizer(LeafSystem):
    """Draws the pipeline's clouds and clusters in Meshcat, each a layer of its own.

    Layers (toggle them under *Scene > perception*): ``raw`` (the input cloud,
    in the camera's colours), ``filtered`` (what the clustering saw, hidden at
    first), ``plane`` (the plane inliers, hidden at first), ``clusters/<k>``
    (cluster k in its own colour, with its axis-aligned box as ``box``).

    Ports:
      - input ``result`` (PerceptionResult);
      - input ``camera_pose`` (RigidTransform X_WF, optional): the pose of the
        pipeline's frame in the world (for a pipeline in the camera frame).

    A periodic publish event every ``1 / rate`` seconds from ``offset`` (and a
    forced publish) draws each new result.
    """

    def __init__(
        self, *, meshcat: Meshcat, rate: float, offset: float = 0.0, point_size: float = 0.003
    ):
        super().__init__()
        self._meshcat = meshcat
        self._point_size = point_size
        self._drawn_clusters = 0
        self._last_time = None
        self._result = self.DeclareAbstractInputPort("result", _result_value())
        self._pose = self.DeclareAbstractInputPort(
            "camera_pose", AbstractValue.Make(RigidTransform())
        )
        self.DeclarePeriodicPublishEvent(1.0 / rate, offset, self._Draw)
        self.DeclareForcedPublishEvent(self._Draw)  # diagram.ForcedPublish draws too
        for layer in ("filtered", "plane"):
            meshcat.SetProperty(f"{MESHCAT_PATH}/{layer}", "visible", False)

    def _Draw(self, context: Context) -> None:
        result: PerceptionResult = self._result.Eval(context)
        if not result.computed or result.time == self._last_time:
            return
        self._last_time = result.time
        meshcat, size = self._meshcat, self._point_size
        if self._pose.HasValue(context):
            meshcat.SetTransform(MESHCAT_PATH, self._pose.Eval(context))

        meshcat.SetObject(f"{MESHCAT_PATH}/raw", finite(result.stages[0].cloud), size)
        meshcat.SetObject(f"{MESHCAT_PATH}/filtered", result.filtered, size)
        if result.planes:
            inliers = np.vstack([plane.points for plane in result.planes])
            meshcat.SetObject(f"{MESHCAT_PATH}/plane", make_cloud(inliers), size, PLANE_COLOUR)
        else:
            meshcat.Delete(f"{MESHCAT_PATH}/plane")
        for k, cluster in enumerate(result.clusters):
            path = f"{MESHCAT_PATH}/clusters/{k}"
            rgba = Rgba(*CLUSTER_COLOURS[k % len(CLUSTER_COLOURS)], 1.0)
            meshcat.SetObject(path, make_cloud(cluster.points), 1.5 * size, rgba)
            start, end = _box_edges(cluster.lower, cluster.upper)
            meshcat.SetLineSegments(f"{path}/box", start, end, 2.0, rgba)
        for k in range(len(result.clusters), self._drawn_clusters):
            meshcat.Delete(f"{MESHCAT_PATH}/clusters/{k}")
        self._drawn_clusters = len(result.clusters)


class ClustersLog(LeafSystem):
    """Collects every pipeline result and writes ``clusters.json`` when closed.

    The file: ``{"camera", "frame", "rate", "steps", "frames"}``, one frame per
    pipeline run: ``time`` [s], ``planes`` (``coefficients`` [a, b, c, d] of
    a x + b y + c z + d = 0 with a unit normal towards the camera, ``inliers``),
    ``clusters`` (``centroid`` [m], ``box`` ``min``/``max`` [m], ``count``),
    coordinates in ``frame``.

    Ports:
      - input ``result`` (PerceptionResult), read by a periodic publish event
        every ``1 / rate`` seconds from ``offset``.
    """

    def __init__(
        self,
        *,
        path: str | os.PathLike,
        rate: float,
        offset: float = 0.0,
        header: dict[str, Any] | None = None,
    ):
        super().__init__()
        self._path = Path(path)
        self._header = dict(header or {})
        self._frames: list[dict[str, Any]] = []
        self._last_time = None
        self._result = self.DeclareAbstractInputPort("result", _result_value())
        self.DeclarePeriodicPublishEvent(1.0 / rate, offset, self._Collect)

    @property
    def frames(self) -> list[dict[str, Any]]:
        return list(self._frames)

    def _Collect(self, context: Context) -> None:
        result: PerceptionResult = self._result.Eval(context)
        if result.computed and result.time != self._last_time:
            self._last_time = result.time
            self._frames.append(result.as_dict())

    def close(self) -> None:
        """Writes the file (again, with every frame so far)."""
        document = dict(self._header, frames=self._frames)
        self._path.write_text(json.dumps(document, indent=1) + "\n", encoding="utf-8")


@dataclass
class AddedPerception:
    """What :func:`AddPerception` added."""

    config: PerceptionConfig
    camera: str  # the camera's name in the world
    points_in_camera: OutputPort  # PointCloud in the camera frame (z forward, y down)
    points_in_world: OutputPort  # PointCloud in the world frame
    camera_pose: OutputPort  # RigidTransform X_WC of the depth camera frame
    pipeline: PointCloudPerception  # its "result" port is the PerceptionResult
    offset: float  # [s] the pipeline's update offset; readers publish at 2 x this
    visualizer: PerceptionVisualizer | None = None
    log: ClustersLog | None = None

    @property
    def result(self) -> OutputPort:
        return self.pipeline.GetOutputPort("result")
