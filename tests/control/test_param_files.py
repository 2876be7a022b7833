"""Parameter files read as ROS reads them: repeated node keys, several files, wildcards and
namespaces, a controller's own type, launch substitutions, ROS 1 files loaded in turn;
source packages laid out as their CMakeLists.txt installs them."""

import logging
import textwrap
from pathlib import Path

import pytest

from armando_drake.control.config import ControllerConfigError, load_controller_config
from armando_drake.control.param_files import NodeEntry
from armando_drake.control.sequencer import JointTrajectoryTargets, PositionTargets
from armando_drake.control.stack import ControllersConfig, arm_controllers, choose_controllers
from armando_drake.description.packages import install_rules, installed_view
from armando_drake.simulation.scenario import load_scenario, merge_overrides

JSB = "joint_state_broadcaster/JointStateBroadcaster"
JTC = "joint_trajectory_controller/JointTrajectoryController"
GROUP = "position_controllers/JointGroupPositionController"


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text))
    return path


def test_a_node_key_given_again_is_merged_later_values_winning(tmp_path):
    path = write(
        tmp_path,
        "c.yaml",
        f"""\
        /**:
          controller_manager:
            ros__parameters:
              update_rate: 50
              arm: {{type: {GROUP}}}
        /**:
          controller_manager:
            ros__parameters:
              update_rate: 200
              jsb: {{type: {JSB}}}
        arm:
          ros__parameters:
            joints: [a]
        arm:
          ros__parameters:
            joints: [j0, j1]
        """,
    )
    config = load_controller_config(path)
    assert config.update_rate == 200
    assert list(config.controllers) == ["arm", "jsb"]
    assert config.controllers["arm"].joints == ["j0", "j1"]


def test_several_files_in_order_later_values_win(tmp_path, caplog):
    base = write(
        tmp_path,
        "base.yaml",
        f"""\
        controller_manager:
          ros__parameters:
            update_rate: 100
            jsb: {{type: {JSB}}}
            arm: {{type: {JTC}}}
        arm:
          ros__parameters:
            joints: [j0]
            command_interfaces: [position]
            state_interfaces: [position, velocity]
            constraints: {{goal_time: 1.0}}
        """,
    )
    site = write(
        tmp_path,
        "site.yaml",
        """\
        controller_manager:
          ros__parameters:
            update_rate: 250
        arm:
          ros__parameters:
            joints: [j0, j1]
            bogus: 1
        """,
    )
    with caplog.at_level(logging.WARNING, logger="armando_drake.control.config"):
        config = load_controller_config([base, site])
    assert config.update_rate == 250
    assert config.source == f"{base}, {site}" and config.sources == [str(base), str(site)]
    arm = config.controllers["arm"]
    assert arm.joints == ["j0", "j1"] and arm.params.goal_time == 1.0  # merged, not replaced
    # A warning names the file that gave the parameter.
    assert [r.getMessage() for r in caplog.records] == [
        f"{site}: arm.ros__parameters.bogus: {JTC} (ROS 2 Jazzy) does not declare it; "
        "ignored, as ROS ignores it"
    ]
    reversed_config = load_controller_config([site, base])
    assert reversed_config.update_rate == 100
    assert reversed_config.controllers["arm"].joints == ["j0"]


@pytest.mark.parametrize(
    "pattern, name, matches",
    [
        ("/**", "/controller_manager", True),
        ("/**", "/a/b/arm", True),
        ("/**/arm", "/arm", True),
        ("/**/arm", "/robot/ns/arm", True),
        ("/*/arm", "/robot/arm", True),
        ("/*/arm", "/arm", False),
        ("/*/arm", "/a/b/arm", False),
        ("/robot/arm", "/robot/arm", True),
        ("/robot/arm", "/other/arm", False),
        ("/robot/*", "/robot/arm", True),
    ],
)
def test_wildcards_as_rclcpp_matches_them(pattern, name, matches):
    assert NodeEntry(pattern, "", "").matches(name) is matches


def test_type_in_the_controllers_own_parameters_and_qualified_names(tmp_path, caplog):
    path = write(
        tmp_path,
        "c.yaml",
        f"""\
        /robot/controller_manager:
          ros__parameters:
            jsb: {{type: {JSB}}}
        /**/arm:
          ros__parameters:
            type: {JTC}
            command_interfaces: [position]
            state_interfaces: [position]
        /robot/arm:
          ros__parameters:
            joints: [j0, j1]
        /other/arm:
          ros__parameters:
            joints: [x]
        /robot/hand:
          ros__parameters:
            type: {GROUP}
            joints: [j2]
        """,
    )
    with caplog.at_level(logging.WARNING, logger="armando_drake.control.config"):
        config = load_controller_config(path)
    assert {name: c.type for name, c in config.controllers.items()} == {
        "jsb": JSB,
        "arm": JTC,
        "hand": GROUP,
    }
    assert config.controllers["arm"].joints == ["j0", "j1"]
    assert [r.getMessage() for r in caplog.records] == [
        f"{path}: /other/arm.ros__parameters: a node of namespace /other, not of the "
        "controller manager's (/robot); ignored"
    ]


