"""map_server's map_io, case for case with Nav2 (jazzy).

Ported from navigation2's (jazzy, f4108e5b1c2bce804a1aa0c7be6673a8eb4a1501)
nav2_map_server/test/unit/test_map_io.cpp (its test map's content
from test/test_constants.cpp: 10 x 10 cells at 0.1 m, origin (2, 3, 1)): saving and
loading back in each format and mode, saveInvalidParameters (0.0 thresholds are
"unspecified" and save), loadInvalidFile and the HomeUserExpanderTestSuite; and the
requests of test/component/test_map_saver_node.cpp and test_map_server_node.cpp (SaveMap's
and LoadMap's fields as save_map's and load_map's arguments).
"""

import numpy as np
import pytest

from armando_drake.navigation.maps import (
    MapError,
    OccupancyMap,
    expand_user_home,
    load_map,
    load_map_yaml,
    save_map,
)

# g_valid_image_content: row-major, the lower-left pixel first.
CONTENT = [
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 100, 100, 100, 0, 0, 100, 100, 100, 0],
    [100, 100, 100, 100, 0, 0, 100, 100, 100, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
]


def the_test_map() -> OccupancyMap:
    return OccupancyMap(np.array(CONTENT, dtype=np.int8), 0.1, (2.0, 3.0, 1.0))


def verify(grid: OccupancyMap) -> None:
    """verifyMapMsg: the resolution, the size and every cell."""
    assert grid.resolution == pytest.approx(0.1)
    assert grid.data.shape == (10, 10)
    assert grid.data.tolist() == CONTENT


@pytest.mark.parametrize("image_format", ["pgm", "png", "bmp"])
def test_loadSaveValid(tmp_path, image_format):
    """loadSaveValidPGM / PNG / BMP: saved (trinary, 0.196 / 0.65) and loaded back."""
    saved = save_map(the_test_map(), tmp_path / "testmap", free_thresh=0.196,
                     occupied_thresh=0.65, image_format=image_format)  # fmt: skip
    assert (tmp_path / f"testmap.{image_format}").is_file()
    verify(load_map(saved))


def test_loadSaveMapModes(tmp_path):
    """Scale mode (png), then raw mode: each loads back the same map."""
    kwargs = dict(free_thresh=0.196, occupied_thresh=0.65, image_format="png")
    saved = save_map(the_test_map(), tmp_path / "testmap", mode="scale", **kwargs)
    assert load_map_yaml(saved)["mode"] == "scale"
    verify(load_map(saved))
    saved = save_map(load_map(saved), tmp_path / "testmap", mode="raw", **kwargs)
    assert load_map_yaml(saved)["mode"] == "raw"
    verify(load_map(saved))


def test_unknown_cells_in_each_mode(tmp_path):
    """Unknown (-1) cells: 205 in trinary, transparent in scale, 255 in raw; -1 again."""
    data = np.array(CONTENT, dtype=np.int8)
    data[0, :3] = -1
    grid = OccupancyMap(data, 0.1, (2.0, 3.0, 1.0))
    for mode in ("trinary", "scale", "raw"):
        loaded = load_map(save_map(grid, tmp_path / mode, mode=mode))
        assert loaded.data.tolist() == data.tolist(), mode


def test_unspecified_image_format_follows_the_mode(tmp_path):
    save_map(the_test_map(), tmp_path / "a", mode="scale")
    save_map(the_test_map(), tmp_path / "b")
    assert (tmp_path / "a.png").is_file() and (tmp_path / "b.pgm").is_file()


def test_saveInvalidParameters(tmp_path):
    grid = the_test_map()
    for free, occupied in ((2.0, 2.0), (-2.0, -2.0), (0.7, 0.2)):
        with pytest.raises(MapError, match="free_thresh"):
            save_map(grid, tmp_path / "testmap", free_thresh=free, occupied_thresh=occupied)
    saved = save_map(grid, tmp_path / "testmap", free_thresh=0.0, occupied_thresh=0.0)
    verify(load_map(saved))  # 0.0: unspecified, 0.25 / 0.65
    with pytest.raises(MapError, match="cannot be written"):
        save_map(grid, tmp_path / "invalid_path" / "testmap")


def test_loadValidYAML(tmp_path):
    saved = save_map(the_test_map(), tmp_path / "testmap", image_format="png")
    params = load_map_yaml(saved)
    assert params["image"] == tmp_path / "testmap.png"
    assert params["resolution"] == pytest.approx(0.1)
    assert params["origin"] == (2.0, 3.0, 1.0)
    assert (params["free_thresh"], params["occupied_thresh"]) == (0.196, 0.65)
    assert (params["mode"], params["negate"]) == ("trinary", False)


