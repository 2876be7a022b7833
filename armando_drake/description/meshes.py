"""Mesh files of a robot description, made loadable by Drake.

Drake renders and collides OBJ (and glTF) meshes; ROS descriptions mostly ship
STL or Collada (DAE). :func:`convert_mesh` turns those into OBJ files with
normals, written once into a cache keyed by the source file's content, so a
second load converts nothing:

- the cache is ``$XDG_CACHE_HOME/armando_drake/meshes`` (``~/.cache`` when the
  variable is not set), see :func:`cache_dir`;
- geometry keeps its own units: the URDF ``scale`` attribute stays as written
  and Drake applies it;
- Collada's ``<unit meter="..">`` is applied (as Gazebo and RViz do); its
  ``up_axis`` is ignored (as RViz does);
- every face gets its own normal (flat shading, as the STL facets are);
- alongside each OBJ a ``.npy`` keeps the vertices, so bounding boxes of
  cached meshes cost no parsing.

:func:`resolve_mesh` turns a URDF ``filename`` (``package://``, ``model://``,
``file://``, absolute or relative) into a file through a
:class:`~armando_drake.description.loader.PackageSearch`.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armando_drake.description.loader import DescriptionError, PackageSearch

# Bumped whenever the OBJ written for the same source would differ.
CONVERTER_VERSION = 2
# Formats converted to OBJ, by lower-case extension.
CONVERTED_FORMATS = (".stl", ".dae")
# Formats Drake reads itself; passed through untouched.
DRAKE_FORMATS = (".obj", ".gltf")
SUPPORTED_FORMATS = CONVERTED_FORMATS + DRAKE_FORMATS


@dataclass
class ConvertedMesh:
    """One mesh file of a description and the file Drake loads for it."""

    source: Path  # the description's mesh file (absolute)
    path: Path  # the file Drake loads: the cached OBJ, or ``source`` itself
    converted: bool  # True when this call wrote ``path`` (False: cache hit or passed through)

    def vertices(self) -> np.ndarray:
        """The mesh vertices, (N, 3), in the file's own units (before URDF ``scale``)."""
        cached = _vertices_file(self.path)
        if cached.is_file():
            return np.load(cached)
        return np.asarray(_load_trimesh(self.source).vertices, dtype=float)


def cache_dir() -> Path:
    """Where converted meshes live: ``$XDG_CACHE_HOME`` (or ``~/.cache``)/armando_drake/meshes."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser() / "armando_drake" / "meshes"


def _vertices_file(obj: Path) -> Path:
    return obj.with_suffix(".vertices.npy")


def _content_key(path: Path) -> str:
    digest = hashlib.sha256(f"armando_drake mesh converter {CONVERTER_VERSION}\n".encode())
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()[:24]


def _load_trimesh(path: Path):
    """The single triangle mesh of an STL/DAE/OBJ/glTF file, in metres per its own units."""
    import trimesh

    try:
        scene = trimesh.load_scene(str(path))
    except Exception as error:  # trimesh raises ValueError, KeyError, ImportError...
        raise DescriptionError(f"{path}: cannot read mesh: {error}") from None
    mesh = scene.to_mesh()
    units = {str(g.metadata.get("units", "")) for g in scene.geometry.values()}
    if path.suffix.lower() == ".dae" and len(units) == 1:
        factor, _, unit = units.pop().partition("*")
        if unit.strip() == "meters":
            mesh.apply_scale(float(factor))
    if len(mesh.faces) == 0:
        raise DescriptionError(f"{path}: mesh has no triangles")
    return mesh


def _obj_text(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, name: str) -> str:
    """OBJ with one normal per face (``f a//n b//n c//n``)."""
    index = np.arange(1, len(faces) + 1)
    corners = np.column_stack([faces[:, 0] + 1, index, faces[:, 1] + 1, index, faces[:, 2] + 1])
    corners = np.column_stack([corners, index])
    return "".join(
        [
            f"# converted by armando_drake (converter {CONVERTER_VERSION}) from {name}\n",
            f"o {name}\n",
            ("v %.9g %.9g %.9g\n" * len(vertices)) % tuple(vertices.ravel()),
            ("vn %.6f %.6f %.6f\n" * len(normals)) % tuple(normals.ravel()),
            ("f %d//%d %d//%d %d//%d\n" * len(faces)) % tuple(corners.ravel()),
        ]
    )


def _write_atomically(path: Path, write) -> None:
    """Writes through a temporary file so concurrent loads never see half a file."""
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    os.close(handle)
    try:
        write(temporary)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def convert_mesh(source: str | os.PathLike) -> ConvertedMesh:
    """The OBJ Drake should load for ``source``, converting it into the cache if needed.

    OBJ and glTF files pass through untouched; other formats raise a
    :class:`DescriptionError` naming the extension.
    """
    source = Path(source).resolve()
    suffix = source.suffix.lower()
    if suffix in DRAKE_FORMATS:
        return ConvertedMesh(source=source, path=source, converted=False)
    if suffix not in CONVERTED_FORMATS:
        raise DescriptionError(
            f"{source}: unsupported mesh format {suffix or '(no extension)'!r}; "
            f"supported: {', '.join(SUPPORTED_FORMATS)}"
        )
    folder = cache_dir()
    target = folder / f"{source.stem}-{_content_key(source)}.obj"
    if target.is_file() and _vertices_file(target).is_file():
        return ConvertedMesh(source=source, path=target, converted=False)
    mesh = _load_trimesh(source)
    vertices = np.asarray(mesh.vertices, dtype=float)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    normals = np.asarray(mesh.face_normals, dtype=float)
    folder.mkdir(parents=True, exist_ok=True)
    text = _obj_text(vertices, faces, normals, source.name)

    def save_vertices(name: str) -> None:
        with open(name, "wb") as stream:
            np.save(stream, vertices)

    _write_atomically(_vertices_file(target), save_vertices)
    _write_atomically(target, lambda name: Path(name).write_text(text))
    return ConvertedMesh(source=source, path=target, converted=True)


def resolve_mesh(
    filename: str, search: PackageSearch, base_dir: str | os.PathLike | None = None
) -> Path:
    """The file a URDF mesh ``filename`` names (it need not exist).

    ``package://pkg/rest`` and ``model://pkg/rest`` go through ``search``
    (unknown packages raise an error listing the search path); ``file://`` and
    absolute paths are taken as they are; relative paths are relative to
    ``base_dir`` (the URDF's folder).
    """
    for scheme in ("package://", "model://"):
        if filename.startswith(scheme):
            package, _, rest = filename[len(scheme) :].partition("/")
            return search.resolve(package) / rest
    if filename.startswith("file://"):
        return Path(filename[len("file://") :])
    path = Path(filename).expanduser()
    if path.is_absolute():
        return path
    if base_dir is None:
        raise DescriptionError(
            f"relative mesh filename {filename!r} but the URDF has no file to be relative to"
        )
    return Path(base_dir) / path
