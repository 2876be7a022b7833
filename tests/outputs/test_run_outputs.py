"""What a world run leaves behind: plots, an offline replay, a ROS 2 bag (MCAP).

One short CLI run (4 s, a target every second, as fast as possible) is shared
by the tests of its outputs; the trajectory and camera recordings run their
own worlds for a second or less.
"""

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.outputs.plots import DPI, FIGURE_SIZE, PLOTS, commanded_at
from armando_drake.outputs.recording import message_definition
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

DURATION = 4.0  # [s]
RATE = 100.0  # [Hz] the controller manager's update_rate
TARGETS = [
    [0.0, 0.0, 0.0, 0.0],
    [1.2, -1.0, 1.2, 0.6],
    [-1.2, 1.0, -1.2, -0.6],
    [0.6, 0.0, -0.6, 1.0],
]
JOINTS = ["j0", "j1", "j2", "j3"]


def world_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--realtime-rate", "0"]
        + list(args),
        capture_output=True,
        text=True,
        check=False,
    )


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """A position run with --output and --record."""
    folder = tmp_path_factory.mktemp("run")
    result = world_cli(
        "--quiet",
        "--duration",
        str(DURATION),
        "--set",
        "sequencer: {period: 1.0}",
        "--output",
        str(folder / "out"),
        "--record",
        str(folder / "run.mcap"),
    )
    assert result.returncode == 0, result.stderr
    assert f"replay: {folder / 'out'}/replay.html" in result.stdout
    assert f"recording: {folder / 'run.mcap'}" in result.stdout
    return folder


def read_bag(path: Path) -> dict[str, list[tuple[int, object]]]:
    """(log time [ns], message) per topic, read with rosbags (not the writer's library)."""
    from rosbags.highlevel import AnyReader

    topics: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for connection, log_time, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append((log_time, message))
        types = {connection.topic: connection.msgtype for connection in reader.connections}
    topics["__types__"] = types
    return topics


def stamp(message) -> float:
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path, newline="") as file:
        rows = list(csv.reader(file))
    return rows[0], np.array([[float(v) for v in row] for row in rows[1:]])


# --- plots ---------------------------------------------------------------------------------


def test_plots_are_written_at_their_size(run_dir):
    import matplotlib.image

    width, height = (round(FIGURE_SIZE[0] * DPI), round(FIGURE_SIZE[1] * DPI))
    for name in PLOTS:
        path = run_dir / "out" / name
        assert path.stat().st_size > 10_000, name
        image = matplotlib.image.imread(path)
        assert image.shape[:2] == (height, width), (name, image.shape)
        # Something is drawn: far from a blank page.
        assert (image[:, :, :3] < 0.5).mean() > 0.005, name


def test_tracking_error_reference_is_the_command_in_force():
    times = np.array([0.0, 0.5, 1.0, 1.5, 2.5])
    command_times = np.array([1.0, 2.0])
    commands = np.array([[1.0], [2.0]])
    held = commanded_at(times, command_times, commands)
    assert np.isnan(held[:2]).all()
    assert held[2:, 0].tolist() == [1.0, 1.0, 2.0]
    ahead = commanded_at(times, command_times, commands, ahead=True)
    assert ahead[:, 0].tolist() == [1.0, 1.0, 2.0, 2.0, 2.0]


# --- replay --------------------------------------------------------------------------------


@pytest.mark.browser
def test_replay_plays_offline_with_the_robot_links(run_dir, chromium):
    from browser import browser_page, wait_for_scene_paths

    replay = run_dir / "out" / "replay.html"
    assert replay.stat().st_size > 100_000
    errors = []
    with browser_page(chromium) as page:
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(replay.as_uri())
        paths = wait_for_scene_paths(
            page, lambda p: any(x.startswith("/drake/illustration/armando/") for x in p)
        )
        # The animation covers the run and moves the links.
        duration, moving = page.evaluate(
            """() => {
              const actions = viewer.animator.actions;
              let moving = 0;
              for (const action of actions) {
                for (const track of action.getClip().tracks) {
                  const v = track.values, n = track.getValueSize();
                  for (let i = n; i < v.length; i++) {
                    if (Math.abs(v[i] - v[i % n]) > 0.1) { moving++; break; }
                  }
                }
              }
              return [viewer.animator.duration, moving];
            }"""
        )
    assert errors == []
    world = MakeWorld(load_scenario("position", "logging: {console_rate: 0}"), quiet=True)
    plant = world.plant
    drawn = {
        plant.get_body(index).name()
        for index in plant.GetBodyIndices(world.robot().robot.model_instance)
        if plant.GetVisualGeometriesForBody(plant.get_body(index))
    }
    links = {p.split("/")[4] for p in paths if p.startswith("/drake/illustration/armando/")}
    assert len(drawn) >= 10 and links == drawn, links ^ drawn
    assert duration == pytest.approx(DURATION, abs=0.1)
    assert moving >= 4  # at least one track per moving joint's link changes by > 0.1


# --- recording -----------------------------------------------------------------------------


