"""Every page opens framed, measured in the rendered page as a user sees it: the robot
(and the camera scenario's objects) fill 90 % of the view's height, centred, nothing cut
off; the jog page redraws the arm as a jog moves it.

Measured in headless Chromium (1280 x 720) from two screenshots, with and without the
content (tests/browser.py, measure_framing). With ARMANDO_DRAKE_SCREENSHOTS=docs/images
the tests save the pages there (docs/viewer.md shows them).
"""

import io
import subprocess
import sys

import numpy as np
import pytest
from browser import (
    measure_framing,
    open_url,
    running,
    save_screenshot,
    scene_children,
    wait_for_scene_paths,
)

from armando_drake.description.framing import FILL

pytestmark = pytest.mark.browser

TOLERANCE = 0.02  # of the view's height: the fill measured from the pixels
CENTRE_TOLERANCE = 0.02  # of the view's height or width: the content's centre
ROBOT = "/drake/illustration/armando"
ACCESSORIES = [ROBOT + "/camera_link"]  # fixed beside the arm, not framed
# The arm's jogged end effector (diagrams/jog.yaml), its world position in the page.
END_EFFECTOR_JS = """() => {
  const o = viewer.scene_tree.find(['drake', 'illustration', 'armando', 'crawer_base']).object;
  o.updateMatrixWorld(true);
  const p = o.getWorldPosition(new viewer.camera.position.constructor());
  return [p.x, -p.z, p.y];  // three.js is y up: the world's x, y, z
}"""
FAST = ["--no-wait", "--duration", "0.01", "--realtime-rate", "0", "--quiet"]


def open_scene(page, url: str) -> None:
    open_url(page, url)
    wait_for_scene_paths(page, lambda paths: any(p.startswith(ROBOT + "/") for p in paths))
    page.wait_for_timeout(1000)  # the camera and the poses of the first publish


def assert_framed(framing, what: str) -> None:
    assert framing is not None, f"{what}: nothing drawn"
    assert not framing.cut, f"{what} cut off: {framing}"
    assert framing.fill == pytest.approx(FILL, abs=TOLERANCE), f"{what}: {framing}"
    row, column = framing.centre
    assert row == pytest.approx(0.5, abs=CENTRE_TOLERANCE), f"{what}: {framing}"
    assert column == pytest.approx(0.5, abs=CENTRE_TOLERANCE), f"{what}: {framing}"


def test_display_frames_the_robot(module_page):
    with running(["armando_drake.display"], r"Meshcat: (\S+)") as (_, url):
        open_scene(module_page, url)
        assert_framed(measure_framing(module_page, [ROBOT], ACCESSORIES), "display")
        save_screenshot(module_page, "display")


def test_world_frames_the_robot(module_page):
    with running(["armando_drake.world", "--keep-serving", *FAST], r"Meshcat: (\S+)") as (_, url):
        open_scene(module_page, url)
        assert_framed(measure_framing(module_page, [ROBOT], ACCESSORIES), "world")
        save_screenshot(module_page, "world")


def test_camera_scenario_frames_the_robot_and_its_objects(module_page):
    with running(
        ["armando_drake.world", "--scenario", "camera", "--keep-serving", *FAST],
        r"Meshcat: (\S+)",
    ) as (_, url):
        open_scene(module_page, url)
        objects = [p for p in scene_children(module_page, "/drake/illustration") if p != ROBOT]
        assert sorted(objects) == [
            "/drake/illustration/blue_disc_visual",
            "/drake/illustration/yellow_box_visual",
        ]
        everything = measure_framing(module_page, [ROBOT, *objects], ACCESSORIES)
        assert_framed(everything, "robot and objects")
        for path in objects:  # each in view, none cut off at an edge
            alone = measure_framing(module_page, [path], [ROBOT, *objects])
            assert alone is not None and not alone.cut, (path, alone)
        save_screenshot(module_page, "camera")


def test_replay_html_frames_the_robot(module_page, tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", *FAST]
        + ["--output", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert result.returncode == 0, result.stderr
    open_scene(module_page, (tmp_path / "replay.html").as_uri())
    assert_framed(measure_framing(module_page, [ROBOT], ACCESSORIES), "replay")


def test_jog_page_is_framed_and_redraws_the_arm_as_it_jogs(module_page):
    """`--scenario jog` at real time: the arm at its home posture fills the view as the
    others do; ten presses of F (jog -z, 5 mm each) move the end effector 50 mm down
    in the open page, without a reload."""
    page = module_page
    with running(
        ["armando_drake.world", "--scenario", "jog", "--no-wait", "--duration", "120"],
        r"Meshcat: (\S+)",
    ) as (_, url):
        open_scene(page, url)
        page.wait_for_function(
            "() => viewer.gui_controllers && 'home (H)' in viewer.gui_controllers",
            timeout=20000,
        )
        assert_framed(measure_framing(page, [ROBOT], ACCESSORIES), "jog")
        start = page.evaluate(END_EFFECTOR_JS)
        before = page.screenshot()
        for _ in range(10):
            page.keyboard.press("KeyF")
        moved = start
        for _ in range(100):  # up to about 20 s
            page.wait_for_timeout(200)
            now = page.evaluate(END_EFFECTOR_JS)
            if abs(now[2] - start[2]) > 0.045 and abs(now[2] - moved[2]) < 1e-4:
                break  # moved, and come to rest
            moved = now
        after = page.screenshot()
        page.get_by_text("Open Controls").click()
        save_screenshot(page, "jog")
    drop = start[2] - now[2]
    assert drop == pytest.approx(0.05, abs=0.01), (start, now)
    assert abs(now[0] - start[0]) < 0.005 and abs(now[1] - start[1]) < 0.005, (start, now)
    # The drawn page changed where the arm is (below the real-time rate plot).
    changed = np.abs(pixels(before) - pixels(after)).sum(axis=2)[60:] > 30
    assert changed.sum() > 1000, changed.sum()


def pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
