"""Config schemas: each field's unit, range and choices beside it, and one checker.

A config dataclass declares a field with :func:`param`, which returns a
``dataclasses.field`` carrying a :class:`Rule` in its metadata; the comment above the
field keeps its meaning::

    @dataclass
    class Camera:
        # Frame rate.
        update_rate: float = param(30.0, unit="Hz", gt=0)
        # Position of the sensor in the link.
        xyz: list[float] = param([0.0, 0.0, 0.0], unit="m", length=3, coordinate=True)

``yaml_load_typed`` reads such a dataclass as any other (the metadata is invisible to
it). Drake's own config structs (``MultibodyPlantConfig``, ``SimulatorConfig``,
``VisualizationConfig``) are not ours to annotate: their rules are declared once in
:data:`DRAKE_SCHEMAS`, keyed by the struct's class and field name.

:func:`check_config` walks a value (dataclasses, Drake structs, lists, dicts) and raises
one-line errors ``<origin>: <key>=<value> <problem>``, the origin being where the key's
value came from (the scenario file, the ``--set`` that set it; ``origin(key)``). The
same declarations serve the scenario's sections, the ros2_control controllers'
parameters (read from their ``ros__parameters``; the YAML loader names the file and
the node key) and the robot description's sensor blocks. Every number must be finite
(unless ``infinite``); then each field's rule:

- ``gt``/``ge``/``lt``/``le``: the range (``must be positive``, ``must be zero or
  positive``, ``must be a whole number >= 1``, ``must be in [0, 1)``), followed by the
  unit; on a list field, the range of each item;
- ``choices``: the value is one of them (``is not one of 'a', 'b'``), followed by
  ``why`` when given; a callable gives them when checked (Drake's integration
  schemes); on a list field, each item is one of them;
- ``length``: the list has that many items (``must be 3 numbers``); ``item_names``
  names the items in messages (``Box x=-1.0``) instead of their index (``xyz.0``);
- ``coordinate``: each item is a coordinate [m] at most :data:`MAX_COORDINATE` from
  the origin;
- ``nonempty``: the list (or text) is not empty; ``unique``: no item of the list is
  listed twice (a list of joint names);
- ``infinite``: the number may be ``.inf`` or ``-.inf`` (a limit that is "none");
  ``nan``: it may be ``.nan`` (ros2_controllers' "no limit");
- ``required``: the key must be given (``True``, or the text of the error); checked
  when the caller passes what the file gave (``given``: a ROS parameter file's
  ``'joints' parameter is missing``);
- ``over``/``under``: a limit beyond which the value is valid but surely a mistake,
  with the reason (``time_step=1e-09 s is below 1e-05 s: a simulated second would
  take hours``).

Rules between fields ("min_points not above max_points", "an object listed twice")
are code, in one place per section: the dataclass's ``check(self)`` method, which the
checker calls once the section's own fields have passed. It raises :class:`Refusal`
with the dotted key (relative to the section) of the field at fault and the problem,
which begins with ``=<value>`` or ``: ``; the checker adds the origin and the label.

A dict field (a per-joint map, as ros2_controllers' ``gains.<joint>``) holds one value
per key: its rule applies to each value, as a list field's to each item.

Labels: a field is named by its dotted key (``actuators.kp``, ``cameras.0.near``). A
dataclass that is named otherwise in messages gives a ``message_prefix(self, parent,
name)`` method returning the text before its fields' names, from its parent's prefix
and its own name (a list item's name is its index): a perception step is
``steps[0] VoxelDownsample: ``, a scene object ``objects.0: object 'ball': ``.
"""

import copy
import dataclasses as dc
import math
import typing
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import GetIntegrationSchemes, SimulatorConfig
from pydrake.visualization import VisualizationConfig

from armando_drake.tools.errors import ConfigError

# The metadata key of a field's Rule.
SCHEMA = "armando_drake.schema"

# [m] the largest coordinate of a position accepted: farther, the double's precision
# (about 1e-12 of the value) is coarser than the contact and joint tolerances.
MAX_COORDINATE = 1e4
# [s] the shortest plant step accepted: below it a simulated second takes hours.
MIN_TIME_STEP = 1e-5


