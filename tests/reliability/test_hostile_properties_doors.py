"""Properties over generated hostile values of the newer doors, beyond a map's resolution
and origin and a costmap's numbers (test_hostile_properties_3.py): every other key of a
map YAML, the AMCL, controller and obstacle-layer parameters of a Nav2 file, the numbers
and names of a Gazebo world, and the entries of a ``robots:`` list. Each generated input
either loads or is refused in one line naming its source; never an internal error."""

import math
from pathlib import Path

import numpy as np
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from armando_drake.description.worlds import load_world
from armando_drake.navigation.amcl import amcl_parameters
from armando_drake.navigation.costmap import costmap_parameters
from armando_drake.navigation.follower import controller_parameters
from armando_drake.navigation.maps import load_map
from armando_drake.simulation.scenario import load_scenario
from armando_drake.simulation.validation import check_scenario
from armando_drake.tools.errors import UserInputError

REPO = Path(__file__).resolve().parents[2]
NAV2 = REPO / "models" / "fra2mo_description" / "config" / "navigation_obstacles.yaml"

ANY_NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**30), 10**30),
    st.sampled_from([0, -0.0, 1e-300, 1e300, 5e-324, -1, 1e9]),
)
ANY_VALUE = st.one_of(
    ANY_NUMBER,
    st.text(max_size=8),
    st.none(),
    st.booleans(),
    st.lists(ANY_NUMBER, max_size=4),
    st.dictionaries(st.text(max_size=3), ANY_NUMBER, max_size=2),
)


def yaml_text(doc) -> str:
    """``doc`` as YAML, non-finite floats as YAML writes them (.nan, .inf)."""
    return yaml.safe_dump(doc, default_flow_style=False, allow_unicode=True)


def one_line_naming(error: UserInputError, *names: str) -> None:
    message = str(error)
    assert "\n" not in message.strip(), message
    for name in names:
        assert name in message, (name, message)


# ---------------------------------------------------------------------------- map YAML

MAP = {"image": "m.pgm", "mode": "trinary", "resolution": 0.05, "origin": [0.0, 0.0, 0.0],
       "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}  # fmt: skip


@given(key=st.sampled_from(["image", "mode", "negate", "occupied_thresh", "free_thresh"]),
       value=ANY_VALUE)  # fmt: skip
def test_any_value_of_any_map_key_loads_or_is_refused_naming_the_file(tmp_path_factory, key, value):
    folder = tmp_path_factory.mktemp("map")
    Image.fromarray(np.full((4, 5), 254, dtype=np.uint8), mode="L").save(folder / "m.pgm")
    (folder / "m.yaml").write_text(yaml_text({**MAP, key: value}))
    try:
        grid = load_map(folder / "m.yaml")
    except UserInputError as error:
        one_line_naming(error, "m.yaml")
        return
    assert grid.data.shape == (4, 5)
    assert np.isin(grid.data, [-1, *range(101)]).all()


# --------------------------------------------------------------------------- Nav2 files


def _node(doc: dict, path: tuple[str, ...]) -> dict:
    for name in path:
        doc = doc[name]
    return doc


NAV2_DOC = yaml.safe_load(NAV2.read_text())
NODES = {
    ("amcl", "ros__parameters"): amcl_parameters,
    ("controller_server", "ros__parameters"): controller_parameters,
    ("controller_server", "ros__parameters", "FollowPath"): controller_parameters,
    ("local_costmap", "local_costmap", "ros__parameters", "obstacle_layer"):
        lambda path: costmap_parameters(path, "local_costmap"),
}  # fmt: skip
KEYS = [
    (node, key)
    for node in NODES
    for key, value in _node(NAV2_DOC, node).items()
    if not isinstance(value, dict)
]


@given(entry=st.sampled_from(KEYS), value=ANY_VALUE)
def test_any_value_of_a_nav2_key_loads_or_is_refused_naming_the_file(
    tmp_path_factory, entry, value
):
    node, key = entry
    doc = yaml.safe_load(NAV2.read_text())
    _node(doc, node)[key] = value
    path = tmp_path_factory.mktemp("nav2") / "nav2.yaml"
    path.write_text(yaml_text(doc))
    try:
        NODES[node](path)
    except UserInputError as error:
        one_line_naming(error, "nav2.yaml")


# -------------------------------------------------------------------------- world files

WORD = st.one_of(
    st.text(st.characters(codec="utf-8", exclude_categories=["Cs", "Cc"]), max_size=12),
    st.lists(ANY_NUMBER, max_size=7).map(lambda values: " ".join(map(repr, values))),
)


def xml_escaped(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


@given(size=WORD, pose=WORD, name=WORD, static=WORD, normal=WORD)
@settings(max_examples=40)
def test_any_world_numbers_and_names_load_or_are_refused_naming_the_file(
    tmp_path_factory, size, pose, name, static, normal
):
    size, pose, name, static, normal = map(xml_escaped, (size, pose, name, static, normal))
    path = tmp_path_factory.mktemp("world") / "yard.sdf"
    path.write_text(
        '<?xml version="1.0"?><sdf version="1.9"><world name="w">'
        f'<model name="ground"><static>true</static><link name="l"><collision name="c">'
        f"<geometry><plane><normal>{normal}</normal></plane></geometry></collision></link></model>"
        f'<model name="{name}"><static>{static}</static><pose>{pose}</pose><link name="l">'
        f"<collision name='c'><geometry><box><size>{size}</size></box></geometry></collision>"
        f"<visual name='v'><geometry><box><size>{size}</size></box></geometry></visual>"
        "</link></model></world></sdf>"
    )
    plant, _ = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.002)
    try:
        load_world(plant, path)
    except UserInputError as error:
        one_line_naming(error, "yard.sdf")
        return
    plant.Finalize()


# ----------------------------------------------------------------------- robots: entries

ENTRY_KEYS = ["name", "prefix", "parent", "namespace", "folder", "base_xyz", "base_rpy"]
POSE_KEYS = ("base_xyz", "base_rpy")  # of the entry's robot:


@given(
    entries=st.lists(
        st.dictionaries(st.sampled_from(ENTRY_KEYS), ANY_VALUE, max_size=3), min_size=1, max_size=3
    )
)
@settings(max_examples=30)
def test_any_robots_entries_load_or_are_refused_naming_the_list(tmp_path_factory, entries):
    folder = tmp_path_factory.mktemp("robots")
    robots = [
        {
            "name": f"arm{k}",
            **{key: value for key, value in entry.items() if key not in POSE_KEYS},
            "robot": {
                "xacro_args": {"use_camera": "false"},
                **{key: value for key, value in entry.items() if key in POSE_KEYS},
            },
        }
        for k, entry in enumerate(entries)
    ]
    path = folder / "robots.yaml"
    path.write_text(yaml_text({"robots": robots, "simulation": {"duration": 0.1}}))
    try:
        scenario = check_scenario(load_scenario(path))
    except UserInputError as error:
        one_line_naming(error)
        message = str(error)
        assert "robots" in message or "robots.yaml" in message, message
        return
    loaded = scenario.robots
    loaded = list(loaded.values()) if isinstance(loaded, dict) else list(loaded)
    assert 1 <= len(loaded) <= 3
    for entry in loaded:
        pose = [*entry.robot.base_xyz, *entry.robot.base_rpy]
        assert all(math.isfinite(v) for v in pose), pose
