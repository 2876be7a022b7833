"""The documentation: the site builds with no warning, the README stays short and gives
the command CI runs, and every command the README and the pages show is one the
commands accept (a few of them run for real, briefly)."""

import contextlib
import importlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import skip_or_fail

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
README_MAX_LINES = 260
PREFIXES = ("python -m armando_drake.", ".venv/bin/python -m armando_drake.")

# The commands whose parser the test can ask for (argv checked in full: unknown options
# and bad values fail); the others get --help appended, which must exit 0.
PARSERS = {
    "world": "armando_drake.world",
    "display": "armando_drake.display",
    "graph": "armando_drake.graph",
    "sweep": "armando_drake.sweeps.sweep",
    "dataset": "armando_drake.sweeps.dataset",
}


def documented_commands() -> list[tuple[str, str]]:
    """(where, command) of every line of a fenced bash block in the README and docs/ that
    runs ``python -m armando_drake.<module>``; continuation lines joined."""
    found = []
    for path in [README, *sorted(DOCS.rglob("*.md"))]:
        text = path.read_text(encoding="utf-8")
        for block in re.finditer(r"^```bash\n(.*?)^```", text, re.S | re.M):
            first_line = text[: block.start()].count("\n") + 2
            joined = re.sub(r"\\\n\s*", " ", block.group(1))
            for offset, line in enumerate(joined.splitlines()):
                line = line.strip()
                if line.startswith(PREFIXES):
                    found.append((f"{path.relative_to(REPO)}:{first_line + offset}", line))
        # The README's chapter table gives one command per chapter, inline.
        if path == README:
            for number, line in enumerate(text.splitlines(), 1):
                for command in re.findall(r"\| `([^`]+)` \|", line):
                    if command.startswith(PREFIXES):
                        found.append((f"README.md:{number}", command))
    return found


COMMANDS = documented_commands()


def _argv(command: str) -> tuple[str, list[str]]:
    """(the module after armando_drake., its arguments) of a documented command."""
    words = shlex.split(command, comments=True)
    assert words[1] == "-m", command
    return words[2].removeprefix("armando_drake."), words[3:]


def test_the_readme_is_short_and_gives_the_ci_command():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines"
    ci_command = (REPO / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci_command in lines, "the README's test command is the one .ci/run runs"
    assert lines.index(ci_command) < 15, "the two commands come first"


def test_the_readme_links_to_files_that_exist():
    """The README's relative links and its picture (mkdocs checks only docs/)."""
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README.read_text(encoding="utf-8"))
    relative = [t for t in targets if "://" not in t]
    assert "docs/images/armando.png" in relative
    assert [t for t in relative if not (REPO / t).exists()] == []


def test_commands_are_found():
    modules = {_argv(command)[0] for _, command in COMMANDS}
    assert {"world", "display", "graph", "sweep", "dataset", "bench", "plots"} <= modules
    assert len(COMMANDS) >= 40
    assert len([where for where, _ in COMMANDS if where.startswith("README.md")]) >= 19
    shown = {shlex.join(shlex.split(command, comments=True)) for _, command in COMMANDS}
    # Every exemption from running still names a documented command.
    assert [key for key in NOT_RUN if not any(key in command for command in shown)] == []


@pytest.mark.parametrize("where, command", COMMANDS, ids=[where for where, _ in COMMANDS])
def test_documented_command_parses(where, command):
    module, argv = _argv(command)
    if module in PARSERS:
        parser = importlib.import_module(PARSERS[module])._parser()
        errors = io.StringIO()
        with contextlib.redirect_stderr(errors):
            try:
                parser.parse_args(argv)
            except SystemExit:
                pytest.fail(f"{where}: {command}\n{errors.getvalue()}")
        return
    output = io.StringIO()
    with contextlib.redirect_stdout(output), contextlib.redirect_stderr(output):
        with pytest.raises(SystemExit) as exit_:
            importlib.import_module(f"armando_drake.{module}").main([*argv, "--help"])
    assert exit_.value.code in (0, None), f"{where}: {command}\n{output.getvalue()}"
    assert "usage:" in output.getvalue()


# Documented commands the test does not run, by a piece of their text, each with why. Any
# other command a page shows is run: one the pages add and that fails fails the test.
NOT_RUN = {
    "armando_drake.bench": "a benchmark (minutes); the suite never runs the benchmarks "
    "(tests/entry_points/test_bench.py checks --quick in-process)",
    "--samples 200": "200 simulations; tests/sweeps/ run the random sampler on a few",
    "--ray HEAD_IP:6379": "HEAD_IP stands for a Ray cluster's address",
    "dataset ik --samples 10000": "10,000 inverse kinematics solves; tests/sweeps/ make small sets",
    "learn ik-node": "a ROS 2 node that serves a trained network until Ctrl-C "
    "(tests/learn/ run it on DDS)",
    "my_robot_description": "~/ws/src/my_robot_description stands for the reader's package",
    "path/to/rl_fra2mo_description": "path/to/ stands for where the reader keeps the package",
    "path/to/turtlebot3_gazebo": "path/to/ stands for where the reader keeps the package "
    "(tests/mobile/test_sdf_robot.py loads a model folder)",
    "leonardo_race_field.sdf": "its package is found from the ROS_PACKAGE_PATH the block's "
    "export line sets (a world_file's package:// does not take --package-path)",
}
# [s] of simulated time appended to the runs of a world (the last --duration wins) and to
# every variant of a sweep.
SHORT = "0.5"