class Refusal(Exception):
    """Raised by a dataclass's ``check(self)``: the field at fault (a dotted key relative
    to the dataclass; "" for the dataclass itself) and the problem, beginning with
    ``=<value>`` or ``: ``. :func:`check_config` turns it into its error."""

    def __init__(self, key: str, problem: str):
        super().__init__(key, problem)
        self.key = key
        self.problem = problem


@dc.dataclass(frozen=True)
class Rule:
    """What a field accepts (see the module's docstring)."""

    unit: str = ""  # "m", "rad/s", "-" (no unit), ...
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: Sequence | Callable[[], Sequence] | None = None
    length: int | None = None
    coordinate: bool = False
    over: tuple[float, str] | None = None  # (limit, why a larger value is refused)
    under: tuple[float, str] | None = None  # (limit, why a smaller value is refused)
    item_names: tuple[str, ...] | None = None
    nonempty: bool = False
    unique: bool = False
    infinite: bool = False
    nan: bool = False  # NaN accepted: "none" (ros2_controllers' limits)
    required: bool | str = False  # True, or the text of the error when missing
    why: str = ""  # why a value outside the choices is refused (appended to the message)
    doc: str = ""

    def choice_list(self) -> tuple:
        """The choices, the callable's called."""
        choices = self.choices() if callable(self.choices) else self.choices
        return tuple(choices or ())

    def item_rule(self) -> "Rule":
        """The rule of each item of a list field (each value of a dict field): its range,
        choices and coordinate rule."""
        return dc.replace(
            self, length=None, item_names=None, nonempty=False, unique=False, required=False
        )


def param(
    default: Any = dc.MISSING,
    *,
    default_factory: Callable[[], Any] | Any = dc.MISSING,
    unit: str = "",
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    choices: Sequence | Callable[[], Sequence] | None = None,
    length: int | None = None,
    coordinate: bool = False,
    over: tuple[float, str] | None = None,
    under: tuple[float, str] | None = None,
    item_names: Sequence[str] | None = None,
    nonempty: bool = False,
    unique: bool = False,
    infinite: bool = False,
    nan: bool = False,
    required: bool | str = False,
    why: str = "",
    doc: str = "",
) -> Any:
    """A dataclass field whose metadata holds its :class:`Rule`. A list or dict
    ``default`` is copied for each instance (as a ``default_factory``)."""
    if isinstance(default, (list, dict)):
        default, default_factory = dc.MISSING, (lambda value=default: copy.deepcopy(value))
    rule = Rule(
        unit=unit,
        gt=gt,
        ge=ge,
        lt=lt,
        le=le,
        choices=tuple(choices) if isinstance(choices, (list, tuple)) else choices,
        length=length,
        coordinate=coordinate,
        over=over,
        under=under,
        item_names=tuple(item_names) if item_names is not None else None,
        nonempty=nonempty,
        unique=unique,
        infinite=infinite,
        nan=nan,
        required=required,
        why=why,
        doc=doc,
    )
    return dc.field(default=default, default_factory=default_factory, metadata={SCHEMA: rule})


# Drake's config structs: field name -> Rule, by struct.
DRAKE_SCHEMAS: dict[type, dict[str, Rule]] = {
    MultibodyPlantConfig: {
        "time_step": Rule(
            unit="s", gt=0, under=(MIN_TIME_STEP, "a simulated second would take hours")
        ),
        "penetration_allowance": Rule(unit="m", gt=0),
        "stiction_tolerance": Rule(unit="m/s", gt=0),
        "contact_model": Rule(choices=("point", "hydroelastic", "hydroelastic_with_fallback")),
        # Not "tamsi": it ignores the PD actuators' gains.
        "discrete_contact_approximation": Rule(choices=("", "sap", "similar", "lagged")),
        "sap_near_rigid_threshold": Rule(unit="-", ge=0),
        "contact_surface_representation": Rule(choices=("triangle", "polygon")),
    },
    SimulatorConfig: {
        "integration_scheme": Rule(choices=GetIntegrationSchemes),
        "max_step_size": Rule(unit="s", gt=0),
        "accuracy": Rule(unit="-", gt=0),
        "start_time": Rule(unit="s"),
        # Simulated over wall-clock time; 0 = as fast as possible.
        "target_realtime_rate": Rule(unit="-", ge=0),
    },
    VisualizationConfig: {
        "publish_period": Rule(unit="s", gt=0),
        "initial_proximity_alpha": Rule(unit="-"),
    },
}


