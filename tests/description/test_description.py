"""Finding packages, expanding xacro and loading descriptions, with their error messages."""

import numpy as np
import pytest
from conftest import make_mini_package
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant

from armando_drake.description.loader import (
    DescriptionError,
    expand_description,
    find_packages,
    load_robot,
)
from armando_drake.description.ros2_control import Ros2ControlError

ROS2_CONTROL = """
<ros2_control name="MiniSystem" type="system">
  <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
  <joint name="JOINT">
    <command_interface name="position"><param name="min">-1.5</param></command_interface>
    <state_interface name="position"><param name="initial_value">0.3</param></state_interface>
    <state_interface name="velocity"/>
  </joint>
</ros2_control>
"""


def test_xacro_package_loads_with_prefix_and_weld(mini_package):
    plant = MultibodyPlant(time_step=0.001)
    X_WB = RigidTransform([0.1, 0.2, 0.3])
    robot = load_robot(plant, mini_package, xacro_args={"prefix": "left_"}, X_WB=X_WB)
    plant.Finalize()
    assert [j.name for j in robot.joints] == ["left_q1", "left_q2"]
    assert robot.base_link == "left_base_link"
    assert robot.joint("left_q2").lower == -2.5
    assert plant.num_positions() == 2  # the base is welded, not floating
    context = plant.CreateDefaultContext()
    X = plant.GetFrameByName("left_base_link").CalcPoseInWorld(context)
    np.testing.assert_allclose(X.translation(), [0.1, 0.2, 0.3])
    # The tip sits 0.125 + 0.2 + 0.1 m above the base when straight.
    tip = plant.GetFrameByName("left_tip").CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(tip, [0.1, 0.2, 0.3 + 0.425], atol=1e-12)


def test_package_url_and_file_resolve_to_the_same_description(mini_package):
    search = find_packages(near=mini_package)
    assert search.resolve("mini_description") == mini_package.resolve()
    by_file = expand_description(mini_package / "urdf" / "mini.urdf.xacro", search=search)
    plant = MultibodyPlant(time_step=0.0)
    robot = load_robot(
        plant, "package://mini_description/urdf/mini.urdf.xacro", package_paths=[mini_package]
    )
    assert robot.urdf == by_file


def test_explicit_package_path_wins_over_the_environment(tmp_path, monkeypatch):
    first = make_mini_package(tmp_path / "first")
    second = make_mini_package(tmp_path / "second")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(second.parent))
    assert find_packages([first.parent]).resolve("mini_description") == first.resolve()
    assert find_packages().resolve("mini_description") == second.resolve()
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    share = make_mini_package(tmp_path / "install" / "share")
    assert find_packages().resolve("mini_description") == share.resolve()


def test_missing_description_file_is_named(tmp_path):
    missing = tmp_path / "nope.urdf.xacro"
    with pytest.raises(DescriptionError, match=rf"{missing}: description file not found"):
        load_robot(MultibodyPlant(0.0), missing)


def test_xacro_syntax_error_names_file_and_line(mini_package):
    parts = mini_package / "urdf" / "parts.xacro"
    parts.write_text(parts.read_text().replace("</link>", "</lnk>"))
    with pytest.raises(DescriptionError) as error:
        load_robot(MultibodyPlant(0.0), mini_package)
    message = str(error.value)
    assert f"{parts}:14:" in message, message
    assert "mismatched tag" in message
    assert "mini.urdf.xacro" in message  # the including file is named too


def test_xacro_expression_error_names_file(mini_package):
    top = mini_package / "urdf" / "mini.urdf.xacro"
    top.write_text(top.read_text().replace('size="0.1 0.1 0.05"', 'size="${1/}"'))
    with pytest.raises(DescriptionError, match=r"mini\.urdf\.xacro.*invalid syntax.*'1/'"):
        load_robot(MultibodyPlant(0.0), mini_package)


def test_unknown_package_in_find_is_named_with_search_path(mini_package, tmp_path):
    top = mini_package / "urdf" / "mini.urdf.xacro"
    top.write_text(top.read_text().replace("$(find mini_description)", "$(find nope_pkg)"))
    with pytest.raises(DescriptionError) as error:
        load_robot(MultibodyPlant(0.0), top, package_paths=[tmp_path / "extra"])
    message = str(error.value)
    assert "unknown package 'nope_pkg'" in message
    assert f"--package-path: {tmp_path / 'extra'}" in message
    assert "project models" in message


def test_unknown_package_url_as_description():
    with pytest.raises(DescriptionError, match="unknown package 'nope_pkg'"):
        load_robot(MultibodyPlant(0.0), "package://nope_pkg/urdf/robot.urdf")


def test_ros2_control_block_is_parsed_with_limits(tmp_path):
    package = make_mini_package(tmp_path, ROS2_CONTROL.replace("JOINT", "q1"))
    robot = load_robot(MultibodyPlant(0.0), package)
    (block,) = robot.ros2_control
    assert (block.name, block.type, block.plugin) == (
        "MiniSystem",
        "system",
        "mock_components/GenericSystem",
    )
    (joint,) = block.joints
    assert joint.command_interface("position").min == -1.5
    assert joint.state_interface("position").initial_value == 0.3
    assert [i.name for i in joint.state_interfaces] == ["position", "velocity"]


@pytest.mark.parametrize(
    "joint, message",
    [
        ("q7", r"<ros2_control name='MiniSystem'>: Joint 'q7' not found in URDF"),
        ("tip_joint", r"<ros2_control name='MiniSystem'>: Joint 'tip_joint' is fixed"),
    ],
)
def test_ros2_control_joint_missing_or_fixed(tmp_path, joint, message):
    package = make_mini_package(tmp_path, ROS2_CONTROL.replace("JOINT", joint))
    with pytest.raises(Ros2ControlError, match=rf"mini\.urdf\.xacro: {message}"):
        load_robot(MultibodyPlant(0.0), package)
