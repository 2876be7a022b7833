"""Camera sensor blocks, their Drake cameras, scene objects, the browser view and frame saving."""

import io
import json
import math
import subprocess
import urllib.error
import urllib.request
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np
import pytest
from browser import CHROMIUM_ARGS
from conftest import skip_or_fail
from PIL import Image
from pydrake.common.yaml import yaml_load_typed
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.sensors import ImageRgba8U

from armando_drake.description.camera_sensors import DEFAULT_FRAME_RATE, parse_camera_sensors
from armando_drake.description.loader import load_robot
from armando_drake.sensors.camera import AddCameraSensors, CameraColorNoise, CameraError
from armando_drake.sensors.image_view import (
    AddFrameSaver,
    AddImageView,
    ImageViewServer,
    depth_millimetres,
)
from armando_drake.sensors.objects import (
    AddSceneObjects,
    Box,
    Cylinder,
    SceneObject,
    SceneObjectError,
    Sphere,
)

# A camera on camera_link, as the Armando description declares it (Gazebo style).
SENSOR = """
<gazebo reference="camera_link">
  <sensor type="TYPE" name="camera">
    <update_rate>RATE</update_rate>
    <pose>POSE</pose>
    <camera>
      <horizontal_fov>FOV</horizontal_fov>
      <image><width>WIDTH</width><height>HEIGHT</height></image>
      <clip><near>NEAR</near><far>FAR</far></clip>
    </camera>
  </sensor>
</gazebo>
"""
DEFAULTS = dict(
    TYPE="camera", RATE="30", POSE="0 0 0 0 0 0", FOV="1.047", WIDTH="320", HEIGHT="240"
) | dict(NEAR="0.1", FAR="100")


def camera_urdf(sensor: str = SENSOR, **values) -> str:
    """A one-link robot: a small camera body with the sensor block on it."""
    for key, value in (DEFAULTS | values).items():
        sensor = sensor.replace(key, str(value))
    return f"""<?xml version="1.0"?>
<robot name="eye">
  <link name="camera_link">
    <visual><geometry><box size="0.02 0.04 0.02"/></geometry></visual>
    <inertial><mass value="0.05"/>
      <inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  {sensor}
</robot>
"""


# The camera link's pose in the world: tilted down and turned, away from the origin.
X_WL = RigidTransform(RollPitchYaw(0.0, 0.35, 0.3), [0.1, -0.2, 0.6])


@pytest.fixture(params=["vtk", "gl"])
def renderer(request):
    """Each of Drake's two renderers; "gl" on DISPLAY or a private Xvfb."""
    if request.param == "gl":
        from armando_drake.tools.xdisplay import DisplayError, ensure_display

        try:
            ensure_display()
        except DisplayError as error:
            skip_or_fail(f"no X display for RenderEngineGl: {error}")
    return request.param


