"""The simulated hardware interface: what gz_ros2_control does for Gazebo.

Every actuated joint gets a Drake joint actuator with the URDF effort limit,
driven through the command interface the description gives it:

- ``position``: PD gains (``kp`` [N m/rad], ``kd`` [N m s/rad]); Drake integrates
  the PD law implicitly inside its discrete solver, so stiff position tracking
  is stable at millisecond steps (gz_ros2_control instead turns a position
  command into a velocity command that sags under gravity). Gravity is fed
  forward at the commanded position (:func:`ConnectHardwareInterface`).
- ``velocity``: a damping-only servo, kp = 0 and kd = ``kv`` [N m s/rad], that
  drives the joint at the commanded velocity (the desired velocity of Drake's
  PD actuator; implicit, so stable at any gain).
- ``effort``: no gains; the commanded torque [N m], clamped to the effort limit,
  goes to the plant's actuation input.

The interface comes from ``<ros2_control>`` (each joint's
``<command_interface name=..>``; with several, position before velocity before
effort), else from ROS 1 ``<transmission>`` blocks
(``hardware_interface/PositionJointInterface | VelocityJointInterface |
EffortJointInterface``, position when absent), else every non-fixed joint is a
position joint. ``min``/``max`` interface parameters merge with the URDF
limits, the tighter winning; the position state interface's ``initial_value``
(0 when absent, clamped into the limits) is the joint's initial position.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Joint, JointActuator, PdControllerGains
from pydrake.systems.controllers import InverseDynamics
from pydrake.systems.framework import Diagram, DiagramBuilder, OutputPort
from pydrake.systems.primitives import (
    Adder,
    AffineSystem,
    MatrixGain,
    Multiplexer,
    ZeroOrderHold,
)

from armando_drake.control.velocity_limits import AddVelocityLimiter
from armando_drake.description.loader import LoadedRobot
from armando_drake.description.ros2_control import (
    ComponentInfo,
    initial_position,
    merge_limits,
)
from armando_drake.description.urdf import JointInfo

_log = logging.getLogger("armando_drake.control.hardware")


@dataclass
class HardwareJoint:
    """One actuated joint of the hardware interface."""

    name: str
    lower: float  # [rad] command limit: URDF limit merged with the interface min
    upper: float  # [rad] command limit: URDF limit merged with the interface max
    effort: float  # [N m] effort limit of the actuator (inf: none)
    initial_position: float  # [rad]
    command_interface: str = "position"  # position | velocity | effort
    velocity: float = np.inf  # [rad/s] URDF velocity limit (inf: none)
    # Whether the URDF joint is continuous (upstream's trajectory controller wraps its
    # position errors into [-pi, pi]).
    continuous: bool = False
    # The gains its actuator uses: [N m/rad] kp and [N m s/rad] kd of a position joint,
    # kp 0 and the velocity gain kv of a velocity joint; 0, 0 on an effort joint.
    kp: float = 0.0
    kd: float = 0.0
    # Where they came from: "scenario", "controller YAML", "derived", "Armando's servos".
    gains_origin: str = ""


@dataclass
class HardwareInterface:
    """The actuated joints, in actuator order, and where they are in the plant."""

    name: str  # the ros2_control block's name, or the robot's
    source: str  # "ros2_control", "transmission" or "non-fixed joints"
    joints: list[HardwareJoint]
    # Index of each joint's position in the model instance's state vector [q; v].
    position_index: list[int]
    # Index of each joint's velocity in the model instance's state vector [q; v].
    velocity_index: list[int]
    num_model_states: int  # size of the model instance's state vector
    # A floating base's rows in the model instance's state vector: its quaternion and
    # position (qw qx qy qz x y z) and its spatial velocity in the world (wx wy wz vx vy
    # vz); empty for a welded robot.
    base_position_index: list[int] = field(default_factory=list)
    base_velocity_index: list[int] = field(default_factory=list)

    @property
    def joint_names(self) -> list[str]:
        return [joint.name for joint in self.joints]

    def find(self, names: list[str]) -> list[int]:
        """Indices into :attr:`joints` of ``names``."""
        index = {name: i for i, name in enumerate(self.joint_names)}
        return [index[name] for name in names]

    def interfaces(self) -> list[str]:
        """Each joint's command interface, hardware order."""
        return [joint.command_interface for joint in self.joints]


INTERFACE_PRIORITY = ("position", "velocity", "effort")


