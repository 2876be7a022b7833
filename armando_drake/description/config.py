"""The scenario's ``robot:`` section: which description is loaded, and where."""

import dataclasses as dc

from armando_drake.tools.schema import param

# No `from __future__ import annotations` here: yaml_load_typed reads the dataclass
# field types at run time and does not resolve string annotations.


@dc.dataclass
class RobotConfig:
    """Which description is loaded and where its base is welded."""

    # A .urdf/.xacro file, a package directory or package://pkg/file, or a Gazebo model
    # (its .sdf, or its folder with model.config); "" is the built-in Armando
    # (models/armando_description/urdf/armando.urdf.xacro).
    description: str = ""
    # xacro:arg values, as name: value.
    xacro_args: dict[str, str] = dc.field(default_factory=dict)
    # Extra folders searched for ROS packages, before ROS_PACKAGE_PATH.
    package_paths: list[str] = dc.field(default_factory=list)
    # Collision geometry: auto (convex when a link collides through a mesh) | boxes (one
    # box around each link's visual geometry) | convex (each collision mesh its convex
    # hull) | as-is | none. See docs/physics.md.
    collision: str = param("auto", choices=("auto", "boxes", "convex", "as-is", "none"))
    # [kg/m^3] Density of the geometry of a link that declares no mass: it gets the mass
    # and inertia of its collision (else visual) geometry at this density.
    density: float = param(1000.0, unit="kg/m^3", gt=0)
    # Whether the robot's links collide with each other. Off by default, as in
    # Gazebo (<self_collide> false); the robot always collides with the ground
    # and the scene objects.
    self_collision: bool = False
    # Position of the base in the world [m]: a fixed base is welded there, a floating
    # one spawned there (as `ros2 run ros_gz_sim create -x -y -z`).
    base_xyz: list[float] = param([0.0, 0.0, 0.0], unit="m", length=3, coordinate=True)
    # Orientation of the base in the world, roll pitch yaw [rad] (a spawn's -R -P -Y).
    base_rpy: list[float] = param([0.0, 0.0, 0.0], unit="rad", length=3)
    # How the base is held: fixed (welded to the world), floating (free: a mobile robot
    # resting on its wheels), or auto: floating when the description has no `world`
    # link and drives wheels (a differential drive in its <gazebo><plugin> blocks or its
    # controller YAML), else fixed.
    base: str = param("auto", choices=("auto", "fixed", "floating"))
