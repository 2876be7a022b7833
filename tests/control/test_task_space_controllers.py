"""The inverse-dynamics torque controllers through the world: MakeWorld, the scenario's
``task:`` section, the registered controller types run by the controller manager at
1 kHz, the errors of summary.json.

iiwa (models/iiwa_description, every joint on the effort interface): both controllers on the four
trajectories (linear / circular x trapezoidal / cubic): max position error <= 1 mm,
max orientation error <= 0.01 rad, joint positions, velocities and efforts within
their URDF limits, no torque clamped. Armando: linear and circular position paths
through the trajectory controller within 2 mm. Bad input: rejected with the reason,
or followed through a singularity with finite torques within the limits.
"""

import json

import numpy as np
import pytest
from conftest import REPO
from PIL import Image
from pydrake.systems.analysis import Simulator

from armando_drake.messages.types import (
    CartesianTrajectory,
    CartesianTrajectoryPoint,
    Float64MultiArray,
    JointTrajectory,
    JointTrajectoryPoint,
)
from armando_drake.outputs.logger import read_joint_states
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.run import run
from armando_drake.simulation.scenario import load_scenario

QUIET = "logging: {console_rate: 0}\nsimulator_config: {target_realtime_rate: 0}"
IIWA_EFFORT = 300.0  # [N m] the iiwa14 URDF's effort limit of every joint
IIWA_VELOCITY = 10.0  # [rad/s] its velocity limit


@pytest.fixture
def at_repository(monkeypatch):
    """The iiwa scenarios name their controller files relative to the repository."""
    monkeypatch.chdir(REPO)


@pytest.mark.parametrize("profile", ["trapezoidal", "cubic"])
@pytest.mark.parametrize("path", ["linear", "circular"])
@pytest.mark.parametrize("scenario_name", ["task_js", "task_os"])
def test_iiwa_follows_the_task_through_the_world(
    at_repository, tmp_path, scenario_name, path, profile
):
    scenario = load_scenario(scenario_name, QUIET + f"\ntask: {{path: {path}, profile: {profile}}}")
    result = run(
        scenario,
        scenario_name=scenario_name,
        output_dir=tmp_path,
        quiet=True,
        replay=False,
        plots=False,
    )
    errors = result.task_space
    print(
        f"iiwa {scenario_name} {path} {profile}: max {errors['max_position_error'] * 1e3:.3f} "
        f"mm (RMS {errors['rms_position_error'] * 1e3:.3f}), "
        f"{errors['max_orientation_error']:.4f} rad, {result.realtime_factor:.2f}x real time"
    )
    assert errors["max_position_error"] <= 1e-3
    assert errors["max_orientation_error"] <= 0.01
    assert 0 < errors["rms_position_error"] <= errors["max_position_error"]
    states = read_joint_states(tmp_path / "joint_states.csv")
    limits = np.array([2.967, 2.094, 2.967, 2.094, 2.967, 2.094, 3.054])  # [rad] URDF
    assert np.all(np.abs(states.position) <= limits)
    assert np.all(np.abs(states.velocity) <= IIWA_VELOCITY)
    assert np.all(np.isfinite(states.effort)) and np.abs(states.effort).max() <= IIWA_EFFORT
    assert np.abs(states.effort).max() > 1.0  # torques were commanded
    # It moved along the path: the end effector's trace spans the path's size.
    table = np.loadtxt(tmp_path / "task_space.csv", delimiter=",", skiprows=1)
    span = np.ptp(table[:, 4:7], axis=0).max()
    assert span >= 0.19  # [m] circle of radius 0.1; line of 0.25 m along y


def test_task_reference_recorded_and_status(at_repository, tmp_path):
    scenario = load_scenario("task_os", QUIET + "\nsimulation: {duration: 0.05}")
    world = MakeWorld(scenario, quiet=True, record=tmp_path / "run.mcap")
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.05)
    status = world.status(simulator.get_context(), "operational_space_controller")
    assert status.state == "executing" and status.accepted == 1 and status.rejected == 0
    world.close(simulator.get_context())
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(tmp_path / "run.mcap", "rb") as file:
        reader = make_reader(file, decoder_factories=[DecoderFactory()])
        messages = [
            (schema.name, channel.topic, decoded)
            for schema, channel, _, decoded in reader.iter_decoded_messages()
            if "cartesian" in channel.topic
        ]
    ((schema, topic, decoded),) = messages
    assert schema == "cartesian_control_msgs/msg/CartesianTrajectory"
    assert topic == "/operational_space_controller/cartesian_trajectory"
    assert decoded.controlled_frame == "iiwa_link_ee" and decoded.header.frame_id == "world"
    assert len(decoded.points) == 2501  # 2.5 s at 1 kHz, both ends
    first = decoded.points[0].pose.position
    np.testing.assert_allclose([first.x, first.y, first.z], [0.55, 0.0, 0.5], atol=2e-3)


