"""Two different robots in one world, each with its own controller YAML: the 7-joint iiwa
(models/iiwa_description, our copy of the course's numbers) and Armando beside it."""

import io
import json

import pytest

from armando_drake.outputs.logger import read_joint_states
from armando_drake.simulation.run import run
from armando_drake.simulation.scenario import load_scenario

TOLERANCE = 0.01  # [rad]
IIWA_TARGETS = [[0.0] * 7, [0.8, -0.6, 0.5, -1.2, 0.4, 0.8, -0.5]]
ARMANDO_TARGETS = [[0.0] * 4, [-0.8, 0.6, -1.0, -0.4]]
# The iiwa's own controller file, as its package would have it (ros2_control's names).
IIWA_CONTROLLERS = """
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    position_controller: {type: forward_command_controller/ForwardCommandController}
position_controller:
  ros__parameters:
    joints: [iiwa_joint_1, iiwa_joint_2, iiwa_joint_3, iiwa_joint_4, iiwa_joint_5,
             iiwa_joint_6, iiwa_joint_7]
    interface_name: position
"""
SCENARIO = f"""
robots:
  - name: iiwa
    robot:
      description: package://iiwa_description/urdf/iiwa14.urdf.xacro
      base_xyz: [0.0, 0.0, 0.0]
    controllers:
      config: CONTROLLERS
      activate: [joint_state_broadcaster, position_controller]
    sequencer: !PositionTargets {{targets: {IIWA_TARGETS}, period: 2.5}}
  - name: armando
    robot:
      description: ""
      xacro_args: {{use_camera: "false"}}
      base_xyz: [0.9, 0.0, 0.0313]
      base_rpy: [0.0, 0.0, 3.1416]
    actuators: {{gravity_feedforward: true}}
    controllers: {{activate: [joint_state_broadcaster, position_controller]}}
    sequencer: !PositionTargets {{targets: {ARMANDO_TARGETS}, period: 2.5}}
logging: {{console_rate: 0}}
simulator_config: {{target_realtime_rate: 0}}
"""


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    out = tmp_path_factory.mktemp("mixed")
    controllers = out / "iiwa_controllers.yaml"
    controllers.write_text(IIWA_CONTROLLERS)
    scenario = load_scenario(None, SCENARIO.replace("CONTROLLERS", str(controllers)))
    run(scenario, output_dir=out, quiet=True, stream=io.StringIO(), replay=False, plots=False)
    return out, json.loads((out / "summary.json").read_text())


def test_each_robot_reaches_its_own_targets(mixed):
    _, summary = mixed
    robots = summary["robots"]
    assert set(robots) == {"iiwa", "armando"}
    assert len(robots["iiwa"]["joint_names"]) == 7 and len(robots["armando"]["joint_names"]) == 4
    for name in robots:
        assert robots[name]["max_final_error"] <= TOLERANCE, (name, robots[name])


@pytest.mark.parametrize(
    "name, joints, final",
    [("iiwa", 7, IIWA_TARGETS[-1]), ("armando", 4, ARMANDO_TARGETS[-1])],
)
def test_each_robot_logs_its_own_joints(mixed, name, joints, final):
    out, summary = mixed
    names = summary["robots"][name]["joint_names"]
    log = read_joint_states(out / name / "joint_states.csv", names)
    assert log.position.shape[1] == joints
    assert abs(log.position[-1] - final).max() <= TOLERANCE
    assert log.times[-1] == pytest.approx(summary["sim_time"], abs=0.02)