def test_no_controller_manager_node_at_all(tmp_path):
    # ros2_control_demos' rrbot_controllers.yaml: the manager's rate comes from the launch.
    path = write(
        tmp_path,
        "c.yaml",
        f"""\
        joint_state_broadcaster:
          ros__parameters:
            type: {JSB}
            update_rate: 50
        forward:
          ros__parameters:
            type: forward_command_controller/ForwardCommandController
            joints: [j0]
            interface_name: position
        publisher:
          ros__parameters:
            wait_sec_between_publish: 5
        """,
    )
    config = load_controller_config(path)
    assert config.update_rate == 100
    assert list(config.controllers) == ["joint_state_broadcaster", "forward"]


def test_types_that_differ_are_one_error(tmp_path):
    path = write(
        tmp_path,
        "c.yaml",
        f"""\
        controller_manager:
          ros__parameters:
            arm: {{type: {GROUP}}}
        arm:
          ros__parameters:
            type: {JTC}
            joints: [j0]
        """,
    )
    with pytest.raises(ControllerConfigError) as error:
        load_controller_config(path)
    assert str(error.value) == (
        f"{path}: arm.ros__parameters.type: type '{JTC}' differs from '{GROUP}'"
    )


def test_a_bad_controller_read_leniently_fails_only_when_activated(tmp_path, caplog):
    path = write(
        tmp_path,
        "c.yaml",
        f"""\
        controller_manager:
          ros__parameters:
            jsb: {{type: {JSB}}}
            fast: {{type: {GROUP}}}
        fast:
          ros__parameters:
            joints: [j0, j0]
        """,
    )
    with pytest.raises(
        ControllerConfigError, match=r"joints=\['j0', 'j0'\] lists 'j0' more than once"
    ):
        load_controller_config(path)
    with caplog.at_level(logging.WARNING, logger="armando_drake.control.config"):
        config = load_controller_config(path, strict=False)
    problem = f"{path}: fast.ros__parameters.joints: joints=['j0', 'j0'] lists 'j0' more than once"
    assert [r.getMessage() for r in caplog.records] == [f"{problem}; 'fast' fails if activated"]
    assert config.controllers["jsb"].supported and not config.controllers["fast"].supported
    with pytest.raises(ControllerConfigError) as error:
        config.controllers["fast"].controller_class  # noqa: B018 (the property raises)
    assert str(error.value) == problem


def test_launch_arguments_from_the_packages_launch_files_and_given(tmp_path):
    package = tmp_path / "demo"
    write(package, "package.xml", "<package><name>demo</name></package>")
    write(
        package,
        "bringup/launch/demo.launch.py",
        """\
        DeclareLaunchArgument(
            "joint_prefix",
            default_value="joint",
            description="Prefix (used with allow_substs)",
        )
        """,
    )
    path = write(
        package,
        "bringup/config/c.yaml",
        f"""\
        arm:
          ros__parameters:
            type: {GROUP}
            joints: [$(var joint_prefix)1, "$(var joint_prefix)2"]
        """,
    )
    assert load_controller_config(path).controllers["arm"].joints == ["joint1", "joint2"]
    given = load_controller_config(path, arguments={"joint_prefix": "j"})
    assert given.controllers["arm"].joints == ["j1", "j2"]
    unknown = write(tmp_path, "u.yaml", "a:\n  ros__parameters:\n    x: $(var nowhere)\n")
    with pytest.raises(ControllerConfigError) as error:
        load_controller_config(unknown)
    assert str(error.value).startswith(
        f"{unknown}:3: $(var nowhere): no value for launch argument 'nowhere'"
    )


def test_ros1_files_loaded_in_turn(tmp_path):
    states = write(
        tmp_path,
        "joint_state_controller.yaml",
        """\
        arm:
          joint_state_controller:
            type: joint_state_controller/JointStateController
            publish_rate: 50
        """,
    )
    arm = write(
        tmp_path,
        "arm_controller.yaml",
        """\
        arm:
          arm_controller:
            type: position_controllers/JointTrajectoryController
            joints: [j0, j1]
            constraints: {goal_time: 0.6}
        """,
    )
    gains = write(
        tmp_path,
        "gains.yaml",
        """\
        arm:
          arm_controller:
            constraints: {goal_time: 0.2}
          hand:
            type: position_controllers/JointPositionController
        """,
    )
    config = load_controller_config([states, arm])
    assert config.ros == 1 and list(config.controllers) == [
        "joint_state_controller",
        "arm_controller",
    ]
    assert config.controllers["arm_controller"].ros_topic == "/arm/arm_controller/command"
    with pytest.raises(ControllerConfigError) as error:
        load_controller_config([states, arm, gains])
    # The error names the file that set the controller last.
    assert str(error.value) == (f"{gains}: arm/hand.joint: No joint given; expected a joint name")
    ros2 = write(tmp_path, "r2.yaml", "a:\n  ros__parameters:\n    type: x\n")
    with pytest.raises(ControllerConfigError, match="give files of one ROS generation"):
        load_controller_config([states, ros2])


