"""The controller YAML loader against the files users write and the mistakes they make."""

import textwrap
from pathlib import Path

import pytest

from armando_drake import MODELS_DIR
from armando_drake.control.config import (
    ControllerConfigError,
    load_controller_config,
    parse_controller_config,
    validate_joints,
)

JOINT_STATE_BROADCASTER = "joint_state_broadcaster/JointStateBroadcaster"
JOINT_GROUP_POSITION_CONTROLLER = "position_controllers/JointGroupPositionController"
FORWARD_COMMAND_CONTROLLER = "forward_command_controller/ForwardCommandController"
JOINT_TRAJECTORY_CONTROLLER = "joint_trajectory_controller/JointTrajectoryController"
PACKAGE_CONFIG = MODELS_DIR / "armando_description" / "config" / "armando_controllers.yaml"
ARMANDO_JOINTS = ["j0", "j1", "j2", "j3"]

# The content the package's armando_controllers.yaml is specified to have.
ARMANDO_YAML = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    position_controller:
      type: position_controllers/JointGroupPositionController
    trajectory_controller:
      type: joint_trajectory_controller/JointTrajectoryController
position_controller:
  ros__parameters:
    joints: [j0, j1, j2, j3]
trajectory_controller:
  ros__parameters:
    joints: [j0, j1, j2, j3]
    command_interfaces: [position]
    state_interfaces: [position, velocity]
"""


def write(tmp_path: Path, text: str, name: str = "controllers.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def namespaced(text: str) -> str:
    """The same file with every node under the ``/**:`` wildcard namespace."""
    return '"/**":\n' + textwrap.indent(text, "  ")


def check_armando(config) -> None:
    assert config.update_rate == 100
    assert {name: c.type for name, c in config.controllers.items()} == {
        "joint_state_broadcaster": JOINT_STATE_BROADCASTER,
        "position_controller": JOINT_GROUP_POSITION_CONTROLLER,
        "trajectory_controller": JOINT_TRAJECTORY_CONTROLLER,
    }
    assert config.controllers["position_controller"].joints == ARMANDO_JOINTS
    position = config.controllers["position_controller"]
    assert (position.interface_name, position.topic) == ("position", "commands")
    trajectory = config.controllers["trajectory_controller"]
    assert (trajectory.interface_name, trajectory.topic) == ("position", "joint_trajectory")
    assert trajectory.params.joints == ARMANDO_JOINTS
    assert trajectory.params.command_interfaces == ["position"]
    assert config.controllers["joint_state_broadcaster"].joints == []
    validate_joints(config, ARMANDO_JOINTS, "armando.urdf.xacro")


@pytest.mark.parametrize("wrap", [lambda text: text, namespaced], ids=["plain", "wildcard"])
def test_armando_content_loads(tmp_path, wrap):
    path = write(tmp_path, wrap(ARMANDO_YAML))
    config = load_controller_config(path)
    check_armando(config)
    assert config.source == str(path)


@pytest.mark.parametrize("wrap", [lambda text: text, namespaced], ids=["plain", "wildcard"])
def test_package_config_loads(tmp_path, wrap):
    check_armando(load_controller_config(write(tmp_path, wrap(PACKAGE_CONFIG.read_text()))))


def test_namespaced_node_keys_and_dotted_names(tmp_path):
    path = write(
        tmp_path,
        """\
        /**/controller_manager:
          ros__parameters:
            update_rate: 250
            arm:
              type: joint_trajectory_controller/JointTrajectoryController
            forward:
              type: forward_command_controller/ForwardCommandController
        robot/arm:
          ros__parameters:
            joints: [j0, j1]
            command_interfaces: [position, velocity]
            state_interfaces: [position]
            allow_partial_joints_goal: true
            interpolation_method: none
            open_loop_control: true
            constraints.goal_time: 0.5
            constraints:
              stopped_velocity_tolerance: 0.02
              j0: {trajectory: 0.2, goal: 0.05}
              j1.goal: 0.1
        forward:
          ros__parameters:
            joints: [j3]
            interface_name: position
        """,
    )
    config = load_controller_config(path)
    assert config.update_rate == 250
    params = config.controllers["arm"].params
    assert params.allow_partial_joints_goal is True
    assert params.interpolation_method == "none"
    assert params.goal_time == 0.5
    assert params.stopped_velocity_tolerance == 0.02
    assert params.trajectory_tolerance == {"j0": 0.2}
    assert params.goal_tolerance == {"j0": 0.05, "j1": 0.1}
    forward = config.controllers["forward"]
    assert (forward.type, forward.topic, forward.interface_name) == (
        FORWARD_COMMAND_CONTROLLER,
        "commands",
        "position",
    )


def test_defaults(tmp_path):
    path = write(
        tmp_path,
        """\
        controller_manager:
          ros__parameters:
            arm: {type: joint_trajectory_controller/JointTrajectoryController}
        arm:
          ros__parameters:
            joints: [j0]
            command_interfaces: [position]
            state_interfaces: [position, velocity]
        """,
    )
    config = load_controller_config(path)
    assert config.update_rate == 100
    params = config.controllers["arm"].params
    assert (
        params.allow_partial_joints_goal,
        params.interpolation_method,
        params.allow_nonzero_velocity_at_trajectory_end,
        params.goal_time,
        params.stopped_velocity_tolerance,
        params.trajectory_tolerance,
        params.goal_tolerance,
    ) == (False, "splines", False, 0.0, 0.01, {}, {})


MANAGER = """\
controller_manager:
  ros__parameters:
    update_rate: {rate}
    pos:
      {type_line}