def render(urdf: str, objects: list[SceneObject], *, time: float = 0.02, renderer="vtk"):
    """Builds plant + camera + objects, simulates ``time`` s; returns (info, color, depth)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.001)
    (model,) = Parser(plant).AddModelsFromString(urdf, "urdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("camera_link"), X_WL)
    AddSceneObjects(plant, objects)
    plant.Finalize()
    (info,) = parse_camera_sensors(ET.fromstring(urdf), "inline.urdf")
    cameras = AddCameraSensors(
        builder, plant, scene_graph, model, [info], renderer=renderer, export=True
    )
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(time)
    context = simulator.get_context()
    color = diagram.GetOutputPort("camera.color_image").Eval(context).data.copy()
    depth = diagram.GetOutputPort("camera.depth_image").Eval(context).data[:, :, 0].copy()
    assert set(cameras) == {"camera"}
    return info, color, depth


def sensor_pose(info) -> RigidTransform:
    """X_WS: the Gazebo sensor frame (x forward, y left, z up) in the world."""
    return X_WL @ RigidTransform(RollPitchYaw(info.rpy), info.xyz)


def project(info, p_S) -> tuple[float, float]:
    """Pinhole projection of a point in the sensor frame, in continuous pixel coordinates.

    Pixel (row i, column j) covers [j, j+1] x [i, i+1]; the optical axis hits
    the image centre (width/2, height/2). fx = fy = width / (2 tan(fov / 2)).
    """
    focal = info.width / (2 * math.tan(info.horizontal_fov / 2))
    forward, left, up = p_S
    return info.width / 2 - focal * left / forward, info.height / 2 - focal * up / forward


def mask_centroid(mask: np.ndarray) -> tuple[float, float]:
    rows, columns = np.nonzero(mask)
    return columns.mean() + 0.5, rows.mean() + 0.5


def red(color):
    return (color[:, :, 0] > 150) & (color[:, :, 1] < 80) & (color[:, :, 2] < 80)


def blue(color):
    return (color[:, :, 2] > 150) & (color[:, :, 0] < 80) & (color[:, :, 1] < 80)


def plate_in_front(info, p_S, *, thickness=0.02, side=0.1, name="plate", rgba=(1, 0, 0, 1)):
    """A square plate facing the camera: its centre at p_S in the sensor frame."""
    X_WO = sensor_pose(info) @ RigidTransform(p_S)
    return SceneObject(
        name=name,
        shape=Box(size=[thickness, side, side]),
        xyz=list(X_WO.translation()),
        rpy=list(RollPitchYaw(X_WO.rotation()).vector()),
        color=list(rgba),
    )


# --------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "fov, width, height",
    [(1.047, 320, 240), (0.7, 320, 240), (1.047, 480, 240)],
    ids=["gazebo-default", "narrow-fov", "wide-image"],
)
def test_object_appears_at_its_pinhole_projection(fov, width, height, renderer):
    urdf = camera_urdf(FOV=fov, WIDTH=width, HEIGHT=height, POSE="0.03 0.01 0.02 0 0.05 -0.04")
    (info,) = parse_camera_sensors(ET.fromstring(urdf))
    centre_S = np.array([1.0, 0.15, -0.1])  # ahead, to the left, below
    plate = plate_in_front(info, centre_S)
    info, color, depth = render(urdf, [plate], renderer=renderer)

    assert color.shape == (height, width, 4)
    face_S = centre_S - [0.01, 0, 0]  # the face towards the camera
    u, v = project(info, face_S)
    # The plate is left of and below the optical axis, so left of and below the image centre.
    assert u < width / 2 - 20 and v > height / 2 + 10
    mask = red(color)
    side_px = 0.1 * info.focal_length / face_S[0]
    assert mask.sum() == pytest.approx(side_px**2, rel=0.12)
    u_seen, v_seen = mask_centroid(mask)
    assert abs(u_seen - u) < 3 and abs(v_seen - v) < 3, (u_seen, v_seen, u, v)
    # Depth images hold the distance along the optical axis, to the face.
    assert depth[int(v), int(u)] == pytest.approx(face_S[0], abs=0.01)
    # Outside the plate the camera sees nothing within range.
    assert np.isinf(depth[2, width - 3])


def test_fov_and_width_move_the_projection_as_predicted(renderer):
    """The same plate lands where fx = width / (2 tan(fov/2)) says, for three cameras."""
    centre_S = np.array([1.2, -0.2, 0.12])  # to the right, above
    seen = {}
    for fov, width in [(1.047, 320), (0.6, 320), (1.047, 640)]:
        urdf = camera_urdf(FOV=fov, WIDTH=width)
        (info,) = parse_camera_sensors(ET.fromstring(urdf))
        info, color, _ = render(urdf, [plate_in_front(info, centre_S)], renderer=renderer)
        u_seen, v_seen = mask_centroid(red(color))
        u, v = project(info, centre_S - [0.01, 0, 0])
        assert abs(u_seen - u) < 3 and abs(v_seen - v) < 3
        seen[fov, width] = u_seen - width / 2
    # Offsets from the image centre scale with the focal length.
    focal = {key: key[1] / (2 * math.tan(key[0] / 2)) for key in seen}
    for key in [(0.6, 320), (1.047, 640)]:
        ratio = seen[key] / seen[1.047, 320]
        assert ratio == pytest.approx(focal[key] / focal[1.047, 320], rel=0.03)
        assert ratio > 1.5  # the change is real, not within the tolerance


def test_gazebo_to_drake_camera_frame():
    (info,) = parse_camera_sensors(ET.fromstring(camera_urdf()))
    R_LC = info.X_LC().rotation().matrix()
    np.testing.assert_allclose(R_LC[:, 2], [1, 0, 0])  # optical axis = link x (forward)
    np.testing.assert_allclose(R_LC[:, 0], [0, -1, 0])  # image right = -link y (left)
    np.testing.assert_allclose(R_LC[:, 1], [0, 0, -1])  # image down = -link z (up)
    assert RotationMatrix(R_LC).IsValid()


def test_blue_disc_in_view_gives_blue_pixels_in_the_expected_region(renderer):
    urdf = camera_urdf()
    (info,) = parse_camera_sensors(ET.fromstring(urdf))
    centre_S = np.array([1.0, 0.0, 0.0])
    X_WO = sensor_pose(info) @ RigidTransform(RollPitchYaw(0, math.pi / 2, 0), centre_S)
    disc = SceneObject(
        name="blue_disc",
        shape=Cylinder(radius=0.15, length=0.05),
        xyz=list(X_WO.translation()),
        rpy=list(RollPitchYaw(X_WO.rotation()).vector()),
        color=[0.0, 0.0, 1.0, 1.0],
    )
    info, color, depth = render(urdf, [disc], renderer=renderer)
    mask = blue(color)
    near_face = 1.0 - 0.025
    radius_px = 0.15 * info.focal_length / near_face
    assert mask.sum() == pytest.approx(math.pi * radius_px**2, rel=0.05)
    rows, columns = np.nonzero(mask)
    distance = np.hypot(columns + 0.5 - info.width / 2, rows + 0.5 - info.height / 2)
    assert distance.max() < radius_px + 1.5  # all blue is inside the predicted circle
    assert depth[info.height // 2, info.width // 2] == pytest.approx(near_face, abs=0.01)


def test_a_camera_inside_its_links_box_sees_through_it_as_gazebo_does(renderer):
    """rrbot's camera (gazebo_ros_demos) sits at the centre of its 5 cm camera_link box
    with its near plane at 2 cm: Gazebo and OpenGL cull the box's back faces."""
    boxed = camera_urdf(NEAR="0.02").replace('size="0.02 0.04 0.02"', 'size="0.05 0.05 0.05"')
    (info,) = parse_camera_sensors(ET.fromstring(boxed))
    centre_S = np.array([1.0, 0.1, 0.05])
    info, color, depth = render(boxed, [plate_in_front(info, centre_S)], renderer=renderer)
    u, v = project(info, centre_S - [0.01, 0, 0])
    mask = red(color)
    side_px = 0.1 * info.focal_length / 0.99
    assert mask.sum() == pytest.approx(side_px**2, rel=0.12)  # the plate, not the box
    u_seen, v_seen = mask_centroid(mask)
    assert abs(u_seen - u) < 3 and abs(v_seen - v) < 3
    assert depth[int(v), int(u)] == pytest.approx(0.99, abs=0.01)
    assert np.isinf(depth[2, 2])  # nothing at 2.5 cm: the box is not drawn


