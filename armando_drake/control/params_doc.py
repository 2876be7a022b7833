"""The controller parameters, as the docs list them, generated from their declarations.

Each registered ROS 2 controller type's parameters dataclass becomes one markdown
table: the ROS parameter name (``constraints.goal_time`` where the dataclass
keeps a flat field), its type, its default, what it accepts (the rule declared with
:func:`~armando_drake.tools.schema.param`: unit, range, choices, required, ...: the
rule the YAML loader checks) and the field's comment (its meaning); then the
upstream parameters the type declares and the simulation ignores
(each ignored with a warning: it would not change the motion), and those it refuses,
with the reason. A parameter upstream (Jazzy) does not declare is in no table: it is
ignored with a warning, as ROS ignores it. The docs' reference page "Controller
parameters" is this block, made at each build of the site by ``docs/hooks.py``
(``tests/control/test_params_doc.py`` checks it); ``--write`` replaces the block between
:data:`BEGIN` and :data:`END` of any markdown file::

    python -m armando_drake.control.params_doc            # prints the block
    python -m armando_drake.control.params_doc --write FILE.md
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import math
import re
import sys
import typing
from pathlib import Path

from armando_drake.control.controllers import lookup, registered_types
from armando_drake.tools.schema import field_rules, rule_text

BEGIN = "<!-- controller-parameters:begin (python -m armando_drake.control.params_doc) -->"
END = "<!-- controller-parameters:end -->"

_FIELD_LINE = re.compile(r"^\s*(\w+)\s*:\s*[^=]+(=.*)?$")


def field_comments(schema: type) -> dict[str, str]:
    """Each field's comment: the ``#`` lines right above it in the class source."""
    comments: dict[str, str] = {}
    for cls in reversed(schema.__mro__):
        if not dataclasses.is_dataclass(cls):
            continue
        pending: list[str] = []
        for line in inspect.getsource(cls).splitlines():
            stripped = line.strip()
            if stripped.startswith("#"):
                pending.append(stripped.lstrip("#").strip())
                continue
            match = _FIELD_LINE.match(line.split("  #")[0])
            if match and "  #" in line:
                pending.append(line.split("  #", 1)[1].strip())
            if match and pending:
                comments[match.group(1)] = " ".join(pending)
            if stripped:
                pending = []
    return comments


def _type_name(annotation) -> str:
    origin = typing.get_origin(annotation)
    if origin is None:
        return getattr(annotation, "__name__", str(annotation))
    arguments = ", ".join(_type_name(argument) for argument in typing.get_args(annotation))
    name = "|" if origin is typing.Union or str(origin) == "<class 'types.UnionType'>" else None
    if name:
        return " | ".join(_type_name(argument) for argument in typing.get_args(annotation))
    return f"{getattr(origin, '__name__', str(origin))}[{arguments}]"


def _default(value) -> str:
    if isinstance(value, float) and math.isinf(value):
        return ".inf" if value > 0 else "-.inf"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, dict) and not value:
        return "{}"
    return str(value)


def parameter_rows(schema: type, prefix: str = "") -> list[tuple[str, str, str, str, str]]:
    """(ROS name, type, default, what it accepts, meaning) of every parameter of
    ``schema``: what it accepts is its declaration's rule (unit, range, choices, ...:
    :func:`~armando_drake.tools.schema.param`), the meaning the comment above it."""
    ros_names = getattr(schema, "ROS_NAMES", {})
    comments = field_comments(schema)
    rules = field_rules(schema)
    defaults = schema()
    hints = typing.get_type_hints(schema)
    rows = []
    for field in dataclasses.fields(schema):
        name = prefix + ros_names.get(field.name, field.name)
        annotation = hints[field.name]
        arguments = typing.get_args(annotation)
        inner = arguments[-1] if typing.get_origin(annotation) is dict else annotation
        if dataclasses.is_dataclass(inner):
            rows += parameter_rows(
                inner, f"{name}.<joint>." if inner is not annotation else f"{name}."
            )
            continue
        if "<joint>" in name and inner is not annotation:
            annotation = inner  # one value per joint
        meaning = comments.get(field.name, "")
        default = getattr(defaults, field.name)
        if "<joint>" in name and isinstance(default, dict):
            default = 0.0  # a joint left out
        rule = rules.get(field.name)
        rows.append((name, _type_name(annotation), _default(default), rule_text(rule), meaning))
    return rows


def _escape(text: str) -> str:
    return text.replace("|", "\\|")


def render() -> str:
    """The markdown block: one table per parameters class, every ROS 2 type using it."""
    groups: dict[type, list[str]] = {}
    refused: dict[type, dict[str, str]] = {}
    ignored: dict[type, set[str]] = {}
    for type_name in registered_types():
        cls = lookup(type_name)
        groups.setdefault(cls.parameters, []).append(type_name)
        refused.setdefault(cls.parameters, {}).update(cls.refused_parameters)
        ignored.setdefault(cls.parameters, set()).update(cls.ignored_parameters)
    lines = [BEGIN, ""]
    for schema, type_names in groups.items():
        lines.append(", ".join(f"`{name}`" for name in type_names) + ":")
        lines.append("")
        lines.append("| parameter | type | default | accepts | meaning |")
        lines.append("|---|---|---|---|---|")
        for name, type_, default, accepts, meaning in parameter_rows(schema):
            lines.append(
                f"| `{_escape(name)}` | `{_escape(type_)}` | `{_escape(default)}` | "
                f"{_escape(accepts)} | {_escape(meaning)} |"
            )
        if ignored[schema]:
            lines.append("")
            lines.append(
                "Declared upstream, not simulated (ignored with a warning): "
                + ", ".join(f"`{name}`" for name in sorted(ignored[schema]))
                + "."
            )
        if refused[schema]:
            lines.append("")
            lines.append(
                "Refused: "
                + "; ".join(f"`{name}` ({reason})" for name, reason in refused[schema].items())
                + "."
            )
        lines.append("")
    lines.append(END)
    return "\n".join(lines)


def replace_block(text: str, block: str) -> str:
    """``text`` with its block between BEGIN and END replaced by ``block``."""
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        raise ValueError(f"no {BEGIN!r} ... {END!r} block")
    return text[:start] + block + text[end + len(END) :]


def main(argv: list[str] | None = None) -> int:
    """Prints the controller parameter tables, or writes them into a markdown file."""
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--write", type=Path, help="the markdown file to update in place")
    args = parser.parse_args(argv)
    block = render()
    if args.write is None:
        sys.stdout.write(block + "\n")
        return 0
    args.write.write_text(replace_block(args.write.read_text(encoding="utf-8"), block), "utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
