"""VTK's antialiasing pass, off by default: the scenario's ``camera.antialiasing``.

Drake's ``RenderEngineVtk`` runs VTK's FXAA filter on every colour frame, with no
parameter to turn it off (``RenderEngineVtkParams`` has none in Drake 1.51). On a machine
without a GPU that filter runs in Mesa's llvmpipe, as an 800-line fragment shader over
every pixel: about 43 ms of CPU per 640 x 480 frame whatever the scene, four fifths of a
colour frame's cost (``docs/design/performance.md``). Drake's OpenGL engine has no
antialiasing at all.

Mesa reads a replacement for any shader it compiles from the folder named by
``MESA_SHADER_READ_PATH``, by the hash of the shader's source (Mesa's "shader
replacement", a documented environment variable). ``armando_drake/tools/shaders/``
(:mod:`armando_drake.tools.mesa`) holds one file: a replacement for that FXAA fragment
shader that copies its input, the frame as rendered.
With it a VTK colour frame costs about a fifth as much, and is the frame without the
antialiasing: the same pixels wherever FXAA leaves a pixel alone (every pixel off an
edge), the edges hard as OpenGL draws them.

Mesa reads the variable at every shader compile, but for good once it finds it unset, so
it must be set before the process's first shader:
:func:`armando_drake.tools.mesa.install` sets it when the package is imported (unless
the user set it). :func:`use_vtk_antialiasing` switches between the replacement and
VTK's own filter for the engines that render their first colour frame after the call (a
world sets it while it is built, before any frame). A user's own
``MESA_SHADER_READ_PATH`` is left alone, and VTK's FXAA runs then. Other GL drivers than
Mesa ignore the variable (and run the filter, cheaply, on a GPU), as does a VTK other
than Drake 1.51's (the hash would differ). So whether the pass runs is not taken on
trust: a 16 x 16 probe frame (:func:`vtk_frames_antialiased`) says it, the log warns
when FXAA runs although it was asked off, and ``summary.json``'s ``cameras`` says what
ran.
"""

from __future__ import annotations

import functools
import logging
import os

from armando_drake.tools.mesa import READ_PATH, SHADER_DIR, install

_log = logging.getLogger("armando_drake.world")

# A value of READ_PATH that replaces nothing (an empty folder name: Mesa keeps looking,
# finds no file, and compiles the shader as given).
_NO_REPLACEMENT = ""


def ours() -> bool:
    """Whether ``MESA_SHADER_READ_PATH`` is the package's (either of its two values),
    not the user's."""
    return os.environ.get(READ_PATH) in (str(SHADER_DIR), _NO_REPLACEMENT)


def use_vtk_antialiasing(on: bool) -> bool:
    """VTK's FXAA pass on (``on``) or off for the VTK engines whose first colour frame is
    rendered after this call; returns whether FXAA runs for them, as a probe frame shows
    (:func:`vtk_frames_antialiased`) when it was asked off. A user's own
    ``MESA_SHADER_READ_PATH`` is kept."""
    install()
    if ours():
        os.environ[READ_PATH] = _NO_REPLACEMENT if on else str(SHADER_DIR)
        if on:
            return True  # nothing is replaced: VTK's own pass runs
    fxaa = vtk_frames_antialiased()
    if fxaa and not on:
        _log.warning(
            "VTK cameras antialias their frames (FXAA) although camera.antialiasing is false: %s",
            f"{READ_PATH}={os.environ.get(READ_PATH)} is the user's"
            if not ours()
            else "Mesa did not take the replacement shader (a GL shader was compiled in "
            "this process before armando_drake was imported, or Drake's VTK is not the "
            "one of Drake 1.51)",
        )
    return fxaa


def vtk_frames_antialiased() -> bool:
    """Whether a VTK colour frame rendered now is antialiased (FXAA): a 16 x 16 probe
    frame of a square turned 0.3 rad has colours between the square's and the
    background's only if it is. About 0.1 s, once per value of ``MESA_SHADER_READ_PATH``."""
    return _probe(os.environ.get(READ_PATH))


@functools.cache
def _probe(read_path: str | None) -> bool:
    import numpy as np
    from pydrake.geometry import (
        Box,
        ClippingRange,
        ColorRenderCamera,
        GeometryId,
        MakeRenderEngineVtk,
        PerceptionProperties,
        RenderCameraCore,
        RenderEngineVtkParams,
        Rgba,
    )
    from pydrake.math import RigidTransform, RollPitchYaw
    from pydrake.systems.sensors import CameraInfo, ImageRgba8U

    engine = MakeRenderEngineVtk(RenderEngineVtkParams())
    black = PerceptionProperties()
    black.AddProperty("phong", "diffuse", Rgba(0, 0, 0, 1))
    X_WB = RigidTransform(RollPitchYaw(0, 0, 0.3), [0, 0, 0])
    engine.RegisterVisual(GeometryId.get_new_id(), Box(1, 1, 1), black, X_WB, False)
    info = CameraInfo(16, 16, np.pi / 2)
    core = RenderCameraCore("probe", info, ClippingRange(0.1, 10), RigidTransform())
    engine.UpdateViewpoint(RigidTransform(RollPitchYaw(np.pi, 0, 0), [0.5, 0.5, 2.0]))
    image = ImageRgba8U(16, 16)
    engine.RenderColorImage(ColorRenderCamera(core, False), image)
    return len(np.unique(image.data[..., :3].reshape(-1, 3), axis=0)) > 2