def command_interfaces(robot: LoadedRobot, *, warn: bool = True) -> tuple[str, str, dict[str, str]]:
    """(interface name, source, {joint: command interface}) of the joints to actuate,
    in the description's order: of the command interfaces the description gives a
    joint (:attr:`LoadedRobot.command_interfaces`, read from ``<ros2_control>`` or
    ROS 1 ``<transmission>`` blocks), the first of position, velocity, effort. A joint
    with none of them is left out (with a warning, when ``warn``)."""
    result = {}
    for joint, given in robot.command_interfaces.items():
        chosen = next((i for i in INTERFACE_PRIORITY if i in given), None)
        if chosen is None:
            if not warn:
                continue
            _log.warning(
                "%s: joint '%s' has command interfaces %s; the simulation drives %s only: "
                "not actuated",
                robot.source,
                joint,
                given,
                ", ".join(INTERFACE_PRIORITY),
            )
            continue
        result[joint] = chosen
    source = robot.actuation_source
    name = robot.ros2_control[0].name if source == "ros2_control" else robot.name
    return name, source, result


def _components_by_joint(robot: LoadedRobot) -> dict[str, ComponentInfo]:
    """Each ``<ros2_control>`` joint component of the description, by joint name."""
    components = {}
    for block in robot.ros2_control:
        for component in block.joints:
            components[component.name] = component
    return components


def _limits_and_start(
    robot: LoadedRobot,
    info: JointInfo,
    joint_name: str,
    component: ComponentInfo | None,
    kind: str,
) -> tuple[float, float, float]:
    """(lower, upper, initial position) [rad] of a joint: the URDF limits merged with
    the interface's, and the initial value clamped into them (warning when moved)."""
    command = component.command_interface("position") if component else None
    if kind != "position":
        command = None
    state = component.state_interface("position") if component else None
    lower, upper = merge_limits(info.lower, info.upper, command)
    q0 = initial_position(lower, upper, state)
    given = state.initial_value if state is not None else None
    if given is not None and given != q0:
        _log.warning(
            "%s: joint '%s': initial_value %g is outside its limits [%g, %g]; it starts at %g",
            robot.source,
            joint_name,
            given,
            lower,
            upper,
            q0,
        )
    return lower, upper, q0


def _joint_actuator(
    plant: MultibodyPlant, joint: Joint, joint_name: str, effort: float
) -> JointActuator:
    """The joint's actuator: the one the parser made, else a new one of ``effort`` [N m]."""
    # Actuators the parser made (e.g. from a <transmission>); the per-instance
    # listing is empty before Finalize(), so look through all of them.
    existing = [
        plant.get_joint_actuator(index)
        for index in plant.GetJointActuatorIndices()
        if plant.get_joint_actuator(index).joint().index() == joint.index()
    ]
    return (
        existing[0] if existing else plant.AddJointActuator(f"{joint_name}_actuator", joint, effort)
    )


def _set_gains(
    actuator: JointActuator,
    joint_name: str,
    interface: str,
    gains: dict[str, list[float]],
    *,
    kp: float,
    kd: float,
    kv: float,
) -> tuple[float, float]:
    """Sets the PD gains of a position or velocity joint's actuator (effort: none);
    returns them (kp, kd), (0, kv) or (0, 0)."""
    if interface == "position":
        joint_kp, joint_kd = gains.get(joint_name, [kp, kd])
        if not (joint_kp > 0 and joint_kd >= 0):
            raise ValueError(
                f"gains of position joint {joint_name}: kp={joint_kp!r} must be > 0 and "
                f"kd={joint_kd!r} >= 0"
            )
        actuator.set_controller_gains(PdControllerGains(p=joint_kp, d=joint_kd))
        return joint_kp, joint_kd
    if interface == "velocity":
        joint_kp, joint_kv = gains.get(joint_name, [0.0, kv])
        if joint_kp != 0 or not joint_kv > 0:
            raise ValueError(
                f"gains of velocity joint {joint_name}: kp={joint_kp!r} must be 0 and "
                f"the velocity gain kv={joint_kv!r} > 0"
            )
        actuator.set_controller_gains(PdControllerGains(p=0.0, d=joint_kv))
        return 0.0, joint_kv
    return 0.0, 0.0


