"""AMCL: the particle filter's models, its parameters, and fra2mo localized from a wrong
initial pose (one short run)."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.navigation.amcl import OMNI, AmclParameters, ParticleFilter, amcl_parameters
from armando_drake.navigation.maps import OccupancyMap
from armando_drake.navigation.pose_buffer import body_odometry, compose, inverse
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides

QUIET = ["logging: {console_rate: 0}", "visualization: {enable_meshcat_creation: false}"]


def _room() -> OccupancyMap:
    data = np.zeros((60, 80), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyMap(data=data, resolution=0.05, origin=(-2.0, -1.5, 0.0))


def test_motion_model_without_noise_moves_each_particle_by_the_odometry():
    params = AmclParameters(alpha1=0.0, alpha2=0.0, alpha3=0.0, alpha4=0.0)
    pf = ParticleFilter(params, _room(), (0.0, 0.0, 0.0))
    particles = np.array([[0.0, 0.0, 0.0], [1.0, -0.5, math.pi / 2]])
    moved = pf.motion(particles, (0.0, 0.0, 0.0), (0.3, 0.0, 0.2))
    assert moved[0] == pytest.approx([0.3, 0.0, 0.2])
    assert moved[1] == pytest.approx([1.0, -0.2, math.pi / 2 + 0.2])
    # With noise, the spread grows with alpha3 (translation from translation).
    params.alpha3 = 0.2
    many = pf.motion(np.zeros((4000, 3)), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    assert np.std(many[:, 0]) == pytest.approx(math.sqrt(0.2), rel=0.1)


def test_omni_motion_model_moves_each_particle_along_the_odometrys_bearing():
    """OmniMotionModel::odometryUpdate (nav2_amcl omni_motion_model.cpp): a strafe of the
    odometry (0.1 m to its left, heading 0) moves a particle heading pi/2 0.1 m along -x;
    the noise: alpha3 on the translation, alpha5 on the strafe across it, alpha1 on the
    rotation."""
    params = AmclParameters(alpha1=0.0, alpha2=0.0, alpha3=0.0, alpha4=0.0, alpha5=0.0)
    params.robot_model_type = OMNI
    pf = ParticleFilter(params, _room(), (0.0, 0.0, 0.0))
    particles = np.array([[0.0, 0.0, 0.0], [1.0, -0.5, math.pi / 2]])
    moved = pf.motion(particles, (0.0, 0.0, 0.0), (0.0, 0.1, 0.3))
    assert moved[0] == pytest.approx([0.0, 0.1, 0.3])
    assert moved[1] == pytest.approx([0.9, -0.5, math.pi / 2 + 0.3])
    # odometry that turned: the bearing taken in the old odometry frame
    moved = pf.motion(particles[:1], (1.0, 1.0, math.pi / 2), (1.0, 1.5, math.pi / 2))
    assert moved[0] == pytest.approx([0.5, 0.0, 0.0])
    # 1 m forward: the strafe's deviation sqrt(alpha5) 1 m, across the motion (y)
    params.alpha5 = 0.1
    many = pf.motion(np.zeros((4000, 3)), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    assert np.std(many[:, 1]) == pytest.approx(math.sqrt(0.1), rel=0.1)
    assert np.std(many[:, 0]) == pytest.approx(0.0, abs=1e-12)
    params.alpha5, params.alpha3, params.alpha1 = 0.0, 0.2, 0.05
    many = pf.motion(np.zeros((4000, 3)), (0.0, 0.0, 0.0), (1.0, 0.0, 1.0))
    assert np.std(many[:, 0]) == pytest.approx(math.sqrt(0.2), rel=0.1)
    assert np.std(many[:, 2]) == pytest.approx(math.sqrt(0.05), rel=0.1)


def test_the_omni_model_is_read_with_alpha5(tmp_path, caplog):
    path = tmp_path / "nav2.yaml"
    path.write_text(
        "amcl:\n  ros__parameters:\n    robot_model_type: nav2_amcl::OmniMotionModel\n"
        "    alpha5: 0.3\n"
    )
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        params = amcl_parameters(path)
    assert (params.robot_model_type, params.alpha5) == (OMNI, 0.3)
    assert "alpha5" not in caplog.text
    path.write_text("amcl:\n  ros__parameters:\n    robot_model_type: nav2_amcl::Tank\n")
    with pytest.raises(
        Exception, match=r"amcl\.ros__parameters\.robot_model_type 'nav2_amcl::Tank'"
    ):
        amcl_parameters(path)


def test_the_likelihood_field_peaks_at_the_true_pose():
    params = AmclParameters(sigma_hit=0.05, z_hit=0.9, z_rand=0.1)
    grid = _room()
    pf = ParticleFilter(params, grid, (0.0, 0.0, 0.0))

    class Scan:  # the walls seen from (0, 0): x from -1.95 to 1.95, y from -1.45 to 1.45
        angle_min, angle_increment, range_min, range_max = -math.pi, 2 * math.pi / 360, 0.1, 10.0
        angles = -math.pi + 2 * math.pi / 360 * np.arange(360)
        c, s = np.cos(angles), np.sin(angles)
        with np.errstate(divide="ignore"):
            tx = np.where(c > 0, 1.95, -1.95) / c
            ty = np.where(s > 0, 1.45, -1.45) / s
        ranges = np.minimum(np.abs(tx), np.abs(ty))

    offsets = np.array([[0, 0, 0], [0.1, 0, 0], [0, -0.1, 0], [0, 0, 0.1]], dtype=float)
    weights = pf.likelihood(offsets, Scan)
    assert np.argmax(weights) == 0
    assert weights[0] > 1.4 * weights[1:].max()


def test_an_update_is_due_as_should_update_filter_tests_each_axis_alone():
    """AmclNode::shouldUpdateFilter: |dx| or |dy| (odometry frame) over update_min_d, or
    |dyaw| over update_min_a, each strictly and alone (a diagonal 0.2 * 0.8 m is not due)."""
    params = AmclParameters(update_min_d=0.2, update_min_a=0.5)
    pf = ParticleFilter(params, _room(), (0.0, 0.0, 0.0))
    state = pf.start((0.0, 0.0, 0.0), (1.0, 1.0, 3.0))
    assert not pf.moved(state, (1.16, 1.16, 3.0))  # 0.226 m along the diagonal
    assert not pf.moved(state, (1.2, 0.8, 3.0))  # exactly update_min_d: not over it
    assert pf.moved(state, (1.0, 1.21, 3.0)) and pf.moved(state, (0.79, 1.0, 3.0))
    assert not pf.moved(state, (1.0, 1.0, 3.0 + 0.5))
    assert pf.moved(state, (1.0, 1.0, -2.78))  # 0.50 rad across +-pi


def test_the_laser_model_takes_every_step_th_beam_and_drops_short_and_long_readings():
    """LikelihoodFieldModel::sensorFunction: beams 0, step, 2 step, ... with step =
    (count - 1) // (max_beams - 1) (640 beams, max_beams 60: 64 beams, every 10th); a
    reading at or under range_min is taken as range_max (AmclNode::updateFilter), which
    the model ignores with NaN and longer readings. A particle's weight is 1 + sum pz^3."""
    params = AmclParameters(max_beams=60, sigma_hit=0.05, z_hit=0.9, z_rand=0.1)
    pf = ParticleFilter(params, _room(), (0.0, 0.0, 0.0))
    z_rand = params.z_rand / 10.0  # z_rand / range_max
    on_wall = (params.z_hit + z_rand) ** 3  # a beam ending in an occupied cell

    class Scan:
        angle_min, angle_increment, range_min, range_max = 0.0, 0.0, 0.1, 10.0
        ranges = np.full(640, np.inf)

    # only every 10th beam is read: the wall 1.975 m ahead (in its cell)
    Scan.ranges[::10] = 1.975
    Scan.ranges[5::10] = 0.5  # between the beams read: never seen
    weight = pf.likelihood(np.zeros((1, 3)), Scan)[0]
    assert weight == pytest.approx(1.0 + 64 * on_wall)
    Scan.ranges[::10] = 0.1  # at range_min: taken as range_max, ignored
    Scan.ranges[0], Scan.ranges[10], Scan.ranges[20] = np.nan, 10.0, 0.10001
    weight = pf.likelihood(np.zeros((1, 3)), Scan)[0]
    field = pf.field[30, 42]  # the cell of (0.10001, 0): 1.45 m from the nearest wall
    pz = params.z_hit * math.exp(-(field**2) / (2 * params.sigma_hit**2)) + z_rand
    assert weight == pytest.approx(1.0 + pz**3)


