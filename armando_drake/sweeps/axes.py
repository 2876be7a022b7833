"""The axes of a sweep and the variants they make.

An axis is a scenario key path and the values it takes:

- a grid axis, ``KEY=VALUES``: a YAML list (``actuators.kp=[2, 4, 8, 16]``) or
  ``linspace(start, stop, count)`` / ``geomspace(start, stop, count)``;
- a random axis, ``KEY=DISTRIBUTION``: ``uniform(low, high)``,
  ``loguniform(low, high)``, ``normal(mean, std)``, ``integers(low, high)``
  (both ends included) or ``choice([a, b, ...])``, drawn ``samples`` times from
  one seeded generator.

The variants are every combination of the grid values (the first axis varies
slowest) times the random samples (sample k draws every random axis in order,
so the first 100 samples of a 200-sample sweep are the 100 of a 100-sample one).

A key path names a field of the scenario YAML, segments separated by dots
(``actuators.kp``). A segment may carry a YAML type tag for a tagged union
field, ``name!Tag``: ``sequencer!PositionTargets.period=[2, 3]`` becomes
``--set 'sequencer: !PositionTargets {period: 2}'``. A key path
``nav.NODE.PLUGIN.PARAMETER`` names a parameter of the navigation's Nav2 YAML
(``nav.controller_server.FollowPath.desired_linear_vel=[0.3, 0.5]``): the run gets it as
``navigation: {params_overrides: {controller_server.FollowPath.desired_linear_vel: 0.3}}``
(navigation/overrides.py). A variant's overrides are
one ``--set`` YAML string per top-level key, all its axes merged:
``actuators.kp=4`` and ``actuators.kd=0.1`` make ``actuators: {kp: 4, kd: 0.1}``.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import yaml

from armando_drake.sweeps.errors import SweepError

_SEGMENT = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:!([A-Za-z_][A-Za-z0-9_:.\[\]]*))?$")
_CALL = re.compile(r"^\s*([A-Za-z_]+)\s*\((.*)\)\s*$", re.S)


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader, reading ``1e-5`` as a float as YAML 1.2 does (not a string)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def _load(text: str) -> Any:
    return yaml.load(text, Loader=_Loader)


@dataclass(frozen=True)
class KeyPath:
    """A scenario key path: ``(name, tag or None)`` per segment."""

    text: str  # as the user wrote it, e.g. "actuators.kp"
    segments: tuple[tuple[str, str | None], ...]

    @staticmethod
    def parse(text: str, option: str = "--grid") -> KeyPath:
        if text.strip().startswith(NAV_PREFIX):
            return _nav_key(text, option)
        segments = []
        for part in text.strip().split("."):
            match = _SEGMENT.match(part)
            if not match:
                raise SweepError(
                    f"{option} {text!r}: {part!r} is not a key path segment (a YAML key, "
                    "optionally with a type tag as name!Tag; list items cannot be addressed)"
                )
            segments.append((match[1], match[2]))
        return KeyPath(text.strip(), tuple(segments))


NAV_PREFIX = "nav."  # nav.KEY: a Nav2 parameter, navigation.params_overrides's KEY


def _nav_key(text: str, option: str) -> KeyPath:
    """``nav.controller_server.FollowPath.desired_linear_vel``: the Nav2 parameter's
    dotted path as one key of ``navigation.params_overrides``."""
    parameter = text.strip()[len(NAV_PREFIX) :]
    if not all(re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", part) for part in parameter.split(".")):
        raise SweepError(
            f"{option} {text!r}: {parameter!r} is not a Nav2 parameter path "
            "(node.plugin.parameter, ros__parameters left out)"
        )
    segments = (("navigation", None), ("params_overrides", None), (parameter, None))
    return KeyPath(text.strip(), segments)


@dataclass(frozen=True)
class Distribution:
    """A random axis's distribution: its name and arguments."""

    name: str  # uniform | loguniform | normal | integers | choice
    arguments: tuple

    def draw(self, rng: np.random.Generator) -> Any:
        """One value, as a plain Python int, float or the chosen item."""
        a = self.arguments
        if self.name == "uniform":
            return float(rng.uniform(a[0], a[1]))
        if self.name == "loguniform":
            return float(math.exp(rng.uniform(math.log(a[0]), math.log(a[1]))))
        if self.name == "normal":
            return float(rng.normal(a[0], a[1]))
        if self.name == "integers":
            return int(rng.integers(a[0], a[1], endpoint=True))
        return a[0][int(rng.integers(len(a[0])))]  # choice

    def text(self) -> str:
        return f"{self.name}({', '.join(_yaml_scalar(x) for x in self.arguments)})"


