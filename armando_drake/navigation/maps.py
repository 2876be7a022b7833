"""Occupancy maps in map_server's format: a map YAML and its PGM/PNG image.

Loading follows nav2_map_server's ``map_io.cpp`` (``loadMapYaml`` / ``loadMapFromFile``):
the image is read as grayscale, ``p = 1 - value/255`` (``value/255`` with ``negate``);
``p >= occupied_thresh`` is occupied (100), ``p <= free_thresh`` free (0), the rest unknown
(-1), or in ``scale`` mode scaled to ``round(100 (p - free)/(occupied - free))``; pixels
that are not opaque are unknown; ``raw`` mode takes the pixel value itself (0..100, else
-1). The image's top row is the map's last row: ``OccupancyMap.data[0]`` is the bottom row,
at the map's origin, as in a nav_msgs/OccupancyGrid.

Saving follows map_io's ``saveMapToFile``: thresholds of 0.0 are "unspecified" (free 0.25,
occupied 0.65); the ``mode`` trinary (254 free, 0 occupied, 205 unknown, with the YAML
map_saver writes: ``occupied_thresh: 0.65``, ``free_thresh: 0.196``), scale (gray
``(100 - value)/100``, unknown transparent) or raw (the value itself, unknown 255); the
``image_format`` pgm, png or bmp ("" = png in scale mode, else pgm; another: png); a
mode not recognized is trinary (map_saver's fallback), any mode is read lower-cased. A map YAML path
beginning with ``~/`` is in the user's home (``expand_user_home_dir_if_needed``).
"""

from __future__ import annotations

import logging
import math
import os
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from PIL import Image

from armando_drake.tools.errors import ConfigError
from armando_drake.tools.files import read_text_file
from armando_drake.tools.schema import MAX_COORDINATE

_log = logging.getLogger("armando_drake.navigation")

MODES = ("trinary", "scale", "raw")
IMAGE_FORMATS = ("bmp", "pgm", "png")  # map_io's "blessed" formats
UNKNOWN = -1
FREE = 0
OCCUPIED = 100
# The largest map loaded, in cells (width x height, read from the image's header before
# it is decoded): a 4096 x 4096 map; a costmap, its inflation and the planner each hold
# arrays of that size.
MAX_MAP_CELLS = 4096 * 4096
# [m/cell] the range of a map's resolution: 0.1 mm to 100 m.
MIN_MAP_RESOLUTION = 1e-4
MAX_MAP_RESOLUTION = 100.0


class MapError(ConfigError):
    """A map YAML or image that cannot be loaded; one line naming the file and the key."""


@dataclass
class OccupancyMap:
    """An occupancy grid as nav_msgs/OccupancyGrid holds it.

    ``data`` is int8 of shape (height, width), row 0 at the bottom (at ``origin``), values
    -1 unknown or 0..100; ``origin`` is the bottom-left corner of cell (0, 0) as
    ``(x, y, yaw)`` in metres and radians; ``resolution`` metres per cell.
    """

    data: np.ndarray
    resolution: float
    origin: tuple[float, float, float]
    source: str = "<memory>"

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def size_m(self) -> tuple[float, float]:
        """The map's extent (width, height) in metres."""
        return self.width * self.resolution, self.height * self.resolution


