"""python -m armando_drake.graph: the world diagram drawn with Graphviz (the rqt_graph step)."""

import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from conftest import skip_or_fail

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

SVG = "{http://www.w3.org/2000/svg}"


def graph(*args: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.graph", *args],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )


@pytest.fixture
def dot() -> str:
    path = shutil.which("dot")
    if path is None:
        skip_or_fail("Graphviz's dot is not installed (apt-get install graphviz)")
    return path


def svg_texts(path) -> list[str]:
    """Every text line of an SVG drawing."""
    root = ET.parse(path).getroot()
    return ["".join(node.itertext()).strip() for node in root.iter(f"{SVG}text")]


def test_svg_names_every_system_and_port_of_the_position_world(dot, tmp_path):
    output = tmp_path / "world.svg"
    result = graph("--scenario", "position", "-o", str(output))
    assert result.returncode == 0, result.stderr
    texts = svg_texts(output)
    world = MakeWorld(load_scenario("position", "logging: {console_rate: 0}"), quiet=True)
    systems = [system.get_name() for system in world.diagram.GetSystems()]
    # plant, scene graph, controller manager, effort state, gravity feed-forward,
    # sequencer, joint-state vector, logger; and the velocity limits' cap (on by
    # default), its zero effort input and the adder of its torque and the feed-forward
    assert len(systems) == 11, systems
    missing = [name for name in systems if f"name={name}" not in texts]
    assert missing == [], f"systems not drawn: {missing}"
    # The named connections: the sequencer's commands topic and the broadcaster's output.
    for port in ("commands", "joint_states", "desired_state", "reference"):
        assert port in texts, port
    # Drake draws one <g class="edge"> per connection.
    root = ET.parse(output).getroot()
    edges = [g for g in root.iter(f"{SVG}g") if g.get("class") == "edge"]
    assert len(edges) >= world.diagram.num_input_ports() + 10, len(edges)


def test_png_and_dot_source(dot, tmp_path):
    result = graph("--scenario", "trajectory", "-o", str(tmp_path / "graph.png"))
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "graph.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "controller_manager" in result.stdout  # it runs the trajectory controller
    result = graph("-o", str(tmp_path / "graph.dot"))
    assert result.returncode == 0, result.stderr
    source = (tmp_path / "graph.dot").read_text()
    assert source.startswith("digraph") and "name=command_sequencer" in source
    assert "position_controller.commands" in source  # the manager's input of that controller


def test_missing_dot_says_how_to_install_it(tmp_path):
    env = dict(os.environ, PATH=str(tmp_path))  # a PATH without dot
    result = graph("-o", str(tmp_path / "world.svg"), env=env)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "error: Graphviz's dot is not on the PATH: install Graphviz "
        "(Debian/Ubuntu: apt-get install graphviz)"
    ]
    assert not (tmp_path / "world.svg").exists()


def test_unknown_extension_is_refused(tmp_path):
    result = graph("-o", str(tmp_path / "world.jpeg"))
    assert result.returncode == 2
    assert "'.jpeg'" in result.stderr and "Traceback" not in result.stderr


def test_help_has_examples():
    result = graph("--help")
    assert result.returncode == 0
    assert "python -m armando_drake.graph -o world.svg" in result.stdout
    assert "apt-get install graphviz" in result.stdout
