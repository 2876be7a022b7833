"""A robot described in SDFormat (a Gazebo model folder) is the robot: its DiffDrive
plugin drives it on cmd_vel, its gpu_lidar scans, its model:// mesh resolves."""

import math

import numpy as np
import pytest
from mobile_world import FIXTURES, run, scenario

from armando_drake.description.loader import expand_description, resolve_description
from armando_drake.description.packages import find_packages

SDF_BOT = FIXTURES / "sdf_bot"
WALL_WORLD = FIXTURES / "sdf_wall_world.sdf"
WALL_X = 2.0  # [m] the wall's face
LIDAR_X = 0.1  # [m] the lidar ahead of base_footprint (chassis 0 + lidar_link 0.1)


def test_a_model_folder_is_its_model_sdf_written_as_urdf():
    search = find_packages(near=SDF_BOT)
    assert resolve_description(str(SDF_BOT), search) == SDF_BOT / "model.sdf"
    urdf = expand_description(SDF_BOT / "model.sdf", search=search)
    assert '<robot name="sdf_bot">' in urdf
    assert f"file://{SDF_BOT / 'meshes' / 'chassis.obj'}" in urdf  # model:// resolved
    assert 'filename="gz-sim-diff-drive-system"' in urdf  # the plugin, in <gazebo>
    assert '<gazebo reference="lidar_link">' in urdf  # the sensor, on its link
    # The lidar link's pose is relative_to the chassis: 0.1 ahead, 0.05 above it.
    assert '<origin xyz="0.1 0 0.05" rpy="0 0 0" />' in urdf
    # A ball caster is fixed, frictionless.
    assert '<joint name="rear_caster_joint" type="fixed">' in urdf


def test_sdf_robot_drives_on_cmd_vel_and_scans_the_wall():
    twist = "twist: {start_delay: 0.5, steps: [{linear: 0.2, angular: 0.0, duration: 2.0}]}"
    loaded = scenario(
        f"robot: {{description: {SDF_BOT}, base_xyz: [0, 0, 0.005]}}",
        f"world_file: {WALL_WORLD}",
        twist,
    )
    result = run(loaded, 3.0)
    robot = result.world.robot()
    assert [d.name for d in robot.robot.drives] == ["gz::sim::systems::DiffDrive"]
    x = result.column("x")[-1]
    assert x == pytest.approx(0.4, abs=0.03)  # 0.2 m/s for 2 s
    assert abs(result.column("y")[-1]) < 0.01
    assert result.column("z")[-1] == pytest.approx(0.0, abs=0.005)  # on its wheels
    port = robot.sensors["front_lidar"]["scan"]
    scan = port.Eval(port.get_system().GetMyContextFromRoot(result.simulator.get_context()))
    scan = scan.message
    assert scan.frame_id == "lidar_link" and len(scan.ranges) == 360
    ahead = float(scan.ranges[int(np.argmin(np.abs(scan.angles())))])
    assert ahead == pytest.approx(WALL_X - x - LIDAR_X, abs=0.02)
    sideways = scan.ranges[int(np.argmin(np.abs(scan.angles() - math.pi / 2)))]
    assert np.isposinf(sideways)  # nothing to the left