def _add_hardware_joint(
    plant: MultibodyPlant,
    robot: LoadedRobot,
    joint_name: str,
    interface: str,
    component: ComponentInfo | None,
    gains: dict[str, list[float]],
    *,
    kp: float,
    kd: float,
    kv: float,
) -> HardwareJoint:
    """Actuates one joint of the plant through ``interface``; returns its description."""
    info = robot.joint(joint_name)
    lower, upper, q0 = _limits_and_start(robot, info, joint_name, component, interface)
    joint = plant.GetJointByName(joint_name, robot.model_instance)
    joint.set_default_positions([q0])
    effort = info.effort if np.isfinite(info.effort) and info.effort > 0 else np.inf
    actuator = _joint_actuator(plant, joint, joint_name, effort)
    joint_kp, joint_kd = _set_gains(actuator, joint_name, interface, gains, kp=kp, kd=kd, kv=kv)
    velocity = info.velocity if np.isfinite(info.velocity) and info.velocity > 0 else np.inf
    return HardwareJoint(
        name=joint_name,
        lower=lower,
        upper=upper,
        effort=effort,
        initial_position=q0,
        command_interface=interface,
        velocity=velocity,
        continuous=info.type == "continuous",
        kp=joint_kp,
        kd=joint_kd,
    )


def AddHardwareInterface(
    plant: MultibodyPlant,
    robot: LoadedRobot,
    *,
    kp: float,
    kd: float,
    kv: float = 1.0,
    gains: dict[str, list[float]] | None = None,
) -> HardwareInterface:
    """Adds the actuators to the (not yet finalized) plant: PD-controlled ones on
    position joints (``kp`` [N m/rad], ``kd`` [N m s/rad]), damping-only ones on
    velocity joints (``kv`` [N m s/rad]), plain ones on effort joints.
    ``gains[joint] = [kp, kd]`` overrides them per joint (a velocity joint's kp
    must be 0, its kd is the velocity gain).

    Sets each joint's default position to its initial value. Call before
    ``plant.Finalize()``; the state indices are filled in by
    :func:`FinishHardwareInterface` afterwards.
    """
    gains = gains or {}
    name, source, kinds = command_interfaces(robot)
    components = _components_by_joint(robot)
    joints = [
        _add_hardware_joint(
            plant,
            robot,
            joint_name,
            kinds[joint_name],
            components.get(joint_name),
            gains,
            kp=kp,
            kd=kd,
            kv=kv,
        )
        for joint_name in kinds
    ]
    return HardwareInterface(
        name=name,
        source=source,
        joints=joints,
        position_index=[],
        velocity_index=[],
        num_model_states=0,
    )


def FinishHardwareInterface(
    plant: MultibodyPlant, robot: LoadedRobot, hardware: HardwareInterface
) -> None:
    """Fills in the state indices once the plant is finalized; checks actuator order."""
    instance = robot.model_instance
    nq = plant.num_positions(instance)
    nv = plant.num_velocities(instance)
    # Where each of the plant's positions and velocities is in the instance's state.
    q_rows = plant.GetPositionsFromArray(instance, np.arange(plant.num_positions()))
    v_rows = plant.GetVelocitiesFromArray(instance, np.arange(plant.num_velocities()))
    q_of = {int(g): i for i, g in enumerate(q_rows)}
    v_of = {int(g): nq + i for i, g in enumerate(v_rows)}
    # Positions and velocities of the instance, by joint (a floating base's come first).
    q_start = {}
    v_start = {}
    for index in plant.GetJointIndices(instance):
        joint = plant.get_joint(index)
        if joint.num_positions() == 0:
            continue
        q_start[joint.name()] = q_of[joint.position_start()]
        v_start[joint.name()] = v_of[joint.velocity_start()]
        if joint.num_positions() == 7 and joint.num_velocities() == 6:  # a floating base
            hardware.base_position_index = [q_of[joint.position_start() + k] for k in range(7)]
            hardware.base_velocity_index = [v_of[joint.velocity_start() + k] for k in range(6)]
    # The desired-state port follows increasing actuator index.
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(instance)]
    order = [actuator.joint().name() for actuator in actuators]
    if order != hardware.joint_names:
        raise RuntimeError(
            f"actuator order {order} differs from {hardware.joint_names}: "
            f"{[a.name() for a in actuators]}"
        )
    hardware.position_index = [q_start[name] for name in order]
    hardware.velocity_index = [v_start[name] for name in order]
    hardware.num_model_states = nq + nv


