"""Gazebo worlds as the scene: the course's race field with every include, a small world
of our own (model:// include, an STL mesh, a textured marker, the built-in ground
plane), one-line errors for a missing model, GZ_SIM_RESOURCE_PATH."""

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import trimesh
from PIL import Image
from pydrake.geometry import Convex, Mesh, Role
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, CoulombFriction
from pydrake.systems.framework import DiagramBuilder

from armando_drake.description.worlds import WorldError, load_world
from armando_drake.simulation.builder import MakeWorld
from tests.conftest import SHARED, skip_or_fail

RACE_FIELD = SHARED / "upstream" / "rl_fra2mo_description" / "worlds" / "leonardo_race_field.sdf"

WORLD = """<?xml version="1.0"?>
<sdf version="1.9">
  <world name="yard">
    <physics name="1ms" type="ignored"><max_step_size>0.001</max_step_size></physics>
    <plugin filename="gz-sim-physics-system" name="gz::sim::systems::Physics"/>
    <light type="directional" name="sun"><pose>0 0 10 0 0 0</pose></light>
    <include><uri>model://ground_plane</uri></include>
    <include>
      <name>crate_a</name>
      <pose>1.5 -0.5 0 0 0 0.7</pose>
      <uri>model://crate</uri>
    </include>
    <include>
      <name>tag</name>
      <pose>0 2 0.5 0 1.5708 0</pose>
      <uri>model://tag</uri>
    </include>
  </world>
</sdf>
"""
CRATE = """<?xml version="1.0"?>
<sdf version="1.6"><model name="crate"><static>true</static>
  <link name="link">
    <visual name="visual"><cast_shadows>true</cast_shadows>
      <geometry><mesh><uri>model://crate/meshes/crate.stl</uri><scale>0.001 0.001 0.001</scale>
      </mesh></geometry>
      <material><script><uri>file://media/materials/scripts/gazebo.material</uri>
        <name>Gazebo/Orange</name></script></material>
    </visual>
    <collision name="collision">
      <geometry><mesh><uri>model://crate/meshes/crate.stl</uri><scale>0.001 0.001 0.001</scale>
      </mesh></geometry>
    </collision>
  </link></model></sdf>
"""
TAG = """<?xml version="1.0"?>
<sdf version="1.4"><model name="marker"><static>true</static>
  <link name="marker">
    <visual name="tag"><geometry><box><size>0.2 0.2 0.002</size></box></geometry>
      <material><script>
        <uri>model://tag/materials/scripts</uri><uri>model://tag/materials/textures</uri>
        <name>tag_face</name></script></material>
    </visual>
    <collision name="collision"><geometry><box><size>0.2 0.2 0.002</size></box></geometry>
    </collision>
  </link></model></sdf>
"""
CONFIG = (
    """<?xml version="1.0"?><model><name>{name}</name><sdf version="1.6">{file}</sdf></model>"""
)


def _models(folder):
    """model://crate (a 0.4 m STL cube, in mm, on the floor) and model://tag (a textured box)."""
    crate = folder / "crate"
    (crate / "meshes").mkdir(parents=True)
    box = trimesh.creation.box(extents=[400, 400, 400])
    box.apply_translation([0, 0, 200])
    box.export(crate / "meshes" / "crate.stl")
    (crate / "crate.sdf").write_text(CRATE)
    (crate / "model.config").write_text(CONFIG.format(name="crate", file="crate.sdf"))
    tag = folder / "tag"
    (tag / "materials" / "scripts").mkdir(parents=True)
    (tag / "materials" / "textures").mkdir(parents=True)
    Image.new("RGB", (8, 8), (0, 0, 0)).save(tag / "materials" / "textures" / "face.png")
    (tag / "materials" / "scripts" / "tag.material").write_text(
        "material tag_face\n{\n technique\n {\n  pass\n  {\n   texture_unit\n   {\n"
        "    texture face.png\n   }\n  }\n }\n}\n"
    )
    (tag / "model.sdf").write_text(TAG)


def _plant():
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    return builder, plant, scene_graph


