"""The twist jog: the keys of ROS's teleop_twist_keyboard on the Meshcat page, driving a
mobile base through its drive's cmd_vel.

::

    u    i    o        forward left   forward   forward right
    j    k    l        turn left      stop      turn right
    m    ,    .        back right     back      back left

    q / z   all speeds +10 % / -10 % (within MAX_JOG_SPEED, MAX_JOG_TURN, MIN_JOG_SPEED)
    w / x   linear speed only
    e / c   angular speed only

Each key is a Meshcat button with its key (a click, a key press, or each repeat of a
held key counts). A move key sets the direction (x, th) in {-1, 0, 1}, as
teleop_twist_keyboard's ``moveBindings`` (``m`` and ``.`` mirrored, as a car backing
up); a speed key scales ``speed`` or ``turn`` and keeps the direction; ``k`` (as any
key that is not a binding upstream) stops. The twist ``(x * speed, th * turn)`` is
published at ``rate`` from the first key on, so that a drive with a
``cmd_vel_timeout`` (diff_drive_controller) keeps it as Gazebo's DiffDrive plugin
keeps the last command; with ``key_timeout`` it falls to zero after that long without
a key, as ROS 1's node does. The messages are ``geometry_msgs/TwistStamped``, which
every drive here takes (a diff_drive_controller's ``cmd_vel``, the plugins' as well).

Meshcat's API must be called from the thread that created the Meshcat: the simulator
runs there.
"""

from __future__ import annotations

import copy
import logging
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from armando_drake.control.stack import ControlStack
from armando_drake.messages.types import PublicationValue, Twist, TwistStamped
from armando_drake.teleop.config import TwistJogConfig
from armando_drake.teleop.gamepad import dead_zone
from armando_drake.tools.errors import ScenarioError

_log = logging.getLogger("armando_drake.world")

# joy_node's default dead zone: stick values below it read 0.
JOY_DEAD_ZONE = 0.05

# key -> (KeyboardEvent.code, (x, th)): teleop_twist_keyboard's moveBindings.
MOVE_KEYS = {
    "u": ("KeyU", (1, 1)),
    "i": ("KeyI", (1, 0)),
    "o": ("KeyO", (1, -1)),
    "j": ("KeyJ", (0, 1)),
    "k": ("KeyK", (0, 0)),
    "l": ("KeyL", (0, -1)),
    "m": ("KeyM", (-1, -1)),
    ",": ("Comma", (-1, 0)),
    ".": ("Period", (-1, 1)),
}
# key -> (KeyboardEvent.code, (speed factor, turn factor)): its speedBindings.
SPEED_KEYS = {
    "q": ("KeyQ", (1.1, 1.1)),
    "z": ("KeyZ", (0.9, 0.9)),
    "w": ("KeyW", (1.1, 1.0)),
    "x": ("KeyX", (0.9, 1.0)),
    "e": ("KeyE", (1.0, 1.1)),
    "c": ("KeyC", (1.0, 0.9)),
}
MOVE_NAMES = {
    "u": "forward left",
    "i": "forward",
    "o": "forward right",
    "j": "turn left",
    "k": "stop",
    "l": "turn right",
    "m": "back right",
    ",": "back",
    ".": "back left",
}
SPEED_NAMES = {
    "q": "speeds +10%",
    "z": "speeds -10%",
    "w": "linear +10%",
    "x": "linear -10%",
    "e": "angular +10%",
    "c": "angular -10%",
}


def button_label(key: str) -> str:
    """The Meshcat button of ``key`` (one of MOVE_KEYS or SPEED_KEYS)."""
    name = MOVE_NAMES.get(key) or SPEED_NAMES[key]
    return f"cmd_vel {name} ({key.upper() if key.isalpha() else key})"


# The range the speed keys scale within: [m/s] and [rad/s] at most (or the configured
# start, if larger), MIN_JOG_SPEED at least, so thousands of presses never overflow (and
# the drive clamps the twist to what its wheels can give).
MAX_JOG_SPEED = 10.0
MAX_JOG_TURN = 10.0
MIN_JOG_SPEED = 1e-3


