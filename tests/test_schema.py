"""The config schema alone: each rule of :func:`param` on a toy dataclass, the walk through
lists, dicts and Drake structs, the origin and the labels in the messages; and that every
numeric field of the scenario's sections declares its unit."""

import dataclasses as dc
import math
import types
import typing

import pytest
from pydrake.multibody.plant import MultibodyPlantConfig

from armando_drake.simulation.scenario import Scenario
from armando_drake.tools.schema import (
    DRAKE_SCHEMAS,
    SCHEMA,
    ConfigError,
    Refusal,
    check_config,
    leaves,
    param,
    range_text,
    rule_at,
)


@dc.dataclass
class Wheel:
    # [m] the wheel's radius.
    radius: float = param(0.1, unit="m", gt=0)
    # [-] spokes.
    spokes: int = param(6, unit="-", ge=3)


@dc.dataclass
class Step:
    """Named ``steps[i] Step: `` in messages."""

    size: float = param(1.0, unit="m", gt=0)

    def message_prefix(self, parent: str, name: str) -> str:
        return f"{parent.removesuffix('.')}[{name}] Step: "


@dc.dataclass
class Toy:
    rate: float = param(10.0, unit="Hz", gt=0)
    delay: float = param(0.0, unit="s", ge=0)
    dead_zone: float = param(0.1, unit="-", ge=0, lt=1)
    threshold: float = param(0.5, unit="-", gt=0, le=1)
    mode: str = param("fast", choices=("fast", "slow"))
    late_mode: str = param("a", choices=lambda: ("a", "b"))
    xyz: list[float] = param([0.0, 0.0, 0.0], unit="m", length=3, coordinate=True)
    size: list[float] = param([1.0, 1.0], unit="m", gt=0, length=2, item_names=("x", "y"))
    step: float = param(0.01, unit="s", gt=0, under=(1e-4, "too slow"), over=(1.0, "too coarse"))
    gain: float = 1.0  # no rule: only finite
    optional_rate: float | None = param(None, unit="Hz", gt=0)
    wheels: list[Wheel] = dc.field(default_factory=lambda: [Wheel(), Wheel()])
    named: dict[str, Wheel] = dc.field(default_factory=lambda: {"front": Wheel()})
    steps: list[Step] = dc.field(default_factory=lambda: [Step()])
    low: float = 0.0
    high: float = 1.0

    def check(self) -> None:
        if self.low > self.high:
            raise Refusal("low", f"={self.low!r} must not exceed high={self.high!r}")


def message(toy, **kwargs) -> str:
    with pytest.raises(ConfigError) as error:
        check_config(toy, **kwargs)
    text = str(error.value)
    assert "\n" not in text
    return text


def test_a_valid_toy_passes():
    check_config(Toy())


@pytest.mark.parametrize(
    "change, expected",
    [
        (dict(rate=0.0), "rate=0.0 must be positive [Hz]"),
        (dict(rate=math.nan), "rate=nan is not a finite number"),
        (dict(gain=math.inf), "gain=inf is not a finite number"),
        (dict(delay=-1.0), "delay=-1.0 must be zero or positive [s]"),
        (dict(dead_zone=1.0), "dead_zone=1.0 must be in [0, 1)"),
        (dict(threshold=0.0), "threshold=0.0 must be in (0, 1]"),
        (dict(mode="medium"), "mode='medium' is not one of 'fast', 'slow'"),
        (dict(late_mode="c"), "late_mode='c' is not one of 'a', 'b'"),
        (dict(xyz=[0.0, 0.0]), "xyz=[0.0, 0.0] must be 3 numbers"),
        (dict(xyz=[0.0, 2e4, 0.0]), "xyz.1=20000.0 m is farther than 10000 m from the origin"),
        (dict(size=[1.0, -2.0]), "y=-2.0 must be positive [m]"),
        (dict(step=1e-5), "step=1e-05 s is below 0.0001 s: too slow"),
        (dict(step=2.0), "step=2.0 s is over 1 s: too coarse"),
        (dict(optional_rate=-1.0), "optional_rate=-1.0 must be positive [Hz]"),
        (dict(low=2.0), "low=2.0 must not exceed high=1.0"),
    ],
)
def test_each_rule_has_its_one_line_message(change, expected):
    assert message(Toy(**change)) == expected


