"""The planar lidar: a description's gpu_lidar block scans a wall at a known distance
as the analytic ray cast says, at its update rate; fra2mo's block parses to its figures."""

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from armando_drake.description.camera_sensors import CameraSensorInfo
from armando_drake.description.lidar_sensors import LidarError, parse_lidar
from armando_drake.description.loader import expand_description, load_robot
from armando_drake.description.packages import find_packages
from armando_drake.description.urdf import parse_sensor_blocks
from armando_drake.sensors import lidar  # noqa: F401  (registers the lidar types)
from armando_drake.sensors.camera import AddCameraSensors
from armando_drake.sensors.camera_scene import CAMERA_SCENE
from armando_drake.sensors.lidar import LIDAR_RENDERER
from armando_drake.sensors.objects import AddSceneObjects, Box, SceneObject
from armando_drake.sensors.registry import AddSensors
from armando_drake.tools.xdisplay import DisplayError, ensure_display
from tests.conftest import SHARED, skip_or_fail

FRA2MO = SHARED / "upstream" / "rl_fra2mo_description"

# A post with a lidar 0.3 m up, on a cylinder housing (radius 4 cm) the beams must not
# see; 360 beams over the full circle, 0.1..5 m, 10 Hz.
SCANNER_URDF = """<?xml version="1.0"?>
<robot name="scanner">
  <link name="base_link">
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <link name="laser">
    <visual><geometry><cylinder radius="0.04" length="0.06"/></geometry></visual>
    <inertial><mass value="0.1"/>
      <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="laser_joint" type="fixed">
    <parent link="base_link"/><child link="laser"/><origin xyz="0 0 0.3"/>
  </joint>
  <gazebo reference="laser">
    <sensor name="front_lidar" type="gpu_lidar">
      <update_rate>10</update_rate>
      <topic>scan</topic>
      <gz_frame_id>laser</gz_frame_id>
      <lidar>
        <scan><horizontal>
          <samples>360</samples><resolution>1</resolution>
          <min_angle>-3.14159</min_angle><max_angle>3.14159</max_angle>
        </horizontal></scan>
        <range><min>0.1</min><max>5.0</max><resolution>0.01</resolution></range>
        NOISE
      </lidar>
    </sensor>
  </gazebo>
</robot>
"""
WALL_X = 2.0  # [m] the wall's face, in front of the lidar (the post at x = 0)
WALL_HALF_WIDTH = 5.0  # [m]


def _scanner(
    tmp_path,
    noise: str = "",
    base_xyz=(0.0, 0.0, 0.0),
    yaw: float = 0.0,
    gl_camera=False,
    urdf: str = SCANNER_URDF,
):
    path = tmp_path / "scanner.urdf"
    path.write_text(urdf.replace("NOISE", noise))
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    robot = load_robot(plant, path, X_WB=RigidTransform(RollPitchYaw(0, 0, yaw), base_xyz))
    wall = SceneObject(
        name="wall",
        shape=Box(size=[0.1, 2 * WALL_HALF_WIDTH, 1.0]),
        xyz=[WALL_X + 0.05, 0.0, 0.5],
    )
    AddSceneObjects(plant, [wall])
    plant.Finalize()
    if gl_camera:  # a camera on Drake's OpenGL engine first, as a scenario's cameras are
        camera = CameraSensorInfo(name="cam", sensor_name="cam", type="camera", link="laser")
        AddCameraSensors(
            builder, plant, scene_graph, robot.model_instance, [camera], renderer="gl", export=True
        )
    added = AddSensors(builder, robot.sensors, plant=plant, robot=robot)
    assert list(added) == ["front_lidar"]
    diagram = builder.Build()
    return diagram, diagram.GetOutputPort("front_lidar.scan")


def _truth(angles: np.ndarray, x0: float = 0.0, y0: float = 0.0) -> np.ndarray:
    """The analytic ray cast from (x0, y0) at each world angle against the wall's face."""
    cos = np.cos(angles)
    with np.errstate(divide="ignore"):
        r = np.where(cos > 1e-9, (WALL_X - x0) / cos, np.inf)
    y = y0 + r * np.sin(angles)
    return np.where(np.isfinite(r) & (np.abs(y) <= WALL_HALF_WIDTH) & (r <= 5.0), r, np.inf)