def test_the_scenario_takes_one_file_or_a_list(tmp_path):
    def config(scenario):  # of its one robot
        return scenario.robots["robot"].controllers.config

    assert config(load_scenario("position")) == []
    one = merge_overrides(load_scenario("position"), "controllers: {config: a.yaml}")
    assert config(one) == ["a.yaml"]
    many = merge_overrides(load_scenario("position"), "controllers: {config: [a.yaml, b.yaml]}")
    assert config(many) == ["a.yaml", "b.yaml"]
    scenario = write(tmp_path, "s.yaml", "controllers:\n  config: c.yaml\n")
    assert config(load_scenario(scenario)) == ["c.yaml"]


def test_the_default_controllers_stand_for_the_files_own(tmp_path):
    path = write(
        tmp_path,
        "c.yaml",
        f"""\
        controller_manager:
          ros__parameters:
            gripper: {{type: {JTC}}}
            arm: {{type: {JTC}}}
            group: {{type: {GROUP}}}
        gripper:
          ros__parameters: {{joints: [g], command_interfaces: [position],
                             state_interfaces: [position]}}
        arm:
          ros__parameters: {{joints: [a, b], command_interfaces: [position],
                             state_interfaces: [position]}}
        group:
          ros__parameters: {{joints: [a, b, g]}}
        """,
    )
    config = load_controller_config(path)
    # Trajectory controllers first, the one with the most joints first.
    assert [c.name for c in arm_controllers(config)] == ["arm", "gripper", "group"]
    activate = ControllersConfig().activate or ["joint_state_broadcaster", "position_controller"]
    choice = choose_controllers(activate, config, PositionTargets(period=2.0))
    assert choice.activate == ["joint_state_broadcaster", "arm"]
    assert isinstance(choice.sequencer, JointTrajectoryTargets)
    assert choice.sequencer.period == 2.0 and not choice.hold
    assert "joint_state_broadcaster" in config.controllers  # added: the file has none


def test_install_rules_lay_a_source_package_out(tmp_path):
    package = tmp_path / "pkg"
    write(
        package,
        "CMakeLists.txt",
        """\
        project(pkg)
        install(DIRECTORY description/ros2_control description/urdf  # two folders
          DESTINATION share/${PROJECT_NAME})
        install(DIRECTORY bringup/config/ DESTINATION share/${PROJECT_NAME}/params)
        install(FILES extra/a.xacro DESTINATION share/${PROJECT_NAME}/urdf/inc)
        install(DIRECTORY include/ DESTINATION include/${PROJECT_NAME})
        install(DIRECTORY ${UNKNOWN}/x DESTINATION share/${PROJECT_NAME})
        install(DIRECTORY meshes DESTINATION share/${PROJECT_NAME} PATTERN "*.tmp" EXCLUDE)
        """,
    )
    for relative in (
        "description/ros2_control/r.xacro",
        "description/urdf/robot.xacro",
        "bringup/config/c.yaml",
        "extra/a.xacro",
        "meshes/own.stl",
        "include/h.hpp",
        "package.xml",
    ):
        write(package, relative, "x")
    assert [(below, path.relative_to(package).as_posix(), contents) for below, path, contents in
            install_rules(package)] == [
        ("", "description/ros2_control", False),
        ("", "description/urdf", False),
        ("params", "bringup/config", True),
        ("urdf/inc", "extra/a.xacro", False),
        ("", "meshes", False),
    ]  # fmt: skip
    view = installed_view(package)
    assert view != package
    for relative in ("ros2_control/r.xacro", "urdf/robot.xacro", "urdf/inc/a.xacro",
                     "params/c.yaml", "meshes/own.stl", "description/urdf/robot.xacro",
                     "package.xml"):  # fmt: skip
        assert (view / relative).is_file(), relative
    assert (view / "params" / "c.yaml").resolve() == (package / "bringup/config/c.yaml").resolve()
    # A package laid out as installed already (no CMakeLists.txt, or nothing moved) is itself.
    plain = tmp_path / "plain"
    write(plain, "urdf/r.urdf", "x")
    assert installed_view(plain) == plain
