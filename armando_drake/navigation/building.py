"""The scenario's navigation added to a diagram, composed as Nav2 composes its servers.

:func:`AddNavigation` reads the Nav2 file of the ``navigation:`` section once
(:func:`~.nav2_params.read_nav2`, ``params_overrides`` applied to the parsed parameters)
and makes from it the servers' parts, each plugin by its Nav2 name (:mod:`.registry`):
the planner server's planner (:func:`~.planner.planner_plugin`), the controller server's
controller and checkers (:func:`~.follower.controller_parameters`), the global costmap's
layers and the local costmap's (:func:`~.costmap.costmap_parameters`), the behaviour
server's behaviours (:func:`~.behaviors.behavior_parameters`), the smoother server's
slot (:mod:`.smoother`) and, with
``localization: amcl``, AMCL's parameters. Then the map (the given map_server map, or
the world's true occupancy at the lidar's height: :mod:`.world_map`) and its costmap; a
goal in an obstacle is refused (its name in the one-line error).

To goals, it adds a :class:`~.navigator.Navigator` publishing cmd_vel to the drive
controller (with AMCL, an :class:`~.amcl.AmclLocalizer` feeding its map -> odom). With
``explore: true`` (and ``localization: slam``) it adds a :class:`~.slam.SlamMapper` on the
drive's odometry and the lidar's scans, and an :class:`~.explore.Explorer` planning on
the map the mapper publishes (the planner with ``allow_unknown``), its pose map -> odom
and the odometry; the world's true occupancy is kept (``Navigation.truth``) to measure
the map built against it.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from pathlib import Path
from typing import Any

from armando_drake.description.packages import find_packages
from armando_drake.messages.types import TwistStamped
from armando_drake.navigation.amcl import AmclLocalizer, ParticleFilter, amcl_parameters
from armando_drake.navigation.behaviors import behavior_parameters
from armando_drake.navigation.bringup import warn_not_run
from armando_drake.navigation.config import NavigationConfig
from armando_drake.navigation.costmap import Costmap, costmap_parameters, make_costmap
from armando_drake.navigation.explore import Explorer, explore_parameters
from armando_drake.navigation.follower import controller_parameters
from armando_drake.navigation.layers import Layers
from armando_drake.navigation.maps import MapError, OccupancyMap, load_map
from armando_drake.navigation.nav2_params import Nav2Params, read_nav2
from armando_drake.navigation.navigator import Navigator, check_goals
from armando_drake.navigation.planner import planner_plugin
from armando_drake.navigation.pose_buffer import PoseBuffer
from armando_drake.navigation.slam import SlamMapper, canvas, slam_parameters
from armando_drake.navigation.smoother import smoother_plugins
from armando_drake.navigation.topics import NavigationSource
from armando_drake.navigation.velocity_smoother import (
    VelocitySmoother,
    velocity_smoother_parameters,
)
from armando_drake.navigation.world_map import LIDAR_TYPES, lidar_height, world_map
from armando_drake.tools.errors import ConfigError, ScenarioError
from armando_drake.tools.extras import require_extra

__all__ = ["AddNavigation", "ConnectLocalization", "Navigation"]

_log = logging.getLogger("armando_drake.navigation")


@dc.dataclass(frozen=True)
class Navigation:
    """What :func:`AddNavigation` built (never changed after)."""

    navigator: Navigator
    drive: str
    grid: OccupancyMap
    costmap: Costmap
    amcl: AmclLocalizer | None = None  # with localization: amcl (its scan is connected by
    # ConnectLocalization, once the sensors are added)
    lidar: str = ""  # the lidar AMCL, the mapper or the obstacle layers read
    mapper: Any = None  # with exploration: the SlamMapper (navigation/slam.py)
    truth: OccupancyMap | None = None  # with exploration: the world's map, to compare

    def final_map(self, context) -> tuple[OccupancyMap, Costmap]:
        """The map the navigation has at ``context`` (the diagram's) and its costmap: the
        map being built when exploring, else the one it was given."""
        if self.mapper is None:
            return self.grid, self.costmap
        grid = self.mapper.current_map(self.mapper.GetMyContextFromRoot(context))
        return grid, make_costmap(grid, self.navigator.costmap_params)


def resolve_file(name: str, key: str, where: str) -> Path:
    """A path or ``package://pkg/rest`` to an existing file."""
    path = Path(name).expanduser()
    if name.startswith("package://"):
        package, _, rest = name[len("package://") :].partition("/")
        search = find_packages()
        if package not in search.packages:
            raise ScenarioError(f"{where}{key}={name!r}: unknown package {package!r}")
        path = search.packages[package] / rest
    if not path.is_file():
        raise ScenarioError(f"{where}{key}={name!r}: no such file")
    return path


def navigation_map(config: NavigationConfig, plant, scene_graph, robot, where: str = ""):
    """The map of ``config``: its map_server map, or the world's at the lidar's height."""
    if config.map:
        return load_map(resolve_file(config.map, "navigation.map", where))
    height = config.scan_height or lidar_height(plant, scene_graph, robot)
    try:
        return world_map(
            plant,
            scene_graph,
            height=height,
            resolution=config.map_resolution,
            exclude=[robot.model_instance],
        )
    except MapError as error:
        raise ScenarioError(
            f"{where}navigation.map_resolution={config.map_resolution!r}: {error}"
        ) from None


def _read(reader, source, key: str, where: str):
    """``reader(source)``, its error prefixed with the scenario's key."""
    try:
        return reader(source)
    except ConfigError as error:
        raise ConfigError(f"{where}navigation.{key}: {error}") from None


@dc.dataclass
class _Servers:
    """The Nav2 file's servers and costmaps, each read once from the parsed file."""

    nav2: Nav2Params
    costmap: Any  # the global costmap's CostmapParameters
    local: Any  # the local costmap's, or None
    planner: Any  # the planner plugin
    controller: Any  # ControllerParameters
    behaviors: Any  # BehaviorParameters or None
    smoothers: dict  # the smoother server's registered plugins (none run by the default tree)
    velocity_smoother: Any  # VelocitySmootherParameters, or None without the node

    @classmethod
    def read(cls, config: NavigationConfig, where: str) -> _Servers:
        path = resolve_file(config.params_file, "navigation.params_file", where)
        nav2 = read_nav2(path, config.params_overrides, where)

        def servers(nav2: Nav2Params) -> _Servers:
            local = None
            if nav2.node("local_costmap", "local_costmap") is not None:
                local = costmap_parameters(nav2, "local_costmap")
            return cls(
                nav2,
                costmap_parameters(nav2),
                local,
                planner_plugin(nav2),
                controller_parameters(nav2),
                behavior_parameters(nav2),
                smoother_plugins(nav2),
                velocity_smoother_parameters(nav2),
            )

        read = _read(servers, nav2, "params_file", where)
        warn_not_run(nav2, localization=config.localization, map_given=bool(config.map))
        return read


def _drive(config: NavigationConfig, stack, where: str) -> str:
    """The drive controller that takes cmd_vel (the first active one, or the named one)."""
    takers = stack.taking(TwistStamped)
    if config.controller:
        takers = [name for name in takers if name == config.controller]
    if not takers or not stack.hardware.base_position_index:
        raise ScenarioError(
            f"{where}navigation needs a floating base with an active drive "
            f"(active: {', '.join(stack.controllers) or 'none'})"
        )
    return takers[0]


def _lidar(stack, what: str, where: str):
    lidars = [b for b in stack.robot.sensors if b.type in LIDAR_TYPES]
    if not lidars:
        raise ScenarioError(f"{where}navigation{what} needs a lidar on the robot")
    return lidars[0]


def _planar(X) -> tuple[float, float, float]:
    return (
        float(X.translation()[0]),
        float(X.translation()[1]),
        float(X.rotation().ToRollPitchYaw().yaw_angle()),
    )


def _poses(stack, lidar) -> tuple[tuple, tuple]:
    """The lidar's (x, y, yaw) in the floating base's frame, and the base's spawn pose."""
    plant, robot = stack.plant, stack.robot
    context = plant.CreateDefaultContext()
    body = plant.get_body(next(iter(plant.GetFloatingBaseBodies())))
    link = plant.GetBodyByName(lidar.link, robot.model_instance).body_frame()
    X_BS = plant.CalcRelativeTransform(context, body.body_frame(), link) @ lidar.X_LS
    return _planar(X_BS), _planar(plant.EvalBodyPoseInWorld(context, body))


def _layers(stack, servers: _Servers, grid: OccupancyMap, where: str) -> Layers | None:
    """The costmaps fed by the lidar's scans: the global one if it has an obstacle layer,
    the file's local_costmap if it has one; None if neither."""
    global_params = servers.costmap if servers.costmap.obstacle_layer is not None else None
    local = servers.local
    if global_params is None and local is None:
        return None
    if local is not None and not math.isclose(local.resolution, grid.resolution):
        _log.warning(
            "%s: local_costmap resolution %g: the local costmap runs on the map's grid (%g)",
            servers.nav2.path,
            local.resolution,
            grid.resolution,
        )
    laser, _ = _poses(stack, _lidar(stack, ": the costmap's obstacle layer", where))
    height = lidar_height(stack.plant, stack.scene_graph, stack.robot)
    return Layers(global_params, local, laser, height)


def AddNavigation(
    builder, config: NavigationConfig, stack, *, where: str = "", publications=None
) -> Navigation:
    """The navigation of ``config`` on the floating base of ``stack``'s robot: to its
    goals, or exploring (``explore: true``); publishes cmd_vel to the first active drive
    (or ``config.controller``) and exports ``navigation_command``. ``publications`` (a
    PublicationRegistry): where its topics are registered
    (:mod:`armando_drake.navigation.topics`)."""
    require_extra("navigation", f"{where}navigation")
    drive = _drive(config, stack, where)
    servers = _Servers.read(config, where)
    hardware = stack.hardware
    system = dict(
        state_size=hardware.num_model_states,
        base_rows=(hardware.base_position_index, hardware.base_velocity_index),
        inscribed_radius=servers.costmap.inscribed_radius,
        footprint=tuple(servers.costmap.polygon),
        start_delay=config.start_delay,
    )
    add = _explorer if config.explore else _navigator
    navigation = add(builder, config, stack, servers, drive, system, where)
    if publications is not None:
        publications.add(*NavigationSource(stack, navigation).table())
    return navigation


def _pose_buffer(builder, stack, drive: str, system: dict) -> PoseBuffer:
    """The robot's PoseBuffer on its state and the drive's odometry, sampled at the
    odometry's rate."""
    logic = next(c.logic for c in stack.manager.controllers if c.name == drive)
    period = getattr(logic, "publish_period", math.inf)
    rate = 1.0 / period if math.isfinite(period) and period > 0 else float(stack.update_rate)
    buffer = builder.AddSystem(
        PoseBuffer(state_size=system["state_size"], base_rows=system["base_rows"], rate=rate)
    )
    buffer.set_name("pose_buffer")
    builder.Connect(
        stack.plant.get_state_output_port(stack.robot.model_instance),
        buffer.GetInputPort("state"),
    )
    builder.Connect(stack.manager.GetOutputPort(f"{drive}.odom"), buffer.GetInputPort("odom"))
    return buffer


def _connect(builder, stack, navigator, drive: str, buffer: PoseBuffer, smoother=None) -> None:
    """The navigator on the robot's state and pose buffer, its cmd_vel to the drive: through
    Nav2's velocity smoother when the file has one (``smoother``: its parameters), as Nav2's
    bringup places it (CLOSED_LOOP: on the drive's odometry)."""
    state = stack.plant.get_state_output_port(stack.robot.model_instance)
    builder.Connect(state, navigator.GetInputPort("state"))
    builder.Connect(buffer.GetOutputPort("poses"), navigator.GetInputPort("poses"))
    command = navigator.GetOutputPort("cmd_vel")
    if smoother is not None:
        system = builder.AddSystem(VelocitySmoother(smoother))
        system.set_name(f"{navigator.get_name()}_velocity_smoother")
        builder.Connect(command, system.GetInputPort("cmd_vel"))
        if smoother.feedback == "CLOSED_LOOP":
            odom = stack.manager.GetOutputPort(f"{drive}.odom")
            builder.Connect(odom, system.GetInputPort("odom"))
        command = system.GetOutputPort("cmd_vel_smoothed")
    builder.Connect(command, stack.command_input(drive))
    builder.ExportOutput(navigator.GetOutputPort("command"), "navigation_command")


def _navigator(builder, config, stack, servers: _Servers, drive, system, where) -> Navigation:
    """A Navigator to the scenario's goals (with AMCL: its localizer)."""
    grid = navigation_map(config, stack.plant, stack.scene_graph, stack.robot, where)
    costmap = make_costmap(grid, servers.costmap)
    goals = config.visits()
    check_goals(goals, costmap, where)
    amcl = config.localization == "amcl"
    layers = _layers(stack, servers, grid, where)
    navigator = builder.AddSystem(
        Navigator(goals, costmap, servers.controller, servers.planner, grid=grid,
                  odometry=amcl, layers=layers, behaviors=servers.behaviors, **system)
    )  # fmt: skip
    navigator.set_name("navigator")
    buffer = _pose_buffer(builder, stack, drive, system)
    _connect(builder, stack, navigator, drive, buffer, servers.velocity_smoother)
    lidar = _lidar(stack, ": the costmap's obstacle layer", where).name if layers else ""
    localizer = None
    if amcl:
        lidar = _lidar(stack, ".localization=amcl", where)
        localizer = _add_amcl(builder, config, stack, servers, grid, buffer, lidar, where)
        builder.Connect(
            localizer.GetOutputPort("map_to_odom"), navigator.GetInputPort("map_to_odom")
        )
        builder.Connect(
            stack.manager.GetOutputPort(f"{drive}.odom"), navigator.GetInputPort("odom")
        )
        lidar = lidar.name
    return Navigation(navigator, drive, grid, costmap, amcl=localizer, lidar=lidar)


def _add_amcl(builder, config, stack, servers: _Servers, grid, buffer, lidar, where):
    """The AmclLocalizer on the robot's pose buffer (the drive's odometry) and, later, the
    lidar's scan."""
    params = _read(amcl_parameters, servers.nav2, "params_file", where)
    laser, spawn = _poses(stack, lidar)
    initial = config.initial_pose or (params.initial_pose if params.set_initial_pose else None)
    if initial is not None and not _on_map(grid, initial):
        key = "navigation.initial_pose" if config.initial_pose else "params_file: amcl initial_pose"
        raise ScenarioError(
            f"{where}{key}={list(initial)!r}: off the map ({grid.source}: x "
            f"{grid.origin[0]:g}..{grid.origin[0] + grid.size_m[0]:g} m, y "
            f"{grid.origin[1]:g}..{grid.origin[1] + grid.size_m[1]:g} m)"
        )
    pf = ParticleFilter(params, grid, laser)
    rate = 2.0 * max(lidar.update_rate, 1.0)  # twice the scans: odometry at each
    amcl = builder.AddSystem(AmclLocalizer(pf, initial or spawn, rate=rate))
    amcl.set_name("amcl")
    builder.Connect(buffer.GetOutputPort("poses"), amcl.GetInputPort("poses"))
    builder.ExportOutput(amcl.GetOutputPort("estimate"), "amcl_estimate")
    return amcl


def _on_map(grid: OccupancyMap, pose) -> bool:
    """Whether the pose's position is finite and within the map's extent."""
    x, y = float(pose[0]), float(pose[1])
    width, height = grid.size_m
    return (
        grid.origin[0] <= x <= grid.origin[0] + width
        and grid.origin[1] <= y <= grid.origin[1] + height
    )


def _explorer(builder, config, stack, servers: _Servers, drive, system, where) -> Navigation:
    """A SlamMapper and an Explorer on ``stack``'s robot (see the module docstring)."""
    lidar = _lidar(stack, ".explore", where)
    slam_file = resolve_file(config.slam_params_file, "navigation.slam_params_file", where)
    slam = _read(slam_parameters, slam_file, "slam_params_file", where)
    explore_file = resolve_file(config.explore_params_file, "navigation.explore_params_file", where)
    explore = _read(explore_parameters, explore_file, "explore_params_file", where)
    planner = servers.planner
    if hasattr(planner.params, "allow_unknown"):  # the map being built is mostly unknown
        planner = type(planner)(dc.replace(planner.params, allow_unknown=True))
    truth = navigation_map(config, stack.plant, stack.scene_graph, stack.robot, where)
    blank = canvas(truth, slam.resolution)
    laser, spawn = _poses(stack, lidar)
    explorer = builder.AddSystem(
        Explorer(explore, servers.costmap, blank, servers.controller, planner, grid=blank,
                 odometry=True, **system)
    )  # fmt: skip
    explorer.set_name("explorer")
    rate = 2.0 * max(lidar.update_rate, 1.0)  # twice the scans: odometry at each
    footprint = 0.5 * servers.costmap.robot_radius
    mapper = builder.AddSystem(
        SlamMapper(slam, blank, laser, rate=rate, footprint=footprint, start=spawn)
    )
    mapper.set_name("slam")
    buffer = _pose_buffer(builder, stack, drive, system)
    _connect(builder, stack, explorer, drive, buffer, servers.velocity_smoother)
    builder.Connect(buffer.GetOutputPort("poses"), mapper.GetInputPort("poses"))
    builder.Connect(stack.manager.GetOutputPort(f"{drive}.odom"), explorer.GetInputPort("odom"))
    builder.Connect(mapper.GetOutputPort("map_to_odom"), explorer.GetInputPort("map_to_odom"))
    builder.Connect(mapper.GetOutputPort("map"), explorer.GetInputPort("map"))
    builder.ExportOutput(mapper.GetOutputPort("estimate"), "slam_estimate")
    return Navigation(
        explorer, drive, blank, explorer.costmap, lidar=lidar.name, mapper=mapper, truth=truth
    )


def ConnectLocalization(builder, navigation: Navigation | None, sensors: dict) -> None:
    """Connects the lidar's scan to AMCL, the mapper and the obstacle layers once the
    sensors are added (nothing to do for the ground truth or without a navigation)."""
    if navigation is None:
        return
    navigator = navigation.navigator if navigation.navigator.layers is not None else None
    for reader in (navigation.amcl, navigation.mapper, navigator):
        if reader is not None:
            builder.Connect(sensors[navigation.lidar]["scan"], reader.GetInputPort("scan"))