def _pose(plant, builder, instance, link="link"):
    plant.Finalize()
    diagram = builder.Build()
    context = plant.GetMyContextFromRoot(diagram.CreateDefaultContext())
    return plant.EvalBodyPoseInWorld(context, plant.GetBodyByName(link, instance))


def test_race_field_loads_every_include():
    """The race field: one model per <include> (13), obstacle_03 at its <pose>, every
    one with collision geometry."""
    if not RACE_FIELD.is_file():
        skip_or_fail(f"the race field is not at {RACE_FIELD}")
    includes = ET.parse(RACE_FIELD).getroot().findall("world/include")
    builder, plant, scene_graph = _plant()
    world = load_world(plant, RACE_FIELD)
    assert len(world.models) == len(includes) == 13
    assert {"roof", "obstacle_03", "obstacle_03_second", "intruder_two"} <= set(world.models)
    assert {"physics", "light", "plugin"} <= set(world.ignored)
    inspector = scene_graph.model_inspector()
    for name, instance in world.models.items():
        body = plant.GetBodyByName("link", instance)
        assert plant.GetCollisionGeometriesForBody(body), name
        assert plant.GetVisualGeometriesForBody(body), name
    X_WO = _pose(plant, builder, world.models["obstacle_03"])
    expected = RigidTransform(RollPitchYaw(0, 0, -1.57), [2.802, 1.684, 0.1])
    assert X_WO.IsNearlyEqualTo(expected, 1e-9)
    # The field's 13 walls and floor are boxes: 13 convex pieces on its link.
    field = plant.GetBodyByName("link", world.models["race_field"])
    shapes = [inspector.GetShape(g) for g in plant.GetCollisionGeometriesForBody(field)]
    assert len(shapes) == 13 and all(isinstance(s, Convex) for s in shapes)


def test_small_world(tmp_path, caplog):
    """Our world: the built-in ground plane (said in one info line), the STL crate at its
    include's pose with a convex collision of its 0.4 m cube, the tag's texture on an OBJ
    box."""
    _models(tmp_path / "models")
    (tmp_path / "worlds").mkdir()
    world_file = tmp_path / "worlds" / "yard.sdf"
    world_file.write_text(WORLD)
    builder, plant, scene_graph = _plant()
    with caplog.at_level("INFO", logger="armando_drake.world"):
        world = load_world(plant, world_file)
    (line,) = [r.message for r in caplog.records if "built-in ground" in r.message]
    assert "model://ground_plane found nowhere on the resource path" in line
    assert list(world.models) == ["ground_plane", "crate_a", "tag"]
    assert {"physics", "plugin", "light", "cast_shadows"} <= set(world.ignored)
    inspector = scene_graph.model_inspector()
    crate = plant.GetBodyByName("link", world.models["crate_a"])
    (collision,) = plant.GetCollisionGeometriesForBody(crate)
    hull = inspector.GetShape(collision)
    assert isinstance(hull, Convex)
    (visual,) = plant.GetVisualGeometriesForBody(crate)
    assert isinstance(inspector.GetShape(visual), Mesh)
    assert inspector.GetShape(visual).extension() == ".obj"
    orange = inspector.GetIllustrationProperties(visual).GetProperty("phong", "diffuse")
    assert (orange.r(), orange.g(), orange.b()) == pytest.approx((1.0, 0.5088, 0.0468))
    (tag_visual,) = plant.GetVisualGeometriesForBody(
        plant.GetBodyByName("marker", world.models["tag"])
    )
    tag_mesh = inspector.GetShape(tag_visual)
    assert isinstance(tag_mesh, Mesh)
    mtl = str(tag_mesh.source().path()).replace(".obj", ".mtl")
    assert re.search(r"map_Kd box-\w+\.png", open(mtl).read())
    X_WC = _pose(plant, builder, world.models["crate_a"])
    assert X_WC.IsNearlyEqualTo(RigidTransform(RollPitchYaw(0, 0, 0.7), [1.5, -0.5, 0]), 1e-9)
    # The hull's top face is 0.4 m up (mm scaled to m).
    assert inspector.num_geometries() == len(inspector.GetAllGeometryIds())
    assert scene_graph.model_inspector().NumGeometriesWithRole(Role.kProximity) == 3