def test_wall_scan_matches_the_ray_cast(tmp_path):
    """Every beam that hits is within the range resolution (1 cm) of the ray cast, and
    the beams whose ray cast is beyond range_max (or behind) are inf; the housing
    around the lidar is not seen."""
    diagram, port = _scanner(tmp_path)
    context = diagram.CreateDefaultContext()
    Simulator(diagram, context).AdvanceTo(0.0)
    publication = port.Eval(context)
    scan = publication.message
    assert publication.count == 1 and scan.stamp == 0.0
    assert len(scan.ranges) == 360 and scan.frame_id == "laser"
    assert scan.angle_increment == pytest.approx(2 * 3.14159 / 359)
    truth = _truth(scan.angles())
    hit = np.isfinite(truth)
    # The wall spans about +-66 deg before its ranges pass 5 m.
    assert 120 < hit.sum() < 140
    assert np.all(np.isfinite(scan.ranges[hit]))
    error = np.abs(scan.ranges[hit] - truth[hit])
    # Within the range resolution (1 cm); interpolated inverse depth is exact on a plane.
    assert error.max() < 1e-3, f"worst beam {np.argmax(error)}: {error.max():.4f} m"
    assert np.all(np.isposinf(scan.ranges[~hit])), "beyond range_max and behind: inf"


def test_a_vtk_lidar_renders_from_the_cameras_scene_graph_not_the_worlds(tmp_path):
    """VTK on the world's scene graph would get the poses at every plant step: the lidar
    renders from the mirror, whose poses are read only when it scans."""
    diagram, _ = _scanner(tmp_path)
    world = diagram.GetSubsystemByName("scene_graph")
    mirror = diagram.GetSubsystemByName(CAMERA_SCENE)
    assert mirror.HasRenderer(LIDAR_RENDERER) and not world.HasRenderer(LIDAR_RENDERER)
    (scanner,) = [s for s in diagram.GetSystems() if isinstance(s, lidar.LidarScanner)]
    query = scanner.get_query_input_port().get_index()
    (source, _) = diagram.connection_map()[(scanner, query)]
    assert source is mirror


def test_a_housing_beyond_range_min_around_the_lidar_is_seen_through(tmp_path):
    """A housing of 15 cm radius around a lidar whose range_min is 10 cm: Gazebo culls
    its back faces and scans the wall; VTK, which draws them, scans from a mirror without
    it (its own: the other sensors still see the housing)."""
    housing = SCANNER_URDF.replace('radius="0.04"', 'radius="0.15"')
    diagram, port = _scanner(tmp_path, urdf=housing)
    assert diagram.HasSubsystemNamed(f"{CAMERA_SCENE}_front_lidar")
    context = diagram.CreateDefaultContext()
    Simulator(diagram, context).AdvanceTo(0.0)
    scan = port.Eval(context).message
    truth = _truth(scan.angles())
    hit = np.isfinite(truth)
    assert np.abs(scan.ranges[hit] - truth[hit]).max() < 1e-3
    assert np.all(np.isposinf(scan.ranges[~hit]))  # not the housing at 0.15 m


def test_beside_a_camera_on_drakes_opengl_engine(tmp_path):
    """A world whose camera renders with RenderEngineGl (GLX): the lidar renders there
    too, its scan as exact as alone, and frames of both keep coming (a VTK EGL context
    beside the GLX one failed to be made current, then the process died of an X error)."""
    try:
        ensure_display()
    except DisplayError as error:
        skip_or_fail(f"Drake's OpenGL renderer needs an X display or Xvfb: {error}")
    diagram, port = _scanner(tmp_path, gl_camera=True)
    context = diagram.CreateDefaultContext()
    simulator = Simulator(diagram, context)
    for k in range(5):
        simulator.AdvanceTo(0.1 * k)
        image = diagram.GetOutputPort("cam.color_image").Eval(context)
        scan = port.Eval(context).message
        assert image.width() > 0 and np.asarray(image.data).any()
        truth = _truth(scan.angles())
        hit = np.isfinite(truth)
        assert 120 < hit.sum() < 140
        assert np.abs(scan.ranges[hit] - truth[hit]).max() < 1e-3
        assert np.all(np.isposinf(scan.ranges[~hit]))


