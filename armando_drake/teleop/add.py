"""The live jogs of a scenario added to a world being built: the arm's (:func:`AddJog`)
and the mobile base's (:func:`AddTwistJog`), as ``MakeWorld`` adds its drivers."""

from __future__ import annotations

from armando_drake.teleop.jog import AddJog
from armando_drake.teleop.twist_jog import AddTwistJog


def AddTeleop(builder, jog, twist_jog, topics, *, meshcat, where, closers: list) -> None:
    """Adds the scenario's ``jog`` and ``twist_jog`` sections (either may be None) on the
    controllers of ``topics.stack`` and sets ``topics.jog`` (the arm's jog) and
    ``topics.twist`` / ``topics.twist_target`` (the base's, publishing cmd_vel as a
    twist sequence does); their controls are deleted by ``closers``. ``where(key)``:
    the origin of a scenario key, for error messages."""
    if jog is not None:
        topics.jog = AddJog(builder, jog, topics.stack, meshcat=meshcat, where=where("jog"))
        if topics.jog is not None:
            closers.append(topics.jog.delete_controls)
    if twist_jog is not None:
        base_jog = AddTwistJog(
            builder, twist_jog, topics.stack, meshcat=meshcat, where=where("twist_jog")
        )
        if base_jog is not None:
            topics.twist, topics.twist_target = base_jog, base_jog.controller
            closers.append(base_jog.delete_controls)
