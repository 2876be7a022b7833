"""The wheel: every subpackage, the models and scenarios inside it, the commands."""

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
COMMANDS = ("world", "display", "graph", "plots", "bench", "sweep", "dataset")


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
def installed(tmp_path_factory) -> Path:
    """The project built as a wheel and installed (not editable) into a folder of its own."""
    root = tmp_path_factory.mktemp("wheel")
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(root), str(REPO)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stderr
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
