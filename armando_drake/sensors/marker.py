"""The ArUco marker object: a thin box whose top face shows an OpenCV ArUco marker.

The marker image comes from OpenCV's ``aruco`` module
(``getPredefinedDictionary`` + ``generateImageMarker``), with a white quiet zone
around it; it is written as a PNG with a textured OBJ box (and its MTL) into
the mesh cache (:func:`~armando_drake.description.meshes.cache_dir`), keyed by
dictionary, id and sizes, and Drake's renderers (GL and VTK) draw the texture.

Frames: the object frame O is the box's centre; the marker frame M (OpenCV's,
as ``solvePnP`` estimates it) is the centre of the top face, x to the image's
right, y to its top, z out of the face: ``X_OM`` = a translation of half the
thickness along O's z. A marker laid flat on the ground shows its face upwards.
"""

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform

from armando_drake.description.meshes import cache_dir
from armando_drake.tools.extras import missing_extra
from armando_drake.tools.schema import Refusal, param

# Pixels per marker bit in the texture (a 4x4 marker with its border: 6 bits wide).
_PIXELS_PER_BIT = 32


class MarkerError(ValueError):
    """A marker that cannot be made (unknown dictionary, id outside it, bad size)."""


def aruco_dictionary(name: str):
    """OpenCV's predefined ArUco dictionary ``name`` (e.g. ``DICT_4X4_50``,
    ``DICT_ARUCO_ORIGINAL``); :class:`MarkerError` listing the names otherwise."""
    import cv2

    names = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
    if name not in names:
        raise MarkerError(
            f"dictionary={name!r} is not an OpenCV ArUco dictionary ({', '.join(names)})"
        )
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def dictionary_size(dictionary) -> int:
    """How many markers the dictionary holds."""
    return int(dictionary.bytesList.shape[0])


@dataclass
class ArucoMarker:
    """An ArUco marker on a thin box (the top face shows it)."""

    # OpenCV's predefined dictionary (cv2.aruco.DICT_*), e.g. DICT_4X4_50.
    dictionary: str = "DICT_ARUCO_ORIGINAL"
    id: int = param(201, unit="-")  # the marker's id in the dictionary
    # [m] side of the black marker square (its outer border)
    side_length: float = param(0.1, unit="m", gt=0)
    margin: float = param(0.02, unit="m", ge=0)  # [m] white quiet zone around the marker
    thickness: float = param(0.005, unit="m", gt=0)  # [m] of the box

    def message_prefix(self, parent: str, name: str) -> str:
        """A marker's fields are named after its type in messages (``ArucoMarker: id``)."""
        return f"{parent}ArucoMarker: " if name else ""

    def check(self) -> None:
        """The dictionary is OpenCV's and holds the id (the sizes are checked beside them)."""
        problem = missing_extra("vision")
        if problem:
            raise Refusal("", f" {problem}")
        try:
            dictionary = aruco_dictionary(self.dictionary)
        except MarkerError as error:
            raise Refusal("dictionary", str(error).removeprefix("dictionary")) from None
        size = dictionary_size(dictionary)
        if not 0 <= self.id < size:
            raise Refusal(
                "id", f"={self.id!r} is outside dictionary {self.dictionary} (ids 0..{size - 1})"
            )

    @property
    def face(self) -> float:
        """[m] side of the box's square face (marker + margins)."""
        return self.side_length + 2 * self.margin

    def X_OM(self) -> RigidTransform:
        """Pose of the marker frame M (OpenCV's) in the object frame O."""
        return RigidTransform([0.0, 0.0, self.thickness / 2])

    def image(self) -> np.ndarray:
        """The face's texture: the marker with its white margin (uint8, grey)."""
        import cv2

        dictionary = aruco_dictionary(self.dictionary)
        bits = dictionary.markerSize + 2  # with the black border
        pixels = bits * _PIXELS_PER_BIT
        marker = cv2.aruco.generateImageMarker(dictionary, self.id, pixels)
        pad = int(round(self.margin / self.side_length * pixels))
        return cv2.copyMakeBorder(marker, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)

    def mesh_file(self, folder: Path | None = None) -> Path:
        """The textured OBJ of the box (written once into ``folder``, the mesh cache
        by default): the top face (+z) shows :meth:`image`, the other faces white."""
        import cv2

        if folder is None:
            folder = cache_dir()
        key = repr((5, self.dictionary, self.id, self.side_length, self.margin, self.thickness))
        digest = hashlib.sha1(key.encode()).hexdigest()[:10]
        stem = f"aruco_{self.dictionary.lower()}_{self.id}_{digest}"
        obj = Path(folder) / f"{stem}.obj"
        if obj.is_file():
            return obj
        obj.parent.mkdir(parents=True, exist_ok=True)
        # Drake's renderers read colour textures (a grey PNG is dropped); RGBA, because
        # RenderEngineGl shears an RGB image whose rows are not a multiple of 4 bytes.
        cv2.imwrite(str(obj.with_suffix(".png")), cv2.cvtColor(self.image(), cv2.COLOR_GRAY2BGRA))
        obj.with_suffix(".mtl").write_text(
            f"newmtl marker\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nmap_Kd {stem}.png\n"
        )
        a, h = self.face / 2, self.thickness / 2
        white = 0.5 * self.margin / self.face if self.margin > 0 else 0.5  # a margin pixel
        # Vertices 1-8: the box's corners, all textured with a white pixel of the margin;
        # 9-12: the top face's corners again, textured with the image's corners. One
        # texture coordinate per vertex, as RenderEngineGl wants it.
        corners = [(x, y, z) for z in (-h, h) for y in (-a, a) for x in (-a, a)]
        corners += [(-a, -a, h), (a, -a, h), (-a, a, h), (a, a, h)]
        uvs = [(white, white)] * 8 + [(0, 0), (1, 0), (0, 1), (1, 1)]
        # Faces (counter-clockwise seen from outside) as vertex/uv/normal indices from 1.
        normals = [(0, 0, 1), (0, 0, -1), (0, -1, 0), (1, 0, 0), (0, 1, 0), (-1, 0, 0)]
        faces = [(9, 10, 12, 11), (1, 3, 4, 2), (1, 2, 6, 5), (2, 4, 8, 6), (4, 3, 7, 8)]
        faces.append((3, 1, 5, 7))
        lines = [f"mtllib {stem}.mtl", "usemtl marker"]
        lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in corners]
        lines += [f"vt {u!r} {v!r}" for u, v in uvs]
        lines += [f"vn {x} {y} {z}" for x, y, z in normals]
        for k, (i, j, m, n) in enumerate(faces, start=1):
            lines += [
                f"f {i}/{i}/{k} {j}/{j}/{k} {m}/{m}/{k}",
                f"f {i}/{i}/{k} {m}/{m}/{k} {n}/{n}/{k}",
            ]
        tmp = obj.with_suffix(".obj.tmp")
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(obj)
        return obj
