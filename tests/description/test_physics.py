"""The physics a description brings when it says nothing of it: servo gains derived from
the robot, collision meshes as convex hulls, seed targets clear of the floor, masses from
geometry (docs/physics.md)."""

import logging
import math

import numpy as np
import pytest
import trimesh
from fixture_packages import box_inertia, chain_urdf, l_profile
from pydrake.geometry import Convex
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from armando_drake.control.gains import SAG_ROTATION
from armando_drake.description.inertia_repairs import DEFAULT_MASS
from armando_drake.description.loader import load_robot
from armando_drake.sensors.objects import AddGround
from armando_drake.simulation.run import run
from armando_drake.simulation.scenario import ONE_ROBOT, load_scenario

QUIET = "logging: {console_rate: 0}\nsimulator_config: {target_realtime_rate: 0}"

# A 30 kg six-joint arm: a 6 kg base and links of 6, 6, 5, 3, 2 and 1 kg, 1.6 m tall.
HEAVY = dict(
    width=0.12,
    lengths=[0.3, 0.5, 0.4, 0.15, 0.15, 0.1],
    masses=[6.0, 6.0, 5.0, 3.0, 2.0, 1.0],
    efforts=[400, 400, 250, 60, 60, 20],
    base=(0.25, 0.15, 7.0),
)
# A 1 kg arm: a 0.3 kg base and links of 0.2, 0.2, 0.15, 0.08, 0.05 and 0.02 kg.
LIGHT = dict(
    width=0.04,
    lengths=[0.08, 0.15, 0.12, 0.05, 0.05, 0.03],
    masses=[0.2, 0.2, 0.15, 0.08, 0.05, 0.02],
    efforts=[6, 6, 4, 1.5, 1.5, 0.5],
    base=(0.1, 0.05, 0.3),
)


def write(tmp_path, name: str, text: str):
    path = tmp_path / f"{name}.urdf"
    path.write_text(text)
    return path


def run_seed(tmp_path, urdf, *sets: str):
    """The seed targets (sized to the robot) on its position controller, 2 s apart,
    with no gains in the scenario; (the run's result, its world's hardware joints)."""
    text = "\n".join(
        [QUIET, f"robot: {{description: {urdf}, base_xyz: [0, 0, 0]}}", *sets]
        + ["sequencer: !PositionTargets {period: 2.0}"]
    )
    scenario = load_scenario("position", text)
    actuators = scenario.robots[ONE_ROBOT].actuators
    assert actuators.kp is None and actuators.kd is None
    result = run(scenario, output_dir=tmp_path / "out", quiet=True, replay=False, plots=False)
    ran = load_scenario(tmp_path / "out" / "scenario.yaml").robots[ONE_ROBOT]  # as it ran
    return result, ran


@pytest.mark.parametrize("arm, mass", [(HEAVY, 30.0), (LIGHT, 1.0)])
@pytest.mark.parametrize("feedforward", [True, False])
def test_an_arm_without_gains_reaches_the_seed_targets(tmp_path, caplog, arm, mass, feedforward):
    assert sum(arm["masses"]) + arm["base"][2] == pytest.approx(mass)
    urdf = write(tmp_path, "arm", chain_urdf("arm", **arm))
    with caplog.at_level(logging.INFO, logger="armando_drake.world"):
        result, ran = run_seed(
            tmp_path, urdf, f"actuators: {{gravity_feedforward: {str(feedforward).lower()}}}"
        )
    assert len(result.steps) == 5
    errors = [step.final_error for step in result.steps]
    assert max(errors) <= 0.01, errors
    # The gains are logged on one line and written to the effective scenario.
    (line,) = [r.message for r in caplog.records if r.message.startswith("actuator gains of")]
    assert line.startswith("actuator gains of arm (derived: wn 30 rad/s, zeta 1")
    gains = ran.actuators.gains
    assert sorted(gains) == [f"joint_{k}" for k in range(1, 7)]
    for joint, (kp, kd) in gains.items():
        assert f"{joint} kp {kp:.4g} kd {kd:.4g}" in line
        assert kp > 0 and kd >= 0


