"""The two commands: installed as console scripts, --help, one-line input errors."""

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", *args], capture_output=True, text=True, timeout=120, cwd=REPO
    )


def test_pyproject_declares_commands_package_and_ray_extras():
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((REPO / "pyproject.toml").read_text())
    scripts = project["project"]["scripts"]
    assert scripts["armando-sweep"] == "armando_drake.sweep:main"
    assert scripts["armando-dataset"] == "armando_drake.dataset:main"
    assert "armando_drake.sweeps" in project["tool"]["setuptools"]["packages"]
    extras = project["project"]["optional-dependencies"]
    assert any(requirement.startswith("ray") for requirement in extras["cluster"])
    assert "armando-drake[cluster]" in extras["test"]  # the test command installs Ray


def test_help_of_both_commands():
    sweep = run("armando_drake.sweep", "--help")
    assert sweep.returncode == 0, sweep.stderr
    for option in ("--grid", "--random", "--resume", "--ray", "--workers", "--plot"):
        assert option in sweep.stdout
    dataset = run("armando_drake.dataset", "ik", "--help")
    assert dataset.returncode == 0, dataset.stderr
    for option in ("--robot", "--samples", "--seed", "--ik", "--frame", "--shards"):
        assert option in dataset.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["--grid", "kp"], "error: --grid 'kp' is not of the form KEY=VALUES"),
        (
            ["--grid", "actuators.kp=[1]", "--workers", "0", "--output", "{tmp}"],
            "error: --workers 0 must be at least 1",
        ),
        (
            ["--random", "actuators.kp=uniform(1, 2)", "--dry-run"],
            "error: --samples 0: a --random axis needs --samples 1 or more",
        ),
    ],
)
def test_input_errors_are_one_line(args, message, tmp_path):
    done = run("armando_drake.sweep", *[a.replace("{tmp}", str(tmp_path)) for a in args])
    assert done.returncode == 2
    assert done.stderr.strip() == message