def test_missing_model_is_one_line(tmp_path):
    """A world naming a model nowhere on the path: one line with the file, the line of
    the <include>, the URI and where it was looked for."""
    world_file = tmp_path / "yard.sdf"
    world_file.write_text(WORLD)
    _, plant, _ = _plant()
    with pytest.raises(WorldError) as error:
        load_world(plant, world_file)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"{world_file}:8: <include> model://crate: model not found")
    assert "GZ_SIM_RESOURCE_PATH" in message


def test_resource_path_variable(tmp_path, monkeypatch):
    """Models in a folder only GZ_SIM_RESOURCE_PATH names are found."""
    _models(tmp_path / "elsewhere")
    world_file = tmp_path / "worlds" / "yard.sdf"
    world_file.parent.mkdir()
    world_file.write_text(WORLD)
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", f"/nonexistent:{tmp_path / 'elsewhere'}")
    _, plant, _ = _plant()
    assert set(load_world(plant, world_file).models) == {"ground_plane", "crate_a", "tag"}


def test_scenario_world_file(tmp_path):
    """A scenario's world_file is the scene: the world's models in the diagram, no
    default ground slab; a missing file names the key."""
    from armando_drake.simulation.scenario import load_scenario

    _models(tmp_path / "models")
    world_file = tmp_path / "yard.sdf"
    world_file.write_text(WORLD)
    scenario = load_scenario("position", f"world_file: {world_file}")
    world = MakeWorld(scenario)
    plant = world.robot().plant
    assert plant.HasModelInstanceNamed("crate_a") and plant.HasModelInstanceNamed("tag")
    assert not plant.HasModelInstanceNamed("scene")
    scenario = load_scenario("position", f"world_file: {tmp_path / 'none.sdf'}")
    with pytest.raises(WorldError, match=r"world_file='.*none\.sdf': no such file"):
        MakeWorld(scenario)


NESTED_WORLD = """<?xml version="1.0"?>
<sdf version="1.9">
  <world name="nested">
    <include><uri>model://ground_plane</uri></include>
    <model name="outer">
      <static>true</static>
      <pose>1 0 0 0 0 1.5707963267948966</pose>
      <link name="base"/>
      <include>
        <name>middle</name>
        <pose>2 0 0 0 0 0</pose>
        <uri>model://wrapper</uri>
      </include>
    </model>
  </world>
</sdf>
"""
WRAPPER = """<?xml version="1.0"?>
<sdf version="1.9"><model name="wrapper">
  <link name="frame_link"><pose>0 0 0.5 0 0 0</pose></link>
  <model name="inner">
    <pose>0 1 0 0 0 0</pose>
    <include><name>crate_in</name><pose>0 0 0.25 0 0 0</pose><uri>model://crate</uri></include>
    <link name="link"><pose>0 0 1 0 0 0</pose>
      <collision name="box"><geometry><box><size>0.1 0.1 0.1</size></box></geometry></collision>
    </link>
  </model>
</model></sdf>
"""


