"""The live jog driven through the Meshcat page in headless Chromium: a slider, the
Cartesian jog buttons and keys, a gamepad, the note of a clamped command."""

import re
import threading
import time

import numpy as np
import pytest
from browser import browser_page, open_url, running
from jog_worlds import jog_world

from armando_drake.teleop.config import GamepadMapping

pytestmark = pytest.mark.browser

# Sets a dat.GUI slider of the Meshcat controls as a user typing in its box does.
SET_SLIDER_JS = """([name, value]) => {
  const input = viewer.gui_controllers[name].domElement.querySelector("input");
  input.value = String(value);
  input.dispatchEvent(new Event("input", {bubbles: true}));
  input.dispatchEvent(new Event("change", {bubbles: true}));
}"""
# What the page sends when the browser's first gamepad changes (meshcat.html).
GAMEPAD_JS = """([buttons, axes]) => viewer.connection.send(MeshCat.msgpack.encode(
  {type: "gamepad", name: "", gamepad: {index: 0, button_values: buttons, axes: axes}}))"""


def wait_until(predicate, page, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        page.wait_for_timeout(20)


def open_jog_page(page, url: str) -> None:
    """Loads the page and opens its controls, which Meshcat shows closed."""
    open_url(page, url)
    page.wait_for_function(
        "() => viewer.gui_controllers && 'home (H)' in viewer.gui_controllers", timeout=20000
    )
    page.get_by_text("Open Controls").click()


def test_a_slider_moved_in_the_page_moves_the_joint_to_its_value(chromium):
    run = jog_world()
    try:
        with browser_page(chromium) as page:
            open_jog_page(page, run.meshcat.web_url())
            run.advance(0.5)
            page.evaluate(SET_SLIDER_JS, ["j1", 0.75])
            wait_until(lambda: run.meshcat.GetSliderValue("j1") == pytest.approx(0.75), page)
            run.advance(2.0)
            q = run.q()
            # The page's box shows the slider's value.
            shown = page.evaluate(
                "() => viewer.gui_controllers['j1'].domElement.querySelector('input').value"
            )
        assert abs(q[1] - 0.75) < 0.01, q
        assert abs(q[2] - 0.9) < 0.01 and abs(q[0]) < 0.01
        assert float(shown) == pytest.approx(0.75)
    finally:
        run.close()


@pytest.mark.parametrize(
    "button, key, axis",
    [("jog +x (W)", None, [1, 0, 0]), ("jog -z (F)", "KeyF", [0, 0, -1])],
    ids=["button +x", "key -z"],
)
def test_a_cartesian_jog_moves_the_end_effector_along_its_axis(chromium, button, key, axis):
    run = jog_world()
    try:
        with browser_page(chromium) as page:
            open_jog_page(page, run.meshcat.web_url())
            run.advance(0.5)
            start = run.end_effector()
            for _ in range(4):
                if key:
                    page.keyboard.press(key)
                else:
                    page.locator("li.cr.function", has_text=button).click()
            wait_until(lambda: run.meshcat.GetButtonClicks(button) == 4, page)
            run.advance(1.5)
        moved = run.end_effector() - start
        direction = moved / np.linalg.norm(moved)
        assert direction @ np.array(axis) > 0.95, moved
        assert np.linalg.norm(moved) == pytest.approx(4 * 0.005, rel=0.15)
    finally:
        run.close()


def test_a_gamepad_in_the_page_moves_the_joint_and_a_clamp_shows_a_note(chromium):
    mapping = GamepadMapping()
    run = jog_world("jog: {home_positions: [2.4, 0.4, 0.9, 0.7]}")
    try:
        with browser_page(chromium) as page:
            open_jog_page(page, run.meshcat.web_url())

            def send(pressed=(), axes=(0.0, 0.0, 0.0, 0.0)):
                buttons = [1.0 if k in pressed else 0.0 for k in range(17)]
                page.evaluate(GAMEPAD_JS, [buttons, list(axes)])
                wait_until(lambda: list(run.meshcat.GetGamepad().axes) == list(axes), page)
                wait_until(lambda: run.meshcat.GetGamepad().button_values == buttons, page)

            send(pressed=[mapping.joint_mode_button])
            run.advance(0.1)
            send(pressed=[mapping.deadman_button], axes=(-1.0, 0.0, 0.0, 0.0))  # j0 up
            run.advance(1.0)
            send()
            run.advance(1.0)
            note = page.locator("li.cr.function", has_text="note: gamepad: j0 clamped")
            note.wait_for(state="visible", timeout=5000)
            text = note.inner_text()
        upper = run.world.robot().stack.hardware.joints[0].upper
        assert abs(run.q()[0] - upper) < 0.01
        assert f"clamped to its upper limit {upper:.3f}" in text
    finally:
        run.close()


def test_world_cli_jog_scenario_follows_a_slider_moved_in_the_page(chromium):
    """`python -m armando_drake.world --scenario jog`, paced at real time, as a user runs it."""
    with running(
        ["armando_drake.world", "--scenario", "jog", "--duration", "30"], r"Meshcat: (\S+)"
    ) as (process, url):
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.extend(process.stdout), daemon=True)
        reader.start()
        with browser_page(chromium) as page:
            open_jog_page(page, url)
            page.evaluate(SET_SLIDER_JS, ["j2", 0.3])

            def printed_j2():
                values = [float(v) for v in re.findall(r"Joint j2: (-?[\d.]+)", "".join(lines))]
                return values and abs(values[-1] - 0.3) < 0.01

            wait_until(printed_j2, page, timeout=15.0)
        assert process.poll() is None  # still running: only Ctrl-C or --duration end it
