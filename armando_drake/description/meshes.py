"""Mesh files of a robot description, made loadable by Drake.

Drake renders and collides OBJ (and glTF) meshes; ROS descriptions mostly ship
STL or Collada (DAE). :func:`convert_mesh` turns those (and OBJ files without
the normals Drake's renderers need) into OBJ files with normals, written once
into a cache keyed by the source file's content (and its textures), so a
second load converts nothing:

- the cache is ``$XDG_CACHE_HOME/armando_drake/meshes`` (``~/.cache`` when the
  variable is not set), see :func:`cache_dir`;
- geometry keeps its own units: the URDF ``scale`` attribute stays as written
  and Drake applies it;
- Collada's ``<unit meter="..">`` is applied (as Gazebo and RViz do); its
  ``up_axis`` is ignored (as RViz does);
- every face gets its own normal (flat shading, as the STL facets are);
- Collada materials are kept: each material becomes an ``newmtl`` of an MTL
  file beside the OBJ (diffuse colour ``Kd``, opacity ``d``, texture
  ``map_Kd`` written as a PNG beside it), and the faces using it follow a
  ``usemtl``; Drake shows them in Meshcat and in camera images (an OBJ's own
  materials are used when the URDF gives the visual no colour);
- alongside each OBJ a ``.npy`` keeps the vertices, so bounding boxes of
  cached meshes cost no parsing.

:func:`convex_hull` writes a mesh's convex hull (computed by trimesh) into the same
cache, keyed by the source's content: what Drake collides with, one hull per mesh file.
:func:`mass_properties` gives the volume, centre and inertia of the solid a mesh bounds
(the importer's masses of links that declare none).

:func:`resolve_mesh` turns a URDF ``filename`` (``package://``, ``model://``,
``file://``, absolute or relative) into a file through a
:class:`~armando_drake.description.loader.PackageSearch`.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armando_drake.description.packages import DescriptionError, PackageSearch

# Bumped whenever the OBJ written for the same source would differ.
CONVERTER_VERSION = 3
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
        return np.asarray(load_mesh(self.source).vertices, dtype=float)


def cache_dir() -> Path:
    """Where converted meshes live: ``$XDG_CACHE_HOME`` (or ``~/.cache``)/armando_drake/meshes."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser() / "armando_drake" / "meshes"


def _vertices_file(obj: Path) -> Path:
    return obj.with_suffix(".vertices.npy")


def _content_key(path: Path) -> str:
    """A hash of the file, and for Collada of the image files it names (its textures)."""
    digest = hashlib.sha256(f"armando_drake mesh converter {CONVERTER_VERSION}\n".encode())
    files = [path]
    if path.suffix.lower() == ".dae":
        text = path.read_text(errors="replace")
        for name in re.findall(r"<init_from>\s*([^<]+?)\s*</init_from>", text):
            image = path.parent / name.removeprefix("file://")
            if image.suffix and image.is_file():
                files.append(image)
    elif path.suffix.lower() == ".obj":
        text = path.read_text(errors="replace")
        for name in re.findall(r"^mtllib\s+(.+?)\s*$", text, re.M):
            library = path.parent / name
            if library.is_file():
                files.append(library)
                maps = re.findall(r"^\s*map_\w+\s+(?:-\S+\s+\S+\s+)*(.+?)\s*$",
                                  library.read_text(errors="replace"), re.M)  # fmt: skip
                files += [library.parent / m for m in maps if (library.parent / m).is_file()]
    for file in files:
        with open(file, "rb") as stream:
            for block in iter(lambda: stream.read(1 << 20), b""):
                digest.update(block)
    return digest.hexdigest()[:24]


def _load_scene(path: Path):
    """The trimesh scene of a mesh file, scaled to metres by its Collada ``<unit>``: the
    one place every use of a mesh (visual and collision, robot and world) is read.

    A Collada ``<up_axis>`` is not applied, as Gazebo and RViz do not: ROS meshes are
    z-up whatever their exporter wrote (many say ``Y_UP``)."""
    import trimesh

    try:
        scene = trimesh.load_scene(str(path))
    except Exception as error:  # trimesh raises ValueError, KeyError, ImportError...
        raise DescriptionError(f"{path}: cannot read mesh: {error}") from None
    units = {str(g.metadata.get("units", "")) for g in scene.geometry.values()}
    if path.suffix.lower() == ".dae" and len(units) == 1:
        factor, _, unit = units.pop().partition("*")
        if unit.strip() == "meters" and float(factor) != 1.0:
            scene = scene.scaled(float(factor))
    return scene


def load_mesh(path: Path):
    """The single triangle mesh of an STL/DAE/OBJ/glTF file, in metres per its own units
    (Collada ``<unit>``)."""
    mesh = _load_scene(path).to_mesh()
    if len(mesh.faces) == 0:
        raise DescriptionError(f"{path}: mesh has no triangles")
    return mesh


