"""``cv2.SimpleBlobDetector``'s result at a fraction of its cost, exactly.

SimpleBlobDetector binarises the grey image at every threshold ``t`` of
``minThreshold, minThreshold + step, ... < maxThreshold`` (``cv2.threshold``,
THRESH_BINARY: a pixel is white when its grey level is above ``floor(t)``), finds
the blobs of each binary image (contours, then the area / circularity / inertia /
convexity / colour filters), groups the centres of successive thresholds that lie
close together, and returns, for each group seen at least ``minRepeatability``
times, the confidence-weighted mean of its centres and twice its median radius.

A binary image only changes when ``floor(t)`` passes a grey level that the image
has. A rendered frame has few of them (7 or 8 in ``vision_blob.yaml``'s view,
against 249 thresholds), so :class:`LevelBlobDetector` runs OpenCV's own
detector once per *distinct* binary image (a single-threshold detector: the same
contours and filters, nothing of ours) and repeats that threshold's centres for
every threshold that gives the same binary image, through a copy of OpenCV's
grouping (``SimpleBlobDetectorImpl::detect`` in ``features2d/src/blobdetector.cpp``:
the distance test against each group's middle centre, the insertion by radius, the
weighted mean). Same centres in the same order give the same keypoints; the only
difference is that a centre comes back from OpenCV as a ``KeyPoint`` (float32,
about 1e-5 px). An image with every grey level costs what OpenCV costs.
"""

from __future__ import annotations

import math

import numpy as np


class LevelBlobDetector:
    """``detect(grey)`` returns what ``cv2.SimpleBlobDetector_create(params).detect(grey)``
    returns (as ``(u, v, diameter)`` tuples [px]), running OpenCV once per distinct
    binary image instead of once per threshold.

    ``params`` is a ``cv2.SimpleBlobDetector_Params``; no mask.
    """

    def __init__(self, params):
        import cv2

        self._params = params
        # The thresholds exactly as OpenCV's loop makes them (float fields, double sum).
        start, stop = float(np.float32(params.minThreshold)), float(np.float32(params.maxThreshold))
        step = float(np.float32(params.thresholdStep))
        if not step > 0:
            raise ValueError(f"thresholdStep={params.thresholdStep!r} must be positive")
        thresholds = []
        t = start
        while t < stop:
            thresholds.append(t)
            t += step
        # cv2.threshold on 8-bit images compares with floor(t), clamped to the 8-bit range.
        self._levels = np.array([min(max(math.floor(t), -1), 255) for t in thresholds], dtype=int)
        self._single: dict[int, object] = {}  # OpenCV detector at one threshold, by level
        self._cv2 = cv2
        # With filterByInertia OpenCV weighs each centre by its squared inertia ratio,
        # which a KeyPoint does not carry: then OpenCV's detector runs as it is.
        self._plain = cv2.SimpleBlobDetector_create(params) if params.filterByInertia else None
        self.binary_images = 0  # distinct binary images of the last detect() (a statistic)

    def _at(self, level: int):
        """OpenCV's detector with the same filters at the single threshold ``level``."""
        detector = self._single.get(level)
        if detector is None:
            cv2 = self._cv2
            one = cv2.SimpleBlobDetector_Params()
            for name in dir(self._params):
                if not name.startswith("_") and not callable(getattr(self._params, name)):
                    setattr(one, name, getattr(self._params, name))
            one.minThreshold = float(level)
            one.maxThreshold = float(level) + 0.5  # the loop runs once, at ``level``
            one.thresholdStep = 1.0
            one.minRepeatability = 1
            detector = self._single[level] = cv2.SimpleBlobDetector_create(one)
        return detector

    def centres(self, grey: np.ndarray, level: int) -> list[tuple[float, float, float]]:
        """(x, y, radius) [px] of the blobs of ``grey`` binarised above ``level``, in
        OpenCV's order (a single threshold groups nothing)."""
        found = self._at(level).detect(grey)
        return [(float(k.pt[0]), float(k.pt[1]), float(k.size) / 2.0) for k in found]

    def detect(self, grey: np.ndarray) -> list[tuple[float, float, float]]:
        """The keypoints (u, v, diameter) [px] of an 8-bit grey image."""
        if grey.dtype != np.uint8 or grey.ndim != 2:
            raise ValueError(f"need an 8-bit grey image, not {grey.dtype} {grey.shape}")
        cv2 = self._cv2
        if self._plain is not None:
            self.binary_images = len(self._levels)
            found = self._plain.detect(grey)
            return [(float(k.pt[0]), float(k.pt[1]), float(k.size)) for k in found]
        histogram = cv2.calcHist([grey], [0], None, [256], [0, 256]).reshape(-1)
        # below[l + 1]: how many grey levels <= l the image has; two thresholds give the
        # same binary image when that count is the same.
        below = np.concatenate(([0], np.cumsum(histogram > 0)))
        params = self._params
        min_distance = float(np.float32(params.minDistBetweenBlobs))
        cache: dict[int, list[tuple[float, float, float]]] = {}
        groups: list[list[tuple[float, float, float]]] = []  # each sorted by radius
        for level in self._levels:
            key = int(below[level + 1])
            current = cache.get(key)
            if current is None:
                current = cache[key] = self.centres(grey, int(level))
            fresh = []
            for x, y, radius in current:
                new = True
                for group in groups:
                    mx, my, mr = group[len(group) // 2]
                    distance = math.hypot(mx - x, my - y)
                    new = distance >= min_distance and distance >= mr and distance >= radius
                    if not new:
                        # Insert after every centre whose radius is not larger (stable).
                        k = len(group)
                        while k > 0 and radius < group[k - 1][2]:
                            k -= 1
                        group.insert(k, (x, y, radius))
                        break
                if new:
                    fresh.append([(x, y, radius)])
            groups.extend(fresh)
        self.binary_images = len(cache)
        keypoints = []
        for group in groups:
            if len(group) < params.minRepeatability:
                continue
            # Without filterByInertia every centre has confidence 1: the plain mean.
            u = sum(c[0] for c in group) / len(group)
            v = sum(c[1] for c in group) / len(group)
            keypoints.append((u, v, float(np.float32(group[len(group) // 2][2] * 2.0))))
        return keypoints
