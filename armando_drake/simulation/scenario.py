"""Scenarios: the typed equivalent of a launch file.

A scenario file in ``diagrams/`` says which robot to load, how the plant is
simulated, which ros2_control controllers run, what drives them and what the
camera sees. It is read with Drake's ``yaml_load_typed`` (the file first, then
optional YAML override strings), so an unknown key, an unknown tag or a value
of the wrong type is an error naming the file.

Two fields are tagged unions, as in manipulation's station scenarios: the
sequencer (``!PositionTargets``, ``!JointTrajectoryTargets``, ``!Sinusoid``)
and each object's shape (``!Box``, ``!Cylinder``, ``!Sphere``). An override
without a tag merges into the variant already there, so
``sequencer: {period: 5}`` changes a trajectory's period and keeps it a
trajectory; a tag chooses a variant anew (from its defaults, then the given
fields).

Each field declares its unit, range and choices beside it
(:func:`~armando_drake.tools.schema.param`);
:func:`~armando_drake.simulation.validation.check_scenario` checks them, and the rules
between fields of the whole scenario (:meth:`Scenario.check`), naming where each value
came from (:class:`ScenarioSources`).
"""

import dataclasses as dc
import os
import re
import textwrap
import types
import typing
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pydrake.common.yaml import yaml_dump, yaml_dump_typed, yaml_load, yaml_load_typed
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig
from pydrake.visualization import VisualizationConfig

from armando_drake import DIAGRAMS_DIR
from armando_drake.control.sequencer import (
    JointTrajectoryTargets,
    PositionTargets,
    Sinusoid,
    one_pass,
)
from armando_drake.control.stack import ActuatorConfig, ControllersConfig
from armando_drake.control.twist import TwistSequence
from armando_drake.description.config import RobotConfig
from armando_drake.kinematics.motion import TaskSpaceMotion
from armando_drake.navigation.config import NavigationConfig
from armando_drake.outputs.config import LoggingConfig
from armando_drake.perception.config import PerceptionConfig
from armando_drake.ros2.config import Ros2Config
from armando_drake.sensors.config import CameraSettings
from armando_drake.sensors.objects import SceneObject
from armando_drake.task.learned_ik import LearnedIkConfig
from armando_drake.teleop.config import JogConfig, TwistJogConfig
from armando_drake.tools.cli import parse_xacro_args
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.files import FileInputError, check_yaml_expansion, read_yaml_file
from armando_drake.tools.schema import Refusal, param
from armando_drake.tools.yaml_keys import duplicate_key
from armando_drake.vision.cameras import ScenarioCamera
from armando_drake.vision.config import VisionConfig

# The slowest pacing accepted (besides 0, as fast as possible): slower, a second lasts hours.
MIN_REALTIME_RATE = 1e-3
# [s] the longest run taken from the sequence itself (no simulation.duration or
# --duration given): one pass of a sequence longer than this is surely a typo.
MAX_DEFAULT_DURATION = 3600.0
NAVIGATION_TIME_PER_GOAL = 30.0  # [s] a navigation's default duration per goal
EXPLORATION_GOALS = 4  # an exploration's default duration: as many goals' times
# [s] the longest run accepted at all (about 11.6 simulated days): longer, the
# run would not end in any useful time, as fast as it may go.
MAX_DURATION = 1e6


@dc.dataclass
class SimulationConfig:
    """How long the simulation runs (how fast: ``Scenario.simulator_config``)."""

    # Simulated time [s]; 0 = one pass of the command sequence (2 s if there is
    # none).
    duration: float = param(
        0.0,
        unit="s",
        ge=0,
        over=(MAX_DURATION, f"{MAX_DURATION / 86400:.1f} simulated days"),
    )


# A robot's name in robots: (its model instance's name scope, its default namespace).
_ROBOT_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
# A namespace: /name, /name/inner, ...
_NAMESPACE = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")
# A description's prefix: letters, digits, _ (it begins names of links and joints).
_PREFIX = re.compile(r"[A-Za-z0-9_]*")
# The most robots in robots: (each is a model, a controller manager and its systems: 64
# arms take minutes to build), the longest name or prefix, and the deepest mount chain
# (a robot on a robot on ...).
MAX_ROBOTS = 64
MAX_NAME_LENGTH = 64
MAX_MOUNT_DEPTH = 8