_DISTRIBUTIONS = {  # name -> (argument count, check of the arguments, what is expected)
    "uniform": (2, lambda a: _numbers(a) and a[0] < a[1], "low < high"),
    "loguniform": (2, lambda a: _numbers(a) and 0 < a[0] < a[1], "0 < low < high"),
    "normal": (2, lambda a: _numbers(a) and a[1] > 0, "mean, std > 0"),
    "integers": (2, lambda a: all(type(x) is int for x in a) and a[0] <= a[1], "int low <= high"),
    "choice": (1, lambda a: isinstance(a[0], list) and len(a[0]) > 0, "a non-empty list"),
}


def _numbers(values) -> bool:
    return all(isinstance(x, int | float) and not isinstance(x, bool) for x in values)


@dataclass(frozen=True)
class Axis:
    """One axis of variation: a key path with grid values or a distribution."""

    key: KeyPath
    values: tuple = ()  # grid axis: its values in order
    distribution: Distribution | None = None  # random axis: what it draws from

    @property
    def name(self) -> str:
        return self.key.text


def _split_item(text: str, option: str) -> tuple[KeyPath, str]:
    key, sep, rhs = text.partition("=")
    if not sep or not key.strip() or not rhs.strip():
        raise SweepError(f"{option} {text!r} is not of the form KEY=VALUES")
    return KeyPath.parse(key, option), rhs.strip()


def _arguments(text: str, item: str, option: str) -> list:
    try:
        arguments = _load(f"[{text}]")
    except yaml.YAMLError as error:
        reason = " ".join(str(error).split())
        raise SweepError(f"{option} {item!r}: bad arguments: {reason}") from None
    return arguments


# The most values one grid axis may have, and the most variants a sweep may have: each
# variant is a world built and run (a second or more), so more would not end in a day
# on a machine of a few cores, and their list alone would fill the memory.
MAX_AXIS_VALUES = 100_000
MAX_VARIANTS = 100_000


def parse_grid(text: str) -> Axis:
    """A ``--grid KEY=VALUES`` item."""
    key, rhs = _split_item(text, "--grid")
    call = _CALL.match(rhs)
    if call and call[1] in ("linspace", "geomspace"):
        arguments = _arguments(call[2], text, "--grid")
        ok = len(arguments) == 3 and _numbers(arguments) and type(arguments[2]) is int
        if not ok or arguments[2] < 1 or (call[1] == "geomspace" and min(arguments[:2]) <= 0):
            raise SweepError(
                f"--grid {text!r}: {call[1]} takes (start, stop, count), count a positive "
                "integer" + (", start and stop positive" if call[1] == "geomspace" else "")
            )
        if arguments[2] > MAX_AXIS_VALUES:
            raise SweepError(
                f"--grid {text!r}: {arguments[2]:,} values, over {MAX_AXIS_VALUES:,} for one "
                "axis (each value is at least one run of a second or more)"
            )
        space = np.linspace if call[1] == "linspace" else np.geomspace
        values = tuple(float(v) for v in space(*arguments))
    else:
        try:
            parsed = _load(rhs)
        except yaml.YAMLError as error:
            raise SweepError(f"--grid {text!r}: not YAML: {' '.join(str(error).split())}") from None
        if not isinstance(parsed, list) or not parsed:
            raise SweepError(
                f"--grid {text!r}: the values must be a non-empty YAML list like [1, 2, 4], "
                "or linspace(start, stop, count) / geomspace(start, stop, count)"
            )
        values = tuple(parsed)
    return Axis(key=key, values=values)


def parse_random(text: str) -> Axis:
    """A ``--random KEY=DISTRIBUTION`` item."""
    key, rhs = _split_item(text, "--random")
    call = _CALL.match(rhs)
    known = ", ".join(f"{name}({expected})" for name, (_, _, expected) in _DISTRIBUTIONS.items())
    if not call or call[1] not in _DISTRIBUTIONS:
        raise SweepError(f"--random {text!r}: the distribution must be one of {known}")
    count, check, expected = _DISTRIBUTIONS[call[1]]
    arguments = _arguments(call[2], text, "--random")
    if len(arguments) != count or not check(arguments):
        raise SweepError(f"--random {text!r}: {call[1]} takes ({expected})")
    return Axis(key=key, distribution=Distribution(call[1], tuple(arguments)))


