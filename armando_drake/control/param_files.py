"""ROS parameter files as ROS reads them, before any controller looks at them.

ROS 2 (``rcl_yaml_param_parser``, then ``rclcpp``'s overrides):

- each top-level key names a node, fully qualified (``/ns/controller_manager``) or
  not (``controller_manager`` is ``/controller_manager``), with wildcards: ``/*`` one
  namespace level, ``/**`` any number (``/**/controller_manager``, ``/**`` alone:
  every node). Mappings above ``ros__parameters`` are namespaces joined with ``/``
  (``/**: {controller_manager: {ros__parameters: ...}}``);
- a node key given again (in the same file or in a later one) is the same node:
  its parameters are merged, a later value replacing an earlier one;
- several files (``--param-file a.yaml --param-file b.yaml``) are read in order, the
  later winning;
- a node takes the parameters of every key that matches its name, in the order the
  keys first appear, a later key's value replacing an earlier one's;
- parameter names with dots (``constraints.goal_time``) are nested mappings;
- ``$(var name)``, as a launch file's ``ParameterFile(..., allow_substs=True)``
  replaces it, is the launch argument's value (:func:`substitute`).

ROS 1 (``rosparam load``): each file is a tree of namespaces loaded in turn into
one parameter tree; a mapping given again is merged (:func:`merge_trees`).

A YAML mapping that gives a key twice is merged the same way (the later values
win), as the ROS parsers do, where the project's other YAML files refuse it.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from armando_drake.description.packages import package_of
from armando_drake.tools.errors import UserInputError
from armando_drake.tools.files import read_yaml_file

_logger = logging.getLogger("armando_drake.control.config")

PARAMETERS_KEY = "ros__parameters"


class ParamFileError(UserInputError, ValueError):
    """A parameter file that cannot be read, with the file (and line or key) at fault."""


# --------------------------------------------------------------------------------------
# Reading


class _MergingLoader(yaml.SafeLoader):
    """PyYAML's safe loader, but a key given twice in a mapping is merged into the
    first: two mappings deep-merged, otherwise the later value kept."""

    def construct_mapping(self, node, deep=False):
        if not isinstance(node, yaml.MappingNode):
            return super().construct_mapping(node, deep=deep)
        self.flatten_mapping(node)
        mapping: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping",
                    node.start_mark,
                    "found unhashable key",
                    key_node.start_mark,
                ) from None
            value = self.construct_object(value_node, deep=True)
            if isinstance(value, dict) and isinstance(mapping.get(key), dict):
                merge_into(mapping[key], value)
            else:
                mapping[key] = value
        return mapping


_MergingLoader.add_constructor(
    "tag:yaml.org,2002:map", lambda loader, node: loader.construct_mapping(node)
)


def merge_into(into: dict[Any, Any], other: dict[Any, Any]) -> None:
    """Deep-merges ``other`` into ``into``: mappings merged, other values replaced."""
    for key, value in other.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            merge_into(into[key], value)
        else:
            into[key] = value


def read_param_file(path: str | Path, arguments: dict[str, str] | None = None) -> Any:
    """The YAML data of the parameter file ``path``: ``$(var name)`` replaced first
    (:func:`substitute` with ``arguments``), repeated keys merged. Errors name the file
    (and the line)."""
    path = Path(path)
    try:
        text = read_yaml_file(path, what="a controller file")
    except OSError as error:
        raise ParamFileError(f"{path}: cannot read controller file: {error.strerror}") from None
    except UnicodeDecodeError as error:
        raise ParamFileError(
            f"{path}: not a text (UTF-8) YAML file: byte {error.start} is "
            f"{error.object[error.start]:#x}"
        ) from None
    if _VAR.search(text):
        # The launch files of the file's package give the defaults; ``arguments`` win.
        arguments = {**launch_defaults(package_of(path)), **(arguments or {})}
        text = substitute(text, arguments, str(path))
    try:
        return yaml.load(text, Loader=_MergingLoader)  # noqa: S506 (a SafeLoader)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        problem = getattr(error, "problem", None) or str(error)
        raise ParamFileError(f"{where}: not valid YAML: {problem}") from None


_VAR = re.compile(r"\$\(\s*var\s+([A-Za-z_][\w.-]*)\s*\)")


def substitute(text: str, arguments: dict[str, str], source: str) -> str:
    """``text`` with each ``$(var name)`` replaced by ``arguments[name]``; a name without
    a value is an error naming the file, its line and the name."""

    def value(match: re.Match) -> str:
        name = match.group(1)
        if name not in arguments:
            line = text.count("\n", 0, match.start()) + 1
            known = ", ".join(sorted(arguments)) or "none"
            raise ParamFileError(
                f"{source}:{line}: $(var {name}): no value for launch argument {name!r} "
                f"(give it in controllers.arguments; known: {known})"
            )
        return str(arguments[name])

    return _VAR.sub(value, text)


_LAUNCH_PY = re.compile(
    r"DeclareLaunchArgument\(\s*(?:name\s*=\s*)?[\"']([\w.-]+)[\"']"
    r"(?:[^()]|\([^()]*\))*?default_value\s*=\s*[\"']([^\"']*)[\"']",
    re.S,
)
_LAUNCH_XML = re.compile(r"<arg\s+name=[\"']([\w.-]+)[\"']\s+default=[\"']([^\"']*)[\"']")
_LAUNCH_YAML = re.compile(
    r"-\s*arg:\s*\n\s*name:\s*[\"']?([\w.-]+)[\"']?\s*\n\s*default:\s*[\"']?([^\"'\n]*)"
)


def launch_defaults(folder: Path | None, limit: int = 200) -> dict[str, str]:
    """The default value of every launch argument the launch files under ``folder``
    declare (``DeclareLaunchArgument("name", default_value="...")``, XML ``<arg
    name default>``, YAML ``arg: {name, default}``); the first declaration of a name
    wins. At most ``limit`` files are read."""
    if folder is None or not folder.is_dir():
        return {}
    found: dict[str, str] = {}
    files = sorted(
        p
        for pattern in ("*.launch.py", "*.launch.xml", "*.launch.yaml", "*launch*.py")
        for p in folder.rglob(pattern)
        if "test" not in p.parts
    )
    for path in list(dict.fromkeys(files))[:limit]:
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            continue
        pattern = _LAUNCH_PY if path.suffix == ".py" else None
        pattern = pattern or (_LAUNCH_XML if path.suffix == ".xml" else _LAUNCH_YAML)
        for name, default in pattern.findall(text):
            found.setdefault(name, default)
    return found


# --------------------------------------------------------------------------------------
# ROS 2: node keys


def unflatten(params: Any, where: str) -> dict[str, Any]:
    """ROS dotted names (``constraints.goal_time``) as nested mappings; ``where`` names
    the mapping in errors."""
    if params is None:
        return {}
    if not isinstance(params, dict):
        raise ParamFileError(f"{where}: expected a mapping, got {params!r}")
    result: dict[str, Any] = {}
    for name, value in params.items():
        name = str(name)
        if isinstance(value, dict):
            value = unflatten(value, f"{where}.{name}")
        *parents, leaf = name.split(".")
        target = result
        for parent in parents:
            target = target.setdefault(parent, {})
            if not isinstance(target, dict):
                raise ParamFileError(f"{where}.{name}: conflicts with a parameter of the same name")
        if isinstance(value, dict) and isinstance(target.get(leaf), dict):
            merge_into(target[leaf], value)
        else:
            target[leaf] = value
    return result


@dataclass
class NodeEntry:
    """One node key of the files, its parameters merged over every place it is given."""

    pattern: str  # the fully qualified node name, with wildcards: "/**/controller_manager"
    key: str  # where it is first written, for messages: "/**/controller_manager.ros__parameters"
    file: str  # the file it is first written in
    params: dict[str, Any] = field(default_factory=dict)
    # Top-level parameter -> (file, key) of the place that set it last.
    origins: dict[str, tuple[str, str]] = field(default_factory=dict)

    @property
    def wildcard(self) -> bool:
        return "*" in self.pattern

    @property
    def basename(self) -> str:
        return self.pattern.rsplit("/", 1)[-1]

    @property
    def namespace(self) -> str:
        return self.pattern.rsplit("/", 1)[0]

    def matches(self, fqn: str) -> bool:
        """Whether the node named ``fqn`` (``/ns/name``) takes these parameters."""
        return _pattern_regex(self.pattern).fullmatch(fqn) is not None


def normalize_node_name(path: str) -> str:
    """A node key as a fully qualified name: ``controller_manager`` ->
    ``/controller_manager``, ``/**/`` + ``arm`` -> ``/**/arm``."""
    name = re.sub("/+", "/", "/" + path.strip("/"))
    return name.rstrip("/") or "/"


def _pattern_regex(pattern: str) -> re.Pattern:
    """rclcpp's wildcards: ``/**`` any number of namespace levels, ``/*`` one."""
    parts = re.split(r"(/\*\*|/\*)", pattern)
    regex = "".join(
        r"(/[^/]+)*" if part == "/**" else r"/[^/]+" if part == "/*" else re.escape(part)
        for part in parts
    )
    return re.compile(regex)


