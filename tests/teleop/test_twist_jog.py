"""The twist jog (diagrams/fra2mo_teleop.yaml): teleop_twist_keyboard's keys on the
Meshcat page drive fra2mo. A key press is what the page sends for it: a ``button``
message over Meshcat's websocket, counted by Meshcat as a click."""

import time

import msgpack
import numpy as np
import pytest
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator
from websockets.sync.client import connect

from armando_drake.outputs.base import COLUMNS
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario, merge_overrides
from armando_drake.teleop.twist_jog import button_label


class TeleopWorld:
    """fra2mo_teleop.yaml built with a Meshcat, unpaced, and a websocket to its page."""

    def __init__(self, *overrides: str):
        scenario = merge_overrides(
            load_scenario("fra2mo_teleop"),
            ["logging: {console_rate: 0}", "simulator_config: {target_realtime_rate: 0}"]
            + list(overrides),
        )
        self.meshcat = Meshcat()
        self.world = MakeWorld(scenario, meshcat=self.meshcat, quiet=True)
        self.simulator = Simulator(self.world.diagram)
        self.simulator.Initialize()

    @property
    def context(self):
        return self.simulator.get_context()

    def press(self, key: str) -> None:
        """The page's message for ``key`` (a click of its button), waited for."""
        label = button_label(key)
        before = self.meshcat.GetButtonClicks(label)
        url = self.meshcat.web_url().replace("http", "ws")
        with connect(url, close_timeout=0.1) as page:
            page.send(msgpack.packb({"type": "button", "name": label}))
        deadline = time.monotonic() + 5.0
        while self.meshcat.GetButtonClicks(label) == before:
            assert time.monotonic() < deadline, f"Meshcat did not count the click of {label}"
            time.sleep(0.002)

    def press_many(self, key: str, times: int) -> None:
        """The page's messages for ``times`` presses of ``key`` on one websocket, waited
        for."""
        label = button_label(key)
        before = self.meshcat.GetButtonClicks(label)
        url = self.meshcat.web_url().replace("http", "ws")
        with connect(url, close_timeout=0.1) as page:
            for _ in range(times):
                page.send(msgpack.packb({"type": "button", "name": label}))
            deadline = time.monotonic() + 60.0
            while self.meshcat.GetButtonClicks(label) < before + times:
                assert time.monotonic() < deadline, f"Meshcat counted too few clicks of {label}"
                time.sleep(0.01)

    def advance(self, seconds: float) -> None:
        self.simulator.AdvanceTo(self.context.get_time() + seconds)

    def published(self):
        """(count, linear.x, angular.z) of the cmd_vel publication."""
        publication = (
            self.world.robot()
            .twist.GetOutputPort("cmd_vel")
            .Eval(self.world.robot().twist.GetMyContextFromRoot(self.context))
        )
        if publication.count == 0:
            return 0, None, None
        twist = publication.message.twist
        return publication.count, twist.linear[0], twist.angular[2]

    def base(self, name: str) -> np.ndarray:
        return self.world.robot().base_log.array()[:, COLUMNS.index(name)]

    def close(self) -> None:
        self.world.close(self.context)


@pytest.fixture
def teleop():
    world = TeleopWorld()
    yield world
    world.close()


def test_the_keys_publish_teleop_twist_keyboards_twists(teleop):
    assert len(teleop.world.robot().twist.buttons) == 15
    teleop.advance(0.25)
    assert teleop.published() == (0, None, None)  # nothing before the first key
    teleop.press("i")
    teleop.advance(0.1)
    _, linear, angular = teleop.published()
    assert (linear, angular) == (0.5, 0.0)
    teleop.press("q")  # all speeds +10 %, the direction kept
    teleop.advance(0.1)
    _, linear, angular = teleop.published()
    assert linear == pytest.approx(0.55, abs=1e-12) and angular == 0.0
    assert teleop.world.robot().twist.speeds(teleop.context) == pytest.approx((0.55, 1.1))
    teleop.press(".")  # back left: backing up as a car turns (teleop_twist_keyboard's)
    teleop.advance(0.1)
    assert teleop.published()[1:] == pytest.approx((-0.55, 1.1))
    teleop.press("x")  # linear only -10 %
    teleop.press("j")  # turn in place, left
    teleop.advance(0.1)
    assert teleop.published()[1:] == pytest.approx((0.0, 1.1))
    teleop.press("k")
    teleop.advance(0.1)
    assert teleop.published()[1:] == (0.0, 0.0)
    assert teleop.world.robot().twist.speeds(teleop.context) == pytest.approx((0.495, 1.1))