@dataclass
class Variant:
    """One combination of axis values."""

    index: int  # position in the sweep, from 0
    values: dict[str, Any] = field(default_factory=dict)  # key path text -> value
    keys: dict[str, KeyPath] = field(default_factory=dict)  # key path text -> parsed

    def overrides(self) -> list[str]:
        """The variant as ``--set`` YAML strings, one per top-level scenario key."""
        return override_yaml(
            {self.keys.get(k) or KeyPath.parse(k): v for k, v in self.values.items()}
        )

    @property
    def name(self) -> str:
        """A short description: ``actuators.kp=4 actuators.kd=0.1``."""
        return " ".join(f"{key}={_yaml_scalar(value)}" for key, value in self.values.items())


def _check_axes(axes: Sequence[Axis]) -> None:
    seen: dict[tuple[str, ...], Axis] = {}
    tags: dict[tuple[str, ...], tuple[str | None, Axis]] = {}
    for axis in axes:
        names = tuple(name for name, _ in axis.key.segments)
        for other_names, other in seen.items():
            shorter = min(len(names), len(other_names))
            if names[:shorter] == other_names[:shorter]:
                raise SweepError(
                    f"axes {other.name!r} and {axis.name!r} set the same scenario key; "
                    "give each key one axis"
                )
        seen[names] = axis
        for depth, (_, tag) in enumerate(axis.key.segments):
            prefix = names[: depth + 1]
            if prefix in tags and tags[prefix][0] != tag:
                raise SweepError(
                    f"axes {tags[prefix][1].name!r} and {axis.name!r} give "
                    f"{'.'.join(prefix)!r} different type tags"
                )
            tags[prefix] = (tag, axis)


def make_variants(
    grid: Sequence[Axis] = (), random: Sequence[Axis] = (), samples: int = 0, seed: int = 0
) -> list[Variant]:
    """Every combination of the grid values, times ``samples`` draws of the random axes."""
    if random and samples < 1:
        raise SweepError(f"--samples {samples}: a --random axis needs --samples 1 or more")
    if samples and not random:
        raise SweepError(f"--samples {samples} without a --random axis")
    if not grid and not random:
        raise SweepError("nothing to sweep: give at least one --grid or --random axis")
    axes = [*grid, *random]
    _check_axes(axes)
    count = math.prod(len(axis.values) for axis in grid) * max(samples, 1)
    if count > MAX_VARIANTS:
        raise SweepError(
            f"{count:,} variants, over {MAX_VARIANTS:,}: at a second or more each, at least "
            f"{count / 86400:,.1f} days of runs; sweep fewer values"
        )
    rng = np.random.default_rng(seed)
    draws = [[axis.distribution.draw(rng) for axis in random] for _ in range(samples)] or [[]]
    variants = []
    for point in itertools.product(*(axis.values for axis in grid)):
        for draw in draws:
            values = dict(zip([axis.name for axis in axes], [*point, *draw], strict=True))
            variants.append(
                Variant(
                    index=len(variants),
                    values=values,
                    keys={axis.name: axis.key for axis in axes},
                )
            )
    return variants


def _yaml_scalar(value: Any) -> str:
    """``value`` as YAML flow text that reads back to the same value (floats exactly)."""
    text = yaml.safe_dump(value, default_flow_style=True, width=math.inf, sort_keys=False)
    if text.endswith("\n...\n"):
        text = text[: -len("\n...\n")]
    return text.strip()


def override_yaml(values: Mapping[KeyPath, Any]) -> list[str]:
    """Nested YAML, one string per top-level key, that sets every key path to its value."""
    tree: dict = {}
    for key, value in values.items():
        node = tree
        for depth, (name, tag) in enumerate(key.segments):
            if depth == len(key.segments) - 1:
                node[(name, tag)] = value
            else:
                node = node.setdefault((name, tag), {})

    def emit(node: Any) -> str:
        if isinstance(node, dict) and node and isinstance(next(iter(node)), tuple):
            items = []
            for (name, tag), child in node.items():
                items.append(f"{name}: {'!' + tag + ' ' if tag else ''}{emit(child)}")
            return "{" + ", ".join(items) + "}"
        return _yaml_scalar(node)

    result = []
    for (name, tag), child in tree.items():
        result.append(f"{name}: {'!' + tag + ' ' if tag else ''}{emit(child)}")
    return result
