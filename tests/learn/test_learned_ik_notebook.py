"""notebooks/11_learned_ik.ipynb runs top to bottom in short mode and prints its figures."""

import re

from conftest import run_notebook


def test_learned_ik_notebook(monkeypatch):
    text, _ = run_notebook("11_learned_ik", monkeypatch, timeout=600)
    assert "| network (ONNX Runtime) |" in text
    raw = re.search(r"^network alone: median position error (\S+) mm$", text, re.M)
    assert raw and float(raw[1]) <= 6.0  # the run's held-out median: 4.9 mm
    refined = re.search(
        r"^network \+ 3 Gauss-Newton steps: median position error (\S+) mm$", text, re.M
    )
    assert refined and float(refined[1]) <= 0.1
    reached = re.findall(r"^target \d+: reached within (\S+) mm", text, re.M)
    assert len(reached) == 2 and max(map(float, reached)) < 3.0
