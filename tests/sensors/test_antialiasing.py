"""VTK cameras without VTK's FXAA pass by default, with it on request (sensors.antialiasing).

Mesa decides once per process whether it replaces shaders, so each case renders in a new
Python."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from armando_drake.sensors.antialiasing import READ_PATH, SHADER_DIR

# A red box turned 0.3 rad about z, seen from 1 m above on a 640 x 480 VTK camera: its
# top face and the background are two flat colours, its edges slanted.
CHILD = """
import json, sys
import numpy as np
import armando_drake
from armando_drake.sensors.antialiasing import use_vtk_antialiasing
from pydrake.geometry import (
    Box, ClippingRange, ColorRenderCamera, GeometryId, MakeRenderEngineVtk,
    PerceptionProperties, RenderCameraCore, RenderEngineVtkParams, Rgba)
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.sensors import CameraInfo, ImageRgba8U

fxaa = use_vtk_antialiasing({on})
engine = MakeRenderEngineVtk(RenderEngineVtkParams())
red = PerceptionProperties()
red.AddProperty("phong", "diffuse", Rgba(0.8, 0.2, 0.2, 1))
X_WB = RigidTransform(RollPitchYaw(0, 0, 0.3), [0, 0, 0])
engine.RegisterVisual(GeometryId.get_new_id(), Box(0.2, 0.2, 0.2), red, X_WB, True)
core = RenderCameraCore(
    "vtk", CameraInfo(640, 480, np.pi / 4), ClippingRange(0.01, 10), RigidTransform())
engine.UpdateViewpoint(RigidTransform(RollPitchYaw(np.pi, 0, 0), [0, 0, 1.0]))
image = ImageRgba8U(640, 480)
engine.RenderColorImage(ColorRenderCamera(core, False), image)
np.save(sys.argv[1], np.array(image.data)[..., :3])
print(json.dumps(fxaa))
"""


def render(tmp_path, on: bool, env: dict | None = None) -> tuple[np.ndarray, bool]:
    """(the box's frame, whether FXAA ran by use_vtk_antialiasing's word), rendered in
    a new Python with ``use_vtk_antialiasing(on)`` and the environment ``env``."""
    out = tmp_path / f"frame_{on}_{bool(env)}.npy"
    environment = {key: value for key, value in os.environ.items() if key != READ_PATH}
    environment |= env or {}
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(CHILD.format(on=on)), str(out)],
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "ERROR" not in done.stderr, done.stderr  # VTK's complaints, e.g. of a shader
    return np.load(out), json.loads(done.stdout.splitlines()[-1])


def colours(frame: np.ndarray) -> int:
    return len(np.unique(frame.reshape(-1, 3), axis=0))


def test_the_shader_folder_holds_one_replacement_for_vtks_fxaa_filter():
    (shader,) = SHADER_DIR.iterdir()
    assert shader.name.startswith("FS_") and shader.suffix == ".glsl"  # Mesa's naming
    assert "texelFetch(Input" in shader.read_text()  # a copy of the pass's input


def test_vtk_frames_have_hard_edges_by_default_and_fxaa_on_request(tmp_path):
    plain, fxaa_plain = render(tmp_path, on=False)
    smooth, fxaa_smooth = render(tmp_path, on=True)
    assert (fxaa_plain, fxaa_smooth) == (False, True)
    # Without the pass: the box and the background, nothing between.
    assert colours(plain) == 2
    box = (plain == plain[240, 320]).all(-1)
    assert 12000 < box.sum() < 20000  # about 129 x 129 px seen from 1 m
    # FXAA blends the slanted edges: colours between the two.
    assert colours(smooth) > 2
    differ = (plain != smooth).any(-1)
    assert 100 < differ.sum() < 2000
    # ... and only there: every pixel it changed lies on the box's outline.
    edge = box ^ np.roll(box, 1, 0) | box ^ np.roll(box, -1, 0)
    edge |= box ^ np.roll(box, 1, 1) | box ^ np.roll(box, -1, 1)
    near_edge = edge | np.roll(edge, 1, 0) | np.roll(edge, -1, 0)
    near_edge |= np.roll(near_edge, 1, 1) | np.roll(near_edge, -1, 1)
    assert not (differ & ~near_edge).any()


SHADER_FIRST = """
import numpy as np
from pydrake.geometry import MakeRenderEngineVtk, RenderEngineVtkParams, RenderCameraCore
from pydrake.geometry import ClippingRange, ColorRenderCamera
from pydrake.math import RigidTransform
from pydrake.systems.sensors import CameraInfo, ImageRgba8U

engine = MakeRenderEngineVtk(RenderEngineVtkParams())  # a frame before the package
core = RenderCameraCore("vtk", CameraInfo(8, 8, 1.0), ClippingRange(0.1, 1), RigidTransform())
engine.RenderColorImage(ColorRenderCamera(core, False), ImageRgba8U(8, 8))
import armando_drake
from armando_drake.sensors.antialiasing import use_vtk_antialiasing
print(use_vtk_antialiasing(False))
"""


def test_fxaa_that_runs_although_asked_off_is_found_and_said():
    # Mesa decides at a process's first shader: one compiled before the package was
    # imported leaves VTK's pass in place, which the probe frame finds.
    environment = {key: value for key, value in os.environ.items() if key != READ_PATH}
    done = subprocess.run(
        [sys.executable, "-c", SHADER_FIRST],
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-1] == "True"
    assert "antialias their frames (FXAA) although camera.antialiasing is false" in done.stderr
    assert "before armando_drake was imported" in done.stderr


def test_a_users_own_shader_folder_is_kept_and_vtk_antialiases(tmp_path):
    own = tmp_path / "shaders"
    own.mkdir()
    frame, fxaa = render(tmp_path, on=False, env={READ_PATH: str(own)})
    assert fxaa is True
    assert colours(frame) > 2


@pytest.mark.parametrize("value", [True, False])
def test_the_scenario_setting_reads_as_a_boolean(value):
    from armando_drake.simulation.scenario import load_scenario

    scenario = load_scenario("camera", f"camera: {{antialiasing: {str(value).lower()}}}")
    assert scenario.camera.antialiasing is value


def test_opengl_cameras_have_no_antialiasing_to_keep_and_say_so(caplog):
    from conftest import skip_or_fail

    from armando_drake.sensors.cameras import _renderer
    from armando_drake.sensors.config import CameraSettings
    from armando_drake.tools.xdisplay import DisplayError, ensure_display

    try:
        ensure_display()
    except DisplayError as error:
        skip_or_fail(f"no X display for RenderEngineGl: {error}")
    assert _renderer(CameraSettings(renderer="gl")) == ("gl", False)
    assert "antialiasing" not in caplog.text
    assert _renderer(CameraSettings(renderer="gl", antialiasing=True)) == ("gl", False)
    assert "camera.antialiasing: OpenGL cameras render without antialiasing" in caplog.text
