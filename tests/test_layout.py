"""The package's architecture, measured from its source (no module is imported).

Layers, bottom to top; a module may import from its own layer's packages and from the
layers below, never from a layer above. The layer map is the one
``docs/design/architecture.md`` shows (its ``layer N  pkg/ pkg/ ...`` block): it is read from
there, so the page and this test cannot disagree, and every package must be on it.

``python tests/test_layout.py`` prints the figures; the tests assert them.
"""

from __future__ import annotations

import ast
import re
import sys
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "armando_drake"

ARCHITECTURE = PACKAGE.parent / "docs" / "design" / "architecture.md"


def documented_layers() -> dict[str, int]:
    """The layer of each package, as the layer map of ``docs/design/architecture.md`` gives
    it (``layer 2  control/ sensors/ navigation/  ...``); ``""`` is the package's root."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    layers = {"": 0}  # armando_drake/__init__.py
    for number, rest in re.findall(r"^layer (\d+)\s+(.*)$", text, re.M):
        for name in re.findall(r"(?<![\w/<>])([a-z][a-z0-9_]*)/", rest):
            layers[name] = int(number)
    return layers


LAYERS = documented_layers()
ENTRY_LAYER = 6  # armando_drake/<name>.py: python -m armando_drake.<name>

# A ros2_control / ros_control controller type string: "<package>/<Type>".
TYPE_STRING = re.compile(
    r"\b[a-z][a-z0-9_]*_(?:controllers?|broadcaster|controller_manager)/[A-Z][A-Za-z0-9]+"
)
BUILDER_MAX_LINES = 350
LONG_FUNCTION = 80
MAX_LONG_FUNCTIONS = 5
LONG_CLASS = 400


def module_name(path: Path) -> str:
    parts = ["armando_drake", *path.relative_to(PACKAGE).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}


def layer_of(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return LAYERS[""]
    if (PACKAGE / parts[1]).is_dir():
        return LAYERS[parts[1]]
    return ENTRY_LAYER


def _imported(node: ast.AST, module: str, is_package: bool) -> list[str]:
    """The armando_drake modules an import statement names (a name imported from a
    package may be a module of it: both are counted when they exist)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name.split(".")[0] == "armando_drake"]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:
        base = module.split(".") if is_package else module.split(".")[:-1]
        base = base[: len(base) - node.level + 1]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    if target.split(".")[0] != "armando_drake":
        return []
    return [target] + [f"{target}.{a.name}" for a in node.names]


def imports() -> list[tuple[str, str, int, bool]]:
    """(importer, imported module, line, outside every function) of every import of the
    package's own modules; ``if TYPE_CHECKING:`` imports are left out (never run). An
    import in a module-level block (``with``, ``try``) runs when the module loads: it is
    not a function-level import."""
    known = modules()
    found = []
    for module, path in known.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        typing_only = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                typing_only |= {id(n) for n in ast.walk(node)}
        in_functions = {
            id(inner)
            for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            for inner in ast.walk(node)
        }
        for node in ast.walk(tree):
            if id(node) in typing_only:
                continue
            for target in _imported(node, module, path.name == "__init__.py"):
                if target in known:
                    found.append((module, target, node.lineno, id(node) not in in_functions))
    return found


def function_level_imports() -> list[str]:
    return [f"{m} line {line} imports {t}" for m, t, line, top in imports() if not top]


def upward_imports() -> list[str]:
    return [
        f"{m} (layer {layer_of(m)}) imports {t} (layer {layer_of(t)}) at line {line}"
        for m, t, line, _ in imports()
        if layer_of(t) > layer_of(m)
    ]


def import_cycles() -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    graph = defaultdict(set)
    for m, t, _, _ in imports():
        if m != t and not t.startswith(f"{m}.") and not m.startswith(f"{t}."):
            graph[m].add(t)
    index, low, stack, on_stack, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    sys.setrecursionlimit(10000)
    for v in list(graph):
        if v not in index:
            visit(v)
    return cycles


def long_functions() -> list[str]:
    found = []
    for module, path in modules().items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > LONG_FUNCTION:
                    found.append(f"{module}.{node.name}: {length} lines")
    return found


def long_classes(paths: dict[str, Path] | None = None) -> list[str]:
    """The classes over :data:`LONG_CLASS` lines (definition to last line), of the package's
    modules or of ``paths`` (module name: file)."""
    found = []
    for module, path in (paths or modules()).items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                length = node.end_lineno - node.lineno + 1
                if length > LONG_CLASS:
                    found.append(f"{module}.{node.name}: {length} lines")
    return found


def type_strings_outside_registry() -> list[str]:
    registry = PACKAGE / "control" / "controllers"
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if registry in path.parents:
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for match in TYPE_STRING.finditer(line):
                found.append(f"{path.relative_to(PACKAGE.parent)}:{number}: {match.group()}")
    return found


def builder_lines() -> int:
    return len((PACKAGE / "simulation" / "builder.py").read_text().splitlines())


def test_no_import_cycle():
    assert import_cycles() == []


def test_no_upward_import():
    assert upward_imports() == []


def test_no_function_level_import_of_our_modules():
    assert function_level_imports() == []


def test_builder_is_a_list_of_steps():
    assert builder_lines() <= BUILDER_MAX_LINES


def test_few_long_functions():
    assert len(long_functions()) <= MAX_LONG_FUNCTIONS, long_functions()


def test_no_class_over_400_lines():
    assert long_classes() == []


def test_controller_type_strings_only_in_the_registry():
    assert type_strings_outside_registry() == []


def test_the_measures_see_what_they_measure(tmp_path):
    """The type-string pattern and the layer table catch what they are for."""
    assert TYPE_STRING.search('type: "position_controllers/JointGroupPositionController"')
    assert TYPE_STRING.search("joint_state_broadcaster/JointStateBroadcaster")
    assert not TYPE_STRING.search("/position_controller/commands")
    assert layer_of("armando_drake.control.manager") < layer_of("armando_drake.simulation.builder")
    assert layer_of("armando_drake.world") == ENTRY_LAYER
    long = tmp_path / "long.py"
    long.write_text("class Long:\n" + "    x = 1\n" * LONG_CLASS)
    short = tmp_path / "short.py"
    short.write_text("class Short:\n" + "    x = 1\n" * (LONG_CLASS - 1))
    assert long_classes({"long": long, "short": short}) == [f"long.Long: {LONG_CLASS + 1} lines"]


def packages() -> set[str]:
    """The subpackages of armando_drake (folders holding Python modules)."""
    return {p.name for p in PACKAGE.iterdir() if p.is_dir() and any(p.rglob("*.py"))}


def test_the_documented_layer_map_lists_every_package_and_only_those():
    assert packages() - set(LAYERS) == set(), f"give each package a layer in {ARCHITECTURE}"
    assert set(LAYERS) - {""} - packages() == set(), f"{ARCHITECTURE} lists no such package"
    assert LAYERS["tools"] == 0 and LAYERS["simulation"] == 5 and LAYERS["benchmarks"] == 6


if __name__ == "__main__":
    figures = {
        "import cycles": import_cycles(),
        "upward imports": upward_imports(),
        "function-level imports of armando_drake modules": function_level_imports(),
        "functions longer than 80 lines": long_functions(),
        "classes longer than 400 lines": long_classes(),
        "controller type strings outside control/controllers/": type_strings_outside_registry(),
    }
    for name, items in figures.items():
        print(f"{name}: {len(items)}")
        for item in items:
            print(f"  {item}")
    print(f"simulation/builder.py: {builder_lines()} lines")