def test_resampling_draws_each_particle_independently():
    """pf_update_resample: each of the n new particles drawn alone by the cumulative weights
    (a particle of weight 1/2 is copied Binomial(n, 1/2) times, not exactly n/2 times as a
    low-variance sampler would), the new weights uniform."""
    pf = ParticleFilter(AmclParameters(), _room(), (0.0, 0.0, 0.0))
    n = 1000
    particles = np.arange(n, dtype=float)[:, None] * np.ones((1, 3))
    weights = np.full(n, 0.5 / (n - 1))
    weights[0] = 0.5
    copies = []
    for _ in range(20):
        drawn, uniform = pf.resample(particles, weights)
        assert uniform == pytest.approx(np.full(n, 1.0 / n))
        copies.append(int(np.sum(drawn[:, 0] == 0.0)))
    assert np.mean(copies) == pytest.approx(n / 2, abs=4 * math.sqrt(n / 4 / 20))
    assert np.std(copies) == pytest.approx(math.sqrt(n / 4), rel=0.5)  # 15.8, not 0


def test_poses_compose_and_the_odometry_is_the_base_frames_pose_as_ros_publishes_it():
    a = (1.0, 2.0, 0.5)
    assert compose(a, inverse(a)) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)

    class Message:
        position, yaw = (0.0, 0.0, 0.0), math.pi / 2

    # Turning in place about an axle 0.04 m ahead of the base frame: the drive's odometry
    # (the axle's midpoint integrated) is odom -> base_link as it is, a pure rotation, as
    # diff_drive_controller and Gazebo's DiffDrive publish it; the offset is not applied.
    assert body_odometry(Message) == pytest.approx((0.0, 0.0, math.pi / 2))
    assert body_odometry(None) == (0.0, 0.0, 0.0)