@dc.dataclass
class RobotEntry:
    """One robot of a world (an entry of the scenario's ``robots:`` map, by its name):
    its description, where it stands or is mounted, and its own control stack."""

    # Its namespace: its ports and topics (/left/joint_states) and its folder of the
    # output (<output>/left/joint_states.csv); "" = /<name>; "/" = the root namespace:
    # plain names (joint_states, the output folder itself) and the description's own
    # model instance name, as the one robot of the top-level keys has.
    namespace: str = ""
    # The description and its base pose: base_xyz/base_rpy in the world, or in the
    # parent link's frame when mounted (parent).
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    # The description's `prefix` xacro argument (the names of its links and joints begin
    # with it; the controller YAML then names the prefixed joints); "" = none given.
    prefix: str = ""
    # "OTHER::link": its base welded to the link `link` of the robot named OTHER (listed
    # before it), at robot.base_xyz/base_rpy in that link's frame; "" = in the world.
    parent: str = ""
    # Its hardware interface's actuators (as the top-level actuators:).
    actuators: ActuatorConfig = dc.field(default_factory=ActuatorConfig)
    # Its controller manager and controller YAML (as the top-level controllers:).
    controllers: ControllersConfig = dc.field(default_factory=ControllersConfig)
    # What commands its controllers (as the top-level sequencer:); absent = nothing.
    sequencer: PositionTargets | JointTrajectoryTargets | Sinusoid | None = None
    # Velocity commands to its drive, a mobile base's (as the top-level twist:).
    twist: TwistSequence | None = None
    # An arm's tool point, whose position the run reports (summary.json's
    # robots.<name>.end_effector; on the terminal, how far apart the arms' tool points
    # ended): the link, "" = the one after its last joint along the links welded to it
    # while they do not branch (a gripper's palm), and the point in that link's frame.
    tool_link: str = ""
    tool_xyz: list[float] = param([0.0, 0.0, 0.0], unit="m", length=3)

    def check(self) -> None:
        if self.namespace not in ("", "/") and not _NAMESPACE.fullmatch(self.namespace):
            raise Refusal("namespace", f"={self.namespace!r} is not a namespace like /left")
        if self.parent and len(self.parent.split("::")) != 2:
            raise Refusal("parent", f"={self.parent!r}: give OTHER_ROBOT::link")
        if len(self.namespace) > MAX_NAME_LENGTH:
            raise Refusal(
                "namespace", f": {len(self.namespace)} characters, over {MAX_NAME_LENGTH}"
            )
        if not _PREFIX.fullmatch(self.prefix):
            raise Refusal("prefix", f"={self.prefix!r}: give letters, digits and _ only")
        if len(self.prefix) > MAX_NAME_LENGTH:
            raise Refusal("prefix", f": {len(self.prefix)} characters, over {MAX_NAME_LENGTH}")

    def space(self, name: str) -> str:
        """Its namespace as robot ``name``: ``/<name>`` when none is given, "" for the
        root namespace."""
        return "" if self.namespace == "/" else self.namespace or f"/{name}"


# The top-level keys of the one robot, which robots: replaces.
ROBOT_KEYS = ("robot", "actuators", "controllers", "sequencer", "twist")
# The name of the one robot of the top-level keys in the robots map they expand into.
ONE_ROBOT = "robot"