def is_number(value: Any) -> bool:
    """An int or float, not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def is_drake_struct(value: Any) -> bool:
    """A Drake config struct (serializable, with ``__fields__``), not a dataclass."""
    return hasattr(type(value), "__fields__") and not dc.is_dataclass(value)


def field_rules(schema: type) -> dict[str, Rule | None]:
    """Field name -> its Rule (None: no rule) of a dataclass type or Drake struct type;
    fields whose names begin with "_" are left out."""
    if dc.is_dataclass(schema):
        return {
            f.name: f.metadata.get(SCHEMA) for f in dc.fields(schema) if not f.name.startswith("_")
        }
    if hasattr(schema, "__fields__"):
        rules = DRAKE_SCHEMAS.get(schema, {})
        return {f.name: rules.get(f.name) for f in schema.__fields__}
    return {}


def rule_at(root: Any, key: str) -> Rule | None:
    """The Rule of the field at the dotted ``key`` of ``root`` (an instance; list indices
    as numbers), None when it has none."""
    value, rule = root, None
    for part in key.split("."):
        if isinstance(value, (list, tuple)) and part.isdigit():
            value, rule = value[int(part)], rule.item_rule() if rule else None
        elif isinstance(value, dict):
            value, rule = value[part], None
        else:
            rule = field_rules(type(value)).get(part)
            value = getattr(value, part)
    return rule


def leaves(value: Any, key: str = "") -> Iterator[tuple[str, Any]]:
    """(dotted key, value) of everything inside ``value`` (dataclasses, Drake structs,
    dicts, lists: a list and then each item), depth first."""
    if dc.is_dataclass(value) and not isinstance(value, type) or is_drake_struct(value):
        for name in field_rules(type(value)):
            yield from leaves(getattr(value, name), f"{key}.{name}".lstrip("."))
    elif isinstance(value, dict):
        for name, item in value.items():
            yield from leaves(item, f"{key}.{name}")
    elif isinstance(value, (list, tuple)):
        yield key, value
        for index, item in enumerate(value):
            yield from leaves(item, f"{key}.{index}")
    else:
        yield key, value


def range_text(rule: Rule, value: Any = 0.0) -> str:
    """What the range of ``rule`` says: ``positive``, ``in [0, 1)``, ... ("" for none)."""
    low = (rule.gt, "(") if rule.gt is not None else (rule.ge, "[")
    high = (rule.lt, ")") if rule.lt is not None else (rule.le, "]")
    if low[0] is not None and high[0] is not None:
        return f"in {low[1]}{low[0]:g}, {high[0]:g}{high[1]}"
    if rule.gt is not None:
        return "positive" if rule.gt == 0 else f"> {rule.gt:g}"
    if rule.ge is not None:
        if isinstance(value, int):
            return f"a whole number >= {rule.ge:g}"
        return "zero or positive" if rule.ge == 0 else f">= {rule.ge:g}"
    if rule.lt is not None:
        return f"< {rule.lt:g}"
    if rule.le is not None:
        return f"<= {rule.le:g}"
    return ""


def _in_range(rule: Rule, value: float) -> bool:
    return not (
        (rule.gt is not None and not value > rule.gt)
        or (rule.ge is not None and not value >= rule.ge)
        or (rule.lt is not None and not value < rule.lt)
        or (rule.le is not None and not value <= rule.le)
    )


def problem_of(rule: Rule | None, value: Any) -> str:
    """What is wrong with ``value`` under ``rule`` (its own rule: a list's length, a
    number's range; not its items'), as ``=<value> <problem>``; "" if nothing."""
    if is_number(value):
        if math.isnan(value) and rule is not None and rule.nan:
            return ""
        if math.isnan(value) or (math.isinf(value) and not (rule is not None and rule.infinite)):
            return f"={value!r} is not a finite number"
        if rule is None:
            return ""
        unit = f" {rule.unit}" if rule.unit and rule.unit != "-" else ""
        if rule.coordinate and abs(value) > MAX_COORDINATE:
            return f"={value!r} m is farther than {MAX_COORDINATE:g} m from the origin"
        if not _in_range(rule, value):
            brackets = f" [{rule.unit}]" if unit else ""
            return f"={value!r} must be {range_text(rule, value)}{brackets}"
        if rule.under is not None and value < rule.under[0]:
            return f"={value!r}{unit} is below {rule.under[0]:g}{unit}: {rule.under[1]}"
        if rule.over is not None and value > rule.over[0]:
            return f"={value!r}{unit} is over {rule.over[0]:g}{unit}: {rule.over[1]}"
    if rule is None:
        return ""
    if rule.choices is not None and isinstance(value, (str, int, float)):
        choices = rule.choice_list()
        if value not in choices:
            why = f": {rule.why}" if rule.why else ""
            return f"={value!r} is not one of {', '.join(repr(c) for c in choices)}{why}"
    if rule.nonempty and isinstance(value, (list, tuple, dict, str)) and not value:
        return f"={value!r} must not be empty"
    if isinstance(value, (list, tuple)):
        if rule.length is not None and len(value) != rule.length:
            return f"={list(value)!r} must be {rule.length} numbers"
        if rule.unique:
            repeated = [item for index, item in enumerate(value) if item in value[:index]]
            if repeated:
                return f"={list(value)!r} lists {repeated[0]!r} more than once"
    return ""


def missing_text(schema: type, name: str, rule: Rule) -> str:
    """The problem of the ``required`` field ``name`` of ``schema`` left out: the rule's
    own text, else ``'<name>' parameter is missing`` with its choices when it has some."""
    if isinstance(rule.required, str):
        return rule.required
    choices = rule.choice_list() if rule.choices is not None else ()
    if not choices:
        return f"'{name}' parameter is missing"
    hint = typing.get_type_hints(schema).get(name)
    several = "one or more of" if typing.get_origin(hint) is list else "one of"
    return f"'{name}' parameter is missing; give {several} {', '.join(map(repr, choices))}"


def rule_text(rule: Rule | None) -> str:
    """What a field's Rule accepts, in words (the reference pages' column): unit, range,
    choices, length, the other rules."""
    if rule is None:
        return ""
    parts = []
    if rule.unit and rule.unit != "-":
        parts.append(f"[{rule.unit}]")
    span = range_text(rule)
    if span:
        parts.append(span)
    if rule.infinite:
        parts.append("`.inf` = none")
    if rule.nan:
        parts.append("`.nan` = none")
    if rule.choices is not None:
        try:
            choices = rule.choice_list()
        except Exception:  # a list known only at run time (e.g. the robot's joints)
            choices = ()
        parts.append(
            "one of " + ", ".join(f"`{c!s}`" if c != "" else '`""`' for c in choices)
            if choices
            else "a name known"
        )
    if rule.length is not None:
        parts.append(f"{rule.length} numbers")
    if rule.coordinate:
        parts.append(f"within {MAX_COORDINATE / 1000:g} km of the origin")
    if rule.over is not None:
        parts.append(f"at most {rule.over[0]:g}")
    if rule.under is not None:
        parts.append(f"at least {rule.under[0]:g}")
    for flag, text in (
        (rule.required, "required"),
        (rule.nonempty, "not empty"),
        (rule.unique, "no item twice"),
    ):
        if flag:
            parts.append(text)
    return ", ".join(parts)


def _split(key: str) -> tuple[str, str]:
    """A root key as (parent prefix, name): ``"a.b"`` -> ``("a.", "b")``."""
    parent, _, name = key.rpartition(".")
    return (f"{parent}." if parent else ""), name


def message_prefix(value: Any, parent: str, name: str) -> str:
    """The text before the names of ``value``'s fields in messages: its own
    ``message_prefix`` method's, else ``<parent><name>.`` (the parent's alone at the
    root)."""
    custom = getattr(value, "message_prefix", None)
    if callable(custom):
        return custom(parent, name)
    return f"{parent}{name}." if name else parent


def check_config(
    value: Any,
    *,
    key: str = "",
    origin: Callable[[str], str] | None = None,
    error: type[Exception] = ConfigError,
    given: Mapping[str, Any] | None = None,
    strip: str = "",
) -> None:
    """Raises ``error`` for the first value inside ``value`` that its rules refuse (see
    the module's docstring): ``<origin(key)>: <label><problem>``, one line.

    ``key``: the dotted key of ``value`` itself ("" for a root section); ``origin``: where
    a dotted key's value came from ("" or None: the message starts with the label);
    ``given``: what the file gave, nested as ``value`` (a ``required`` field it leaves
    out is refused, ``<label>: '<name>' parameter is missing``; None: not checked);
    ``strip``: a dotted prefix (``"robots.robot."``) left out of the keys and labels of
    what is below it, which the file names without it."""
    parent, name = _split(key)
    context = _Context(origin or (lambda _key: ""), error, strip)
    _visit(value, key, parent, name, None, context, given)


@dc.dataclass(frozen=True)
class _Context:
    origin: Callable[[str], str]
    error: type[Exception]
    strip: str = ""

    def fail(self, key: str, text: str):
        """The error for ``key`` with the message ``text``, both without ``strip``."""
        return _error(self.error, self.origin, key.removeprefix(self.strip),
                      text.removeprefix(self.strip))  # fmt: skip


def _given(given: Any, name: str) -> Mapping[str, Any] | None:
    """What ``given`` gave under ``name`` when it is a mapping, else None."""
    if isinstance(given, Mapping):
        inner = given.get(name)
        return inner if isinstance(inner, Mapping) else None
    return None


def _join(key: str, name: str) -> str:
    return f"{key}.{name}" if key else name


def _visit(value, key, parent, name, rule, context, given) -> None:
    """Checks ``value`` (at dotted ``key``, labelled ``parent + name``) and what it holds;
    ``given``: what the file gave for it (a mapping, or None)."""
    problem = problem_of(rule, value)
    if problem:
        raise context.fail(key, f"{parent}{name}{problem}")
    if dc.is_dataclass(value) and not isinstance(value, type) or is_drake_struct(value):
        prefix = message_prefix(value, parent, name)
        for field, field_rule in field_rules(type(value)).items():
            at = _join(key, field)
            if given is not None and field_rule is not None and field_rule.required:
                if field not in given:
                    text = missing_text(type(value), field, field_rule)
                    raise context.fail(at, f"{prefix}{field}: {text}")
            item = getattr(value, field)
            _visit(item, at, prefix, field, field_rule, context, _given(given, field))
        check = getattr(value, "check", None)
        if dc.is_dataclass(value) and callable(check):
            try:
                check()
            except Refusal as refusal:
                at = _join(key, refusal.key) if refusal.key else key
                label = f"{prefix}{refusal.key}" if refusal.key else f"{parent}{name}"
                raise context.fail(at, f"{label}{refusal.problem}") from None
    elif isinstance(value, dict):
        inner = f"{parent}{name}." if name else parent
        item_rule = rule.item_rule() if rule is not None else None
        for item_name, item in value.items():
            _visit(item, _join(key, str(item_name)), inner, str(item_name), item_rule, context,
                   _given(given, item_name))  # fmt: skip
    elif isinstance(value, (list, tuple)):
        item_rule = rule.item_rule() if rule is not None else None
        names = rule.item_names if rule is not None else None
        for index, item in enumerate(value):
            if names is not None and index < len(names):
                item_parent, item_name = parent, names[index]
            else:
                item_parent, item_name = (f"{parent}{name}." if name else parent), str(index)
            _visit(item, _join(key, str(index)), item_parent, item_name, item_rule, context,
                   None)  # fmt: skip


def _error(error: type[Exception], origin: Callable[[str], str], key: str, text: str):
    """``error`` with its one-line message; it carries ``key`` (the dotted key at fault)
    and ``text`` (the message without the origin) for a caller that names the place
    otherwise (a controller YAML's node key)."""
    where = origin(key)
    raised = error(f"{where}: {text}" if where else text)
    raised.key, raised.text = key, text
    return raised
