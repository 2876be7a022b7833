"""`python -m armando_drake.display`: the RViz step, run as a user would."""

import subprocess
import sys

import pytest
from browser import browser_page, open_url, running, wait_for_scene_paths

from armando_drake import DEFAULT_DESCRIPTION


def display(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.display", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_loop_once_on_the_builtin_armando_exits_0():
    result = display("--loop-once", "--position", "0.5", "-0.5", "0.5", "0.2", "--show-collision")
    assert result.returncode == 0, result.stderr
    assert f"from {DEFAULT_DESCRIPTION}" in result.stdout
    assert "Joints: j0 [-2.57, 2.57], j1 [-3.14, 3.14], j2 [-3.14, 3.14], j3 [-3.14, 3.14]" in (
        result.stdout
    )
    assert "Meshcat: http://" in result.stdout


@pytest.mark.parametrize(
    "position, message",
    [
        (["0", "0"], "error: --position has 2 values, expected 4 (j0, j1, j2, j3)"),
        (["0", "3.5", "0", "0"], "error: --position j1=3.5 is outside its limits [-3.14, 3.14]"),
    ],
)
def test_bad_position_is_refused(position, message):
    result = display("--loop-once", "--position", *position)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_missing_description_is_named(tmp_path):
    result = display("--loop-once", "--description", str(tmp_path / "robot.urdf"))
    assert result.returncode == 2
    assert f"error: {tmp_path / 'robot.urdf'}: description file not found" in result.stderr


def test_bad_xacro_arg_is_named():
    result = display("--loop-once", "--xacro-arg", "prefix=left_")
    assert result.returncode == 2
    assert "--xacro-arg 'prefix=left_' is not of the form name:=value" in result.stderr


@pytest.mark.browser
def test_meshcat_page_shows_every_link_in_both_layers(chromium):
    """Chromium opens the running display and finds each link of Armando in the scene."""
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    from armando_drake.description.loader import load_robot

    plant, _ = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.0)
    robot = load_robot(plant)
    plant.Finalize()
    links = [
        plant.get_body(index).name()
        for index in plant.GetBodyIndices(robot.model_instance)
        if plant.GetCollisionGeometriesForBody(plant.get_body(index))
    ]
    assert len(links) >= 10
    with running(["armando_drake.display"], r"Meshcat: (\S+)") as (_, url):
        with browser_page(chromium) as page:
            open_url(page, url)

            def complete(paths):
                return all(
                    f"/drake/{layer}/{robot.name}/{link}" in paths
                    for link in links
                    for layer in ("illustration", "proximity")
                )

            paths = wait_for_scene_paths(page, complete)
            missing = [
                link for link in links if f"/drake/illustration/{robot.name}/{link}" not in paths
            ]
            assert not missing, f"links missing from the Meshcat scene: {missing}"
            assert complete(paths)
            # The view preset hides the collision layer and points the camera.
            visible = page.evaluate(
                "() => viewer.scene_tree.find(['drake', 'proximity']).object.visible"
            )
            assert visible is False
            # Robot pixels: the screenshot differs from the empty background
            # around the middle where the arm stands.
            png = page.screenshot()
    import io

    from matplotlib import image

    pixels = image.imread(io.BytesIO(png), format="png")[..., :3]
    view = pixels[60:]  # below the page's real-time rate plot
    # The background is a grey gradient (r == g == b); the arm has coloured parts (the
    # red base, the blue gripper). test_framing.py measures where it is drawn.
    saturation = view.max(axis=-1) - view.min(axis=-1)
    assert (saturation > 0.15).sum() > 5000, "no coloured robot pixels in the view"