@dc.dataclass
class Scenario:
    """Everything the world builder needs."""

    # The robot description and its pose.
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    # Several robots in one world, by name (a letter or _, then letters, digits, _), each
    # with its description, pose or mount, namespace and control stack
    # (docs/multi_robot.md); instead of robot, actuators, controllers, sequencer and
    # twist. A list of entries with a `name:` each is read as this map. Empty = the one
    # robot of those keys (expand_robots makes it the map's only entry).
    robots: dict[str, RobotEntry] = dc.field(default_factory=dict)
    # Drake's plant settings (time step [s], contact approximation). The
    # approximation must support PD actuators: anything but tamsi. Without
    # sampled output ports the plant's step is a discrete update; with them it
    # is an unrestricted one, after which the simulator asks every Python
    # system for its witness functions, through pybind, at every step (about
    # 4 us per Python system per 1 ms step). The outputs (state, net
    # actuation) are then computed from the current state when read.
    plant_config: MultibodyPlantConfig = dc.field(
        default_factory=lambda: MultibodyPlantConfig(
            time_step=0.001, discrete_contact_approximation="lagged", use_sampled_output_ports=False
        )
    )
    # Whether a ground plane (a half space at z = 0) is added (not with a world_file).
    ground: bool = True
    # A Gazebo world (SDFormat <world> file, or package://pkg/worlds/x.sdf) as the scene,
    # instead of the ground: its included models (docs/worlds.md); "" = none.
    world_file: str = ""
    # Extra folders where the world's model://NAME includes are looked for, before the
    # world's own package (after GZ_SIM_RESOURCE_PATH and the like).
    world_resource_paths: list[str] = dc.field(default_factory=list)
    # Simple static objects placed in the world.
    objects: list[SceneObject] = dc.field(default_factory=list)
    # The hardware interface's actuators.
    actuators: ActuatorConfig = dc.field(default_factory=ActuatorConfig)
    # The controller manager.
    controllers: ControllersConfig = dc.field(default_factory=ControllersConfig)
    # What commands the controllers, by tag: !PositionTargets,
    # !JointTrajectoryTargets or !Sinusoid (control/sequencer.py); absent or
    # null = nothing (commands come from the diagram's input ports).
    sequencer: PositionTargets | JointTrajectoryTargets | Sinusoid | None = None
    # Velocity commands (cmd_vel) to a mobile base's drive: steps of {linear [m/s],
    # angular [rad/s], duration [s]} published at `rate` (control/twist.py); absent = none.
    twist: TwistSequence | None = None
    # Goals a mobile base drives to as Nav2 does: a global plan on the costmap of the
    # world's (or a given) map, Regulated Pure Pursuit on it, the parameters of a Nav2
    # YAML (armando_drake/navigation/config.py, docs/navigation.md); absent = none.
    navigation: NavigationConfig | None = None
    # A task-space motion of the end effector (path, time law, start positions):
    # published once at t = 0 to the active controller that takes a Cartesian
    # trajectory (as a CartesianTrajectory) or else a joint trajectory (planned by
    # closed-loop inverse kinematics, as a JointTrajectory); absent = none.
    task: TaskSpaceMotion | None = None
    # Target poses of the end effector through a learned IK network (an ONNX file of
    # python -m armando_drake.learn ik) to the first active position controller
    # (armando_drake/task/learned_ik.py); absent = none.
    learned_ik: LearnedIkConfig | None = None
    # Live jog from the Meshcat page: joint sliders, Cartesian jog buttons and keys,
    # a gamepad, home; publishing on a position controller's command topic
    # (armando_drake/teleop/config.py); absent = none.
    jog: JogConfig | None = None
    # Live cmd_vel from the Meshcat page's keys, as teleop_twist_keyboard's (u i o / j k l
    # / m , . and q z w x e c), to a mobile base's drive (armando_drake/teleop/config.py,
    # twist_jog.py); absent = none.
    twist_jog: TwistJogConfig | None = None
    # Camera sensors of the description.
    camera: CameraSettings = dc.field(default_factory=CameraSettings)
    # Cameras on links of the robot, with the fields of a <gazebo><sensor>
    # block (armando_drake/vision/cameras.py); added even when camera.enabled is off
    # (which switches the description's cameras), rendered and shown as camera: says.
    cameras: list[ScenarioCamera] = dc.field(default_factory=list)
    # OpenCV detectors on the cameras (blob, ArUco); absent = none.
    vision: VisionConfig | None = None
    # Point clouds from a camera's depth and the pipeline run on them (clusters,
    # planes); absent = none. See armando_drake/perception/config.py.
    perception: PerceptionConfig | None = None
    # Joint-state logging.
    logging: LoggingConfig = dc.field(default_factory=LoggingConfig)
    # Run length.
    simulation: SimulationConfig = dc.field(default_factory=SimulationConfig)
    # Drake's simulator settings, applied with ApplySimulatorConfig:
    # target_realtime_rate is the pacing (simulated over wall-clock time; 1 =
    # real time, 0 = as fast as possible); the integrator settings matter only
    # for continuous state, which a world with a discrete plant does not have.
    simulator_config: SimulatorConfig = dc.field(
        default_factory=lambda: SimulatorConfig(target_realtime_rate=1.0)
    )
    # Meshcat visualization (Drake's VisualizationConfig).
    visualization: VisualizationConfig = dc.field(default_factory=VisualizationConfig)
    # The running world on DDS as a ROS 2 robot, and on Foxglove.
    ros2: Ros2Config = dc.field(default_factory=Ros2Config)

    def check(self) -> None:
        """The rules between sections: an object listed twice, a crawling pacing, a
        rate above the plant's, a sequence that never ends. (Each field's own rules
        are beside it; those that need the robot and the controller YAML are
        :func:`~armando_drake.simulation.validation.check_against_world`.)"""
        self._check_robots()
        names = set()
        for index, obj in enumerate(self.objects):
            if obj.name in names:
                raise Refusal(f"objects.{index}", f": object {obj.name!r} is listed twice")
            names.add(obj.name)
        if self.navigation is not None and _driven(self, self.navigation).twist is not None:
            raise Refusal("navigation", ": both it and twist would publish cmd_vel; keep one")
        pacing = self.simulator_config.target_realtime_rate
        if 0 < pacing < MIN_REALTIME_RATE:
            raise Refusal(
                "simulator_config.target_realtime_rate",
                f"={pacing!r} is below {MIN_REALTIME_RATE:g} (0 = as fast as possible): a "
                "simulated second would take hours",
            )
        plant_rate = 1.0 / self.plant_config.time_step
        rates = [("ros2.clock_rate", self.ros2.clock_rate)]
        rates += [(f"cameras.{i}.update_rate", c.update_rate) for i, c in enumerate(self.cameras)]
        for key, rate in rates:
            if rate > plant_rate * (1 + 1e-9):
                raise Refusal(key, f"={rate!r} Hz is above the plant's rate {plant_rate:g} Hz")
        if self.simulation.duration <= 0:
            duration = default_duration(self)
            if duration > MAX_DEFAULT_DURATION:
                raise Refusal(
                    "sequencer" if _has_sequencer(self) else "task",
                    f": one pass lasts {duration:.4g} s, over {MAX_DEFAULT_DURATION:g} s; give "
                    "simulation.duration (or --duration) to run that long",
                )

    def _check_robots(self) -> None:
        """robots: without the one robot's keys (nor other robots beside the one robot of
        those keys); names that are names, distinct namespaces; each mount on a robot
        listed before; each section's robot listed."""
        robots = self.robots
        given = [key for key in ROBOT_KEYS if getattr(self, key) != getattr(Scenario(), key)]
        one = self.__dict__.get("_sources", ScenarioSources()).one_robot
        if one and list(robots) != [one]:
            given = given or [ROBOT_KEYS[0]]
        if robots and given:
            raise Refusal(
                given[0], ": a key of the one robot, beside robots: (give it in each robot's entry)"
            )
        if len(robots) > MAX_ROBOTS:
            raise Refusal("robots", f": {len(robots)} robots, over the limit of {MAX_ROBOTS}")
        names, spaces, depths = [], [], {}
        for name, entry in robots.items():
            if len(name) > MAX_NAME_LENGTH:
                raise Refusal(
                    f"robots.{name[:20]}...",
                    f": a name of {len(name)} characters, over {MAX_NAME_LENGTH}",
                )
            if not _ROBOT_NAME.fullmatch(name):
                raise Refusal(
                    f"robots.{name}", ": give a name (a letter or _, then letters, digits, _)"
                )
            if entry.space(name) in spaces:
                given = entry.namespace or entry.space(name)
                raise Refusal(f"robots.{name}.namespace", f"={given!r} is another robot's too")
            other = entry.parent.split("::")[0]
            if entry.parent and other not in names:
                raise Refusal(
                    f"robots.{name}.parent",
                    f"={entry.parent!r}: no robot {other!r} is listed before "
                    f"{name!r} (listed: {', '.join(names) or 'none'})",
                )
            depths[name] = depths[other] + 1 if entry.parent else 0
            if depths[name] >= MAX_MOUNT_DEPTH:
                raise Refusal(
                    f"robots.{name}.parent",
                    f"={entry.parent!r}: a mount chain of {depths[name] + 1} robots, over "
                    f"the limit of {MAX_MOUNT_DEPTH}",
                )
            names.append(name)
            spaces.append(entry.space(name))
        for key in ROBOT_SECTIONS:
            section = getattr(self, key)
            target = getattr(section, "robot", "")
            if names and target and target not in names:
                raise Refusal(
                    f"{key}.robot", f"={target!r}: no such robot (listed: {', '.join(names)})"
                )