@pytest.mark.parametrize(
    "shape, inside, outside",
    [
        (("Box", 0.2, 0.4, 0.6), [0.09, -0.19, 0.29], [0.11, 0, 0]),
        (("Sphere", 0.1), [0.05, 0.05, 0.05], [0.06, 0.06, 0.06]),
        (("Cylinder", 0.1, 0.4), [0.07, -0.07, 0.19], [0.0, 0.0, 0.21]),
        (("Capsule", 0.1, 0.4), [0.0, 0.05, 0.28], [0.0, 0.08, 0.28]),
        (("Ellipsoid", 0.1, 0.2, 0.3), [0.0, 0.19, 0.0], [0.09, 0.0, 0.15]),
    ],
    ids=lambda value: value[0] if isinstance(value, tuple) else None,
)
def test_the_visuals_enclosing_a_point_are_the_convex_ones_holding_it(shape, inside, outside):
    import pydrake.geometry as geometry

    from armando_drake.sensors.camera_scene import enclosing

    scene_graph = geometry.SceneGraph()
    source = scene_graph.RegisterSource("test")
    frame = scene_graph.RegisterFrame(source, geometry.GeometryFrame("link"))
    X_FG = RigidTransform(RollPitchYaw(0.3, -0.2, 0.5), [0.5, -0.2, 0.1])
    kind, *sizes = shape
    instance = geometry.GeometryInstance(X_FG, getattr(geometry, kind)(*sizes), "visual")
    instance.set_perception_properties(geometry.PerceptionProperties())
    visual = scene_graph.RegisterGeometry(source, frame, instance)
    assert enclosing(scene_graph, frame, X_FG @ np.array(inside)) == [visual]
    assert enclosing(scene_graph, frame, X_FG @ np.array(outside)) == []