def test_an_arm_without_inertials_or_effort_limits_reaches_the_seed_targets(tmp_path, caplog):
    """A ROS-Industrial style description: no <inertial>, effort="0". Its links weigh
    their boxes at 1000 kg/m^3; its actuators are unlimited, and say so."""
    arm = dict(HEAVY, efforts=[0] * 6)
    urdf = write(tmp_path, "bare_arm", chain_urdf("bare_arm", **arm, inertials=False))
    with caplog.at_level(logging.INFO):
        result, ran = run_seed(tmp_path, urdf)
    messages = [r.message for r in caplog.records]
    (masses,) = [m for m in messages if "6 link(s) declare no mass" in m]
    total = 1000.0 * 0.12**2 * sum(HEAVY["lengths"])
    assert f"{total:.4g} kg in all" in masses
    assert any("no effort limit (effort missing or 0) on joint_1" in m for m in messages)
    assert sorted(ran.actuators.gains) == [f"joint_{k}" for k in range(1, 7)]
    errors = [step.final_error for step in result.steps]
    assert len(errors) == 5 and max(errors) <= 0.01, errors


def test_derived_stiffness_holds_the_heavy_arm_within_the_sag_bound(tmp_path):
    """Without feed-forward, gravity bends each joint by at most tau_g / kp: below
    SAG_ROTATION wherever the effort limit allows that stiffness."""
    from armando_drake.control.gains import joint_loads
    from armando_drake.simulation.builder import MakeWorld

    urdf = write(tmp_path, "arm", chain_urdf("arm", **HEAVY))
    scenario = load_scenario("position", f"{QUIET}\nrobot: {{description: {urdf}}}")
    world = MakeWorld(scenario, quiet=True)
    loads = joint_loads(world.plant, world.robot().robot, world.robot().stack.hardware)
    for joint in world.robot().stack.hardware.joints:
        load = loads[joint.name]
        # The shoulder carries the arm: 112 N m at the worst pose, so kp > 2.2e4 N m/rad.
        if joint.name == "joint_2":
            assert load.gravity == pytest.approx(9.81 * 11.65, rel=0.1)
        assert load.gravity / joint.kp <= SAG_ROTATION + 1e-12
        assert joint.kp >= load.inertia * 30.0**2 - 1e-9
        assert joint.kd == pytest.approx(max(0.0, 2 * math.sqrt(joint.kp * load.inertia)), rel=1e-9)
    world.close()


def test_the_iiwa_without_gains_reaches_every_seed_style_target(iiwa_package, tmp_path, caplog):
    with caplog.at_level(logging.INFO, logger="armando_drake.world"):
        result, ran = run_seed(tmp_path, iiwa_package)
    (line,) = [r.message for r in caplog.records if r.message.startswith("actuator gains of")]
    assert line.startswith("actuator gains of iiwa14 (derived: wn 30 rad/s, zeta 1")
    assert sorted(ran.actuators.gains) == [f"iiwa_joint_{k}" for k in range(1, 8)]
    errors = [step.final_error for step in result.steps]
    assert len(errors) == 5 and max(errors) <= 0.01, (errors, line)


# ---------------------------------------------------------------------------- collisions

L_ARM = """<?xml version="1.0"?>
<robot name="l_arm">
  <link name="base_link">
    <collision><origin xyz="0 0 0.03"/><geometry><box size="0.1 0.1 0.05"/></geometry></collision>
    <inertial><mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <link name="bracket">
    <visual><geometry><mesh filename="bracket.stl"/></geometry></visual>
    <collision><geometry><mesh filename="bracket.stl"/></geometry></collision>
    <inertial><mass value="0.5"/>
      <inertia ixx="1e-2" iyy="1e-2" izz="1e-2" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="yaw" type="revolute">
    <parent link="base_link"/><child link="bracket"/>
    <!-- Tilted 135 degrees: the L's open corner points at the floor. -->
    <origin xyz="0 0 0.5" rpy="0 2.356194490192345 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/>
  </joint>
</robot>
"""