def test_ten_thousand_speed_keys_keep_the_jog_finite_and_within_its_limits(teleop):
    """q pressed 10,000 times (1.1 ** 10000 overflows a float): the speeds stop at their
    ceilings; z 10,000 times: at their floor, from which q still raises them."""
    from armando_drake.teleop.twist_jog import MAX_JOG_SPEED, MAX_JOG_TURN, MIN_JOG_SPEED

    jog = teleop.world.robot().twist
    teleop.press("i")
    teleop.press_many("q", 10_000)
    teleop.advance(0.2)
    assert jog.speeds(teleop.context) == (MAX_JOG_SPEED, MAX_JOG_TURN)
    _, linear, angular = teleop.published()
    assert (linear, angular) == (MAX_JOG_SPEED, 0.0)
    teleop.press("j")  # the next key is a finite command, not NaN
    teleop.advance(0.2)
    assert teleop.published()[1:] == (0.0, MAX_JOG_TURN)
    teleop.press_many("z", 10_000)
    teleop.advance(0.2)
    assert jog.speeds(teleop.context) == (MIN_JOG_SPEED, MIN_JOG_SPEED)
    teleop.press("q")
    teleop.advance(0.2)
    assert jog.speeds(teleop.context) == pytest.approx((1.1 * MIN_JOG_SPEED,) * 2)
    rows = teleop.world.robot().base_log.array()
    assert np.isfinite(rows).all()
    teleop.press("k")
    teleop.advance(0.2)
    assert np.isfinite(teleop.world.robot().base_log.array()).all()


def test_the_base_drives_forward_after_i_and_stops_after_k(teleop):
    teleop.advance(0.5)  # settled on its wheels
    teleop.press("i")
    teleop.advance(2.0)
    count, linear, _ = teleop.published()
    assert linear == 0.5 and count >= 19  # repeated at 10 Hz while it holds
    x, y, speed = teleop.base("x"), teleop.base("y"), teleop.base("linear")
    assert x[-1] - x[0] > 0.8  # about 0.5 m/s for 2 s, less the start
    assert abs(y[-1]) < 0.02
    assert speed[-1] == pytest.approx(0.5, abs=0.02)
    teleop.press("k")
    teleop.advance(1.0)
    x_stop = teleop.base("x")[-1]
    teleop.advance(0.5)
    assert abs(teleop.base("x")[-1] - x_stop) < 1e-3
    assert abs(teleop.base("linear")[-1]) < 0.01


def test_with_a_key_timeout_the_twist_falls_to_zero():
    world = TeleopWorld("twist_jog: {key_timeout: 0.3}")
    try:
        world.press("i")
        world.advance(0.25)
        assert world.published()[1] == 0.5
        world.advance(0.2)
        assert world.published()[1:] == (0.0, 0.0)
    finally:
        world.close()


def test_a_drive_that_a_twist_sequence_drives_is_refused():
    scenario = merge_overrides(
        load_scenario("fra2mo_teleop"),
        [
            "logging: {console_rate: 0}",
            "twist: {steps: [{linear: 0.1, angular: 0.0, duration: 1.0}]}",
        ],
    )
    with pytest.raises(ScenarioError, match=r"diff_drive already takes its cmd_vel"):
        MakeWorld(scenario, meshcat=Meshcat(), quiet=True)


def test_without_a_meshcat_there_is_no_twist_jog():
    scenario = merge_overrides(load_scenario("fra2mo_teleop"), ["logging: {console_rate: 0}"])
    world = MakeWorld(scenario, quiet=True)
    assert world.robot().twist is None