def test_loadInvalidYAML(tmp_path):
    with pytest.raises(MapError):
        load_map_yaml(tmp_path / "invalid_file.yaml")


def test_HomeUserExpander():
    assert expand_user_home("", "/home/user") == ""
    assert expand_user_home("valid_file.yaml", "/home/user") == "valid_file.yaml"
    assert expand_user_home("~/valid_file.yaml", "") == "~/valid_file.yaml"
    assert expand_user_home("~/valid_file.yaml", "/home/user") == "/home/user/valid_file.yaml"


def test_a_map_yaml_under_home_loads_from_tilde(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    save_map(the_test_map(), tmp_path / "testmap")
    verify(load_map("~/testmap.yaml"))


def test_loadInvalidFile(tmp_path):
    """loadInvalidFile: an empty YAML name (MAP_DOES_NOT_EXIST) and a YAML that does not
    exist (INVALID_MAP_METADATA) are refused."""
    with pytest.raises(MapError, match="empty"):
        load_map("")
    with pytest.raises(MapError, match="does not exist"):
        load_map(tmp_path / "foo.yaml")


# -- nav2_map_server/test/component/test_map_saver_node.cpp (the SaveMap request's fields
# as save_map's arguments)


def test_SaveMap(tmp_path):
    saved = save_map(the_test_map(), tmp_path / "test_map", image_format="png",
                     mode="trinary", free_thresh=0.196, occupied_thresh=0.65)  # fmt: skip
    verify(load_map(saved))


def test_SaveMapDefaultParameters(tmp_path):
    saved = save_map(the_test_map(), tmp_path / "test_map", image_format="", mode="trinary",
                     free_thresh=0.0, occupied_thresh=0.0)  # fmt: skip
    verify(load_map(saved))


def test_SaveMapInvalidParameters(tmp_path):
    grid, path = the_test_map(), tmp_path / "test_map"
    kwargs = dict(free_thresh=0.196, occupied_thresh=0.65)
    verify(load_map(save_map(grid, path, image_format="invalid_format", **kwargs)))
    # map_mode "invalid_mode": trinary, and the map saves
    verify(load_map(save_map(grid, path, image_format="png", mode="invalid_mode", **kwargs)))
    assert load_map_yaml(path.with_suffix(".yaml"))["mode"] == "trinary"
    for free, occupied in ((2.0, 2.0), (-2.0, -2.0), (0.7, 0.2)):
        with pytest.raises(MapError):
            save_map(grid, path, mode="trinary", free_thresh=free, occupied_thresh=occupied)


# -- nav2_map_server/test/component/test_map_server_node.cpp (the LoadMap request's
# map_url as load_map's path; its results as a map or a refusal)


def test_LoadMap(tmp_path):
    verify(load_map(save_map(the_test_map(), tmp_path / "test_map", image_format="png")))


def test_LoadMapNull():
    with pytest.raises(MapError, match="empty"):  # RESULT_MAP_DOES_NOT_EXIST
        load_map("")


def test_LoadMapInvalidYaml(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(MapError, match="invalid_file.yaml"):  # RESULT_INVALID_MAP_METADATA
        load_map("invalid_file.yaml")


def test_LoadMapInvalidImage(tmp_path):
    # test/invalid_image.yaml, verbatim: its image does not exist (RESULT_INVALID_MAP_DATA)
    (tmp_path / "invalid_image.yaml").write_text(
        'image: "invalid.png"\nresolution: 0.1\norigin: [2.0, 3.0, 1.0]\n'
        'occupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\nmode: "trinary"\n'
    )
    with pytest.raises(MapError, match="key 'image'.*does not exist"):
        load_map(tmp_path / "invalid_image.yaml")
    (tmp_path / "invalid.png").write_text("not an image")
    with pytest.raises(MapError, match="key 'image'.*cannot be read"):
        load_map(tmp_path / "invalid_image.yaml")


def test_a_map_mode_is_read_in_any_case(tmp_path):
    # map_mode_from_string lower-cases the YAML's mode
    saved = save_map(the_test_map(), tmp_path / "test_map", mode="Scale")
    assert load_map_yaml(saved)["mode"] == "scale"
    saved.write_text(saved.read_text().replace("mode: scale", "mode: Scale"))
    verify(load_map(saved))
