"""``diff_drive_controller/DiffDriveController``: upstream's cases (ros2_controllers jazzy,
diff_drive_controller/test/test_diff_drive_controller.cpp) re-expressed on the logic, and
its parameters as the YAML loader reads them."""

import math

import numpy as np
import pytest

from armando_drake.control.config import ControllerConfigError, parse_controller_config
from armando_drake.control.controllers import ControllerJoints, lookup
from armando_drake.control.controllers.diff_drive import OdometryState, RateLimiter
from armando_drake.messages.types import Twist, TwistStamped

TYPE = "diff_drive_controller/DiffDriveController"
LEFT, RIGHT = "left_wheels", "right_wheels"


def controller(**parameters):
    """The controller of a one-file YAML with these ros__parameters (upstream's test
    defaults: wheel_separation 1.0, wheel_radius 0.1)."""
    params = {
        "left_wheel_names": [LEFT],
        "right_wheel_names": [RIGHT],
        "wheel_separation": 1.0,
        "wheel_radius": 0.1,
        **parameters,
    }
    config = parse_controller_config(
        {
            "controller_manager": {"ros__parameters": {"update_rate": 100, "base": {"type": TYPE}}},
            "base": {"ros__parameters": params},
        },
        "test.yaml",
    )
    entry = config.controllers["base"]
    logic = lookup(TYPE)(
        name="base", joints=ControllerJoints.make([LEFT, RIGHT]), params=entry.params
    )
    logic.configure(update_rate=100)
    return logic


class Wheels:
    """The wheels' feedback: positions integrated from the commanded velocities."""

    def __init__(self):
        self.q = np.zeros(2)
        self.v = np.zeros(2)

    def __call__(self, desired):
        return self.q.copy(), self.v.copy()


def step(logic, memory, now, message=None, wheels=None, dt=0.01):
    wheels = wheels or Wheels()
    memory = logic.update(now, message, memory, wheels)
    wheels.v = memory.desired[2:].copy()
    wheels.q = wheels.q + wheels.v * dt
    return memory


def twist(linear, angular=0.0, stamp=0.0):
    return TwistStamped(stamp=stamp, twist=Twist(linear=(linear, 0, 0), angular=(0, 0, angular)))


def wheel_velocities(memory):
    return memory.desired[2:]


def test_speed_limiter():
    """test_speed_limiter: acceleration 2, deceleration -4, reverse acceleration -8, reverse
    deceleration 10 m/s^2: each 1 m/s step reaches its wheel speed (10 rad/s at radius 0.1)
    only after |step| / limit seconds, never before. (Upstream's updates all have time 0, so
    its command never times out; here the clock runs, so the timeout is off.)"""
    logic = controller(
        **{
            "linear.x.max_acceleration": 2.0,
            "linear.x.max_deceleration": -4.0,
            "linear.x.max_acceleration_reverse": -8.0,
            "linear.x.max_deceleration_reverse": 10.0,
            "cmd_vel_timeout": 0.0,
        }
    )
    memory, wheels, now, dt = logic.initial_memory(), Wheels(), 0.0, 0.001
    memory = step(logic, memory, now, twist(0.0), wheels, dt)
    for _ in range(3):
        now += 0.01
        memory = step(logic, memory, now, None, wheels, 0.01)
        assert np.allclose(wheel_velocities(memory), 0.0, atol=1e-3)
    for linear, time_acc, below in ((1.0, 0.5, True), (0.0, 0.25, False), (-1.0, 0.125, False),
                                    (0.0, 0.1, True)):  # fmt: skip
        target = linear / 0.1
        message = twist(linear)
        for i in range(math.floor(time_acc / dt) - 1):
            now += dt
            memory = step(logic, memory, now, message if i == 0 else None, wheels, dt)
            velocities = wheel_velocities(memory)
            assert np.all(velocities < target) if below else np.all(velocities > target), (i, now)
        now += dt
        memory = step(logic, memory, now, None, wheels, dt)
        assert np.allclose(wheel_velocities(memory), target, atol=1e-3)
        for _ in range(3):
            now += 0.01
            memory = step(logic, memory, now, None, wheels, 0.01)
            assert np.allclose(wheel_velocities(memory), target, atol=1e-3)


