"""The running world on DDS: a separate process drives it, /tf and /clock match the plant."""

import re
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from ros2_support import EXAMPLE, new_domain_id, python, subprocess_env

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

pytest.importorskip("cyclonedds")

SEED_TARGETS = [
    [0.0, 0.0, 0.0, 0.0],
    [1.2, -1.0, 1.2, 0.6],
    [-1.2, 1.0, -1.2, -0.6],
    [0.6, 0.0, -0.6, 1.0],
    [0.0, 0.0, 0.0, 0.0],
]


def _world(scenario: str, domain_id: int, extra: str = ""):
    overrides = f"ros2: {{enabled: true, domain_id: {domain_id}}}\nlogging: {{console_rate: 0}}\n"
    return MakeWorld(load_scenario(scenario, overrides + extra), quiet=True)


def test_example_node_in_another_process_drives_the_arm():
    """The course's node, a plain DDS participant in its own process: it gets /joint_states
    at the broadcaster's rate, its targets are reached, its bad command is rejected."""
    domain_id = new_domain_id()
    world = _world("ros2", domain_id)
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(1.0)  # the rate is counted in wall time
    simulator.Initialize()
    node = subprocess.Popen(
        [python(), str(EXAMPLE), "--domain-id", str(domain_id), "--bad-command"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=subprocess_env(),
    )
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(node.stdout), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 90
        while node.poll() is None and time.monotonic() < deadline:
            simulator.AdvanceTo(simulator.get_context().get_time() + 0.1)
        # A few more ticks: the last command is handled, the arm is where it holds.
        simulator.AdvanceTo(simulator.get_context().get_time() + 0.5)
    finally:
        node.kill()
        reader.join(5)
    context = simulator.get_context()
    status = world.status(context, "position_controller")
    q = world.joint_positions(context)
    world.close(context)
    output = "".join(lines)
    assert node.returncode == 0, output

    # /joint_states at the broadcaster's rate: the count over 5 s of wall time within 5 %
    # of the rate times the simulation time their stamps span (a loaded machine runs the
    # world slower than real time; the rate is per simulated second).
    pattern = r"joint_states: (\d+) messages in ([\d.]+) s .*, ([\d.]+) s of simulation time"
    count, seconds, simulated = re.search(pattern, output).groups()
    expected = world.robot().stack.update_rate * float(simulated)
    assert float(simulated) >= 1.0, output  # the window saw the world run
    assert abs(int(count) - expected) <= max(2, 0.05 * expected), output
    # Every seed target reached within 0.01 rad (as the node measured it on /joint_states).
    reached = r"^target \d+ \[.*\] reached: max error (\S+) rad"
    errors = [float(e) for e in re.findall(reached, output, re.M)]
    assert len(errors) == len(SEED_TARGETS), output
    assert max(errors) <= 0.01, output
    # The bad command (two values for four joints) rejected with upstream's reason; the arm
    # holds the last target, in the node's view and in the plant.
    assert "bad command [0.1, 0.2] sent" in output
    assert status.rejected == 1 and status.accepted == len(SEED_TARGETS), status
    assert status.last_error == "command size (2) does not match number of interfaces (4)"
    holding = re.search(r"bad command: holding target 4 .* max error (\S+) rad", output)
    assert holding and float(holding.group(1)) <= 0.01, output
    assert np.abs(q - SEED_TARGETS[-1]).max() <= 0.01
    print(f"joint_states {count} in {seconds} s; target errors {errors}", file=sys.stderr)


def _chain(transforms: dict, child: str):
    """The pose of frame ``child`` in the root of the /tf tree, composed link by link."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform

    X = RigidTransform()
    depth = 0
    while child in transforms:
        parent, t = transforms[child]
        r, p = t["rotation"], t["translation"]
        X_PC = RigidTransform(
            Quaternion(w=r["w"], x=r["x"], y=r["y"], z=r["z"]), [p["x"], p["y"], p["z"]]
        )
        X = X_PC @ X
        child, depth = parent, depth + 1
    return child, X, depth


def test_tf_clock_and_joint_states_equal_the_plant():
    """Mid-motion, /tf composed from the world to the last link equals the plant's forward
    kinematics, /clock and the stamps equal the simulation time, /joint_states the plant's
    joints, and a late subscriber still gets /robot_description and /tf_static."""
    domain_id = new_domain_id()
    from armando_drake.ros2.dds import DdsNode

    world = _world("position", domain_id)  # the sequencer moves the arm
    received: dict[str, list] = {"/tf": [], "/clock": [], "joint_states": []}
    listener = DdsNode(domain_id=domain_id)
    for topic, type_name in (
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/clock", "rosgraph_msgs/msg/Clock"),
        ("joint_states", "sensor_msgs/msg/JointState"),
    ):
        listener.subscribe(topic, type_name, received[topic].append)
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(0)
    simulator.Initialize()
    time.sleep(1.0)  # discovery between the two participants of this process
    # [s] the arm on its way from target 1 (sent at 3 s) to target 2 (at 6 s): a tick of the
    # bridge, computed as Drake computes periodic event times.
    T = 615 * (1.0 / world.robot().stack.update_rate)
    simulator.AdvanceTo(T)
    context = simulator.get_context()
    stamp_ns = round(T * 1e9)

    def nanoseconds(time) -> int:
        return time["sec"] * 1_000_000_000 + time["nanosec"]

    def stamp(header) -> int:
        return nanoseconds(header["stamp"])

    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not (
        any(stamp(m["transforms"][0]["header"]) == stamp_ns for m in received["/tf"])
        and any(stamp(m["header"]) == stamp_ns for m in received["joint_states"])
        and any(nanoseconds(m["clock"]) == stamp_ns for m in received["/clock"])
    ):
        time.sleep(0.02)
    latched = {"/tf_static": [], "robot_description": []}
    for topic, type_name in (
        ("/tf_static", "tf2_msgs/msg/TFMessage"),
        ("robot_description", "std_msgs/msg/String"),
    ):
        listener.subscribe(topic, type_name, latched[topic].append, "latched")
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not all(latched.values()):
        time.sleep(0.02)

    # /clock: the simulation time, to the nanosecond.
    clocks = [nanoseconds(m["clock"]) for m in received["/clock"]]
    assert stamp_ns in clocks and max(clocks) == stamp_ns
    # /joint_states at T: the plant's positions and velocities.
    (sample,) = [m for m in received["joint_states"] if stamp(m["header"]) == stamp_ns]
    q = world.joint_positions(context)
    assert sample["name"] == world.robot().stack.hardware.joint_names
    assert np.abs(np.array(sample["position"]) - q).max() <= 1e-12
    for target in SEED_TARGETS[1:3]:  # mid-motion, resting at neither
        assert np.abs(q - target).max() > 0.1, q

    # /tf at T plus /tf_static: every link's pose in the world equals forward kinematics.
    (tf,) = [m for m in received["/tf"] if stamp(m["transforms"][0]["header"]) == stamp_ns]
    transforms = {
        t["child_frame_id"]: (t["header"]["frame_id"], t["transform"])
        for t in latched["/tf_static"][-1]["transforms"] + tf["transforms"]
    }
    plant = world.plant
    plant_context = plant.GetMyContextFromRoot(context)
    deepest = max(transforms, key=lambda link: _chain(transforms, link)[2])
    errors = {}
    for link in transforms:
        root, X_WL, _ = _chain(transforms, link)
        assert root == "world"
        X_WL_plant = plant.EvalBodyPoseInWorld(plant_context, plant.GetBodyByName(link))
        errors[link] = np.abs(X_WL.GetAsMatrix4() - X_WL_plant.GetAsMatrix4()).max()
    assert errors[deepest] <= 1e-9, errors
    assert max(errors.values()) <= 1e-9, errors
    assert len(tf["transforms"]) == len(world.robot().stack.hardware.joints)
    # Latched topics reach a subscriber that joins late.
    assert latched["robot_description"][-1]["data"] == world.robot().robot.urdf
    world.close(context)
    listener.close()
    print(f"tf error of {deepest}: {errors[deepest]:.2e}", file=sys.stderr)


def test_trajectory_over_dds_is_validated_as_in_process():
    """A JointTrajectory from DDS: a bad one rejected with upstream's reason, a good one run."""
    domain_id = new_domain_id()
    from armando_drake.messages.definitions import joint_trajectory_message
    from armando_drake.messages.types import JointTrajectory, JointTrajectoryPoint
    from armando_drake.ros2.dds import DdsNode

    world = _world(
        "ros2",
        domain_id,
        "controllers: {activate: [joint_state_broadcaster, trajectory_controller]}",
    )
    assert world.diagram.GetSubsystemByName("ros2_bridge").commands[0].topic == (
        "trajectory_controller/joint_trajectory"
    )
    joints = world.robot().stack.controller_joints["trajectory_controller"]
    publisher = DdsNode(domain_id=domain_id)
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(0)
    simulator.Initialize()
    topic = "trajectory_controller/joint_trajectory"
    type_name = "trajectory_msgs/msg/JointTrajectory"
    publisher.advertise(topic, type_name)
    writer = publisher.writer(topic)
    deadline = time.monotonic() + 10
    while writer.get_publication_matched_status().current_count == 0:
        assert time.monotonic() < deadline, "the world's subscription was not found"
        time.sleep(0.02)

    def send_and_run(message, seconds):
        publisher.publish(topic, type_name, joint_trajectory_message(message))
        bridge = world.diagram.GetSubsystemByName("ros2_bridge")
        count = bridge.received[topic]
        deadline = time.monotonic() + 10
        while bridge.received[topic] == count and time.monotonic() < deadline:
            time.sleep(0.01)
        simulator.AdvanceTo(simulator.get_context().get_time() + seconds)

    target = (0.6, -0.4, 0.8, 0.2)
    bad = JointTrajectory(
        joint_names=(*joints[:-1], "no_such_joint"),
        points=(JointTrajectoryPoint(positions=target, time_from_start=1.0),),
    )
    send_and_run(bad, 0.1)
    status = world.status(simulator.get_context(), "trajectory_controller")
    assert status.rejected == 1 and "no_such_joint" in status.last_error, status
    good = JointTrajectory(
        joint_names=tuple(joints),
        points=(JointTrajectoryPoint(positions=target, time_from_start=1.0),),
    )
    send_and_run(good, 2.0)
    context = simulator.get_context()
    status = world.status(context, "trajectory_controller")
    assert status.accepted == 1 and status.state == "succeeded", status
    assert np.abs(world.joint_positions(context) - target).max() <= 0.01
    world.close(context)
    publisher.close()


def test_the_final_line_names_the_dds_commands_that_drove_the_arm():
    """With no sequencer, the commands DDS brought are what drove the arm: the summary's
    controller is "dds" and the final line names their topic; none came, "none"."""
    from armando_drake.messages.types import Float64MultiArray
    from armando_drake.simulation.run import _result

    world = _world("ros2", new_domain_id())
    bridge = world.ros2_bridge
    assert bridge is world.diagram.GetSubsystemByName("ros2_bridge")
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(0)
    simulator.Initialize()
    scenario = load_scenario("ros2")
    before = _result(scenario, world, simulator, None, None, None)
    assert (before.controller, before.driven) == ("none", "")
    assert before.headline().startswith("the scenario with no controller driving the arm: ")
    topic = "position_controller/commands"
    k = [command.topic for command in bridge.commands].index(topic)
    bridge._Receive(k, Float64MultiArray(data=(0.3, -0.2, 0.4, 0.1)))  # as Cyclone's thread
    simulator.AdvanceTo(1.0)
    assert (
        np.abs(world.joint_positions(simulator.get_context()) - [0.3, -0.2, 0.4, 0.1]).max() < 0.05
    )
    after = _result(scenario, world, simulator, None, None, None)
    after.scenario = "ros2.yaml"
    assert (after.controller, after.driven) == ("dds", topic)
    assert after.summary()["controller"] == "dds"
    assert after.headline().startswith(f"ros2.yaml with DDS commands driving the arm ({topic}): ")
    world.close(simulator.get_context())


def test_without_ros2_the_world_imports_no_dds_and_no_foxglove():
    code = (
        "import sys\n"
        "from pydrake.systems.analysis import Simulator\n"
        "from armando_drake.simulation.builder import MakeWorld\n"
        "from armando_drake.simulation.scenario import load_scenario\n"
        "world = MakeWorld(load_scenario('position', 'logging: {console_rate: 0}'), quiet=True)\n"
        "Simulator(world.diagram).AdvanceTo(0.1)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('cyclonedds', 'foxglove')))\n"
    )
    result = subprocess.run(
        [python(), "-c", code], capture_output=True, text=True, env=subprocess_env(), timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


def test_camera_topics_carry_the_rendered_frames():
    """With the camera on: /camera/image_raw (best effort, rgb8) holds the frame Drake
    rendered, /camera/camera_info its intrinsics, both stamped at the frame's time."""
    from armando_drake.ros2.dds import DdsNode

    domain_id = new_domain_id()
    world = _world("camera", domain_id, "camera: {live_view: false, depth: false}")
    (name,) = world.robot().cameras
    received = {"camera/image_raw": [], "camera/camera_info": []}
    listener = DdsNode(domain_id=domain_id)
    listener.subscribe(
        "camera/image_raw",
        "sensor_msgs/msg/Image",
        received["camera/image_raw"].append,
        "sensor_data",
    )
    listener.subscribe(
        "camera/camera_info", "sensor_msgs/msg/CameraInfo", received["camera/camera_info"].append
    )
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    time.sleep(1.0)  # discovery
    simulator.AdvanceTo(0.1)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not all(len(v) >= 3 for v in received.values()):
        time.sleep(0.02)
    context = simulator.get_context()
    rendered = world.diagram.GetOutputPort(f"{name}.color_image").Eval(context)
    intrinsics = (
        world.robot().cameras[name].sensor.default_color_render_camera().core().intrinsics()
    )
    world.close(context)
    listener.close()

    image, info = received["camera/image_raw"][-1], received["camera/camera_info"][-1]
    assert (image["width"], image["height"]) == (rendered.width(), rendered.height())
    assert image["encoding"] == "rgb8" and image["step"] == 3 * image["width"]
    assert image["header"]["stamp"] == info["header"]["stamp"]
    pixels = np.frombuffer(bytes(image["data"]), np.uint8).reshape(image["height"], -1, 3)
    # The last frame published is the one rendered at its stamp (the camera holds its
    # image between frames), so it equals what the port holds now.
    assert np.array_equal(pixels, rendered.data[:, :, :3])
    assert pixels.std() > 1.0  # a scene, not a blank frame
    assert info["k"][0] == pytest.approx(intrinsics.focal_x())
    assert info["k"][2] == pytest.approx(intrinsics.center_x())