pos:
  ros__parameters:
{params}
"""
GOOD_TYPE = "type: position_controllers/JointGroupPositionController"
GOOD_PARAMS = "    joints: [j0, j1]"


@pytest.mark.parametrize(
    "rate, type_line, params, key, message",
    [
        (
            "100",
            "params_file: pos.yaml",
            GOOD_PARAMS,
            "controller_manager.ros__parameters.pos",
            "The 'type' param was not defined for 'pos'",
        ),
        (
            "0",
            GOOD_TYPE,
            GOOD_PARAMS,
            "controller_manager.ros__parameters.update_rate",
            "update_rate=0 must be a positive integer [Hz]",
        ),
        (
            "-10",
            GOOD_TYPE,
            GOOD_PARAMS,
            "controller_manager.ros__parameters.update_rate",
            "update_rate=-10 must be a positive integer [Hz]",
        ),
        (
            "100.5",
            GOOD_TYPE,
            GOOD_PARAMS,
            "controller_manager.ros__parameters.update_rate",
            "update_rate=100.5 must be a positive integer [Hz]",
        ),
        (
            "100",
            GOOD_TYPE,
            "    use_sim_time: true",
            "pos.ros__parameters.joints",
            "'joints' parameter is missing",
        ),
        (
            "100",
            GOOD_TYPE,
            "    joints: []",
            "pos.ros__parameters.joints",
            "joints=[] must not be empty",
        ),
        (
            "100",
            GOOD_TYPE,
            "    joints: [j0, j1, j0]",
            "pos.ros__parameters.joints",
            "joints=['j0', 'j1', 'j0'] lists 'j0' more than once",
        ),
        (
            "100",
            "type: forward_command_controller/ForwardCommandController",
            GOOD_PARAMS,
            "pos.ros__parameters.interface_name",
            "'interface_name' parameter is missing; give one of 'position', 'velocity', 'effort'",
        ),
        (
            "100",
            "type: forward_command_controller/ForwardCommandController",
            GOOD_PARAMS + "\n    interface_name: ''",
            "pos.ros__parameters.interface_name",
            "interface_name='' is not one of 'position', 'velocity', 'effort': the interfaces "
            "simulated",
        ),
        (
            "100",
            "type: forward_command_controller/ForwardCommandController",
            GOOD_PARAMS + "\n    interface_name: acceleration",
            "pos.ros__parameters.interface_name",
            "interface_name='acceleration' is not one of 'position', 'velocity', 'effort': the "
            "interfaces simulated",
        ),
        (
            "100",
            "type: joint_trajectory_controller/JointTrajectoryController",
            GOOD_PARAMS + "\n    state_interfaces: [position]",
            "pos.ros__parameters.command_interfaces",
            "'command_interfaces' parameter is missing; give one or more of "
            "'position', 'velocity', 'acceleration', 'effort'",
        ),
        (
            "100",
            "type: joint_trajectory_controller/JointTrajectoryController",
            GOOD_PARAMS + "\n    command_interfaces: [position]\n    state_interfaces: [torque]",
            "pos.ros__parameters.state_interfaces",
            "state_interfaces.0='torque' is not one of 'position', 'velocity', 'acceleration'",
        ),
        (
            "100",
            "type: joint_trajectory_controller/JointTrajectoryController",
            GOOD_PARAMS
            + "\n    command_interfaces: [position]\n    state_interfaces: [position]"
            + "\n    interpolation_method: cubic",
            "pos.ros__parameters.interpolation_method",
            "interpolation_method='cubic' is not one of 'splines', 'none'",
        ),
        (
            "100",
            "type: joint_trajectory_controller/JointTrajectoryController",
            GOOD_PARAMS
            + "\n    command_interfaces: [position]\n    state_interfaces: [position]"
            + "\n    constraints: {goal_time: -1}",
            "pos.ros__parameters.constraints.goal_time",
            "constraints.goal_time=-1.0 must be zero or positive [s]",
        ),
    ],
    ids=[
        "missing-type",
        "update-rate-zero",
        "update-rate-negative",
        "update-rate-float",
        "joints-missing",
        "joints-empty",
        "joints-duplicated",
        "interface-missing",
        "interface-empty",
        "interface-acceleration",
        "command-interfaces-missing",
        "state-interface-unknown",
        "interpolation-unknown",
        "goal-time-negative",
    ],
)
def test_bad_file_names_file_and_key(tmp_path, rate, type_line, params, key, message):
    text = MANAGER.format(rate=rate, type_line=type_line, params=params)
    path = write(tmp_path, text)
    with pytest.raises(ControllerConfigError) as error:
        load_controller_config(path)
    assert str(error.value) == f"{path}: {key}: {message}"


def test_unknown_type_is_noted_and_fails_only_when_used(tmp_path, caplog):
    # As upstream's controller manager, which fails when it loads a controller it has no
    # plugin for, not when it reads the file: the file loads, with one warning.
    text = MANAGER.format(
        rate=100, type_line="type: position_controllers/JointGroupVelocityController",
        params=GOOD_PARAMS,
    )  # fmt: skip
    path = write(tmp_path, text)
    with caplog.at_level("WARNING", logger="armando_drake.control.config"):
        config = load_controller_config(path)
    key = "controller_manager.ros__parameters.pos.type"
    assert [r.getMessage() for r in caplog.records] == [
        f"{path}: {key}: controller type 'position_controllers/JointGroupVelocityController' "
        "is not supported; 'pos' fails if activated"
    ]
    pos = config.controllers["pos"]
    assert not pos.supported and pos.joints == [] and pos.topic is None
    validate_joints(config, ARMANDO_JOINTS, "armando.urdf.xacro")  # nothing to check
    with pytest.raises(ControllerConfigError) as error:
        pos.controller_class  # noqa: B018  (the property raises)
    assert str(error.value) == (
        f"{path}: {key}: unknown controller type "
        "'position_controllers/JointGroupVelocityController'; "
        "supported: joint_state_broadcaster/JointStateBroadcaster, "
        "diff_drive_controller/DiffDriveController, "
        "forward_command_controller/ForwardCommandController, "
        "position_controllers/JointGroupPositionController, "
        "velocity_controllers/JointGroupVelocityController, "
        "effort_controllers/JointGroupEffortController, "
        "joint_trajectory_controller/JointTrajectoryController, "
        "vision_controllers/LookAtPointController, "
        "vision_controllers/ImprovedLookAtPointController, "
        "task_space_controllers/JointSpaceInverseDynamics, "
        "task_space_controllers/OperationalSpaceInverseDynamics, "
        "vision_controllers/JointSpaceLookAtController, "
        "vision_controllers/OperationalSpaceLookAtController, "
        "forward_command_controller/MultiInterfaceForwardCommandController, "
        "pid_controller/PidController"
    )


def test_unknown_joint_names_file_key_and_known_joints(tmp_path):
    path = write(tmp_path, ARMANDO_YAML.replace("joints: [j0, j1, j2, j3]", "joints: [j0, x]", 1))
    config = load_controller_config(path)
    with pytest.raises(ControllerConfigError) as error:
        validate_joints(config, ARMANDO_JOINTS, "armando.urdf.xacro")
    assert str(error.value) == (
        f"{path}: position_controller.ros__parameters.joints: unknown joint 'x' of controller "
        "'position_controller'; armando.urdf.xacro has known joints: j0, j1, j2, j3"
    )


def test_namespaced_error_names_namespaced_key(tmp_path):
    path = write(tmp_path, namespaced(ARMANDO_YAML.replace("update_rate: 100", "update_rate: 0")))
    with pytest.raises(ControllerConfigError, match="update_rate=0") as error:
        load_controller_config(path)
    assert str(error.value).startswith(
        f"{path}: /**/controller_manager.ros__parameters.update_rate: "
    )


@pytest.mark.parametrize(
    "text, message",
    [
        ("controller_manager: [1, 2\n", r":2: not valid YAML"),
        ("- a\n- b\n", r": expected a mapping of ROS nodes, got \['a', 'b'\]"),
        ("pos:\n  ros__parameters: {joints: [j0]}\n", r": controller_manager: no 'controller_"),
    ],
    ids=["syntax", "not-a-mapping", "no-manager"],
)
def test_unusable_files(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(ControllerConfigError, match=message) as error:
        load_controller_config(path)
    assert str(error.value).startswith(str(path))


def test_missing_file(tmp_path):
    with pytest.raises(ControllerConfigError, match="cannot read controller file"):
        load_controller_config(tmp_path / "absent.yaml")


def test_parse_names_given_source():
    with pytest.raises(ControllerConfigError) as error:
        parse_controller_config({"controller_manager": {"ros__parameters": {"a": {}}}}, "inline")
    assert str(error.value) == (
        "inline: controller_manager.ros__parameters.a: The 'type' param was not defined for 'a'"
    )