def _driven(scenario: Scenario, section) -> RobotEntry:
    """The entry of the robot a section of :data:`ROBOT_SECTIONS` acts on: the one it
    names, else the first."""
    named = scenario.robots.get(getattr(section, "robot", ""))
    return named or next(iter(scenario.robots.values()), RobotEntry())


def _has_sequencer(scenario: Scenario) -> bool:
    """Whether the one robot of the top-level keys has a sequencer."""
    one = scenario.robots.get(scenario.__dict__.get("_sources", ScenarioSources()).one_robot)
    return one is not None and one.sequencer is not None


# The sections of a scenario that act on one robot of robots:, its `robot` field naming
# it (the first by default).
ROBOT_SECTIONS = ("task", "learned_ik", "jog", "navigation", "twist_jog", "vision", "perception")


def expand_robots(scenario: Scenario) -> Scenario:
    """``scenario`` with its robots as the map ``robots: {name: entry}``, as
    :func:`load_scenario` returns it: the one robot of its top-level keys (robot,
    actuators, controllers, sequencer, twist) becomes the entry :data:`ONE_ROBOT` in the
    root namespace (its ports, topics and output folder as named without robots:), those
    keys back to their defaults; a scenario with robots: as it is (its top-level keys, if
    any, refused by :meth:`Scenario.check`). A new scenario (``scenario`` is not changed),
    its sources kept (:attr:`ScenarioSources.one_robot` names the expanded robot)."""
    robots, sources = scenario.robots, sources_of(scenario)
    if robots or sources.one_robot:  # a map already
        return scenario
    entry = RobotEntry(namespace="/", **{key: getattr(scenario, key) for key in ROBOT_KEYS})
    defaults = Scenario()
    expanded = dc.replace(
        scenario,
        robots={ONE_ROBOT: entry},
        **{key: getattr(defaults, key) for key in ROBOT_KEYS},
    )
    expanded.__dict__["_sources"] = dc.replace(sources, one_robot=ONE_ROBOT)
    return expanded


@dc.dataclass(frozen=True)
class ScenarioRobot:
    """One robot of a scenario's robots map as the world builder reads it: its entry, the
    sections that act on it and where its keys came from (no copy of the scenario)."""

    name: str  # its name in the map
    index: int  # its place in the map
    entry: RobotEntry
    # The sections of ROBOT_SECTIONS that act on it, by key (None: not on it, or absent).
    sections: dict[str, Any]
    # Where its keys (sequencer.period, actuators.kp, ...) came from: the scenario's
    # own sources for the one robot of the top-level keys, else its entry of robots:.
    sources: "ScenarioSources"
    top_level: bool = False  # whether it is the one robot of the top-level keys

    @property
    def namespace(self) -> str:
        """ "/left" ("" in the root namespace)."""
        return self.entry.space(self.name)

    @property
    def folder(self) -> str:
        """Its output subfolder ("" in the root namespace)."""
        return self.namespace.strip("/")

    @property
    def model_name(self) -> str | None:
        """Its model instance's name: its own, or None (the description's) in the root
        namespace."""
        return self.name if self.namespace else None

    @property
    def robot(self) -> RobotConfig:
        """Its description settings, with its prefix as the ``prefix`` xacro argument."""
        robot = self.entry.robot
        if not self.entry.prefix:
            return robot
        return dc.replace(robot, xacro_args={**robot.xacro_args, "prefix": self.entry.prefix})

    def section(self, key: str):
        """Its section ``key`` of :data:`ROBOT_SECTIONS`, or None."""
        return self.sections.get(key)

    def where(self, key: str) -> str:
        """``"<origin>: "`` of its ``key`` (``sequencer``, ``controllers.update_rate``)."""
        return f"{self.sources.of(key)}: "


def scenario_robots(scenario: Scenario) -> dict[str, ScenarioRobot]:
    """The robots of ``scenario``'s robots map, by name, in order, each with the sections
    that act on it (the one naming it, else the first)."""
    sources = sources_of(scenario)
    origin = sources.of("robots")  # the file, or the --set that gave them
    robots = {}
    for index, (name, entry) in enumerate(scenario.robots.items()):
        sections = {}
        for key in ROBOT_SECTIONS:
            section = getattr(scenario, key)
            target = getattr(section, "robot", "")
            named = target in scenario.robots
            sections[key] = section if (target == name if named else index == 0) else None
        top_level = name == sources.one_robot
        robots[name] = ScenarioRobot(
            name=name,
            index=index,
            entry=entry,
            sections=sections,
            sources=sources if top_level else ScenarioSources(f"{origin}: robots.{index} ({name})"),
            top_level=top_level,
        )
    return robots


