"""An optional feature without its extra installed: one line naming the extra to install,
exit 2, before the run (never an internal error with a ModuleNotFoundError)."""

import os
import subprocess
import sys

import pytest
from test_input_errors import assert_one_line, run_main

from armando_drake import DIAGRAMS_DIR
from armando_drake.tools.extras import EXTRAS, MissingExtraError, missing_extra, require_extra


def block(monkeypatch, *names: str) -> None:
    """Makes ``import name`` (and its submodules) fail here, as without the package."""
    for loaded in [m for m in sys.modules if m.split(".")[0] in names]:
        monkeypatch.setitem(sys.modules, loaded, None)
    for name in names:
        monkeypatch.setitem(sys.modules, name, None)


@pytest.mark.parametrize(
    "blocked, args, needles",
    [
        ("cv2", ["--scenario", "vision_blob"], ["vision.blob needs OpenCV (cv2)", "[vision]"]),
        ("cv2", ["--scenario", "vision_armando"], ["vision.blob needs OpenCV (cv2)", "[vision]"]),
        ("cv2", ["--scenario", "vision_look_at"], ["object 'marker'", "OpenCV (cv2)", "[vision]"]),
        ("cv2", ["--scenario", "vision_dynamic"], ["object 'marker'", "OpenCV (cv2)", "[vision]"]),
        ("sklearn", ["--scenario", "perception"], ["scikit-learn and SciPy", "[perception]"]),
        ("foxglove", ["--foxglove", "0"], ["--foxglove", "Foxglove SDK", "[ros2]"]),
        ("onnxruntime", ["--scenario", "learned_ik"], ["learned_ik", "ONNX Runtime", "[learn]"]),
    ],
    ids=[
        "vision_blob",
        "vision_armando",
        "vision_look_at",
        "vision_dynamic",
        "perception",
        "foxglove",
        "learned_ik",
    ],
)
def test_a_missing_extra_is_one_line_naming_it(blocked, args, needles, monkeypatch, capsys):
    monkeypatch.chdir(DIAGRAMS_DIR.parent)  # the iiwa scenarios name models/ from there
    block(monkeypatch, blocked)
    code, out, err = run_main(*args, "--set", "camera: {live_view: false}", capsys=capsys)
    assert code == 2, err
    line = assert_one_line(err, *needles, "pip install 'armando-drake[")
    assert "ModuleNotFoundError" not in line
    assert " simulated in " not in out


def test_every_extra_is_one_of_pyproject(monkeypatch):
    import tomllib

    extras = tomllib.loads((DIAGRAMS_DIR.parent / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    assert {extra for extra, _, _ in EXTRAS.values()} <= set(extras)
    assert all(missing_extra(feature) is None for feature in EXTRAS)  # the test extra has all
    block(monkeypatch, "ray")
    with pytest.raises(MissingExtraError) as raised:
        require_extra("cluster", "--ray auto")
    assert str(raised.value) == (
        "--ray auto needs Ray (ray), which is not installed: pip install 'armando-drake[cluster]'"
    )


def test_ros2_without_cyclone_dds_is_one_line_in_the_shell(tmp_path):
    # In its own process: this one may have loaded Cyclone DDS already (its imports are
    # made once).
    (tmp_path / "sitecustomize.py").write_text("import sys\nsys.modules['cyclonedds'] = None\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(tmp_path), env.get("PYTHONPATH")]))
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--ros2", "--no-meshcat"]
        + ["--realtime-rate", "0", "--duration", "0.1"],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert result.returncode == 2, result.stderr
    assert_one_line(result.stderr, "Cyclone DDS", "pip install 'armando-drake[ros2]'")