@dataclass
class _Part:
    """The triangles of one material, in the mesh file's frame."""

    vertices: np.ndarray  # (N, 3) [m]
    faces: np.ndarray  # (M, 3) vertex indices
    uv: np.ndarray | None  # (N, 2) texture coordinates, None without a texture
    color: tuple[float, float, float, float]  # diffuse RGBA in [0, 1]
    image: object = None  # PIL image of the diffuse texture, or None


def _material_of(visual) -> tuple[tuple[float, float, float, float], object]:
    """(diffuse RGBA in [0, 1], texture image or None) of a trimesh visual."""
    rgba = np.array([0.7, 0.7, 0.7, 1.0])
    image = None
    if getattr(visual, "kind", None) == "texture" or hasattr(visual, "material"):
        material = getattr(visual, "material", None)
        factor = getattr(material, "baseColorFactor", None)
        if factor is None:
            factor = getattr(material, "diffuse", None)
        if factor is not None:
            rgba = np.asarray(factor, dtype=float).ravel()[:4] / 255.0
        image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    elif getattr(visual, "kind", None) in ("face", "vertex"):
        colors = np.asarray(visual.face_colors, dtype=float)
        rgba = colors.mean(axis=0)[:4] / 255.0
    if len(rgba) == 3:
        rgba = np.append(rgba, 1.0)
    return tuple(float(c) for c in rgba), image


def _parts(path: Path) -> list[_Part]:
    """The mesh split by material, every node's transform applied."""
    parts = []
    for mesh in _load_scene(path).dump():
        if len(mesh.faces) == 0:
            continue
        color, image = _material_of(mesh.visual)
        uv = getattr(mesh.visual, "uv", None)
        if image is None or uv is None or len(uv) != len(mesh.vertices):
            uv, image = None, None
        parts.append(
            _Part(
                vertices=np.asarray(mesh.vertices, dtype=float),
                faces=np.asarray(mesh.faces, dtype=np.int64),
                uv=None if uv is None else np.asarray(uv, dtype=float),
                color=color,
                image=image,
            )
        )
    if not parts:
        raise DescriptionError(f"{path}: mesh has no triangles")
    return parts


def _material_obj(
    parts: list[_Part], name: str, mtl_name: str, texture_names: list[str | None]
) -> tuple[str, str]:
    """OBJ text (one ``usemtl`` group per part, face normals) and its MTL text."""
    obj = [
        f"# converted by armando_drake (converter {CONVERTER_VERSION}) from {name}\n",
        f"mtllib {mtl_name}\n",
    ]
    mtl = [f"# materials of {name}\n"]
    v_offset = vt_offset = vn_offset = 0
    for index, (part, texture) in enumerate(zip(parts, texture_names, strict=True)):
        material = f"material_{index}"
        r, g, b, a = part.color
        mtl.append(
            f"newmtl {material}\nKa 0 0 0\nKd {r:.6g} {g:.6g} {b:.6g}\nKs 0 0 0\nd {a:.6g}\n"
        )
        if texture:
            mtl.append(f"map_Kd {texture}\n")
        v, f = part.vertices, part.faces
        a_, b_ = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
        normals = np.cross(a_, b_)
        lengths = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
        obj.append(f"o {material}\nusemtl {material}\n")
        obj.append(("v %.9g %.9g %.9g\n" * len(v)) % tuple(v.ravel()))
        obj.append(("vn %.6f %.6f %.6f\n" * len(normals)) % tuple(normals.ravel()))
        n = np.arange(len(f)) + 1 + vn_offset
        fv = f + 1 + v_offset
        if texture:
            obj.append(("vt %.9g %.9g\n" * len(part.uv)) % tuple(part.uv.ravel()))
            ft = f + 1 + vt_offset
            corners = np.column_stack(
                [fv[:, 0], ft[:, 0], n, fv[:, 1], ft[:, 1], n, fv[:, 2], ft[:, 2], n]
            )
            obj.append(("f %d/%d/%d %d/%d/%d %d/%d/%d\n" * len(f)) % tuple(corners.ravel()))
            vt_offset += len(part.uv)
        else:
            corners = np.column_stack([fv[:, 0], n, fv[:, 1], n, fv[:, 2], n])
            obj.append(("f %d//%d %d//%d %d//%d\n" * len(f)) % tuple(corners.ravel()))
        v_offset += len(v)
        vn_offset += len(f)
    return "".join(obj), "".join(mtl)


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


def _needs_normals(path: Path) -> bool:
    """An OBJ without vertex normals, which Drake's renderers refuse ("OBJ has no normals")."""
    if path.suffix.lower() != ".obj":
        return False
    with open(path, "rb") as stream:
        return not any(line.startswith(b"vn ") for line in stream)


