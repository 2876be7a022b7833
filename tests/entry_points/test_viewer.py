"""The world's viewer as a user meets it: framed on the robot, waiting for a browser,
still serving the run after it, printed once; the replay bounded; the progress bar."""

import base64
import io
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from armando_drake.description.framing import FIELD_OF_VIEW, camera_pose_for
from armando_drake.outputs.replay import ReplaySampler
from armando_drake.simulation.run import Progress

HALF = 0.5  # the robot's image spans at least this share of the view's height or width


def world(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.world", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        stdin=subprocess.DEVNULL,
    )


def test_url_is_printed_once_and_the_run_exits_when_done():
    start = time.monotonic()
    result = world("--exit-when-done", "--no-wait", "--duration", "1", "--realtime-rate", "0")
    assert result.returncode == 0, result.stderr
    output = result.stdout + result.stderr
    assert len(re.findall(r"http://\S+", output)) == 1, output
    assert "keeps serving" not in output
    assert time.monotonic() - start < 120


def test_without_a_terminal_the_run_neither_waits_nor_stays():
    # stdin is not a terminal: no wait for a browser, no serving after the run.
    result = world("--duration", "0.5", "--realtime-rate", "0")
    assert result.returncode == 0, result.stderr
    assert "waiting up to" not in result.stdout
    assert "keeps serving" not in result.stdout


def test_camera_view_only_with_meshcat_or_when_asked():
    fast = ["--scenario", "camera", "--duration", "0.1", "--realtime-rate", "0", "--quiet"]
    without = world("--no-meshcat", *fast)
    assert without.returncode == 0, without.stderr
    assert "Camera view:" not in without.stdout
    asked = world("--no-meshcat", "--camera-view", *fast)
    assert asked.returncode == 0, asked.stderr
    assert re.search(r"^Camera view: http://127\.0\.0\.1:\d+", asked.stdout, re.M)
    with_meshcat = world("--exit-when-done", *fast)
    assert with_meshcat.returncode == 0, with_meshcat.stderr
    assert "Camera view: http://" in with_meshcat.stdout


