"""The camera's colour hold renders only the frames read, at the readers' rates."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.sensors import ImageRgba8U

from armando_drake.description.camera_sensors import parse_camera_sensors
from armando_drake.sensors.camera import AddCameraSensors
from armando_drake.sensors.frame_hold import FrameHold, FrameReader
from armando_drake.sensors.image_view import AddFrameSaver
from armando_drake.tools.xdisplay import DisplayError, ensure_display
from tests.conftest import skip_or_fail

# A 30 Hz, 64 x 48 camera looking along the world's +x, and a ball falling through its view.
CAMERA = """<?xml version="1.0"?>
<robot name="eye">
  <link name="camera_link">
    <inertial><mass value="0.05"/>
      <inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <gazebo reference="camera_link">
    <sensor type="depth" name="camera"><update_rate>30</update_rate>
      <camera><horizontal_fov>1.047</horizontal_fov>
        <image><width>64</width><height>48</height></image>
        <clip><near>0.1</near><far>10</far></clip></camera></sensor>
  </gazebo>
</robot>
"""
BALL = """<?xml version="1.0"?>
<robot name="ball"><link name="ball">
  <visual><geometry><sphere radius="0.2"/></geometry></visual>
  <inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
</link></robot>
"""


class Reader(LeafSystem):
    """Reads an image port at ``rate`` from ``offset`` and keeps (time, image) of each read."""

    def __init__(self, rate: float, offset: float):
        super().__init__()
        self.reads: list[tuple[float, np.ndarray]] = []
        self._input = self.DeclareAbstractInputPort("image", AbstractValue.Make(ImageRgba8U()))
        self.DeclarePeriodicPublishEvent(1.0 / rate, offset, self._Read)

    def _Read(self, context):
        self.reads.append((context.get_time(), self._input.Eval(context).data.copy()))


def camera_world(*, readers=(), saver=None, still=False, renderer="vtk"):
    """The camera and the falling ball (``still``: the ball welded in view); ``readers``:
    (rate, offset) of Reader systems on its colour image, each told to the camera.
    Returns (diagram, camera, readers, a zero-order hold of every frame that a reader at
    the same times reads)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.001)
    (eye,) = Parser(plant).AddModelsFromString(CAMERA, "urdf")
    Parser(plant).AddModelsFromString(BALL, "urdf")
    X_WL = RigidTransform(RollPitchYaw(0, 0, 0), [0, 0, 0.5])
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("camera_link"), X_WL)
    if still:
        X_WBall = RigidTransform([1.5, 0, 0.6])
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("ball"), X_WBall)
    plant.Finalize()
    if not still:
        ball = plant.GetBodyByName("ball")
        plant.SetDefaultFloatingBaseBodyPose(ball, RigidTransform([1.5, 0, 0.9]))
    (info,) = parse_camera_sensors(ET.fromstring(CAMERA), "inline.urdf")
    camera = AddCameraSensors(builder, plant, scene_graph, eye, [info], renderer=renderer)["camera"]
    every = builder.AddSystem(FrameHold(ImageRgba8U(64, 48), frame_rate=30.0))
    builder.Connect(camera.sensor.GetOutputPort("color_image"), every.get_input_port())
    added, references = [], []
    for rate, offset in readers:
        reader, reference = (
            builder.AddSystem(Reader(rate, offset)),
            builder.AddSystem(Reader(rate, offset)),
        )
        builder.Connect(camera.color_image, reader.get_input_port())
        builder.Connect(every.get_output_port(), reference.get_input_port())
        camera.read_color(rate, offset)
        added.append(reader)
        references.append(reference)
    if saver is not None:
        AddFrameSaver(builder, camera, saver, depth=False)
    return builder.Build(), camera, added, references


def test_a_camera_nobody_reads_renders_no_colour():
    diagram, camera, _, _ = camera_world()
    Simulator(diagram).AdvanceTo(0.99)
    assert camera.hold.on_demand and camera.hold.samples == 0
    assert camera.hold.renders_on_read == 0


def test_a_10_hz_reader_of_a_30_hz_camera_costs_10_renders_a_second_and_sees_the_same_frames():
    diagram, camera, (reader,), (reference,) = camera_world(readers=[(10.0, 1e-4)])
    Simulator(diagram).AdvanceTo(0.99)
    assert camera.hold.samples == 10  # t = 0, 0.1, ..., 0.9: not 30
    assert camera.hold.renders_on_read == 0
    assert len(reader.reads) == len(reference.reads) == 10
    for (t, image), (t_reference, held) in zip(reader.reads, reference.reads, strict=True):
        assert t == t_reference
        np.testing.assert_array_equal(image, held)  # the frame of t = k / 30, held
    first, last = reader.reads[0][1], reader.reads[-1][1]
    assert np.any(first != last)  # the ball fell: the frames differ