def test_camera_block_loaded_through_load_robot(tmp_path):
    path = tmp_path / "eye.urdf"
    path.write_text(camera_urdf(TYPE="rgbd_camera", RATE="15"))
    robot = load_robot(MultibodyPlant(time_step=0.001), path)
    (info,) = robot.cameras
    assert (info.name, info.link, info.type, info.frame_rate) == (
        "camera",
        "camera_link",
        "rgbd_camera",
        15.0,
    )
    assert info.has_depth and str(path) in info.source


def test_armando_camera_sees_the_arm():
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.001)
    robot = load_robot(plant)
    plant.Finalize()
    (info,) = robot.cameras
    assert (info.name, info.link, info.type) == ("camera", "camera_link", "camera")
    cameras = AddCameraSensors(builder, plant, scene_graph, robot.model_instance, robot.cameras)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    sensor = cameras["camera"].sensor
    sensor_context = sensor.GetMyContextFromRoot(context)
    color = sensor.GetOutputPort("color_image").Eval(sensor_context).data
    depth = sensor.GetOutputPort("depth_image_32f").Eval(sensor_context).data[:, :, 0]
    assert color.shape == (info.height, info.width, 4)
    # Something (the arm, its base) is in view, within a metre and beyond the near plane.
    seen = np.isfinite(depth)
    assert 0.01 * depth.size < seen.sum() < depth.size
    assert info.near < depth[seen].min() < 1.0
    assert len(np.unique(color[seen].reshape(-1, 4), axis=0)) > 10


# --------------------------------------------------------------------------
# Parsing: defaults, names, noise, errors
# --------------------------------------------------------------------------


def test_sdformat_defaults_and_topic_name():
    sensor = """<gazebo reference="camera_link"><sensor type="depth" name="kinect">
      <topic>/arm/camera</topic><camera/></sensor></gazebo>"""
    (info,) = parse_camera_sensors(ET.fromstring(camera_urdf(sensor)))
    assert (info.name, info.topic, info.sensor_name) == ("arm_camera", "/arm/camera", "kinect")
    assert (info.width, info.height, info.horizontal_fov) == (320, 240, 1.047)
    assert (info.near, info.far, info.update_rate) == (0.1, 100.0, 0.0)
    assert info.frame_rate == DEFAULT_FRAME_RATE == 30.0
    assert info.noise is None and info.xyz == [0, 0, 0]
    assert info.focal_length == pytest.approx(320 / (2 * math.tan(1.047 / 2)))


def test_other_sensor_types_are_ignored_and_noise_is_read():
    sensor = """<gazebo reference="camera_link">
      <sensor type="imu" name="imu"/>
      <sensor type="camera" name="cam"><camera><noise><type>gaussian</type>
        <mean>0.01</mean><stddev>0.007</stddev></noise></camera></sensor></gazebo>"""
    (info,) = parse_camera_sensors(ET.fromstring(camera_urdf(sensor)))
    assert info.name == "cam" and info.noise.mean == 0.01 and info.noise.stddev == 0.007