def _blocks() -> dict[str, list[str]]:
    """The commands to run, by code block (where its first command is), in page order; a
    command already run in an earlier block is not run again."""
    blocks: dict[str, list[str]] = {}
    seen = set()
    for where, command in COMMANDS:
        normal = shlex.join(shlex.split(command, comments=True))
        if normal in seen or any(key in command for key in NOT_RUN):
            continue
        seen.add(normal)
        page, line = where.rsplit(":", 1)
        previous = next(reversed(blocks), None)
        if previous and previous.startswith(page + ":") and _block_of(where) == _block_of(previous):
            blocks[previous].append(command)
        else:
            blocks[where] = [command]
    return blocks


def _block_of(where: str) -> int:
    """Which code block holds the line ``where`` (the number of fences before it); a line
    outside the blocks (a row of the README's table) is a block of its own."""
    page, line = where.rsplit(":", 1)
    lines = (REPO / page).read_text(encoding="utf-8").splitlines()[: int(line)]
    fences = sum(1 for x in lines if x.startswith("```"))
    return fences if fences % 2 else -int(line)


BLOCKS = _blocks()


def _workspace(tmp_path: Path) -> Path:
    """A directory laid out as the clone the pages' commands run from: the project's files
    (linked), ../shared beside it when the machine has it, and an empty out/."""
    clone = tmp_path / "armando-drake"
    clone.mkdir()
    for name in ("armando_drake", "models", "diagrams", "docs", "examples", "notebooks"):
        (clone / name).symlink_to(REPO / name)
    shared = REPO.parent / "shared"
    if shared.is_dir():
        (tmp_path / "shared").symlink_to(shared)
    return clone


def _expected_files(module: str, argv: list[str]) -> list[str]:
    """The files the pages say a command writes, from its options."""
    files = []
    for option, value in zip(argv, argv[1:], strict=False):
        if module == "world" and option == "--output":
            files += [f"{value}/summary.json"]
            files += [] if "--no-replay" in argv else [f"{value}/replay.html"]
        elif option in ("--record", "-o") or (module == "sweep" and option == "--output"):
            files.append(value)
        elif option == "--save-frames":
            files.append(value)
    return files


