"""Sweep axes: parsing, the variants they make, and the overrides each variant passes."""

import pytest
import yaml

from armando_drake.sweeps.axes import (
    KeyPath,
    make_variants,
    override_yaml,
    parse_grid,
    parse_random,
)
from armando_drake.sweeps.errors import SweepError


def test_grid_is_every_combination_first_axis_slowest():
    variants = make_variants(
        [parse_grid("actuators.kp=[2, 4, 8]"), parse_grid("actuators.kd=[0.1, 0.4]")]
    )
    assert [v.index for v in variants] == list(range(6))
    assert [(v.values["actuators.kp"], v.values["actuators.kd"]) for v in variants] == [
        (2, 0.1),
        (2, 0.4),
        (4, 0.1),
        (4, 0.4),
        (8, 0.1),
        (8, 0.4),
    ]
    # Both axes under one top-level key: one --set, as the world takes it.
    assert variants[3].overrides() == ["actuators: {kp: 4, kd: 0.4}"]


def test_overrides_read_back_to_the_values_exactly():
    values = {
        KeyPath.parse("actuators.kp"): 1 / 3,
        KeyPath.parse("actuators.gains"): {"j0": [1e-5, 2.5]},
        KeyPath.parse("simulation.duration"): 3,
        KeyPath.parse("robot.collision"): "none",
        KeyPath.parse("robot.description"): "4",  # a string that looks like a number
    }
    texts = override_yaml(values)
    assert len(texts) == 3  # actuators, simulation, robot
    merged = {}
    for text in texts:
        merged.update(yaml.safe_load(text))
    assert merged == {
        "actuators": {"kp": 1 / 3, "gains": {"j0": [1e-5, 2.5]}},
        "simulation": {"duration": 3},
        "robot": {"collision": "none", "description": "4"},
    }


def test_type_tag_segment_becomes_a_yaml_tag():
    (variant,) = make_variants([parse_grid("sequencer!PositionTargets.period=[2.5]")])
    assert variant.overrides() == ["sequencer: !PositionTargets {period: 2.5}"]


def test_grid_values_are_yaml_12_numbers_and_spaces():
    assert parse_grid("a.b=[1e-5, 2E3, 1_000, fast]").values == (1e-5, 2000.0, 1000, "fast")
    assert parse_grid("a.b=linspace(0, 1, 5)").values == (0.0, 0.25, 0.5, 0.75, 1.0)
    assert parse_grid("a.b=geomspace(1, 64, 4)").values == pytest.approx((1, 4, 16, 64))


def test_random_axes_are_reproducible_and_prefix_stable():
    axes = [parse_random("actuators.kp=uniform(1, 20)"), parse_random("a.n=integers(1, 3)")]
    first = make_variants(random=axes, samples=50, seed=1)
    again = make_variants(random=axes, samples=50, seed=1)
    longer = make_variants(random=axes, samples=80, seed=1)
    other = make_variants(random=axes, samples=50, seed=2)
    assert [v.values for v in first] == [v.values for v in again]
    assert [v.values for v in first] == [v.values for v in longer[:50]]
    assert [v.values for v in first] != [v.values for v in other]
    kp = [v.values["actuators.kp"] for v in first]
    assert all(1 <= x < 20 for x in kp) and max(kp) - min(kp) > 10
    assert {v.values["a.n"] for v in first} == {1, 2, 3}
    # The override carries the drawn float exactly.
    assert yaml.safe_load(first[7].overrides()[0])["actuators"]["kp"] == kp[7]


def test_grid_times_random_samples():
    variants = make_variants(
        [parse_grid("a.x=[1, 2]")], [parse_random("a.y=choice([p, q])")], samples=3, seed=0
    )
    assert len(variants) == 6
    assert [v.values["a.x"] for v in variants] == [1, 1, 1, 2, 2, 2]
    assert [v.values["a.y"] for v in variants[:3]] == [v.values["a.y"] for v in variants[3:]]


@pytest.mark.parametrize(
    "grid, random, message",
    [
        (["actuators.kp"], [], "'actuators.kp' is not of the form KEY=VALUES"),
        (["actuators.kp=4"], [], "must be a non-empty YAML list"),
        (["actuators.kp=[]"], [], "must be a non-empty YAML list"),
        (["targets.0=[1]"], [], "'0' is not a key path segment"),
        (["a.b=linspace(0, 1)"], [], "linspace takes (start, stop, count)"),
        ([], ["a.b=uniform(3, 1)"], "uniform takes (low < high)"),
        ([], ["a.b=gauss(0, 1)"], "the distribution must be one of"),
        (["a=[1]", "a.b=[2]"], [], "axes 'a' and 'a.b' set the same scenario key"),
        (["a!X.b=[1]", "a!Y.c=[2]"], [], "give 'a' different type tags"),
    ],
)
def test_bad_axes_are_named(grid, random, message):
    with pytest.raises(SweepError) as error:
        make_variants(
            [parse_grid(g) for g in grid],
            [parse_random(r) for r in random],
            samples=2 if random else 0,
        )
    assert message in str(error.value)


def test_random_needs_samples_and_something_to_sweep():
    with pytest.raises(SweepError, match="needs --samples"):
        make_variants(random=[parse_random("a.b=uniform(0, 1)")])
    with pytest.raises(SweepError, match="nothing to sweep"):
        make_variants()
