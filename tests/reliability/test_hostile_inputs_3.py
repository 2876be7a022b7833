"""Hostile inputs on the newer doors: map YAMLs and images, Nav2 parameter files, SLAM
files and the navigation section's goals. Each ends in one line naming the file, the key
or the value at fault (a UserInputError: exit 2 on the command line), in bounded time:
never an internal error, a hang or a silent wrong run."""

import json
import os
import shutil
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import refused_in_one_line
from PIL import Image

from armando_drake.learning.network import ALL_FEATURES, IkModel
from armando_drake.learning.training import read_dataset
from armando_drake.navigation.amcl import amcl_parameters
from armando_drake.navigation.costmap import costmap_parameters
from armando_drake.navigation.follower import controller_parameters
from armando_drake.navigation.maps import MAX_MAP_CELLS, OccupancyMap, load_map, save_map
from armando_drake.navigation.nav2_params import read_nav2
from armando_drake.navigation.slam import slam_parameters
from armando_drake.simulation.scenario import load_scenario
from armando_drake.simulation.validation import check_scenario
from armando_drake.tools.errors import UserInputError

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "models" / "fra2mo_description" / "config"
WATCHDOG = 60  # [s] a refusal takes milliseconds; more is a hang


def refused(call, *names: str) -> str:
    """``call()`` raises a UserInputError whose message is one line naming ``names``,
    within the watchdog's time."""
    return refused_in_one_line(call, UserInputError, names, WATCHDOG)


# ------------------------------------------------------------------------------ maps

MAP_YAML = {
    "image": "map.pgm",
    "mode": "trinary",
    "resolution": 0.05,
    "origin": [-1.0, -1.0, 0.0],
    "negate": 0,
    "occupied_thresh": 0.65,
    "free_thresh": 0.196,
}


def write_map(folder: Path, pixels: bytes | None = None, **changes) -> Path:
    """A map YAML (MAP_YAML with ``changes``) and its image (``pixels``, or a blank one)."""
    image = folder / changes.get("image", "map.pgm")
    if pixels is None:
        Image.fromarray(np.full((20, 30), 254, dtype=np.uint8), mode="L").save(image)
    elif isinstance(pixels, bytes):
        image.write_bytes(pixels)
    text = yaml.safe_dump({**MAP_YAML, **changes})
    for word in (".nan", ".inf", "-.inf"):  # safe_dump quotes nothing: written as YAML reads
        text = text.replace(f"'{word}'", word)
    path = folder / "map.yaml"
    path.write_text(text)
    return path


