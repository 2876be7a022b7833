"""VTK's antialiasing pass, off by default: the scenario's ``camera.antialiasing``.

Drake's ``RenderEngineVtk`` runs VTK's FXAA filter on every colour frame, with no
parameter to turn it off (``RenderEngineVtkParams`` has none in Drake 1.51). On a machine
without a GPU that filter runs in Mesa's llvmpipe, as an 800-line fragment shader over
every pixel: about 43 ms of CPU per 640 x 480 frame whatever the scene, four fifths of a
colour frame's cost (``docs/design/performance.md``). Drake's OpenGL engine has no
antialiasing at all.

Mesa reads a replacement for any shader it compiles from the folder named by
``MESA_SHADER_READ_PATH``, by the hash of the shader's source (Mesa's "shader
replacement", a documented environment variable). :data:`SHADER_DIR` holds one file: a
replacement for that FXAA fragment shader that copies its input, the frame as rendered.
With it a VTK colour frame costs about a fifth as much, and is the frame without the
antialiasing: the same pixels wherever FXAA leaves a pixel alone (every pixel off an
edge), the edges hard as OpenGL draws them.

Mesa reads the variable at every shader compile, but for good once it finds it unset, so
it must be set before the process's first shader: :func:`install` sets it when the
package is imported (unless the user set it). :func:`use_vtk_antialiasing` switches
between the replacement and VTK's own filter for the engines that render their first
colour frame after the call (a world sets it while it is built, before any frame). A
user's own ``MESA_SHADER_READ_PATH`` is left alone, and VTK's FXAA runs then. Other GL
drivers than Mesa ignore the variable (and run the filter, cheaply, on a GPU), as does a
VTK other than Drake 1.51's (the hash would differ; ``tests/sensors/test_antialiasing.py``
checks that the file takes effect).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

_log = logging.getLogger("armando_drake.world")

# Mesa's shader-replacement folder variable.
READ_PATH = "MESA_SHADER_READ_PATH"
# The folder of replacement shaders: VTK's FXAA fragment shader, as a copy of its input.
SHADER_DIR = Path(__file__).resolve().parent / "mesa_shaders"
# A value of READ_PATH that replaces nothing (an empty folder name: Mesa keeps looking,
# finds no file, and compiles the shader as given).
_NO_REPLACEMENT = ""


def install() -> None:
    """Points Mesa at :data:`SHADER_DIR` unless ``MESA_SHADER_READ_PATH`` is set already
    (the package does this when it is imported, before any shader is compiled)."""
    os.environ.setdefault(READ_PATH, str(SHADER_DIR))


def ours() -> bool:
    """Whether ``MESA_SHADER_READ_PATH`` is the package's (either of its two values),
    not the user's."""
    return os.environ.get(READ_PATH) in (str(SHADER_DIR), _NO_REPLACEMENT)


def use_vtk_antialiasing(on: bool) -> bool:
    """VTK's FXAA pass on (``on``) or off for the VTK engines whose first colour frame is
    rendered after this call; returns whether FXAA runs for them. A user's own
    ``MESA_SHADER_READ_PATH`` is kept (and FXAA then runs)."""
    install()
    if not ours():
        _log.info(
            "%s=%s is set: VTK cameras antialias their frames (FXAA) as Drake does",
            READ_PATH,
            os.environ.get(READ_PATH),
        )
        return True
    os.environ[READ_PATH] = _NO_REPLACEMENT if on else str(SHADER_DIR)
    return on
