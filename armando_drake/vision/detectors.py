"""OpenCV detectors on a camera's colour image, as Drake systems.

Both run in a periodic unrestricted update at the camera's rate (just after
each frame is held), keep what they found in their state and output it from
there, so reading their ports costs nothing and no Python runs per plant step.
The image processing is OpenCV's (``opencv-python-headless``), not ours:

- :class:`BlobDetector`: ``cv2.SimpleBlobDetector`` with the seed's parameters
  (thresholds 1..250 step 1, area >= 100 px, circularity >= 0.8) on the grey
  image, run once per distinct binary image rather than once per threshold
  (:mod:`armando_drake.vision.blobs`: the same keypoints); outputs the keypoints
  (pixel centre, diameter) and an annotated image (the keypoints drawn, ``cv2.drawKeypoints``);
- :class:`ArucoDetector`: ``cv2.aruco.ArucoDetector`` (AprilTag corners) then ``cv2.solvePnP``
  (IPPE_SQUARE or iterative, refined by LM) with the camera's own intrinsics; publishes the
  marker's pose in the camera frame (``cam_T_marker``, a :class:`MarkerPose`
  that also names the camera's link and mount, which is what the look-at-point
  controllers read) and in the world, and an annotated image (marker outline
  and axes). A frame without the marker publishes nothing.

Pixel coordinates follow OpenCV and Drake: (0, 0) is the centre of the top-left
pixel, u to the right, v down.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import EventStatus, LeafSystem
from pydrake.systems.sensors import ImageRgba8U

from armando_drake.messages.types import MarkerPose, Publication, PublicationValue
from armando_drake.sensors.marker import MarkerError, aruco_dictionary, dictionary_size
from armando_drake.tools.memo import LastResult
from armando_drake.vision.blobs import LevelBlobDetector

_log = logging.getLogger("armando_drake.vision")

# The detectors run this long after each frame is held [s], so they see that frame.
FRAME_DELAY = 1e-4


class DetectorError(ValueError):
    """A detector that cannot be built; the message names the key and the bad value."""


# --------------------------------------------------------------------------------------
# Messages


@dataclass(frozen=True)
class Keypoint:
    """One blob: its centre [px] (u right, v down) and diameter [px]."""

    u: float
    v: float
    diameter: float


@dataclass(frozen=True)
class BlobDetection:
    """What :class:`BlobDetector` found in one frame."""

    stamp: float = 0.0  # [s] time of the frame
    keypoints: tuple[Keypoint, ...] = ()

    def __deepcopy__(self, memo):
        return self


@dataclass(frozen=True)
class BlobTarget:
    """How :class:`BlobDetector` turns its largest keypoint into a target point for the
    look-at-point controllers: the ray through the keypoint's centre, at the distance
    where a blob of ``diameter`` [m] seen face on has the keypoint's diameter [px]."""

    K: np.ndarray  # [px] the camera's intrinsic matrix (3 x 3)
    diameter: float  # [m] the object's true diameter
    camera: str  # the camera's name
    link: str  # the link the camera is mounted on
    X_LC: RigidTransform  # the camera's optical frame in that link

    def point(self, keypoint: Keypoint) -> np.ndarray:
        """p_C [m]: the target point in the camera frame C (z forward, x right, y down)."""
        ray = np.linalg.solve(self.K, [keypoint.u, keypoint.v, 1.0])
        focal = math.sqrt(self.K[0, 0] * self.K[1, 1])
        return ray * (focal * self.diameter / max(keypoint.diameter, 1e-9))


def intrinsic_matrix(camera) -> np.ndarray:
    """K (3 x 3) [px] of an added camera's colour renderer, as Drake renders it."""
    intrinsics = camera.sensor.default_color_render_camera().core().intrinsics()
    return np.asarray(intrinsics.intrinsic_matrix(), dtype=float)


def _rgba_image(bgr: np.ndarray) -> ImageRgba8U:
    import cv2

    height, width = bgr.shape[:2]
    image = ImageRgba8U(width, height)
    # Converted straight into the image's memory: assigning through ``mutable_data[:]``
    # cost 2.8 ms a 640 x 480 frame here, this 0.35 ms.
    out = image.mutable_data
    converted = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGBA, dst=out)
    if converted is not out and not np.shares_memory(converted, out):
        out[:] = converted  # OpenCV allocated elsewhere after all
    return image


