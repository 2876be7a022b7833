"""The robots of the task-space tests: the KUKA iiwa from ../shared, the built-in Armando.

The project's loader cannot yet load a ``world``-rooted description, so the iiwa is
expanded here with the PyPI ``xacro`` (``$(find iiwa_description)`` mapped to
``../shared/upstream``) and parsed by Drake's Parser, which maps the URDF's ``world``
link to its world body. No SceneGraph is attached, so the STL meshes are not read.
iiwa14 URDF: effort limit 300 N m and velocity limit 10 rad/s on every joint;
position limits +-170, +-120, +-170, +-120, +-170, +-120, +-175 degrees; joint
damping 0.5 N m s; end effector ``iiwa_link_ee`` 45 mm past the flange.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
from conftest import SHARED, skip_or_fail
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

IIWA_PACKAGE = SHARED / "upstream" / "iiwa_description"
IIWA_XACRO = IIWA_PACKAGE / "urdf" / "iiwa14.urdf.xacro"
IIWA_END_EFFECTOR = "iiwa_link_ee"
ARMANDO_END_EFFECTOR = "crawer_base"


@contextlib.contextmanager
def _find(packages: dict[str, Path]):
    """``$(find pkg)`` of the PyPI xacro resolved from ``packages``."""
    from xacro import substitution_args

    def eval_find(name: str) -> str:
        return str(packages[name])

    saved = substitution_args._eval_find, substitution_args._eval_dict.get("find")
    substitution_args._eval_find = eval_find
    substitution_args._eval_dict["find"] = eval_find
    try:
        yield
    finally:
        substitution_args._eval_find, substitution_args._eval_dict["find"] = saved


def iiwa_urdf(hardware_interface: str = "EffortJointInterface") -> str:
    """The iiwa14 URDF text, xacro expanded (skips, or fails under CI, without ../shared)."""
    if not IIWA_XACRO.is_file():
        skip_or_fail(f"the iiwa description is not at {IIWA_XACRO}")
    import xacro

    with _find({"iiwa_description": IIWA_PACKAGE}):
        document = xacro.process_file(
            str(IIWA_XACRO), mappings={"hardware_interface": hardware_interface}
        )
    return document.toprettyxml(indent="  ")


def add_iiwa(plant: MultibodyPlant):
    """Adds the iiwa (7 actuated joints, welded to the world by its URDF); its instance."""
    urdf = iiwa_urdf()  # first: it skips (or fails under CI) without ../shared
    parser = Parser(plant)
    parser.package_map().Add("iiwa_description", str(IIWA_PACKAGE))
    (instance,) = parser.AddModelsFromString(urdf, "urdf")
    return instance


def add_armando(plant: MultibodyPlant):
    """Adds the built-in Armando with one torque actuator per joint at its URDF effort."""
    from armando_drake.description.loader import load_robot

    robot = load_robot(plant)
    for info in robot.joints:
        joint = plant.GetJointByName(info.name, robot.model_instance)
        effort = info.effort if np.isfinite(info.effort) else np.inf
        plant.AddJointActuator(f"{info.name}_motor", joint, effort)
    return robot.model_instance
