"""notebooks/06_vision runs top to bottom in short mode, as tests/entry_points/
test_notebooks.py runs the others, and prints what it promises."""

import re

from conftest import run_notebook


def test_vision_notebook(monkeypatch):
    text, pictures = run_notebook("06_vision", monkeypatch)
    assert pictures == 4, text  # raw + keypoints, the marker, the look-at plots, Armando
    errors = [float(e) for e in re.findall(r"px, (\S+) px from the projected centre", text)]
    assert len(errors) == 2 and max(errors) <= 2.0, text
    assert "keypoints: 2" in text
    match = re.search(r"position error (\S+) mm, orientation error (\S+) deg", text)
    assert match and float(match[1]) <= 5.0 and float(match[2]) <= 2.0, text
    match = re.search(r"final pointing error (\S+) rad", text)
    assert match and float(match[1]) < 0.05, text  # after 2 s in short mode
    match = re.search(r"final pointing error at the disc (\S+) rad", text)
    assert match and float(match[1]) < 0.05, text  # Armando, after 2 s
    dynamic = re.findall(r"_look_at_controller: max path error (\S+) mm, pointing error at the "
                         r"end (\S+) rad", text)  # fmt: skip
    assert len(dynamic) == 2, text  # 1 s in short mode: halfway along the path
    assert all(float(mm) <= 2.0 and float(rad) < 0.05 for mm, rad in dynamic), text