def test_cmd_vel_timeout_brakes_then_a_timely_command_drives():
    """A command older than cmd_vel_timeout (0.5 s) sets the wheels to 0; a new one drives
    them (wheel_radius 1 so that rad/s = m/s)."""
    logic = controller(wheel_separation=0.4, wheel_radius=1.0)
    memory = logic.initial_memory()
    memory = step(logic, memory, 0.0, twist(1.0))
    assert np.allclose(wheel_velocities(memory), 1.0)
    memory = step(logic, memory, 0.501)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])
    assert memory.status.detail["timed_out"]
    memory = step(logic, memory, 0.6, twist(1.0))
    assert np.array_equal(wheel_velocities(memory), [1.0, 1.0])
    assert not memory.status.detail["timed_out"]


def test_before_any_command_nothing_is_written_then_the_timeout_brakes():
    logic = controller(wheel_radius=1.0)
    memory = step(logic, logic.initial_memory(), 0.0)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])
    assert math.isnan(memory.internal.reference[0])
    memory = step(logic, memory, 0.6)
    assert memory.internal.reference == (0.0, 0.0)


def test_zero_cmd_vel_timeout_disables_timeout():
    """A command stamped 1 s, updated at 11 s: the wheels still follow it."""
    logic = controller(wheel_separation=0.4, wheel_radius=1.0, cmd_vel_timeout=0.0)
    memory = step(logic, logic.initial_memory(), 0.0)
    memory = step(logic, memory, 1.0, twist(1.0, stamp=1.0))
    memory = step(logic, memory, 11.0)
    assert np.array_equal(wheel_velocities(memory), [1.0, 1.0])


def test_a_command_already_older_than_the_timeout_is_ignored():
    logic = controller(wheel_radius=1.0)
    memory = step(logic, logic.initial_memory(), 0.0)
    memory = step(logic, memory, 2.0, twist(1.0, stamp=1.0))
    assert memory.status.rejected == 1
    assert "older than the current time by 1.0000000000 seconds" in memory.status.last_error
    assert not np.any(wheel_velocities(memory))


def test_a_zero_stamp_and_a_plain_twist_count_as_now():
    logic = controller(wheel_radius=1.0)
    memory = step(logic, logic.initial_memory(), 5.0, twist(0.5, stamp=0.0))
    assert np.allclose(wheel_velocities(memory), 0.5)
    memory = step(logic, memory, 5.1, Twist(linear=(0.25, 0, 0)))
    assert np.allclose(wheel_velocities(memory), 0.25)
    assert memory.status.accepted == 2


def test_nan_command_keeps_the_reference():
    logic = controller(wheel_radius=1.0)
    memory = step(logic, logic.initial_memory(), 0.0, twist(0.3))
    memory = step(logic, memory, 0.01, twist(math.nan))
    assert memory.internal.reference == (0.3, 0.0)
    assert memory.status.rejected == 1
    assert np.allclose(wheel_velocities(memory), 0.3)


def test_correct_initialization_using_parameters():
    """wheel_separation 0.4, radius 1.0: linear 1 m/s -> both wheels 1 rad/s; a turn
    spins them apart by w * separation / 2 / radius."""
    logic = controller(wheel_separation=0.4, wheel_radius=1.0)
    memory = step(logic, logic.initial_memory(), 0.0, twist(1.0))
    assert np.array_equal(wheel_velocities(memory), [1.0, 1.0])
    memory = step(logic, memory, 0.01, twist(0.0, 1.0))
    assert np.allclose(wheel_velocities(memory), [-0.2, 0.2])


def test_multipliers_scale_the_kinematics():
    logic = controller(
        wheel_separation=0.4,
        wheel_radius=1.0,
        wheel_separation_multiplier=2.0,
        left_wheel_radius_multiplier=0.5,
        right_wheel_radius_multiplier=2.0,
    )
    memory = step(logic, logic.initial_memory(), 0.0, twist(1.0, 1.0))
    # (1 - 1 * 0.8 / 2) / 0.5 and (1 + 0.4) / 2
    assert np.allclose(wheel_velocities(memory), [1.2, 0.7])