def AddGravityFeedforward(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    robot: LoadedRobot,
    hardware: HardwareInterface,
    desired_state: OutputPort,
) -> OutputPort:
    """The torques [N m] that hold the arm against gravity at the commanded positions,
    one per actuator of the robot (actuator order), computed in C++; returns that output
    port. The system computing it is named ``gravity_feedforward``.

    ``desired_state`` is [q_d; v_d] of the hardware joints (actuator order). The
    chain is Drake's: an ``AffineSystem`` places q_d of the position joints into the
    plant's default state (every other position at its default, velocities zero),
    ``InverseDynamics`` in gravity-compensation mode gives the generalized forces
    -tau_g(q), and a ``MatrixGain`` maps them onto the actuators of the position
    joints by the pseudo-inverse of the actuation matrix (velocity and effort joints
    get 0: the feed-forward is for position joints only). Drake caches each output
    on its input, so the chain runs when the desired state changes, never per plant
    step. On a mixed robot the velocity and effort joints do not sit at a commanded
    position, so their measured positions go in instead (the diagram then also has
    the input ``state``, the robot's [q; v], connected here, and the chain runs at
    every plant step).

    Every system in a diagram costs a little at every plant step, whether or not it
    computes (the simulator asks it for its next event and tells it the time), so
    when the placement and the mapping are identities (the robot's joints are the
    plant's only degrees of freedom, in actuator order, every one a position joint
    with one actuator), ``InverseDynamics`` alone takes [q_d; v_d] as the plant's
    state (gravity compensation reads only the positions) and its generalized forces
    are the actuator torques.
    """
    n = len(hardware.joints)
    mixed = any(joint.command_interface != "position" for joint in hardware.joints)
    state = plant.get_state_output_port(robot.model_instance)
    measured_size = state.size() if mixed else 0  # the measured state goes in too
    select, x_default = _gravity_placement(plant, robot, hardware, measured_size)
    to_torque = _gravity_to_torque(plant, robot, hardware)
    gravity = InverseDynamics(plant, mode=InverseDynamics.InverseDynamicsMode.kGravityCompensation)
    places_q_d_in_order = np.zeros((2 * n, 2 * n))
    places_q_d_in_order[:n, :n] = np.eye(n)
    if (
        not mixed
        and np.array_equal(select, places_q_d_in_order)
        and not x_default.any()
        and np.array_equal(to_torque, np.eye(n))
    ):
        builder.AddNamedSystem("gravity_feedforward", gravity)
        builder.Connect(desired_state, gravity.get_input_port_estimated_state())
        return gravity.get_output_port_generalized_force()
    inner = _gravity_chain(gravity, select, x_default, to_torque, n, measured_size)
    system = builder.AddNamedSystem("gravity_feedforward", inner)
    builder.Connect(desired_state, system.GetInputPort("desired_state"))
    if mixed:
        builder.Connect(state, system.GetInputPort("state"))
    return system.GetOutputPort("feedforward")


def _gravity_placement(
    plant: MultibodyPlant,
    robot: LoadedRobot,
    hardware: HardwareInterface,
    measured_size: int,
) -> tuple[np.ndarray, np.ndarray]:
    """(matrix, offset) placing [q_d; v_d] (and, when ``measured_size`` > 0, the measured
    state of that size) into the plant's state: q_d of the position joints, the measured
    positions of the others, every other position at its default, velocities zero."""
    n = len(hardware.joints)
    context = plant.CreateDefaultContext()
    x_default = plant.GetPositionsAndVelocities(context)
    x_default[plant.num_positions() :] = 0.0
    columns = 2 * n + measured_size
    select = np.zeros((len(x_default), columns))
    for i, joint in enumerate(hardware.joints):
        row = plant.GetJointByName(joint.name, robot.model_instance).position_start()
        if joint.command_interface == "position":
            select[row, i] = 1.0  # q_d
        else:
            select[row, 2 * n + hardware.position_index[i]] = 1.0  # measured q
        x_default[row] = 0.0  # replaced by the above
    return select, x_default


def _gravity_to_torque(
    plant: MultibodyPlant, robot: LoadedRobot, hardware: HardwareInterface
) -> np.ndarray:
    """Maps generalized forces onto the robot's actuators (zero rows off position joints)."""
    rows = [int(index) for index in plant.GetJointActuatorIndices(robot.model_instance)]
    to_torque = np.linalg.pinv(plant.MakeActuationMatrix())[rows]
    for i, joint in enumerate(hardware.joints):
        if joint.command_interface != "position":
            to_torque[i, :] = 0.0
    return to_torque