BAD = [
    (dict(WIDTH=0), "<image><width>=0 must be positive [px]"),
    (dict(HEIGHT=-5), "<image><height>=-5 must be positive [px]"),
    (dict(WIDTH="32.5"), "<image/width>='32.5' is not a whole number"),
    (dict(WIDTH="wide"), "<image/width>='wide' is not a number"),
    (dict(FOV=0), "<horizontal_fov>=0.0 must be in (0, 3.14159) [rad]"),
    (dict(FOV=3.2), "<horizontal_fov>=3.2 must be in (0, 3.14159) [rad]"),
    (dict(NEAR=0), "<clip><near>=0.0 must be positive [m]"),
    (dict(NEAR=2, FAR=2), "<clip><far>=2.0 must be greater than near=2.0"),
    (dict(NEAR=0.5, FAR=0.2), "<clip><far>=0.2 must be greater than near=0.5"),
    (dict(RATE=-1), "<update_rate>=-1.0 must be zero or positive [Hz]"),
    (dict(POSE="0 0 1"), "<pose>='0 0 1' is not 6 numbers"),
    (dict(FAR="inf"), "<clip><far>=inf is not a finite number"),
]


@pytest.mark.parametrize("values, message", BAD, ids=[m.split("=")[0] for _, m in BAD])
def test_bad_camera_values_are_rejected_with_file_and_value(values, message):
    with pytest.raises(CameraError) as error:
        parse_camera_sensors(ET.fromstring(camera_urdf(**values)), "robot.urdf.xacro")
    assert str(error.value).startswith("robot.urdf.xacro: camera sensor 'camera': ")
    assert message in str(error.value)


def test_reference_to_missing_link_is_rejected():
    sensor = SENSOR.replace('reference="camera_link"', 'reference="camera_lnk"')
    with pytest.raises(CameraError, match=r"reference='camera_lnk' is not a link of the URDF"):
        parse_camera_sensors(ET.fromstring(camera_urdf(sensor)), "robot.urdf")


def test_unsupported_noise_and_duplicate_names_are_rejected():
    noisy = SENSOR.replace("</camera>", "<noise><type>salt</type></noise></camera>")
    with pytest.raises(CameraError, match=r"<noise><type>='salt' is not supported"):
        parse_camera_sensors(ET.fromstring(camera_urdf(noisy)))
    with pytest.raises(CameraError, match=r"camera name 'camera' is used twice"):
        parse_camera_sensors(ET.fromstring(camera_urdf(SENSOR + SENSOR)))


# --------------------------------------------------------------------------
# Noise
# --------------------------------------------------------------------------


def test_color_noise_has_gazebo_stddev_and_holds_between_samples():
    noise = CameraColorNoise(width=64, height=48, frame_rate=10.0, mean=0.02, stddev=0.05, seed=3)
    context = noise.CreateDefaultContext()
    grey = ImageRgba8U(64, 48)
    grey.mutable_data[:] = 128
    noise.get_input_port().FixValue(context, grey)
    simulator = Simulator(noise, context)
    simulator.AdvanceTo(0.01)
    first = noise.get_output_port().Eval(context).data.astype(float)
    delta = first[:, :, :3] - 128
    assert delta.std() == pytest.approx(0.05 * 255, rel=0.1)
    assert delta.mean() == pytest.approx(0.02 * 255, abs=0.5)
    assert np.all(first[:, :, 3] == 128)  # alpha untouched
    simulator.AdvanceTo(0.09)  # no new sample before 0.1 s
    np.testing.assert_array_equal(noise.get_output_port().Eval(context).data, first)
    simulator.AdvanceTo(0.11)
    assert np.any(noise.get_output_port().Eval(context).data != first)


# --------------------------------------------------------------------------
# Scene objects
# --------------------------------------------------------------------------


@dataclass
class Scene:
    objects: list[SceneObject] = field(default_factory=list)


def test_scene_objects_load_from_yaml():
    objects = yaml_load_typed(
        schema=Scene,
        data="""
objects:
- {name: cube, shape: !Box {size: [0.05, 0.05, 0.05]}, xyz: [0.3, 0, 0.025]}
- {name: ball, shape: !Sphere {radius: 0.03}, xyz: [0.3, 0.1, 0.03], color: [0, 1, 0, 1]}
""",
    ).objects
    plant, _ = AddMultibodyPlantSceneGraph(DiagramBuilder(), time_step=0.001)
    AddSceneObjects(plant, objects)
    plant.Finalize()
    assert [o.name for o in objects] == ["cube", "ball"]
    assert plant.num_collision_geometries() == 2
    assert len(plant.GetVisualGeometriesForBody(plant.world_body())) == 2
    with pytest.raises(SceneObjectError, match="has no SceneGraph"):
        AddSceneObjects(MultibodyPlant(time_step=0.001), objects)


