"""Hostile Gazebo worlds: what would take minutes or wait forever is refused at once, in
one line naming the file, before Drake sees it: a world of 10,000 boxes (as models or as
links of one model), a collision mesh of 20,000 parts, a FIFO as a model's model.sdf or
as the world file. A world within the limits loads."""

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import refused_in_one_line
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from armando_drake.description.worlds import (
    MAX_MESH_PARTS,
    MAX_WORLD_ELEMENTS,
    MAX_WORLD_MODELS,
    WorldError,
    load_world,
)

WATCHDOG = 30  # [s] a refusal takes well under a second; more is a hang
BOX = (
    '<link name="{link}"><pose>{x} {y} 0.25 0 0 0</pose>'
    '<collision name="c"><geometry><box><size>0.2 0.2 0.5</size></box></geometry></collision>'
    '<visual name="v"><geometry><box><size>0.2 0.2 0.5</size></box></geometry></visual></link>'
)


def write_world(path: Path, body: str) -> Path:
    path.write_text(
        f'<?xml version="1.0"?>\n<sdf version="1.9"><world name="w">\n{body}\n</world></sdf>\n'
    )
    return path


def boxes_as_models(count: int) -> str:
    return "\n".join(
        f'<model name="b{k}"><static>true</static>{box}</model>'
        for k in range(count)
        for box in [BOX.format(link="l", x=k % 100, y=k // 100)]
    )


def load(path: Path):
    plant, _ = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.002)
    return load_world(plant, path)


def refused(path: Path, *names: str) -> str:
    """Loading ``path`` raises a WorldError of one line naming ``names``, within the
    watchdog's time."""
    return refused_in_one_line(lambda: load(path), WorldError, names, WATCHDOG)


def test_a_world_of_10000_boxes_is_refused_before_drake_parses_it(tmp_path):
    path = write_world(tmp_path / "boxes.sdf", boxes_as_models(10_000))
    start = time.monotonic()
    message = refused(path, "boxes.sdf", str(MAX_WORLD_MODELS), "models")
    assert time.monotonic() - start < 10, message


def test_10000_boxes_as_links_of_one_model_are_refused(tmp_path):
    links = "".join(BOX.format(link=f"l{k}", x=k % 100, y=k // 100) for k in range(10_000))
    path = write_world(
        tmp_path / "links.sdf", f'<model name="m"><static>true</static>{links}</model>'
    )
    refused(path, "links.sdf", str(MAX_WORLD_ELEMENTS))


def test_10000_includes_of_one_box_model_are_refused(tmp_path):
    folder = tmp_path / "models" / "box"
    folder.mkdir(parents=True)
    (folder / "model.sdf").write_text(
        '<sdf version="1.9"><model name="box"><static>true</static>'
        f"{BOX.format(link='l', x=0, y=0)}</model></sdf>"
    )
    includes = "\n".join(
        f"<include><uri>model://box</uri><name>b{k}</name><pose>{k} 0 0 0 0 0</pose></include>"
        for k in range(10_000)
    )
    refused(write_world(tmp_path / "many.sdf", includes), "many.sdf", str(MAX_WORLD_MODELS))


def test_a_world_of_100_boxes_loads(tmp_path):
    loaded = load(write_world(tmp_path / "yard.sdf", boxes_as_models(100)))
    assert len(loaded.models) == 100


def tetrahedra_obj(path: Path, count: int) -> Path:
    """An OBJ of ``count`` separate tetrahedra (each a convex part)."""
    corners = np.array([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0], [0, 0, 0.05]])
    faces = np.array([[1, 3, 2], [1, 2, 4], [1, 4, 3], [2, 3, 4]])
    lines = []
    for k in range(count):
        offset = np.array([k % 150, k // 150, 0]) * 0.1
        lines += [f"v {x:g} {y:g} {z:g}" for x, y, z in corners + offset]
    lines += [f"f {a + 4 * k} {b + 4 * k} {c + 4 * k}" for k in range(count) for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_collision_mesh_of_20000_parts_is_refused_naming_it(tmp_path):
    mesh = tetrahedra_obj(tmp_path / "gravel.obj", 20_000)
    body = (
        '<model name="gravel"><static>true</static><link name="l"><collision name="c">'
        f"<geometry><mesh><uri>{mesh}</uri></mesh></geometry></collision></link></model>"
    )
    start = time.monotonic()
    message = refused(write_world(tmp_path / "pit.sdf", body), "gravel.obj", "20000")
    assert str(MAX_MESH_PARTS) in message
    assert time.monotonic() - start < 20, message


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_as_a_models_model_sdf_is_refused_naming_it(tmp_path):
    folder = tmp_path / "models" / "crate"
    folder.mkdir(parents=True)
    os.mkfifo(folder / "model.sdf")
    world = write_world(tmp_path / "yard.sdf", "<include><uri>model://crate</uri></include>")
    refused(world, str(folder / "model.sdf"), "FIFO")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_as_the_world_file_is_refused(tmp_path):
    os.mkfifo(tmp_path / "world.sdf")
    refused(tmp_path / "world.sdf", "world.sdf", "FIFO")


def test_the_command_refuses_a_world_of_10000_boxes_in_one_line_with_exit_2(tmp_path):
    world = write_world(tmp_path / "boxes.sdf", boxes_as_models(10_000))
    scenario = tmp_path / "yard.yaml"
    scenario.write_text(f"world_file: {world}\nsimulation: {{duration: 0.1}}\n")
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--scenario", str(scenario),
         "--no-meshcat", "--realtime-rate", "0", "--quiet"],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "boxes.sdf" in lines[0] and str(MAX_WORLD_MODELS) in lines[0]


def test_a_lidar_mounted_100_m_up_is_warned_about_naming_it_and_its_height(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--scenario", "fra2mo",
         "--set", "robot: {base_xyz: [0, 0, 100]}", "--duration", "0.1",
         "--no-meshcat", "--realtime-rate", "0", "--quiet"],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    output = result.stdout + result.stderr  # the log's lines: on stdout when not a terminal
    warned = [line for line in output.splitlines() if "sees nothing" in line]
    assert len(warned) == 1, output
    assert "'laser_frame'" in warned[0] and "100 m above the world's floor" in warned[0]