def test_nested_lists_dicts_and_custom_labels():
    assert message(Toy(wheels=[Wheel(), Wheel(radius=-1.0)])) == (
        "wheels.1.radius=-1.0 must be positive [m]"
    )
    assert message(Toy(wheels=[Wheel(spokes=2)])) == (
        "wheels.0.spokes=2 must be a whole number >= 3"
    )
    assert message(Toy(named={"front": Wheel(radius=0.0)})) == (
        "named.front.radius=0.0 must be positive [m]"
    )
    assert message(Toy(steps=[Step(), Step(size=0.0)])) == (
        "steps[1] Step: size=0.0 must be positive [m]"
    )
    # Checked alone, under a key of its own.
    assert (
        message([Step(size=-1.0)], key="steps") == "steps[0] Step: size=-1.0 must be positive [m]"
    )
    assert (
        message(Wheel(radius=0.0), key="car.wheel") == "car.wheel.radius=0.0 must be positive [m]"
    )


def test_the_origin_of_the_key_is_named():
    origins = {"rate": "--set 'rate: 0'", "wheels.1.radius": "cars.yaml"}
    origin = lambda key: origins.get(key, "<defaults>")  # noqa: E731 (a one-line table)
    assert (
        message(Toy(rate=0.0), origin=origin) == "--set 'rate: 0': rate=0.0 must be positive [Hz]"
    )
    assert message(Toy(wheels=[Wheel(), Wheel(radius=-1.0)]), origin=origin) == (
        "cars.yaml: wheels.1.radius=-1.0 must be positive [m]"
    )
    assert message(Toy(low=5.0), origin=origin) == ("<defaults>: low=5.0 must not exceed high=1.0")


def test_the_error_class_is_the_callers():
    class ToyError(ConfigError):
        pass

    with pytest.raises(ToyError, match="^rate=0.0 must be positive"):
        check_config(Toy(rate=0.0), error=ToyError)


def test_drake_structs_are_checked_by_their_table():
    assert DRAKE_SCHEMAS[MultibodyPlantConfig]["time_step"].unit == "s"
    config = MultibodyPlantConfig(time_step=-1.0)
    assert message(config, key="plant_config") == (
        "plant_config.time_step=-1.0 must be positive [s]"
    )
    config = MultibodyPlantConfig(discrete_contact_approximation="tamsi")
    assert message(config, key="plant_config").startswith(
        "plant_config.discrete_contact_approximation='tamsi' is not one of '', 'sap'"
    )


def test_leaves_and_rule_at():
    keys = dict(leaves(Toy()))
    assert keys["wheels.1.radius"] == 0.1 and keys["xyz"] == [0.0, 0.0, 0.0]
    assert rule_at(Toy(), "wheels.0.radius").unit == "m"
    assert rule_at(Toy(), "xyz.2").coordinate
    assert rule_at(Scenario(), "plant_config.time_step").gt == 0
    assert range_text(rule_at(Toy(), "dead_zone")) == "in [0, 1)"


# ---------------------------------------------------------------- the scenario's sections


def _dataclasses_in(schema, seen: set) -> None:
    """Every dataclass type reachable from ``schema`` through its fields' types."""
    if schema in seen or not dc.is_dataclass(schema):
        return
    seen.add(schema)
    for hint in typing.get_type_hints(schema).values():
        for inner in _inner_types(hint):
            _dataclasses_in(inner, seen)


def _inner_types(hint) -> list:
    found = [hint]
    for arg in typing.get_args(hint):
        found += _inner_types(arg)
    return found


def _is_numeric(hint) -> bool:
    """int or float, or an Optional, list or dict of them (not bool)."""
    if hint in (int, float):
        return True
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        return any(_is_numeric(a) for a in typing.get_args(hint) if a is not type(None))
    if origin in (list, dict):
        return _is_numeric(typing.get_args(hint)[-1])
    return False


def test_every_numeric_field_of_the_scenario_declares_its_unit():
    sections: set = set()
    _dataclasses_in(Scenario, sections)
    assert len(sections) > 20  # the sections, the sequencer and shape variants, the steps
    missing = []
    for section in sections:
        hints = typing.get_type_hints(section)
        for field in dc.fields(section):
            if _is_numeric(hints[field.name]):
                rule = field.metadata.get(SCHEMA)
                if rule is None or not rule.unit:
                    missing.append(f"{section.__name__}.{field.name}")
    assert not missing, missing


def test_every_numeric_field_of_drakes_structs_declares_its_unit():
    for struct, rules in DRAKE_SCHEMAS.items():
        for field in struct.__fields__:
            if field.type in (int, float):
                assert field.name in rules and rules[field.name].unit, (struct, field.name)