def _number(doc: dict, key: str, path: Path) -> float:
    if key not in doc:
        raise MapError(f"{path}: key '{key}' is missing")
    value = doc[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MapError(f"{path}: key '{key}' must be a number, not {value!r}")
    return float(value)


def expand_user_home(name: str, home: str | None = None) -> str:
    """map_io's ``expand_user_home_dir_if_needed``: ``~/...`` with ``~`` replaced by
    ``home`` (default: ``$HOME``); unchanged when it does not begin with ``~/`` or
    there is no home."""
    home = os.environ.get("HOME", "") if home is None else home
    if len(name) < 2 or not name.startswith("~/") or not home:
        return name
    return home + name[1:]


def _read_yaml(path: Path) -> dict:
    if not path.exists():
        raise MapError(f"{path}: the map YAML does not exist")
    try:
        doc = yaml.safe_load(read_text_file(path, what="a map YAML"))
    except UnicodeDecodeError:
        raise MapError(f"{path}: not a map YAML (not UTF-8 text)") from None
    except OSError as error:
        raise MapError(f"{path}: the map YAML cannot be read ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise MapError(f"{path}: not YAML ({' '.join(str(error).split())})") from None
    if not isinstance(doc, dict):
        raise MapError(f"{path}: a map YAML is a mapping (image, resolution, origin, ...)")
    return doc


def load_map_yaml(path: str | Path) -> dict:
    """The checked parameters of a map YAML, as ``loadMapYaml``: image (a path, relative
    to the YAML's folder), resolution, origin, free/occupied thresholds, mode, negate.
    A ``path`` beginning with ``~/`` is in the user's home."""
    if not str(path):
        raise MapError("map YAML: the file name is empty, can't load")
    path = Path(expand_user_home(str(path)))
    doc = _read_yaml(path)
    image = doc.get("image")
    if not isinstance(image, str) or not image:
        raise MapError(f"{path}: key 'image' must name the map's image, not {image!r}")
    image_path = Path(image) if image.startswith("/") else path.parent / image
    resolution = _number(doc, "resolution", path)
    if not resolution > 0:
        raise MapError(f"{path}: key 'resolution' must be positive, not {resolution}")
    if not MIN_MAP_RESOLUTION <= resolution <= MAX_MAP_RESOLUTION:
        raise MapError(
            f"{path}: key 'resolution' is {resolution!r} m/cell, outside "
            f"{MIN_MAP_RESOLUTION:g}..{MAX_MAP_RESOLUTION:g} m/cell"
        )
    origin = doc.get("origin")
    if not isinstance(origin, list) or len(origin) != 3:
        raise MapError(f"{path}: key 'origin' must be [x, y, yaw] (3 numbers), not {origin!r}")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in origin):
        raise MapError(f"{path}: key 'origin' must hold numbers, not {origin!r}")
    if not all(math.isfinite(v) for v in origin):
        raise MapError(f"{path}: key 'origin' must hold finite numbers, not {origin!r}")
    if max(abs(origin[0]), abs(origin[1])) > MAX_COORDINATE:
        raise MapError(
            f"{path}: key 'origin' {origin!r} is farther than {MAX_COORDINATE:g} m from 0"
        )
    free = _number(doc, "free_thresh", path)
    occupied = _number(doc, "occupied_thresh", path)
    if not 0.0 <= free < occupied <= 1.0:
        raise MapError(
            f"{path}: keys 'free_thresh' {free} and 'occupied_thresh' {occupied} must be "
            "0 <= free_thresh < occupied_thresh <= 1"
        )
    mode = doc.get("mode", "trinary")
    mode = mode.lower() if isinstance(mode, str) else mode  # map_mode_from_string
    if mode not in MODES:
        raise MapError(f"{path}: key 'mode' is {mode!r}, not one of {', '.join(MODES)}")
    negate = doc.get("negate", 0)
    if negate not in (0, 1, True, False):
        raise MapError(f"{path}: key 'negate' must be 0 or 1, not {negate!r}")
    return {
        "image": image_path,
        "resolution": resolution,
        "origin": tuple(float(v) for v in origin),
        "free_thresh": free,
        "occupied_thresh": occupied,
        "mode": mode,
        "negate": bool(negate),
    }


def _read_image(path: Path, yaml_path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """The image's gray values (uint8) and, if it has one, its alpha channel."""
    try:
        info = os.stat(path)
    except OSError:
        raise MapError(f"{yaml_path}: key 'image': the image {path} does not exist") from None
    if not stat.S_ISREG(info.st_mode):
        raise MapError(f"{yaml_path}: key 'image': {path} is not a regular file")
    try:
        with Image.open(path) as image:
            width, height = image.size  # from the header: nothing is decoded yet
            if width * height > MAX_MAP_CELLS:
                raise MapError(
                    f"{yaml_path}: key 'image': {path} is {width} x {height} pixels "
                    f"({width * height:,} cells), over the limit of {MAX_MAP_CELLS:,} cells"
                )
            alpha = None
            if image.mode in ("RGBA", "LA", "PA") or "transparency" in image.info:
                alpha = np.asarray(image.convert("RGBA"))[..., 3]
            gray = np.asarray(image.convert("L"))
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as error:
        reason = " ".join(str(error).split())
        raise MapError(f"{yaml_path}: key 'image': {path} cannot be read ({reason})") from None
    return gray, alpha


def occupancy_from_image(
    gray: np.ndarray,
    *,
    mode: str = "trinary",
    negate: bool = False,
    free_thresh: float = 0.25,
    occupied_thresh: float = 0.65,
    alpha: np.ndarray | None = None,
) -> np.ndarray:
    """map_io's conversion of a grayscale image (top row first) into occupancy values
    (int8, bottom row first)."""
    if mode == "raw":
        result = gray.astype(np.int16)
        result[(result < FREE) | (result > OCCUPIED)] = UNKNOWN
        return np.flipud(result.astype(np.int8))
    p = gray.astype(np.float32) / np.float32(255.0)
    if not negate:
        p = np.float32(1.0) - p
    result = np.full(gray.shape, UNKNOWN, dtype=np.int8)
    result[p >= np.float32(occupied_thresh)] = OCCUPIED
    result[p <= np.float32(free_thresh)] = FREE
    if mode == "scale":
        between = (p > np.float32(free_thresh)) & (p < np.float32(occupied_thresh))
        scaled = (p - np.float32(free_thresh)) / np.float32(occupied_thresh - free_thresh)
        result[between] = np.round(scaled[between] * np.float32(100.0)).astype(np.int8)
    if alpha is not None:
        result[alpha < 255] = UNKNOWN
    return np.flipud(result)


def load_map(path: str | Path) -> OccupancyMap:
    """A map_server map: the YAML's parameters and its image as an :class:`OccupancyMap`."""
    params = load_map_yaml(path)  # refuses an empty name
    path = Path(expand_user_home(str(path)))
    gray, alpha = _read_image(params["image"], path)
    data = occupancy_from_image(
        gray,
        mode=params["mode"],
        negate=params["negate"],
        free_thresh=params["free_thresh"],
        occupied_thresh=params["occupied_thresh"],
        alpha=alpha,
    )
    return OccupancyMap(
        data=np.ascontiguousarray(data),
        resolution=params["resolution"],
        origin=params["origin"],
        source=str(path),
    )


def save_parameters(free_thresh: float, occupied_thresh: float, image_format: str, mode: str):
    """map_io's ``checkSaveParameters``: (free, occupied, format, mode) with 0.0
    thresholds taken as unspecified (0.25, 0.65), an unspecified format chosen by the mode
    and a mode not recognized taken as trinary (map_saver's, with a warning); a MapError
    for thresholds out of order."""
    mode = str(mode).lower()  # map_mode_from_string
    if mode not in MODES:
        _log.warning("map_saver: map mode %r not recognized, using trinary", mode)
        mode = "trinary"
    if occupied_thresh == 0.0:
        occupied_thresh = 0.65
        _log.warning("map_saver: occupied threshold unspecified; set to 0.65")
    if free_thresh == 0.0:
        free_thresh = 0.25
        _log.warning("map_saver: free threshold unspecified; set to 0.25")
    if not (free_thresh >= 0.0 and occupied_thresh <= 1.0 and free_thresh < occupied_thresh):
        raise MapError(
            f"map_saver: free_thresh {free_thresh} and occupied_thresh {occupied_thresh} must "
            "be 0 <= free_thresh < occupied_thresh <= 1"
        )
    image_format = (image_format or ("png" if mode == "scale" else "pgm")).lower()
    if image_format not in IMAGE_FORMATS:
        _log.warning(
            "map_saver: image format %r is not one of %s; png is written instead",
            image_format,
            ", ".join(IMAGE_FORMATS),
        )
        image_format = "png"
    if mode == "scale" and image_format != "png":
        _log.warning(
            "map_saver: mode scale needs transparency, which %s has not (unknown cells "
            "are written gray); consider png",
            image_format,
        )
    return free_thresh, occupied_thresh, image_format, mode


def map_image(data: np.ndarray, mode: str, free_thresh: float, occupied_thresh: float):
    """map_io's ``tryWriteMapToFile`` pixels of occupancy ``data`` (bottom row first):
    the image (top row first), gray uint8 or, in scale mode, gray and alpha."""
    data = data.astype(np.int16)
    known = (data >= 0) & (data <= 100)
    if mode == "raw":
        return np.flipud(np.where(known, data, 255).astype(np.uint8))
    if mode == "scale":
        gray = np.where(known, np.rint((100.0 - data) / 100.0 * 255.0), 128).astype(np.uint8)
        alpha = np.where(known, 255, 0).astype(np.uint8)
        return np.flipud(np.stack([gray, alpha], axis=-1))
    pixels = np.full(data.shape, 205, dtype=np.uint8)
    pixels[known & (data <= round(free_thresh * 100.0))] = 254
    pixels[known & (data >= round(occupied_thresh * 100.0))] = 0
    return np.flipud(pixels)


def save_map(
    grid: OccupancyMap,
    path: str | Path,
    *,
    free_thresh: float = 0.25,
    occupied_thresh: float = 0.65,
    image_format: str = "",
    mode: str = "trinary",
) -> Path:
    """map_saver's output: ``<path>.<image_format>`` and ``<path>.yaml``; ``path`` is
    given without suffix (a ``.yaml`` one is dropped). Thresholds of 0.0 mean unspecified
    (0.25, 0.65); in trinary mode a cell is free at ``value <= rint(100 free_thresh)``,
    occupied at ``value >= rint(100 occupied_thresh)`` (see :func:`map_image`). Returns
    the YAML's path."""
    path = Path(path)
    if path.suffix == ".yaml":
        path = path.with_suffix("")
    try:
        free_thresh, occupied_thresh, image_format, mode = save_parameters(
            free_thresh, occupied_thresh, image_format, mode
        )
    except MapError as error:
        raise MapError(f"{path}: {error}") from None
    pixels = map_image(grid.data, mode, free_thresh, occupied_thresh)
    image_path = path.with_suffix(f".{image_format}")
    if pixels.ndim == 3 and image_format != "png":  # no transparency: gray only
        pixels = pixels[..., 0]
    try:
        Image.fromarray(pixels, mode="LA" if pixels.ndim == 3 else "L").save(image_path)
    except OSError as error:
        raise MapError(f"{image_path}: the map cannot be written ({error})") from None
    x, y, yaw = grid.origin
    thresholds = (0.65, 0.196) if mode == "trinary" else (occupied_thresh, free_thresh)
    text = (
        f"image: {image_path.name}\n"
        f"mode: {mode}\n"
        f"resolution: {_exact(grid.resolution)}\n"
        f"origin: [{_exact(x)}, {_exact(y)}, {_exact(yaw)}]\n"
        "negate: 0\n"
        f"occupied_thresh: {thresholds[0]:g}\n"
        f"free_thresh: {thresholds[1]:g}\n"
    )
    yaml_path = path.with_suffix(".yaml")
    yaml_path.write_text(text)
    return yaml_path


def _exact(value: float) -> str:
    """A number written with the digits that read back to it exactly (map_saver's 3
    decimals would write a resolution of 0.0004 as 0.000, which does not load)."""
    if value == 0 or not math.isfinite(value):
        return "0"
    text = repr(float(value))
    mantissa, e, exponent = text.partition("e")
    return f"{mantissa}.0e{exponent}" if e and "." not in mantissa else text  # YAML 1.1
