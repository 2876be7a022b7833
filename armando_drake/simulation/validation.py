"""Every input of a run checked at the door, once, before Drake sees a value.

:func:`check_scenario` goes over a loaded :class:`~armando_drake.simulation.scenario.Scenario`
(after every ``--set`` and command-line option) with the one checker of
:mod:`armando_drake.tools.schema`: every number in it is finite, each field is in
the range, of the length and one of the choices declared beside it, and the rules
between fields of each section (its ``check()``) hold.
:func:`check_against_world` does the checks that need the robot and the
controller YAML: the plant step against the controller period, rates against
the plant rate, gains of joints that exist, the sequencer's period against the
controller period. Both raise :class:`InputError`, a
:class:`~armando_drake.simulation.scenario.ScenarioError` whose one-line
message names the value, the key and where it came from (the scenario file,
or the ``--set '...'`` / option that set it; see
:func:`~armando_drake.simulation.scenario.sources_of`), which the command line
turns into ``error: ...`` and exit code 2.

Physics that would run but not do what was asked are refused too, each with
its reason in the message: a plant step longer than the controller period
(the controllers would see one state per several ticks), a proportional gain
above :data:`~armando_drake.simulation.scenario.MAX_GAIN` (no servo is that stiff,
and the arm slams into its limits), a rate above the plant's (nothing happens
between plant steps). A controller period that is not a multiple of the plant step
runs, with a warning naming the step actually used.
"""

from __future__ import annotations

import logging

from armando_drake.control.sequencer import Sinusoid
from armando_drake.simulation.scenario import (
    Scenario,
    ScenarioError,
    ScenarioRobot,
    sources_of,
)
from armando_drake.tools.schema import check_config

_log = logging.getLogger("armando_drake.world")


class InputError(ScenarioError):
    """An input that the run refuses; the message is one line naming the value, the key
    and the file or option it came from."""


def _fail(robot: ScenarioRobot, key: str, problem: str) -> InputError:
    """The error for ``robot``'s ``key``: ``<origin>: <key><problem>``, where ``problem``
    begins with ``=<value>`` (as ``kp=-1.0 must be positive``) or ``: ``."""
    return InputError(f"{robot.sources.of(key)}: {key}{problem}")


def check_scenario(scenario: Scenario, source: str = "") -> Scenario:
    """Raises :class:`InputError` for the first value of ``scenario`` that its schema
    refuses (not a finite number, out of its range, the wrong length, not one of its
    choices, against a rule of its section). ``source``: the scenario file's name in the
    messages (default: the file :func:`~armando_drake.simulation.scenario.load_scenario`
    read); the one robot of the top-level keys is named by those keys, as the file
    names it. Returns ``scenario``."""
    sources = sources_of(scenario)
    if source:  # the caller's name for the file wins
        sources.file = source
    strip = f"robots.{sources.one_robot}." if sources.one_robot else ""
    check_config(scenario, origin=sources.of, error=InputError, strip=strip)
    return scenario


def check_against_world(
    scenario: Scenario,
    robot: ScenarioRobot,
    *,
    sequencer,
    update_rate: int,
    update_rate_source: str,
    joints: dict[str, str],
) -> None:
    """The checks of one robot of ``scenario`` that need its description and controller
    YAML.

    ``sequencer``: the one that drives its controllers (its entry's, or the one
    :func:`~armando_drake.control.stack.choose_controllers` chose); ``update_rate`` [Hz]:
    the controller manager's rate (from ``update_rate_source``, the controller YAML or
    the scenario); ``joints``: the robot's actuated joints and their command interfaces.
    """
    step = scenario.plant_config.time_step
    plant_rate = 1.0 / step
    period = 1.0 / update_rate
    where = update_rate_source
    if robot.entry.controllers.update_rate:
        where = robot.sources.of("controllers.update_rate")
    if update_rate > plant_rate * (1 + 1e-9):
        if robot.entry.controllers.update_rate:  # the scenario's rate is the one too high
            raise InputError(
                f"{where}: controllers.update_rate={update_rate!r} Hz is above the plant's "
                f"rate {plant_rate:g} Hz (plant_config.time_step={step!r} s, from "
                f"{robot.sources.of('plant_config.time_step')}): the controllers would "
                "run between plant steps"
            )
        raise _fail(
            robot,
            "plant_config.time_step",
            f"={step!r} s is longer than the controller period 1/{update_rate} s (update_rate "
            f"from {where}): the controllers would see one state per several ticks",
        )
    publish = scenario.visualization.publish_period
    if publish < min(step, 1e-3) * (1 - 1e-9):  # Meshcat between plant steps: wasted work
        raise _fail(
            robot,
            "visualization.publish_period",
            f"={publish!r} s is shorter than the plant step {step!r} s",
        )
    ticks = period / step
    if abs(ticks - round(ticks)) > 1e-6 * ticks:
        _log.warning(
            "%s: the controller period 1/%d s is not a multiple of the plant step %g s: "
            "the controllers read the state of the latest plant step (every %.4g steps)",
            where,
            update_rate,
            step,
            ticks,
        )
    _check_gains(robot, joints)
    console = scenario.logging.console_rate
    if console > update_rate:
        raise _fail(
            robot,
            "logging.console_rate",
            f"={console!r} Hz is above the controller rate {update_rate} Hz (from {where}), "
            "the rate of the joint states it prints",
        )
    save_rate = scenario.camera.save_rate
    if save_rate > plant_rate:
        raise _fail(
            robot,
            "camera.save_rate",
            f"={save_rate!r} Hz is above the plant's rate {plant_rate:g} Hz",
        )
    _check_sequencer(robot, sequencer, update_rate, where)


def _check_gains(robot: ScenarioRobot, joints: dict[str, str]) -> None:
    """Each of the robot's per-joint gains names an actuated joint; a position joint's kp
    is positive."""
    for joint, gains in robot.entry.actuators.gains.items():
        if joint not in joints:
            raise _fail(
                robot,
                f"actuators.gains.{joint}",
                f": no actuated joint {joint!r} (actuated: {', '.join(joints) or 'none'})",
            )
        if joints[joint] == "position" and gains[0] <= 0:
            raise _fail(
                robot,
                f"actuators.gains.{joint}",
                f"={gains!r}: kp of position joint {joint!r} must be positive",
            )


def _check_sequencer(robot: ScenarioRobot, config, update_rate: int, where: str) -> None:
    if config is None:
        return
    period = 1.0 / update_rate
    if isinstance(config, Sinusoid):
        rate = config.rate or update_rate
        if rate > update_rate:
            raise _fail(
                robot,
                "sequencer.rate",
                f"={rate!r} Hz is above the controller rate {update_rate} Hz (from {where})",
            )
        if config.frequency > rate / 2:
            raise _fail(
                robot,
                "sequencer.frequency",
                f"={config.frequency!r} Hz is above half the publication rate {rate:g} Hz: "
                "the samples would not follow the wave",
            )
        return
    if config.period < period * (1 - 1e-9):
        raise _fail(
            robot,
            "sequencer.period",
            f"={config.period!r} s is shorter than the controller period 1/{update_rate} s "
            f"(from {where}): the controllers would never see most targets",
        )
