"""Mesa's shader replacement, pointed at the package's folder when the package is imported.

Mesa reads a replacement for a shader it compiles from the folder named by
``MESA_SHADER_READ_PATH``, by the hash of the shader's source; it reads the variable at
every compile, but for good once it finds it unset, so it is set before the process's
first shader: :func:`install`, called by ``armando_drake/__init__.py``. The folder,
``tools/shaders/``, holds the replacement of VTK's FXAA shader that
:mod:`armando_drake.sensors.antialiasing` switches on and off.
"""

import os
from pathlib import Path

# Mesa's shader-replacement folder variable.
READ_PATH = "MESA_SHADER_READ_PATH"
# The folder of replacement shaders: VTK's FXAA fragment shader, as a copy of its input.
SHADER_DIR = Path(__file__).resolve().parent / "shaders"


def install() -> None:
    """Points Mesa at :data:`SHADER_DIR` unless ``MESA_SHADER_READ_PATH`` is set already."""
    os.environ.setdefault(READ_PATH, str(SHADER_DIR))