def _contacts_at_home(urdf, collision: str) -> tuple[list[tuple[str, str]], object]:
    """(body pairs in contact with the robot at its default pose, bracket's shape)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    load_robot(plant, urdf, collision=collision)
    AddGround(plant, scene_graph)
    plant.Finalize()
    diagram = builder.Build()
    context = scene_graph.GetMyContextFromRoot(diagram.CreateDefaultContext())
    query = scene_graph.get_query_output_port().Eval(context)
    inspector = scene_graph.model_inspector()

    def body(geometry) -> str:
        return plant.GetBodyFromFrameId(inspector.GetFrameId(geometry)).name()

    pairs = [
        tuple(sorted((body(p.id_A), body(p.id_B)))) for p in query.ComputePointPairPenetration()
    ]
    bracket = plant.GetBodyByName("bracket")
    (shape,) = [inspector.GetShape(g) for g in plant.GetCollisionGeometriesForBody(bracket)]
    return pairs, shape


def test_an_l_shaped_link_collides_as_its_hull_not_its_bounding_box(tmp_path):
    """The L (two 4 cm bars 0.5 m long) hangs 0.5 m up, its open corner down: its convex
    hull stays 0.11 m above the floor, the box around it reaches 0.2 m below."""
    vertices, faces = l_profile(0.04, 0.5)
    trimesh.Trimesh(vertices, faces).export(tmp_path / "bracket.stl")
    urdf = write(tmp_path, "l_arm", L_ARM)
    pairs, shape = _contacts_at_home(urdf, "auto")
    assert isinstance(shape, Convex) and pairs == []
    # Drake collides with the L's own hull (cached as OBJ), not a box around it.
    path = str(shape.source().path())
    assert path.endswith(".hull.obj")
    hull = trimesh.load(path)
    assert hull.volume == pytest.approx(trimesh.Trimesh(vertices, faces).convex_hull.volume)
    pairs, _ = _contacts_at_home(urdf, "boxes")
    assert ("bracket", "ground") in pairs


def test_seed_targets_that_hit_the_floor_are_scaled_back(tmp_path, caplog):
    """A 1 m arm lying along x, 0.3 m above the floor on a 4 cm post: the seed's shoulder
    pitch of +1.0 rad would put its tip 0.54 m into the floor; the target is scaled back
    until the arm clears it, and reached."""
    arm = chain_urdf(
        "flat", width=0.06, lengths=[0.05, 1.0], masses=[1.0, 2.0], efforts=[200, 200],
        base=(0.04, 0.25, 3.0), axes=("0 0 1", "0 1 0"),
    )  # fmt: skip
    # The second link lies along +x at home.
    tilted = f'<origin xyz="0 0 0.05" rpy="0 {math.pi / 2!r} 0"/>'
    arm = arm.replace('<origin xyz="0 0 0.05"/>', tilted)
    urdf = write(tmp_path, "flat", arm)
    with caplog.at_level(logging.WARNING, logger="armando_drake.world"):
        result, _ = run_seed(tmp_path, urdf)
    scaled = [r.message for r in caplog.records if "scaled back" in r.message]
    assert len(scaled) == 1 and "seed target 2 of flat scaled back" in scaled[0], scaled
    assert "link_2 with ground" in scaled[0]
    pitch = result.steps[2].target[1]
    # Clear: the tip (1 m out, 3 cm thick) stays above the floor at 0.3 m.
    assert 0 < pitch and math.sin(pitch) * 1.0 + 0.03 < 0.30
    assert pitch >= 0.1  # scaled back by no more than needed (steps of 10 %)
    assert max(step.final_error for step in result.steps) <= 0.01


def test_armandos_own_seed_is_clear_of_collisions():
    """The built-in Armando's seed targets are not checked in a world (they were written
    for it): they are clear, paths included."""
    from armando_drake.control.clearance import clear_targets
    from armando_drake.control.sequencer import SEED_TARGETS
    from armando_drake.simulation.builder import MakeWorld

    world = MakeWorld(load_scenario("position", QUIET), quiet=True)
    seed = [list(target) for target in SEED_TARGETS]
    names = world.robot().stack.hardware.joint_names
    start = [joint.initial_position for joint in world.robot().stack.hardware.joints]
    instance = world.robot().robot.model_instance
    assert clear_targets(world.plant, world.scene_graph, instance, names, seed, start) == seed
    world.close()


# ---------------------------------------------------------------------------- inertia

NO_INERTIAL = """<?xml version="1.0"?>
<robot name="bare">
  <link name="base_link">
    <inertial><mass value="2"/>{base}</inertial>
  </link>
  <link name="box_link">
    <collision><origin xyz="0 0 0.15" rpy="0 0 0.3"/>
      <geometry><box size="0.1 0.2 0.3"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="box_link"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <link name="mesh_link">
    <visual><geometry><cylinder radius="0.05" length="0.2"/></geometry></visual>
    <collision><geometry><mesh filename="rod.stl" scale="0.001 0.001 0.001"/></geometry></collision>
  </link>
  <joint name="j2" type="revolute"><parent link="box_link"/><child link="mesh_link"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <link name="cylinder_link">
    <visual><geometry><cylinder radius="0.05" length="0.2"/></geometry></visual>
  </link>
  <joint name="j3" type="revolute"><parent link="mesh_link"/><child link="cylinder_link"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <link name="frame_link"/>
  <joint name="j4" type="revolute"><parent link="cylinder_link"/><child link="frame_link"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>