@pytest.mark.parametrize("clamped", [True, False])
def test_open_loop_odometry_with_clamped_and_unclamped_input(clamped):
    """Open loop, dt 0.1 s: a 5 m/s command integrates 0.5 m/s (clamped) or 5 m/s for the
    step, then 5 rad/s the heading."""
    limits = {"linear.x.max_velocity": 0.5, "angular.z.max_velocity": 0.5} if clamped else {}
    logic = controller(open_loop=True, **limits)
    expected = 0.5 if clamped else 5.0
    memory = step(logic, logic.initial_memory(), 0.0)
    memory = step(logic, memory, 0.1, twist(5.0))
    odometry = memory.internal.odometry
    assert odometry.linear == pytest.approx(expected, abs=1e-3)
    assert odometry.x == pytest.approx(expected * 0.1, abs=1e-3)
    memory = step(logic, memory, 0.2, twist(0.0, 5.0))
    odometry = memory.internal.odometry
    assert odometry.angular == pytest.approx(expected, abs=1e-3)
    assert odometry.heading == pytest.approx(expected * 0.1, abs=1e-3)


@pytest.mark.parametrize(
    "left, right, pose, twist_",
    [
        (1.0, 1.0, (1.0, 0.0, 0.0), (1.0, 0.0)),  # TestLinearMotion
        (-1.0, 1.0, (0.0, 0.0, 2.0), (0.0, 2.0)),  # TestPureRotation
        (1.0, 2.0, (1.5 * math.sin(1.0), -1.5 * (math.cos(1.0) - 1.0), 1.0), (1.5, 1.0)),
    ],
    ids=["linear", "pure_rotation", "exact_arc"],
)
def test_odometry_integrates_the_axles_midpoint(left, right, pose, twist_):
    """Upstream's test_odometry.cpp (wheel separation 1 m, 1 s): the pose integrated is the
    wheel axle's midpoint's, published as the base frame's; turning in place (TestPureRotation)
    leaves it where it was, whatever offset the base frame has from the axle."""
    start = OdometryState()
    assert (start.x, start.y, start.heading, start.linear, start.angular) == (0, 0, 0, 0, 0)
    odometry = start.from_travel(left, right, 1.0, 1.0, 10)
    assert (odometry.x, odometry.y, odometry.heading) == pytest.approx(pose, abs=1e-12)
    assert (odometry.linear, odometry.angular) == pytest.approx(twist_)
    assert start.from_travel(1.0, 1.0, 1.0, 1e-7, 10) is start  # TestSmallDtRejection


def test_position_feedback_odometry_integrates_an_arc_exactly():
    """Wheels that turned a quarter circle of radius 1 m (separation 0.5 m) in one update:
    the exact integration puts the base at (1, 1) heading pi/2."""
    logic = controller(wheel_separation=0.5, wheel_radius=1.0, velocity_rolling_window_size=1)
    memory = logic.initial_memory()
    quarter = math.pi / 2
    wheels = Wheels()
    wheels.q = np.array([quarter * 0.75, quarter * 1.25])  # arcs of radius 0.75 m, 1.25 m
    # (a command: before the first one upstream integrates no odometry)
    memory = logic.update(1.0, twist(0.0), memory, wheels)
    odometry = memory.internal.odometry
    assert (odometry.x, odometry.y, odometry.heading) == pytest.approx((1.0, 1.0, quarter))
    message = logic.output("odom", memory)
    assert message.yaw == pytest.approx(quarter) and message.position[:2] == pytest.approx((1, 1))


def test_odometry_is_published_at_publish_rate():
    logic = controller(publish_rate=20.0, wheel_radius=1.0)
    memory, stamps = logic.initial_memory(), []
    for k in range(21):
        memory = step(logic, memory, k * 0.01, twist(0.1) if k == 0 else None)
        stamp = logic.output("odom", memory).stamp
        if not stamps or stamp != stamps[-1]:
            stamps.append(stamp)
    assert stamps == pytest.approx([0.0, 0.06, 0.11, 0.16])


