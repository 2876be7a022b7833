"""Other differential-drive packages: a diffbot-style robot (ros2_control velocity wheels and
a diff_drive_controller YAML) and a TurtleBot3-style one (Gazebo classic's
gazebo_ros_diff_drive with ROS 1 tags). Both fixtures are our own (tests/mobile/fixtures)."""

import shutil

import numpy as np
import pytest
from mobile_world import CLASSIC_BOT, MINIBOT, run, scenario

from armando_drake.messages.types import Twist, TwistStamped
from armando_drake.tools.errors import UserInputError


def minibot(*overrides):
    return scenario(
        f"robot: {{description: {MINIBOT}, base_xyz: [0.0, 0.0, 0.06]}}",
        "controllers: {config: '', activate: [joint_state_broadcaster, minibot_base_controller]}",
        *overrides,
    )


def classic_bot(*overrides, args="{}"):
    return scenario(
        f"robot: {{description: {CLASSIC_BOT}, base_xyz: [0.0, 0.0, 0.01], xacro_args: {args}}}",
        "controllers: {activate: [joint_state_broadcaster]}",
        *overrides,
    )


def test_minibot_diff_drive_controller_limits_velocity_and_acceleration():
    # 0.8 m/s asked: max_velocity 0.5 m/s, reached at max_acceleration 1.0 m/s^2.
    twist = "twist: {start_delay: 0.3, steps: [{linear: 0.8, angular: 0.0, duration: 1.2}]}"
    result = run(minibot(twist), 1.5)
    world = result.world
    assert world.robot().mobile.floating and world.robot().mobile.base_link == "base_link"
    assert (
        world.robot().mobile.drives == ["minibot_base_controller"]
        and world.robot().mobile.plugins == []
    )
    assert result.world.robot().twist_target == "minibot_base_controller"
    # 0.2 s into the step: 0.2 m/s (the controller's 50 Hz ticks lag a tick or two).
    assert 0.15 < result.at("linear", 0.5) < 0.21
    assert abs(np.mean(result.between("linear", 1.0, 1.5)) - 0.5) < 0.01
    assert abs(np.mean(result.between("odom_linear", 1.1, 1.5)) - 0.5) < 0.01
    # The odometry (position feedback) follows the ground truth where nothing slips.
    assert result.world.robot().base_log.summary()["odometry_drift"]["max_position_at_axle"] < 5e-3


def test_minibot_cmd_vel_timeout_brakes_a_single_command():
    """One TwistStamped at 0.1 s (0.3 m/s): driven until it is 0.5 s old, then braked at the
    acceleration limit (1 m/s^2: 0.3 s to stop)."""

    def publish(world, context):
        world.publish(
            context,
            "minibot_base_controller",
            TwistStamped(stamp=0.1, twist=Twist(linear=(0.3, 0, 0))),
        )

    result = run(minibot("twist: null"), 1.3, before=publish, at=0.1)
    assert abs(result.at("linear", 0.55) - 0.3) < 0.01
    assert result.at("linear", 0.75) < 0.25  # braking since 0.6 s
    assert abs(result.at("linear", 1.25)) < 0.005
    status = result.world.status(result.simulator.get_context(), "minibot_base_controller")
    assert status.detail["timed_out"] and status.accepted == 1


def test_classic_plugin_world_odometry_and_wheel_acceleration():
    twist = "twist: {start_delay: 0.3, steps: [{linear: 0.3, angular: 0.5, duration: 1.5}]}"
    result = run(classic_bot(twist), 1.8)
    world = result.world
    assert world.robot().mobile.plugins == ["diff_drive"]
    entry = world.robot().stack.config.controllers["diff_drive"]
    assert entry.ros_topic == "/cmd_vel" and entry.drive.odometry_source == "world"
    assert entry.drive.max_wheel_torque == 10.0 and entry.drive.update_rate == 50.0
    # wheelAcceleration 1 m/s^2 on each wheel's rim: 0.1 s into the step, ~0.1 m/s.
    assert 0.06 < result.at("linear", 0.4) < 0.13
    assert abs(np.mean(result.between("linear", 1.2, 1.8)) - 0.3) / 0.3 < 0.02
    assert abs(np.mean(result.between("angular", 1.2, 1.8)) - 0.5) / 0.5 < 0.02
    # odometrySource world: the odometry is the model's pose, however the wheels slip.
    drift = result.world.robot().base_log.summary()["odometry_drift"]
    assert drift["max_position"] < 1e-3 and drift["final_heading"] < 1e-3


def test_classic_plugin_encoder_odometry_and_link_friction():
    twist = "twist: {start_delay: 0.2, steps: [{linear: 0.2, angular: 0.0, duration: 1.0}]}"
    result = run(classic_bot(twist, args="{odometry_source: encoder}"), 1.4)
    assert (
        result.world.robot().stack.config.controllers["diff_drive"].drive.odometry_source
        == "encoder"
    )
    assert result.world.robot().base_log.summary()["odometry_drift"]["max_position_at_axle"] < 5e-3
    # The caster's <mu1>0.05</mu1> (a box: no caster default), the wheels' 0.9.
    plant, inspector = result.world.plant, result.world.scene_graph.model_inspector()
    for link, mu in (("caster_back_link", 0.05), ("wheel_left_link", 0.9)):
        (geometry,) = plant.GetCollisionGeometriesForBody(plant.GetBodyByName(link))
        friction = inspector.GetProximityProperties(geometry).GetProperty(
            "material", "coulomb_friction"
        )
        assert friction.dynamic_friction() == pytest.approx(mu)


