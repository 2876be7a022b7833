"""The scenario's ``navigation:`` section: goals that fra2mo drives to as Nav2 would.

::

    navigation:
      params_file: package://fra2mo_description/config/navigation.yaml  # a Nav2 YAML
      map: ""                    # a map_server YAML; "" = the world's true occupancy
      goals:
        - {name: dock, x: 1.5, y: 1.5, yaw: 1.57}
        - {name: gate, x: -1.5, y: 0.5, yaw: 3.14}
      order: [gate, dock]        # the goals' names, in the order visited; [] = as listed
      localization: ground_truth

(No ``from __future__ import annotations`` here: ``yaml_load_typed`` needs the field
types as types.)
"""

import dataclasses as dc
import math

from armando_drake.tools.schema import Refusal, param

LOCALIZATIONS = ("ground_truth", "amcl", "slam")
# The most goals, and the most visits in `order`: each is planned for and driven to in
# turn (a run of 2000 goals is hours of simulated driving).
MAX_GOALS = 2000


@dc.dataclass
class NavigationGoal:
    """A goal pose on the map (a NavigateToPose goal)."""

    # Its name, used by `order` and in the messages and the summary.
    name: str = ""
    # [m] position in the map frame (the world's).
    x: float = param(0.0, unit="m")
    y: float = param(0.0, unit="m")
    # [rad] heading, counter-clockwise from +x.
    yaw: float = param(0.0, unit="rad")


@dc.dataclass
class NavigationConfig:
    """Navigation to goals: a global plan on the costmap, Regulated Pure Pursuit on it."""

    # The Nav2 parameter file (planner_server, controller_server, global_costmap): a
    # path, or package://pkg/...
    params_file: str = ""
    # Parameters of the Nav2 file replaced (or added) for this run, by their dotted
    # path without the ros__parameters level:
    # {controller_server.FollowPath.desired_linear_vel: 0.3} (navigation/overrides.py).
    params_overrides: dict[str, float] = param(default_factory=dict, unit="the parameter's own")
    # A map_server map YAML; "" = the world's collision geometry cut at the lidar's
    # height (navigation/world_map.py).
    map: str = ""
    # [m/cell] the resolution of the world's map when `map` is "".
    map_resolution: float = param(0.05, unit="m", gt=0, le=1.0)
    # [m] the height at which the world is cut for its map; 0 = the lidar's (or 0.2 m
    # without a lidar).
    scan_height: float = param(0.0, unit="m", ge=0)
    # The goal poses; [] = none: the robot waits for one (/goal_pose, or a script's
    # BasicNavigator).
    goals: list[NavigationGoal] = dc.field(default_factory=list)
    # The goals' names in the order they are visited; [] = the order of `goals`.
    order: list[str] = dc.field(default_factory=list)
    # Where the robot's pose comes from: the ground truth (the plant's state), or AMCL
    # (the Nav2 YAML's amcl section) on the drive's odometry and the lidar's scans.
    localization: str = param("ground_truth", choices=LOCALIZATIONS)
    # [m, m, rad] AMCL's initial pose estimate (x, y, yaw); [] = the Nav2 YAML's
    # amcl.initial_pose with set_initial_pose, else where the robot is spawned.
    initial_pose: list[float] = param([], unit="m")
    # [s] simulation time at which the first goal is sent (the robot settles first).
    start_delay: float = param(1.0, unit="s", ge=0)
    # The drive controller that gets cmd_vel, by name; "" = the first active one.
    controller: str = ""
    # Exploration (explore_lite): drive to the frontiers of the map being built by SLAM
    # (localization: slam) until none is left; then no goals are given.
    explore: bool = False
    # slam_toolbox's parameter file (localization: slam).
    slam_params_file: str = ""
    # explore_lite's parameter file (explore: true).
    explore_params_file: str = ""
    # In a world of several robots (robots:), the name of the one it acts on; "" = the
    # first listed.
    robot: str = ""

    def check(self) -> None:
        """Named goals, each once; an order of known names; a parameter file."""
        if not self.params_file:
            raise Refusal("params_file", ": a Nav2 parameter file is needed")
        if self.explore != (self.localization == "slam"):
            raise Refusal("explore", ": exploration and localization: slam go together")
        if self.explore:
            if self.goals:
                raise Refusal("goals", ": an exploration chooses its own goals; give none")
            for key in ("slam_params_file", "explore_params_file"):
                if not getattr(self, key):
                    raise Refusal(key, ": a parameter file is needed to explore")
        if len(self.goals) > MAX_GOALS:
            raise Refusal("goals", f": {len(self.goals)} goals, over the limit of {MAX_GOALS}")
        if len(self.order) > MAX_GOALS:
            raise Refusal("order", f": {len(self.order)} visits, over the limit of {MAX_GOALS}")
        names = set()
        for k, goal in enumerate(self.goals):
            if not goal.name:
                raise Refusal(f"goals.{k}.name", ": a goal needs a name")
            if goal.name in names:
                raise Refusal(f"goals.{k}.name", f"={goal.name!r} is given twice")
            names.add(goal.name)
            if not all(math.isfinite(v) for v in (goal.x, goal.y, goal.yaw)):
                raise Refusal(f"goals.{k}", f": goal {goal.name!r} is not finite")
        if self.initial_pose and len(self.initial_pose) != 3:
            raise Refusal("initial_pose", f"={self.initial_pose!r} must be [x, y, yaw] or []")
        for k, name in enumerate(self.order):
            if name not in names:
                raise Refusal(
                    f"order.{k}", f"={name!r} is not a goal (goals: {', '.join(sorted(names))})"
                )

    def visits(self) -> list[NavigationGoal]:
        """The goals in the order they are visited."""
        by_name = {goal.name: goal for goal in self.goals}
        return [by_name[name] for name in self.order] if self.order else list(self.goals)