def png_header(width: int, height: int) -> bytes:
    """A PNG's signature, IHDR chunk (8-bit gray) and a few bytes of image data."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(bytes(64)))


MAP_CASES = {
    "resolution inf": ({"resolution": ".inf"}, None, ["map.yaml", "resolution", "inf"]),
    "resolution 1e300": ({"resolution": 1e300}, None, ["map.yaml", "resolution", "1e+300"]),
    "resolution 1e-9": ({"resolution": 1e-9}, None, ["map.yaml", "resolution"]),
    "origin nan": ({"origin": [".nan", 0.0, 0.0]}, None, ["map.yaml", "origin", "nan"]),
    "origin inf": ({"origin": [0.0, ".inf", 0.0]}, None, ["map.yaml", "origin", "inf"]),
    "pgm 100000x100000": ({}, b"P5\n100000 100000\n255\n" + bytes(64), ["map.pgm", "100000"]),
    "pgm maxval 0": ({}, b"P5\n4 4\n0\n" + bytes(16), ["map.pgm"]),
    "png 100000x100000": (
        {"image": "map.png"},
        png_header(100_000, 100_000),
        ["map.png", "100000"],
    ),
    "image a directory": ({"image": "."}, "none", ["map.yaml", "image"]),
    "image a fifo": ({"image": "fifo.pgm"}, "fifo", ["fifo.pgm"]),
}


@pytest.mark.parametrize("case", sorted(MAP_CASES))
def test_a_hostile_map_is_refused_in_one_line(tmp_path, case):
    changes, pixels, names = MAP_CASES[case]
    if pixels == "fifo":
        os.mkfifo(tmp_path / "fifo.pgm")
    path = write_map(tmp_path, pixels, **changes)
    refused(lambda: load_map(path), *names)


def test_a_binary_map_yaml_is_refused(tmp_path):
    path = tmp_path / "map.yaml"
    path.write_bytes(bytes(range(256)) * 4)
    refused(lambda: load_map(path), "map.yaml")


def test_a_fifo_map_yaml_is_refused(tmp_path):
    path = tmp_path / "map.yaml"
    os.mkfifo(path)
    refused(lambda: load_map(path), "map.yaml")


def test_a_map_over_the_cell_limit_is_refused_from_its_header(tmp_path):
    side = int(MAX_MAP_CELLS**0.5) + 1
    header = f"P5\n{side} {side}\n255\n".encode()
    path = write_map(tmp_path, header + bytes(16))
    message = refused(lambda: load_map(path), "map.pgm", f"{side}")
    assert f"{MAX_MAP_CELLS:,}" in message or str(MAX_MAP_CELLS) in message


def test_a_4000_by_4000_map_loads(tmp_path):
    pixels = np.full((4000, 4000), 254, dtype=np.uint8)
    Image.fromarray(pixels, mode="L").save(tmp_path / "map.pgm")
    path = write_map(tmp_path, (tmp_path / "map.pgm").read_bytes())
    assert load_map(path).data.shape == (4000, 4000)


@pytest.mark.parametrize(
    "resolution, origin", [(0.0004, (1e-5, -1234.56789, 0.1)), (7.5, (1e4, 3.3e-7, -3.14159))]
)
def test_a_saved_map_loads_back_with_its_resolution_and_origin(tmp_path, resolution, origin):
    grid = OccupancyMap(np.zeros((5, 7), dtype=np.int8), resolution, origin)
    loaded = load_map(save_map(grid, tmp_path / "saved"))
    assert loaded.resolution == resolution
    assert loaded.origin == origin


# ------------------------------------------------------------------------------ Nav2 files


def nav2_file(folder: Path, source: str, node: tuple, key: str, value) -> Path:
    doc = yaml.safe_load((CONFIG / source).read_text())
    target = doc
    for name in node:
        target = target[name]
    target[key] = value
    path = folder / "nav2.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


GLOBAL = ("global_costmap", "global_costmap", "ros__parameters")
LOCAL = ("local_costmap", "local_costmap", "ros__parameters")
SCAN = (*LOCAL, "obstacle_layer", "scan")
RPP = ("controller_server", "ros__parameters", "FollowPath")
AMCL = ("amcl", "ros__parameters")
SLAM = ("slam_toolbox", "ros__parameters")


def global_costmap(path):
    return costmap_parameters(path, "global_costmap")


def local_costmap(path):
    return costmap_parameters(path, "local_costmap")


NAV = "navigation.yaml"
OBSTACLES = "navigation_obstacles.yaml"
NAV2_CASES = {
    "max_particles 1e9": (NAV, AMCL, "max_particles", 1e9, amcl_parameters),
    "inflation_radius nan": (
        NAV, (*GLOBAL, "inflation_layer"), "inflation_radius", float("nan"), global_costmap
    ),
    "inflation_radius 1e6": (
        NAV, (*GLOBAL, "inflation_layer"), "inflation_radius", 1e6, global_costmap
    ),
    "cost_scaling_factor negative": (
        NAV, (*GLOBAL, "inflation_layer"), "cost_scaling_factor", -4.0, global_costmap
    ),
    "cost_scaling_factor nan": (
        NAV, (*GLOBAL, "inflation_layer"), "cost_scaling_factor", float("nan"), global_costmap
    ),
    "footprint flat list": (NAV, GLOBAL, "footprint", [0.1, 0.2, 0.3, 0.4], global_costmap),
    "footprint strings": (NAV, GLOBAL, "footprint", "[[a, b], [c, d], [e, f]]", global_costmap),
    "footprint of strings": (NAV, GLOBAL, "footprint", [["a", "b"]] * 3, global_costmap),
    "footprint nan": (
        NAV, GLOBAL, "footprint", "[[.nan, 0.1], [0.1, -0.1], [-0.1, -0.1]]", global_costmap
    ),
    "footprint degenerate": (
        NAV, GLOBAL, "footprint", "[[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]]", global_costmap
    ),
    "footprint self-intersecting": (
        NAV, GLOBAL, "footprint", "[[0.2, 0.2], [-0.2, -0.2], [0.2, -0.2], [-0.2, 0.2]]",
        global_costmap,
    ),
    "robot_radius 1e6": (NAV, GLOBAL, "robot_radius", 1e6, global_costmap),
    "lethal_cost_threshold 0": (NAV, GLOBAL, "lethal_cost_threshold", 0, global_costmap),
    "lethal_cost_threshold 1000": (NAV, GLOBAL, "lethal_cost_threshold", 1000, global_costmap),
    "resolution 1e-5": (NAV, GLOBAL, "resolution", 1e-5, global_costmap),
    "combination_method max": (
        OBSTACLES, (*LOCAL, "obstacle_layer"), "combination_method", "max", local_costmap
    ),
    "combination_method 7": (
        OBSTACLES, (*LOCAL, "obstacle_layer"), "combination_method", 7, local_costmap
    ),
    "obstacle_max_range nan": (OBSTACLES, SCAN, "obstacle_max_range", float("nan"), local_costmap),
    "controller_frequency 1e5": (
        NAV, ("controller_server", "ros__parameters"), "controller_frequency", 1e5,
        controller_parameters,
    ),
    "desired_linear_vel 1e6": (NAV, RPP, "desired_linear_vel", 1e6, controller_parameters),
    "desired_linear_vel nan": (
        NAV, RPP, "desired_linear_vel", float("nan"), controller_parameters
    ),
    "slam resolution 1e-5": ("slam.yaml", SLAM, "resolution", 1e-5, slam_parameters),
    "slam max_laser_range inf": (
        "slam.yaml", SLAM, "max_laser_range", float("inf"), slam_parameters
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(NAV2_CASES))
def test_a_hostile_nav2_value_is_refused_naming_the_file_and_key(tmp_path, case):
    source, node, key, value, loader = NAV2_CASES[case]
    path = nav2_file(tmp_path, source, node, key, value)
    refused(lambda: loader(path), "nav2.yaml", key)


@pytest.mark.parametrize("content", ["binary", "fifo", "directory", "list"])
def test_a_nav2_file_that_is_not_a_yaml_mapping_is_refused(tmp_path, content):
    path = tmp_path / "nav2.yaml"
    if content == "binary":
        path.write_bytes(bytes(range(256)) * 4)
    elif content == "fifo":
        os.mkfifo(path)
    elif content == "directory":
        path.mkdir()
    else:
        path.write_text("- a\n- b\n")
    refused(lambda: read_nav2(path), "nav2.yaml")


# ------------------------------------------------------------------------------ the command line

TIME_LIMIT = 120  # [s] a refused run stops while it is built
MEMORY_LIMIT = 4 * 2**30  # [bytes] of address space


def world(args: list[str], cwd: Path) -> tuple[subprocess.CompletedProcess, float]:
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    start = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--realtime-rate", "0"]
        + ["--duration", "0.5", "--quiet", *args],
        capture_output=True,
        text=True,
        timeout=TIME_LIMIT,
        cwd=cwd,
        preexec_fn=limit,
    )
    return result, time.monotonic() - start


def one_line_error(result) -> str:
    assert result.returncode == 2, result.stderr[-3000:]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr[-3000:]
    return lines[0]


def scenario_with(tmp_path: Path, **navigation) -> Path:
    doc = yaml.safe_load((REPO / "diagrams" / "fra2mo_amcl.yaml").read_text())
    doc["navigation"].update(navigation)
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_map_with_an_infinite_resolution_ends_the_run_in_one_line(tmp_path):
    shutil.copy(REPO / "models/fra2mo_description/maps/arena.pgm", tmp_path / "map.pgm")
    map_path = write_map(tmp_path, (tmp_path / "map.pgm").read_bytes(), resolution=".inf")
    scenario = scenario_with(tmp_path, map=str(map_path))
    result, _ = world(["--scenario", str(scenario), "--output", str(tmp_path / "out")], tmp_path)
    line = one_line_error(result)
    assert "map.yaml" in line and "resolution" in line


def test_a_nav2_file_with_a_nan_inflation_radius_ends_the_run_in_one_line(tmp_path):
    node = (*GLOBAL, "inflation_layer")
    nav2 = nav2_file(tmp_path, NAV, node, "inflation_radius", float("nan"))
    scenario = scenario_with(tmp_path, params_file=str(nav2))
    result, _ = world(["--scenario", str(scenario), "--output", str(tmp_path / "out")], tmp_path)
    line = one_line_error(result)
    assert "nav2.yaml" in line and "inflation_radius" in line


@pytest.mark.parametrize(
    "navigation, names",
    [
        ({"initial_pose": [500.0, 500.0, 0.0]}, ["initial_pose", "500"]),
        ({"map": "", "map_resolution": 1e-4, "localization": "ground_truth"},
         ["map_resolution"]),
        ({"order": ["north_east"] * 10_000}, ["order", "10000"]),
        ({"goals": [{"name": f"g{k}", "x": 0.1, "y": 0.1} for k in range(5000)], "order": []},
         ["goals", "5000"]),
    ],
    ids=["initial pose off the map", "map_resolution 1e-4", "10000 repeats", "5000 goals"],
)  # fmt: skip
def test_a_hostile_navigation_section_ends_the_run_in_one_line(tmp_path, navigation, names):
    scenario = scenario_with(tmp_path, **navigation)
    result, seconds = world(
        ["--scenario", str(scenario), "--output", str(tmp_path / "out")], tmp_path
    )
    line = one_line_error(result)
    for name in names:
        assert name in line, (name, line)


# ------------------------------------------------------------------------------ robots:


def robots_scenario(folder: Path, entries: list[dict]) -> Path:
    path = folder / "robots.yaml"
    path.write_text(yaml.safe_dump({"robots": entries}))
    return path


def arm(name: str, **entry) -> dict:
    return {"name": name, "robot": {"xacro_args": {"use_camera": "false"}}, **entry}


ROBOTS_CASES = {
    "a name of 300 characters": ([arm("a" * 300)], ["robots.", "300"]),
    "a mount chain of 20 robots": (
        [arm("r0")] + [arm(f"r{k}", parent=f"r{k - 1}::link4") for k in range(1, 20)],
        ["robots.r", "parent", "mount"],
    ),
    "100 arms": ([arm(f"arm{k}") for k in range(100)], ["robots", "100"]),
    "1000 arms": ([arm(f"arm{k}") for k in range(1000)], ["robots", "1000"]),
    "a prefix carrying XML": ([arm("left", prefix='"/><xacro:include filename="/etc/passwd"/>')],
                              ["robots.left.prefix"]),
    "a prefix with colons": ([arm("left", prefix="left::arm")], ["robots.left.prefix"]),
    "a prefix of 300 characters": ([arm("left", prefix="p" * 300)], ["robots.left.prefix"]),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(ROBOTS_CASES))
def test_a_hostile_robots_list_is_refused_naming_the_entry(tmp_path, case):
    entries, names = ROBOTS_CASES[case]
    path = robots_scenario(tmp_path, entries)
    refused(lambda: check_scenario(load_scenario(path)), *names)


def test_50_robots_and_a_mount_chain_of_8_are_accepted(tmp_path):
    entries = [arm(f"arm{k}") for k in range(50)]
    assert len(check_scenario(load_scenario(robots_scenario(tmp_path, entries))).robots) == 50
    chain = [arm("r0")] + [arm(f"r{k}", parent=f"r{k - 1}::link4") for k in range(1, 8)]
    assert len(check_scenario(load_scenario(robots_scenario(tmp_path, chain))).robots) == 8


def test_a_robots_list_of_1000_arms_ends_the_run_in_one_line(tmp_path):
    path = robots_scenario(tmp_path, [arm(f"arm{k}") for k in range(1000)])
    result, _ = world(["--scenario", str(path), "--output", str(tmp_path / "out")], tmp_path)
    line = one_line_error(result)
    assert "robots" in line and "1000" in line


# ------------------------------------------------------------------------------ networks, data

NETWORK = REPO / "models" / "learned_ik" / "armando_ik_network.onnx"


def network_with(folder: Path, metadata=None, drop: bool = False) -> Path:
    """The shipped network with its metadata replaced (``metadata``: a dict or text) or
    dropped."""
    import onnx

    model = onnx.load(str(NETWORK))
    entry = next(p for p in model.metadata_props if p.key == "armando_drake")
    original = json.loads(entry.value)
    if drop:
        model.metadata_props.remove(entry)
    elif metadata is not None:
        entry.value = metadata(original) if callable(metadata) else metadata
    path = folder / "net.onnx"
    onnx.save(model, str(path))
    return path


def _changed(**changes):
    return lambda original: json.dumps({**original, **changes})


NETWORK_CASES = {
    "metadata missing": (dict(drop=True), ["net.onnx", "metadata"]),
    "metadata not JSON": (dict(metadata="{not json"), ["net.onnx", "not JSON"]),
    "metadata a list": (dict(metadata="[1, 2]"), ["net.onnx", "JSON object"]),
    "no joint_names": (
        dict(metadata=lambda m: json.dumps({k: v for k, v in m.items() if k != "joint_names"})),
        ["net.onnx", "joint_names"],
    ),
    "no features": (
        dict(metadata=lambda m: json.dumps({k: v for k, v in m.items() if k != "features"})),
        ["net.onnx", "features"],
    ),
    "lower of a wrong length": (dict(metadata=_changed(lower=[0.0])), ["net.onnx", "lower"]),
    "wrong input shape": (dict(metadata=_changed(features=["x", "y"])), ["net.onnx", "features"]),
    "wrong output size": (
        dict(metadata=lambda m: json.dumps({
            **m, "joint_names": m["joint_names"] + ["extra"], "lower": m["lower"] + [0.0],
            "upper": m["upper"] + [1.0], "angular": m["angular"] + [True],
        })),
        ["net.onnx", "joints need"],
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(NETWORK_CASES))
def test_a_hostile_network_is_refused_naming_the_file(tmp_path, case):
    kwargs, names = NETWORK_CASES[case]
    path = network_with(tmp_path, **kwargs)
    refused(lambda: IkModel(path), *names)


@pytest.mark.parametrize("kind", ["fifo", "directory", "garbage"])
def test_a_network_that_is_not_a_file_of_onnx_is_refused(tmp_path, kind):
    path = tmp_path / "net.onnx"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    else:
        path.write_bytes(bytes(range(256)) * 16)
    refused(lambda: IkModel(path), "net.onnx")


def dataset(folder: Path, rows: int = 20, *, drop: str = "", nan_row: int = -1, meta=None):
    import pyarrow as pa
    import pyarrow.parquet as pq

    names = ["j0", "j1"]
    rng = np.random.default_rng(0)
    columns = {name: rng.uniform(-1, 1, rows) for name in ALL_FEATURES}
    columns.update({f"q_{name}": rng.uniform(-1, 1, rows) for name in names})
    if nan_row >= 0:
        columns["x"][nan_row] = np.nan
    columns.pop(drop, None)
    metadata = {"kind": "ik", "joint_names": names} if meta is None else meta
    table = pa.table(columns).replace_schema_metadata(
        {"armando_drake": metadata if isinstance(metadata, str) else json.dumps(metadata)}
    )
    path = folder / "data.parquet"
    pq.write_table(table, path)
    return path


DATA_CASES = {
    "empty": (dict(rows=0), ["data.parquet", "no rows"]),
    "a joint column missing": (dict(drop="q_j1"), ["data.parquet", "q_j1"]),
    "a feature column missing": (dict(drop="r22"), ["data.parquet", "r22"]),
    "a NaN row": (dict(nan_row=7), ["data.parquet", "row 7"]),
    "metadata not JSON": (dict(meta="{oops"), ["data.parquet", "metadata"]),
    "joint_names not a list": (
        dict(meta={"kind": "ik", "joint_names": 3}),
        ["data.parquet", "joint_names"],
    ),
}


@pytest.mark.parametrize("case", sorted(DATA_CASES))
def test_a_hostile_data_set_is_refused_naming_the_file(tmp_path, case):
    kwargs, names = DATA_CASES[case]
    path = dataset(tmp_path, **kwargs)
    refused(lambda: read_dataset(path), *names)


def test_a_fifo_as_the_data_set_is_refused(tmp_path):
    path = tmp_path / "data.parquet"
    os.mkfifo(path)
    refused(lambda: read_dataset(path), "data.parquet")


def learn(args: list[str], cwd: Path, timeout: float = TIME_LIMIT) -> subprocess.CompletedProcess:
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    return subprocess.run(
        [sys.executable, "-m", "armando_drake.learn", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
        preexec_fn=limit,
    )


@pytest.mark.parametrize(
    "args, names",
    [
        (["ik", "--data", "FIFO", "--output", "out"], ["FIFO"]),
        (["ik", "--data", "data.parquet", "--output", "out", "--neighbours", "1000000000"],
         ["--neighbours", "1000000000"]),
        (["ik", "--data", "data.parquet", "--output", "out", "--refine-steps", "-3"],
         ["--refine-steps", "-3"]),
        (["ik-node", "--network", "FIFO"], ["FIFO"]),
        (["ik-node", "--domain-id", "300"], ["--domain-id", "300"]),
        (["ik-node", "--namespace", "bad name/<x>"], ["--namespace", "bad name"]),
        (["ik-node", "--duration", "-1"], ["--duration", "-1"]),
        (["ik-node", "--duration", "nan"], ["--duration", "nan"]),
        (["ik-node", "--refine-steps", "-2"], ["--refine-steps", "-2"]),
    ],
    ids=["data a FIFO", "neighbours 1e9", "negative refine steps", "network a FIFO",
         "domain 300", "bad namespace", "negative duration", "NaN duration",
         "node negative refine steps"],
)  # fmt: skip
def test_a_hostile_learn_option_ends_in_one_line(tmp_path, args, names):
    os.mkfifo(tmp_path / "FIFO")
    dataset(tmp_path)
    result = learn(args, tmp_path)
    line = one_line_error(result)
    for name in names:
        assert name in line, (name, line)


def test_a_scenario_learned_ik_rate_of_1e9_is_refused(tmp_path):
    path = tmp_path / "scenario.yaml"
    doc = yaml.safe_load((REPO / "diagrams" / "learned_ik.yaml").read_text())
    doc["learned_ik"]["rate"] = 1e9
    path.write_text(yaml.safe_dump(doc))
    refused(lambda: check_scenario(load_scenario(path)), "learned_ik.rate", "1000000000")


# ------------------------------------------------------------------------------ the output folder


def read_only_folder(tmp_path: Path) -> Path:
    """A folder the run cannot write in: a read-only one, or (as root, who writes in
    any) one on /sys, where nobody can."""
    if os.geteuid() == 0:
        return Path("/sys/armando_drake_out")
    out = tmp_path / "out"
    out.mkdir()
    out.chmod(0o500)
    return out


def test_a_read_only_output_folder_ends_the_run_in_one_line(tmp_path):
    out = read_only_folder(tmp_path)
    result, _ = world(["--scenario", "position", "--output", str(out)], tmp_path)
    line = one_line_error(result)
    assert str(out) in line


def test_a_read_only_output_folder_ends_learn_in_one_line(tmp_path):
    out = read_only_folder(tmp_path)
    dataset(tmp_path)
    line = one_line_error(learn(["ik", "--data", "data.parquet", "--output", str(out)], tmp_path))
    assert str(out) in line
