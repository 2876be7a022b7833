"""A Nav2 parameter file read once: its mapping, the scenario's overrides applied to it.

:func:`read_nav2` reads the YAML of ``navigation.params_file`` and applies
``navigation.params_overrides`` to the parsed mapping (:func:`.overrides.apply_overrides`);
the planner server, the controller server, the behaviour server, the costmaps and AMCL
each take their node from the one :class:`Nav2Params` it returns, and every message names
the user's file (``<file>: controller_server.ros__parameters.FollowPath.<key>``).

The loaders of this package take a :class:`Nav2Params` or a path (read then, without
overrides): :func:`as_nav2`. :func:`fill` sets a parameter dataclass's fields from a
node's keys, each value of its field's type, and checks them with the fields' declared
rules (the schema's, the file and key named).
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from armando_drake.navigation.overrides import apply_overrides
from armando_drake.tools.errors import ConfigError
from armando_drake.tools.files import read_text_file
from armando_drake.tools.schema import field_rules, problem_of

ROS = "ros__parameters"


@dc.dataclass(frozen=True)
class Nav2Params:
    """A Nav2 YAML as parsed (overrides applied), and the file it came from."""

    path: Path
    doc: dict

    def node(self, *names: str) -> dict | None:
        """``<names...>.ros__parameters`` (e.g. ``"global_costmap", "global_costmap"``), or
        None when the file has no such node."""
        node: Any = self.doc
        for name in names:
            node = node.get(name) if isinstance(node, dict) else None
        ros = node.get(ROS) if isinstance(node, dict) else None
        return ros if isinstance(ros, dict) else None

    def where(self, *names: str) -> str:
        """The messages' prefix for a node: ``<file>: <names>.ros__parameters``."""
        return f"{self.path}: {'.'.join(names)}.{ROS}"

    def required(self, name: str) -> dict:
        """``<name>.ros__parameters``; a ConfigError naming the file without it."""
        ros = self.node(name)
        if ros is None:
            raise ConfigError(f"{self.path}: {name}.{ROS}: missing (no {name} in the file)")
        return ros


def read_yaml(path: Path) -> dict:
    """A YAML file's mapping ({} when it is not one); a one-line error naming it."""
    try:
        doc = yaml.safe_load(read_text_file(path, what="a parameter file"))
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a YAML parameter file (not UTF-8 text)") from None
    except (OSError, yaml.YAMLError) as error:
        raise ConfigError(f"{path}: cannot be read ({' '.join(str(error).split())})") from None
    if doc is not None and not isinstance(doc, dict):
        raise ConfigError(
            f"{path}: a parameter file is a mapping of nodes, not {type(doc).__name__}"
        )
    return doc or {}


def read_nav2(path: str | Path, overrides: Mapping[str, float] | None = None, where: str = ""):
    """The Nav2 file ``path`` parsed, ``overrides`` (dotted keys) applied to the mapping."""
    path = Path(path)
    doc = read_yaml(path)
    if overrides:
        apply_overrides(doc, overrides, f"{where}navigation.params_overrides.", path)
    return Nav2Params(path, doc)


def as_nav2(source: Nav2Params | str | Path) -> Nav2Params:
    """``source`` itself, or the file it names read (no overrides)."""
    return source if isinstance(source, Nav2Params) else read_nav2(source)


def fill(params, node: Mapping, where: str, keys=None) -> list[str]:
    """``params``' fields set from ``node``'s keys (all fields, or ``keys``), each of its
    field's type (a bool from true/false, a number from a number) and checked by its
    declared rule (:func:`~armando_drake.tools.schema.problem_of`, the checker's own
    test): a wrong one is a ConfigError ``<where>.<key>=<value> <problem>``. Returns the
    keys of ``node`` that are not fields."""
    rules = field_rules(type(params))
    names = set(rules) if keys is None else set(keys)
    for key in node:
        if key in names:
            _set(params, key, node[key], where)
            problem = problem_of(rules.get(key), getattr(params, key))
            if problem:
                raise ConfigError(f"{where}.{key}{problem}")
    return [key for key in node if key not in names]


def _set(params, key: str, value, where: str) -> None:
    default = getattr(params, key)
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"{where}.{key}={value!r} must be true or false")
    elif isinstance(default, (int, float)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where}.{key}={value!r} must be a number")
        value = float(value) if isinstance(default, float) else value
    setattr(params, key, value)
