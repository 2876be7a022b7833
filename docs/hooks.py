"""MkDocs hook: the reference pages generated from the code, at every build.

``mkdocs.yml`` names this file under ``hooks:``. Its ``on_files`` adds three pages that
exist only in the built site, so they cannot go stale:

- ``reference/cli.md``: every command's ``--help``, as the command prints it;
- ``reference/scenario-keys.md``: every scenario key, from the dataclasses of
  ``armando_drake/simulation/scenario.py`` (type, default, unit and range from
  ``tools.schema.param``, meaning from the comment above the field);
- ``reference/controller-parameters.md``: every controller type's parameters
  (``armando_drake.control.params_doc``);
- ``reference/navigation-parameters.md``: the Nav2 parameters of the implemented plugins,
  honoured or not (``armando_drake.navigation.reference``).

``python docs/hooks.py DIR`` writes the four pages into DIR, to read them without a build.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import io
import os
import sys
import types
import typing
from pathlib import Path

# The checkout these docs belong to, before any installed copy of the package.
REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from armando_drake.control import params_doc  # noqa: E402
from armando_drake.navigation import reference as navigation_reference  # noqa: E402
from armando_drake.simulation.scenario import Scenario  # noqa: E402
from armando_drake.tools.schema import field_rules, rule_text  # noqa: E402

# (module, arguments before --help, title) of every command, in the order of the page.
COMMANDS = [
    ("world", [], "Run a world"),
    ("display", [], "Look at a robot"),
    ("graph", [], "Draw the world diagram"),
    ("plots", [], "Redraw the plots of a run"),
    ("sweep", [], "Many runs of a scenario"),
    ("dataset", [], "Data sets"),
    ("dataset", ["ik"], "The inverse-kinematics data set"),
    ("bench", [], "The benchmark suite"),
]
# argparse wraps the help at the terminal's width: a fixed one for the page.
HELP_COLUMNS = "100"


def help_text(module: str, arguments: list[str]) -> str:
    """What ``python -m armando_drake.<module> <arguments> --help`` prints."""
    command = importlib.import_module(f"armando_drake.{module}")
    out = io.StringIO()
    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_COLUMNS
    try:
        with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
            command.main([*arguments, "--help"])
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns
    return out.getvalue().rstrip()


def cli_page() -> str:
    lines = [
        "# Command-line reference",
        "",
        "Generated at each build of these pages from the commands' own `--help`. Every",
        "command is also installed as a console script: `armando-world`, `armando-display`,",
        "`armando-graph`, `armando-plots`, `armando-sweep`, `armando-dataset`, `armando-bench`.",
        "Exit codes and the one-line errors: [Input checks and exit codes](errors.md).",
        "",
    ]
    for module, arguments, title in COMMANDS:
        command = " ".join(["python -m", f"armando_drake.{module}", *arguments])
        lines += [f"## {title}: `{command}`", "", "```text", help_text(module, arguments)]
        lines += ["```", ""]
    return "\n".join(lines)


def _type_name(annotation) -> str:
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        tagged = len(_members(annotation)) > 1
        return " | ".join(
            f"!{a.__name__}" if tagged and dataclasses.is_dataclass(a) else _type_name(a)
            for a in typing.get_args(annotation)
        )
    if origin is None:
        if annotation is type(None):
            return "null"
        return getattr(annotation, "__name__", str(annotation))
    arguments = ", ".join(_type_name(a) for a in typing.get_args(annotation))
    return f"{getattr(origin, '__name__', str(origin))}[{arguments}]"


def _default(value) -> str:
    if dataclasses.is_dataclass(value) or hasattr(type(value), "__fields__"):
        return ""
    if isinstance(value, float) and value in (float("inf"), float("-inf")):
        return ".inf" if value > 0 else "-.inf"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if value is None:
        return "null"
    if isinstance(value, list) and value and dataclasses.is_dataclass(value[0]):
        return f"{len(value)} entries"
    return str(value)


def _meaning(schema, name: str) -> str:
    """The comment above a dataclass field, or the first paragraph of a Drake struct
    property's docstring."""
    if dataclasses.is_dataclass(schema):
        try:
            return params_doc.field_comments(schema).get(name, "")
        except (OSError, TypeError):
            return ""
    doc = getattr(getattr(schema, name, None), "__doc__", None) or ""
    return " ".join(doc.split("\n\n", 1)[0].split()) if not doc.startswith("(self") else ""


