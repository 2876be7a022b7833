"""Servo gains that suit the robot: each position joint's PD actuator sized from the
robot's own inertia, gravity and effort limits, when neither the scenario nor the
controller YAML gives them.

For position joint i (its hardware row), over the home pose (every joint at its
initial position) and :data:`SAMPLE_POSES` poses drawn (with a fixed seed) inside the
joint limits:

- ``M_i``: the largest diagonal entry of the mass matrix (Drake's ``CalcMassMatrix``:
  the joint's own link and every link outboard of it, plus the actuator's reflected
  inertia when the description gives one);
- ``g_i``: the largest torque gravity asks of the joint (``CalcGravityGeneralizedForces``);

then, with the natural frequency ``wn`` and the damping ratio ``zeta``
(:class:`GainRule`):

- ``kp = max(M_i wn^2, g_i / sag, b_i wn)``: the bandwidth, a stiffness that holds
  the arm within ``sag`` of its target without the gravity feed-forward (real servo
  drives and Gazebo's PID have none), and enough to drive the joint's own URDF damping
  ``b_i`` at that bandwidth;
- bounded by the effort limit: ``kp <= effort / sag`` (a larger kp saturates the
  actuator on an error smaller than ``sag`` anyway) and by :data:`MAX_GAIN`;
- ``kd = max(0, 2 zeta sqrt(kp M_i) - b_i)``: the damping ratio ``zeta`` at ``M_i``,
  counting the URDF damping Drake already applies; bounded by :data:`MAX_DAMPING`.

``sag`` is :data:`SAG_ROTATION` [rad] on a revolute joint, :data:`SAG_TRANSLATION`
[m] on a prismatic one.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from collections.abc import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import PdControllerGains

from armando_drake.control.hardware import HardwareInterface
from armando_drake.description.loader import LoadedRobot

_log = logging.getLogger("armando_drake.world")

# [rad/s] the default natural frequency of a derived position servo (about 5 Hz, an
# industrial drive's position loop).
NATURAL_FREQUENCY = 30.0
# [-] the default damping ratio of a derived servo: critical, no overshoot on a step.
DAMPING_RATIO = 1.0
# [rad] the largest sag gravity may cause a revolute joint without feed-forward.
SAG_ROTATION = 0.005
# [m] the largest sag gravity may cause a prismatic joint without feed-forward.
SAG_TRANSLATION = 0.001
# Poses drawn inside the joint limits, besides the home pose, for M_i and g_i.
SAMPLE_POSES = 32
# [rad] the range drawn on a joint without limits (a continuous joint).
UNLIMITED_RANGE = math.pi
# [N m/rad] (or N/m) the largest proportional gain accepted. Industrial servos
# run at 1e3..1e5; above 1e6 the discrete step's implicit PD is all stiffness
# and a position command throws the joint to its limit.
MAX_GAIN = 1e6
# [N m s/rad] (or N s/m) the largest derivative (and velocity) gain accepted.
MAX_DAMPING = 1e5


@dc.dataclass(frozen=True)
class GainRule:
    """How derived gains are sized."""

    natural_frequency: float = NATURAL_FREQUENCY  # [rad/s] wn
    damping_ratio: float = DAMPING_RATIO  # [-] zeta


@dc.dataclass
class JointLoad:
    """What a joint's servo carries, over the home pose and the sample poses."""

    inertia: float  # [kg m^2] or [kg] the largest mass-matrix diagonal entry M_i
    gravity: float  # [N m] or [N] the largest |gravity torque| g_i
    damping: float  # [N m s/rad] or [N s/m] the URDF joint damping b_i
    prismatic: bool


@dc.dataclass
class JointGains:
    """The gains a position or velocity joint's actuator uses, and where they came from."""

    joint: str
    kp: float  # [N m/rad] (0 on a velocity joint)
    kd: float  # [N m s/rad] (a velocity joint: its velocity gain kv)
    origin: str  # "derived", "scenario", "controller YAML", "Armando's servos"
    load: JointLoad | None = None  # the load the derivation used (derived gains only)