@pytest.mark.parametrize(
    "overrides, match",
    [
        (
            ["controllers: {config: CONFIG}"],
            r"bad\.yaml: minibot_base_controller\.ros__parameters\.left_wheel_names: unknown joint "
            r"'front_left_wheel_joint' of controller 'minibot_base_controller'",
        ),
        (
            ["controllers: {config: NEGATIVE}"],
            r"negative\.yaml: minibot_base_controller\.ros__parameters\.wheel_radius: "
            r"wheel_radius=-0\.05 must be positive \[m\]",
        ),
    ],
)
def test_bad_diff_drive_yaml_is_a_one_line_error(tmp_path, overrides, match):
    text = (MINIBOT / "config" / "minibot_controllers.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        text.replace(
            'left_wheel_names: ["left_wheel_joint"]', 'left_wheel_names: ["front_left_wheel_joint"]'
        )
    )
    negative = tmp_path / "negative.yaml"
    negative.write_text(text.replace("wheel_radius: 0.05", "wheel_radius: -0.05"))
    overrides = [
        o.replace("CONFIG", str(bad)).replace("NEGATIVE", str(negative)) for o in overrides
    ]
    with pytest.raises(UserInputError, match=match) as error:
        run(minibot(*overrides), 0.1)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    "args, match",
    [
        (
            "{wheel_diameter: '-0.066'}",
            r'classic_bot\.urdf\.xacro: <plugin name="classic_bot_controller" '
            r'filename="libgazebo_ros_diff_drive\.so">: <wheelDiameter>-0\.066</wheelDiameter> '
            r"must be > 0",
        ),
        ("{wheel_acceleration: '-1'}", r"<wheelAcceleration>-1 must be >= 0"),
    ],
)
def test_bad_plugin_values_are_one_line_errors(args, match):
    with pytest.raises(UserInputError, match=match) as error:
        run(classic_bot(args=args), 0.1)
    assert "\n" not in str(error.value)


def test_a_plugin_wheel_joint_that_does_not_exist_names_the_file_and_joint(tmp_path):
    package = tmp_path / "classic_bot_description"
    (package / "urdf").mkdir(parents=True)
    (package / "package.xml").write_text((CLASSIC_BOT / "package.xml").read_text())
    text = (CLASSIC_BOT / "urdf" / "classic_bot.urdf.xacro").read_text()
    (package / "urdf" / "classic_bot.urdf.xacro").write_text(
        text.replace(
            "<leftJoint>wheel_left_joint</leftJoint>", "<leftJoint>wheel_lef_joint</leftJoint>"
        )
    )
    with pytest.raises(UserInputError) as error:
        run(scenario(f"robot: {{description: {package}}}"), 0.1)
    message = str(error.value)
    assert "\n" not in message
    assert str(package / "urdf" / "classic_bot.urdf.xacro") in message
    assert "left wheel joint 'wheel_lef_joint' is not a joint of the robot" in message
    assert "(its moving joints: wheel_left_joint, wheel_right_joint)" in message


def test_a_file_drive_not_activated_is_activated_as_its_bring_up_spawns_it(caplog):
    """fra2mo's scenario on another robot: its activation list names only the broadcaster;
    the controller file's own drive takes cmd_vel, said in one line."""
    twist = "twist: {start_delay: 0.3, steps: [{linear: 0.3, angular: 0.0, duration: 1.0}]}"
    overrides = ("controllers: {config: '', activate: [joint_state_broadcaster]}", twist)
    with caplog.at_level("INFO", logger="armando_drake.world"):
        result = run(minibot(*overrides), 1.3)
    assert result.world.robot().twist_target == "minibot_base_controller"
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("drive: ")]
    assert lines == ["drive: the controller file's own 'minibot_base_controller' takes cmd_vel"]
    assert abs(np.mean(result.between("linear", 1.0, 1.3)) - 0.3) < 0.01


def test_left_wheels_on_the_right_are_warned_and_drive_as_placed(tmp_path, caplog):
    """A description whose "left" wheel sits at -y (as ros2_control_demos' diffbot): a left
    turn command turns it right, as Gazebo would, and one warning says why."""
    package = tmp_path / "minibot_description"
    shutil.copytree(MINIBOT, package)
    xacro = package / "urdf" / "minibot.urdf.xacro"
    source = xacro.read_text()
    swapped = source.replace('side="left" y="${wheel_y}"', 'side="left" y="${-wheel_y}"')
    swapped = swapped.replace('side="right" y="${-wheel_y}"', 'side="right" y="${wheel_y}"')
    assert swapped.count("${-wheel_y}") == 1 and swapped != source
    xacro.write_text(swapped)
    mirrored = package
    twist = "twist: {start_delay: 0.3, steps: [{linear: 0.0, angular: 0.5, duration: 1.0}]}"
    with caplog.at_level("WARNING"):
        result = run(minibot(f"robot: {{description: {mirrored}}}", twist), 1.3)
    assert any(
        "its left wheels are on the base's right (-y)" in r.getMessage() for r in caplog.records
    )
    assert np.mean(result.between("angular", 0.9, 1.3)) < -0.4  # turning right
