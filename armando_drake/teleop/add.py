"""The live jogs of a scenario added to a world being built: the arm's (:func:`AddJog`)
and the mobile base's (:func:`AddTwistJog`), as ``MakeWorld`` adds its drivers."""

from __future__ import annotations

from armando_drake.teleop.jog import AddJog
from armando_drake.teleop.twist_jog import AddTwistJog


def AddTeleop(builder, jog, twist_jog, stack, *, meshcat, where, closers: list):
    """Adds the scenario's ``jog`` and ``twist_jog`` sections (either may be None) on the
    controllers of ``stack`` (a ControlStack); their controls are deleted by ``closers``.
    ``where(key)``: the origin of a scenario key, for error messages. Returns (the arm's
    MeshcatJog, the base's TwistJog, publishing cmd_vel as a twist sequence does), each
    None when not added."""
    arm_jog = base_jog = None
    if jog is not None:
        arm_jog = AddJog(builder, jog, stack, meshcat=meshcat, where=where("jog"))
        if arm_jog is not None:
            closers.append(arm_jog.delete_controls)
    if twist_jog is not None:
        base_jog = AddTwistJog(builder, twist_jog, stack, meshcat=meshcat, where=where("twist_jog"))
        if base_jog is not None:
            closers.append(base_jog.delete_controls)
    return arm_jog, base_jog
