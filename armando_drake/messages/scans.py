"""sensor_msgs/LaserScan, as the lidar sensors publish it on their ``scan`` port."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class LaserScan:
    """One planar scan: ``ranges[i]`` is the distance along the beam at angle
    ``angle_min + i * angle_increment`` (counter-clockwise about the frame's z axis,
    0 along its x axis); ``inf`` where nothing is within ``range_max``, ``-inf``
    where something is nearer than ``range_min`` (as Gazebo publishes, after REP 117).
    """

    stamp: float = 0.0  # [s] simulation time of the scan (header.stamp)
    frame_id: str = ""  # the frame the angles are measured in
    angle_min: float = 0.0  # [rad] angle of the first beam
    angle_max: float = 0.0  # [rad] angle of the last beam
    angle_increment: float = 0.0  # [rad] between beams
    time_increment: float = 0.0  # [s] between beams (all beams at once here)
    scan_time: float = 0.0  # [s] between scans
    range_min: float = 0.0  # [m]
    range_max: float = 0.0  # [m]
    ranges: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [m] one per beam (read only)
    intensities: np.ndarray = field(
        default_factory=lambda: np.zeros(0)
    )  # empty: no intensities are simulated

    def __deepcopy__(self, memo):
        return self  # immutable: see armando_drake/messages/types.py

    def angles(self) -> np.ndarray:
        """[rad] the angle of each beam."""
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges))

    def points(self) -> np.ndarray:
        """(3, N) the hit points in the scan's frame (beams with a finite range only)."""
        angles, ranges = self.angles(), np.asarray(self.ranges)
        hit = np.isfinite(ranges)
        return np.vstack(
            [ranges[hit] * np.cos(angles[hit]), ranges[hit] * np.sin(angles[hit]), 0 * ranges[hit]]
        )

    def hits(self) -> int:
        """How many beams returned a finite range."""
        return int(np.count_nonzero(np.isfinite(self.ranges)))

    def describe(self) -> str:
        """One line: beams, field of view, ranges."""
        span = math.degrees(self.angle_max - self.angle_min)
        limits = f"{self.range_min:g}..{self.range_max:g} m"
        return f"{len(self.ranges)} beams over {span:.1f} deg, {limits}"
