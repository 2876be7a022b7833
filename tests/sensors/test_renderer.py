"""Choosing the camera renderer, and the private Xvfb that Drake's OpenGL renderer runs on."""

import os
import shutil
import subprocess
import sys
import textwrap
import time

import pytest
from conftest import skip_or_fail

from armando_drake.sensors.camera import CameraError, choose_renderer
from armando_drake.simulation.scenario import ScenarioError, load_scenario

CHILD = """
import os
from armando_drake.sensors.camera import choose_renderer
from armando_drake.tools import xdisplay
print(choose_renderer({wanted!r}), os.environ.get("DISPLAY", ""),
      xdisplay._started.pid if xdisplay._started else 0, flush=True)
"""


def choose_in_a_fresh_process(wanted: str, env_changes: dict) -> tuple[int, str, str]:
    """(return code, stdout, stderr) of choose_renderer(wanted) in a new Python."""
    env = dict(os.environ)
    for key, value in env_changes.items():
        if value is None:
            env.pop(key, None)
        else:
            env[key] = value
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(CHILD.format(wanted=wanted))],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    return done.returncode, done.stdout, done.stderr


@pytest.fixture
def xvfb():
    if shutil.which("Xvfb") is None:
        skip_or_fail("Xvfb is not installed (Debian package xvfb)")


def test_auto_without_a_display_starts_a_private_xvfb_that_dies_with_the_process(xvfb):
    code, out, err = choose_in_a_fresh_process("auto", {"DISPLAY": None})
    assert code == 0, err
    renderer, display, pid = out.split()
    assert renderer == "gl"
    assert display.startswith(":") and display[1:].isdigit()
    pid = int(pid)
    assert pid > 0
    # The child has exited: Linux's parent-death signal has ended its Xvfb (a zombie at
    # most, where nothing reaps it).
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and os.path.exists(f"/proc/{pid}"):
        time.sleep(0.05)
    status = open(f"/proc/{pid}/stat").read().split()[2] if os.path.exists(f"/proc/{pid}") else ""
    assert status in ("", "Z"), f"Xvfb {pid} still runs ({status})"


def test_auto_falls_back_to_vtk_and_gl_fails_clearly_without_xvfb():
    no_xvfb = {"DISPLAY": None, "PATH": os.path.dirname(sys.executable)}
    code, out, err = choose_in_a_fresh_process("auto", no_xvfb)
    assert code == 0, err
    assert out.split()[0] == "vtk"
    code, out, err = choose_in_a_fresh_process("gl", no_xvfb)
    assert code != 0
    assert "camera.renderer='gl' needs an X display: Xvfb is not installed" in err
    assert "apt install xvfb" in err


def test_vtk_is_taken_as_asked_and_an_unknown_renderer_is_named():
    assert choose_renderer("vtk") == "vtk"
    with pytest.raises(CameraError, match="camera.renderer='opengl' must be one of auto, gl, vtk"):
        choose_renderer("opengl")


def test_an_unknown_renderer_in_a_scenario_names_the_file():
    from armando_drake.simulation.builder import MakeWorld

    scenario = load_scenario("camera", "camera: {renderer: opengl, live_view: false}")
    with pytest.raises(ScenarioError, match=r"override 'camera: .*': camera\.renderer='opengl'"):
        MakeWorld(scenario, quiet=True, source="diagrams/camera.yaml")
    scenario = load_scenario("camera")
    scenario.camera.renderer = "opengl"
    with pytest.raises(ScenarioError, match=r"^diagrams/camera\.yaml: camera\.renderer='opengl'"):
        MakeWorld(scenario, quiet=True, source="diagrams/camera.yaml")