def _bounded(value: float, start: float, ceiling: float) -> float:
    """A scaled speed kept in [MIN_JOG_SPEED, max(ceiling, start)]."""
    return min(max(value, MIN_JOG_SPEED), max(ceiling, start))


@dataclass
class TwistJogState:
    """The twist jog's memory between two readings of the keys."""

    speed: float  # [m/s]
    turn: float  # [rad/s]
    x: int = 0  # the direction of the linear speed: -1, 0, 1
    th: int = 0  # the direction of the angular speed: -1, 0, 1
    clicks: dict[str, int] = field(default_factory=dict)  # per button
    started: bool = False  # a key was pressed: publishing
    last_key: float = 0.0  # [s] when a key was last pressed
    stick: tuple[float, float] | None = None  # the gamepad's (linear, angular) while enabled


class TwistJog(LeafSystem):
    """Reads the teleop_twist_keyboard keys of a Meshcat page and publishes the twist.

    .. pydrake_system::

        name: TwistJog
        output_ports:
        - cmd_vel
        - command

    - ``cmd_vel``: a Publication of TwistStamped;
    - ``command``: vector (linear [m/s], angular [rad/s]) of the latest message, for logs.
    """

    def __init__(self, *, meshcat, config: TwistJogConfig, controller: str = ""):
        super().__init__()
        self.controller = controller  # the drive's name
        self._meshcat = meshcat
        self._config = config
        # Where the click counts come from (a callable of a button's label): the page.
        self.clicks_source = meshcat.GetButtonClicks
        # Where the gamepad state comes from (a Meshcat.Gamepad): the page's first gamepad;
        # a test may feed synthetic states instead.
        self.gamepad_source = meshcat.GetGamepad
        self._buttons: dict[str, str] = {}  # label -> key
        for key, (code, _) in list(MOVE_KEYS.items()) + list(SPEED_KEYS.items()):
            label = button_label(key)
            meshcat.AddButton(label, code)
            self._buttons[label] = key
        self._state = self.DeclareAbstractState(
            AbstractValue.Make(TwistJogState(speed=config.speed, turn=config.turn))
        )
        self._topic = self.DeclareAbstractState(PublicationValue())
        self._command = self.DeclareDiscreteState(BasicVector(np.zeros(2)))
        self.DeclareStateOutputPort("cmd_vel", self._topic)
        self.DeclareStateOutputPort("command", self._command)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / config.rate, 0.0, self._Update)

    @property
    def buttons(self) -> list[str]:
        return list(self._buttons)

    def delete_controls(self) -> None:
        """Removes the keys' buttons from the page."""
        names = self._meshcat.GetButtonNames()
        for label in self._buttons:
            if label in names:
                self._meshcat.DeleteButton(label)

    def speeds(self, context) -> tuple[float, float]:
        """([m/s], [rad/s]) the current speed and turn."""
        jog = self._jog_state(context)
        return jog.speed, jog.turn

    def command(self, context) -> tuple[float, float]:
        """(linear [m/s], angular [rad/s]) last published."""
        value = self.GetMyContextFromRoot(context).get_discrete_state(self._command).value()
        return float(value[0]), float(value[1])

    def _jog_state(self, context) -> TwistJogState:
        return self.GetMyContextFromRoot(context).get_abstract_state(self._state).get_value()

    def _Update(self, context, state) -> EventStatus:
        jog = copy.deepcopy(context.get_abstract_state(self._state).get_value())
        now = context.get_time()
        scaled = False
        for key in self._pressed(jog):
            jog.started, jog.last_key = True, now
            if key in MOVE_KEYS:
                jog.x, jog.th = MOVE_KEYS[key][1]
            else:
                linear, angular = SPEED_KEYS[key][1]
                jog.speed = _bounded(jog.speed * linear, self._config.speed, MAX_JOG_SPEED)
                jog.turn = _bounded(jog.turn * angular, self._config.turn, MAX_JOG_TURN)
                scaled = True
        if scaled:  # once per reading, however many speed keys came
            _log.info("twist jog: currently speed %.3g m/s, turn %.3g rad/s", jog.speed, jog.turn)
        timeout = self._config.key_timeout
        if jog.started and timeout > 0 and now - jog.last_key >= timeout - 1e-12:
            jog.x = jog.th = 0
        self._read_gamepad(jog, now)
        state.get_mutable_abstract_state(self._state).set_value(jog)
        if not jog.started:
            return EventStatus.DidNothing()
        linear, angular = jog.stick or (jog.x * jog.speed, jog.th * jog.turn)
        message = TwistStamped(
            stamp=now,
            frame_id=self._config.frame_id,
            twist=Twist(linear=(linear, 0.0, 0.0), angular=(0.0, 0.0, angular)),
        )
        publication = context.get_abstract_state(self._topic).get_value()
        state.get_mutable_abstract_state(self._topic).set_value(publication.publish(message, now))
        state.get_mutable_discrete_state(self._command).set_value([linear, angular])
        return EventStatus.Succeeded()

    def _read_gamepad(self, jog: TwistJogState, now: float) -> None:
        """teleop_twist_joy's mapping: while the enable button is held, the left stick
        (Gamepad API axes 1 forward-down, 0 sideways-right, so both negated as ROS's joy
        reports them) sets the twist; on its release the base stops."""
        config = self._config
        gamepad = self.gamepad_source() if config.gamepad else None
        held = False
        if gamepad is not None and gamepad.index is not None:
            buttons = gamepad.button_values
            held = config.gamepad_enable_button < len(buttons) and (
                buttons[config.gamepad_enable_button] > 0.5
            )
        if held:
            axes = list(gamepad.axes) + [0.0, 0.0]
            forward, left = (-dead_zone(axes[1], JOY_DEAD_ZONE), -dead_zone(axes[0], JOY_DEAD_ZONE))
            jog.stick = (forward * config.gamepad_scale_linear, left * config.gamepad_scale_angular)
            jog.started, jog.last_key = True, now
        elif jog.stick is not None:  # released: stop, as teleop_twist_joy does
            jog.stick, jog.x, jog.th = None, 0, 0

    def _pressed(self, jog: TwistJogState) -> list[str]:
        """The keys pressed since the last reading, each as often as it was (the move
        keys in the end decide the direction; the speed keys all count)."""
        pressed = []
        for label, key in self._buttons.items():
            clicks = self.clicks_source(label)
            pressed += [key] * max(0, clicks - jog.clicks.get(label, 0))
            jog.clicks[label] = clicks
        return pressed


