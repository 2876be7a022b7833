"""A lidar's scan drawn in Meshcat: its hit points, redrawn at the scan rate.

:func:`AddScanViews` draws every ``sensor_msgs/msg/LaserScan`` row of the world's
publication table: a :class:`ScanView` reads the row's port and, a thousandth of a period
after each scan, sets the Meshcat object ``/drake/lidar/<sensor>`` to the scan's points
(those with a finite range) at the sensor's pose in the world (from the plant's body
poses). A few hundred points ten times a second: nothing at the plant's steps.
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import Meshcat, Rgba
from pydrake.math import RigidTransform
from pydrake.perception import PointCloud
from pydrake.systems.framework import LeafSystem

from armando_drake.messages.publications import Publications
from armando_drake.messages.types import PublicationValue
from armando_drake.sensors.image_view import PUBLISH_OFFSET_FRACTION

SCAN_PATH = "/drake/lidar"
SCAN_COLOUR = Rgba(1.0, 0.1, 0.1, 1.0)
POINT_SIZE = 0.03  # [m]
LASER_SCAN = "sensor_msgs/msg/LaserScan"


class ScanView(LeafSystem):
    """Draws one lidar's latest scan in Meshcat.

    Ports:
      - input ``scan`` (Publication of LaserScan);
      - input ``body_poses`` (the plant's body poses in the world).
    """

    def __init__(self, meshcat: Meshcat, *, name: str, body: int, X_BS, rate: float, poses):
        super().__init__()
        self._meshcat = meshcat
        self.path = f"{SCAN_PATH}/{name}"
        self._body, self._X_BS = body, X_BS
        self._scan = self.DeclareAbstractInputPort("scan", PublicationValue())
        self._poses = self.DeclareAbstractInputPort("body_poses", poses.Allocate())
        self._count = 0
        self.drawn = 0  # scans drawn so far
        period = 1.0 / rate
        self.DeclarePeriodicPublishEvent(period, PUBLISH_OFFSET_FRACTION * period, self._Draw)

    def _Draw(self, context) -> None:
        publication = self._scan.Eval(context)
        if publication.count <= self._count:
            return
        self._count = publication.count
        points = publication.message.points()
        cloud = PointCloud(points.shape[1])
        cloud.mutable_xyzs()[:] = points.astype(np.float32)
        X_WS: RigidTransform = self._poses.Eval(context)[self._body] @ self._X_BS
        self._meshcat.SetObject(self.path, cloud, POINT_SIZE, SCAN_COLOUR)
        self._meshcat.SetTransform(self.path, X_WS, context.get_time())
        self.drawn += 1


def AddScanViews(builder, table: Publications, plant, meshcat: Meshcat) -> list[ScanView]:
    """A :class:`ScanView` for every published ``sensor_msgs/msg/LaserScan`` row of
    ``table`` read from a port (a scanner with its ``info``: name, link pose, rate, and
    its ``body_frame_id`` in ``plant``'s scene graph)."""
    views, names = [], set()
    for topic in table.published(recorded=True, live=True):
        if topic.type_name != LASER_SCAN or topic.port is None:
            continue
        scanner = topic.port.get_system()
        info = scanner.info
        name = info.name if info.name not in names else topic.name.strip("/").replace("/", "_")
        names.add(name)
        body = plant.GetBodyFromFrameId(scanner.body_frame_id)
        view = builder.AddNamedSystem(
            f"scan_view_{name}",
            ScanView(
                meshcat,
                name=name,
                body=int(body.index()),
                X_BS=info.X_LS,
                rate=info.update_rate,
                poses=plant.get_body_poses_output_port(),
            ),
        )
        builder.Connect(topic.port, view.GetInputPort("scan"))
        builder.Connect(plant.get_body_poses_output_port(), view.GetInputPort("body_poses"))
        views.append(view)
    return views
