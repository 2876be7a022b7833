"""The notebooks run top to bottom in short mode and print what they promise.

Each notebook is executed by nbclient in the ``python3`` kernel (ipykernel
starts it with this interpreter), from the ``notebooks`` folder as a user
would, with ``ARMANDO_DRAKE_SHORT=1``. A cell that raises fails the test.
"""

import json
import re
import sys
from pathlib import Path

import nbclient
import nbformat
import pytest
from conftest import COURSE_PACKAGE, run_notebook

NOTEBOOKS = Path(__file__).resolve().parents[2] / "notebooks"


def execute(name: str, monkeypatch) -> tuple[str, int]:
    """Runs notebooks/<name>.ipynb in short mode: the text its cells printed, its image count."""
    return run_notebook(name, monkeypatch)


def test_kernel_runs_this_interpreter_in_the_notebooks_folder():
    notebook = nbformat.v4.new_notebook()
    notebook.cells = [
        nbformat.v4.new_code_cell("import os, sys; print(sys.executable, os.getcwd())")
    ]
    nbclient.NotebookClient(
        notebook, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOKS)}}
    ).execute()
    executable, cwd = notebook.cells[0].outputs[0].text.split()
    assert Path(executable).resolve() == Path(sys.executable).resolve()
    assert Path(cwd).resolve() == NOTEBOOKS


def test_bring_up(monkeypatch):
    text, _ = execute("01_bring_up", monkeypatch)
    assert "Robot 'armando'" in text
    for joint, limit in [("j0", 2.57), ("j1", 3.14), ("j2", 3.14), ("j3", 3.14)]:
        assert re.search(rf"^{joint}\s+revolute\s+{-limit:.2f}\s+{limit:.2f}\s", text, re.M), joint
    assert "collision layer shown: True" in text
    assert "visual layer shown: False" in text


def test_control(monkeypatch):
    text, pictures = execute("02_control", monkeypatch)
    assert pictures == 6  # per run: positions.png and efforts.png
    for scenario in ("position", "trajectory"):
        match = re.search(rf"^{scenario}: (\d+) steps, largest final error (\S+) rad$", text, re.M)
        assert match, f"no summary line for {scenario}"
        assert int(match[1]) == 5
        assert float(match[2]) <= 0.01
    match = re.search(r"^sinusoid: tracking error (\S+) rad$", text, re.M)
    assert match and float(match[1]) < 0.05
    # Each run wrote its logs where the notebook plots them from.
    from armando_drake import PROJECT_ROOT

    folder = PROJECT_ROOT / "out" / "notebooks" / "02_control"
    for scenario in ("position", "trajectory", "sinusoid"):
        header = (folder / scenario / "joint_states.csv").read_text().splitlines()[0]
        assert "j0_effort" in header
    summary = json.loads((folder / "position" / "summary.json").read_text())
    assert len(summary["steps"]) == 5


def test_camera(monkeypatch):
    text, pictures = execute("03_camera", monkeypatch)
    assert pictures == 2  # colour and depth; the blue pixels
    assert "cameras: camera" in text
    match = re.search(r"^blue pixels: (\d+)$", text, re.M)
    assert match and int(match[1]) > 1000
    depth = re.search(r"^median depth on the disc: (\S+) m$", text, re.M)
    assert depth and 0.1 < float(depth[1]) < 2.0


def test_your_robot(monkeypatch):
    text, _ = execute("04_your_robot", monkeypatch)
    if (COURSE_PACKAGE / "urdf" / "arm.urdf").is_file():
        assert f"Using the course package at {COURSE_PACKAGE}" in text
    else:
        assert "falls back to the built-in Armando model" in text
    assert "joints: j0 [-2.57, 2.57], j1 [-3.14, 3.14]" in text
    match = re.search(r"^largest final error: (\S+) rad$", text, re.M)
    assert match and float(match[1]) <= 0.01


def test_task_space(monkeypatch):
    text, pictures = execute("05_task_space", monkeypatch)
    assert pictures == 6  # four comparisons, two paths
    rows = re.findall(
        r"^(linear|circular)\s+(trapezoidal|cubic)\s+(joint space|operational space)"
        r"\s+(\S+)\s+(\S+)\s+(\S+)\s+\S+$",
        text,
        re.M,
    )
    assert len(rows) == 8
    for *_, largest, rms, orientation in rows:
        assert float(largest) <= 1.0 and 0 < float(rms) <= float(largest)  # [mm]
        assert float(orientation) <= 0.01  # [rad]
    for path in ("linear", "circular"):
        match = re.search(rf"^Armando {path}: max position error (\S+) mm$", text, re.M)
        assert match and float(match[1]) <= 2.0


def test_mobile_robot(monkeypatch):
    text, pictures = execute("09_mobile_robot", monkeypatch)
    assert pictures == 2  # the x-y path, the scan
    # 4.5 s: the fall, then 0.2 m/s straight from 1 s: about 0.7 m.
    travelled = re.search(r"^distance travelled: (\S+) m$", text, re.M)
    assert travelled and 0.6 < float(travelled[1]) < 0.8
    drift = re.search(r"^odometry drift: (\S+) mm$", text, re.M)
    assert drift and float(drift[1]) < 20.0
    samples = re.search(r"^base.csv: (\d+) samples over (\S+) s$", text, re.M)
    assert samples and float(samples[2]) == pytest.approx(4.5, abs=0.05)
    scan = re.search(
        r"^/scan: (\d+) messages, 640 ranges each, (\d+) hits, nearest (\S+) m$", text, re.M
    )
    assert scan and int(scan[1]) >= 40 and int(scan[2]) > 300
    assert 0.1 <= float(scan[3]) < 2.0


def test_navigation(monkeypatch):
    text, pictures = run_notebook("10_navigation", monkeypatch, timeout=240)
    assert pictures == 3  # the navigation figure, map and costmap, the sweep's figure
    assert re.search(r"^goal \(0.7, -0.6, -1.0\): SUCCEEDED at t = \S+ s$", text, re.M)
    error = re.search(
        r"^goal: reached True, position error (\S+) m, yaw error (\S+) rad",
        text,
        re.M,
    )
    assert error and float(error[1]) <= 0.1 and float(error[2]) <= 0.2
    assert "goals reached: 1/1, collisions: 0" in text
    cells = re.search(
        r"^occupied cells: (\d+), lethal or inscribed costmap cells: (\d+)$", text, re.M
    )
    assert cells and int(cells[2]) > int(cells[1]) > 100  # inflated by the robot's radius
    rows = re.findall(r"^([01]) +(\d) +(\S+) +(\S+) +(\S+) +(\S+) +(\d+)  (0\.[46])$", text, re.M)
    assert [(r[0], r[7]) for r in rows] == [("0", "0.4"), ("1", "0.6")]
    assert all(r[1] == "1" and r[6] == "0" for r in rows)  # the first goal, no collision
    assert float(rows[1][2]) < float(rows[0][2])  # faster
