"""The torque controller as a Drake system, and the helper that wires it to a plant.

:class:`TorqueController` runs one law of :mod:`armando_drake.kinematics.control_laws` as
a periodic discrete update at the controller's rate (e.g. 1 kHz); its torque is a
state output, so the plant never calls Python between ticks. The reference comes
from a Drake ``TrajectorySource`` (C++), see :func:`AddTorqueController`.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder, EventStatus, LeafSystem
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import Trajectory

from armando_drake.kinematics.arm import TaskSpaceError


class TorqueController(LeafSystem):
    """Joint torques from a torque law, updated every ``period`` seconds.

    .. pydrake_system::

        name: TorqueController
        input_ports:
        - estimated_state
        - reference
        output_ports:
        - actuation

    ``estimated_state``: the model instance's state [q; v] (the plant's
    ``get_state_output_port(instance)``). ``reference``: the law's reference vector
    (``law.reference_size`` numbers). ``actuation``: torques [N m] for the plant's
    ``get_actuation_input_port(instance)``, clamped to the effort limits, held
    between ticks. The first torque is computed at initialization.
    """

    def __init__(self, *, law, period: float):
        super().__init__()
        if not np.isfinite(period) or period <= 0.0:
            raise TaskSpaceError(f"period={period!r} s must be positive")
        self.law = law
        self.period = float(period)
        arm = law.arm
        self._state = self.DeclareVectorInputPort("estimated_state", arm.num_instance_states)
        self._reference = self.DeclareVectorInputPort("reference", law.reference_size)
        self._torque = self.DeclareDiscreteState(arm.num_joints)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._UpdateTorque)
        self.DeclareInitializationDiscreteUpdateEvent(self._UpdateTorque)
        self.DeclareStateOutputPort("actuation", self._torque)

    def _UpdateTorque(self, context, discrete_state) -> EventStatus:
        state = self._state.Eval(context)
        reference = self._reference.Eval(context)
        discrete_state.set_value(self._torque, self.law.CalcActuation(state, reference))
        return EventStatus.Succeeded()


def AddTorqueController(
    builder: DiagramBuilder,
    *,
    plant: MultibodyPlant,
    law,
    reference: Trajectory,
    period: float,
    name: str = "torque_controller",
) -> TorqueController:
    """Adds a :class:`TorqueController` and the ``TrajectorySource`` of its reference.

    Wires the plant's state of the law's model instance to ``estimated_state``, the
    source (named ``{name}_reference``) to ``reference`` and ``actuation`` to the
    plant's actuation input of that instance. ``reference`` is a trajectory of
    ``law.reference_size`` rows: ``JointReference.as_reference_trajectory()`` for the
    joint-space law, ``CartesianTrajectory.as_reference_trajectory(period)`` for the
    operational-space one.
    """
    if reference.rows() != law.reference_size or reference.cols() != 1:
        raise TaskSpaceError(
            f"reference has {reference.rows()}x{reference.cols()} values; "
            f"{type(law).__name__} needs a {law.reference_size}x1 vector"
        )
    instance = law.arm.model_instance
    controller = builder.AddNamedSystem(name, TorqueController(law=law, period=period))
    source = builder.AddNamedSystem(f"{name}_reference", TrajectorySource(reference))
    builder.Connect(
        plant.get_state_output_port(instance), controller.GetInputPort("estimated_state")
    )
    builder.Connect(source.get_output_port(), controller.GetInputPort("reference"))
    builder.Connect(controller.GetOutputPort("actuation"), plant.get_actuation_input_port(instance))
    return controller