def AddTwistJog(
    builder, config: TwistJogConfig, stack: ControlStack, *, meshcat=None, where: str = ""
) -> TwistJog | None:
    """The twist jog of ``config`` on ``meshcat``, publishing on the cmd_vel input of
    ``config.controller`` or the first active drive of ``stack`` that nothing drives
    yet; None without a Meshcat to read. Errors: :class:`ScenarioError` naming
    ``where``."""
    takers = stack.taking(TwistStamped)
    free = [name for name in takers if not builder.IsConnectedOrExported(stack.command_input(name))]
    wanted = f"twist_jog.controller={config.controller!r}" if config.controller else "twist_jog"
    name = config.controller or (free or takers or [""])[0]
    if name in takers and name not in free:
        raise ScenarioError(
            f"{where}{wanted}: {name} already takes its cmd_vel from the scenario's twist "
            "sequence; jog a drive nothing else drives (twist: null)"
        )
    if name not in free:
        raise ScenarioError(
            f"{where}{wanted} needs an active drive (a diff_drive_controller or the "
            f"description's drive plugin) that nothing else drives; such drives: "
            f"{', '.join(free) or 'none'}"
        )
    if meshcat is None or getattr(meshcat, "recording_only", False):
        _log.warning("twist jog: no Meshcat to read (--no-meshcat?): the base stays put")
        return None
    jog = builder.AddSystem(TwistJog(meshcat=meshcat, config=config, controller=name))
    jog.set_name("twist_jog")
    builder.Connect(jog.GetOutputPort("cmd_vel"), stack.command_input(name))
    _log.info(
        "twist jog: keys u i o / j k l / m , . and q z w x e c on %s at %g Hz "
        "(speed %g m/s, turn %g rad/s)",
        name,
        config.rate,
        config.speed,
        config.turn,
    )
    return jog
