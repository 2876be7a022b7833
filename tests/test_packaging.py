"""The release check: the source distribution and the wheel a user would install, built
with ``python -m build`` and checked with ``twine``; every subpackage and every file the
package reads at run time inside the wheel (a package-data pattern removed fails the check,
naming the files); the metadata a package index shows; the wheel installed in a fresh
virtual environment, where its commands print the version and a short world runs."""

import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
import zipfile
from email.parser import Parser
from pathlib import Path

import pytest

import armando_drake

REPO = Path(__file__).resolve().parents[1]
COMMANDS = ("world", "display", "graph", "plots", "bench", "sweep", "dataset", "learn")
# The source tree's folders the package resolves at run time, by their name in the wheel:
# models/ and diagrams/ ship as armando_drake/models and armando_drake/diagrams.
DATA_DIRS = [folder.relative_to(REPO) for folder in armando_drake.DATA_DIRS]
# Caches, hidden files and (at the root) build products and outputs of a working tree.
NOT_SOURCE = ("__pycache__", "*.pyc", ".*")
NOT_SOURCE_AT_ROOT = ("*.egg-info", "build", "dist", "out", "bench.json")


def _pyproject() -> dict:
    tomllib = pytest.importorskip("tomllib")
    return tomllib.loads((REPO / "pyproject.toml").read_text())


def _not_source(folder: str, names: list[str]) -> set[str]:
    """``shutil.copytree``'s ``ignore``: the names :data:`NOT_SOURCE` matches, and at the
    root those of :data:`NOT_SOURCE_AT_ROOT` too."""
    patterns = NOT_SOURCE + (NOT_SOURCE_AT_ROOT if Path(folder) == REPO else ())
    return shutil.ignore_patterns(*patterns)(folder, names)


def _files_under(folder: Path) -> list[Path]:
    """The files of ``folder`` as a release ships them (no caches, no hidden files)."""
    return sorted(
        path
        for path in folder.rglob("*")
        if path.is_file()
        and not any(
            part.startswith(".") or part == "__pycache__" for part in path.relative_to(folder).parts
        )
        and path.suffix != ".pyc"
    )


def notebook_scenarios() -> set[str]:
    """The scenario files the notebooks load: every string in their code that names one."""
    names = {path.stem for path in (REPO / "diagrams").glob("*.yaml")}
    found = set()
    for notebook in (REPO / "notebooks").glob("*.ipynb"):
        for cell in json.loads(notebook.read_text())["cells"]:
            if cell["cell_type"] == "code":
                for text in re.findall(r"[\"']([\w./-]+)[\"']", "".join(cell["source"])):
                    stem = text.removesuffix(".yaml")
                    if stem in names:
                        found.add(f"diagrams/{stem}.yaml")
    return found


def runtime_files() -> list[str]:
    """Every file the package reads at run time, by its name in the wheel: each file of the
    data folders the package resolves (``armando_drake.DATA_DIRS``), which holds the
    scenarios the notebooks load and the model files the scenarios name; and every file
    of the package that is not Python (the replacement shader of ``tools/shaders/``)."""
    package = REPO / "armando_drake"
    return sorted(
        [
            f"armando_drake/{path.relative_to(REPO).as_posix()}"
            for folder in DATA_DIRS
            for path in _files_under(REPO / folder)
        ]
        + [
            path.relative_to(REPO).as_posix()
            for path in _files_under(package)
            if path.suffix not in (".py", ".pyc")
        ]
    )


def missing_from_wheel(wheel: Path) -> list[str]:
    """The files read at run time (:func:`runtime_files`) that ``wheel`` lacks, by name."""
    names = set(zipfile.ZipFile(wheel).namelist())
    return [name for name in runtime_files() if name not in names]