def test_turned_and_moved_scanner(tmp_path):
    """The sensor turned by 30 deg and 0.5 m to the side: the ranges follow its pose."""
    yaw = math.radians(30)
    diagram, port = _scanner(tmp_path, base_xyz=(0.0, 0.5, 0.0), yaw=yaw)
    context = diagram.CreateDefaultContext()
    Simulator(diagram, context).AdvanceTo(0.0)
    scan = port.Eval(context).message
    truth = _truth(scan.angles() + yaw, y0=0.5)
    hit = np.isfinite(truth)
    assert hit.sum() > 100
    assert np.abs(scan.ranges[hit] - truth[hit]).max() < 0.01
    assert np.all(np.isposinf(scan.ranges[~hit]))


def test_scans_at_the_update_rate_with_seeded_noise(tmp_path):
    """0.45 s at 10 Hz: 5 scans stamped 0, 0.1, ..., 0.4; Gaussian noise of 2 cm shows
    in the ranges' spread, the same in a second run."""
    noise = "<noise type='gaussian'><mean>0.0</mean><stddev>0.02</stddev></noise>"
    results = []
    for _ in range(2):
        diagram, port = _scanner(tmp_path, noise=noise)
        context = diagram.CreateDefaultContext()
        simulator = Simulator(diagram, context)
        stamps = []
        for step in range(10):  # sample the port every 50 ms
            simulator.AdvanceTo(step * 0.05)
            publication = port.Eval(context)
            if not stamps or publication.count > len(stamps):
                stamps.append(publication.message.stamp)
        simulator.AdvanceTo(0.45)
        publication = port.Eval(context)
        assert publication.count == 5
        assert stamps == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
        scan = publication.message
        truth = _truth(scan.angles())
        hit = np.isfinite(truth) & (truth < 4.9)
        residual = scan.ranges[hit] - truth[hit]
        assert 0.015 < residual.std() < 0.025
        results.append(scan.ranges.copy())
    np.testing.assert_array_equal(results[0], results[1])


def test_fra2mo_lidar_block():
    """fra2mo's gpu_lidar: 640 samples over -3.14..3.14 rad, 0.1..10 m at 1 cm, 10 Hz,
    on laser_frame, topic lidar."""
    source = FRA2MO / "urdf" / "fra2mo.urdf.xacro"
    if not source.is_file():
        skip_or_fail(f"fra2mo's description is not at {FRA2MO}")
    search = find_packages(near=source)
    root = ET.fromstring(expand_description(source, {}, search))
    (block,) = [b for b in parse_sensor_blocks(root, source) if b.type == "gpu_lidar"]
    info = parse_lidar(block)
    assert (info.beams, info.angle_min, info.angle_max) == (640, -3.14, 3.14)
    assert math.degrees(info.angle_max - info.angle_min) == pytest.approx(359.8, abs=0.1)
    assert (info.range_min, info.range_max, info.range_resolution) == (0.1, 10.0, 0.01)
    assert (info.update_rate, info.link, info.frame_id, info.topic) == (
        10.0,
        "laser_frame",
        "laser_frame",
        "lidar",
    )
    assert info.noise is None


def test_bad_block_is_one_line(tmp_path):
    """A range whose max is not above its min is refused naming the file and the sensor."""
    text = SCANNER_URDF.replace("<max>5.0</max>", "<max>0.05</max>").replace("NOISE", "")
    root = ET.fromstring(text)
    (block,) = parse_sensor_blocks(root, "scanner.urdf")
    with pytest.raises(LidarError) as error:
        parse_lidar(block)
    message = str(error.value)
    assert "\n" not in message
    assert "scanner.urdf" in message and "front_lidar" in message and "<max>=0.05" in message