def robot_duration(robot: ScenarioRobot) -> float:
    """[s] one pass of the robot's command sequence; the task's motion and 0.5 s of
    holding without one; the learned IK's targets, a period each, without either; the
    twist sequence and 1 s of stopping; the navigation's start delay and 30 s a goal
    (four for an exploration); 2 s without any."""
    entry, task = robot.entry, robot.section("task")
    learned, navigation = robot.section("learned_ik"), robot.section("navigation")
    if entry.sequencer is not None:
        return one_pass(entry.sequencer)
    if task is not None:
        return task.duration + 0.5
    if learned is not None:
        return learned.start_delay + max(1, len(learned.targets)) * learned.period
    if navigation is not None:  # a bound: give simulation.duration
        goals = len(navigation.goals) or EXPLORATION_GOALS * navigation.explore
        return navigation.start_delay + NAVIGATION_TIME_PER_GOAL * goals
    return 2.0 if entry.twist is None else entry.twist.one_pass() + 1.0


def default_duration(scenario: Scenario) -> float:
    """[s] the longest of the robots' :func:`robot_duration`."""
    return max(robot_duration(robot) for robot in scenario_robots(scenario).values())


def resolve_scenario_path(name: str | os.PathLike) -> Path:
    """A scenario file: a path, or the name of a file in ``diagrams/``."""
    path = Path(name)
    try:
        if path.is_file() or (path.exists() and path.suffix in (".yaml", ".yml")):
            return path  # a FIFO, a device or a directory: the reader says which
        for candidate in (DIAGRAMS_DIR / path, DIAGRAMS_DIR / f"{path}.yaml"):
            if candidate.is_file():
                return candidate
    except OSError as error:  # a name too long for the file system, ...
        raise ScenarioError(f"{_shortened(str(name))}: {error.strerror}") from None
    available = ", ".join(sorted(p.stem for p in DIAGRAMS_DIR.glob("*.yaml")))
    raise ScenarioError(f"{name}: scenario file not found (files in diagrams/: {available})")


def _union_members(schema) -> tuple[type, ...]:
    """The dataclass members of a Union (or Optional Union) field type; () otherwise."""
    if typing.get_origin(schema) not in (typing.Union, types.UnionType):
        return ()
    return tuple(t for t in typing.get_args(schema) if dc.is_dataclass(t))


def _keep_variants(data, current) -> None:
    """Tags each untagged mapping of ``data`` (a ``yaml_load`` result) that sets a
    Union field of ``current`` with the variant ``current`` holds there, so an
    override without a tag merges into that variant instead of starting over from
    the Union's first one (Drake's rule for an untagged mapping)."""
    if not (isinstance(data, dict) and dc.is_dataclass(current)):
        return
    hints = typing.get_type_hints(type(current))
    for name, value in data.items():
        if name not in hints or not hasattr(current, name):
            continue
        old = getattr(current, name)
        # Only a Union of several dataclasses is tagged (an Optional of one is not).
        tagged = len(_union_members(hints[name])) > 1
        if tagged and isinstance(value, dict) and "_tag" not in value:
            if dc.is_dataclass(old):
                value["_tag"] = "!" + type(old).__name__
        _keep_variants(value, old)


# Drake's message (``yaml_load_typed``, pydrake 1.51) for a tag that is none of a Union
# field's members: "The yaml type tag value 'Sine' did not match any of the allowed type
# options for 'sequencer' ((<class '...PositionTargets'>, ...))".
_UNKNOWN_TAG = re.compile(
    r"The yaml type tag value '(?P<tag>\w+)' did not match any of the allowed type "
    r"options for '(?P<field>\w+)'(?: \(+(?P<options>[^()]*)\)+)?"
)


def parse_unknown_tag(text: str) -> tuple[str, str, str] | None:
    """(the tag, the field, the options as Drake lists them) of Drake's message for an
    unknown tag; None for any other message. The one place that reads Drake's wording
    (tests/simulation/test_scenario.py checks it against the loader's message)."""
    match = _UNKNOWN_TAG.search(" ".join(text.split()))
    if match is None:
        return None
    return match["tag"], match["field"], match["options"] or ""


def _one_line(error: Exception, current) -> str:
    """Drake's message of a YAML error as one line, with a bad tag's choices spelled
    as tags."""
    text = " ".join(str(error).split())
    unknown = parse_unknown_tag(text)
    if unknown is not None:
        tag, field, listed = unknown
        # A Union inside a list: the choices are Drake's list of options.
        choices = ", ".join(_tag_choices(type(current), field)) or listed
        where = "" if field == "_" else f"{field}: "
        text = f"{where}unknown tag !{tag} (choose {choices})"
    return text


def _tag_choices(schema, field: str, seen=()) -> list[str]:
    """The tags of the Union field named ``field`` in ``schema`` or a dataclass nested
    in it (through lists, dicts and Unions); [] when there is none."""
    if not dc.is_dataclass(schema) or schema in seen:
        return []
    for name, hint in typing.get_type_hints(schema).items():
        members = _union_members(hint)
        if name == field and members:
            return [f"!{t.__name__}" for t in members]
        nested = [hint, *typing.get_args(hint)]
        for inner in nested:
            for candidate in (inner, *typing.get_args(inner)):
                choices = _tag_choices(candidate, field, (*seen, schema))
                if choices:
                    return choices
    return []