class Pad:
    """A gamepad state as Meshcat.Gamepad gives it (Gamepad API standard mapping)."""

    def __init__(self, enable: bool, forward: float = 0.0, left: float = 0.0):
        self.index = 0
        self.button_values = [1.0 if enable else 0.0] + [0.0] * 15
        self.axes = [-left, -forward, 0.0, 0.0]  # axes 0, 1: right and down positive


def test_a_gamepad_drives_as_teleop_twist_joy_while_its_enable_button_is_held(teleop):
    jog = teleop.world.robot().twist
    jog.gamepad_source = lambda: Pad(enable=False, forward=1.0)
    teleop.advance(0.3)
    assert teleop.published()[0] == 0  # the stick without the enable button: nothing
    jog.gamepad_source = lambda: Pad(enable=True, forward=1.0, left=0.5)
    teleop.advance(0.3)
    _, linear, angular = teleop.published()
    assert linear == pytest.approx(0.5)  # scale_linear.x at full stick
    assert angular == pytest.approx(0.5 * (0.5 - 0.05) / 0.95)  # dead zone 0.05 rescaled
    teleop.advance(1.5)
    assert np.mean(teleop.base("linear")[-20:]) == pytest.approx(0.5, abs=0.02)
    jog.gamepad_source = lambda: Pad(enable=False, forward=1.0)
    teleop.advance(0.3)
    assert teleop.published()[1:] == (0.0, 0.0)  # released: stopped


# Presses a key in the page as a keyboard does (Meshcat's window-level keydown handler calls
# the key's button, which sends its message): ``times`` times in one go.
PRESS_KEY_JS = """([code, times]) => {
  for (let i = 0; i < times; i++) {
    document.body.dispatchEvent(new KeyboardEvent("keydown", {code: code, bubbles: true}));
  }
}"""


@pytest.mark.browser
def test_ten_thousand_speed_keys_in_the_page_keep_the_base_finite(teleop, chromium):
    """The same 10,000 presses of q, typed in the real page in headless Chromium: every
    one reaches Meshcat as a click, the speeds stop at their ceilings, the next key drives
    a finite command and no NaN reaches the base's log."""
    from browser import browser_page, open_url

    from armando_drake.teleop.twist_jog import MAX_JOG_SPEED, MAX_JOG_TURN

    label = button_label("q")
    with browser_page(chromium) as page:
        open_url(page, teleop.meshcat.web_url())
        page.wait_for_function(
            "() => viewer.keydown_callbacks && 'KeyQ' in viewer.keydown_callbacks", timeout=20000
        )
        page.evaluate(PRESS_KEY_JS, ["KeyI", 1])
        before = teleop.meshcat.GetButtonClicks(label)
        page.evaluate(PRESS_KEY_JS, ["KeyQ", 10_000])
        deadline = time.monotonic() + 60.0
        while teleop.meshcat.GetButtonClicks(label) < before + 10_000:
            assert time.monotonic() < deadline, "Meshcat counted too few clicks of q"
            time.sleep(0.01)
        teleop.advance(0.5)
        jog = teleop.world.robot().twist
        assert jog.speeds(teleop.context) == (MAX_JOG_SPEED, MAX_JOG_TURN)
        assert teleop.published()[1:] == (MAX_JOG_SPEED, 0.0)
        turns = teleop.meshcat.GetButtonClicks(button_label("j"))
        page.evaluate(PRESS_KEY_JS, ["KeyJ", 1])
        while teleop.meshcat.GetButtonClicks(button_label("j")) == turns:
            assert time.monotonic() < deadline, "Meshcat did not count the click of j"
            time.sleep(0.01)
        teleop.advance(0.5)
        assert teleop.published()[1:] == (0.0, MAX_JOG_TURN)
    rows = teleop.world.robot().base_log.array()
    assert len(rows) and np.isfinite(rows).all()
    assert np.ptp(rows[:, COLUMNS.index("x")]) > 0.01  # it drove, at a finite speed