class BlobDetector(LeafSystem):
    """``cv2.SimpleBlobDetector`` on each frame of a colour image.

    .. pydrake_system::

        name: BlobDetector
        input_ports:
        - color_image
        output_ports:
        - keypoints
        - annotated_image
        - cam_T_target

    - ``color_image``: ImageRgba8U, held at the camera rate.
    - ``keypoints``: :class:`BlobDetection` of the latest frame.
    - ``annotated_image``: ImageRgba8U, the frame with the keypoints drawn.
    - ``cam_T_target`` (only with ``target``): Publication of :class:`MarkerPose`, the
      largest keypoint's point (:class:`BlobTarget`) in the camera frame (identity
      rotation), a new one for each frame with a keypoint: what the look-at-point
      controllers read.

    Runs every ``1 / frame_rate`` [s] (offset :data:`FRAME_DELAY`).
    """

    def __init__(
        self,
        *,
        width: int,
        height: int,
        frame_rate: float,
        min_threshold: float = 1.0,
        max_threshold: float = 250.0,
        threshold_step: float = 1.0,
        min_area: float = 100.0,
        min_circularity: float = 0.8,
        skip_repeated_thresholds: bool = True,
        target: BlobTarget | None = None,
        on_detection=None,
    ):
        super().__init__()
        import cv2

        if not frame_rate > 0:
            raise DetectorError(f"frame_rate={frame_rate!r} must be positive")
        params = cv2.SimpleBlobDetector_Params()
        params.minThreshold = float(min_threshold)
        params.maxThreshold = float(max_threshold)
        params.thresholdStep = float(threshold_step)
        params.filterByArea = True
        params.minArea = float(min_area)
        params.maxArea = float(width * height)
        params.filterByCircularity = True
        params.minCircularity = float(min_circularity)
        params.filterByConvexity = False
        params.filterByInertia = False
        self._detector = cv2.SimpleBlobDetector_create(params)
        self._levels = LevelBlobDetector(params) if skip_repeated_thresholds else None
        self._on_detection = on_detection
        self.frames = 0  # frames processed (a statistic, not state)
        self.detections = 0  # frames with at least one keypoint
        self.seconds = 0.0  # [s] wall-clock time spent in OpenCV
        self.last_frame = LastResult()  # the last frame's keypoints, for a frame the same
        self.history: list[BlobDetection] = []  # every frame's keypoints (keypoints.csv)
        self._input = self.DeclareAbstractInputPort(
            "color_image", AbstractValue.Make(ImageRgba8U(width, height))
        )
        self._keypoints = self.DeclareAbstractState(AbstractValue.Make(BlobDetection()))
        self._annotated = self.DeclareAbstractState(AbstractValue.Make(ImageRgba8U(width, height)))
        self.DeclareStateOutputPort("keypoints", self._keypoints)
        self.DeclareStateOutputPort("annotated_image", self._annotated)
        self._target = target
        # (time [s], target point in the camera frame [m]) of every frame with a target:
        # the run's vision.csv (a statistic kept beside the state, as the counts are).
        self.target_history: list[tuple[float, tuple[float, float, float]]] = []
        if target is not None:
            self._target_state = self.DeclareAbstractState(PublicationValue())
            self.DeclareStateOutputPort("cam_T_target", self._target_state)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / frame_rate, FRAME_DELAY, self._Update)

    @property
    def target(self) -> BlobTarget | None:
        """How keypoints become look-at targets; None when they do not."""
        return self._target

    def detect(self, bgr: np.ndarray) -> tuple[Keypoint, ...]:
        """The blobs of a BGR (or grey) image."""
        import cv2

        grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr
        if self._levels is not None:
            return tuple(Keypoint(u, v, d) for u, v, d in self._levels.detect(grey))
        found = self._detector.detect(grey)
        return tuple(Keypoint(float(k.pt[0]), float(k.pt[1]), float(k.size)) for k in found)

    def _Update(self, context, state) -> EventStatus:
        import time

        import cv2

        start = time.perf_counter()
        frame = np.asarray(self._input.Eval(context).data)
        known = self.last_frame.get(frame)
        if known is None:
            bgr = cv2.cvtColor(frame, cv2.COLOR_RGBA2BGR)
            keypoints = self.detect(bgr)
            annotated = _rgba_image(
                cv2.drawKeypoints(
                    bgr,
                    [cv2.KeyPoint(k.u, k.v, k.diameter) for k in keypoints],
                    None,
                    (0, 0, 255),
                    cv2.DRAW_MATCHES_FLAGS_DRAW_RICH_KEYPOINTS,
                )
            )
            self.last_frame.put((keypoints, annotated), frame)
        else:
            keypoints, annotated = known
        self.seconds += time.perf_counter() - start
        self.frames += 1
        self.detections += bool(keypoints)
        detection = BlobDetection(stamp=context.get_time(), keypoints=keypoints)
        self.history.append(detection)
        state.get_mutable_abstract_state(self._keypoints).set_value(detection)
        state.get_mutable_abstract_state(self._annotated).set_value(annotated)
        if self._target is not None and keypoints:
            target = self._target
            largest = max(keypoints, key=lambda k: k.diameter)
            point = target.point(largest)
            self.target_history.append((detection.stamp, tuple(float(c) for c in point)))
            pose = RigidTransform(point)
            message = MarkerPose(
                stamp=detection.stamp,
                frame_id=target.camera,
                pose=pose,
                link=target.link,
                X_LC=target.X_LC,
            )
            previous: Publication = context.get_abstract_state(self._target_state).get_value()
            state.get_mutable_abstract_state(self._target_state).set_value(
                previous.publish(message, stamp=detection.stamp)
            )
        if self._on_detection is not None:
            self._on_detection(detection)
        return EventStatus.Succeeded()