def test_a_camera_on_a_still_scene_renders_once_and_holds_that_frame_again():
    diagram, camera, (reader,), (reference,) = camera_world(readers=[(30.0, 1e-4)], still=True)
    Simulator(diagram).AdvanceTo(0.99)
    assert camera.hold.samples == 30
    assert camera.hold.reuses == 29  # the scene's poses never changed: one render
    assert len(reader.reads) == len(reference.reads) == 30
    for (_, image), (_, rendered) in zip(reader.reads, reference.reads, strict=True):
        np.testing.assert_array_equal(image, rendered)  # each frame rendered, the same
    assert np.any(reader.reads[0][1] != reader.reads[0][1][0, 0])  # the ball is in view


def test_an_opengl_camera_on_a_still_scene_renders_once_too():
    try:
        ensure_display()
    except DisplayError as error:
        skip_or_fail(f"Drake's OpenGL renderer needs an X display or Xvfb: {error}")
    diagram, camera, (reader,), (reference,) = camera_world(
        readers=[(30.0, 1e-4)], still=True, renderer="gl"
    )
    Simulator(diagram).AdvanceTo(0.99)
    assert camera.hold.samples == 30 and camera.hold.reuses == 29
    for (_, image), (_, rendered) in zip(reader.reads, reference.reads, strict=True):
        np.testing.assert_array_equal(image, rendered)


def test_a_moving_scene_is_rendered_at_every_frame_read():
    diagram, camera, _, _ = camera_world(readers=[(30.0, 1e-4)])
    Simulator(diagram).AdvanceTo(0.99)
    assert camera.hold.samples == 30 and camera.hold.reuses == 0


def test_a_frame_held_again_gets_noise_of_its_own_as_a_rendered_one_would():
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.001)
    (eye,) = Parser(plant).AddModelsFromString(CAMERA, "urdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("camera_link"))
    plant.Finalize()
    (info,) = parse_camera_sensors(ET.fromstring(CAMERA), "inline.urdf")
    camera = AddCameraSensors(builder, plant, scene_graph, eye, [info])["camera"]
    color = camera.sensor.GetOutputPort("color_image")
    holds = []
    for watch in (True, False):
        hold = builder.AddSystem(
            FrameHold(ImageRgba8U(64, 48), frame_rate=30.0, stddev=0.05, seed=3, watch_scene=watch)
        )
        builder.Connect(color, hold.get_input_port(0))
        if watch:
            poses = builder.GetSubsystemByName("camera_scene_poses").get_output_port()
            builder.Connect(poses, hold.GetInputPort("scene_poses"))
        reader = builder.AddSystem(Reader(30.0, 1e-4))
        builder.Connect(hold.get_output_port(), reader.get_input_port())
        holds.append((hold, reader))
    Simulator(builder.Build()).AdvanceTo(0.2)
    (watched, watched_reads), (every, every_reads) = holds
    assert watched.reuses == 5 and every.reuses == 0
    frames = [image for _, image in watched_reads.reads]
    assert np.any(frames[0] != frames[1])  # fresh noise on each frame
    for (_, image), (_, rendered) in zip(watched_reads.reads, every_reads.reads, strict=True):
        np.testing.assert_array_equal(image, rendered)


def test_readers_at_several_rates_get_the_union_of_their_frames():
    diagram, camera, readers, references = camera_world(readers=[(10.0, 1e-4), (15.0, 1e-4)])
    Simulator(diagram).AdvanceTo(0.99)
    # 10 Hz: 0, 3, 6, ... of the 30 frames; 15 Hz: 0, 2, 4, ...; both: 20 frames.
    assert camera.hold.samples == 20
    for reader, reference in zip(readers, references, strict=True):
        for (_, image), (_, held) in zip(reader.reads, reference.reads, strict=True):
            np.testing.assert_array_equal(image, held)


def test_the_frame_saver_reads_at_the_camera_rate(tmp_path):
    diagram, camera, _, _ = camera_world(saver=tmp_path / "frames")
    Simulator(diagram).AdvanceTo(0.99)
    assert camera.hold.samples == 30
    assert len(list((tmp_path / "frames").iterdir())) == 30


def test_a_read_the_hold_was_not_told_of_renders_the_instant_read():
    diagram, camera, _, _ = camera_world()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.25)
    context = simulator.get_context()
    image = camera.color_image.Eval(camera.hold.GetMyContextFromRoot(context)).data
    rendered = camera.sensor.GetOutputPort("color_image").Eval(
        camera.sensor.GetMyContextFromRoot(context)
    )
    np.testing.assert_array_equal(image, rendered.data)
    assert camera.hold.renders_on_read == 1


