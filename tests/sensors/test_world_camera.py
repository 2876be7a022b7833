"""The camera in the running world: the scenario's disc in view, the live page in Chromium."""

import numpy as np
import pytest
from browser import browser_page, open_url, running
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario


def project(world, context, p_W):
    """Pixel (u, v) of world point p_W in the camera, by the pinhole model."""
    camera = world.robot().cameras["camera"]
    info = camera.info
    plant = world.plant
    X_WL = plant.GetBodyByName(info.link).EvalPoseInWorld(plant.GetMyContextFromRoot(context))
    X_WC = X_WL @ info.X_LC()
    p_C = X_WC.inverse() @ np.asarray(p_W)
    f = info.width / (2 * np.tan(info.horizontal_fov / 2))
    u = info.width / 2 + f * p_C[0] / p_C[2]
    v = info.height / 2 + f * p_C[1] / p_C[2]
    return np.array([u, v]), p_C[2]


def test_camera_scenario_frame_shows_the_blue_disc():
    scenario = load_scenario("camera", "logging: {console_rate: 0}\ncamera: {live_view: false}")
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.05)
    context = simulator.get_context()
    image = world.diagram.GetOutputPort("camera.color_image").Eval(context).data
    depth = world.diagram.GetOutputPort("camera.depth_image").Eval(context).data[..., 0]
    assert image.shape == (480, 640, 4)
    (disc,) = [o for o in scenario.objects if o.name == "blue_disc"]
    top_centre = np.array(disc.xyz) + [0, 0, disc.shape.length / 2]
    (u, v), distance = project(world, context, top_centre)
    assert 0 <= u < 640 and 0 <= v < 480, (u, v)
    rgb = image[..., :3].astype(int)
    # Blue by hue: the lit side and the darker top both have b >> r, g; the
    # light-blue sky (r, g high) and the grey ground do not.
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    blue = (b > 20) & (b > 2 * r) & (b > 2 * g)
    # The disc's top face around its projected centre is blue...
    region = blue[int(v) - 10 : int(v) + 10, int(u) - 10 : int(u) + 10]
    assert region.mean() > 0.9
    # ... thousands of pixels are, and nearly all of them lie around that centre.
    ys, xs = np.nonzero(blue)
    assert len(xs) > 5000
    assert abs(np.median(xs) - u) < 60 and abs(np.median(ys) - v) < 60
    # The depth there is the distance along the optical axis to the disc's top.
    assert depth[int(round(v)), int(round(u))] == pytest.approx(distance, abs=0.01)


SNAPSHOT_JS = """() => {
  const image = document.querySelector('img');
  if (!image || !image.complete || image.naturalWidth === 0) return null;
  const canvas = document.createElement('canvas');
  canvas.width = image.naturalWidth;
  canvas.height = image.naturalHeight;
  const context = canvas.getContext('2d');
  context.drawImage(image, 0, 0);
  const data = context.getImageData(0, 0, canvas.width, canvas.height).data;
  const colours = new Set();
  let blue = 0;
  for (let i = 0; i < data.length; i += 4) {
    const [r, g, b] = [data[i], data[i + 1], data[i + 2]];
    colours.add((r << 16) | (g << 8) | b);
    if (b > 20 && b > 2 * r && b > 2 * g) blue += 1;
  }
  return [canvas.width, canvas.height, colours.size, blue];
}"""


@pytest.mark.browser
def test_live_view_during_a_run_shows_the_camera_image(chromium):
    args = [
        "armando_drake.world",
        "--scenario",
        "camera",
        "--no-meshcat",
        "--camera-view",
        "--duration",
        "60",
        "--quiet",
    ]
    with running(args, r"Camera view: (\S+)") as (_, url):
        with browser_page(chromium) as page:
            open_url(page, url)
            # The page swaps its image at the camera rate; take the one it shows
            # as soon as one is decoded, draw it on a canvas and read it back.
            handle = page.wait_for_function(SNAPSHOT_JS, timeout=60000)
            width, height, colours, blue = handle.json_value()
    assert [width, height] == [640, 480]
    assert colours > 20, "the live image is (nearly) one colour"
    assert blue > 5000, "the blue disc is not in the live image"


def test_camera_max_rate_caps_the_cameras_for_interactive_runs_and_says_so(tmp_path):
    import json
    import subprocess
    import sys

    def run(*extra):
        out = tmp_path / ("capped" if extra else "own")
        command = [sys.executable, "-m", "armando_drake.world", "--scenario", "vision_blob"]
        command += ["--no-meshcat", "--realtime-rate", "0", "--renderer", "vtk"]
        command += ["--duration", "0.5", "--output", str(out), *extra]
        done = subprocess.run(command, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        return json.loads((out / "summary.json").read_text()), done.stdout + done.stderr

    own, log = run()
    assert "interactive" not in own and "interactive setting" not in log  # off by default
    assert own["vision"]["frames"] == 15  # the scenario's 30 Hz
    camera = {"renderer": "RenderEngineVtk", "width": 640, "height": 480, "rate": 30.0}
    assert own["cameras"] == {"top_camera": camera | {"antialiasing": "none"}}
    # VTK's FXAA pass on request: said in the summary and the log, the same detections.
    smooth, log = run("--set", "camera: {antialiasing: true}")
    assert smooth["cameras"] == {"top_camera": camera | {"antialiasing": "FXAA"}}
    assert "rendered by RenderEngineVtk with FXAA" in log
    assert smooth["vision"]["detections"] == own["vision"]["detections"] == 15
    capped, log = run("--camera-max-rate", "10")
    assert capped["interactive"] == {"camera.max_rate": 10.0}
    assert "camera.max_rate=10 (an interactive setting)" in log
    assert "renders at 10 Hz instead of its 30 Hz" in log
    assert capped["vision"]["frames"] == 5  # the detector follows its camera
