"""Maps in map_server's format: the course's saved map, trinary/scale/raw semantics, saving."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from armando_drake.navigation.maps import MapError, load_map, save_map


def _write(tmp_path, pixels, mode="trinary", negate=0, free=0.25, occupied=0.65, name="m"):
    Image.fromarray(np.asarray(pixels, dtype=np.uint8), mode="L").save(tmp_path / f"{name}.pgm")
    (tmp_path / f"{name}.yaml").write_text(
        f"image: {name}.pgm\nmode: {mode}\nresolution: 0.1\norigin: [1.0, -2.0, 0.0]\n"
        f"negate: {negate}\noccupied_thresh: {occupied}\nfree_thresh: {free}\n"
    )
    return tmp_path / f"{name}.yaml"


def test_course_map_loads_and_round_trips(fra2mo_package, tmp_path):
    grid = load_map(fra2mo_package / "maps" / "map.yaml")
    # map.pgm: P5 507 x 258 at 0.04 m/cell, origin [-10.1, -5.13, 0] (its YAML).
    assert (grid.width, grid.height) == (507, 258)
    assert grid.resolution == 0.04
    assert grid.origin == (-10.1, -5.13, 0.0)
    assert grid.size_m == pytest.approx((20.28, 10.32))
    counts = {v: int((grid.data == v).sum()) for v in (-1, 0, 100)}
    assert sum(counts.values()) == 507 * 258  # trinary: nothing in between
    assert counts[100] > 1000 and counts[0] > 100_000
    saved = save_map(grid, tmp_path / "copy")
    again = load_map(saved)
    np.testing.assert_array_equal(again.data, grid.data)
    assert again.origin == grid.origin and again.resolution == grid.resolution
    pixels = np.asarray(Image.open(tmp_path / "copy.pgm"))
    assert set(np.unique(pixels)) <= {0, 205, 254}


def test_trinary_scale_raw_semantics(tmp_path):
    # p = 1 - value/255: 0 -> 1.0, 100 -> 0.608, 128 -> 0.498, 200 -> 0.216, 254 -> 0.004
    row = [0, 100, 128, 200, 254]
    pixels = [row, [255, 255, 255, 255, 255]]
    trinary = load_map(_write(tmp_path, pixels, name="t"))
    # data row 0 is the image's bottom row (all white: free)
    np.testing.assert_array_equal(trinary.data[0], [0, 0, 0, 0, 0])
    np.testing.assert_array_equal(trinary.data[1], [100, -1, -1, 0, 0])
    scale = load_map(_write(tmp_path, pixels, mode="scale", name="s"))
    # 100: (0.6078 - 0.25) / 0.4 * 100 = 89.46 -> 89; 128: (0.4980 - 0.25) / 0.4 -> 62
    np.testing.assert_array_equal(scale.data[1], [100, 89, 62, 0, 0])
    negated = load_map(_write(tmp_path, pixels, negate=1, name="n"))
    # negate: p = value/255: 100 -> 0.392 and 128 -> 0.502 unknown, 200 -> 0.784 occupied
    np.testing.assert_array_equal(negated.data[1], [0, -1, -1, 100, 100])
    raw = load_map(_write(tmp_path, [[0, 50, 100, 101, 255]], mode="raw", name="r"))
    np.testing.assert_array_equal(raw.data[0], [0, 50, 100, -1, -1])
    assert raw.origin == (1.0, -2.0, 0.0)


def test_transparent_pixels_are_unknown(tmp_path):
    rgba = np.zeros((1, 2, 4), dtype=np.uint8)
    rgba[..., 3] = [255, 0]
    Image.fromarray(rgba, mode="RGBA").save(tmp_path / "a.png")
    (tmp_path / "a.yaml").write_text(
        "image: a.png\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.25\n"
    )
    np.testing.assert_array_equal(load_map(tmp_path / "a.yaml").data, [[100, -1]])


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("image: m.pgm", "image: none.pgm"), "key 'image': the image"),
        (("free_thresh: 0.25", "free_thresh: 0.7"), "keys 'free_thresh' 0.7 and 'occupied_thresh'"),
        (("mode: trinary", "mode: binary"), "key 'mode' is 'binary'"),
        (("origin: [1.0, -2.0, 0.0]", "origin: [1.0, 2.0]"), "key 'origin' must be [x, y, yaw]"),
        (("resolution: 0.1", "resolution: -1"), "key 'resolution' must be positive"),
    ],
)
def test_bad_map_yaml_is_one_line_naming_file_and_key(tmp_path, edit, message):
    path = _write(tmp_path, [[0, 254]])
    path.write_text(path.read_text().replace(*edit))
    with pytest.raises(MapError) as error:
        load_map(path)
    text = str(error.value)
    assert "\n" not in text and str(path) in text and message in text
