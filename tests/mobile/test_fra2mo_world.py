"""fra2mo with its lidar in a world: the package's own arena (diagrams/fra2mo.yaml) and
the course's race field; the scan sees the obstacles where the world puts them."""

import math

import numpy as np
from mobile_world import run, scenario
from pydrake.systems.analysis import Simulator

IDLE = "twist: null"


def _scan(result):
    """The latest LaserScan of fra2mo's lidar."""
    port = result.world.robot().sensors["laser_frame"]["scan"]
    context = port.get_system().GetMyContextFromRoot(result.simulator.get_context())
    return port.Eval(context).message


def _beam(scan, angle: float) -> float:
    """[m] the range of the beam nearest ``angle`` [rad]."""
    return float(scan.ranges[int(np.argmin(np.abs(scan.angles() - angle)))])


def test_lidar_scans_the_arena():
    """At rest at the origin: 640 beams over 359.8 deg at 10 Hz, the crate's face 1.45 m
    ahead, the pillar's side 1.1 m to the left, the south wall 2.5 m to the right, each
    within 1 cm (the lidar is over base_footprint)."""
    result = run(scenario(IDLE), 0.45)
    scan = _scan(result)
    assert len(scan.ranges) == 640 and scan.frame_id == "laser_frame"
    assert abs(math.degrees(scan.angle_max - scan.angle_min) - 359.8) < 0.1
    assert (scan.range_min, scan.range_max, scan.scan_time) == (0.1, 10.0, 0.1)
    assert abs(scan.stamp - 0.4) < 1e-9  # scans at 0, 0.1, ..., 0.4 s
    assert abs(_beam(scan, 0.0) - 1.45) < 0.01, _beam(scan, 0.0)
    assert abs(_beam(scan, math.pi / 2) - 1.1) < 0.01, _beam(scan, math.pi / 2)
    assert abs(_beam(scan, -math.pi / 2) - 2.5) < 0.01, _beam(scan, -math.pi / 2)
    # Inside closed walls every beam hits something within 10 m.
    assert scan.hits() == 640


def test_fra2mo_on_the_course_race_field(fra2mo_package):
    """The course's leonardo_race_field.sdf as fra2mo's world: spawned as the course spawns
    it (0.1 m up, on the field's floor), it rests there and its lidar sees the field."""
    world_file = fra2mo_package / "worlds" / "leonardo_race_field.sdf"
    result = run(scenario(IDLE, f"world_file: {world_file}"), 0.6)
    z = result.between("z", 0.4, 0.6)
    assert np.ptp(z) < 1e-3 and abs(np.mean(z) - 0.1) < 2e-3, np.mean(z)
    scan = _scan(result)
    assert len(scan.ranges) == 640 and scan.hits() > 100


# The crate crate_1 (0.3 m cube, 0.5 m high) at x = 1.6: its face toward the origin at x = 1.45.
CRATE_FACE = 1.45  # [m]
BODY_RADIUS = 0.11  # [m] fra2mo's body cylinder, about base_footprint


def test_driven_into_a_crate_it_stops_against_it(tmp_path):
    """fra2mo spawned 0.35 m short of the crate and driven at it at 0.2 m/s for 3 s (0.6 m):
    it stops against the face (no tunnelling: its front never passes the face by more than
    3 mm) and stays there; the summary counts one contact episode, with crate_1."""
    spawn = "robot: {base_xyz: [1.0, 0.0, 0.1]}"
    twist = "twist: {start_delay: 0.5, steps: [{linear: 0.2, angular: 0.0, duration: 3.0}]}"
    result = run(scenario(spawn, twist), 3.6)
    front = result.column("x") + BODY_RADIUS
    assert front.max() < CRATE_FACE + 0.003, front.max() - CRATE_FACE
    assert abs(front[-1] - CRATE_FACE) < 0.003, front[-1] - CRATE_FACE
    assert abs(result.column("y")[-1]) < 0.01 and abs(result.column("yaw")[-1]) < 0.02
    contacts = result.world.robot().base_log.summary()["contacts"]
    assert contacts["episodes"] == 1 and contacts["bodies"] == ["crate_1::link"], contacts
    # It reaches the face 0.34 m after starting (0.5 s + 1.7 s at 0.2 m/s, plus the start).
    assert 2.1 < contacts["first_contact_time"] < 2.5, contacts


def test_scan_drawn_in_meshcat():
    """With Meshcat on, the lidar's scan is drawn as points at /drake/lidar/laser_frame,
    redrawn at each scan (10 Hz)."""
    from pydrake.geometry import Meshcat

    from armando_drake.simulation.builder import MakeWorld

    meshcat = Meshcat()
    world = MakeWorld(scenario(IDLE), meshcat=meshcat, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.35)
    view = world.diagram.GetSubsystemByName("scan_view_laser_frame")
    assert view.drawn == 4  # the scans of 0, 0.1, 0.2, 0.3 s
    assert meshcat.HasPath("/drake/lidar/laser_frame")
    world.close(simulator.get_context())