@pytest.mark.parametrize(
    "enable, prefix, expected",
    [
        (False, "test_prefix", ("odom", "base_link")),
        (True, "test_prefix", ("test_prefix/odom", "test_prefix/base_link")),
        (True, "", ("odom", "base_link")),
    ],
)
def test_frame_ids_with_tf_prefix(enable, prefix, expected):
    """configure_succeeds_tf_*_no_namespace: the prefix only when enabled and given."""
    logic = controller(tf_frame_prefix_enable=enable, tf_frame_prefix=prefix)
    message = logic.output("odom", logic.initial_memory())
    assert (message.frame_id, message.child_frame_id) == expected


@pytest.mark.parametrize(
    "enable, prefix, expected",
    [
        (False, "test_prefix", ("odom", "base_link")),
        (True, "test_prefix", ("test_prefix/odom", "test_prefix/base_link")),
        (True, "", ("test_namespace/odom", "test_namespace/base_link")),
    ],
)
def test_frame_ids_with_tf_prefix_and_namespace(enable, prefix, expected):
    """configure_succeeds_tf_*_set_namespace: a blank prefix takes the namespace."""
    logic = controller(tf_frame_prefix_enable=enable, tf_frame_prefix=prefix)
    logic.set_namespace("/test_namespace")
    message = logic.output("odom", logic.initial_memory())
    assert (message.frame_id, message.child_frame_id) == expected


def test_no_odometry_before_the_first_command():
    """update_and_write_commands returns early while the reference is NaN: no odometry
    integrated or published (the wheels turned meanwhile) until a command (or the
    timeout's braking) sets it."""
    logic = controller(wheel_radius=1.0, wheel_separation=0.5)
    memory = logic.initial_memory()
    wheels = Wheels()
    wheels.q = np.array([0.3, 0.3])
    memory = logic.update(0.1, None, memory, wheels)
    assert memory.internal.odometry.x == 0.0 and memory.internal.last_publish == -math.inf
    memory = logic.update(0.2, twist(0.0), memory, wheels)
    assert memory.internal.odometry.x == pytest.approx(0.3)
    assert logic.output("odom", memory).stamp == 0.2


def test_cleanup():
    """TEST_F cleanup: moving, then deactivated: the wheels halted; cleaned up: still."""
    logic = controller(wheel_separation=0.4, wheel_radius=0.1)
    memory = step(logic, logic.initial_memory(), 0.0, twist(1.0, 1.0))
    assert (wheel_velocities(memory) > 0.0).all()
    memory = logic.deactivate(0.01, memory)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])
    memory = logic.reset(0.02, memory)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])


def test_deactivate_then_activate():
    """TEST_F deactivate_then_activate (and correct_initialization_using_parameters):
    halted on deactivation despite updates and commands; the reference NaN on activation,
    the wheels at their last command (0); a new command drives again."""
    logic = controller(wheel_separation=0.4, wheel_radius=1.0)
    memory = step(logic, logic.initial_memory(), 0.0, twist(1.0))
    assert np.array_equal(wheel_velocities(memory), [1.0, 1.0])
    memory = logic.deactivate(0.3, memory)
    memory = step(logic, memory, 0.31, twist(1.0))  # the subscriber is inactive
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])
    memory = logic.activate(0.32, memory)
    assert all(math.isnan(v) for v in memory.internal.reference)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])
    memory = step(logic, memory, 0.33, twist(1.0))
    assert np.array_equal(wheel_velocities(memory), [1.0, 1.0])


def test_reset_zeroes_the_odometry_pose():
    """reset() (on_cleanup, on_error, on_configure): resetOdometry, x = y = heading = 0;
    the wheels' last positions kept, so the next update does not jump."""
    logic = controller(wheel_radius=1.0, wheel_separation=0.5, velocity_rolling_window_size=1)
    wheels = Wheels()
    memory = step(logic, logic.initial_memory(), 0.0, twist(1.0), wheels)
    for k in range(1, 11):
        memory = step(logic, memory, 0.01 * k, twist(1.0), wheels)
    assert memory.internal.odometry.x > 0.05
    memory = logic.reset(0.11, memory)
    odometry = memory.internal.odometry
    assert (odometry.x, odometry.y, odometry.heading) == (0.0, 0.0, 0.0)
    memory = logic.activate(0.11, memory)
    memory = step(logic, memory, 0.12, twist(1.0), wheels)
    assert memory.internal.odometry.x == pytest.approx(0.01, abs=1e-9)


