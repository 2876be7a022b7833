"""fra2mo, the course's mobile robot: it rests on its wheels, follows cmd_vel, and its wheel
odometry agrees with the ground truth where its wheels do not slip."""

import math

import numpy as np
from mobile_world import run, scenario

# The course spawns fra2mo 0.1 m above the ground (gazebo_fra2mo.launch.py).
SPAWN = "robot: {base_xyz: [0.0, 0.0, 0.1], base_rpy: [0.0, 0.0, 0.0]}"
IDLE = "twist: null"


def _rests(result, start: float, end: float) -> None:
    """Between ``start`` and ``end`` [s]: base height steady within 1 mm, on the ground
    within 1 mm, horizontal drift under 1 mm/s, level (heading unchanged)."""
    z = result.between("z", start, end)
    x, y = result.between("x", start, end), result.between("y", start, end)
    assert np.ptp(z) < 1e-3, f"base height varies by {np.ptp(z) * 1e3:.3f} mm"
    assert abs(float(np.mean(z))) < 1e-3, f"base_footprint {np.mean(z) * 1e3:.3f} mm off the ground"
    drift = math.hypot(x[-1] - x[0], y[-1] - y[0]) / (end - start)
    assert drift < 1e-3, f"drifts {drift * 1e3:.3f} mm/s while idle"


def test_fra2mo_spawned_at_the_course_pose_rests_on_its_wheels():
    result = run(scenario(SPAWN, IDLE, "simulation: {duration: 2.0}"), 2.0)
    world = result.world
    assert world.robot().mobile.floating and world.robot().mobile.base_link == "base_footprint"
    assert world.robot().mobile.plugins == ["diff_drive"]
    assert world.robot().stack.hardware.interfaces() == ["velocity", "velocity"]
    # It falls 0.1 m, lands, and rests: over the last second nothing moves.
    assert result.at("z", 0.0) == 0.1
    _rests(result, 1.0, 2.0)
    assert abs(result.column("yaw")[-1]) < 1e-3


def test_cmd_vel_steady_state_twist_within_two_percent():
    twist = "twist: {start_delay: 0.5, steps: [{linear: 0.2, angular: 0.2, duration: 3.0}]}"
    result = run(scenario(twist), 3.5)
    linear = result.between("linear", 2.0, 3.4)
    angular = result.between("angular", 2.0, 3.4)
    assert abs(np.mean(linear) - 0.2) / 0.2 < 0.02, np.mean(linear)
    assert abs(np.mean(angular) - 0.2) / 0.2 < 0.02, np.mean(angular)
    # The odometry reports the same twist (its rolling mean), within 1 %.
    assert abs(np.mean(result.between("odom_linear", 2.0, 3.4)) - 0.2) < 0.002
    assert abs(np.mean(result.between("odom_angular", 2.0, 3.4)) - 0.2) < 0.002


def test_odometry_agrees_with_ground_truth_on_a_straight_and_a_turn():
    # 0.4 m straight, a quarter turn of radius 0.2 m to the left, 0.3 m straight.
    steps = (
        "twist: {start_delay: 0.5, steps: ["
        "{linear: 0.2, angular: 0.0, duration: 2.0},"
        "{linear: 0.1, angular: 0.5, duration: 3.14159},"
        "{linear: 0.2, angular: 0.0, duration: 1.5}]}"
    )
    result = run(scenario(steps), 7.5)
    summary = result.world.robot().base_log.summary()
    travelled = summary["distance_travelled"]
    assert 1.0 < travelled < 1.1  # 0.4 + pi/2 * 0.2 + 0.3 m, less what the ramps take
    drift = summary["odometry_drift"]
    # The wheels hardly slip: at the axle, which the odometry integrates, within 1 % of the
    # distance, and the heading within 0.01 rad of a quarter turn.
    assert drift["max_position_at_axle"] < 0.01 * travelled, drift
    assert drift["final_heading"] < 0.01, drift
    assert abs(summary["final_pose_odom_frame"]["yaw"] - math.pi / 2) < 0.02
    # base_footprint is 0.04025 m behind the axle: its odometry is off by that offset turned
    # through the quarter turn (0.04025 * sqrt(2) = 0.057 m), plus the slip above.
    offset = 0.04025 * math.sqrt(2)
    assert abs(drift["final_position"] - offset) < 0.01, drift


def test_the_summary_has_a_base_section(tmp_path):
    from armando_drake.simulation.run import run as run_scenario

    loaded = scenario(
        "twist: {start_delay: 0.2, steps: [{linear: 0.2, angular: 0.0, duration: 1.0}]}",
        "simulation: {duration: 1.5}",
        "simulator_config: {target_realtime_rate: 0.0}",
    )
    result = run_scenario(loaded, output_dir=tmp_path, quiet=True, replay=False)
    assert result.controller == "twist" and result.driven == "diff_drive"
    base = result.base
    assert 0.17 < base["distance_travelled"] < 0.21  # 0.2 m/s for 1 s, less the ramp
    assert abs(base["final_pose"]["x"] - base["distance_travelled"]) < 2e-3
    # The step from rest to 0.2 m/s spins the wheels up at once (the plugin has no
    # acceleration limit): they slip for some 30 ms until friction has the 10 kg robot
    # moving, and the odometry counts those few millimetres that were not travelled.
    assert 1e-3 < base["odometry_drift"]["final_position"] < 6e-3
    header = (tmp_path / "base.csv").read_text().splitlines()[0]
    assert header.startswith("time,x,y,z,yaw,")
    assert (tmp_path / "base_path.png").is_file() and (tmp_path / "base_velocity.png").is_file()
