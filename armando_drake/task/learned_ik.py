"""Target poses through the learned inverse kinematics: the scenario's ``learned_ik:``.

The course's IK node subscribes to a target pose and publishes the joint angles its
network answers. :func:`AddLearnedIk` builds the same in the diagram: the targets
(one pose ``[x, y, z, roll, pitch, yaw]`` in the world every ``period`` seconds) come
from a Drake ``TrajectorySource`` (a zero-order hold, C++), an
:class:`~armando_drake.learning.network.IkNetwork` answers them at ``rate`` (with
``refine_steps`` Gauss-Newton steps on the world's own plant), and
:class:`JointCommandPublisher` publishes each new answer as a ``Float64MultiArray`` to
the first active position controller (``JointGroupPositionController``).
"""

import dataclasses as dc
import logging
import math
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import DiagramBuilder, EventStatus, LeafSystem
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from armando_drake.control.stack import ControlStack
from armando_drake.kinematics.arm import ArmModel, TaskSpaceError
from armando_drake.learning.network import IkModel, IkNetwork, LearnedIkError
from armando_drake.messages.types import Float64MultiArray, PublicationValue
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.extras import require_extra
from armando_drake.tools.schema import Refusal, param

_log = logging.getLogger("armando_drake.world")

# No `from __future__ import annotations` here: yaml_load_typed reads the dataclass
# field types at run time.


@dc.dataclass
class LearnedIkConfig:
    """Target poses of the end effector, turned into joint commands by a network."""

    # The network: an ONNX file of python -m armando_drake.learn ik (relative to the
    # working folder, the scenario's folder or the project's root).
    network: str = param("", doc="ONNX file of python -m armando_drake.learn ik")
    # The targets, one after another: [x, y, z, roll, pitch, yaw] of the end effector
    # in the world [m, rad]. An arm with fewer than 6 joints takes only some
    # orientations (Armando: roll and yaw, pitch 0).
    targets: list[list[float]] = param([], unit="m, rad")
    # [s] between targets; the first is sent at start_delay.
    period: float = param(3.0, unit="s", gt=0)
    start_delay: float = param(0.0, unit="s", ge=0)
    # Gauss-Newton steps after the network (0 = the network alone).
    refine_steps: int = param(3, unit="-", ge=0, le=50)
    # [Hz] how often the network answers the current target.
    rate: float = param(
        10.0, unit="Hz", gt=0, over=(1000.0, "faster than a network answers (about 1 ms a pose)")
    )
    # In a world of several robots (robots:), the name of the one it acts on; "" = the
    # first listed.
    robot: str = ""

    def check(self) -> None:
        if not self.network:
            raise Refusal("network", ": give the ONNX file of python -m armando_drake.learn ik")
        if not self.targets:
            raise Refusal("targets", ": give at least one [x, y, z, roll, pitch, yaw]")
        for index, target in enumerate(self.targets):
            if len(target) != 6 or not all(math.isfinite(v) for v in target):
                raise Refusal(
                    f"targets.{index}", f"={target!r}: give 6 finite numbers [x y z r p y]"
                )


class JointCommandPublisher(LeafSystem):
    """Publishes joint positions as a ``Float64MultiArray`` when they change.

    .. pydrake_system::

        name: JointCommandPublisher
        input_ports:
        - positions
        output_ports:
        - commands

    ``positions``: the vector to publish (in the controller's joint order, after
    ``order`` picks them). ``commands``: a Publication, checked every ``period``
    seconds; a new message only when a position moved by more than 1e-9.
    """

    def __init__(self, size: int, order, period: float):
        super().__init__()
        self._order = np.asarray(order, dtype=int)
        self._positions = self.DeclareVectorInputPort("positions", size)
        self._publication = self.DeclareAbstractState(PublicationValue())
        self.DeclareStateOutputPort("commands", self._publication)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._Update)

    def _Update(self, context, state) -> EventStatus:
        q = self._positions.Eval(context)[self._order]
        publication = context.get_abstract_state(self._publication).get_value()
        last = publication.message.data if publication.message is not None else None
        if last is not None and np.max(np.abs(np.asarray(last) - q)) <= 1e-9:
            return EventStatus.DidNothing()
        message = Float64MultiArray(data=tuple(float(v) for v in q))
        state.get_mutable_abstract_state(self._publication).set_value(
            publication.publish(message, context.get_time())
        )
        return EventStatus.Succeeded()