def collect_nodes(data: Any, source: str, entries: dict[str, NodeEntry]) -> None:
    """Adds the node keys of the ROS 2 parameter file ``data`` (read from ``source``) to
    ``entries`` (pattern -> entry, in first-appearance order), merging a key given
    again."""
    if data is None:
        return
    if not isinstance(data, dict):
        raise ParamFileError(f"{source}: expected a mapping of ROS nodes, got {data!r}")
    _collect(data, source, [], entries)


def _collect(data: dict, source: str, path: list[str], entries: dict[str, NodeEntry]) -> None:
    for raw_key, value in data.items():
        key = str(raw_key)
        here = [*path, key]
        written = "/".join(here)
        if not isinstance(value, dict):
            raise ParamFileError(
                f"{source}: {written}: expected a node or namespace mapping, got {value!r}"
            )
        if PARAMETERS_KEY not in value:
            _collect(value, source, here, entries)
            continue
        extra = sorted(str(k) for k in value if k != PARAMETERS_KEY)
        if extra:
            raise ParamFileError(
                f"{source}: {written}.{extra[0]}: a node holds only '{PARAMETERS_KEY}'"
            )
        where = f"{written}.{PARAMETERS_KEY}"
        try:
            params = unflatten(value[PARAMETERS_KEY], where)
        except ParamFileError as error:
            raise ParamFileError(f"{source}: {error}") from None
        pattern = normalize_node_name(written)
        entry = entries.get(pattern)
        if entry is None:
            entry = entries[pattern] = NodeEntry(pattern, where, source)
        merge_into(entry.params, params)
        for name in params:
            entry.origins[name] = (source, where)