def _check_lists(data, schema, prefix: str = "") -> None:
    """Fails where ``data`` (a ``yaml_load`` mapping for the dataclass ``schema``) gives a
    scalar for a list or a mapping field: Drake's loader would take ``""`` as ``[]``, and
    fails on others with Python's own words (``'float' object is not iterable``)."""
    if not (isinstance(data, dict) and dc.is_dataclass(schema)):
        return
    hints = typing.get_type_hints(schema)
    for name, value in data.items():
        hint = hints.get(name)
        if hint is None:
            continue
        key = f"{prefix}{name}"
        if typing.get_origin(hint) is list and not isinstance(value, list):
            raise ScenarioError(f"{key}: expected a list, got {value!r}")
        if typing.get_origin(hint) is dict and not isinstance(value, dict):
            raise ScenarioError(f"{key}: expected a mapping, got {value!r}")
        if typing.get_origin(hint) in (list, dict):
            inner = typing.get_args(hint)[-1] if typing.get_args(hint) else None
            items = value if isinstance(value, list) else list(value.values())
            for index, item in enumerate(items):
                if dc.is_dataclass(inner) and not isinstance(item, dict):
                    raise ScenarioError(f"{key}.{index}: expected a mapping, got {item!r}")
                if dc.is_dataclass(inner):
                    _check_lists(item, inner, f"{key}.{index}.")
            continue
        members = [m for m in [hint, *typing.get_args(hint)] if dc.is_dataclass(m)]
        if members and value is None and type(None) not in typing.get_args(hint):
            raise ScenarioError(f"{key}: expected a mapping, got null (a section cannot be unset)")
        if members and value is not None and not isinstance(value, dict):
            raise ScenarioError(f"{key}: expected a mapping, got {value!r}")
        if isinstance(value, dict) and len(members) > 1:  # a tagged union: the tag's member
            tag = str(value.get("_tag", "")).lstrip("!")
            members = [m for m in members if m.__name__ == tag] or members
        for member in members:
            _check_lists(value, member, f"{key}.")


def _one_or_many(data) -> None:
    """The fields that take one value or a list, as lists: ``controllers.config: a.yaml``
    is ``[a.yaml]``, ``""`` (or null) none (in each of ``robots:`` too)."""
    robots = data.get("robots") if isinstance(data, dict) else None
    for entry in robots.values() if isinstance(robots, dict) else []:
        _one_or_many(entry)
    controllers = data.get("controllers") if isinstance(data, dict) else None
    if isinstance(controllers, dict) and "config" in controllers:
        value = controllers["config"]
        if value is None or value == "":
            controllers["config"] = []
        elif isinstance(value, str):
            controllers["config"] = [value]


def _robots_as_map(data) -> bool:
    """A ``robots:`` list of a ``yaml_load`` mapping (entries with a ``name:`` each) as the
    map of those entries by name, in place; whether it was a list (which then replaces
    every robot, as a list does). Raises ValueError naming the entry for a name missing,
    not a name, or given twice."""
    robots = data.get("robots") if isinstance(data, dict) else None
    if not isinstance(robots, list):
        return False
    by_name = {}
    for index, entry in enumerate(robots):
        if not isinstance(entry, dict):
            raise ValueError(f"robots.{index}: expected a mapping, got {entry!r}")
        entry = dict(entry)
        name = entry.pop("name", "")
        if not isinstance(name, str) or not _ROBOT_NAME.fullmatch(name):
            raise ValueError(
                f"robots.{index}.name={name!r}: give a name (a letter or _, then letters, "
                "digits, _)"
            )
        if name in by_name:
            raise ValueError(f"robots.{index}.name={name!r} is listed twice")
        by_name[name] = entry
    data["robots"] = by_name
    return True


def _in_given_order(scenario: Scenario, data, before: Iterable[str] = ()) -> Scenario:
    """``scenario`` with its robots in the order ``before`` (the robots it had), then
    ``data`` (the ``yaml_load`` mapping it was read from) lists them: the loader
    passes a mapping through a dump that sorts its keys, and a robot's order matters
    (the first is the sections' default, a mount names a robot listed before)."""
    robots = data.get("robots") if isinstance(data, dict) else None
    order = list(dict.fromkeys([*before, *(robots if isinstance(robots, dict) else [])]))
    listed = {name: scenario.robots[name] for name in order if name in scenario.robots}
    scenario.robots = {**listed, **scenario.robots}
    return scenario


def dump_scenario(scenario: Scenario) -> str:
    """``scenario`` as YAML that :func:`load_scenario` reads back to an equal scenario,
    its robots as a ``robots:`` list (a mapping's dump would sort them by name), or the
    one robot of the top-level keys as those keys (the form it was given in)."""
    one = scenario.__dict__.get("_sources", ScenarioSources()).one_robot
    entry = scenario.robots.get(one)
    plain = RobotEntry(namespace="/", **{key: getattr(entry, key, None) for key in ROBOT_KEYS})
    if one and list(scenario.robots) == [one] and entry == plain:  # only the keys' fields
        scenario = dc.replace(scenario, robots={}, **{k: getattr(entry, k) for k in ROBOT_KEYS})
    text = yaml_dump_typed(dc.replace(scenario, robots={}))
    entries = "".join(
        f"  - name: {name}\n" + textwrap.indent(yaml_dump_typed(entry), "    ")
        for name, entry in scenario.robots.items()
    )
    return text.replace("robots: {}\n", f"robots:\n{entries}" if entries else "robots: []\n")


def _keep_robot_variants(data, current: Scenario) -> None:
    """:func:`_keep_variants` for each entry of ``robots:`` that ``current`` has too."""
    robots = data.get("robots")
    if isinstance(robots, dict):
        for name, entry in robots.items():
            if name in current.robots:
                _keep_variants(entry, current.robots[name])