def test_chainable_controller_chained_mode():
    """TEST_F chainable_controller_chained_mode: the reference interfaces NaN at first (the
    wheels not NaN); a preceding controller's 3 m/s on them drives the wheels at 3 rad/s;
    halted on deactivation."""
    logic = controller(wheel_separation=0.4, wheel_radius=1.0)
    assert logic.set_chained_mode(True) and logic.chained_mode
    assert logic.reference_interfaces() == ["base/linear/velocity", "base/angular/velocity"]
    memory = logic.initial_memory()
    assert all(math.isnan(v) for v in memory.internal.reference)
    assert not np.isnan(wheel_velocities(memory)).any()
    memory = logic.write_reference(memory, 3.0, 0.0)
    memory = step(logic, memory, 0.0)
    assert np.array_equal(wheel_velocities(memory), [3.0, 3.0])
    memory = step(logic, memory, 1.0)  # no cmd_vel timeout in chained mode
    assert np.array_equal(wheel_velocities(memory), [3.0, 3.0])
    memory = logic.deactivate(1.3, memory)
    memory = step(logic, memory, 1.31)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])


def test_chainable_controller_unchained_mode():
    """TEST_F chainable_controller_unchained_mode: a command older than cmd_vel_timeout
    brakes; a timely one drives; halted on deactivation."""
    logic = controller(wheel_separation=0.4, wheel_radius=1.0)
    assert logic.set_chained_mode(False) and not logic.chained_mode
    memory = step(logic, logic.initial_memory(), 0.0, twist(1.0))
    memory = step(logic, memory, 0.501)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])
    memory = step(logic, memory, 0.6, twist(1.0))
    assert np.array_equal(wheel_velocities(memory), [1.0, 1.0])
    memory = logic.deactivate(0.9, memory)
    memory = step(logic, memory, 0.91)
    assert np.array_equal(wheel_velocities(memory), [0.0, 0.0])


@pytest.mark.parametrize(
    "parameters, match",
    [
        (
            {"right_wheel_names": []},
            r"base\.ros__parameters\.right_wheel_names: right_wheel_names=\[\] must not be empty",
        ),
        (
            {"right_wheel_names": ["a", "b"]},
            r"The number of left wheels \[1\] and the number of right wheels \[2\] are different",
        ),
        (
            {"wheel_radius": -0.035},
            r"test\.yaml: base\.ros__parameters\.wheel_radius: "
            r"wheel_radius=-0\.035 must be positive \[m\]",
        ),
        ({"wheel_separation": 0.0}, r"wheel_separation=0\.0 must be positive \[m\]"),
        (
            {"linear.x.max_velocity": -1.0},
            r"linear\.x\.max_velocity=-1\.0 must be zero or positive",
        ),
        (
            {"linear.x.max_velocity": 1.0, "linear.x.min_velocity": 2.0},
            r"linear\.x\.min_velocity=2\.0 must be <= 0",
        ),
        ({"cmd_vel_timeout": -1.0}, r"cmd_vel_timeout=-1\.0 must be zero or positive \[s\]"),
    ],
)
def test_bad_parameters_are_one_line_errors_naming_file_key_and_value(parameters, match):
    with pytest.raises(ControllerConfigError, match=match) as error:
        controller(**parameters)
    assert "\n" not in str(error.value)


def test_a_parameter_jazzy_does_not_declare_is_ignored_with_one_warning(caplog):
    """As ROS ignores an undeclared parameter (a likely typo stays visible)."""
    with caplog.at_level("WARNING"):
        controller(odometry_topic="odom")
    (line,) = [r.getMessage() for r in caplog.records if "odometry_topic" in r.getMessage()]
    assert "base.ros__parameters.odometry_topic" in line and "does not declare it" in line


def test_deprecated_has_limits_false_disables_them():
    logic = controller(
        wheel_radius=1.0,
        **{"linear.x.has_velocity_limits": False, "linear.x.max_velocity": 0.1},
    )
    memory = step(logic, logic.initial_memory(), 0.0, twist(1.0))
    assert np.allclose(wheel_velocities(memory), 1.0)