@pytest.mark.browser
def test_the_run_waits_for_a_browser_then_starts(chromium):
    from browser import browser_page, open_url

    process = subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", "--wait", "60", "--exit-when-done"]
        + ["--duration", "1", "--realtime-rate", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        lines = []
        for line in process.stdout:
            lines.append(line)
            if "waiting up to 60 s for a browser" in line:
                break
        url = re.search(r"Meshcat: (\S+)", "".join(lines)).group(1)
        time.sleep(3.0)
        assert process.poll() is None, "the run did not wait for a browser"
        with browser_page(chromium) as page:
            open_url(page, url)
            rest, _ = process.communicate(timeout=60)
        assert process.returncode == 0
        # The run started when the page opened, and ran to its end; the messages come in
        # that order: waiting, the browser connected, the state at t = 0.
        assert "no browser connected" not in rest
        assert not any(line.startswith("[t=") for line in lines), lines
        assert rest.index("browser connected") < rest.index("[t=0.000 s]"), rest
        assert "1.00 s simulated" in rest
        assert len(re.findall(r"http://\S+", "".join(lines) + rest)) == 1
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


@pytest.mark.browser
def test_after_the_run_the_page_answers_frames_the_robot_and_holds_the_replay(chromium):
    from browser import browser_page, open_url, robot_span, wait_for_scene_paths

    process = subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", "--keep-serving", "--no-wait"]
        + ["--duration", "2", "--realtime-rate", "0", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        lines = []
        for line in process.stdout:
            lines.append(line)
            if "keeps serving the run" in line:
                break
        output = "".join(lines)
        assert "2.00 s simulated" in output, output
        assert len(re.findall(r"http://\S+", output)) == 1, output
        url = re.search(r"Meshcat: (\S+)", output).group(1)
        time.sleep(1.0)
        assert process.poll() is None, "the process ended with the run"
        with browser_page(chromium) as page:
            open_url(page, url)
            paths = wait_for_scene_paths(
                page, lambda p: any(x.startswith("/drake/illustration/armando/") for x in p)
            )
            assert any(x.startswith("/drake/illustration/armando/") for x in paths)
            assert "/ground" in paths
            duration = page.evaluate("() => viewer.animator.duration")
            height, width = robot_span(page)
    finally:
        process.terminate()
        process.wait(timeout=10)
    assert duration == pytest.approx(2.0, abs=0.1)  # the whole run, to scrub
    assert max(height, width) >= HALF, (height, width)


@pytest.mark.browser
def test_replay_html_opens_framed_on_the_robot(tmp_path, chromium):
    from browser import browser_page, robot_span, wait_for_scene_paths

    result = world(
        "--no-meshcat", "--realtime-rate", "0", "--duration", "1", "--output", str(tmp_path)
    )
    assert result.returncode == 0, result.stderr
    with browser_page(chromium) as page:
        page.goto((tmp_path / "replay.html").as_uri())
        wait_for_scene_paths(
            page, lambda p: any(x.startswith("/drake/illustration/armando/") for x in p)
        )
        height, width = robot_span(page)
    assert max(height, width) >= HALF, (height, width)
    assert height < 1.0 and width < 1.0  # not cut by the view's edges


def test_camera_sees_every_point_within_the_field_of_view():
    rng = np.random.default_rng(3)
    points = rng.uniform([-0.1, -0.2, 0.0], [0.7, 0.2, 0.5], size=(200, 3))
    camera, target = camera_pose_for(points, [0.45, -0.45, 0.23])
    back = (camera - target) / np.linalg.norm(camera - target)
    assert np.allclose(np.cross(back, [0.45, -0.45, 0.23]), 0, atol=1e-9)  # the preset's side
    up = np.array([0, 0, 1.0]) - back[2] * back
    up /= np.linalg.norm(up)
    right = np.cross(up, back)
    depth = (camera - points) @ back
    vertical = ((points - camera) @ up) / depth
    horizontal = ((points - camera) @ right) / depth
    slope = 0.9 * np.tan(np.radians(FIELD_OF_VIEW) / 2)
    # Every point within 90 % of the half view up-down and left-right (a square view:
    # the height of any landscape view); from the nearest such camera, so the extreme
    # points of one direction reach both edges, and they lie as far from each edge.
    assert np.abs(vertical).max() <= slope + 1e-9
    assert np.abs(horizontal).max() <= slope + 1e-9
    binding = vertical if np.abs(vertical).max() > np.abs(horizontal).max() else horizontal
    assert binding.max() == pytest.approx(slope, rel=1e-6)
    assert binding.min() == pytest.approx(-slope, rel=1e-6)
    assert horizontal.max() == pytest.approx(-horizontal.min(), rel=1e-6)
    assert vertical.max() == pytest.approx(-vertical.min(), rel=1e-6)


@pytest.mark.parametrize("size", [0.3, 1.3, 5.0])  # Armando, the iiwa, a mobile robot's scene
def test_the_framing_scales_with_the_scene(size):
    """The same scene at any size is seen the same: camera and target scale with it."""
    rng = np.random.default_rng(5)
    points = rng.uniform([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0], size=(100, 3))
    camera, target = camera_pose_for(points, [0.45, -0.45, 0.23])
    scaled = camera_pose_for(size * points, [0.45, -0.45, 0.23])
    assert np.allclose(scaled[0], size * camera, rtol=1e-6)
    assert np.allclose(scaled[1], size * target, rtol=1e-6)


def test_replay_sampler_keeps_a_bounded_evenly_spaced_set_of_frames():
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource([1.0, 2.0]))
    sampler = builder.AddSystem(ReplaySampler(state_size=2, rate=32.0, max_frames=64))
    builder.Connect(source.get_output_port(), sampler.get_input_port())
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(100.0)  # 3201 samples at 32 per second without thinning
    times, states = sampler.frames()
    assert 32 <= len(times) <= 64
    assert times[0] == 0.0 and times[-1] >= 100.0 - sampler.interval
    assert np.allclose(np.diff(times), sampler.interval)
    assert sampler.interval == pytest.approx(2.0)  # 1/32 s doubled six times
    assert np.array_equal(states, np.tile([1.0, 2.0], (len(times), 1)))
    short = Simulator(simulator.get_system())
    short.AdvanceTo(1.0)  # a new simulation starts a new set, at the full rate
    times, _ = sampler.frames()
    assert len(times) == 33 and sampler.interval == pytest.approx(1 / 32)


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_on_a_terminal_silent_elsewhere():
    quiet = io.StringIO()
    progress = Progress(10.0, stream=quiet)
    progress.update(5.0)
    progress.finish()
    assert quiet.getvalue() == ""
    terminal = _Terminal()
    progress = Progress(10.0, stream=terminal)
    time.sleep(0.05)
    progress.update(5.0)
    progress._bar.refresh()
    text = terminal.getvalue()
    progress.finish()
    assert "5.00/10.00 s simulated" in text, text
    assert re.search(r"\d+\.\dx real time", text), text
    assert ", ," not in text, text
    assert re.search(r"<\d\d:\d\d", text), text  # time left


def test_console_lines_print_above_the_progress_bar(capsys):
    """The once-a-second console log does not land on the bar's line: the bar is
    cleared before the line is written and drawn again after it."""
    terminal = _Terminal()
    progress = Progress(10.0, stream=terminal)
    progress.update(2.0)
    progress._bar.refresh()
    drawn = len(terminal.getvalue())
    with progress.printing_above():
        print("[t=2.000 s] Joint positions:")
    progress.finish()
    assert capsys.readouterr().out == "[t=2.000 s] Joint positions:\n"
    after = terminal.getvalue()[drawn:]
    assert re.match(r"\r +\r", after), repr(after)  # cleared first
    assert "2.00/10.00 s simulated" in after, repr(after)  # then drawn again


def test_the_view_frames_the_arm_not_the_accessories_fixed_beside_it():
    """Armando's camera stands 0.75 m from the arm on a link welded to the base: it is
    not part of what the view frames; the base and every link the joints carry are."""
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.multibody.tree import BodyIndex
    from pydrake.systems.framework import DiagramBuilder

    from armando_drake.description.loader import load_robot
    from armando_drake.outputs.view import arm_frames, body_frames

    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, 0.001)
    robot = load_robot(plant)
    plant.Finalize()
    framed = arm_frames(plant, [robot.model_instance])
    everything = body_frames(plant, [robot.model_instance])
    names = {}
    for index in range(1, plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        frame = plant.GetBodyFrameIdIfExists(body.index())
        if frame is not None:
            names[frame] = body.name()
    left_out = sorted(names[f] for f in everything - framed)
    assert left_out == ["camera_link"], left_out
    assert {"base_link", "wrist"} <= {names[f] for f in framed}


def test_a_live_page_gets_only_the_poses_that_moved():
    """On a live Meshcat the poses stream only when they change: nothing while the arm
    holds still, the moving links while it moves, at the paths Drake's visualizers drew."""
    sys.path.insert(0, str(Path(__file__).parents[1] / "teleop"))
    from jog_worlds import jog_world

    run = jog_world()
    try:
        streamer = run.world.diagram.GetSubsystemByName("meshcat_moved_poses")
        paths = [path for paths in streamer._paths.values() for path in paths]
        assert "/drake/illustration/armando/crawer_base" in paths
        assert "/drake/proximity/armando/crawer_base" in paths
        assert any(path.startswith("/drake/inertia/") for path in paths)
        assert all(run.meshcat.HasPath(path) for path in paths), paths
        run.advance(1.0)
        assert streamer.messages == 0  # the arm holds its home posture
        run.meshcat.SetSliderValue("j1", 0.8)
        run.advance(2.0)
        moved = streamer.messages
        assert moved > 0
        run.advance(1.0)
        assert streamer.messages == moved  # at rest again
    finally:
        run.close()


@pytest.mark.parametrize(
    "viewer",
    [["--exit-when-done", "--no-wait"], ["--no-meshcat"]],
    ids=["live-meshcat", "replay-only"],
)
def test_the_mapping_command_runs_with_a_viewer_and_its_outputs(viewer, tmp_path):
    """The README's Mapping command with Meshcat live (or only the replay's own Meshcat) and
    --output: the exploration runs, its map and replay are written."""
    out = tmp_path / "explore"
    args = ["--scenario", "fra2mo_explore", *viewer, "--duration", "4", "--realtime-rate", "0"]
    result = world(*args, "--output", str(out), timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "Traceback" not in result.stderr
    assert "fra2mo_explore.yaml exploring" in result.stdout
    for name in ("map.yaml", "summary.json", "replay.html", "navigation.png"):
        assert (out / name).stat().st_size > 0, name
    replay = (out / "replay.html").read_text()
    blobs = re.findall(r"[A-Za-z0-9+/]{200,}={0,2}", replay)  # Meshcat's messages, in base64
    assert any(b"/drake/navigation/map" in base64.b64decode(blob) for blob in blobs)
