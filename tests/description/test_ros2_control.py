"""The <ros2_control> parser against the cases upstream's component parser tests."""

import xml.etree.ElementTree as ET

import pytest

from armando_drake.description.ros2_control import (
    Ros2ControlError,
    initial_position,
    merge_limits,
    parse_ros2_control,
)

URDF = """<robot name="r">
  <link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>
  <joint name="fixed1" type="fixed"><parent link="b"/><child link="c"/></joint>
  {block}
</robot>"""

GOOD = """<ros2_control name="Sys" type="system">
  <hardware><plugin>mock_components/GenericSystem</plugin><param name="k">1</param></hardware>
  <joint name="j1">
    <command_interface name="position">
      <param name="min">-1</param><param name="max">1</param>
    </command_interface>
    <state_interface name="position"><param name="initial_value">0.5</param></state_interface>
    <state_interface name="velocity"/>
  </joint>
  <sensor name="ft"><state_interface name="force.x"/></sensor>
</ros2_control>"""


def parse(block: str):
    return parse_ros2_control(ET.fromstring(URDF.format(block=block)), source="robot.urdf")


def test_good_block():
    (info,) = parse(GOOD)
    assert info.hardware_parameters == {"k": "1"}
    (joint,) = info.joints
    command = joint.command_interface("position")
    assert (command.min, command.max) == (-1.0, 1.0)
    assert joint.state_interface("position").initial_value == 0.5
    assert [s.name for s in info.sensors] == ["ft"]


def test_no_block_means_no_hardware():
    assert parse("") == []


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('<joint name="j1">', "<joint>", "no attribute 'name' in 'joint' tag"),
        ('name="Sys" ', "", "no attribute 'name' in 'ros2_control' tag"),
        ('type="system"', 'type="robot"', "has type='robot'; expected system"),
        (
            "<plugin>mock_components/GenericSystem</plugin>",
            "",
            "Missing <plugin> tag of <hardware> element for 'Sys'",
        ),
        ('<param name="k">1</param>', "<param>1</param>", "no attribute 'name' in 'param' tag"),
        (
            '<state_interface name="velocity"/>',
            '<state_interface name=""/>',
            "empty interface type in 'state_interface' of 'j1'",
        ),
        (
            '<state_interface name="velocity"/>',
            '<state_interface name="velocity" size="two"/>',
            "size='two' of state_interface 'velocity' of 'j1' is not an integer",
        ),
        (
            '<state_interface name="velocity"/>',
            '<state_interface name="velocity" size="-1"/>',
            "size=-1 of state_interface 'velocity' of 'j1' is negative",
        ),
        ('<joint name="j1">', '<joint name="j9">', "Joint 'j9' not found in URDF"),
        ('<joint name="j1">', '<joint name="fixed1">', "Joint 'fixed1' is fixed"),
        (
            '<sensor name="ft"><state_interface name="force.x"/></sensor>',
            "<actuator/>",
            "unknown tag <actuator> in <ros2_control name='Sys'>",
        ),
        ('<state_interface name="velocity"/>', "<limits/>", "unknown tag <limits> in <joint"),
        (
            '<param name="min">-1</param>',
            '<param name="min">low</param>',
            "command_interface 'position' of 'j1' min='low' is not a number",
        ),
        ('<param name="min">-1</param>', '<param name="min">2</param>', "has min=2.0 > max=1.0"),
    ],
)
def test_bad_blocks_are_refused_with_the_reason(old, new, message):
    assert old in GOOD
    with pytest.raises(Ros2ControlError) as error:
        parse(GOOD.replace(old, new, 1))
    assert str(error.value).startswith("robot.urdf: ")
    assert message in str(error.value)


def test_not_a_urdf():
    with pytest.raises(Ros2ControlError, match="not a URDF: the root element is <sdf>"):
        parse_ros2_control(ET.fromstring("<sdf/>"))


def test_limits_merge_the_tighter_way_and_initial_value_is_clamped():
    (info,) = parse(GOOD)
    command = info.joints[0].command_interface("position")
    assert merge_limits(-3.0, 0.5, command) == (-1.0, 0.5)
    assert merge_limits(-3.0, 3.0, None) == (-3.0, 3.0)
    state = info.joints[0].state_interface("position")
    assert initial_position(-1.0, 1.0, state) == 0.5
    assert initial_position(0.7, 1.0, state) == 0.7  # clamped into the limits
    assert initial_position(-1.0, -0.2, None) == -0.2  # absent: 0, clamped
