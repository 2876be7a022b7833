"""The simulated hardware interface: what gz_ros2_control does for Gazebo.

Every joint with a ``position`` command interface in the ``<ros2_control>``
block (or, without one, every joint the description actuates) gets a Drake
joint actuator with PD gains and the URDF effort limit. Drake integrates the
PD law implicitly inside its discrete solver, so stiff position tracking is
stable at millisecond steps (gz_ros2_control instead turns a position command
into a velocity command that sags under gravity). ``min``/``max`` interface
parameters merge with the URDF limits, the tighter winning; the position
state interface's ``initial_value`` (0 when absent, clamped into the limits)
is the joint's initial position.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import PdControllerGains

from armando_drake.description.importer import actuated_joints
from armando_drake.description.loader import LoadedRobot, parse_urdf
from armando_drake.description.ros2_control import initial_position, merge_limits

_log = logging.getLogger("armando_drake.control.hardware")


@dataclass
class HardwareJoint:
    """One actuated joint of the hardware interface."""

    name: str
    lower: float  # [rad] command limit: URDF limit merged with the interface min
    upper: float  # [rad] command limit: URDF limit merged with the interface max
    effort: float  # [N m] effort limit of the actuator
    initial_position: float  # [rad]


@dataclass
class HardwareInterface:
    """The actuated joints, in actuator order, and where they are in the plant."""

    name: str  # the ros2_control block's name, or the robot's
    source: str  # "ros2_control", "transmission" or "all joints"
    joints: list[HardwareJoint]
    # Index of each joint's position in the model instance's state vector [q; v].
    position_index: list[int]
    # Index of each joint's velocity in the model instance's state vector [q; v].
    velocity_index: list[int]
    num_model_states: int  # size of the model instance's state vector

    @property
    def joint_names(self) -> list[str]:
        return [joint.name for joint in self.joints]

    def find(self, names: list[str]) -> list[int]:
        """Indices into :attr:`joints` of ``names``."""
        index = {name: i for i, name in enumerate(self.joint_names)}
        return [index[name] for name in names]


def _actuated_joint_names(robot: LoadedRobot) -> tuple[str, str, list[str]]:
    """(interface name, source, joint names) of the joints to actuate."""
    names, source = actuated_joints(parse_urdf(robot.urdf, robot.source))
    name = robot.ros2_control[0].name if source == "ros2_control" else robot.name
    return name, source, names


def AddHardwareInterface(
    plant: MultibodyPlant,
    robot: LoadedRobot,
    *,
    kp: float,
    kd: float,
    gains: dict[str, list[float]] | None = None,
) -> HardwareInterface:
    """Adds PD-controlled actuators to the (not yet finalized) plant.

    Sets each joint's default position to its initial value. Call before
    ``plant.Finalize()``; the state indices are filled in by
    :func:`FinishHardwareInterface` afterwards.
    """
    gains = gains or {}
    name, source, names = _actuated_joint_names(robot)
    interfaces = {}
    for block in robot.ros2_control:
        for component in block.joints:
            interfaces[component.name] = component
    joints = []
    for joint_name in names:
        info = robot.joint(joint_name)
        component = interfaces.get(joint_name)
        command = component.command_interface("position") if component else None
        state = component.state_interface("position") if component else None
        lower, upper = merge_limits(info.lower, info.upper, command)
        q0 = initial_position(lower, upper, state)
        joint = plant.GetJointByName(joint_name, robot.model_instance)
        joint.set_default_positions([q0])
        existing = [
            plant.get_joint_actuator(index)
            for index in plant.GetJointActuatorIndices(robot.model_instance)
            if plant.get_joint_actuator(index).joint().index() == joint.index()
        ]
        effort = info.effort if np.isfinite(info.effort) and info.effort > 0 else np.inf
        actuator = (
            existing[0]
            if existing
            else plant.AddJointActuator(f"{joint_name}_actuator", joint, effort)
        )
        joint_kp, joint_kd = gains.get(joint_name, [kp, kd])
        if joint_kp <= 0 or joint_kd < 0:
            raise ValueError(
                f"gains of {joint_name}: kp={joint_kp!r} must be > 0 and kd={joint_kd!r} >= 0"
            )
        actuator.set_controller_gains(PdControllerGains(p=joint_kp, d=joint_kd))
        joints.append(
            HardwareJoint(
                name=joint_name, lower=lower, upper=upper, effort=effort, initial_position=q0
            )
        )
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
    # Positions and velocities of the instance, in instance order, by joint.
    q_start = {}
    v_start = {}
    q_offset = v_offset = 0
    for index in plant.GetJointIndices(instance):
        joint = plant.get_joint(index)
        q_start[joint.name()] = q_offset
        v_start[joint.name()] = nq + v_offset
        q_offset += joint.num_positions()
        v_offset += joint.num_velocities()
    # The desired-state port follows increasing actuator index.
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(instance)]
    order = [actuator.joint().name() for actuator in actuators]
    if order != hardware.joint_names:
        raise RuntimeError(f"actuator order {order} differs from {hardware.joint_names}")
    hardware.position_index = [q_start[name] for name in order]
    hardware.velocity_index = [v_start[name] for name in order]
    hardware.num_model_states = nq + nv


class GravityFeedforward:
    """The torques that hold the arm against gravity at a commanded position.

    ``feedforward(q_d)`` takes the hardware joints' desired positions [rad]
    (actuator order) and returns one torque [N m] per actuator of the robot:
    the generalized forces -tau_g(q) that cancel gravity with the hardware
    joints at q_d and every other position at its default, mapped onto the
    actuators by the pseudo-inverse of the actuation matrix. Fed to the
    plant's actuation input, they make the steady-state error of the PD
    actuators independent of their gains.

    The controller manager calls it when a desired position changes, so a
    held command costs nothing per step. It evaluates the plant in a context
    of its own.
    """

    def __init__(self, plant: MultibodyPlant, robot: LoadedRobot, hardware: HardwareInterface):
        self._plant = plant
        self._context = plant.CreateDefaultContext()
        self._q_default = plant.GetPositions(self._context)
        self._q_rows = [
            plant.GetJointByName(joint.name, robot.model_instance).position_start()
            for joint in hardware.joints
        ]
        rows = [int(index) for index in plant.GetJointActuatorIndices(robot.model_instance)]
        # Generalized forces of the whole plant -> torques of the robot's actuators.
        self._to_torque = np.linalg.pinv(plant.MakeActuationMatrix())[rows]

    @property
    def size(self) -> int:
        """Number of torques: the robot's actuators."""
        return self._to_torque.shape[0]

    def __call__(self, desired_positions) -> np.ndarray:
        q = self._q_default.copy()
        q[self._q_rows] = desired_positions
        self._plant.SetPositions(self._context, q)
        return -self._to_torque @ self._plant.CalcGravityGeneralizedForces(self._context)