def _bare_world(controller: str):
    """The iiwa with one torque controller and no task: its command input is exported."""
    scenario = load_scenario(
        "task_os",
        QUIET + f"\ncontrollers: {{activate: [joint_state_broadcaster, {controller}]}}\ntask: null",
    )
    scenario.task = None
    return MakeWorld(scenario, quiet=True)


def _cartesian(points) -> CartesianTrajectory:
    return CartesianTrajectory(
        frame_id="world",
        controlled_frame="iiwa_link_ee",
        points=tuple(
            CartesianTrajectoryPoint(time_from_start=t, position=tuple(p), orientation=(0, 0, 1, 0))
            for t, p in points
        ),
    )


def test_cartesian_trajectory_out_of_reach_is_rejected(at_repository):
    world = _bare_world("operational_space_controller")
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    q0 = world.joint_positions(context).copy()
    world.publish(context, "operational_space_controller", _cartesian([(1.0, [1.8, 0.0, 0.5])]))
    simulator.AdvanceTo(0.3)
    status = world.status(context, "operational_space_controller")
    assert status.rejected == 1 and status.accepted == 0
    assert "beyond its reach" in status.last_error and "[1.8, 0.0, 0.5]" in status.last_error
    # Before any accepted reference the controller holds where it started.
    assert np.abs(world.joint_positions(context) - q0).max() < 1e-3
    for bad, reason in (
        (_cartesian([(1.0, [np.nan, 0.0, 0.5])]), "must be 3 finite numbers"),
        (_cartesian([(1.0, [0.5, 0.0, 0.5]), (0.5, [0.5, 0.0, 0.4])]), "is not after point 0"),
        (
            CartesianTrajectory(
                controlled_frame="no_such_link", points=_cartesian([(1, [0.5, 0, 0.5])]).points
            ),
            "no_such_link",
        ),
    ):
        world.publish(context, "operational_space_controller", bad)
        simulator.AdvanceTo(context.get_time() + 0.01)
        assert reason in world.status(context, "operational_space_controller").last_error


def test_cartesian_trajectory_through_a_singularity_gives_finite_clamped_torques(at_repository):
    """Straight up to the edge of the workspace (the arm stretched out, singular): the
    damped pseudo-inverse keeps the torques finite and the clamp within the limits."""
    world = _bare_world("operational_space_controller")
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    world.publish(
        context,
        "operational_space_controller",
        _cartesian([(0.5, [0.1, 0.0, 1.25]), (1.0, [0.0, 0.0, 1.30])]),
    )
    simulator.AdvanceTo(1.5)
    status = world.status(context, "operational_space_controller")
    assert status.accepted == 1, status.last_error
    effort = world.diagram.GetSubsystemByName("controller_manager").GetOutputPort("effort_command")
    manager_context = effort.get_system().GetMyContextFromRoot(context)
    tau = effort.Eval(manager_context)
    assert np.all(np.isfinite(tau)) and np.abs(tau).max() <= IIWA_EFFORT
    assert np.all(np.isfinite(world.joint_positions(context)))


def test_too_fast_cartesian_trajectory_is_clamped_with_one_warning(at_repository, caplog):
    """Half a metre in 50 ms from the upright (singular) start: the torques hit the
    effort limits; they stay finite and within them, and the log says so once."""
    world = _bare_world("operational_space_controller")
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    world.publish(context, "operational_space_controller", _cartesian([(0.05, [0.5, 0.0, 0.8])]))
    simulator.AdvanceTo(0.5)
    status = world.status(context, "operational_space_controller")
    assert status.accepted == 1 and status.detail["saturated_ticks"] > 0
    effort = read_effort(world, context)
    assert np.all(np.isfinite(effort)) and np.abs(effort).max() <= IIWA_EFFORT
    assert caplog.text.count("torques clamped to the effort limits") == 1
    assert "near a singularity or the workspace boundary" in caplog.text


def read_effort(world, context) -> np.ndarray:
    """[N m] the controller manager's effort command now."""
    manager = world.robot().stack.manager
    return manager.GetOutputPort("effort_command").Eval(manager.GetMyContextFromRoot(context))


