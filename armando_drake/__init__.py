"""armando-drake: bring up a ROS robot arm in Drake, without ROS 2 or Gazebo."""

from pathlib import Path

__version__ = "0.1.0"

# The project's own data folders, next to the package in the source tree.
PROJECT_ROOT = Path(__file__).resolve().parent.parent
MODELS_DIR = PROJECT_ROOT / "models"
DIAGRAMS_DIR = PROJECT_ROOT / "diagrams"
# The built-in robot: our own Armando description.
DEFAULT_DESCRIPTION = MODELS_DIR / "armando_description" / "urdf" / "armando.urdf.xacro"