def _into_one_robot(data: dict, scenario: Scenario) -> None:
    """The one-robot keys of an override (``actuators: {kp: 4}``) moved, in place, into
    the entry of ``scenario``'s one robot of the top-level keys (:func:`expand_robots`),
    which they set; left as given beside other robots (which refuse them)."""
    one = scenario.__dict__.get("_sources", ScenarioSources()).one_robot
    given = {key: data[key] for key in ROBOT_KEYS if key in data}
    robots = data.get("robots", {})
    if not (given and one in scenario.robots and isinstance(robots, dict)):
        return
    entry = robots.get(one, {})
    if set(robots) - {one} or not isinstance(entry, dict):
        return
    for key in given:
        del data[key]
    data["robots"] = {**robots, one: {**entry, **given}}


def _merge(scenario: Scenario, text: str) -> Scenario:
    """``scenario`` with the YAML ``text`` merged over it (see :func:`_keep_variants`)."""
    data = yaml_load(data=text)
    if data is None:
        raise ScenarioError(
            "nothing to set (null); give a YAML mapping, e.g. 'actuators: {kp: 4.0}'"
        )
    if not isinstance(data, dict):
        raise ScenarioError(f"expected a YAML mapping, got {data!r}")
    sources = scenario.__dict__.get("_sources")
    if _robots_as_map(data):  # a list replaces the robots
        scenario = dc.replace(scenario, robots={})
    _into_one_robot(data, scenario)
    _one_or_many(data)
    _check_lists(data, Scenario)
    _keep_variants(data, scenario)
    _keep_robot_variants(data, scenario)
    merged = yaml_load_typed(data=yaml_dump(data), defaults=scenario)
    merged = _in_given_order(merged, data, before=scenario.robots)
    if sources is not None:
        merged.__dict__["_sources"] = sources
    return merged


@dc.dataclass
class ScenarioSources:
    """Where the values of a scenario came from, for error messages: a file, and the
    override (``--set '...'``) or command-line option that last set each key."""

    # The scenario file, or "<defaults>".
    file: str = "<defaults>"
    # Dotted key ("actuators.kp", "objects") -> its origin ("--set 'actuators: {kp: -1}'").
    keys: dict[str, str] = dc.field(default_factory=dict)
    # The name the one robot of the top-level keys got in the robots map
    # (expand_robots); "" before the expansion, or for a scenario with robots:.
    one_robot: str = ""

    def of(self, key: str) -> str:
        """The origin of the dotted ``key``: the override that set it or a key above
        it; else the latest that set a key below it; else the file."""
        parts = key.split(".")
        for end in range(len(parts), 0, -1):
            origin = self.keys.get(".".join(parts[:end]))
            if origin is not None:
                return origin
        below = [origin for k, origin in self.keys.items() if k.startswith(f"{key}.")]
        return below[-1] if below else self.file

    def note(self, key: str, origin: str) -> None:
        """Records that ``origin`` set ``key`` (and everything below it), as the latest."""
        self.keys = {k: v for k, v in self.keys.items() if k != key and not k.startswith(f"{key}.")}
        self.keys[key] = origin


def sources_of(scenario: Scenario) -> ScenarioSources:
    """The :class:`ScenarioSources` kept with ``scenario`` (made empty on first use)."""
    sources = scenario.__dict__.get("_sources")
    if sources is None:
        sources = scenario.__dict__["_sources"] = ScenarioSources()
    return sources


def _leaf_keys(data, prefix: str = "") -> list[str]:
    """The dotted keys of the leaves of a ``yaml_load`` mapping (a tagged mapping, a
    list or a scalar is a leaf: it replaces what was there)."""
    if not isinstance(data, dict) or (prefix and "_tag" in data):
        return [prefix] if prefix else []
    keys = []
    for name, value in data.items():
        if name == "_tag":
            continue
        keys += _leaf_keys(value, f"{prefix}.{name}" if prefix else str(name))
    return keys


def merge_overrides(scenario: Scenario, overrides, label: str = "--set") -> Scenario:
    """``scenario`` with each YAML string of ``overrides`` merged over it in turn.

    An untagged mapping keeps the variant of a Union field (see the module's
    docstring); a tag chooses one. The keys each override sets are noted, with
    it, in :func:`sources_of` the result.
    """
    sources = sources_of(scenario)
    for override in [overrides] if isinstance(overrides, str) else overrides:
        if not override.strip():
            raise ScenarioError(
                f"{label} {override!r}: nothing to set; give a YAML mapping, e.g. "
                "'actuators: {kp: 4.0}'"
            )
        check_yaml_expansion(override, f"{label} {_shortened(override)!r}")
        _refuse_duplicate_keys(override, f"{label} {override!r}")
        try:
            scenario = _merge(scenario, override)
            keys = _leaf_keys(yaml_load(data=override))
        except Exception as error:  # yaml_load_typed raises RuntimeError, KeyError, ...
            raise ScenarioError(f"{label} {override!r}: {_one_line(error, scenario)}") from None
        one = f"robots.{sources.one_robot}." if sources.one_robot else ""
        for key in keys:  # the one robot's keys also as its file names them
            for noted in dict.fromkeys([key, key.removeprefix(one) if one else key]):
                sources.note(noted, f"{label} {override!r}")
    scenario.__dict__["_sources"] = sources
    return scenario