BAD_OBJECTS = [
    (dict(shape="cone"), "object 'thing': shape='cone' is not one of !Box, !Cylinder, !Sphere"),
    (dict(shape=Sphere(radius=-0.1)), "object 'thing': Sphere radius=-0.1 must be positive"),
    (
        dict(shape=Cylinder(radius=0.1, length=0.0)),
        "object 'thing': Cylinder length=0.0 must be positive",
    ),
    (
        dict(shape=Box(size=[0.1, 0.1])),
        "object 'thing': Box size=[0.1, 0.1] must be 3 numbers",
    ),
    (dict(color=[0, 0, 2, 1]), "object 'thing': color=[0, 0, 2, 1] must be RGBA in [0, 1]"),
    (dict(xyz=[0, 0]), "object 'thing': xyz=[0, 0] must be 3 numbers"),
]


@pytest.mark.parametrize("values, message", BAD_OBJECTS)
def test_bad_scene_objects_are_rejected(values, message):
    with pytest.raises(SceneObjectError) as error:
        AddSceneObjects(MultibodyPlant(time_step=0.001), [SceneObject(name="thing", **values)])
    assert str(error.value) == message or str(error.value).startswith(message)


# --------------------------------------------------------------------------
# Browser view and frame saving
# --------------------------------------------------------------------------


