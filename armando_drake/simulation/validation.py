"""Every input of a run checked at the door, once, before Drake sees a value.

:func:`check_scenario` goes over a loaded :class:`~armando_drake.simulation.scenario.Scenario`
(after every ``--set`` and command-line option): every number in it is finite,
the numbers with a range are in it, names with a fixed set of choices are one
of them. :func:`check_against_world` does the checks that need the robot and the
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
above :data:`MAX_GAIN` (no servo is that stiff, and the arm slams into its
limits), a rate above the plant's (nothing happens between plant steps). A
controller period that is not a multiple of the plant step runs, with a
warning naming the step actually used.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from typing import Any

from armando_drake.control.sequencer import Sinusoid
from armando_drake.sensors.objects import SceneObjectError, validate_object
from armando_drake.simulation.scenario import Scenario, ScenarioError, default_duration, sources_of

_log = logging.getLogger("armando_drake.world")

# [N m/rad] (or N/m) the largest proportional gain accepted. Industrial servos
# run at 1e3..1e5; above 1e6 the discrete step's implicit PD is all stiffness
# and a position command throws the joint to its limit.
MAX_GAIN = 1e6
# [N m s/rad] (or N s/m) the largest derivative (and velocity) gain accepted.
MAX_DAMPING = 1e5

# [s] the shortest plant step accepted: below it a simulated second takes hours.
MIN_TIME_STEP = 1e-5
# The slowest pacing accepted (besides 0, as fast as possible): slower, a second lasts hours.
MIN_REALTIME_RATE = 1e-3
# [s] the longest run taken from the sequence itself (no simulation.duration or
# --duration given): one pass of a sequence longer than this is surely a typo.
MAX_DEFAULT_DURATION = 3600.0
# [s] the longest run accepted at all (about 11.6 simulated days): longer, the
# run would not end in any useful time, as fast as it may go.
MAX_DURATION = 1e6

# Names with a fixed set of choices: dotted key -> the choices.
CHOICES = {
    "robot.collision": ("auto", "boxes", "convex", "as-is", "none"),
    "plant_config.contact_model": ("point", "hydroelastic", "hydroelastic_with_fallback"),
    "plant_config.discrete_contact_approximation": ("", "sap", "similar", "lagged"),
    "plant_config.contact_surface_representation": ("triangle", "polygon"),
    "camera.renderer": ("auto", "gl", "vtk"),
}

# Numbers with a range: dotted key (a "*" matches a list index) -> (low, low
# included, what the rule says). Every other number need only be finite.
POSITIVE, NON_NEGATIVE = (0.0, False, "positive"), (0.0, True, "zero or positive")
RANGES = {
    "plant_config.time_step": POSITIVE,
    "plant_config.penetration_allowance": POSITIVE,
    "plant_config.stiction_tolerance": POSITIVE,
    "plant_config.sap_near_rigid_threshold": NON_NEGATIVE,
    "actuators.kp": POSITIVE,
    "actuators.kd": NON_NEGATIVE,
    "actuators.kv": NON_NEGATIVE,
    "sequencer.period": POSITIVE,
    "sequencer.start_delay": NON_NEGATIVE,
    "sequencer.frequency": POSITIVE,
    "sequencer.rate": POSITIVE,
    "camera.save_rate": NON_NEGATIVE,
    "logging.console_rate": NON_NEGATIVE,
    "simulator_config.max_step_size": POSITIVE,
    "simulator_config.accuracy": POSITIVE,
    "simulator_config.target_realtime_rate": NON_NEGATIVE,
    "visualization.publish_period": POSITIVE,
    "simulation.duration": NON_NEGATIVE,
    "task.duration": POSITIVE,
    "task.radius": POSITIVE,
    "task.acceleration_time": POSITIVE,
    "cameras.*.horizontal_fov": POSITIVE,
    "cameras.*.near": POSITIVE,
    "cameras.*.far": POSITIVE,
    "cameras.*.update_rate": POSITIVE,
    "ros2.clock_rate": NON_NEGATIVE,
}
# [m] the largest coordinate of a position accepted: farther, the double's precision
# (about 1e-12 of the value) is coarser than the contact and joint tolerances.
MAX_COORDINATE = 1e4
# Positions: dotted key pattern of each coordinate.
POSITIONS = ("robot.base_xyz.*", "objects.*.xyz.*", "cameras.*.xyz.*")
# Vectors of a fixed length: dotted key -> length.
LENGTHS = {"robot.base_xyz": 3, "robot.base_rpy": 3}


class InputError(ScenarioError):
    """An input that the run refuses; the message is one line naming the value, the key
    and the file or option it came from."""


def _fail(scenario: Scenario, key: str, problem: str) -> InputError:
    """The error for ``key``: ``<origin>: <key><problem>``, where ``problem`` begins with
    ``=<value>`` (as ``kp=-1.0 must be positive``) or ``: ``."""
    return InputError(f"{sources_of(scenario).of(key)}: {key}{problem}")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _walk(value: Any, key: str):
    """(dotted key, value) of every number, string and number list inside ``value``
    (dataclasses, lists, dicts), depth first."""
    if dc.is_dataclass(value) and not isinstance(value, type):
        for field in dc.fields(value):
            if not field.name.startswith("_"):
                yield from _walk(getattr(value, field.name), f"{key}.{field.name}".lstrip("."))
    elif isinstance(value, dict):
        for name, item in value.items():
            yield from _walk(item, f"{key}.{name}")
    elif isinstance(value, (list, tuple)):
        yield key, value
        for index, item in enumerate(value):
            yield from _walk(item, f"{key}.{index}")
    else:
        yield key, value
    # Drake's config structs (MultibodyPlantConfig, ...) are not dataclasses.
    if hasattr(type(value), "__fields__") and not dc.is_dataclass(value):
        for field in type(value).__fields__:
            yield from _walk(getattr(value, field.name), f"{key}.{field.name}".lstrip("."))


def _pattern(key: str) -> str:
    """``key`` with its list indices as ``*`` (``cameras.0.near`` -> ``cameras.*.near``)."""
    return ".".join("*" if part.isdigit() else part for part in key.split("."))


def check_scenario(scenario: Scenario, source: str = "") -> None:
    """Raises :class:`InputError` for the first value of ``scenario`` that is not a
    finite number, out of its range, the wrong length or not one of its choices.
    ``source``: the scenario file's name in the messages (default: the file
    :func:`~armando_drake.simulation.scenario.load_scenario` read)."""
    if source:  # the caller's name for the file wins
        sources_of(scenario).file = source
    for key, value in _walk(scenario, ""):
        pattern = _pattern(key)
        if _is_number(value):
            if not math.isfinite(value):
                raise _fail(scenario, key, f"={value!r} is not a finite number")
            if pattern in POSITIONS and abs(value) > MAX_COORDINATE:
                raise _fail(
                    scenario,
                    key,
                    f"={value!r} m is farther than {MAX_COORDINATE:g} m from the origin",
                )
            if pattern in RANGES:
                low, included, rule = RANGES[pattern]
                if value < low or (value == low and not included):
                    raise _fail(scenario, key, f"={value!r} must be {rule}")
        elif isinstance(value, str) and pattern in CHOICES and value not in CHOICES[pattern]:
            choices = ", ".join(repr(c) for c in CHOICES[pattern])
            raise _fail(scenario, key, f"={value!r} is not one of {choices}")
        elif isinstance(value, (list, tuple)) and pattern in LENGTHS:
            if len(value) != LENGTHS[pattern]:
                raise _fail(scenario, key, f"={list(value)!r} must have {LENGTHS[pattern]} numbers")
    _check_sim_settings(scenario)
    _check_actuators(scenario)
    _check_objects(scenario)
    _check_bounded(scenario)


def _check_bounded(scenario: Scenario) -> None:
    """The values that would make a run last for ever: a tiny plant step, a crawling
    pacing, a publication faster than the plant, a sequence that never ends."""
    step = scenario.plant_config.time_step
    if step < MIN_TIME_STEP:
        raise _fail(
            scenario,
            "plant_config.time_step",
            f"={step!r} s is below {MIN_TIME_STEP:g} s: a simulated second would take hours",
        )
    pacing = scenario.simulator_config.target_realtime_rate
    if 0 < pacing < MIN_REALTIME_RATE:
        raise _fail(
            scenario,
            "simulator_config.target_realtime_rate",
            f"={pacing!r} is below {MIN_REALTIME_RATE:g} (0 = as fast as possible): a "
            "simulated second would take hours",
        )
    plant_rate = 1.0 / step
    for key, rate in [("ros2.clock_rate", scenario.ros2.clock_rate)] + [
        (f"cameras.{i}.update_rate", camera.update_rate)
        for i, camera in enumerate(scenario.cameras)
    ]:
        if rate > plant_rate * (1 + 1e-9):
            raise _fail(scenario, key, f"={rate!r} Hz is above the plant's rate {plant_rate:g} Hz")
    if scenario.simulation.duration > MAX_DURATION:
        raise _fail(
            scenario,
            "simulation.duration",
            f"={scenario.simulation.duration!r} s is over {MAX_DURATION:g} s "
            f"({MAX_DURATION / 86400:.1f} simulated days)",
        )
    if scenario.simulation.duration <= 0:
        duration = default_duration(scenario)
        if duration > MAX_DEFAULT_DURATION:
            key = "task" if scenario.sequencer is None else "sequencer"
            raise _fail(
                scenario,
                key,
                f": one pass lasts {duration:.4g} s, over {MAX_DEFAULT_DURATION:g} s; give "
                "simulation.duration (or --duration) to run that long",
            )


def _check_sim_settings(scenario: Scenario) -> None:
    from pydrake.systems.analysis import GetIntegrationSchemes

    scheme = scenario.simulator_config.integration_scheme
    if scheme not in GetIntegrationSchemes():
        raise _fail(
            scenario,
            "simulator_config.integration_scheme",
            f"={scheme!r} is not one of {', '.join(GetIntegrationSchemes())}",
        )
    if scenario.plant_config.discrete_contact_approximation == "tamsi":
        raise _fail(
            scenario,
            "plant_config.discrete_contact_approximation",
            "='tamsi' ignores PD actuator gains; use 'lagged', 'sap' or 'similar'",
        )


def _check_actuators(scenario: Scenario) -> None:
    actuators = scenario.actuators
    for name, value, limit in (
        ("kp", actuators.kp, MAX_GAIN),
        ("kd", actuators.kd, MAX_DAMPING),
        ("kv", actuators.kv, MAX_DAMPING),
    ):
        if value > limit:
            raise _fail(scenario, f"actuators.{name}", "=" + _too_stiff(value, limit))
    for joint, gains in actuators.gains.items():
        key = f"actuators.gains.{joint}"
        if len(gains) != 2:
            raise _fail(scenario, key, f"={gains!r} must be two numbers [kp, kd]")
        kp, kd = gains
        if kp < 0 or kd < 0:
            raise _fail(scenario, key, f"={gains!r}: gains must be zero or positive")
        if kp > MAX_GAIN or kd > MAX_DAMPING:
            raise _fail(scenario, key, f"={gains!r}: " + _too_stiff(max(kp, kd), MAX_GAIN))


def _too_stiff(value: float, limit: float) -> str:
    return (
        f"{value!r} is above {limit:g}: stiffer than any real servo, it throws the joint "
        "against its limits"
    )


def _check_objects(scenario: Scenario) -> None:

    names = set()
    for index, obj in enumerate(scenario.objects):
        try:
            validate_object(obj)
        except SceneObjectError as error:
            raise _fail(scenario, f"objects.{index}", f": {error}") from None
        if obj.name in names:
            raise _fail(scenario, f"objects.{index}", f": object {obj.name!r} is listed twice")
        names.add(obj.name)


def check_against_world(
    scenario: Scenario, *, update_rate: int, update_rate_source: str, joints: dict[str, str]
) -> None:
    """The checks that need the robot and the controller YAML.

    ``update_rate`` [Hz]: the controller manager's rate (from ``update_rate_source``,
    the controller YAML or the scenario); ``joints``: the robot's actuated joints
    and their command interfaces.
    """
    step = scenario.plant_config.time_step
    plant_rate = 1.0 / step
    period = 1.0 / update_rate
    where = update_rate_source
    if scenario.controllers.update_rate:
        where = sources_of(scenario).of("controllers.update_rate")
    if update_rate > plant_rate * (1 + 1e-9):
        if scenario.controllers.update_rate:  # the scenario's rate is the one too high
            raise InputError(
                f"{where}: controllers.update_rate={update_rate!r} Hz is above the plant's "
                f"rate {plant_rate:g} Hz (plant_config.time_step={step!r} s, from "
                f"{sources_of(scenario).of('plant_config.time_step')}): the controllers would "
                "run between plant steps"
            )
        raise _fail(
            scenario,
            "plant_config.time_step",
            f"={step!r} s is longer than the controller period 1/{update_rate} s (update_rate "
            f"from {where}): the controllers would see one state per several ticks",
        )
    publish = scenario.visualization.publish_period
    if publish < min(step, 1e-3) * (1 - 1e-9):  # Meshcat between plant steps: wasted work
        raise _fail(
            scenario,
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
    for joint, gains in scenario.actuators.gains.items():
        if joint not in joints:
            raise _fail(
                scenario,
                f"actuators.gains.{joint}",
                f": no actuated joint {joint!r} (actuated: {', '.join(joints) or 'none'})",
            )
        if joints[joint] == "position" and gains[0] <= 0:
            raise _fail(
                scenario,
                f"actuators.gains.{joint}",
                f"={gains!r}: kp of position joint {joint!r} must be positive",
            )
    console = scenario.logging.console_rate
    if console > update_rate:
        raise _fail(
            scenario,
            "logging.console_rate",
            f"={console!r} Hz is above the controller rate {update_rate} Hz (from {where}), "
            "the rate of the joint states it prints",
        )
    save_rate = scenario.camera.save_rate
    if save_rate > plant_rate:
        raise _fail(
            scenario,
            "camera.save_rate",
            f"={save_rate!r} Hz is above the plant's rate {plant_rate:g} Hz",
        )
    _check_sequencer(scenario, update_rate, where)


def _check_sequencer(scenario: Scenario, update_rate: int, where: str) -> None:

    config = scenario.sequencer
    if config is None:
        return
    period = 1.0 / update_rate
    if isinstance(config, Sinusoid):
        rate = config.rate or update_rate
        if rate > update_rate:
            raise _fail(
                scenario,
                "sequencer.rate",
                f"={rate!r} Hz is above the controller rate {update_rate} Hz (from {where})",
            )
        if config.frequency > rate / 2:
            raise _fail(
                scenario,
                "sequencer.frequency",
                f"={config.frequency!r} Hz is above half the publication rate {rate:g} Hz: "
                "the samples would not follow the wave",
            )
        return
    if config.period < period * (1 - 1e-9):
        raise _fail(
            scenario,
            "sequencer.period",
            f"={config.period!r} s is shorter than the controller period 1/{update_rate} s "
            f"(from {where}): the controllers would never see most targets",
        )