def test_the_courses_amcl_parameters_load_and_those_not_applied_are_named(fra2mo_package, caplog):
    with caplog.at_level(logging.WARNING, "armando_drake.navigation"):
        params = amcl_parameters(fra2mo_package / "config" / "navigation.yaml")
    assert (params.alpha1, params.alpha4, params.sigma_hit) == (0.2, 0.2, 0.9)
    assert (params.max_particles, params.max_beams) == (500, 60)
    assert (params.update_min_d, params.update_min_a) == (0.2, 0.3)
    assert params.set_initial_pose and params.initial_pose == (0.0, 0.0, 0.0)
    assert "amcl.ros__parameters.alpha5: the omni motion model's" in caplog.text
    assert "amcl.ros__parameters.min_particles: KLD sampling is not applied" in caplog.text


def test_amcl_localizes_fra2mo_on_the_saved_map_from_half_a_metre_and_0_3_rad_off():
    # diagrams/fra2mo_amcl.yaml: the truth is the spawn pose (0, 0, 0), the estimate starts
    # 0.5 m and 0.3 rad off; the map is the saved one; 10 s of driving from start_delay.
    scenario = merge_overrides(load_scenario("fra2mo_amcl"), QUIET)
    assert scenario.navigation.map.endswith("maps/arena.yaml")
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    simulator.AdvanceTo(scenario.navigation.start_delay + 10.01)
    amcl = world.robot().navigation.amcl
    context = amcl.GetMyContextFromRoot(simulator.get_context())
    map_to_odom = amcl.GetOutputPort("map_to_odom").Eval(context)
    pose = compose(map_to_odom, amcl.GetInputPort("poses").Eval(context).odom.latest)
    plant = world.plant
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    X = plant.EvalBodyPoseInWorld(plant.GetMyContextFromRoot(simulator.get_context()), body)
    truth = (*X.translation()[:2], X.rotation().ToRollPitchYaw().yaw_angle())
    assert math.hypot(truth[0], truth[1]) > 1.0  # it drove toward its first goal
    assert math.hypot(pose[0] - truth[0], pose[1] - truth[1]) < 0.1
    assert abs(math.remainder(pose[2] - truth[2], 2 * math.pi)) < 0.05
    # The summary's localization errors: the wrong start, then within 0.1 m / 0.05 rad
    # from 5 s on.
    navigator = world.robot().navigation.navigator
    errors = navigator.summary(navigator.GetMyContextFromRoot(simulator.get_context()))[
        "localization"
    ]
    samples = errors["errors"]
    assert samples[0]["time"] == 1.0 and len(samples) == 11  # each second from start_delay
    assert samples[0]["position"] > 0.3 and samples[0]["yaw"] > 0.25  # AMCL at work at rest
    assert errors["final_position_error"] < 0.1 and errors["final_yaw_error"] < 0.05
    assert errors["max_position_error_settled"] < 0.1
    assert errors["max_yaw_error_settled"] < 0.05
