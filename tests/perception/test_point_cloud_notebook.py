"""notebooks/07_point_cloud runs top to bottom in short mode, as tests/entry_points/
test_notebooks.py runs the others, and shows every stage and the three clusters."""

import re

from conftest import run_notebook


def test_point_cloud_notebook(monkeypatch):
    text, pictures = run_notebook("07_point_cloud", monkeypatch)
    assert pictures == 2  # the stages, the clusters
    stages = re.findall(r"^stage (.+): (\d+) points", text, re.M)
    assert [name for name, _ in stages][0] == "input"
    assert len(stages) == 6 and int(stages[0][1]) == 640 * 480
    angle = re.search(r"normal (\S+) deg from vertical$", text, re.M)
    assert angle and float(angle[1]) < 1.0
    assert re.search(r"^clusters: 3$", text, re.M)
    assert len(re.findall(r"^cluster \d: centroid", text, re.M)) == 3