@dc.dataclass
class LearnedIk:
    """What :func:`AddLearnedIk` added."""

    controller: str  # the position controller it commands
    network: IkNetwork  # the system (output "positions")
    targets: list[RigidTransform]  # X_WE of each target
    times: list[float]  # [s] when each target is sent
    arm: ArmModel  # the end effector on the world's plant (its FK)


def AddLearnedIk(
    builder: DiagramBuilder,
    config: LearnedIkConfig,
    stack: ControlStack,
    *,
    base_pose: RigidTransform,
    where: str = "",
) -> LearnedIk:
    """Target poses -> :class:`IkNetwork` -> the first active position controller of
    ``stack``. ``base_pose``: X_WD, where the robot's base frame is (as the network's
    data set had it at the origin)."""
    targets = stack.taking(Float64MultiArray, position_targets=True)
    if not targets:
        raise ScenarioError(
            f"{where}learned_ik needs an active position controller; "
            f"active: {', '.join(stack.controllers) or 'none'}"
        )
    name = targets[0]
    command = stack.command_input(name)
    if builder.IsConnectedOrExported(command):
        raise ScenarioError(
            f"{where}learned_ik: {name} is already driven (by the sequencer?); "
            "give the scenario one of them"
        )
    require_extra("learned_ik", f"{where}learned_ik")
    try:
        model = IkModel(Path(config.network))
    except LearnedIkError as error:
        raise ScenarioError(f"{where}learned_ik.network: {error}") from None
    joints = stack.controller_joints[name]
    missing = [j for j in model.joint_names if j not in joints]
    if missing:
        raise ScenarioError(
            f"{where}learned_ik.network: {config.network} answers joints {missing} that "
            f"{name} does not command ({', '.join(joints)})"
        )
    plant, instance = stack.plant, stack.robot.model_instance
    try:
        arm = ArmModel(
            plant=plant, end_effector_frame=model.metadata["frame"], model_instance=instance
        )
    except TaskSpaceError as error:
        raise ScenarioError(f"{where}learned_ik.network: {error}") from None
    period = 1.0 / config.rate
    network = builder.AddNamedSystem(
        "learned_ik",
        IkNetwork(model, X_WD=base_pose, arm=arm, refine_steps=config.refine_steps, period=period),
    )
    poses = np.array(config.targets, dtype=float)
    times = [config.start_delay + k * config.period for k in range(len(poses))]
    # A zero-order hold keeps a sample until the next break: one more break after the
    # last target keeps it (past the end, the last segment holds).
    breaks = [*times, times[-1] + config.period]
    trajectory = PiecewisePolynomial.ZeroOrderHold(breaks, np.vstack([poses, poses[-1:]]).T)
    source = builder.AddNamedSystem("learned_ik_targets", TrajectorySource(trajectory))
    builder.Connect(source.get_output_port(), network.GetInputPort("pose"))
    # The network's joints in the controller's order (the others held at their start).
    order = [model.joint_names.index(j) if j in model.joint_names else -1 for j in joints]
    if -1 in order:
        raise ScenarioError(
            f"{where}learned_ik.network: {name} commands joints the network does not answer "
            f"({', '.join(j for j in joints if j not in model.joint_names)})"
        )
    publisher = builder.AddNamedSystem(
        "learned_ik_commands", JointCommandPublisher(model.num_joints, order, period)
    )
    builder.Connect(network.GetOutputPort("positions"), publisher.get_input_port())
    builder.Connect(publisher.GetOutputPort("commands"), command)
    _log.info(
        "learned IK: %d target poses every %g s through %s (%d Gauss-Newton steps) to %s",
        len(poses),
        config.period,
        config.network,
        config.refine_steps,
        name,
    )
    X = [RigidTransform(RollPitchYaw(p[3:]), p[:3]) for p in poses]
    return LearnedIk(controller=name, network=network, targets=X, times=times, arm=arm)