def joint_loads(
    plant: MultibodyPlant, robot: LoadedRobot, hardware: HardwareInterface
) -> dict[str, JointLoad]:
    """Each hardware joint's :class:`JointLoad`, by name, from the finalized plant."""
    context = plant.CreateDefaultContext()
    joints = [plant.GetJointByName(j.name, robot.model_instance) for j in hardware.joints]
    rows = [joint.velocity_start() for joint in joints]
    starts = [joint.position_start() for joint in joints]
    q_home = plant.GetPositions(context)
    lows = np.array(
        [j.lower if math.isfinite(j.lower) else -UNLIMITED_RANGE for j in hardware.joints]
    )
    highs = np.array(
        [j.upper if math.isfinite(j.upper) else UNLIMITED_RANGE for j in hardware.joints]
    )
    rng = np.random.default_rng(0)
    draws = rng.uniform(lows, highs, size=(SAMPLE_POSES, len(joints)))
    inertia = np.zeros(len(joints))
    gravity = np.zeros(len(joints))
    for pose in [None, *draws]:
        q = q_home.copy()
        if pose is not None:
            q[starts] = pose
        plant.SetPositions(context, q)
        inertia = np.maximum(inertia, np.diag(plant.CalcMassMatrix(context))[rows])
        gravity = np.maximum(gravity, np.abs(plant.CalcGravityGeneralizedForces(context))[rows])
    return {
        j.name: JointLoad(
            inertia=float(inertia[k]),
            gravity=float(gravity[k]),
            damping=float(robot.joint(j.name).damping),
            prismatic=robot.joint(j.name).type == "prismatic",
        )
        for k, j in enumerate(hardware.joints)
    }


def derive_kp(load: JointLoad, effort: float, rule: GainRule) -> float:
    """The derived stiffness of a joint [N m/rad or N/m] (see the module's docstring)."""
    wn = rule.natural_frequency
    sag = SAG_TRANSLATION if load.prismatic else SAG_ROTATION
    kp = max(load.inertia * wn * wn, load.gravity / sag, load.damping * wn)
    if math.isfinite(effort) and effort > 0:
        kp = min(kp, effort / sag)
    return float(min(max(kp, 1e-9), MAX_GAIN))


def derive_kd(load: JointLoad, kp: float, rule: GainRule) -> float:
    """The derived damping of a joint of stiffness ``kp`` [N m s/rad or N s/m]."""
    kd = 2.0 * rule.damping_ratio * math.sqrt(kp * load.inertia) - load.damping
    return float(min(max(kd, 0.0), MAX_DAMPING))


def derive_gains(
    plant: MultibodyPlant,
    robot: LoadedRobot,
    hardware: HardwareInterface,
    wanted: dict[str, tuple[float | None, float | None]],
    rule: GainRule,
) -> dict[str, JointGains]:
    """The derived gains of the position joints in ``wanted`` (joint: (kp or None, kd or
    None); None is derived, a number kept), set on their actuators of the finalized
    ``plant``; by joint."""
    if not wanted:
        return {}
    loads = joint_loads(plant, robot, hardware)
    result = {}
    for joint in hardware.joints:
        if joint.name not in wanted:
            continue
        load = loads[joint.name]
        kp, kd = wanted[joint.name]
        kp = derive_kp(load, joint.effort, rule) if kp is None else kp
        kd = derive_kd(load, kp, rule) if kd is None else kd
        _actuator_of(plant, robot, joint.name).set_controller_gains(PdControllerGains(p=kp, d=kd))
        result[joint.name] = JointGains(joint.name, kp, kd, "derived", load)
    return result


def _actuator_of(plant: MultibodyPlant, robot: LoadedRobot, joint_name: str):
    joint = plant.GetJointByName(joint_name, robot.model_instance)
    for index in plant.GetJointActuatorIndices(robot.model_instance):
        actuator = plant.get_joint_actuator(index)
        if actuator.joint().index() == joint.index():
            return actuator
    raise KeyError(f"joint {joint_name!r} has no actuator")


def gains_table(robot_name: str, gains: Sequence[JointGains], rule: GainRule) -> str:
    """One line naming the gains of every position and velocity joint: ``actuator gains
    of iiwa14 (derived: wn 30 rad/s, zeta 1): iiwa_joint_1 kp 1.2e+04 kd 250, ...``."""
    origins = sorted({g.origin for g in gains})
    how = ", ".join(origins)
    if "derived" in origins:
        how = how.replace(
            "derived",
            f"derived: wn {rule.natural_frequency:g} rad/s, zeta {rule.damping_ratio:g}, "
            f"sag < {SAG_ROTATION:g} rad",
        )
    return f"actuator gains of {robot_name} ({how}): " + ", ".join(
        f"{g.joint} {'kv' if g.kp == 0 else 'kp'} "
        + (f"{g.kd:.4g}" if g.kp == 0 else f"{g.kp:.4g} kd {g.kd:.4g}")
        + (f" [{g.origin}]" if len(origins) > 1 else "")
        for g in gains
    )