def simulate_with_view(tmp_path, *, seconds=0.1):
    """Camera looking at a blue disc and a red plate; image view + frame saver attached."""
    urdf = camera_urdf()
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.001)
    (model,) = Parser(plant).AddModelsFromString(urdf, "urdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("camera_link"), X_WL)
    (info,) = parse_camera_sensors(ET.fromstring(urdf))
    X_WO = sensor_pose(info) @ RigidTransform(RollPitchYaw(0, math.pi / 2, 0), [1.0, 0.0, 0.0])
    objects = [
        SceneObject(
            name="disc",
            shape=Cylinder(radius=0.15, length=0.05),
            xyz=list(X_WO.translation()),
            rpy=list(RollPitchYaw(X_WO.rotation()).vector()),
            color=[0, 0, 1, 1],
        ),
        plate_in_front(info, np.array([0.8, 0.25, 0.1])),
    ]
    AddSceneObjects(plant, objects)
    plant.Finalize()
    cameras = AddCameraSensors(builder, plant, scene_graph, model, [info])
    server = AddImageView(builder, cameras)
    AddFrameSaver(builder, cameras["camera"], tmp_path / "frames", rate=10.0)
    diagram = builder.Build()
    Simulator(diagram).AdvanceTo(seconds)
    return server, info


def fetch(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=5) as response:
        return response.read()


def test_image_view_serves_latest_frames_over_http(tmp_path):
    server, info = simulate_with_view(tmp_path)
    try:
        assert server.frame_count("camera") == 3  # t = 0, 1/30, 2/30 (+ offset) within 0.1 s
        color = np.array(Image.open(io.BytesIO(fetch(server.url + "camera/camera.png"))))
        assert color.shape == (240, 320, 3)
        assert blue(color).sum() > 4000 and red(color).sum() > 300
        # Depth is rendered on demand: the first ask starts it from the next frame.
        assert not server.wants_depth("camera")
        with pytest.raises(urllib.error.HTTPError) as not_yet:
            fetch(server.url + "camera/camera/depth.png")
        assert not_yet.value.code == 503
        assert server.wants_depth("camera")
        server.publish("camera", np.zeros((240, 320, 4), np.uint8), np.ones((240, 320)))
        depth = Image.open(io.BytesIO(fetch(server.url + "camera/camera/depth.png")))
        assert depth.size == (320, 240) and depth.mode == "L"
        page = fetch(server.url).decode()
        assert "/cameras.json" in page and "naturalWidth" in page
        with pytest.raises(urllib.error.HTTPError) as missing:
            fetch(server.url + "camera/nothere.png")
        assert missing.value.code == 404
        assert "no camera 'nothere' (cameras: camera)" in missing.value.read().decode()
    finally:
        server.close()


def test_frame_saver_writes_color_and_millimetre_depth(tmp_path):
    server, info = simulate_with_view(tmp_path, seconds=0.25)
    server.close()
    names = sorted(p.name for p in (tmp_path / "frames").iterdir())
    assert names == [f"camera_{i:06d}{kind}" for i in range(3) for kind in (".png", "_depth.png")]
    color = np.array(Image.open(tmp_path / "frames" / "camera_000002.png"))
    depth = np.array(Image.open(tmp_path / "frames" / "camera_000002_depth.png"))
    assert color.shape == (240, 320, 3) and depth.dtype == np.uint16
    assert depth[120, 160] == pytest.approx(975, abs=10)  # disc face at 0.975 m
    assert depth[2, 317] == 0  # nothing in range: no reading
    np.testing.assert_array_equal(depth_millimetres(np.array([[np.inf, 0.5, 70.0]])), [[0, 500, 0]])


def test_image_view_server_counts_frames_and_rejects_bad_images():
    with ImageViewServer(title="test") as server:
        assert server.frame_count("top") == 0
        with pytest.raises(ValueError, match=r"color image shape \(4, 5\) is not"):
            server.publish("top", np.zeros((4, 5), dtype=np.uint8))
        image = np.full((4, 5, 4), 9, dtype=np.uint8)
        server.publish("top", image, time=0.5)
        image[:] = 200  # the server keeps its own copy
        png = np.array(Image.open(io.BytesIO(fetch(server.url + "camera/top.png"))))
        assert png.shape == (4, 5, 3) and np.all(png == 9)
        server.publish("top", image, time=0.6)
        meta = json.loads(fetch(server.url + "camera/top.json"))
        assert (meta["count"], meta["width"], meta["height"], meta["time"]) == (2, 5, 4, 0.6)
        png = np.array(Image.open(io.BytesIO(fetch(server.url + "camera/top.png"))))
        assert np.all(png == 200)  # a new frame is encoded anew
        assert "<title>test</title>" in fetch(server.url).decode()


@pytest.mark.parametrize("how", ["closed", "reset"])
def test_image_view_ignores_a_connection_the_page_closed(how, capfd):
    import socket
    import struct

    with ImageViewServer(title="test") as server:
        server.publish("top", np.full((480, 640, 4), 9, dtype=np.uint8), time=0.5)
        handler = server._handler_class()
        for path in ("/camera/top.png", "/", "/cameras.json"):
            ours, page = socket.socketpair()
            page.sendall(f"GET {path} HTTP/1.1\r\nHost: localhost\r\n\r\n".encode())
            if how == "reset":
                page.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            page.close()  # the tab closed before the answer: writing it fails
            handler(ours, ("127.0.0.1", 0), server._httpd)  # answers, and returns quietly
            ours.close()
        # Still serving.
        png = np.array(Image.open(io.BytesIO(fetch(server.url + "camera/top.png"))))
        assert png.shape == (480, 640, 3)
    captured = capfd.readouterr()
    assert "Traceback" not in captured.err and "BrokenPipeError" not in captured.err


@pytest.mark.browser
def test_image_view_in_headless_chromium(tmp_path, chromium):
    server, info = simulate_with_view(tmp_path)
    command = [
        chromium,
        "--headless",
        *CHROMIUM_ARGS,
        f"--user-data-dir={tmp_path / 'profile'}",
        "--virtual-time-budget=4000",
        "--window-size=800,600",
    ]
    try:
        dom = subprocess.run(
            [*command, "--dump-dom", server.url], capture_output=True, text=True, timeout=60
        ).stdout
        screenshot = tmp_path / "view.png"
        subprocess.run(
            [*command, f"--screenshot={screenshot}", server.url], capture_output=True, timeout=60
        )
    finally:
        server.close()
    # The page's script writes the decoded image size into the document.
    assert f'data-natural-width="{info.width}"' in dom, dom[-2000:]
    assert f'data-natural-height="{info.height}"' in dom
    assert "320x240 px, t = 0.067 s, frame 3" in dom
    pixels = np.array(Image.open(screenshot).convert("RGB"))
    assert pixels.shape == (600, 800, 3)
    # The camera image is on the page: blue disc pixels, and many distinct colours.
    assert blue(pixels).sum() > 3000
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 20