def test_nested_models_three_deep(tmp_path):
    """A <model> wrapping an <include> of a model holding a <model> holding an <include>
    (4 levels): every body where the composed poses say, every one static (welded) since
    the outer model is, the deepest crate's STL collision on its own scoped instance."""
    _models(tmp_path / "models")
    wrapper = tmp_path / "models" / "wrapper"
    wrapper.mkdir()
    (wrapper / "model.sdf").write_text(WRAPPER)
    world_file = tmp_path / "nested.sdf"
    world_file.write_text(NESTED_WORLD)
    builder, plant, scene_graph = _plant()
    world = load_world(plant, world_file)
    assert list(world.models) == ["ground_plane", "outer"]
    names = ["outer::middle", "outer::middle::inner", "outer::middle::inner::crate_in"]
    assert all(plant.HasModelInstanceNamed(n) for n in names)
    plant.Finalize()
    assert plant.num_positions() == 0  # static inherited: nothing floats
    context = plant.GetMyContextFromRoot(builder.Build().CreateDefaultContext())

    def where(link, model):
        body = plant.GetBodyByName(link, plant.GetModelInstanceByName(model))
        return plant.EvalBodyPoseInWorld(context, body)

    # outer at (1, 0, 0) turned 90° about z: its +x is the world's +y.
    assert where("base", "outer").translation() == pytest.approx([1, 0, 0], abs=1e-9)
    assert where("frame_link", "outer::middle").translation() == pytest.approx(
        [1, 2, 0.5], abs=1e-9
    )
    # inner at (0, 1, 0) in middle: the world's -x from middle's origin (1, 2, 0).
    inner = where("link", "outer::middle::inner")
    assert inner.translation() == pytest.approx([0, 2, 1], abs=1e-9)
    assert RollPitchYaw(inner.rotation()).yaw_angle() == pytest.approx(1.5707963267948966)
    crate = where("link", "outer::middle::inner::crate_in")
    assert crate.translation() == pytest.approx([0, 2, 0.25], abs=1e-9)
    body = plant.GetBodyByName("link", plant.GetModelInstanceByName(names[-1]))
    (collision,) = plant.GetCollisionGeometriesForBody(body)
    assert isinstance(scene_graph.model_inspector().GetShape(collision), Convex)


SHARED_MESH_WORLD = """<?xml version="1.0"?>
<sdf version="1.9">
  <world name="shared">
    <model name="pair"><static>true</static>
      <link name="link">
        <collision name="left"><pose>-1 0 0 0 0 0</pose>
          <geometry><mesh><uri>model://crate/meshes/crate.stl</uri>
          <scale>0.001 0.001 0.001</scale></mesh></geometry></collision>
        <collision name="right"><pose>1 0 0 0 0 0</pose>
          <geometry><mesh><uri>model://crate/meshes/crate.stl</uri>
          <scale>0.001 0.001 0.001</scale></mesh></geometry></collision>
        <collision name="right"><pose>0 3 0 0 0 0</pose>
          <geometry><mesh><uri>model://crate/meshes/crate.stl</uri>
          <scale>0.001 0.001 0.001</scale></mesh></geometry></collision>
      </link>
    </model>
  </world>
</sdf>
"""


def test_collisions_sharing_one_mesh(tmp_path):
    """Three <collision>s of one link on one mesh file load, each named by its own name
    (a repeated name gets a number), each at its own pose."""
    _models(tmp_path / "models")
    world_file = tmp_path / "shared.sdf"
    world_file.write_text(SHARED_MESH_WORLD)
    _, plant, scene_graph = _plant()
    world = load_world(plant, world_file)
    inspector = scene_graph.model_inspector()
    body = plant.GetBodyByName("link", world.models["pair"])
    ids = plant.GetCollisionGeometriesForBody(body)
    names = sorted(inspector.GetName(g).split("::")[-1] for g in ids)
    assert names == ["link_left_0", "link_right2_0", "link_right_0"]
    poses = sorted(tuple(inspector.GetPoseInFrame(g).translation()) for g in ids)
    assert [v for pose in poses for v in pose] == pytest.approx([-1, 0, 0, 0, 3, 0, 1, 0, 0])


INCH_WORLD = """<?xml version="1.0"?>
<sdf version="1.9">
  <world name="inches">
    <model name="floor"><static>true</static>
      <link name="link">
        <collision name="slab"><geometry><mesh><uri>slab.dae</uri></mesh></geometry></collision>
        <visual name="slab"><geometry><mesh><uri>slab.dae</uri></mesh></geometry></visual>
      </link>
    </model>
  </world>
</sdf>
"""


