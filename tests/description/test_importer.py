"""Any ROS description into Drake: the course's arm_description and synthetic ones."""

from __future__ import annotations

import logging
import re
import struct
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import COURSE_PACKAGE
from pydrake.geometry import (
    Box,
    ClippingRange,
    ColorRenderCamera,
    Convex,
    MakeRenderEngineVtk,
    Mesh,
    RenderCameraCore,
    RenderEngineVtkParams,
    Role,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.sensors import CameraInfo

from armando_drake.control.controllers import default_controller_config
from armando_drake.description.importer import (
    actuated_joints,
    prepare_urdf,
)
from armando_drake.description.loader import DescriptionError, find_packages, load_robot

ARM_URDF = COURSE_PACKAGE / "urdf" / "arm.urdf"


@pytest.fixture
def arm(course_package) -> Path:
    """The course's arm_description (conftest: skipped if absent, failing under CI)."""
    return course_package


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch) -> Path:
    """A private mesh cache, so tests never touch the user's."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg-cache"))
    return tmp_path / "xdg-cache" / "armando_drake" / "meshes"


def _plant_with(description, **kwargs):
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    robot = load_robot(plant, description, **kwargs)
    plant.Finalize()
    return builder, plant, scene_graph, robot


def _proximity_ids(plant, scene_graph) -> dict[str, list]:
    """Body name -> ids of the proximity geometries registered for it."""
    inspector = scene_graph.model_inspector()
    result = {}
    for index in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        frame = plant.GetBodyFrameIdIfExists(body.index())
        if frame is None:
            continue
        ids = inspector.GetGeometries(frame, Role.kProximity)
        if ids:
            result[body.name()] = ids
    return result


def _proximity_shapes(plant, scene_graph) -> dict[str, list]:
    """Body name -> proximity shapes registered for it."""
    inspector = scene_graph.model_inspector()
    return {
        name: [inspector.GetShape(i) for i in ids]
        for name, ids in _proximity_ids(plant, scene_graph).items()
    }


# --------------------------------------------------------------------------
# The course's arm_description
# --------------------------------------------------------------------------


def test_arm_loads_with_four_revolute_joints(arm):
    _, plant, _, robot = _plant_with(arm)
    assert [(j.name, j.type) for j in robot.joints] == [(f"j{i}", "revolute") for i in range(4)]
    names = [plant.get_joint(i).name() for i in plant.GetJointIndices(robot.model_instance)]
    moving = [plant.GetJointByName(n, robot.model_instance) for n in names]
    assert sorted(j.name() for j in moving if j.num_positions() == 1) == ["j0", "j1", "j2", "j3"]
    assert plant.num_positions() == 4


def _strip_geometry(urdf: str) -> str:
    root = ET.fromstring(urdf)
    for link in root.findall("link"):
        for kind in ("visual", "collision"):
            for item in link.findall(kind):
                link.remove(item)
    return ET.tostring(root, encoding="unicode")


def test_arm_forward_kinematics_equal_the_urdf(arm):
    _, plant, _, robot = _plant_with(arm)
    reference = MultibodyPlant(0.0)
    (instance,) = Parser(reference).AddModelsFromString(
        _strip_geometry(ARM_URDF.read_text()), "urdf"
    )
    reference.WeldFrames(reference.world_frame(), reference.GetFrameByName("base_link", instance))
    reference.Finalize()
    context, reference_context = plant.CreateDefaultContext(), reference.CreateDefaultContext()
    bodies = [plant.get_body(i) for i in plant.GetBodyIndices(robot.model_instance)]
    assert len(bodies) == len(ET.fromstring(ARM_URDF.read_text()).findall("link")) == 17
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = rng.uniform(lower, upper)
        plant.SetPositions(context, q)
        reference.SetPositions(reference_context, q)
        for body in bodies:
            X_WB = plant.EvalBodyPoseInWorld(context, body)
            X_WR = reference.EvalBodyPoseInWorld(
                reference_context, reference.GetBodyByName(body.name(), instance)
            )
            assert np.abs(X_WB.GetAsMatrix4() - X_WR.GetAsMatrix4()).max() < 1e-9, body.name()


def _stl_bounds(path: Path) -> np.ndarray:
    """(2, 3) bounds of an STL file, read without trimesh."""
    data = path.read_bytes()
    (count,) = struct.unpack_from("<I", data, 80)
    if len(data) == 84 + 50 * count:
        records = np.frombuffer(data, dtype=np.uint8, offset=84).reshape(count, 50)
        points = records[:, 12:48].copy().view("<f4").reshape(-1, 3).astype(float)
    else:
        text = data.decode("ascii", errors="replace")
        points = np.array(re.findall(r"vertex\s+(\S+)\s+(\S+)\s+(\S+)", text), dtype=float)
    return np.array([points.min(axis=0), points.max(axis=0)])


def _obj_bounds(path: Path) -> np.ndarray:
    points = np.array(
        [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("v ")],
        dtype=float,
    )
    return np.array([points.min(axis=0), points.max(axis=0)])


def test_arm_meshes_are_the_stl_geometry_times_its_scale(arm):
    _, plant, scene_graph, _ = _plant_with(arm)
    inspector = scene_graph.model_inspector()
    urdf = ET.fromstring(ARM_URDF.read_text())
    declared = {}  # link -> (stl name, scale) of its visual
    for link in urdf.findall("link"):
        mesh = link.find("visual/geometry/mesh")
        if mesh is not None:
            scale = np.array(mesh.get("scale").split(), dtype=float)
            declared[link.get("name")] = (Path(mesh.get("filename")).name, scale)
    checked = 0
    for name, (stl, scale) in declared.items():
        frame = plant.GetBodyFrameIdIfExists(plant.GetBodyByName(name).index())
        (geometry,) = inspector.GetGeometries(frame, Role.kIllustration)
        shape = inspector.GetShape(geometry)
        assert isinstance(shape, Mesh) and shape.extension() == ".obj"
        loaded = _obj_bounds(Path(shape.source().path())) * shape.scale3()
        expected = _stl_bounds(arm / "meshes" / stl) * scale
        assert np.abs(loaded - expected).max() < 1e-4, (name, loaded, expected)
        checked += 1
    assert checked == 13


def test_arm_inertia_warnings_name_base_link_and_values(arm, caplog):
    search = find_packages(near=arm)
    with caplog.at_level(logging.WARNING, logger="armando_drake.description.importer"):
        prepared = prepare_urdf(ARM_URDF.read_text(), search, source=ARM_URDF)
    fixes = {fix.link: fix for fix in prepared.inertia_fixes}
    assert set(fixes) == {"base_link", "base_turn"}
    base = fixes["base_link"]
    assert base.old[:3] == (1.06682889e08, 9.92165844e07, 1.26939175e08)
    assert base.mass == 0.1
    # A 0.1 kg part a few centimetres across: inertia around 1e-4 kg m^2.
    assert all(5e-5 < moment < 5e-4 for moment in base.new)
    (message,) = [w for w in prepared.warnings if "'base_link'" in w]
    assert "arm.urdf:24" in message and "1.067e+08" in message and f"{base.new[0]:.4g}" in message
    assert message in caplog.text
    # Drake now holds the replaced inertia.
    _, plant, _, _ = _plant_with(arm)
    inertia = plant.GetBodyByName("base_link").default_rotational_inertia()
    assert inertia.CalcPrincipalMomentsOfInertia().max() < 1e-3


def test_arm_second_preparation_converts_nothing(arm, cache):
    search = find_packages(near=arm)
    text = ARM_URDF.read_text()
    first = prepare_urdf(text, search, source=ARM_URDF, collision="as-is")
    second = prepare_urdf(text, search, source=ARM_URDF, collision="as-is")
    assert len(first.converted) == 8  # distinct STL files the URDF uses
    assert second.converted == []
    assert [m.path for m in second.meshes] == [m.path for m in first.meshes]
    assert sorted(p.name for p in cache.glob("*.obj")) == sorted(m.path.name for m in first.meshes)


@pytest.mark.parametrize(
    "mode, shape_type, per_body",
    [
        ("auto", Convex, 1),
        ("boxes", Box, 1),
        ("convex", Convex, 1),
        ("as-is", Mesh, 1),
        ("none", None, 0),
    ],
)
def test_arm_collision_modes(arm, mode, shape_type, per_body):
    builder, plant, scene_graph, _ = _plant_with(arm, collision=mode)
    shapes = _proximity_shapes(plant, scene_graph)
    if per_body == 0:
        assert shapes == {}
        return
    assert len(shapes) == 13  # every link with visual geometry
    assert all(len(s) == per_body and isinstance(s[0], shape_type) for s in shapes.values())
    # No self-contact at rest: a servo and the bracket across its joint are filtered...
    diagram = builder.Build()
    context = scene_graph.GetMyContextFromRoot(diagram.CreateDefaultContext())
    query = scene_graph.get_query_output_port().Eval(context)
    assert query.ComputePointPairPenetration() == []
    ids = {name: found[0] for name, found in _proximity_ids(plant, scene_graph).items()}
    inspector = scene_graph.model_inspector()
    assert inspector.CollisionFiltered(ids["dyn2"], ids["f4"])
    assert inspector.CollisionFiltered(ids["dyn3"], ids["f5"])
    # ...but links further apart still collide.
    assert not inspector.CollisionFiltered(ids["base_link"], ids["wrist"])
    assert not inspector.CollisionFiltered(ids["dyn2"], ids["f5"])
    if mode == "boxes":
        # The base box is the base STL's bounding box (millimetres times 0.001).
        bounds = _stl_bounds(arm / "meshes" / "base_link.stl") * 0.001
        assert np.allclose(shapes["base_link"][0].size(), bounds[1] - bounds[0], atol=1e-6)


def test_arm_is_drawn(arm):
    def render(description) -> np.ndarray:
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
        if description is not None:
            load_robot(plant, description)
        plant.Finalize()
        scene_graph.AddRenderer("vtk", MakeRenderEngineVtk(RenderEngineVtkParams()))
        diagram = builder.Build()
        context = diagram.CreateDefaultContext()
        query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
        core = RenderCameraCore(
            "vtk", CameraInfo(320, 240, np.pi / 3), ClippingRange(0.01, 10.0), RigidTransform()
        )
        # Camera 0.6 m in front of the arm (-y), level with its middle, looking at +y.
        X_WC = RigidTransform(RotationMatrix.MakeXRotation(-np.pi / 2), [0.0, -0.6, 0.17])
        image = query.RenderColorImage(ColorRenderCamera(core), scene_graph.world_frame_id(), X_WC)
        return np.array(image.data)[:, :, :3].astype(int)

    blank, drawn = render(None), render(arm)
    changed = np.any(blank != drawn, axis=2)
    red = (drawn[:, :, 0] > 120) & (drawn[:, :, 1] < 60) & (drawn[:, :, 2] < 60)
    assert changed.sum() > 2000  # of 76800 pixels
    assert red.sum() > 400  # the arm's "red" material
    # The upright arm stands in the middle of the picture, its ~35 cm height in full view.
    columns, rows = np.nonzero(changed.any(axis=0))[0], np.nonzero(changed.any(axis=1))[0]
    assert 140 < columns.mean() < 180 and columns.max() - columns.min() < 80
    assert 5 < rows.min() < 60 and 160 < rows.max() < 235


# --------------------------------------------------------------------------
# Synthetic descriptions
# --------------------------------------------------------------------------

URDF_TEMPLATE = """<?xml version="1.0"?>
<robot name="synthetic">
  <link name="base">
    <visual><geometry><box size="0.2 0.2 0.1"/></geometry></visual>
    <inertial>
      <mass value="1"/><inertia ixx="0.004" iyy="0.004" izz="0.007" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <link name="arm">
    <visual>
      <origin xyz="0 0 0.05" rpy="0 0 1.5707963267948966"/>
      <geometry>
        <mesh filename="package://synthetic/meshes/part.stl" scale="0.01 0.01 0.01"/>
      </geometry>
    </visual>
    <collision>
      <geometry><mesh filename="{collision}"/></geometry>
    </collision>
    <inertial>
      <mass value="0.5"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <joint name="j2" type="revolute">
    <parent link="arm"/><child link="tip"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <link name="tip">
    <visual><geometry><mesh filename="../meshes/part.dae"/></geometry></visual>
  </link>
  <transmission name="t1">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="j1">
      <hardwareInterface>hardware_interface/PositionJointInterface</hardwareInterface>
    </joint>
    <actuator name="m1"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