def _refuse_duplicate_keys(text: str, where: str) -> None:
    """A key given twice in one mapping is an error (the loader would keep the last);
    ``where`` is the file (the message gives ``file:line``) or the override."""

    found = duplicate_key(text)
    if found is not None:
        line, problem = found
        at = (
            f":{line}"
            if "\n" in text.strip() or not where.startswith(("--set", "override"))
            else ""
        )
        raise ScenarioError(f"{where}{at}: {problem}")


def load_scenario(
    filename: str | os.PathLike | None = None, overrides: str | None = None
) -> Scenario:
    """Reads a scenario file (a path or a name in ``diagrams/``) and an override string;
    the scenario with its robots as a map (:func:`expand_robots`): the one robot of the
    top-level keys is the entry :data:`ONE_ROBOT`, and later overrides of those keys
    (:func:`merge_overrides`) set that entry."""
    scenario = Scenario()
    source = "<defaults>"
    try:
        if filename is not None:
            path = resolve_scenario_path(filename)
            source = str(path)
            _refuse_duplicate_keys(read_yaml_file(path, what="the scenario"), source)
            data = yaml_load(filename=str(path))
            if isinstance(data, dict) and (
                isinstance(data.get("controllers"), dict) or "robots" in data
            ):
                _robots_as_map(data)
                _one_or_many(data)
                scenario = yaml_load_typed(data=yaml_dump(data), defaults=scenario)
                scenario = _in_given_order(scenario, data)
            else:
                scenario = yaml_load_typed(filename=str(path), defaults=scenario)
            _anchor_file_paths(scenario, path)
        if overrides:
            scenario = merge_overrides(scenario, overrides, label="override")
        scenario = expand_robots(scenario)
    except (ScenarioError, FileInputError):
        raise
    except OSError as error:
        raise ScenarioError(f"{filename}: cannot read the scenario: {error.strerror}") from None
    except UnicodeDecodeError:
        raise ScenarioError(f"{source}: not a text (UTF-8) YAML file") from None
    except Exception as error:  # yaml_load_typed raises RuntimeError, KeyError, ...
        raise ScenarioError(f"{source}: {_one_line(error, scenario)}") from None
    if source != "<defaults>":
        sources_of(scenario).file = source
    return scenario


def _anchored(value: str, scenario_file: Path) -> str:
    """A relative path a scenario file names: as given where it exists from the working
    folder (as before), else from the scenario file's folder, else, for a scenario of
    ``diagrams/``, from the project's root (where ``models/`` is), so a scenario runs
    from any folder."""
    if not value or "://" in value or Path(value).is_absolute() or Path(value).exists():
        return value
    bases = [scenario_file.parent]
    if scenario_file.resolve().parent == DIAGRAMS_DIR.resolve():
        bases.append(DIAGRAMS_DIR.parent)
    for base in bases:
        if (base / value).exists():
            return str(base / value)
    return value


def _anchor_file_paths(scenario: Scenario, scenario_file: Path) -> None:
    """The relative file paths of a scenario file (its controller YAML files, the learned
    IK network), see :func:`_anchored`."""
    for controllers in [scenario.controllers] + [r.controllers for r in scenario.robots.values()]:
        controllers.config = [_anchored(value, scenario_file) for value in controllers.config]
    if scenario.learned_ik is not None:
        scenario.learned_ik.network = _anchored(scenario.learned_ik.network, scenario_file)


def note_option(scenario, keys: Iterable[str], option: str) -> None:
    """Records that the command-line ``option`` set the scenario's dotted ``keys``, for
    the messages of :mod:`armando_drake.simulation.validation`."""

    for key in keys:
        sources_of(scenario).note(key, option)


def apply_scenario_arguments(scenario, args):
    """The scenario with ``--set``, ``--description``, ``--package-path`` and
    ``--xacro-arg`` applied."""

    scenario = merge_overrides(scenario, args.set)
    if args.description is not None:
        only_robot(scenario, "--description").robot.description = args.description
        note_option(scenario, ("robot.description",), "--description")
    for entry in scenario.robots.values():  # a search path: every robot's
        entry.robot.package_paths += args.package_path
    if getattr(args, "xacro_arg", None):
        robot = only_robot(scenario, "--xacro-arg").robot
        robot.xacro_args = {**robot.xacro_args, **parse_xacro_args(args.xacro_arg)}
        note_option(scenario, ("robot.xacro_args",), "--xacro-arg")
    return scenario


def only_robot(scenario: Scenario, option: str) -> RobotEntry:
    """The entry of ``scenario``'s only robot, which the command-line ``option`` sets;
    a :class:`ScenarioError` naming the option for a scenario of several robots."""
    if len(scenario.robots) != 1:
        names = ", ".join(scenario.robots) or "none"
        raise ScenarioError(
            f"{option}: the scenario has {len(scenario.robots)} robots ({names}) and the "
            "option sets the only one; give it to one robot with --set 'robots: {NAME: ...}'"
        )
    return next(iter(scenario.robots.values()))


def _shortened(text: str, limit: int = 200) -> str:
    """``text`` cut to ``limit`` characters for a message (an override may be huge)."""
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def start_positions(robot: ScenarioRobot) -> list[tuple[list[float], str, str]]:
    """The joints' start positions the task and the jog acting on ``robot`` give, with
    their origins."""
    starts = []
    task, jog = robot.section("task"), robot.section("jog")
    if task is not None and task.start_positions:
        key = "task.start_positions"
        starts.append((task.start_positions, robot.where(key), key))
    if jog is not None and jog.home_positions:
        key = "jog.home_positions"
        starts.append((jog.home_positions, robot.where(key), key))
    return starts