def test_collada_inches_world_collision(tmp_path):
    """A Collada floor in inches (<unit meter="0.0254">, a 40 x 40 x 4 in slab, its top
    4 in = 0.1016 m up) as a world collision: a ball dropped on it rests on its top
    within 1 mm (Drake physics), and the visual OBJ has the same size."""
    from pydrake.geometry import Sphere
    from pydrake.multibody.tree import SpatialInertia
    from pydrake.systems.analysis import Simulator

    slab = trimesh.creation.box(extents=[40, 40, 4])
    slab.apply_translation([0, 0, 2])
    dae = trimesh.exchange.dae.export_collada(slab).decode()
    dae = dae.replace("<asset>", '<asset><unit name="inch" meter="0.0254"/>', 1)
    (tmp_path / "slab.dae").write_text(dae)
    world_file = tmp_path / "inches.sdf"
    world_file.write_text(INCH_WORLD)
    builder, plant, scene_graph = _plant()
    world = load_world(plant, world_file)
    radius, top = 0.05, 4 * 0.0254
    ball = plant.AddRigidBody(
        "ball", plant.AddModelInstance("ball"), SpatialInertia.SolidSphereWithMass(1.0, radius)
    )
    plant.RegisterCollisionGeometry(
        ball, RigidTransform(), Sphere(radius), "ball", CoulombFriction(1.0, 1.0)
    )
    plant.set_penetration_allowance(1e-4)
    plant.Finalize()
    inspector = scene_graph.model_inspector()
    (visual,) = plant.GetVisualGeometriesForBody(plant.GetBodyByName("link", world.models["floor"]))
    vertices = trimesh.load(str(inspector.GetShape(visual).source().path()), force="mesh")
    assert vertices.bounds[1][2] == pytest.approx(top, abs=1e-6)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetFreeBodyPose(context, ball, RigidTransform([0.1, -0.2, top + radius + 0.05]))
    simulator.AdvanceTo(1.5)
    z = plant.EvalBodyPoseInWorld(context, ball).translation()[2]
    assert z - radius == pytest.approx(top, abs=1e-3)


GAZEBO_GROUND = """<?xml version="1.0" ?>
<sdf version="1.5"><model name="ground_plane"><static>true</static>
  <link name="link">
    <collision name="collision">
      <geometry><plane><normal>0 0 1</normal><size>100 100</size></plane></geometry>
      <surface><friction><ode><mu>100</mu><mu2>50</mu2></ode></friction></surface>
    </collision>
    <visual name="visual"><cast_shadows>false</cast_shadows>
      <geometry><plane><normal>0 0 1</normal><size>100 100</size></plane></geometry>
      <material><script><uri>file://media/materials/scripts/gazebo.material</uri>
        <name>Gazebo/Grey</name></script></material>
    </visual>
  </link></model></sdf>
"""
STATIC_BOX = """<model name="box_{i}"><static>true</static><pose>{x} {y} 0.25 0 0 0</pose>
  <link name="link"><collision name="collision"><geometry><box><size>0.5 0.5 0.5</size></box>
  </geometry></collision></link></model>"""
TILTED_PLANE = """<model name="ramp"><static>true</static><pose>0 20 0 0 0 0</pose>
  <link name="link"><collision name="collision"><pose>0 0 1 0 0 0</pose>
  <geometry><plane><normal>0 0.6 0.8</normal></plane></geometry></collision></link></model>"""


