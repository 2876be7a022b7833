"""The scenario's navigation added to a diagram: goals (:mod:`.navigator`), or mapping by
exploration (:mod:`.slam` + :mod:`.explore`).

:func:`AddNavigation` builds the navigator of the ``navigation:`` section; with
``explore: true`` (and ``localization: slam``) it adds a :class:`~.slam.SlamMapper` on the
drive's odometry and the lidar's scans, and an :class:`~.explore.Explorer` planning on
the map the mapper publishes (NavFn with ``allow_unknown``), its pose map -> odom and
the odometry. The world's true occupancy is kept (``Navigation.truth``) to measure the
map built against it.
"""

from __future__ import annotations

import dataclasses as dc

from armando_drake.messages.types import TwistStamped
from armando_drake.navigation import navigator as goals_navigator
from armando_drake.navigation.costmap import costmap_parameters
from armando_drake.navigation.explore import Explorer, explore_parameters
from armando_drake.navigation.follower import controller_parameters
from armando_drake.navigation.navigator import (
    ConnectLocalization,
    Navigation,
    _axle_offset,
    navigation_map,
    resolve_file,
)
from armando_drake.navigation.overrides import overridden_file
from armando_drake.navigation.planner import planner_parameters
from armando_drake.navigation.slam import SlamMapper, canvas, slam_parameters
from armando_drake.navigation.world_map import LIDAR_TYPES
from armando_drake.tools.errors import ConfigError, ScenarioError
from armando_drake.tools.extras import require_extra

__all__ = ["AddNavigation", "ConnectLocalization"]


def AddNavigation(builder, config, stack, *, where: str = "") -> Navigation:
    """The navigation of ``config``: to its goals, or exploring (``explore: true``)."""
    if not config.explore:
        return goals_navigator.AddNavigation(builder, config, stack, where=where)
    return AddExploration(builder, config, stack, where=where)


def _read(reader, key: str, config, where: str):
    path = resolve_file(getattr(config, key), f"navigation.{key}", where)
    if key == "params_file":
        path = overridden_file(path, config.params_overrides, where)
    try:
        return reader(path)
    except ConfigError as error:
        raise ConfigError(f"{where}navigation.{key}: {error}") from None


def _poses(stack, lidar):
    """The lidar's (x, y, yaw) in the floating base's frame, and the base's spawn pose."""
    plant, robot = stack.plant, stack.robot
    context = plant.CreateDefaultContext()
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    link = plant.GetBodyByName(lidar.link, robot.model_instance).body_frame()
    X_BS = plant.CalcRelativeTransform(context, body.body_frame(), link) @ lidar.X_LS
    X_WB = plant.EvalBodyPoseInWorld(context, body)

    def planar(X):
        return (X.translation()[0], X.translation()[1], X.rotation().ToRollPitchYaw().yaw_angle())

    return planar(X_BS), planar(X_WB)


def AddExploration(builder, config, stack, *, where: str = "") -> Navigation:
    """A SlamMapper and an Explorer on ``stack``'s robot (see the module docstring)."""
    require_extra("navigation", f"{where}navigation")
    takers = stack.taking(TwistStamped)
    if config.controller:
        takers = [name for name in takers if name == config.controller]
    if not takers or not stack.hardware.base_position_index:
        raise ScenarioError(f"{where}navigation needs a floating base with an active drive")
    lidars = [b for b in stack.robot.sensors if b.type in LIDAR_TYPES]
    if not lidars:
        raise ScenarioError(f"{where}navigation.explore needs a lidar on the robot")
    costmap_params = _read(costmap_parameters, "params_file", config, where)
    planner = dc.replace(
        _read(planner_parameters, "params_file", config, where), allow_unknown=True
    )
    controller = _read(controller_parameters, "params_file", config, where)
    slam = _read(slam_parameters, "slam_params_file", config, where)
    explore = _read(explore_parameters, "explore_params_file", config, where)
    truth = navigation_map(config, stack.plant, stack.scene_graph, stack.robot, where)
    blank = canvas(truth, slam.resolution)
    laser, spawn = _poses(stack, lidars[0])
    axle = _axle_offset(stack, takers[0])
    hardware = stack.hardware
    explorer = builder.AddSystem(
        Explorer(
            explore,
            costmap_params,
            blank,
            controller,
            planner,
            state_size=hardware.num_model_states,
            base_rows=(hardware.base_position_index, hardware.base_velocity_index),
            inscribed_radius=costmap_params.inscribed_radius,
            start_delay=config.start_delay,
            grid=blank,
            amcl_axle=axle,
        )  # fmt: skip
    )
    explorer.set_name("explorer")
    rate = 2.0 * max(lidars[0].update_rate, 1.0)  # twice the scans: odometry at each
    footprint = 0.5 * costmap_params.robot_radius
    mapper = builder.AddSystem(
        SlamMapper(slam, blank, laser, axle=axle, rate=rate, footprint=footprint, start=spawn)
    )
    mapper.set_name("slam")
    plant, instance = stack.plant, stack.robot.model_instance
    builder.Connect(plant.get_state_output_port(instance), explorer.GetInputPort("state"))
    builder.Connect(explorer.GetOutputPort("cmd_vel"), stack.command_input(takers[0]))
    builder.ExportOutput(explorer.GetOutputPort("command"), "navigation_command")
    odom = stack.manager.GetOutputPort(f"{takers[0]}.odom")
    builder.Connect(odom, mapper.GetInputPort("odom"))
    builder.Connect(odom, explorer.GetInputPort("odom"))
    builder.Connect(mapper.GetOutputPort("map_to_odom"), explorer.GetInputPort("map_to_odom"))
    builder.Connect(mapper.GetOutputPort("map"), explorer.GetInputPort("map"))
    builder.ExportOutput(mapper.GetOutputPort("estimate"), "slam_estimate")
    return Navigation(
        navigator=explorer, drive=takers[0], grid=blank, costmap=explorer.costmap,
        lidar=lidars[0].name, mapper=mapper, truth=truth,
    )  # fmt: skip