def test_recording_joint_states_equal_the_csv_sample_for_sample(run_dir):
    bag = read_bag(run_dir / "run.mcap")
    assert bag["__types__"] == {
        "/joint_states": "sensor_msgs/msg/JointState",
        "/position_controller/commands": "std_msgs/msg/Float64MultiArray",
    }
    header, rows = read_csv(run_dir / "out" / "joint_states.csv")
    states = bag["/joint_states"]
    assert len(states) == DURATION * RATE + 1, len(states)  # both ends
    assert len(states) == len(rows)
    for (log_time, message), row in zip(states, rows, strict=True):
        assert list(message.name) == JOINTS
        assert log_time == round(stamp(message) * 1e9)
        assert stamp(message) == pytest.approx(row[0], abs=1e-6)
        recorded = np.column_stack([message.position, message.velocity, message.effort])
        np.testing.assert_allclose(recorded.ravel(), row[1:], rtol=1e-9, atol=1e-12)


def test_recording_commands_equal_commands_csv(run_dir):
    bag = read_bag(run_dir / "run.mcap")
    _, rows = read_csv(run_dir / "out" / "commands.csv")
    commands = bag["/position_controller/commands"]
    assert len(commands) == len(TARGETS) == len(rows)
    for (log_time, message), row, target in zip(commands, rows, TARGETS, strict=True):
        assert log_time == round(row[0] * 1e9)
        assert message.data.tolist() == target == row[1:].tolist()


def test_message_definitions_are_those_of_ros2(tmp_path):
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    for type_name in (
        "sensor_msgs/msg/JointState",
        "std_msgs/msg/Float64MultiArray",
        "trajectory_msgs/msg/JointTrajectory",
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CameraInfo",
    ):
        expected, _ = store.generate_msgdef(type_name, ros_version=2)
        assert message_definition(type_name) == expected, type_name


def test_trajectory_recording(tmp_path):
    scenario = load_scenario(
        "trajectory", "logging: {console_rate: 0}\nsequencer: {period: 0.5, cyclic: true}"
    )
    world = MakeWorld(scenario, quiet=True, record=tmp_path / "trajectory.mcap")
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(3.0)
    world.close()
    bag = read_bag(tmp_path / "trajectory.mcap")
    trajectories = bag["/trajectory_controller/joint_trajectory"]
    # Cyclic: the 5-point trajectory again every 2.5 s, seen by the recorder one tick later.
    assert [t for t, _ in trajectories] == [0, 2_500_000_000]
    message = trajectories[0][1]
    assert list(message.joint_names) == JOINTS
    assert [p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in message.points] == [
        pytest.approx(0.5 * (k + 1)) for k in range(5)
    ]
    assert message.points[1].positions.tolist() == TARGETS[1]
    assert len(bag["/joint_states"]) == 301  # 0, 0.01, ..., 3.0 s


def test_camera_recording_holds_the_frames_the_camera_took(tmp_path):
    from armando_drake.sensors.camera import AddedCamera

    scenario = load_scenario(
        "camera", "logging: {console_rate: 0}\ncamera: {live_view: false, depth: false}"
    )
    world = MakeWorld(scenario, quiet=True, record=tmp_path / "camera.mcap")
    camera = world.robot().cameras["camera"]
    assert isinstance(camera, AddedCamera)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.5)
    last_frame = camera.color_image.Eval(
        world.diagram.GetSubsystemContext(camera.color_image.get_system(), simulator.get_context())
    ).data[:, :, :3]
    world.close()
    bag = read_bag(tmp_path / "camera.mcap")
    images, infos = bag["/camera/image_raw"], bag["/camera/camera_info"]
    rate = camera.info.frame_rate
    assert len(images) == len(infos) == round(0.5 * rate)  # 15 frames at 30 Hz
    assert [t for t, _ in images] == [round(k / rate * 1e9) for k in range(len(images))]
    image = images[-1][1]
    assert (image.encoding, image.width, image.height, image.step) == ("rgb8", 640, 480, 1920)
    pixels = image.data.reshape(480, 640, 3)
    np.testing.assert_array_equal(pixels, last_frame)
    info = infos[-1][1]
    focal = 640 / (2 * math.tan(camera.info.horizontal_fov / 2))
    np.testing.assert_allclose(info.k, [focal, 0, 319.5, 0, focal, 239.5, 0, 0, 1], atol=0.51)
    assert info.header.frame_id == image.header.frame_id == camera.info.link
    assert stamp(info) == stamp(image) == pytest.approx((len(images) - 1) / rate, abs=1e-9)


def test_record_makes_its_missing_folder_as_output_does(tmp_path, monkeypatch):
    # The README's example, as written, from a folder where out/ does not exist yet.
    monkeypatch.chdir(tmp_path)
    result = world_cli("--duration", "0.2", "--output", "out/run1", "--record", "out/run1.mcap")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "out" / "run1.mcap").stat().st_size > 0
    assert (tmp_path / "out" / "run1" / "summary.json").is_file()
    nested = tmp_path / "a" / "b" / "run.mcap"
    assert world_cli("--duration", "0.1", "--record", str(nested)).returncode == 0
    assert nested.stat().st_size > 0


def test_record_under_a_file_fails_before_the_run(tmp_path):
    (tmp_path / "taken").write_text("")
    path = tmp_path / "taken" / "run.mcap"
    result = world_cli("--record", str(path))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"error: --record {path}: cannot make folder {path.parent}: ")
    assert " simulated in " not in result.stdout


def test_record_without_permission_fails_before_the_run(tmp_path):
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o500)
    path = folder / "run.mcap"
    if os.access(folder, os.W_OK):  # root ignores the mode: a place even root cannot write
        path = Path("/sys/armando_drake_run.mcap")
    try:
        result = world_cli("--record", str(path))
    finally:
        folder.chmod(0o700)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: --record {path}: cannot write there")
    assert " simulated in " not in result.stdout
    assert not path.exists()
