"""notebooks/06_vision runs top to bottom in short mode, as tests/entry_points/
test_notebooks.py runs the others, and prints what it promises."""

import re
from pathlib import Path

import nbclient
import nbformat
from conftest import IIWA_PACKAGE, skip_or_fail

NOTEBOOK = Path(__file__).resolve().parents[2] / "notebooks" / "06_vision.ipynb"


def test_vision_notebook(monkeypatch):
    if not IIWA_PACKAGE.is_dir():
        skip_or_fail(f"06_vision's last part needs {IIWA_PACKAGE}")
    monkeypatch.setenv("ARMANDO_DRAKE_SHORT", "1")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    assert all(
        not cell.get("outputs") and cell.get("execution_count") is None
        for cell in notebook.cells
        if cell.cell_type == "code"
    ), "06_vision.ipynb is committed with outputs; clear them"
    nbclient.NotebookClient(
        notebook,
        kernel_name="python3",
        timeout=120,
        resources={"metadata": {"path": str(NOTEBOOK.parent)}},
    ).execute()
    outputs = [output for cell in notebook.cells for output in cell.get("outputs", [])]
    text = "\n".join(output.text for output in outputs if output.output_type == "stream")
    pictures = sum("image/png" in output.get("data", {}) for output in outputs)
    assert pictures == 3, text  # raw + keypoints, the marker, the look-at plots
    errors = [float(e) for e in re.findall(r"px, (\S+) px from the projected centre", text)]
    assert len(errors) == 2 and max(errors) <= 2.0, text
    assert "keypoints: 2" in text
    match = re.search(r"position error (\S+) mm, orientation error (\S+) deg", text)
    assert match and float(match[1]) <= 5.0 and float(match[2]) <= 2.0, text
    match = re.search(r"final pointing error (\S+) rad", text)
    assert match and float(match[1]) < 0.05, text  # after 2 s in short mode
