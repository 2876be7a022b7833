"""Properties over generated hostile values of the newer doors: whatever number a map
YAML's resolution or origin holds, whatever a Nav2 footprint or a costmap's numbers are,
the loader returns finite, in-range values or refuses in one line naming the file and key;
never an internal error."""

import math

import numpy as np
import yaml
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from armando_drake.navigation.costmap import costmap_parameters
from armando_drake.navigation.maps import load_map
from armando_drake.tools.errors import UserInputError

ANY_NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**30), 10**30),
    st.sampled_from([0, -0.0, 1e-300, 1e300, 5e-324]),
)
ANY_VALUE = st.one_of(ANY_NUMBER, st.text(max_size=5), st.none(), st.booleans())


def dumped(value) -> str:
    """``value`` as YAML reads it back (non-finite floats as .nan / .inf)."""
    if isinstance(value, float) and not math.isfinite(value):
        return ".nan" if math.isnan(value) else (".inf" if value > 0 else "-.inf")
    return yaml.safe_dump(value, default_flow_style=True).strip().removesuffix("...").strip()


@given(resolution=ANY_VALUE, x=ANY_VALUE, y=ANY_VALUE, yaw=ANY_VALUE)
def test_a_map_yaml_loads_finite_or_is_refused_naming_its_key(
    tmp_path_factory, resolution, x, y, yaw
):
    folder = tmp_path_factory.mktemp("map")
    Image.fromarray(np.zeros((4, 5), dtype=np.uint8), mode="L").save(folder / "m.pgm")
    (folder / "m.yaml").write_text(
        f"image: m.pgm\nresolution: {dumped(resolution)}\n"
        f"origin: [{dumped(x)}, {dumped(y)}, {dumped(yaw)}]\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    try:
        grid = load_map(folder / "m.yaml")
    except UserInputError as error:
        message = str(error)
        assert "\n" not in message and "m.yaml" in message
        assert "resolution" in message or "origin" in message, message
        return
    assert math.isfinite(grid.resolution) and grid.resolution > 0
    assert all(math.isfinite(v) for v in grid.origin)


POINT = st.lists(ANY_NUMBER, min_size=2, max_size=2)


@given(
    footprint=st.one_of(st.lists(POINT, max_size=6), st.lists(ANY_VALUE, max_size=6), ANY_VALUE),
    radius=ANY_VALUE,
    inflation=ANY_VALUE,
    lethal=ANY_VALUE,
)
def test_a_costmap_loads_in_range_or_is_refused_naming_its_key(
    tmp_path_factory, footprint, radius, inflation, lethal
):
    path = tmp_path_factory.mktemp("nav2") / "nav2.yaml"
    node = {
        "robot_radius": radius,
        "footprint": footprint,
        "lethal_cost_threshold": lethal,
        "plugins": ["inflation_layer"],
        "inflation_layer": {
            "plugin": "nav2_costmap_2d::InflationLayer",
            "inflation_radius": inflation,
        },
    }
    path.write_text(
        yaml.safe_dump({"global_costmap": {"global_costmap": {"ros__parameters": node}}})
    )
    try:
        params = costmap_parameters(path, "global_costmap")
    except UserInputError as error:
        message = str(error)
        assert "\n" not in message and "nav2.yaml" in message
        return
    assert 0 < params.robot_radius <= 10 and 0 <= params.inflation_radius <= 50
    assert all(math.isfinite(c) for p in params.footprint for c in p)