@dataclass
class NodeParameters:
    """The parameters a node takes from every key that matches its name."""

    fqn: str  # the node: "/controller_manager", "/ns/arm_controller"
    params: dict[str, Any] = field(default_factory=dict)
    origins: dict[str, tuple[str, str]] = field(default_factory=dict)
    entries: list[NodeEntry] = field(default_factory=list)  # the keys that matched

    @property
    def found(self) -> bool:
        return bool(self.entries)

    def where(self, parameter: str = "") -> tuple[str, str]:
        """(file, node key) of the place that set ``parameter`` (dotted), else of the
        node's most specific key (one without wildcards), else of its first."""
        top = parameter.split(".")[0]
        if top in self.origins:
            return self.origins[top]
        concrete = [entry for entry in self.entries if not entry.wildcard]
        entry = (concrete or self.entries or [None])[0]
        if entry is None:
            return "", f"{self.fqn.lstrip('/')}.{PARAMETERS_KEY}"
        return entry.file, entry.key


def node_parameters(entries: dict[str, NodeEntry], fqn: str) -> NodeParameters:
    """The parameters of the node ``fqn``: every matching key's, in order."""
    result = NodeParameters(fqn)
    for entry in entries.values():
        if entry.matches(fqn):
            merge_into(result.params, _copy(entry.params))
            result.origins.update(entry.origins)
            result.entries.append(entry)
    return result


def _copy(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_copy(v) for v in value]
    return value


# --------------------------------------------------------------------------------------
# ROS 1: one parameter tree


def merge_trees(documents: list[tuple[str, Any]]) -> tuple[dict[str, Any], dict[str, str]]:
    """The ROS 1 parameter files ``documents`` ((file, data) in load order) as one tree,
    as ``rosparam load`` of each in turn leaves it, and which file last set each
    mapping (by its ``/``-joined path)."""
    tree: dict[str, Any] = {}
    origins: dict[str, str] = {}
    for source, data in documents:
        if data is None:
            continue
        if not isinstance(data, dict):
            raise ParamFileError(f"{source}: expected a mapping of parameters, got {data!r}")
        _note_origins(data, source, "", origins)
        merge_into(tree, _copy(data))
    return tree, origins


def _note_origins(data: dict, source: str, path: str, origins: dict[str, str]) -> None:
    for key, value in data.items():
        where = f"{path}/{key}" if path else str(key)
        if isinstance(value, dict):
            origins[where] = source
            _note_origins(value, source, where, origins)
