"""The course's own fra2mo package (../shared/upstream/rl_fra2mo_description), as users have
it: its body mesh is missing, its wheels collide with STL meshes named by file://$(find)
URIs, its DiffDrive plugin's wheel_separation (0.22 m, twice the body radius) is not its
wheels' (0.13 m)."""

import logging

import numpy as np
from mobile_world import run, scenario

SPAWN = "robot: {base_xyz: [0.0, 0.0, 0.1], base_rpy: [0.0, 0.0, 0.0]}"


def upstream(package, *overrides):
    return scenario(SPAWN, f"robot: {{description: {package}}}", *overrides)


def test_upstream_fra2mo_loads_rests_and_turns_as_in_gazebo(fra2mo_package, caplog):
    twist = "twist: {start_delay: 0.5, steps: [{linear: 0.2, angular: 0.2, duration: 2.5}]}"
    loaded = upstream(fra2mo_package, twist)
    with caplog.at_level(logging.INFO, logger="armando_drake"):
        result = run(loaded, 3.0)
    text = caplog.text
    # The missing body mesh is a warning; the wheels' STL meshes become cylinders.
    assert "rl_fra2mo_body.stl' not found" in text and "drawn without this visual" in text
    assert "'left_wheel_link' collides as a cylinder 0.035 m in radius and 0.006 m wide" in text
    assert "wheel_separation=0.22 m, but the wheels are 0.13 m apart" in text
    world = result.world
    assert world.robot().mobile.floating and world.robot().mobile.plugins == ["diff_drive"]
    # The base link keeps its own inertia (the missing visual does not shrink it).
    assert "link 'base_link': inertia" not in text
    # Resting before the command: on the ground, steady.
    z = result.between("z", 0.3, 0.5)
    assert np.ptp(z) < 1e-3 and abs(np.mean(z)) < 1e-3
    # Steady state: the speed as commanded, the yaw rate 0.22 / 0.13 times it (as Gazebo
    # turns the course's robot), each within 2 %.
    linear = np.mean(result.between("linear", 2.0, 2.9))
    angular = np.mean(result.between("angular", 2.0, 2.9))
    assert abs(linear - 0.2) / 0.2 < 0.02, linear
    assert abs(angular - 0.2 * 0.22 / 0.13) / (0.2 * 0.22 / 0.13) < 0.02, angular
    # Its odometry, computed with 0.22 m too, reports the commanded yaw rate.
    assert abs(np.mean(result.between("odom_angular", 2.0, 2.9)) - 0.2) < 0.004