"""


@pytest.mark.parametrize("density", [1000.0, 2700.0])
def test_links_without_inertial_weigh_their_geometry(tmp_path, caplog, density):
    # A 2 x 4 x 10 cm rod in millimetres, as an STL.
    trimesh.creation.box(extents=(20, 40, 100)).export(tmp_path / "rod.stl")
    urdf = write(tmp_path, "bare", NO_INERTIAL.replace("{base}", box_inertia(2, (0.1,) * 3)))
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, 0.001)
    with caplog.at_level(logging.WARNING, logger="armando_drake.description.importer"):
        robot = load_robot(plant, urdf, density=density)
    plant.Finalize()
    volumes = {
        "box_link": 0.1 * 0.2 * 0.3,  # its collision box
        "mesh_link": 0.02 * 0.04 * 0.1,  # its collision mesh, not its visual cylinder
        "cylinder_link": math.pi * 0.05**2 * 0.2,  # no collision: its visual
    }
    for link, volume in volumes.items():
        assert plant.GetBodyByName(link).default_mass() == pytest.approx(density * volume)
    # The box's inertia about its centre, in its own axes: m (b^2 + c^2) / 12, ...
    body = plant.GetBodyByName("box_link")
    mass = density * volumes["box_link"]
    about_com = body.default_spatial_inertia().Shift(body.default_com())
    moments = about_com.CalcRotationalInertia().CalcPrincipalMomentsOfInertia()
    expected = mass / 12 * np.array([0.2**2 + 0.3**2, 0.1**2 + 0.3**2, 0.1**2 + 0.2**2])
    assert np.allclose(np.sort(moments), np.sort(expected))
    assert np.allclose(body.default_com(), [0, 0, 0.15])
    # A link without any geometry keeps the small default mass.
    assert plant.GetBodyByName("frame_link").default_mass() == DEFAULT_MASS
    # One warning names every link given its geometry's mass.
    (line,) = [r.message for r in caplog.records if "declare no mass" in r.message]
    assert line.count(" kg (") == 3 and "box_link" in line and "cylinder_link" in line
    assert f"at {density:g} kg/m^3" in line
    assert any("box_link" in w for w in robot.warnings)