def test_plane_ground_with_30_static_models(tmp_path, caplog):
    """Gazebo's own ground_plane folder (a <plane>, mu 100) then 30 static models, a
    Drake HalfSpace would crash on (docs/worlds.md): the plane is a box slab under z = 0
    (one info line says so), its friction kept, a ball rests on it; a tilted <plane>'s
    slab faces its normal."""
    from pydrake.geometry import Box, Sphere
    from pydrake.multibody.tree import SpatialInertia
    from pydrake.systems.analysis import Simulator

    (tmp_path / "models" / "ground_plane").mkdir(parents=True)
    (tmp_path / "models" / "ground_plane" / "model.sdf").write_text(GAZEBO_GROUND)
    boxes = "\n".join(STATIC_BOX.format(i=i, x=3 + i % 6, y=3 + i // 6) for i in range(30))
    world_file = tmp_path / "plane.sdf"
    world_file.write_text(
        '<sdf version="1.9"><world name="plane">'
        f"<include><uri>model://ground_plane</uri></include>{boxes}{TILTED_PLANE}</world></sdf>"
    )
    builder, plant, scene_graph = _plant()
    with caplog.at_level("INFO", logger="armando_drake.world"):
        world = load_world(plant, world_file)
    (line,) = [r.message for r in caplog.records if "<plane>" in r.message]
    assert "ground_plane, ramp" in line and "box slab" in line
    assert len(world.models) == 32
    inspector = scene_graph.model_inspector()
    ground = plant.GetBodyByName("link", world.models["ground_plane"])
    (collision,) = plant.GetCollisionGeometriesForBody(ground)
    slab = inspector.GetShape(collision)
    assert isinstance(slab, Box) and slab.height() == pytest.approx(0.1)
    assert slab.width() == slab.depth() == pytest.approx(100)
    X_BS = inspector.GetPoseInFrame(collision)
    assert X_BS.translation() == pytest.approx([0, 0, -0.05], abs=1e-9)
    friction = inspector.GetProximityProperties(collision).GetProperty(
        "material", "coulomb_friction"
    )
    assert (friction.static_friction(), friction.dynamic_friction()) == (100, 50)
    (ramp,) = plant.GetCollisionGeometriesForBody(plant.GetBodyByName("link", world.models["ramp"]))
    X_RS = inspector.GetPoseInFrame(ramp)
    assert X_RS.rotation().col(2) == pytest.approx([0, 0.6, 0.8], abs=1e-9)
    expected = np.array([0, 0, 1]) - 0.05 * np.array([0, 0.6, 0.8])
    assert X_RS.translation() == pytest.approx(expected, abs=1e-9)
    radius = 0.05
    ball = plant.AddRigidBody(
        "ball", plant.AddModelInstance("ball"), SpatialInertia.SolidSphereWithMass(1.0, radius)
    )
    plant.RegisterCollisionGeometry(
        ball, RigidTransform(), Sphere(radius), "ball", CoulombFriction(1.0, 1.0)
    )
    plant.set_penetration_allowance(1e-4)
    plant.Finalize()
    simulator = Simulator(builder.Build())
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetFreeBodyPose(context, ball, RigidTransform([0.5, 0.5, radius + 0.05]))
    simulator.AdvanceTo(1.0)
    z = plant.EvalBodyPoseInWorld(context, ball).translation()[2]
    assert z - radius == pytest.approx(0, abs=1e-3)


def test_scenario_world_file_package_from_package_path(tmp_path, monkeypatch):
    """world_file: package://yard_world/... found through --package-path alone (as the
    robot description's packages are), not only ROS_PACKAGE_PATH; model:// includes of
    that world found in the package's models/."""
    from argparse import Namespace

    from armando_drake.simulation.scenario import apply_scenario_arguments, load_scenario

    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    package = tmp_path / "workspace" / "yard_world"
    _models(package / "models")
    (package / "package.xml").write_text("<package><name>yard_world</name></package>")
    (package / "worlds").mkdir()
    (package / "worlds" / "yard.sdf").write_text(WORLD)
    text = "world_file: package://yard_world/worlds/yard.sdf"
    scenario = load_scenario("position", text)
    with pytest.raises(WorldError, match=r"unknown package 'yard_world' \(searched "):
        MakeWorld(scenario)
    args = Namespace(set=[], description=None, package_path=[str(tmp_path / "workspace")])
    scenario = apply_scenario_arguments(load_scenario("position", text), args)
    plant = MakeWorld(scenario).robot().plant
    assert plant.HasModelInstanceNamed("crate_a") and plant.HasModelInstanceNamed("tag")


def _including(name: str, uri: str) -> str:
    return (
        f'<sdf version="1.9"><model name="{name}"><link name="link"/>'
        f"<include><uri>{uri}</uri></include></model></sdf>"
    )


@pytest.mark.parametrize("case", ["itself", "loop", "world", "binary"])
def test_include_loops_and_binary_worlds_are_one_line(tmp_path, case):
    """A model including itself, two models including each other, a world including
    itself, a binary world file: one WorldError line naming the file, no internal error."""
    models = tmp_path / "models"
    for name, uri in (("selfish", "model://selfish"), ("a", "model://b"), ("b", "model://a")):
        (models / name).mkdir(parents=True)
        (models / name / "model.sdf").write_text(_including(name, uri))
    world_file = tmp_path / "w.sdf"
    uri = {"itself": "model://selfish", "loop": "model://a", "world": world_file.as_uri()}
    if case == "binary":
        world_file.write_bytes(bytes(range(256)) * 4)
    else:
        world_file.write_text(
            f'<sdf version="1.9"><world name="w"><include><uri>{uri[case]}</uri></include>'
            "</world></sdf>"
        )
    _, plant, _ = _plant()
    with pytest.raises(WorldError) as error:
        load_world(plant, world_file, resource_paths=[models])
    message = str(error.value)
    assert "\n" not in message
    expected = {
        "itself": r"includes itself \(.*w\.sdf -> .*selfish/model\.sdf -> .*selfish/model\.sdf\)",
        "loop": r"a/model\.sdf includes itself \(.*a/model\.sdf -> .*b/model\.sdf -> .*a/model",
        "world": r"w\.sdf includes itself",
        "binary": r"w\.sdf: the world file is not a text \(SDFormat\) file",
    }[case]
    assert re.search(expected, message), message


FRAME_WORLD = """<?xml version="1.0"?>
<sdf version="1.6">
  <world name="old">
    <include>
      <uri>model://crate</uri>
      <name>crate_a</name>
      <pose frame="">1.5 -0.5 0 0 0 0.7</pose>
    </include>
    <model name="post"><static>true</static>
      <pose frame=''>0 2 0 0 0 0</pose>
      <link name="link"><pose frame="">0 0 0.5 0 0 0</pose>
        <collision name="collision"><geometry><box><size>0.1 0.1 1</size></box></geometry>
        </collision>
      </link>
    </model>
  </world>
</sdf>
"""


def test_sdformat_16_pose_frames(tmp_path):
    """SDFormat 1.6's <pose frame=""> (AWS RoboMaker's worlds write it on every include),
    which Drake's SDFormat 1.9 has no attribute for: an empty frame is the parent's."""
    _models(tmp_path / "models")
    world_file = tmp_path / "old.world"
    world_file.write_text(FRAME_WORLD)
    builder, plant, _ = _plant()
    world = load_world(plant, world_file)
    plant.Finalize()
    context = plant.GetMyContextFromRoot(builder.Build().CreateDefaultContext())

    def where(model):
        body = plant.GetBodyByName("link", world.models[model])
        return plant.EvalBodyPoseInWorld(context, body).translation()

    assert where("crate_a") == pytest.approx([1.5, -0.5, 0], abs=1e-9)
    assert where("post") == pytest.approx([0, 2, 0.5], abs=1e-9)


INVALID_STATIC_WORLD = """<?xml version="1.0"?>
<sdf version="1.6">
  <world name="floor">
    <model name="slab"><static>1</static>
      <link name="link">
        <inertial><mass>1000</mass>
          <inertia><ixx>1200083.33</ixx><iyy>8333416.66</iyy><izz>2033333.33</izz>
          </inertia></inertial>
        <collision name="collision"><geometry><box><size>4 4 0.1</size></box></geometry>
        </collision>
      </link>
    </model>
  </world>
</sdf>
"""


def test_a_static_model_with_an_invalid_inertia_loads(tmp_path):
    """A static model's inertia is never used (AWS RoboMaker's warehouse floor declares
    moments that fail the triangle inequality): it loads, welded where it is."""
    world_file = tmp_path / "floor.world"
    world_file.write_text(INVALID_STATIC_WORLD)
    builder, plant, _ = _plant()
    world = load_world(plant, world_file)
    assert _pose(plant, builder, world.models["slab"]).translation() == pytest.approx([0, 0, 0])
    assert plant.num_positions() == 0
