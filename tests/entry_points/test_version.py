"""The version: written once (pyproject.toml), printed by ``--version`` on every command,
with the git commit of a checkout, and named in what a run writes (summary.json, MCAP)."""

import importlib.metadata
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

import armando_drake
from armando_drake.outputs.recording import METADATA_NAME
from armando_drake.tools import version

REPO = Path(__file__).resolve().parents[2]
COMMANDS = ("world", "display", "graph", "plots", "bench", "sweep", "dataset", "learn")
GIT = ["git", "-c", "user.name=test", "-c", "user.email=test@invalid", "-c", "commit.gpgsign=false"]


def pyproject_version() -> str:
    tomllib = pytest.importorskip("tomllib")
    return tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]


@pytest.fixture
def fresh_lookups():
    """The version and commit looked up anew in the test, and again after it."""
    version.package_version.cache_clear()
    version.git_commit.cache_clear()
    yield
    version.package_version.cache_clear()
    version.git_commit.cache_clear()


def test_the_package_version_is_pyproject_s():
    assert armando_drake.__version__ == version.package_version() == pyproject_version()


def test_pyproject_field_reads_the_project_table():
    text = (
        '[build-system]\nrequires = ["setuptools"]\n\n'
        '[project]\nname = "armando-drake"\nversion = "1.2.3"\n\n'
        '[tool.other]\nversion = "9.9"\n'
    )
    assert version.pyproject_field(text, "version") == "1.2.3"
    assert version.pyproject_field(text, "name") == "armando-drake"
    assert version.pyproject_field(text, "description") is None
    assert version.pyproject_field('[tool.other]\nversion = "9.9"\n', "version") is None


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_prints_the_version(command):
    result = subprocess.run(
        [sys.executable, "-m", f"armando_drake.{command}", "--version"],
        env=dict(os.environ, PYTHONPATH=str(REPO)),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert (result.returncode, result.stderr) == (0, "")
    expected = f"armando-drake {pyproject_version()}"
    commit = version.git_commit()
    if commit is not None:
        expected += f" (commit {commit})"
    assert result.stdout == expected + "\n"


def test_version_text_names_the_commit_of_a_checkout():
    text = version.version_text()
    assert re.fullmatch(r"armando-drake \S+( \(commit [0-9a-f]{4,}(-dirty)?\))?", text), text
    assert ("(commit " in text) == (version.git_commit() is not None)


def _git(folder: Path, *args: str) -> str:
    return subprocess.run(
        [*GIT, "-C", str(folder), *args], capture_output=True, text=True, check=True
    ).stdout.strip()


def test_git_commit_from_a_checkout_dirty_untracked_or_without_git(
    tmp_path, monkeypatch, fresh_lookups
):
    package = tmp_path / "armando_drake"
    package.mkdir()
    (package / "__init__.py").write_text('"""A package."""\n')
    (tmp_path / "README.md").write_text("readme\n")
    monkeypatch.setattr(version, "_ROOT", tmp_path)

    assert version.git_commit() is None  # not a git checkout
    version.git_commit.cache_clear()

    _git(tmp_path, "init", "-q")
    _git(tmp_path, "add", "README.md")
    _git(tmp_path, "commit", "-q", "-m", "readme")
    assert version.git_commit() is None  # a checkout, but the package is not tracked in it
    version.git_commit.cache_clear()

    _git(tmp_path, "add", "armando_drake/__init__.py")
    _git(tmp_path, "commit", "-q", "-m", "package")
    head = _git(tmp_path, "rev-parse", "--short", "HEAD")
    assert version.git_commit() == head
    version.git_commit.cache_clear()

    (tmp_path / "untracked.txt").write_text("not a change of the commit\n")
    assert version.git_commit() == head
    version.git_commit.cache_clear()

    (package / "__init__.py").write_text('"""A changed package."""\n')
    assert version.git_commit() == f"{head}-dirty"
    assert version.provenance()["commit"] == f"{head}-dirty"
    version.git_commit.cache_clear()

    monkeypatch.setenv("PATH", str(tmp_path / "no-git-here"))
    assert version.git_commit() is None  # no git: no commit, and no error
    assert "commit" not in version.provenance()


def test_outside_a_source_tree_the_metadata_tells_the_version(tmp_path, monkeypatch, fresh_lookups):
    try:
        installed = importlib.metadata.version("armando-drake")
    except importlib.metadata.PackageNotFoundError:
        installed = "unknown"
    monkeypatch.setattr(version, "_ROOT", tmp_path)
    assert version.package_version() == installed
    version.package_version.cache_clear()
    # Another project's pyproject.toml beside the installed package is not ours.
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "other"\nversion = "7.0"\n')
    assert version.package_version() == installed


def test_a_run_names_its_version_in_summary_and_mcap(tmp_path):
    output, recording = tmp_path / "run", tmp_path / "run.mcap"
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--realtime-rate", "0"]
        + ["--duration", "0.5", "--quiet", "--no-replay", "--output", str(output)]
        + ["--record", str(recording)],
        env=dict(os.environ, PYTHONPATH=str(REPO)),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    expected = version.provenance()
    assert expected["version"] == pyproject_version()
    summary = json.loads((output / "summary.json").read_text())
    assert summary["armando_drake"] == expected
    with recording.open("rb") as stream:
        metadata = {record.name: record.metadata for record in make_reader(stream).iter_metadata()}
    assert metadata == {METADATA_NAME: expected}
