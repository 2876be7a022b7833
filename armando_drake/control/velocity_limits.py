"""Joint velocity limits: the URDF ``<limit velocity>`` enforced on every command interface.

Gazebo's physics caps a joint's speed at its velocity limit whatever drives it; Drake's
plant enforces position limits only. This module adds the cap in front of the plant,
as a small diagram of C++ primitives (no Python at the plant's steps):

- ``position`` and ``velocity`` joints: Drake's PD actuator, integrated implicitly with
  ``q_next = q + h v_next`` (h the plant's step), gives the torque
  ``kp (q_d - q - h v_next) + kd (v_d - v_next) = K (u - v_next)`` with
  ``K = kp h + kd`` and ``u = (kp (q_d - q) + kd v_d) / K``: a velocity servo towards
  ``u``. The limiter saturates ``u`` at the limit and shifts the desired position (a
  velocity joint: its desired velocity) by the excess, so that the servo drives the
  joint towards at most the limit. While ``|u|`` is within the limit the desired state
  passes unchanged (the run is the same as without the cap).
- ``effort`` joints: the velocity the command would reach over the step,
  ``w = v + h tau / M`` (``M`` the joint's diagonal of the mass matrix at home), is
  capped: the torque ``-c (w - clip(w, -limit, limit))``, ``c = M / h``, is added to
  the command.
- every limited servo joint also gets ``-c (v - clip(v, -limit, limit))``, ``c = 0.9 M /
  h``, on the measured velocity: a weak servo dragged past its limit by a neighbour's
  acceleration is taken back within a step or two; and on every limited joint the
  excess is integrated (``0.3 M / h`` per step, reset to zero once under the limit), so
  that a steady load such as gravity leaves no excess.
- the velocity each cap acts on also carries the pull of the other joints through the
  mass matrix: ``-sum_j M_ij / M_ii (v_j - v_j_before)`` (their velocity change over the
  step before, held by a ``ZeroOrderHold``). A light joint on a heavy one (Armando's tip
  on its shoulder: ``M_ij`` as large as ``M_ii``) is otherwise dragged past its limit
  within one step, before its measured velocity shows it (2 % over, when both step
  together).

A joint without a finite velocity limit passes unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Diagram, DiagramBuilder, OutputPort
from pydrake.systems.primitives import (
    AffineSystem,
    ConstantVectorSource,
    MatrixGain,
    Multiplexer,
    Saturation,
    ZeroOrderHold,
)

from armando_drake.description.loader import LoadedRobot

if TYPE_CHECKING:  # the hardware interface adds the limiter
    from armando_drake.control.hardware import HardwareInterface

# Shares of the one-step (deadbeat) gain M / h that the cap on the measured velocity
# uses: on an effort joint, and on top of a servo's (which already drives it back).
EFFORT_CAP_SHARE = 1.0
SERVO_CAP_SHARE = 0.9
# Share of M / h per step that integrates the measured velocity's excess (a steady load,
# such as gravity, leaves none).
INTEGRAL_SHARE = 0.3
# Share of the one-step (deadbeat) approach to the limit that a servo whose demand is
# saturated keeps (see _matrices): it closes its gap to the limit with a time constant
# of about h / APPROACH_SHARE (7 ms at 1 ms steps) whatever its damping.
APPROACH_SHARE = 0.15
# The largest loop gain the coupling between two capped joints may close (see
# _coupling_weight): a light joint on a heavy one has a small one (Armando's tip on its
# shoulder: 0.02); two strongly coupled joints (a gripper's finger on its wrist) get a
# share of the coupling only.
COUPLING_LOOP_GAIN = 0.25


@dataclass
class VelocityLimiter:
    """The limiter's ports: ``desired_state`` ([q_d; v_d] actuator order, capped) and
    ``torque`` (the effort joints' cap [N m], actuator order; None without one)."""

    desired_state: OutputPort
    torque: OutputPort | None


def limited_joints(hardware: HardwareInterface) -> list[int]:
    """Indices (actuator order) of the joints the limiter caps: a finite velocity limit
    and a way to cap it (a servo with a velocity gain, or the effort interface)."""
    return [
        i
        for i, joint in enumerate(hardware.joints)
        if np.isfinite(joint.velocity)
        and (joint.command_interface == "effort" or joint.kp > 0 or joint.kd > 0)
    ]


def slowest_move(
    joints: Sequence, targets: Sequence[Sequence[float]], start: Sequence[float], period: float
) -> str:
    """One line naming the joint whose velocity limit keeps it longest from a target it
    is given ``period`` [s] to reach (``joints``: hardware joints with ``name`` and
    ``velocity`` [rad/s or m/s], in the targets' order; ``start``: their positions
    before the first target), with its limit and the time the move needs; "" when
    every move fits in its period."""
    worst = (period, "", 0.0, 0)
    previous = np.asarray(start, dtype=float)
    for k, target in enumerate(np.asarray(targets, dtype=float)):
        for joint, step in zip(joints, np.abs(target - previous), strict=True):
            if np.isfinite(joint.velocity) and joint.velocity > 0:
                needed = float(step) / joint.velocity
                if needed > worst[0] * (1 + 1e-9):
                    worst = (needed, joint.name, float(step), k)
        previous = target
    needed, name, step, k = worst
    if not name:
        return ""
    limit = next(j.velocity for j in joints if j.name == name)
    return (
        f"joint {name} (velocity limit {limit:g} rad/s) needs {needed:.3g} s to move "
        f"{step:.3g} rad to target {k}, {period:g} s are given: the targets are reached "
        "late or not at all (actuators: {velocity_limits: false} lifts the cap)"
    )


def slowest_wave(joints: Sequence, amplitude: Sequence[float], frequency: float) -> str:
    """One line naming the joint whose velocity limit is below the peak speed of its wave
    (``amplitude`` [rad or m] at ``frequency`` [Hz]), with both; "" when none is."""
    for joint, reach in zip(joints, amplitude, strict=True):
        speed = 2 * np.pi * frequency * abs(float(reach))
        if np.isfinite(joint.velocity) and speed > joint.velocity * (1 + 1e-9):
            return (
                f"joint {joint.name}'s velocity limit {joint.velocity:g} rad/s is below "
                f"its wave's peak speed {speed:.3g} rad/s: the wave is followed late and "
                "flattened (actuators: {velocity_limits: false} lifts the cap)"
            )
    return ""


@dataclass
class _Matrices:
    """The limiter's linear maps over z = [q_d; v_d; x; tau; i_up; i_down; v_before] (x the
    robot's state, tau the effort command, i_up >= 0 and i_down <= 0 the integral of the
    measured velocity beyond +limit and -limit, v_before the joints' velocities one step
    before): ``A z + offset`` = [u; w; i_up'; i_down'] (the
    servos' demands, the velocities the cap acts on, the integrals' next values) is
    saturated between ``lower`` and ``upper`` into s; the capped desired state is
    ``C [z; s]``, the cap's torque ``E [z; s]``."""

    A: np.ndarray
    offset: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    C: np.ndarray
    E: np.ndarray


def _coupling_weight(matrix: np.ndarray, starts: list[int], i: int, j: int) -> float:
    """The weight (0 to 1) of joint j's pull in joint i's capped velocity: the loop it
    closes (i's cap torque accelerates j, whose velocity change i's cap sees a step
    later) has the gain ``g = SERVO_CAP_SHARE r / (1 - r)``, r = M_ij^2 / (M_ii M_jj),
    kept at most :data:`COUPLING_LOOP_GAIN` so that it cannot ring."""
    a, b = starts[i], starts[j]
    r = matrix[a, b] ** 2 / (matrix[a, a] * matrix[b, b])
    if r >= 1.0:
        return 0.0
    gain = SERVO_CAP_SHARE * r / (1.0 - r)
    return min(1.0, COUPLING_LOOP_GAIN / gain) if gain > 0 else 1.0


def _matrices(
    plant: MultibodyPlant, robot: LoadedRobot, hardware: HardwareInterface, rows: list[int]
) -> _Matrices:
    """The limiter's maps for the joints ``rows`` (see :class:`_Matrices`)."""
    n = len(hardware.joints)
    h = plant.time_step() if plant.time_step() > 0 else 1e-3
    x0 = 2 * n  # where the robot's state starts in z
    tau = x0 + hardware.num_model_states  # where the effort command starts
    before = tau + 3 * n  # where the joints' velocities one step before start
    size = tau + 4 * n
    A = np.zeros((4 * n, size))
    offset = np.zeros(4 * n)
    lower = np.concatenate([np.full(2 * n, -np.inf), np.zeros(n), np.full(n, -np.inf)])
    upper = np.concatenate([np.full(3 * n, np.inf), np.zeros(n)])
    C = np.zeros((2 * n, size + 4 * n))
    C[:, : 2 * n] = np.eye(2 * n)
    E = np.zeros((n, size + 4 * n))
    matrix = plant.CalcMassMatrix(plant.CreateDefaultContext())
    starts = [
        plant.GetJointByName(joint.name, robot.model_instance).velocity_start()
        for joint in hardware.joints
    ]
    inverse = np.linalg.inv(matrix)
    for i in rows:
        joint = hardware.joints[i]
        limit = joint.velocity
        m = matrix[starts[i], starts[i]]
        v_row = x0 + hardware.velocity_index[i]
        # The velocity w the cap acts on (an effort joint's: plus what its command adds
        # over the step), taken back by c per step, and the measured velocity's excess
        # integrated (zero once back under the limit). w also carries what the other
        # joints' accelerations of the step before add through the mass matrix's
        # coupling (-M_ij / M_ii dv_j): a light joint on a heavy one is dragged by it
        # within a step, before its measured velocity shows it.
        lower[n + i], upper[n + i] = -limit, limit
        A[n + i, v_row] = 1.0
        for j in range(n):
            if j != i:
                share = matrix[starts[i], starts[j]] / m * _coupling_weight(matrix, starts, i, j)
                A[n + i, x0 + hardware.velocity_index[j]] -= share
                A[n + i, before + j] += share
        effort = joint.command_interface == "effort"
        if effort:
            A[n + i, tau + i] = h / m
        c = (EFFORT_CAP_SHARE if effort else SERVO_CAP_SHARE) * m / h
        E[i, :size] = -c * A[n + i]
        E[i, size + n + i] = c
        for k, sign in ((2 * n + i, 1.0), (3 * n + i, -1.0)):
            A[k, tau + n + (k - 2 * n)] = 1.0
            A[k, v_row] = INTEGRAL_SHARE * m / h
            offset[k] = -sign * INTEGRAL_SHARE * m / h * limit
            E[i, tau + n + (k - 2 * n)] = -1.0
        if effort:
            continue
        # The servo's demand u, saturated: the excess u - s moves q_d by -(K / kp) (u - s),
        # or v_d by -(K / kd) (u - s).
        # The demand is saturated where the servo's torque K (u - v_next) would take the
        # joint APPROACH_SHARE of the way to the limit within the step (M_free: the
        # joint's inertia with every other joint free, 1 / (M^-1)_ii):
        # u <= L + g (L - w), g = APPROACH_SHARE M_free / (h K), w the velocity the cap
        # acts on; that is, y = u + g w saturated at +-(1 + g) L. Saturating u at L
        # alone would leave a servo with little damping (small K) the torque
        # K (L - v), next to nothing, far below its limit.
        gain = joint.kp * plant.time_step() + joint.kd
        free = 1.0 / inverse[starts[i], starts[i]]
        reach = APPROACH_SHARE * free / (h * gain)
        lower[i], upper[i] = -(1 + reach) * limit, (1 + reach) * limit
        A[i, i] = joint.kp / gain
        A[i, x0 + hardware.position_index[i]] = -joint.kp / gain
        A[i, n + i] = joint.kd / gain
        A[i] += reach * A[n + i]  # the measured velocity and the coupling's pull
        target, scale = (i, gain / joint.kp) if joint.kp > 0 else (n + i, gain / joint.kd)
        C[target, :size] -= scale * A[i]
        C[target, size + i] += scale
    return _Matrices(A, offset, lower, upper, C, E)


def _limiter_diagram(
    maps: _Matrices, n: int, state_size: int, h: float, velocities: list[int]
) -> Diagram:
    """The limiter as one diagram: inputs ``desired_state``, ``state`` and ``effort``,
    outputs ``desired_state`` and ``torque``; the integrals and the joints' velocities
    (``velocities``: their indices in the state) are held by a ``ZeroOrderHold`` at
    the plant's step ``h``, so that the maps see them one step before."""
    inner = DiagramBuilder()
    inputs = inner.AddNamedSystem("inputs", Multiplexer([2 * n, state_size, n, 2 * n, n]))
    pick = inner.AddNamedSystem("joint_velocities", MatrixGain(np.eye(state_size)[velocities]))
    before = inner.AddNamedSystem("velocity_hold", ZeroOrderHold(h, n))
    demand = inner.AddNamedSystem("demand", AffineSystem(D=maps.A, y0=maps.offset, time_period=0.0))
    cap = inner.AddNamedSystem("cap", Saturation(maps.lower, maps.upper))
    integrals = inner.AddNamedSystem("integrals", MatrixGain(np.eye(4 * n)[2 * n :]))
    hold = inner.AddNamedSystem("integral_hold", ZeroOrderHold(h, 2 * n))
    both = inner.AddNamedSystem("inputs_and_cap", Multiplexer([6 * n + state_size, 4 * n]))
    desired = inner.AddNamedSystem("capped_desired_state", MatrixGain(maps.C))
    torque = inner.AddNamedSystem("velocity_cap", MatrixGain(maps.E))
    inner.ExportInput(inputs.get_input_port(0), "desired_state")
    inner.ExportInput(inputs.get_input_port(1), "state")
    inner.ConnectInput("state", pick.get_input_port())
    inner.Connect(pick.get_output_port(), before.get_input_port())
    inner.Connect(before.get_output_port(), inputs.get_input_port(4))
    inner.ExportInput(inputs.get_input_port(2), "effort")
    inner.Connect(hold.get_output_port(), inputs.get_input_port(3))
    inner.Connect(inputs.get_output_port(), demand.get_input_port())
    inner.Connect(demand.get_output_port(), cap.get_input_port())
    inner.Connect(cap.get_output_port(), integrals.get_input_port())
    inner.Connect(integrals.get_output_port(), hold.get_input_port())
    inner.Connect(inputs.get_output_port(), both.get_input_port(0))
    inner.Connect(cap.get_output_port(), both.get_input_port(1))
    inner.Connect(both.get_output_port(), desired.get_input_port())
    inner.Connect(both.get_output_port(), torque.get_input_port())
    inner.ExportOutput(desired.get_output_port(), "desired_state")
    inner.ExportOutput(torque.get_output_port(), "torque")
    return inner.Build()


def AddVelocityLimiter(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    robot: LoadedRobot,
    hardware: HardwareInterface,
    desired_state: OutputPort,
    effort: OutputPort | None,
) -> VelocityLimiter | None:
    """Adds the system ``velocity_limits`` between ``desired_state`` ([q_d; v_d] of the
    hardware joints, actuator order) and the plant (see the module's docstring); None
    when no joint has a finite velocity limit to cap. ``effort`` is the effort joints'
    command [N m] (actuator order; None: none)."""
    rows = limited_joints(hardware)
    if not rows:
        return None
    maps = _matrices(plant, robot, hardware, rows)
    n = len(hardware.joints)
    h = plant.time_step() if plant.time_step() > 0 else 1e-3
    system = builder.AddNamedSystem(
        "velocity_limits",
        _limiter_diagram(maps, n, hardware.num_model_states, h, hardware.velocity_index),
    )
    builder.Connect(desired_state, system.GetInputPort("desired_state"))
    builder.Connect(plant.get_state_output_port(robot.model_instance), system.GetInputPort("state"))
    if effort is None:
        effort = builder.AddNamedSystem("no_effort", ConstantVectorSource(np.zeros(n)))
        effort = effort.get_output_port()
    builder.Connect(effort, system.GetInputPort("effort"))
    return VelocityLimiter(
        desired_state=system.GetOutputPort("desired_state"),
        torque=system.GetOutputPort("torque"),
    )