def _run(module: str, argv: list[str], cwd: Path, where: str) -> str:
    """Runs one documented command; its output. A display serves until Ctrl-C: it is
    stopped once it has printed its Meshcat URL."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [env.get("PYTHONPATH")])])
    command = [sys.executable, "-m", f"armando_drake.{module}", *argv]
    if module in ("world", "sweep"):
        command += ["--duration", SHORT]
    if module == "display" and "--loop-once" not in argv:
        process = subprocess.Popen(
            command,
            cwd=cwd,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        lines = []
        for line in process.stdout:
            lines.append(line)
            if line.startswith("Meshcat: "):
                break
        process.terminate()
        process.wait(timeout=30)
        assert any(x.startswith("Meshcat: ") for x in lines), f"{where}:\n{''.join(lines)}"
        return "".join(lines)
    result = subprocess.run(
        command,
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, f"{where}: {shlex.join(command)}\n{result.stdout}{result.stderr}"
    return result.stdout


@pytest.mark.parametrize("where", list(BLOCKS))
def test_documented_commands_run_as_written(where, tmp_path):
    """Each command of a page's code block (and the README's chapter table), in order, in a
    directory laid out as the clone: exit 0, the simulated time given, and the files its
    options name written. Worlds run for SHORT simulated seconds; with the viewer on they
    start at once and exit at the end, as they do without a terminal."""
    clone = _workspace(tmp_path)
    for command in BLOCKS[where]:
        module, argv = _argv(command)
        if any(a.startswith("../shared") for a in argv) and not (tmp_path / "shared").is_dir():
            skip_or_fail(f"{command} needs ../shared beside the clone")
        if module == "graph" and not shutil.which("dot"):
            skip_or_fail("the graph needs Graphviz's dot (apt-get install graphviz)")
        output = _run(module, argv, clone, f"{where}: {command}")
        if module == "world":
            assert f"{float(SHORT):.2f} s simulated" in output, f"{command}\n{output}"
        missing = [f for f in _expected_files(module, argv) if not (clone / f).exists()]
        assert missing == [], f"{command}: not written: {missing}"


def test_site_builds_without_a_warning(tmp_path):
    """mkdocs build --strict: a broken link or anchor, a page missing from the nav or a
    nav entry without its page fails it (mkdocs.yml's validation settings)."""
    try:
        import material  # noqa: F401
        import mkdocs  # noqa: F401
    except ImportError:
        skip_or_fail("MkDocs and its Material theme are not installed (pip install -e '.[docs]')")
    site = tmp_path / "site"
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "WARNING" not in result.stderr, result.stderr
    # The generated reference pages, from the code.
    cli = (site / "reference" / "cli" / "index.html").read_text()
    assert "usage: python -m armando_drake.world" in cli
    assert "usage: python -m armando_drake.dataset ik" in cli
    keys = (site / "reference" / "scenario-keys" / "index.html").read_text()
    assert "actuators.kp" in keys and "N m/rad" in keys
    assert "sequencer !Sinusoid: frequency" in keys
    parameters = (site / "reference" / "controller-parameters" / "index.html").read_text()
    assert "constraints.goal_time" in parameters
    navigation = (site / "reference" / "navigation-parameters" / "index.html").read_text()
    assert "inflation_radius" in navigation and "warned: not applied" in navigation
    pages = list(site.rglob("index.html"))
    assert len(pages) >= 25, len(pages)


def test_navigation_parameters_page_lists_the_course_keys(fra2mo_package):
    """Every key the course's navigation.yaml gives the implemented nodes and plugins is in
    the generated page, in its node's or plugin's table."""
    import yaml

    sys.path.insert(0, str(REPO / "docs"))
    try:
        hooks = importlib.import_module("hooks")
    finally:
        sys.path.remove(str(REPO / "docs"))
    page = hooks.navigation_parameters_page()
    tables = {}
    for block in page.split("\n## ")[1:]:
        title = block.splitlines()[0]
        tables[title.split(" ")[0]] = set(re.findall(r"^\| `([^`]+)` \|", block, re.M))
    doc = yaml.safe_load((fra2mo_package / "config" / "navigation.yaml").read_text())
    ros = {node: doc[node]["ros__parameters"] for node in ("amcl", "controller_server")}
    ros["planner_server"] = doc["planner_server"]["ros__parameters"]
    ros["global_costmap"] = doc["global_costmap"]["global_costmap"]["ros__parameters"]
    expected = []  # (table, key)
    for node, params in ros.items():
        layers = params.get("plugins", [])
        plugins = {"FollowPath", "goal_checker", "progress_checker", "GridBased"}
        for key, value in params.items():
            if key in ("static_layer", "inflation_layer", *plugins) and isinstance(value, dict):
                expected += [(key, inner) for inner in value]
            elif key not in layers:  # the obstacle layer: not implemented
                expected.append((node, key))
    missing = [(table, key) for table, key in expected if key not in tables[table]]
    assert missing == [] and len(expected) > 80
    assert "| `desired_linear_vel` | honoured |" in page
    assert "| `min_particles` | warned: not applied | KLD sampling" in page


def _hooks():
    sys.path.insert(0, str(REPO / "docs"))
    try:
        return importlib.import_module("hooks")
    finally:
        sys.path.remove(str(REPO / "docs"))


def test_navigation_pages_agree_with_the_implemented_plugins():
    """The generated Navigation parameters page and docs/navigation.md say the same of the
    Nav2 plugins as the registries: every implemented planner, controller and costmap layer
    has its table, with nothing of it warned as not applied wholesale; every substitution is
    on both pages; every Nav2 plugin name navigation.md gives is one the reference knows; and
    every implemented layer is described in navigation.md."""
    from armando_drake.navigation.registry import CONTROLLERS, LAYERS, PLANNERS

    page = _hooks().navigation_parameters_page()
    guide = (DOCS / "navigation.md").read_text(encoding="utf-8")
    titles = re.findall(r"^## (.+)$", page, re.M)
    for registry in (LAYERS, PLANNERS, CONTROLLERS):
        for plugin in registry.implemented():
            assert [t for t in titles if f"({plugin.name})" in t], (registry.kind, plugin.name)
        names = [p.name for p in registry.substituted()]
        for plugin in registry.substituted():
            assert plugin.name in page, (registry.kind, plugin.name)
            # The guide's table may shorten a family: `nav2_smac_planner::SmacPlanner2D`,
            # `...Hybrid`.
            cls = plugin.name.split("::")[-1]
            family = [
                n.split("::")[-1] for n in names if n.split("::")[0] == plugin.name.split("::")[0]
            ]
            tail = cls[len(os.path.commonprefix(family)) :] if len(family) > 1 else cls
            assert plugin.name in guide or f"`...{tail}`" in guide, plugin.name
    for plugin in LAYERS.implemented():
        title = plugin.cls.title  # obstacle_layer
        section = page.split(f"## {title} ({plugin.name})")[1].split("\n## ")[0]
        assert "| honoured |" in section, title
        assert title.replace("_", " ") in guide, f"docs/navigation.md never describes the {title}"
        # The costmap's own table does not call the layer unapplied.
        assert not re.search(rf"^\| `{title}` \| warned", page, re.M), title
    known = {p.name for r in (LAYERS, PLANNERS, CONTROLLERS) for p in r.implemented()}
    known |= {p.name for r in (LAYERS, PLANNERS, CONTROLLERS) for p in r.substituted()}
    mentioned = set(re.findall(r"`((?:nav2_\w+|dwb_core)::\w+)`", guide))
    assert mentioned and [m for m in mentioned if m not in known and m not in page] == []
    assert "nav2_costmap_2d::ObstacleLayer" in mentioned & known
