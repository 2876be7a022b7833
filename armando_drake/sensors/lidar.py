"""Planar lidars (Gazebo's ``gpu_lidar``, ``lidar``, ``gpu_ray``, ``ray``) from rendered depth.

A description's lidar block (:mod:`armando_drake.description.lidar_sensors`) becomes
one :class:`LidarScanner`: at its ``<update_rate>`` (a periodic discrete update) it
renders a ring of 1-pixel-high depth images around the sensor's z axis with Drake's
``RenderEngineVtk`` (headless, through EGL) and turns them into a
``sensor_msgs/LaserScan`` (:class:`~armando_drake.messages.scans.LaserScan`), as
Gazebo's ``gpu_lidar`` renders its scan. Its output ``scan`` is a
:class:`~armando_drake.messages.types.Publication` of the latest scan, exported by
the sensor registry as ``<sensor name>.scan``.

Why rendering: Drake 1.51's ``QueryObject`` has no ray-cast query. A ray caster of
our own (the scene's triangles cut by the scan plane, then 640 rays against the
segments, in numpy) took 17.7 ms a scan on the race field's meshes; the ring of four
depth cameras takes about 4.5 ms (rendering cost hardly depends on the width), and
sees every shape the cameras see (primitives, OBJ, glTF) with no code per shape.

Geometry of the ring: the scan's span is cut into ``ceil(span / 90 deg)`` equal
sectors, one pinhole camera each (the beams evenly spaced in angle, the pixels evenly
spaced in tangent). Each camera has at least two pixels per beam; a beam's range
comes from the depth of the two pixels around its direction: for a plane, the
inverse depth is linear across the image, so interpolating it is exact on flat
surfaces; across a depth edge (neighbours more than 5 % apart) the nearer pixel is
taken. The depth image holds z-depth along the camera's axis; the range along a beam
at angle phi off that axis is ``z / cos(phi)``.

Ranges follow Gazebo (REP 117): ``inf`` where nothing is within ``range_max``,
``-inf`` where something is nearer than ``range_min``. The cameras' near clipping
plane is at ``range_min``: what is nearer than that along a camera's axis is not
seen at all (the robot's own body, as Gazebo's clipping sphere hides it); toward a
sector's edge the clipped band reaches ``range_min / cos(45 deg)``. ``<noise
type="gaussian">`` adds ``mean + stddev * N(0, 1)`` to each finite range, drawn from a
generator seeded by the sensor's name and the scan's number (the same every run).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    ClippingRange,
    DepthRange,
    DepthRenderCamera,
    MakeRenderEngineGl,
    MakeRenderEngineVtk,
    QueryObject,
    RenderCameraCore,
    RenderEngineGlParams,
    RenderEngineVtkParams,
    SceneGraph,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.sensors import CameraInfo

from armando_drake.description.camera_sensors import R_SC
from armando_drake.description.lidar_sensors import LIDAR_SENSOR_TYPES, LidarInfo, parse_lidar
from armando_drake.description.loader import LoadedRobot
from armando_drake.description.urdf import SensorBlock
from armando_drake.messages.definitions import laser_scan_message
from armando_drake.messages.publications import Topic
from armando_drake.messages.scans import LaserScan
from armando_drake.messages.types import Publication, PublicationValue
from armando_drake.sensors.camera_scene import CAMERA_SCENE, SceneFor
from armando_drake.sensors.image_view import PUBLISH_OFFSET_FRACTION
from armando_drake.sensors.registry import register_sensor
from armando_drake.tools.errors import ScenarioError

_log = logging.getLogger("armando_drake.world")

# The SceneGraph renderer every lidar renders with.
LIDAR_RENDERER = "armando_lidar"
GL_RENDERER = "gl"  # the name the cameras give Drake's OpenGL engine (camera_config's default)
# The widest sector one camera of the ring covers.
MAX_SECTOR = math.pi / 2  # [rad]
# Pixels per beam at a camera's centre (at least), and the widest image.
PIXELS_PER_BEAM = 2
MAX_WIDTH = 4096  # [px]
# Neighbouring depths further apart than this fraction are an edge (no interpolation).
EDGE_FRACTION = 0.05
# [m] a ground robot's lidar is below this: one higher (or below the world's z = 0) whose
# first scan sees nothing is warned about (a base_xyz or <origin> off by a unit, say).
MAX_LIDAR_HEIGHT = 3.0


class _Sector:
    """One camera of the ring and the beams it measures."""

    def __init__(self, info: LidarInfo, yaw: float, half_fov: float, beams: np.ndarray):
        increment = info.angle_increment or math.radians(1.0)
        focal = max(PIXELS_PER_BEAM / increment, 50.0)
        width = math.ceil(2.0 * focal * math.tan(half_fov)) + 3
        if width > MAX_WIDTH:
            focal *= (MAX_WIDTH - 3) / (width - 3)
            width = MAX_WIDTH
        self.width, self.focal, self.cx = width, focal, (width - 1) / 2.0
        # Near plane at range_min (what is nearer is not seen), far beyond range_max.
        near = max(info.range_min, 1e-3)
        far = info.range_max * 1.01 + 0.01
        core = RenderCameraCore(
            LIDAR_RENDERER,
            # Drake's renderers put the optical axis at (cx - 1/2, cy - 1/2) in the
            # image's pixel-centre coordinates (measured on a wall seen at 30 deg): this
            # centres it between columns (W - 1) / 2 and on the single row.
            CameraInfo(width, 1, focal, focal, width / 2.0, 0.5),
            ClippingRange(near, far),
            RigidTransform(),
        )
        self.camera = DepthRenderCamera(core, DepthRange(near * 1.0001, far * 0.9999))
        # The camera in the sensor frame S: turned by yaw about S's z, Drake's convention.
        self.X_SC = RigidTransform(RotationMatrix.MakeZRotation(yaw) @ R_SC)
        self.beams = beams  # indices into the scan
        phi = info.angle_min + beams * info.angle_increment - yaw  # off the camera axis
        self.u = self.cx - focal * np.tan(phi)  # pixel coordinate of each beam
        self.i0 = np.clip(np.floor(self.u).astype(int), 0, width - 2)
        self.w = self.u - self.i0
        self.inv_cos = 1.0 / np.cos(phi)

    def ranges(self, depth: np.ndarray) -> np.ndarray:
        """[m] the range of each of this sector's beams from a depth row (0: too near,
        inf: too far)."""
        z0, z1 = depth[self.i0], depth[self.i0 + 1]
        nearest = np.where(self.w < 0.5, z0, z1)
        with np.errstate(divide="ignore", invalid="ignore"):
            smooth = (
                (z0 > 0)
                & (z1 > 0)
                & np.isfinite(z0)
                & np.isfinite(z1)
                & (np.abs(z0 - z1) <= EDGE_FRACTION * np.minimum(z0, z1))
            )
            interpolated = 1.0 / ((1.0 - self.w) / z0 + self.w / z1)
        z = np.where(smooth, interpolated, nearest)
        return np.where(z > 0, z * self.inv_cos, -np.inf)


def ring(info: LidarInfo) -> list[_Sector]:
    """The cameras that cover the scan, each with its beams."""
    beams = np.arange(info.beams)
    span = info.angle_max - info.angle_min
    count = max(1, math.ceil(span / MAX_SECTOR - 1e-9))
    sector = span / count
    # A margin of a few pixels: the outermost beams fall inside the image.
    half_fov = sector / 2 + max(info.angle_increment, math.radians(0.5))
    which = np.zeros(info.beams, dtype=int)
    if sector > 0:
        which = np.minimum(((beams * info.angle_increment) // sector).astype(int), count - 1)
    yaws = info.angle_min + (np.arange(count) + 0.5) * sector
    return [_Sector(info, yaws[k], half_fov, beams[which == k]) for k in range(count)]


class LidarScanner(LeafSystem):
    """A planar lidar on a body: its scan from rendered depth at its update rate.

    Ports:
      - input ``geometry_query`` (QueryObject, from the SceneGraph that renders: the
        plant's, or the cameras' own, where the body's frame is ``render_frame_id``)
      - output ``scan`` (:class:`Publication` of :class:`LaserScan`, state: reading it
        renders nothing)
    """

    def __init__(
        self, info: LidarInfo, *, body_frame_id, X_BS: RigidTransform, render_frame_id=None
    ):
        super().__init__()
        self.info = info
        self.body_frame_id = body_frame_id  # the body's frame in the plant's scene graph
        # Its frame in the scene graph the query comes from (the cameras' own, or the same).
        self._frame = body_frame_id if render_frame_id is None else render_frame_id
        self._sectors = ring(info)
        self._X_BC = [X_BS @ sector.X_SC for sector in self._sectors]
        self._X_BS = X_BS
        self._query = self.DeclareAbstractInputPort(
            "geometry_query", AbstractValue.Make(QueryObject())
        )
        state = self.DeclareAbstractState(PublicationValue())
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / info.update_rate, 0.0, self._update)
        self.DeclareStateOutputPort("scan", state)

    def get_query_input_port(self):
        return self._query

    def scan_ranges(self, query, count: int = 0) -> np.ndarray:
        """[m] the ranges of one scan from the scene ``query`` holds (noise of scan
        number ``count``)."""
        info = self.info
        ranges = np.empty(info.beams)
        for sector, X_BC in zip(self._sectors, self._X_BC, strict=True):
            image = query.RenderDepthImage(sector.camera, self._frame, X_BC)
            ranges[sector.beams] = sector.ranges(np.asarray(image.data, dtype=float).ravel())
        hit = np.isfinite(ranges)
        if info.noise is not None and info.noise.stddev + abs(info.noise.mean) > 0:
            rng = np.random.default_rng((info.seed, count))
            noise = info.noise.mean + info.noise.stddev * rng.standard_normal(int(hit.sum()))
            ranges[hit] += noise
        ranges[hit & (ranges < info.range_min)] = -np.inf
        ranges[ranges > info.range_max] = np.inf
        return ranges

    def _warn_if_misplaced(self, query) -> None:
        """Warns, naming the sensor and its height, when a first scan that saw nothing was
        taken over :data:`MAX_LIDAR_HEIGHT` above the world's z = 0 or below it."""
        height = float((query.GetPoseInWorld(self._frame) @ self._X_BS).translation()[2])
        if 0.0 <= height <= MAX_LIDAR_HEIGHT:
            return
        info = self.info
        where = "above" if height > 0 else "below"
        _log.warning(
            "%s: lidar %r on link %r sees nothing in its first scan: it is %.3g m %s the "
            "world's floor (z = 0), where a ground robot's lidar is 0 to %g m up: check the "
            "robot's base_xyz and the sensor's <origin>/<pose>",
            info.source or "the description", info.name, info.link, abs(height), where,
            MAX_LIDAR_HEIGHT,
        )  # fmt: skip

    def _update(self, context, state) -> None:
        previous: Publication = context.get_abstract_state(0).get_value()
        stamp = context.get_time()
        query = self._query.Eval(context)
        ranges = self.scan_ranges(query, previous.count)
        if previous.count == 0 and not np.isfinite(ranges).any():
            self._warn_if_misplaced(query)
        ranges.flags.writeable = False
        info = self.info
        scan = LaserScan(
            stamp=stamp,
            frame_id=info.frame_id,
            angle_min=info.angle_min,
            angle_max=info.angle_max,
            angle_increment=info.angle_increment,
            scan_time=1.0 / info.update_rate,
            range_min=info.range_min,
            range_max=info.range_max,
            ranges=ranges,
        )
        state.get_mutable_abstract_state(0).set_value(previous.publish(scan, stamp))


def _scene_graph(builder: DiagramBuilder) -> SceneGraph:
    for system in builder.GetSystems():
        if isinstance(system, SceneGraph) and not system.get_name().startswith(CAMERA_SCENE):
            return system
    raise ScenarioError("a lidar needs a SceneGraph in the diagram (AddMultibodyPlant)")


def _engine(scene_graph: SceneGraph):
    """The lidar's depth renderer: VTK through EGL, or Drake's OpenGL engine when the
    world's cameras render with it (an EGL context beside their GLX one fails to be made
    current, and the process then dies of an X error)."""
    if scene_graph.HasRenderer(GL_RENDERER):
        return MakeRenderEngineGl(RenderEngineGlParams())
    return MakeRenderEngineVtk(RenderEngineVtkParams())


def AddLidar(
    builder: DiagramBuilder, info: LidarInfo, *, plant: MultibodyPlant, robot: LoadedRobot
) -> LidarScanner:
    """The scanner of ``info`` on its link of ``robot``, fed by the diagram's SceneGraph
    (which gets the lidar renderer the first time): the world's when the cameras render
    with OpenGL, else the cameras' own (:mod:`~armando_drake.sensors.camera_scene`)."""
    scene_graph = _scene_graph(builder)
    if not plant.HasBodyNamed(info.link, robot.model_instance):
        raise ScenarioError(
            f'{info.source}: <gazebo reference="{info.link}"><sensor name="{info.name}">: '
            f"{info.link!r} is not a link of {robot.name!r}"
        )
    body = plant.GetBodyByName(info.link, robot.model_instance)
    frame = plant.GetBodyFrameIdOrThrow(body.index())
    renders, render_frame = scene_graph, frame  # OpenGL cameras' engine: the world's
    if not scene_graph.HasRenderer(GL_RENDERER):
        # VTK on the world's scene graph would cost at every plant step: the cameras' own
        # scene graph (the same geometry, its poses read only when a scan renders); a
        # lidar inside a convex visual (its housing) gets a mirror without that visual,
        # which VTK would draw from inside where Gazebo culls its back faces.
        p_F = info.X_LS.translation()
        scene = SceneFor(builder, scene_graph, frame, p_F, info.range_min, ("lidar", info.name))
        renders, render_frame = scene.scene_graph, scene.frame(frame)
    if not renders.HasRenderer(LIDAR_RENDERER):
        renders.AddRenderer(LIDAR_RENDERER, _engine(scene_graph))
    scanner = builder.AddSystem(
        LidarScanner(info, body_frame_id=frame, X_BS=info.X_LS, render_frame_id=render_frame)
    )
    scanner.set_name(f"lidar_{info.name}")
    builder.Connect(renders.get_query_output_port(), scanner.get_query_input_port())
    return scanner


class Lidar:
    """The sensor registry's entry for the lidar types (:data:`LIDAR_SENSOR_TYPES`)."""

    @staticmethod
    def add(
        builder: DiagramBuilder, block: SensorBlock, *, plant: MultibodyPlant, robot: LoadedRobot
    ) -> dict[str, OutputPort]:
        info = parse_lidar(block)
        scanner = AddLidar(builder, info, plant=plant, robot=robot)
        _log.info("lidar %s on %s: %s, topic %s", info.name, info.link, info.describe(), info.topic)
        return {"scan": scanner.GetOutputPort("scan")}

    @staticmethod
    def topics(outputs: dict[str, OutputPort], *, namespace: str = "") -> list[Topic]:
        """Its scan on ``<namespace>/<topic>`` (``/scan``), a sensor_msgs/LaserScan, its
        frames after ``<namespace>/`` as the robot's links are named on /tf."""
        port = outputs["scan"]
        info = port.get_system().info
        space = namespace.strip("/")
        topic = f"{namespace.rstrip('/')}/{info.topic.lstrip('/')}"
        period = 1.0 / info.update_rate
        return [
            Topic(topic, "sensor_msgs/msg/LaserScan", port=port, read=_scan_read(space),
                  rate=info.update_rate, offset=PUBLISH_OFFSET_FRACTION * period)
        ]  # fmt: skip


def _scan_read(space: str):
    """The ``read`` of a scan port: each new scan as a LaserScan message stamped with
    its own stamp, its frame after ``<space>/`` (a robot of several)."""

    def read(publication: Publication, time: float):
        if publication.count <= 0:
            return None
        message = laser_scan_message(publication.message)
        if space:
            message["header"]["frame_id"] = f"{space}/{message['header']['frame_id']}"
        return message, publication.message.stamp, publication.count

    return read


for _type in LIDAR_SENSOR_TYPES:
    register_sensor(_type)(Lidar)