@pytest.mark.parametrize(
    ("rate", "offset", "start", "end", "reads"),
    [
        (30.0, 1e-4, 1 / 30, 2 / 30, True),
        (10.0, 1e-4, 0.1, 0.1 + 1 / 30, True),
        (10.0, 1e-4, 0.1 + 1 / 30, 0.1 + 2 / 30, False),
        (10.0, 1e-4, 0.1 + 2 / 30, 0.2, False),
        (60.0, 0.0, 0.5, 0.5 + 1 / 30, True),
    ],
)
def test_a_reader_reads_in_a_period_when_one_of_its_instants_is_in_it(
    rate, offset, start, end, reads
):
    assert FrameReader(rate, offset).reads_between(start, end) is reads
    assert FrameReader(rate, offset, active=lambda: False).reads_between(start, end) is False


def test_a_reader_needs_a_positive_rate_and_offset():
    hold = FrameHold(ImageRgba8U(4, 3), frame_rate=30.0, on_demand=True)
    with pytest.raises(ValueError, match=r"rate=0.0 must be positive"):
        hold.add_reader(0.0)
    with pytest.raises(ValueError, match=r"offset=-1.0 must be >= 0"):
        hold.add_reader(10.0, -1.0)


def scene_camera_images(own_scene: bool, time: float = 0.3):
    """(colour, depth, X_WB) of the falling-ball camera at ``time``, its VTK camera on the
    cameras' own scene graph or on the world's."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.001)
    (eye,) = Parser(plant).AddModelsFromString(CAMERA, "urdf")
    Parser(plant).AddModelsFromString(BALL, "urdf")
    plant.WeldFrames(
        plant.world_frame(), plant.GetFrameByName("camera_link"), RigidTransform([0, 0, 0.5])
    )
    plant.Finalize()
    plant.SetDefaultFloatingBaseBodyPose(plant.GetBodyByName("ball"), RigidTransform([1.5, 0, 0.9]))
    (info,) = parse_camera_sensors(ET.fromstring(CAMERA), "inline.urdf")
    camera = AddCameraSensors(builder, plant, scene_graph, eye, [info], own_scene=own_scene)
    sensor = camera["camera"].sensor
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(time)
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    color = sensor.GetOutputPort("color_image").Eval(context).data.copy()
    depth = sensor.GetOutputPort("depth_image_32f").Eval(context).data.copy()
    return color, depth, sensor.GetOutputPort("body_pose_in_world").Eval(context)


def test_vtk_cameras_on_their_own_scene_graph_render_the_same_images():
    color, depth, X_WB = scene_camera_images(own_scene=True)
    color_world, depth_world, X_WB_world = scene_camera_images(own_scene=False)
    assert np.any(color != color[0, 0])  # the ball is in view
    np.testing.assert_array_equal(color, color_world)
    np.testing.assert_array_equal(depth, depth_world)
    assert X_WB.IsExactlyEqualTo(X_WB_world)


@pytest.mark.parametrize("mean, stddev", [(0.0, 1.785), (2.55, 5.1), (0.0, 0.3)])
def test_the_noise_table_draws_each_level_as_rounded_gaussian_noise_would(mean, stddev):
    from statistics import NormalDist

    from armando_drake.sensors.frame_hold import NOISE_BINS, noise_levels

    levels = noise_levels(mean, stddev)  # [0..255 units]: Gazebo's 0.007 is 1.785
    values, counts = np.unique(levels, return_counts=True)
    assert values.min() < mean < values.max()
    normal = NormalDist(mean, stddev)
    # the outermost levels hold the tails
    for value, count in zip(values[1:-1], counts[1:-1], strict=True):
        exact = normal.cdf(value + 0.5) - normal.cdf(value - 0.5)
        assert abs(count / NOISE_BINS - exact) <= 1 / NOISE_BINS, value


def test_colour_noise_on_a_frame_has_the_mean_and_deviation_asked_and_keeps_alpha():
    from armando_drake.sensors.frame_hold import add_color_noise, noise_levels

    grey = np.full((400, 400, 4), 128, dtype=np.uint8)
    grey[..., 3] = 200
    grey[:10, :, :3] = 0  # clamped at 0: never below
    rng = np.random.default_rng(7)
    noisy = add_color_noise(grey, rng, noise_levels(2.55, 5.1)).astype(float)
    middle = noisy[10:, :, :3] - 128
    assert middle.mean() == pytest.approx(2.55, abs=0.03)
    # rounding adds 1/12 of a level squared to the variance
    assert middle.std() == pytest.approx(np.sqrt(5.1**2 + 1 / 12), rel=0.01)
    assert noisy[:10, :, :3].min() == 0
    assert (noisy[..., 3] == 200).all()
    again = add_color_noise(grey, rng, noise_levels(2.55, 5.1))
    assert (again != noisy).any()  # a draw of its own