def test_rate_limiter_is_control_toolbox_s():
    """Asymmetric first derivative limits by the sign of the previous value; the jerk limited
    only while accelerating; bounds that are not an interval refused."""
    limiter = RateLimiter.ros_limiter(math.nan, 1.0, -8.0, 2.0, -4.0, 10.0)
    assert limiter.min_value == -1.0
    assert limiter.limit(1.0, 0.5, 0.5, 0.1) == pytest.approx(0.7)  # +2 m/s^2 going forward
    assert limiter.limit(0.0, 0.5, 0.5, 0.1) == pytest.approx(0.1)  # -4 m/s^2 slowing forward
    assert limiter.limit(-2.0, -0.5, -0.5, 0.1) == pytest.approx(-1.0)  # -8 m/s^2, then -1
    assert limiter.limit(1.0, -0.5, -0.5, 0.1) == pytest.approx(0.5)  # +10 m/s^2 in reverse
    jerky = RateLimiter.ros_limiter(max_second_derivative=1.0)
    assert jerky.limit(1.0, 0.0, 0.0, 0.1) == pytest.approx(0.01)  # the jerk speeds it up
    assert jerky.limit(0.6, 0.5, 0.0, 0.1) == 0.6  # the jerk against the acceleration: free
    with pytest.raises(ValueError, match="Invalid value limits"):
        RateLimiter.ros_limiter(2.0, 1.0)


def test_init_fails_without_parameters():
    """TEST_F init_fails_without_parameters: no wheel names, separation or radius."""
    with pytest.raises(ControllerConfigError):
        parse_controller_config(
            {
                "controller_manager": {
                    "ros__parameters": {"update_rate": 100, "base": {"type": TYPE}}
                },
                "base": {"ros__parameters": {}},
            },
            "test.yaml",
        )


@pytest.mark.parametrize(
    "parameters",
    [
        {},  # activate_succeeds_with_pos_resources_assigned: position feedback by default
        {"position_feedback": False},  # activate_succeeds_with_vel_resources_assigned
        {"open_loop": True},  # activate_succeeds_with_open_loop_assigned
        {"open_loop": True, "position_feedback": False},  # ..._unnecessary_resources_1
    ],
)
def test_activate_succeeds_with_each_feedback(parameters):
    """The activate_succeeds_* cases: configured and activated, a command drives."""
    logic = controller(wheel_separation=0.4, wheel_radius=1.0, **parameters)
    memory = logic.activate(0.0, logic.initial_memory())
    memory = step(logic, memory, 0.01, twist(1.0))
    assert np.array_equal(wheel_velocities(memory), [1.0, 1.0])


def test_reference_interfaces_are_properly_exported():
    """TEST_F reference_interfaces_are_properly_exported: exactly 2, linear then angular,
    ``<node name>/<linear|angular>/velocity``."""
    logic = controller()
    assert logic.reference_interfaces() == ["base/linear/velocity", "base/angular/velocity"]


def test_load_controller():
    """test_load_diff_drive_controller.cpp TEST(TestLoadDiffDriveController, load_controller):
    its test/config/test_diff_drive_controller.yaml (NaN limits: none) loads."""
    limits = {
        f"{axis}.{key}": math.nan
        for axis in ("linear.x", "angular.z")
        for key in ("max_velocity", "min_velocity", "max_acceleration", "max_deceleration",
                    "max_acceleration_reverse", "max_deceleration_reverse", "max_jerk",
                    "min_jerk")
    }  # fmt: skip
    logic = controller(
        wheel_separation=0.40, wheel_radius=0.02, wheel_separation_multiplier=1.0,
        left_wheel_radius_multiplier=1.0, right_wheel_radius_multiplier=1.0,
        odom_frame_id="odom", base_frame_id="base_link",
        pose_covariance_diagonal=[0.0] * 6, twist_covariance_diagonal=[0.0] * 6,
        position_feedback=False, open_loop=True, enable_odom_tf=True, cmd_vel_timeout=0.5,
        publish_limited_velocity=True, velocity_rolling_window_size=10, **limits,
    )  # fmt: skip
    memory = step(logic, logic.initial_memory(), 0.0, twist(0.02))
    assert np.allclose(wheel_velocities(memory), [1.0, 1.0])