def test_joint_trajectory_outside_the_limits_is_rejected(at_repository):
    world = _bare_world("joint_space_controller")
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    names = tuple(f"iiwa_joint_{i}" for i in range(1, 8))
    target = [0.0, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0]  # joint 2 beyond 2.094 rad
    world.publish(
        context,
        "joint_space_controller",
        JointTrajectory(
            joint_names=names,
            points=(JointTrajectoryPoint(positions=tuple(target), time_from_start=1.0),),
        ),
    )
    simulator.AdvanceTo(0.1)
    status = world.status(context, "joint_space_controller")
    assert status.rejected == 1
    assert "position 2.5 of joint 'iiwa_joint_2' is outside its limits" in status.last_error
    # A good one in a shuffled joint order is followed.
    goal = np.array([0.2, 0.5, -0.1, -1.2, 0.1, 1.0, 0.3])
    order = [6, 0, 5, 1, 4, 2, 3]
    world.publish(
        context,
        "joint_space_controller",
        JointTrajectory(
            joint_names=tuple(names[i] for i in order),
            points=(JointTrajectoryPoint(positions=tuple(goal[order]), time_from_start=1.0),),
        ),
    )
    simulator.AdvanceTo(2.0)
    assert world.status(context, "joint_space_controller").state == "succeeded"
    np.testing.assert_allclose(world.joint_positions(context), goal, atol=1e-3)


def test_effort_controller_holds_the_iiwa_with_gravity_torques(at_repository):
    """effort_controllers/JointGroupEffortController: the commanded torques reach the
    joints; the gravity torques at the start hold the arm there."""
    world = _bare_world("effort_controller")
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    plant = world.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    q0 = np.array([0.0, 0.4117, 0.0, -1.4609, 0.0, 1.269, 0.0])  # [rad] task_os's start
    plant.SetPositions(plant_context, world.robot().robot.model_instance, q0)
    gravity = -plant.CalcGravityGeneralizedForces(plant_context)
    world.publish(context, "effort_controller", Float64MultiArray(tuple(gravity.tolist())))
    simulator.AdvanceTo(0.5)
    held = np.abs(world.joint_positions(context) - q0).max()
    world.publish(context, "effort_controller", Float64MultiArray((0.0,) * 7))
    simulator.AdvanceTo(1.0)
    fallen = np.abs(world.joint_positions(context) - q0).max()
    print(f"effort controller: drift {held:.2e} rad with gravity torques, {fallen:.3f} without")
    assert held < 1e-3 and fallen > 0.1


@pytest.mark.parametrize("path", ["linear", "circular"])
def test_armando_follows_position_paths(path):
    scenario = load_scenario("task_armando", QUIET + f"\ntask: {{path: {path}}}")
    result = run(scenario, scenario_name="task_armando", quiet=True, replay=False, plots=False)
    errors = result.task_space
    print(f"Armando {path}: max {errors['max_position_error'] * 1e3:.3f} mm")
    assert errors["max_position_error"] <= 2e-3
    assert result.driven == "trajectory_controller"


def test_task_outputs_summary_csv_and_plots(tmp_path):
    scenario = load_scenario("task_armando", QUIET + "\ntask: {path: circular}")
    run(scenario, scenario_name="task_armando", output_dir=tmp_path, quiet=True, replay=False)
    summary = json.loads((tmp_path / "summary.json").read_text())
    errors = summary["task_space"]
    assert set(errors) == {"max_position_error", "rms_position_error", "max_orientation_error"}
    assert 0 < errors["rms_position_error"] < errors["max_position_error"] <= 2e-3
    assert summary["controller"] == "task"
    header = (tmp_path / "task_space.csv").read_text().splitlines()[0].split(",")
    assert header[0] == "time" and "position_error" in header and "orientation_error" in header
    table = np.loadtxt(tmp_path / "task_space.csv", delimiter=",", skiprows=1)
    assert len(table) == 301  # 3 s at Armando's 100 Hz, both ends
    assert table[:, header.index("position_error")].max() == pytest.approx(
        errors["max_position_error"], rel=1e-6
    )
    for plot in ("task_error.png", "joint_torques.png", "task_path.png"):
        with Image.open(tmp_path / plot) as image:
            assert image.size == (1000, 700), plot


@pytest.mark.parametrize(
    "override, message",
    [
        (
            "controllers: {activate: [joint_state_broadcaster, position_controller]}",
            "task needs an active controller that takes a CartesianTrajectory or a "
            "JointTrajectory; active: position_controller",
        ),
        ("task: {start_positions: [0.1, 0.2]}", "task.start_positions=[0.1, 0.2] must have 4"),
        ("task: {start_positions: [0, 0, 9, 0]}", "9.0 of joint 'j2' is outside its limits"),
        ("task: {profile: bang}", "profile='bang' must be one of"),
    ],
)
def test_bad_task_sections_are_one_line_errors(override, message):
    from armando_drake.simulation.scenario import ScenarioError

    scenario = load_scenario("task_armando", QUIET + "\n" + override)
    with pytest.raises(ScenarioError, match="task") as error:
        MakeWorld(scenario, quiet=True, source="task_armando.yaml")
    assert message in str(error.value)
    # The origin of the task: the override that set it, else the file.
    origin = f"override {QUIET + chr(10) + override!r}" if override.startswith("task") else None
    assert str(error.value).startswith(f"{origin or 'task_armando.yaml'}: ")
