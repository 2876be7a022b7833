"""armando-drake: bring up a ROS robot arm in Drake, without ROS 2 or Gazebo."""

from pathlib import Path

from armando_drake.tools.mesa import install as _install_shaders
from armando_drake.tools.version import package_version

# Before any shader is compiled: VTK cameras' antialiasing pass off unless a scenario
# asks for it (armando_drake.sensors.antialiasing).
_install_shaders()

# The version of pyproject.toml (armando_drake.tools.version), as the package metadata has it.
__version__ = package_version()

_PACKAGE_DIR = Path(__file__).resolve().parent


def _data_dir(name: str) -> Path:
    """A data folder of the project: inside the package when installed from a wheel
    (pyproject.toml maps ``models/`` and ``diagrams/`` into it), beside the package
    in the source tree and in an editable install."""
    installed = _PACKAGE_DIR / name
    return installed if installed.is_dir() else _PACKAGE_DIR.parent / name


# The source tree's root (notebooks write their outputs below it).
PROJECT_ROOT = _PACKAGE_DIR.parent
# The project's own robot descriptions and scenario files.
MODELS_DIR = _data_dir("models")
DIAGRAMS_DIR = _data_dir("diagrams")
# The data folders the package reads at run time: the wheel ships every file of them
# (pyproject.toml), as tests/test_packaging.py checks.
DATA_DIRS = (MODELS_DIR, DIAGRAMS_DIR)
# The built-in robot: our own Armando description.
DEFAULT_DESCRIPTION = MODELS_DIR / "armando_description" / "urdf" / "armando.urdf.xacro"
