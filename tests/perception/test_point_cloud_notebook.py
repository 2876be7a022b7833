"""notebooks/07_point_cloud runs top to bottom in short mode, as tests/entry_points/
test_notebooks.py runs the others, and shows every stage and the three clusters."""

import re
from pathlib import Path

import nbclient
import nbformat

NOTEBOOK = Path(__file__).resolve().parents[2] / "notebooks" / "07_point_cloud.ipynb"


def test_point_cloud_notebook(monkeypatch):
    monkeypatch.setenv("ARMANDO_DRAKE_SHORT", "1")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    assert all(
        not cell.get("outputs") and cell.get("execution_count") is None
        for cell in notebook.cells
        if cell.cell_type == "code"
    ), "07_point_cloud.ipynb is committed with outputs; clear them"
    nbclient.NotebookClient(
        notebook,
        kernel_name="python3",
        timeout=120,
        resources={"metadata": {"path": str(NOTEBOOK.parent)}},
    ).execute()
    outputs = [output for cell in notebook.cells for output in cell.get("outputs", [])]
    text = "\n".join(output.text for output in outputs if output.output_type == "stream")
    pictures = sum("image/png" in output.get("data", {}) for output in outputs)
    assert pictures == 2  # the stages, the clusters
    stages = re.findall(r"^stage (.+): (\d+) points", text, re.M)
    assert [name for name, _ in stages][0] == "input"
    assert len(stages) == 6 and int(stages[0][1]) == 640 * 480
    angle = re.search(r"normal (\S+) deg from vertical$", text, re.M)
    assert angle and float(angle[1]) < 1.0
    assert re.search(r"^clusters: 3$", text, re.M)
    assert len(re.findall(r"^cluster \d: centroid", text, re.M)) == 3
