"""The drive plugins of a description's <gazebo> blocks, read with upstream's defaults."""

import math
import xml.etree.ElementTree as ET

import pytest

from armando_drake.description.drive import (
    GAZEBO_ROS,
    GAZEBO_ROS1,
    GZ_SIM,
    link_friction,
    parse_drive_plugins,
)
from armando_drake.description.packages import DescriptionError

JOINTS = '<joint name="l" type="continuous"/><joint name="r" type="continuous"/>'


def drives(plugin: str):
    return parse_drive_plugins(ET.fromstring(f'<robot name="x">{JOINTS}{plugin}</robot>'), "x.urdf")


def test_gazebo_sim_diff_drive_defaults_and_limits():
    (drive,) = drives(
        '<gazebo><plugin name="gz::sim::systems::DiffDrive" filename="gz-sim-diff-drive-system">'
        "<left_joint>l</left_joint><right_joint>r</right_joint>"
        "<max_velocity>1.0</max_velocity><max_angular_velocity>2.0</max_angular_velocity>"
        "<min_linear_acceleration>-3</min_linear_acceleration></plugin></gazebo>"
    )
    assert drive.dialect == GZ_SIM and drive.joints == ("l", "r")
    assert (drive.wheel_separation, drive.wheel_radius, drive.odom_rate) == (1.0, 0.2, 50.0)
    assert drive.topic == "cmd_vel" and drive.odometry_source == "encoder"
    # Each bound on its own: the axis-less tag sets both axes, an axis tag overrides it.
    assert (drive.linear.max_velocity, drive.angular.max_velocity) == (1.0, 2.0)
    assert drive.linear.min_velocity == -math.inf
    assert drive.linear.min_acceleration == -3.0 and drive.angular.min_acceleration == -math.inf


def test_gazebo_classic_ros2_tags_namespace_and_remapping():
    (drive,) = drives(
        '<gazebo><plugin name="dd" filename="libgazebo_ros_diff_drive.so">'
        "<ros><namespace>/demo</namespace><remapping>cmd_vel:=cmd_demo</remapping></ros>"
        "<left_joint>l</left_joint><right_joint>r</right_joint>"
        "<wheel_separation>1.25</wheel_separation><wheel_diameter>0.6</wheel_diameter>"
        "<max_wheel_torque>20</max_wheel_torque><max_wheel_acceleration>1.0</max_wheel_acceleration>"
        "<odometry_source>0</odometry_source><robot_base_frame>chassis</robot_base_frame>"
        "</plugin></gazebo>"
    )
    assert drive.dialect == GAZEBO_ROS and drive.name == "dd"
    assert (drive.wheel_separation, drive.wheel_radius) == (1.25, 0.3)
    assert (drive.max_wheel_torque, drive.max_wheel_acceleration) == (20.0, 1.0)
    assert drive.topic == "demo/cmd_demo" and drive.odom_topic == "demo/odom"
    assert drive.odometry_source == "encoder" and drive.base_frame == "chassis"
    assert drive.publish_odom_tf is False  # ROS 2's default


def test_gazebo_classic_ros1_defaults():
    (drive,) = drives(
        '<gazebo><plugin name="c" filename="libgazebo_ros_diff_drive.so">'
        "<leftJoint>l</leftJoint><rightJoint>r</rightJoint></plugin></gazebo>"
    )
    assert drive.dialect == GAZEBO_ROS1
    assert (drive.wheel_separation, drive.wheel_radius) == (0.34, 0.075)
    assert drive.max_wheel_torque == 5.0 and drive.max_wheel_acceleration == math.inf
    assert drive.odometry_source == "world" and drive.publish_odom_tf is True
    assert drive.base_frame == "base_footprint" and drive.update_rate == 100.0


def test_other_plugins_are_not_drives():
    assert drives('<gazebo><plugin name="p" filename="libgazebo_ros_p3d.so"/></gazebo>') == []


@pytest.mark.parametrize(
    "body, match",
    [
        ("<left_joint>l</left_joint>", "no right wheel joint"),
        (
            "<left_joint>l</left_joint><right_joint>q</right_joint>",
            r"right wheel joint 'q' is not a joint of the robot \(its moving joints: l, r\)",
        ),
        (
            "<left_joint>l</left_joint><right_joint>r</right_joint><wheel_radius>-0.035</wheel_radius>",
            r"<wheel_radius>-0.035</wheel_radius> must be > 0",
        ),
        (
            "<left_joint>l</left_joint><right_joint>r</right_joint><wheel_radius>big</wheel_radius>",
            r"<wheel_radius>big</wheel_radius> is not a number",
        ),
    ],
)
def test_bad_plugins_are_one_line_errors_naming_file_plugin_and_value(body, match):
    plugin = (
        f'<gazebo><plugin name="d" filename="gz-sim-diff-drive-system">{body}</plugin></gazebo>'
    )
    with pytest.raises(DescriptionError, match=r'x\.urdf: <plugin name="d" .*' + match):
        drives(plugin)


def test_link_friction_reads_mu1_and_mu2():
    root = ET.fromstring(
        '<robot name="x"><gazebo reference="a"><mu1>0.1</mu1><mu2>0.2</mu2></gazebo>'
        '<gazebo reference="b"><mu1 value="0.5"/></gazebo></robot>'
    )
    assert link_friction(root) == {"a": 0.1, "b": 0.5}