</robot>
"""


@pytest.fixture
def synthetic(tmp_path) -> Path:
    """A package ``synthetic``: ASCII STL (cm), Collada (unit 0.01 m), a massless tip."""
    package = tmp_path / "ws" / "synthetic"
    (package / "meshes").mkdir(parents=True)
    (package / "urdf").mkdir()
    (package / "package.xml").write_text(
        '<?xml version="1.0"?><package format="3"><name>synthetic</name></package>'
    )
    # 4 x 2 x 6 cm part in centimetres, as an ASCII STL.
    box = trimesh.creation.box((4.0, 2.0, 6.0))
    (package / "meshes" / "part.stl").write_text(trimesh.exchange.stl.export_stl_ascii(box))
    (package / "meshes" / "hull.obj").write_text(trimesh.exchange.obj.export_obj(box))
    # The same part as Collada, declared in centimetres.
    dae = trimesh.exchange.dae.export_collada(box).decode()
    dae = dae.replace("<up_axis>", '<unit meter="0.01" name="centimeter"/><up_axis>')
    (package / "meshes" / "part.dae").write_text(dae)
    (package / "meshes" / "part.ply").write_text("ply\n")
    write_urdf(package, "package://synthetic/meshes/part.stl")
    return package


def write_urdf(package: Path, collision: str) -> Path:
    path = package / "urdf" / "robot.urdf"
    path.write_text(URDF_TEMPLATE.replace("{collision}", collision))
    return path


def test_synthetic_loads_with_stl_dae_and_geometry_mass(synthetic, caplog):
    with caplog.at_level(logging.WARNING, logger="armando_drake.description.importer"):
        builder, plant, scene_graph, robot = _plant_with(synthetic, collision="boxes")
    tip = plant.GetBodyByName("tip")
    # The massless tip weighs its 4 x 2 x 6 cm Collada visual (in cm) at 1000 kg/m^3.
    mass = 1000.0 * 0.04 * 0.02 * 0.06
    assert tip.default_mass() == pytest.approx(mass)
    # About its centre: ixx = m (b^2 + c^2) / 12.
    moments = tip.default_rotational_inertia().get_moments()
    assert np.allclose(moments, mass * np.array([40, 52, 20]) * 1e-4 / 12)
    assert "1 link(s) declare no mass" in caplog.text and "tip 0.048 kg" in caplog.text
    # With collision boxes, the arm's STL collision became one box around its rotated
    # visual: 2 x 4 x 6 cm at z 5 cm.
    (box,) = _proximity_shapes(plant, scene_graph)["arm"]
    assert np.allclose(box.size(), [0.02, 0.04, 0.06])
    # The simulation runs (a massless tip would fail here).
    from pydrake.systems.analysis import Simulator

    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.05)
    assert np.all(
        np.isfinite(plant.GetPositions(plant.GetMyContextFromRoot(simulator.get_context())))
    )


def test_synthetic_dae_unit_is_applied(synthetic):
    prepared = prepare_urdf(
        (synthetic / "urdf" / "robot.urdf").read_text(),
        find_packages(near=synthetic),
        source=synthetic / "urdf" / "robot.urdf",
    )
    (dae,) = [m for m in prepared.meshes if m.source.suffix == ".dae"]
    bounds = _obj_bounds(dae.path)
    assert np.allclose(bounds[1] - bounds[0], [0.04, 0.02, 0.06])
    (stl,) = [m for m in prepared.meshes if m.source.suffix == ".stl"]
    assert np.allclose(_obj_bounds(stl.path), [[-2, -1, -3], [2, 1, 3]])


def test_synthetic_actuation_and_default_controllers(synthetic):
    root = ET.fromstring((synthetic / "urdf" / "robot.urdf").read_text())
    assert actuated_joints(root) == (["j1"], "transmission")
    ros2 = ET.fromstring(
        "<robot><joint name='a' type='revolute'/><joint name='b' type='revolute'/>"
        "<ros2_control name='s' type='system'><joint name='b'>"
        "<command_interface name='position'/></joint><joint name='a'>"
        "<command_interface name='velocity'/></joint></ros2_control></robot>"
    )
    assert actuated_joints(ros2) == (["b"], "ros2_control")
    for transmission in root.findall("transmission"):
        root.remove(transmission)
    assert actuated_joints(root) == (["j1", "j2"], "non-fixed joints")
    config = default_controller_config(["j1", "j2"])
    manager = config["controller_manager"]["ros__parameters"]
    assert manager["update_rate"] == 100
    assert manager["trajectory_controller"]["type"] == (
        "joint_trajectory_controller/JointTrajectoryController"
    )
    assert config["position_controller"]["ros__parameters"]["joints"] == ["j1", "j2"]
    assert config["trajectory_controller"]["ros__parameters"]["joints"] == ["j1", "j2"]


def test_synthetic_obj_collision_passes_through_as_is(synthetic):
    write_urdf(synthetic, "package://synthetic/meshes/hull.obj")
    _, plant, scene_graph, _ = _plant_with(synthetic, collision="as-is")
    (mesh,) = _proximity_shapes(plant, scene_graph)["arm"]
    assert isinstance(mesh, Mesh)
    assert Path(mesh.source().path()) == synthetic / "meshes" / "hull.obj"


AT_COLLISION = r"robot\.urdf:(?P<line>\d+): link 'arm': "


@pytest.mark.parametrize(
    "collision, expected",
    [
        (
            "package://synthetic/meshes/gone.stl",
            r"'package://synthetic/meshes/gone\.stl' not found",
        ),
        (
            "package://synthetic/meshes/part.ply",
            r"unsupported mesh format '\.ply'; supported: \.stl, \.dae, \.obj, \.gltf",
        ),
        (
            "package://nope/part.stl",
            r"unknown package 'nope' \(searched .*package of the description: ",
        ),
    ],
)
def test_synthetic_bad_meshes_name_file_and_line(synthetic, collision, expected):
    path = write_urdf(synthetic, collision)
    with pytest.raises(DescriptionError, match=AT_COLLISION + ".*" + expected) as error:
        _plant_with(synthetic)
    line = int(re.search(AT_COLLISION, str(error.value))["line"])
    assert collision in path.read_text().splitlines()[line - 1]


def test_unknown_collision_mode_is_refused(synthetic):
    with pytest.raises(DescriptionError, match=r"collision='hulls' must be one of"):
        _plant_with(synthetic, collision="hulls")
