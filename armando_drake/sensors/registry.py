"""The sensor registry: each Gazebo sensor type a description may name, by its type.

A robot's URDF mounts sensors as Gazebo reads them, ``<gazebo reference="LINK">
<sensor type="TYPE" name="NAME">``. Each type the world simulates is one class
that registers itself under that type with :func:`register_sensor` and adds its
Drake systems for one block (:class:`~armando_drake.description.urdf.SensorBlock`):

    @register_sensor("altimeter")
    class Altimeter:
        @staticmethod
        def add(builder, block, *, plant, robot) -> dict[str, OutputPort]:
            ...

:func:`AddSensors` adds every block of a description whose type is registered and
exports each output it returns as ``<sensor name>.<output>``; a type nothing
registers is named in one warning (Gazebo would simulate it; the world does not).
The camera types are the camera section's
(:func:`~armando_drake.sensors.cameras.AddCameras`: the scenario's renderer, live
view and frame saver). Types come from the modules that register them (imported
before the world is built) and, from other distributions, from the entry points of
the group ``armando_drake.sensors`` (imported once, before the first lookup), as
controller types do.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import logging
from collections.abc import Callable, Sequence
from typing import Any

from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder, OutputPort

from armando_drake.description.camera_sensors import CAMERA_SENSOR_TYPES
from armando_drake.description.loader import LoadedRobot
from armando_drake.description.urdf import SensorBlock
from armando_drake.messages.publications import PublicationRegistry, register
from armando_drake.tools.errors import ScenarioError

_log = logging.getLogger("armando_drake.world")

ENTRY_POINT_GROUP = "armando_drake.sensors"

_TYPES: dict[str, Any] = {}
_entry_points_loaded = False


def register_sensor(type_name: str) -> Callable[[type], type]:
    """Class decorator: registers a sensor class under the Gazebo sensor ``type_name``.
    The class has ``add(builder, block, *, plant, robot)`` returning its outputs by name,
    and may have ``topics(outputs, *, namespace)``, the rows of the publication table
    (:class:`~armando_drake.messages.publications.Topic`) its outputs are published on:
    they are then recorded, bridged and sent to Foxglove with no other edit.
    Registering a type twice (or a camera type) is an error."""

    def decorate(cls: type) -> type:
        if type_name in CAMERA_SENSOR_TYPES:
            raise ValueError(f"sensor type {type_name!r} is the camera section's")
        if type_name in _TYPES and _TYPES[type_name] is not cls:
            raise ValueError(
                f"sensor type {type_name!r} is already registered by "
                f"{_TYPES[type_name].__module__}.{_TYPES[type_name].__qualname__}"
            )
        if not callable(getattr(cls, "add", None)):
            raise TypeError(f"{cls.__qualname__} needs add(builder, block, *, plant, robot)")
        _TYPES[type_name] = cls
        return cls

    return decorate


def unregister_sensor(type_name: str) -> None:
    """Removes a registered type (for tests that register a toy one)."""
    _TYPES.pop(type_name, None)


def load_entry_points() -> tuple[str, ...]:
    """Imports each module of the entry-point group ``armando_drake.sensors`` (each
    registers its types); the modules imported. A module that fails to import is an
    error naming it."""
    global _entry_points_loaded
    _entry_points_loaded = True
    loaded = []
    for entry_point in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        try:
            importlib.import_module(entry_point.module)
        except Exception as error:
            _entry_points_loaded = False
            raise ImportError(
                f"sensor entry point {entry_point.name!r} = {entry_point.value!r}: "
                f"{type(error).__name__}: {error}",
                name=entry_point.module,
            ) from error
        loaded.append(entry_point.module)
    return tuple(loaded)


def sensor_types() -> tuple[str, ...]:
    """Every registered sensor type, in registration order."""
    if not _entry_points_loaded:
        load_entry_points()
    return tuple(_TYPES)


def AddSensors(
    builder: DiagramBuilder,
    blocks: Sequence[SensorBlock],
    *,
    plant: MultibodyPlant,
    robot: LoadedRobot,
    namespace: str = "",
    publications: PublicationRegistry | None = None,
) -> dict[str, dict[str, OutputPort]]:
    """The systems of each sensor block whose type is registered (cameras excepted);
    each output exported as ``<name>.<output>`` (``<namespace>/<name>.<output>`` for a
    robot of several); the topics of a type with ``topics(outputs, *, namespace)``
    registered in ``publications``. Returns the outputs by sensor name."""
    space = f"{namespace.strip('/')}/" if namespace.strip("/") else ""
    known = sensor_types()
    added: dict[str, dict[str, OutputPort]] = {}
    ignored = []
    for block in blocks:
        if block.type in CAMERA_SENSOR_TYPES:
            continue
        if block.type not in known:
            ignored.append(f"{block.name} ({block.type or 'no type'} on {block.link})")
            continue
        if block.name in added:
            raise ScenarioError(f"{block.where()}: sensor name {block.name!r} is used twice")
        outputs = _TYPES[block.type].add(builder, block, plant=plant, robot=robot)
        for output, port in outputs.items():
            builder.ExportOutput(port, f"{space}{block.name}.{output}")
        added[block.name] = dict(outputs)
        topics = getattr(_TYPES[block.type], "topics", None)
        if topics is not None:
            register(publications, *topics(outputs, namespace=namespace))
        _log.info("sensor %s (%s) on %s", block.name, block.type, block.link)
    if ignored:
        _log.warning(
            "%s: sensors of types the world does not simulate, ignored: %s (simulated: %s)",
            robot.source,
            ", ".join(ignored),
            ", ".join(known) or "cameras only",
        )
    return added
