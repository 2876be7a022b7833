"""The live jogs of a scenario added to a world being built: the arm's (:func:`AddJog`)
and the mobile base's (:func:`AddTwistJog`), as ``MakeWorld`` adds its drivers."""

from __future__ import annotations

from armando_drake.teleop.jog import AddJog
from armando_drake.teleop.twist_jog import AddTwistJog


def AddTeleop(builder, scenario, topics, *, meshcat, where, closers: list) -> None:
    """Adds ``scenario.jog`` and ``scenario.twist_jog`` (either may be None) on the
    controllers of ``topics.stack`` and sets ``topics.jog`` (the arm's jog) and
    ``topics.twist`` / ``topics.twist_target`` (the base's, publishing cmd_vel as a
    twist sequence does); their controls are deleted by ``closers``. ``where(key)``:
    the origin of a scenario key, for error messages."""
    if scenario.jog is not None:
        topics.jog = AddJog(
            builder, scenario.jog, topics.stack, meshcat=meshcat, where=where("jog")
        )
        if topics.jog is not None:
            closers.append(topics.jog.delete_controls)
    if scenario.twist_jog is not None:
        jog = AddTwistJog(
            builder, scenario.twist_jog, topics.stack, meshcat=meshcat, where=where("twist_jog")
        )
        if jog is not None:
            topics.twist, topics.twist_target = jog, jog.controller
            closers.append(jog.delete_controls)