def _gravity_chain(
    gravity: InverseDynamics,
    select: np.ndarray,
    x_default: np.ndarray,
    to_torque: np.ndarray,
    n: int,
    measured_size: int,
) -> Diagram:
    """The placement, gravity compensation and actuator mapping as one diagram, inputs
    ``desired_state`` (and ``state`` when ``measured_size`` > 0), output ``feedforward``."""
    inner = DiagramBuilder()
    placement = inner.AddNamedSystem("plant_state", AffineSystem(D=select, y0=x_default))
    dynamics = inner.AddNamedSystem("gravity_compensation", gravity)
    torque = inner.AddNamedSystem("actuator_torque", MatrixGain(to_torque))
    if measured_size:
        stack = inner.AddNamedSystem("inputs", Multiplexer([2 * n, measured_size]))
        inner.ExportInput(stack.get_input_port(0), "desired_state")
        inner.ExportInput(stack.get_input_port(1), "state")
        inner.Connect(stack.get_output_port(), placement.get_input_port())
    else:
        inner.ExportInput(placement.get_input_port(), "desired_state")
    inner.Connect(placement.get_output_port(), dynamics.get_input_port_estimated_state())
    inner.Connect(dynamics.get_output_port_generalized_force(), torque.get_input_port())
    inner.ExportOutput(torque.get_output_port(), "feedforward")
    return inner.Build()


def AddEffortState(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    robot: LoadedRobot,
) -> OutputPort:
    """The effort state interface [N m]: per actuator of the robot (actuator order), the
    torque its actuator applied over the last plant step, as a servo reports it.

    A C++ ``ZeroOrderHold`` named ``effort_state`` latches the plant's net actuation in
    every plant step's own discrete update (same period, offset 0), so the value it
    holds comes from the step's own solve. Reading the plant's net actuation port
    instead would solve the step ahead from the current state with the command then in
    force, and again once a new command arrives at the same time: one more contact
    solve at every tick whose command changes. Before the first step it holds zeros (no
    torque applied yet). A continuous plant (time step 0) gets the net actuation port
    itself.

    The hold latches at every plant step rather than once per controller update (in
    the step before it): a periodic event with an offset does not fall on the plant's
    step times exactly in floating point (0.009 + k 0.01 against m 0.001). On a 1 ms
    plant at 100 Hz about a quarter of such latches ran in a simulator stop of their
    own and solved the contact problem once more, and one in thirteen held the torque
    of the next step. Events of the same period and offset fall on the same times, and
    the run costs the same.
    """
    effort = plant.get_net_actuation_output_port(robot.model_instance)
    h = plant.time_step()
    if h <= 0:
        return effort
    hold = builder.AddNamedSystem("effort_state", ZeroOrderHold(h, effort.size()))
    builder.Connect(effort, hold.get_input_port())
    return hold.get_output_port()


def ConnectHardwareInterface(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    robot: LoadedRobot,
    hardware: HardwareInterface,
    *,
    desired_state: OutputPort,
    effort: OutputPort | None,
    gravity_feedforward: bool,
    velocity_limits: bool = False,
) -> OutputPort | None:
    """Wires the commands to the plant: ``desired_state`` ([q_d; v_d], actuator order)
    to the PD actuators' desired-state input; to the actuation input the sum of the
    gravity feed-forward of the position joints (when ``gravity_feedforward``) and
    ``effort`` (the effort joints' commanded torques [N m], zero on other joints;
    None when no joint takes effort commands). The joints' velocity limits are capped
    on the way when ``velocity_limits``
    (:func:`~armando_drake.control.velocity_limits.AddVelocityLimiter`).
    Returns the gravity feed-forward's output port (:func:`AddGravityFeedforward`), or
    None without one."""
    instance = robot.model_instance
    torques = []
    # The feed-forward stays at the command (cached, not run per plant step); while a
    # velocity limit holds the joint back, the limiter's integral takes up the difference.
    limiter = None
    if velocity_limits:
        limiter = AddVelocityLimiter(builder, plant, robot, hardware, desired_state, effort)
    capped = desired_state
    if limiter is not None:
        capped = limiter.desired_state
        if limiter.torque is not None:
            torques.append(limiter.torque)
    builder.Connect(capped, plant.get_desired_state_input_port(instance))
    feedforward = None
    if gravity_feedforward and "position" in hardware.interfaces():
        feedforward = AddGravityFeedforward(builder, plant, robot, hardware, desired_state)
        torques.append(feedforward)
    if effort is not None:
        torques.append(effort)
    if len(torques) == 1:
        builder.Connect(torques[0], plant.get_actuation_input_port(instance))
    elif torques:
        adder = builder.AddNamedSystem("actuation", Adder(len(torques), len(hardware.joints)))
        for k, torque in enumerate(torques):
            builder.Connect(torque, adder.get_input_port(k))
        builder.Connect(adder.get_output_port(), plant.get_actuation_input_port(instance))
    return feedforward
