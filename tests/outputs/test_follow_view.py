"""The viewer keeps a mobile robot and its task in view (outputs/follow.py, outputs/view.py):
the first view frames the arena with the robot and its goals, then the camera follows the
base; from the camera Meshcat is given and the base's pose, the base never leaves the
view."""

import re
import subprocess
import sys

import numpy as np
import pytest
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator

from armando_drake.outputs.follow import BUTTON, TIME_CONSTANT, in_view
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

QUIET = "logging: {console_rate: 0}"


def test_in_view_is_the_cameras_frustum():
    camera, target = [0.0, -5.0, 0.0], [0.0, 0.0, 0.0]  # looking along +y, 30 deg tall
    assert in_view([0.0, 0.0, 0.0], camera, target)
    edge = 5.0 * np.tan(np.radians(15.0))
    assert in_view([0.0, 0.0, 0.99 * edge], camera, target)
    assert not in_view([0.0, 0.0, 1.01 * edge], camera, target)
    assert in_view([1.5 * edge, 0.0, 0.0], camera, target, aspect=16 / 9)
    assert not in_view([1.5 * edge, 0.0, 0.0], camera, target)
    assert not in_view([0.0, -6.0, 0.0], camera, target)  # behind the camera


def test_fra2mo_and_its_goals_stay_in_view_while_the_camera_follows():
    meshcat = Meshcat()
    scenario = load_scenario("fra2mo_goals", QUIET)
    world = MakeWorld(scenario, meshcat=meshcat, quiet=True)
    follow = world.diagram.GetSubsystemByName("follow_camera")
    assert BUTTON in meshcat.GetButtonNames()
    plant, base = world.plant, world.robot().mobile.base_link
    body = plant.GetBodyByName(base, world.robot().robot.model_instance)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    first = follow.camera.copy(), follow.target.copy()
    nav_goals = (
        world.robot()
        .navigation.navigator.nav_state(
            world.robot().navigation.navigator.GetMyContextFromRoot(simulator.get_context())
        )
        .goals
    )
    assert len(nav_goals) == 4
    for goal in nav_goals:  # the arena framed: every goal in the first view
        assert in_view([goal.x, goal.y, 0.0], *first), goal
    seen, lag = [], []
    for t in np.arange(0.5, 20.01, 0.5):
        simulator.AdvanceTo(t)
        context = plant.GetMyContextFromRoot(simulator.get_context())
        position = plant.EvalBodyPoseInWorld(context, body).translation()
        seen.append(in_view(position, follow.camera, follow.target))
        lag.append(np.linalg.norm(follow.target[:2] - position[:2]))
    assert all(seen), seen
    assert follow.moves > 150  # 10 Hz for 20 s
    # Smooth, and close: the target trails the base by its lag at fra2mo's 0.26 m/s at most.
    assert max(lag[4:]) < 0.26 * TIME_CONSTANT * 2 + 0.05, lag
    offset = follow.camera - follow.target
    assert np.allclose(offset, first[0] - first[1])  # the view's direction and distance kept
    world.close(simulator.get_context())


# The page's projection of a scene object's origin: normalised device coordinates
# (x, y in [-1, 1] inside the view; z < 1 before the far plane), from its world position
# and the page's own camera; and that position (x, y) [m] in the world's frame.
PROJECT_JS = """(path) => {
  const node = viewer.scene_tree.find(path);
  const point = new node.object.position.constructor();
  node.object.getWorldPosition(point);
  viewer.camera.updateMatrixWorld();
  const ndc = point.clone().project(viewer.camera);
  return [ndc.x, ndc.y, ndc.z, point.x, -point.z];  // three.js is y up: world x, y
}"""


CONTACTS_VISIBLE_JS = """() => {
  const node = viewer.scene_tree.find(["drake", "contact_forces"]);
  return node.object.visible;
}"""


@pytest.mark.browser
def test_the_page_keeps_fra2mo_in_view_for_the_whole_run(chromium):
    """fra2mo_goals live for 20 simulated seconds in headless Chromium: at every console
    line (each simulated second) the base's origin, projected with the page's camera, is
    inside the view, and the view moved with it; screenshots of the start, the middle and
    the end (docs/images/fra2mo_goals_*.png with ARMANDO_DRAKE_SCREENSHOTS)."""
    from browser import browser_page, open_url, save_screenshot, wait_for_scene_paths

    base = ["drake", "illustration", "fra2mo", "base_link"]
    process = subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", "--scenario", "fra2mo_goals"]
        + ["--wait", "60", "--exit-when-done", "--duration", "20", "--realtime-rate", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    seen, contacts = {}, None
    try:
        lines = []
        for line in process.stdout:
            lines.append(line)
            if "waiting up to 60 s for a browser" in line:
                break
        url = re.search(r"Meshcat: (\S+)", "".join(lines)).group(1)
        with browser_page(chromium) as page:
            open_url(page, url)
            wait_for_scene_paths(page, lambda paths: "/" + "/".join(base) in paths)
            for line in process.stdout:
                lines.append(line)
                match = re.match(r"\[t=(\d+\.\d+) s\]", line)
                if not match:
                    continue
                t = float(match.group(1))
                seen[t] = page.evaluate(PROJECT_JS, base)
                if t == 10.0:  # the wheels' contact forces: hidden (a layer to switch on)
                    contacts = page.evaluate(CONTACTS_VISIBLE_JS)
                shot = {1.0: "start", 10.0: "middle", 20.0: "end"}.get(t)
                if shot:
                    save_screenshot(page, f"fra2mo_goals_{shot}")
            process.wait(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, "".join(lines)
    assert len(seen) >= 19, sorted(seen)
    assert contacts is False, contacts
    outside = {t: p for t, p in seen.items() if not (abs(p[0]) < 1 and abs(p[1]) < 1 and p[2] < 1)}
    assert not outside, outside
    start = seen[min(seen)]
    farthest = max(np.hypot(p[3] - start[3], p[4] - start[4]) for p in seen.values())
    assert farthest > 1.5, farthest  # it drove across the arena (to its first goal, 2 m)