def _escape(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _members(annotation) -> list[type]:
    """The dataclass members of a Union or Optional field type."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return [a for a in typing.get_args(annotation) if dataclasses.is_dataclass(a)]
    return []


def _fields(schema) -> list[tuple[str, object]]:
    """(name, annotation) of a dataclass's or Drake struct's fields."""
    if dataclasses.is_dataclass(schema):
        hints = typing.get_type_hints(schema)
        return [(f.name, hints[f.name]) for f in dataclasses.fields(schema) if f.name[0] != "_"]
    return [(f.name, f.type) for f in getattr(schema, "__fields__", ())]


def _nested(annotation):
    """The dataclass or Drake struct a field holds (directly, in a list or as dict
    values), the key suffix that reaches it, and its tagged variants."""
    origin = typing.get_origin(annotation)
    if origin is list:
        inner, suffix = typing.get_args(annotation)[0], "[]"
    elif origin is dict:
        inner, suffix = typing.get_args(annotation)[-1], ".<name>"
    else:
        inner, suffix = annotation, ""
    members = _members(inner)
    if len(members) > 1:
        return None, suffix, members
    if len(members) == 1:
        inner = members[0]
    if dataclasses.is_dataclass(inner) or hasattr(inner, "__fields__"):
        return inner, suffix, []
    return None, suffix, []


def _instance(schema):
    try:
        return schema()
    except TypeError:
        return None


def key_rows(schema, default, prefix: str) -> list[tuple[str, str, str, str, str]]:
    """(key, type, default, accepts, meaning) of every leaf under ``schema``."""
    rows = []
    rules = field_rules(schema)
    for name, annotation in _fields(schema):
        key = f"{prefix}{name}"
        value = getattr(default, name, None) if default is not None else None
        inner, suffix, variants = _nested(annotation)
        meaning = _meaning(schema, name)
        if variants:
            rows.append((key + suffix, _type_name(annotation), _default(value), "", meaning))
            for variant in variants:
                current = value if type(value) is variant else _instance(variant)
                rows += key_rows(variant, current, f"{key}{suffix} !{variant.__name__}: ")
            continue
        if inner is not None:
            if suffix or value is None:
                current = _instance(inner)
                rows.append((key + suffix, _type_name(annotation), _default(value), "", meaning))
            else:
                current = value
            rows += key_rows(inner, current, f"{key}{suffix}.")
            continue
        rule = rules.get(name)
        rows.append((key, _type_name(annotation), _default(value), rule_text(rule), meaning))
    return rows


def scenario_keys_page() -> str:
    lines = [
        "# Scenario keys",
        "",
        "Generated at each build of these pages from the dataclasses of",
        "`armando_drake/simulation/scenario.py` and the sections they hold: every key a",
        "scenario file (or `--set`) may give, its type, its default in a scenario that does",
        "not give it, what it accepts (unit, range, choices; checked before Drake sees the",
        "value, see [Input checks](errors.md)) and the comment beside it in the code. A",
        "`[]` in a key is each item of a list, `<name>` each key of a mapping, and",
        "`key !Tag: field` a field of the variant a YAML tag chooses (`sequencer: !Sinusoid",
        "{frequency: 0.1}`). How scenarios are read and overridden:",
        "[Scenarios](scenarios.md).",
        "",
    ]
    scenario = Scenario()
    comments = params_doc.field_comments(Scenario)
    for name, annotation in _fields(Scenario):
        lines += [f"## `{name}`", "", comments.get(name, ""), ""]
        rows = _section_rows(name, annotation, getattr(scenario, name))
        lines += ["| key | type | default | accepts | meaning |", "|---|---|---|---|---|"]
        for key, type_, default, accepts, meaning in rows:
            default = f"`{_escape(default)}`" if default else ""
            lines.append(
                f"| `{_escape(key)}` | `{_escape(type_)}` | {default} | {_escape(accepts)} | "
                f"{_escape(meaning)} |"
            )
        lines.append("")
    return "\n".join(lines)


def _section_rows(name: str, annotation, value) -> list[tuple[str, str, str, str, str]]:
    """The rows of one top-level scenario key."""
    rule = field_rules(Scenario).get(name)
    inner, suffix, variants = _nested(annotation)
    row = (name + suffix, _type_name(annotation), _default(value), rule_text(rule), "")
    if variants:
        rows = [row]
        for variant in variants:
            current = value if type(value) is variant else _instance(variant)
            rows += key_rows(variant, current, f"{name}{suffix} !{variant.__name__}: ")
        return rows
    if inner is None:
        return [row]
    if suffix or value is None:
        return [row, *key_rows(inner, _instance(inner), f"{name}{suffix}.")]
    return key_rows(inner, value, f"{name}.")


def controller_parameters_page() -> str:
    block = params_doc.render()
    return "\n".join(
        [
            "# Controller parameters",
            "",
            "Generated at each build of these pages from the parameter dataclasses of the",
            "registered controller types (`armando_drake/control/params_doc.py`; `python -m",
            "armando_drake.control.params_doc` prints the same tables). The parameters each",
            "controller type reads from its `ros__parameters`, with their ROS names, types,",
            "defaults and meanings; how the controllers behave:",
            "[Controllers](controllers.md).",
            "",
            block,
            "",
        ]
    )


def navigation_parameters_page() -> str:
    return "\n".join(
        [
            "# Navigation parameters",
            "",
            "Generated at each build of these pages from the tables the Nav2 YAML loaders use",
            "(`armando_drake/navigation/reference.py`; `python -m",
            "armando_drake.navigation.reference` prints the same tables). For each implemented",
            "node and plugin, every parameter the loaders know: *honoured* (applied as Nav2",
            "does), *accepted, no effect here* (read without a warning: frames, topics, rates",
            "of a ROS node) or *warned: not applied* (a warning names it, with why). A key in",
            "none of these is warned about as not used. How the navigation works:",
            "[Navigation](../navigation.md).",
            "",
            navigation_reference.render(),
        ]
    )


PAGES = {
    "reference/cli.md": cli_page,
    "reference/scenario-keys.md": scenario_keys_page,
    "reference/controller-parameters.md": controller_parameters_page,
    "reference/navigation-parameters.md": navigation_parameters_page,
}


def on_files(files, config):
    """MkDocs event: the generated pages join the site's files."""
    from mkdocs.structure.files import File

    for path, make in PAGES.items():
        files.append(File.generated(config, path, content=make()))
    return files


if __name__ == "__main__":
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    for path, make in PAGES.items():
        (folder / path).parent.mkdir(parents=True, exist_ok=True)
        (folder / path).write_text(make() + "\n")
        print(folder / path)