def _build(source: Path, outdir: Path, *what: str) -> None:
    """``python -m build`` of ``source`` into ``outdir`` (``--wheel``, ``--sdist`` or both)."""
    build = subprocess.run(
        [sys.executable, "-m", "build", *what, "--outdir", str(outdir), str(source)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stdout[-4000:] + build.stderr[-4000:]


def test_every_subpackage_is_listed_in_pyproject():
    tomllib = pytest.importorskip("tomllib")
    listed = set(
        tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    found = {
        ".".join(init.parent.relative_to(REPO).parts)
        for init in (REPO / "armando_drake").rglob("__init__.py")
    }
    assert found - listed == set(), "add these to [tool.setuptools] packages"
    assert {"armando_drake.models", "armando_drake.diagrams"} <= listed


@pytest.fixture(scope="module")
def dists(tmp_path_factory) -> Path:
    """The folder with the source distribution and the wheel that ``python -m build``
    makes of the project (the wheel built from the source distribution)."""
    root = tmp_path_factory.mktemp("dist")
    _build(REPO, root)
    return root


@pytest.fixture(scope="module")
def installed(dists) -> Path:
    """The project built as a wheel and installed (not editable) into a folder of its own."""
    root = dists
    (wheel,) = root.glob("armando_drake-*.whl")
    target = root / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target)]
        + [str(wheel)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert install.returncode == 0, install.stderr
    return target


def test_wheel_holds_models_scenarios_and_commands(installed):
    (wheel,) = installed.parent.glob("armando_drake-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "armando_drake/models/armando_description/urdf/armando.urdf.xacro" in names
    assert "armando_drake/models/armando_description/config/armando_controllers.yaml" in names
    for scenario in (REPO / "diagrams").glob("*.yaml"):
        assert f"armando_drake/diagrams/{scenario.name}" in names
    (entry_points,) = [n for n in names if n.endswith("entry_points.txt")]
    text = zipfile.ZipFile(wheel).read(entry_points).decode()
    for command in COMMANDS:
        assert f"armando-{command} = armando_drake.{command}:main" in text


def test_installed_world_runs_from_another_folder(installed, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(installed))
    where = subprocess.run(
        [sys.executable, "-c", "import armando_drake as a; print(a.__file__); print(a.MODELS_DIR)"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    assert where == [
        str(installed / "armando_drake" / "__init__.py"),
        str(installed / "armando_drake" / "models"),
    ]
    run = subprocess.run(
        [sys.executable, "-m", "armando_drake.world"]
        + ["--no-meshcat", "--realtime-rate", "0", "--duration", "1", "--quiet"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "1.00 s simulated" in run.stdout
    script = subprocess.run(
        [str(installed / "bin" / "armando-world"), "--help"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert script.returncode == 0, script.stderr
    assert "--scenario" in script.stdout


def test_the_files_read_at_run_time_are_the_data_folders():
    files = runtime_files()
    assert "armando_drake/models/armando_description/urdf/armando.urdf.xacro" in files
    assert "armando_drake/diagrams/position.yaml" in files
    # What the notebooks load, and the model files the scenarios name, are among them.
    scenarios = notebook_scenarios()
    assert "diagrams/camera.yaml" in scenarios
    # What the scenarios load (their comments may name the course's packages, not ours).
    texts = [
        "\n".join(line.split("#", 1)[0] for line in scenario.read_text().splitlines())
        for scenario in (REPO / "diagrams").glob("*.yaml")
    ]
    named = {ref.rstrip(".") for text in texts for ref in re.findall(r"\bmodels/[\w./-]+", text)}
    assert named, "the scenarios name model files (controller YAML)"
    # Descriptions named as packages: our models/ is where they are found.
    packages = {
        f"models/{ref}" for text in texts for ref in re.findall(r"package://([\w./-]+)", text)
    }
    assert "models/iiwa_description/urdf/iiwa14.urdf.xacro" in packages
    for path in scenarios | named | packages:
        wheel_path = f"armando_drake/{path}"  # a file, or a folder with files
        assert wheel_path in files or any(f.startswith(wheel_path + "/") for f in files), path


def test_sdist_and_wheel_pass_twine_check(dists):
    files = sorted(str(path) for path in dists.glob("armando_drake-*") if path.is_file())
    assert len(files) == 2, files
    check = subprocess.run(
        [sys.executable, "-m", "twine", "check", "--strict", *files],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert check.returncode == 0, check.stdout + check.stderr
    assert check.stdout.count("PASSED") == 2, check.stdout


def test_wheel_holds_every_file_read_at_run_time(dists):
    (wheel,) = dists.glob("armando_drake-*.whl")
    assert missing_from_wheel(wheel) == []


def test_a_package_data_pattern_removed_fails_the_check(tmp_path):
    """The same check on a wheel whose pyproject.toml lost the scenarios' pattern names
    every scenario file it lacks."""
    source = tmp_path / "source"
    shutil.copytree(REPO, source, ignore=_not_source)
    pyproject = source / "pyproject.toml"
    pattern = '"armando_drake.diagrams" = ["*.yaml", "sweeps/*.args"]\n'
    assert pattern in pyproject.read_text()
    pyproject.write_text(pyproject.read_text().replace(pattern, ""))
    _build(source, tmp_path / "dist", "--wheel")
    (wheel,) = (tmp_path / "dist").glob("armando_drake-*.whl")
    scenarios = [
        f"armando_drake/diagrams/{p.relative_to(REPO / 'diagrams').as_posix()}"
        for p in _files_under(REPO / "diagrams")
    ]
    assert "armando_drake/diagrams/position.yaml" in scenarios
    assert missing_from_wheel(wheel) == sorted(scenarios)


def test_sdist_holds_the_project(dists):
    """The source distribution builds the wheel (``python -m build`` built it from it) and
    holds every file of the project a user builds or tests from: the package, its data,
    README, LICENSE, NOTICE, CHANGELOG, tests, notebooks, examples, benchmarks, the docs."""
    (sdist,) = dists.glob("armando_drake-*.tar.gz")
    with tarfile.open(sdist) as archive:
        top = f"{sdist.name.removesuffix('.tar.gz')}/"
        names = {name.removeprefix(top) for name in archive.getnames()}
    expected = {"pyproject.toml", "README.md", "LICENSE", "NOTICE", "CHANGELOG.md", "MANIFEST.in"}
    expected.add("mkdocs.yml")
    for folder in ("armando_drake", *map(str, DATA_DIRS), "tests", "notebooks", "examples", "docs"):
        expected |= {p.relative_to(REPO).as_posix() for p in _files_under(REPO / folder)}
    expected |= {p.relative_to(REPO).as_posix() for p in _files_under(REPO / "benchmarks")}
    assert sorted(expected - names) == []


def test_metadata_a_package_index_shows(dists):
    pyproject = _pyproject()["project"]
    (wheel,) = dists.glob("armando_drake-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        (metadata_name,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        metadata = Parser().parsestr(archive.read(metadata_name).decode())
        licences = {n.rpartition("/")[2] for n in archive.namelist() if "/licenses/" in n}
    assert metadata["Name"] == "armando-drake"
    assert metadata["Version"] == pyproject["version"]
    assert metadata["License-Expression"] == pyproject["license"] == "BSD-3-Clause"
    assert set(metadata.get_all("License-File")) == licences == {"LICENSE", "NOTICE"}
    classifiers = metadata.get_all("Classifier")
    assert "Programming Language :: Python :: 3 :: Only" in classifiers
    assert any(c.startswith("Development Status ::") for c in classifiers)
    assert "ros2_control" in metadata["Keywords"].split(",")
    # No project URL until the project has a public address (none is invented).
    assert metadata.get_all("Project-URL") is None
    # The README is the long description, as markdown (twine check renders it).
    assert metadata["Description-Content-Type"] == "text/markdown"
    assert metadata.get_payload().strip() == (REPO / "README.md").read_text().strip()


def test_licence_at_the_root_is_the_declared_one():
    licence = (REPO / "LICENSE").read_text()
    assert licence.startswith("BSD 3-Clause License\n")
    assert _pyproject()["project"]["license"] == "BSD-3-Clause"
    # The model's licence is the same, with the same holder.
    assert (REPO / "models" / "armando_description" / "LICENSE").read_text() == licence
    holder = re.search(r"^Copyright \(c\) .+$", licence, re.MULTILINE).group(0)
    assert holder in (REPO / "NOTICE").read_text()


def test_changelog_has_the_version():
    version = _pyproject()["project"]["version"]
    changelog = (REPO / "CHANGELOG.md").read_text()
    sections = re.findall(r"^## \[([^\]]+)\](?: - (\d{4}-\d\d-\d\d))?$", changelog, re.MULTILINE)
    assert sections[0] == ("Unreleased", "")
    assert sections[1][0] == version and sections[1][1], "the version's section, dated"


def test_wheel_runs_in_a_fresh_virtual_environment(dists, tmp_path):
    """The wheel installed with its dependencies (from the package index, pip's cache) in a
    new virtual environment that sees nothing of this one: every command prints the
    version (no commit: not a checkout), and a short world runs and writes it."""
    version = _pyproject()["project"]["version"]
    (wheel,) = dists.glob("armando_drake-*.whl")
    venv = tmp_path / "venv"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    subprocess.run([sys.executable, "-m", "venv", str(venv)], env=env, check=True, timeout=120)
    python, bin_dir = venv / "bin" / "python", venv / "bin"
    install = subprocess.run(
        # --no-compile: byte-compiling Drake, NumPy and Matplotlib on install is half the
        # install's time here, and Python compiles what it imports anyway.
        [str(python), "-m", "pip", "install", "-q", "--no-compile", str(wheel)],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert install.returncode == 0, install.stdout[-4000:] + install.stderr[-4000:]
    where = subprocess.run(
        [str(python), "-c", "import armando_drake, sys; print(armando_drake.__file__, sys.prefix)"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    assert Path(where[0]).is_relative_to(venv) and Path(where[1]) == venv
    for command in COMMANDS:
        printed = subprocess.run(
            [str(bin_dir / f"armando-{command}"), "--version"],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert (printed.returncode, printed.stderr) == (0, ""), command
        assert printed.stdout == f"armando-drake {version}\n", command
    run = subprocess.run(
        [str(bin_dir / "armando-world"), "--no-meshcat", "--realtime-rate", "0"]
        + ["--duration", "1", "--quiet", "--no-replay", "--output", "run"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "1.00 s simulated" in run.stdout
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["armando_drake"] == {"version": version}
    assert summary["sim_time"] == pytest.approx(1.0)