class ArucoDetector(LeafSystem):
    """ArUco detection and pose estimation on each frame of a colour image.

    .. pydrake_system::

        name: ArucoDetector
        input_ports:
        - color_image
        - body_poses
        output_ports:
        - cam_T_marker
        - marker_in_world
        - annotated_image

    - ``color_image``: ImageRgba8U, held at the camera rate.
    - ``body_poses``: the plant's body poses (for the camera's pose in the world).
    - ``cam_T_marker``: Publication of :class:`MarkerPose` (in the camera frame),
      a new one for each frame where the marker is found.
    - ``marker_in_world``: Publication of :class:`MarkerPose` (``frame_id`` world).
    - ``annotated_image``: ImageRgba8U, the frame with the marker's outline and axes.
    """

    def __init__(
        self,
        *,
        width: int,
        height: int,
        frame_rate: float,
        K: np.ndarray,
        dictionary: str,
        marker_id: int,
        side_length: float,
        camera: str,
        link: str,
        link_body_index: int,
        X_LC: RigidTransform,
    ):
        super().__init__()
        import cv2

        try:
            self._dictionary = aruco_dictionary(dictionary)
        except MarkerError as error:
            raise DetectorError(str(error)) from None
        size = dictionary_size(self._dictionary)
        if not 0 <= marker_id < size:
            raise DetectorError(
                f"marker_id={marker_id!r} is outside dictionary {dictionary} (ids 0..{size - 1})"
            )
        if not side_length > 0:
            raise DetectorError(f"side_length={side_length!r} must be positive [m]")
        if not frame_rate > 0:
            raise DetectorError(f"frame_rate={frame_rate!r} must be positive")
        parameters = cv2.aruco.DetectorParameters()
        # AprilTag's corner refinement: on our renders at 0.5 m, 8 random poses gave at most
        # 0.95 mm and 0.96 degrees of error, against 3.3 mm and 3.6 degrees with SUBPIX.
        # OpenCV 5's AprilTag refinement may hand the corners back rotated by a multiple of
        # 90 degrees (seen on a marker square to the image), so their order is taken from a
        # detection without refinement (see estimate()).
        parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_APRILTAG
        self._detector = cv2.aruco.ArucoDetector(self._dictionary, parameters)
        self._coarse = cv2.aruco.ArucoDetector(self._dictionary, cv2.aruco.DetectorParameters())
        self._K = np.asarray(K, dtype=float)
        self._marker_id = int(marker_id)
        self._side = float(side_length)
        half = self._side / 2
        # OpenCV's corner order: top-left, top-right, bottom-right, bottom-left (M frame).
        self._object_points = np.array(
            [[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]], dtype=float
        )
        self._camera, self._link, self._X_LC = camera, link, X_LC
        self._body = int(link_body_index)
        self.frames = 0
        self.detections = 0
        # (time [s], marker position in the camera frame [m]) of every detection: the
        # run's vision.csv (a statistic kept beside the state, as the counts are).
        self.history: list[tuple[float, tuple[float, float, float]]] = []
        self.seconds = 0.0  # [s] wall-clock time in OpenCV
        self.last_frame = LastResult()  # the last frame's marker pose, for a frame the same
        self._input = self.DeclareAbstractInputPort(
            "color_image", AbstractValue.Make(ImageRgba8U(width, height))
        )
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", AbstractValue.Make([RigidTransform()])
        )
        self._camera_state = self.DeclareAbstractState(PublicationValue())
        self._world_state = self.DeclareAbstractState(PublicationValue())
        self._annotated = self.DeclareAbstractState(AbstractValue.Make(ImageRgba8U(width, height)))
        self.DeclareStateOutputPort("cam_T_marker", self._camera_state)
        self.DeclareStateOutputPort("marker_in_world", self._world_state)
        self.DeclareStateOutputPort("annotated_image", self._annotated)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / frame_rate, FRAME_DELAY, self._Update)

    def estimate(self, bgr: np.ndarray) -> tuple[RigidTransform | None, Any]:
        """X_CM of the marker in a BGR image (None if not found) and the corners found."""
        import cv2

        grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
        corners, ids, _ = self._coarse.detectMarkers(grey)
        if ids is None:
            return None, corners
        for k, marker_id in enumerate(np.asarray(ids).reshape(-1)):
            if int(marker_id) != self._marker_id:
                continue
            image_points = np.asarray(corners[k], dtype=float).reshape(4, 2)
            image_points = self._refine(grey, image_points)
            rvec, tvec = self._solve(image_points)
            if rvec is None:
                return None, corners
            R, _ = cv2.Rodrigues(rvec)
            return RigidTransform(RotationMatrix(R), np.asarray(tvec).reshape(3)), corners
        return None, corners

    def _solve(self, image_points: np.ndarray):
        """(rvec, tvec) of the marker from its corners: the candidates of IPPE_SQUARE
        and of the iterative method (IPPE_SQUARE alone can return a wrong pose, with
        78 px of reprojection error, for a marker seen exactly square on), the one that
        reprojects best, refined by Levenberg-Marquardt; (None, None) if none fits."""
        import cv2

        candidates = []
        for flags in (cv2.SOLVEPNP_IPPE_SQUARE, cv2.SOLVEPNP_ITERATIVE):
            count, rvecs, tvecs, errors = cv2.solvePnPGeneric(
                self._object_points, image_points, self._K, np.zeros(5), flags=flags
            )
            for k in range(count):
                candidates.append((float(np.ravel(errors)[k]), rvecs[k], tvecs[k]))
        if not candidates:
            return None, None
        error, rvec, tvec = min(candidates, key=lambda candidate: candidate[0])
        if not np.isfinite(error) or error > 5.0:  # [px] RMS: not this marker's square
            return None, None
        rvec, tvec = cv2.solvePnPRefineLM(
            self._object_points, image_points, self._K, np.zeros(5), rvec, tvec
        )
        return rvec, tvec

    def _refine(self, grey: np.ndarray, coarse: np.ndarray) -> np.ndarray:
        """The refined corners of the marker at ``coarse`` (4 x 2 [px]) in ``grey``, in
        the coarse corners' order; ``coarse`` itself when the refined detection missed
        it. The refined detection runs on the marker's box with a margin of half its
        size: the part of the image its corners are refined from, at a fraction of the
        cost of the whole frame."""
        height, width = grey.shape
        low, high = coarse.min(axis=0), coarse.max(axis=0)
        margin = 0.5 * float((high - low).max()) + 8.0  # [px]
        x0, y0 = (max(int(v - margin), 0) for v in low)
        x1, y1 = min(int(high[0] + margin) + 1, width), min(int(high[1] + margin) + 1, height)
        refined, refined_ids, _ = self._detector.detectMarkers(grey[y0:y1, x0:x1])
        refined_ids = [] if refined_ids is None else np.asarray(refined_ids).reshape(-1)
        best, best_distance = coarse, np.inf
        for k, marker_id in enumerate(refined_ids):
            if int(marker_id) != self._marker_id:
                continue
            points = np.asarray(refined[k], dtype=float).reshape(4, 2) + (x0, y0)
            for shift in range(4):
                rolled = np.roll(points, shift, axis=0)
                distance = float(np.abs(rolled - coarse).max())
                if distance < best_distance:
                    best, best_distance = rolled, distance
        return best if best_distance < 3.0 else coarse  # [px]

    def _Update(self, context, state) -> EventStatus:
        import time

        import cv2

        start = time.perf_counter()
        frame = np.asarray(self._input.Eval(context).data)
        known = self.last_frame.get(frame)
        if known is None:
            bgr = cv2.cvtColor(frame, cv2.COLOR_RGBA2BGR)
            X_CM, corners = self.estimate(bgr)
            annotated = bgr.copy()
            if corners:
                cv2.aruco.drawDetectedMarkers(annotated, corners)
            if X_CM is not None:
                rvec, _ = cv2.Rodrigues(X_CM.rotation().matrix())
                cv2.drawFrameAxes(
                    annotated, self._K, np.zeros(5), rvec, X_CM.translation(), self._side / 2
                )
            annotated = _rgba_image(annotated)
            self.last_frame.put((X_CM, annotated), frame)
        else:
            X_CM, annotated = known
        self.seconds += time.perf_counter() - start
        self.frames += 1
        state.get_mutable_abstract_state(self._annotated).set_value(annotated)
        if X_CM is None:
            return EventStatus.Succeeded()
        self.detections += 1
        now = context.get_time()
        self.history.append((now, tuple(float(c) for c in X_CM.translation())))
        common = dict(stamp=now, marker_id=self._marker_id, link=self._link, X_LC=self._X_LC)
        in_camera = MarkerPose(frame_id=self._camera, pose=X_CM, **common)
        previous: Publication = context.get_abstract_state(self._camera_state).get_value()
        state.get_mutable_abstract_state(self._camera_state).set_value(
            previous.publish(in_camera, stamp=now)
        )
        if self._poses.HasValue(context):
            X_WL = self._poses.Eval(context)[self._body]
            in_world = MarkerPose(frame_id="world", pose=X_WL @ self._X_LC @ X_CM, **common)
            previous = context.get_abstract_state(self._world_state).get_value()
            state.get_mutable_abstract_state(self._world_state).set_value(
                previous.publish(in_world, stamp=now)
            )
        return EventStatus.Succeeded()


# --------------------------------------------------------------------------------------
@dataclasses.dataclass
class AddedDetectors:
    """What :func:`AddDetectors` added."""

    blob: BlobDetector | None = None
    aruco: ArucoDetector | None = None
    blob_camera: str = ""
    aruco_camera: str = ""
    commands: Any = None  # VectorLogSink of the desired state, with a look-at controller
    marker_goal: Any = None  # the MarkerGoal, with an aruco detector and a navigation
    command_joints: list = dataclasses.field(default_factory=list)  # its joints' names
    # The controllers the marker's pose drives (the look-at controllers), by YAML name.
    driven: list = dataclasses.field(default_factory=list)
    # What it logs: "velocity" (desired state [q; v], v logged) or "effort" (torques).
    command_kind: str = "velocity"
    # Annotated image output ports, by camera name.
    annotated: dict = dataclasses.field(default_factory=dict)