def convert_mesh(source: str | os.PathLike) -> ConvertedMesh:
    """The OBJ Drake should load for ``source``, converting it into the cache if needed.

    OBJ and glTF files pass through untouched; other formats raise a
    :class:`DescriptionError` naming the extension.
    """
    source = Path(source).resolve()
    suffix = source.suffix.lower()
    if suffix in DRAKE_FORMATS and not _needs_normals(source):
        return ConvertedMesh(source=source, path=source, converted=False)
    if suffix not in CONVERTED_FORMATS + (".obj",):
        raise DescriptionError(
            f"{source}: unsupported mesh format {suffix or '(no extension)'!r}; "
            f"supported: {', '.join(SUPPORTED_FORMATS)}"
        )
    folder = cache_dir()
    target = folder / f"{source.stem}-{_content_key(source)}.obj"
    if target.is_file() and _vertices_file(target).is_file():
        return ConvertedMesh(source=source, path=target, converted=False)
    folder.mkdir(parents=True, exist_ok=True)
    if suffix in (".dae", ".obj"):
        parts = _parts(source)
        vertices = np.vstack([part.vertices for part in parts])
        textures = []
        for index, part in enumerate(parts):
            if part.image is None:
                textures.append(None)
                continue
            image_path = target.with_name(f"{target.stem}-texture{index}.png")
            _write_atomically(image_path, lambda name, im=part.image: im.save(name, format="PNG"))
            textures.append(image_path.name)
        mtl_path = target.with_suffix(".mtl")
        text, mtl = _material_obj(parts, source.name, mtl_path.name, textures)
        _write_atomically(mtl_path, lambda name: Path(name).write_text(mtl))
    else:
        mesh = load_mesh(source)
        vertices = np.asarray(mesh.vertices, dtype=float)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        normals = np.asarray(mesh.face_normals, dtype=float)
        text = _obj_text(vertices, faces, normals, source.name)
    return _write_converted(source, target, vertices, text)


# Bumped whenever the hull written for the same source would differ.
HULL_VERSION = 1
# [m] (in the file's units) the thinnest side of the box standing in for a flat mesh's hull.
MIN_HULL_SIDE = 1e-3


def _hull_of(mesh):
    """The convex hull (a trimesh) of ``mesh``'s vertices; a flat or degenerate mesh (no
    volume to wrap) gets the box around its vertices, no side thinner than
    :data:`MIN_HULL_SIDE`."""
    import trimesh

    try:
        hull = mesh.convex_hull
        if hull.volume > 0 and len(hull.faces) >= 4:
            return hull
    except Exception:  # qhull refuses coplanar points (QhullError), trimesh may raise others
        pass
    low, high = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    extents = np.maximum(high - low, MIN_HULL_SIDE)
    return trimesh.creation.box(extents=extents).apply_translation((low + high) / 2)


def convex_hull(source: str | os.PathLike) -> ConvertedMesh:
    """The convex hull of a mesh file (STL, DAE, OBJ, glTF; Collada in metres by its
    ``<unit>``) as an OBJ with face normals in the cache, keyed by the source's content;
    ``converted`` is True when this call wrote it. What Drake collides with, declared
    convex: one hull per mesh file."""
    source = Path(source).resolve()
    if source.suffix.lower() not in SUPPORTED_FORMATS:
        convert_mesh(source)  # raises the unsupported-format message
    folder = cache_dir()
    digest = hashlib.sha256(f"hull {HULL_VERSION} {_content_key(source)}".encode())
    target = folder / f"{source.stem}-{digest.hexdigest()[:24]}.hull.obj"
    if target.is_file() and _vertices_file(target).is_file():
        return ConvertedMesh(source=source, path=target, converted=False)
    folder.mkdir(parents=True, exist_ok=True)
    hull = _hull_of(load_mesh(source))
    vertices = np.asarray(hull.vertices, dtype=float)
    faces = np.asarray(hull.faces, dtype=np.int64)
    text = _obj_text(vertices, faces, np.asarray(hull.face_normals, dtype=float), source.name)
    return _write_converted(source, target, vertices, text)


def _write_converted(source: Path, target: Path, vertices: np.ndarray, text: str) -> ConvertedMesh:
    """Writes a converted mesh's OBJ ``text`` at ``target`` and its vertices beside it."""

    def save_vertices(name: str) -> None:
        with open(name, "wb") as stream:
            np.save(stream, vertices)

    _write_atomically(_vertices_file(target), save_vertices)
    _write_atomically(target, lambda name: Path(name).write_text(text))
    return ConvertedMesh(source=source, path=target, converted=True)


def mass_properties(path: str | os.PathLike, scale=(1.0, 1.0, 1.0)):
    """(volume [m^3], centre [m], inertia per unit density [m^5] about the centre, in
    the file's axes) of the solid a mesh file bounds, scaled by ``scale``: the mesh itself
    when it is closed, else its convex hull."""
    mesh = load_mesh(Path(path)).copy()
    mesh.apply_transform(np.diag([*np.asarray(scale, dtype=float), 1.0]))
    if not (mesh.is_watertight and mesh.is_volume and mesh.volume > 0):
        mesh = _hull_of(mesh)
    mesh.density = 1.0
    return float(mesh.volume), np.asarray(mesh.center_mass), np.asarray(mesh.moment_inertia)


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
