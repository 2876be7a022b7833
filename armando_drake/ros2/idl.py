"""Cyclone DDS types of the ROS 2 messages, generated from their ``.msg`` definitions.

:func:`idl_type` turns a message of :mod:`armando_drake.messages.definitions` (the
``rosbags`` type store, as MCAP and Foxglove read it) into a Cyclone DDS ``IdlStruct``
named as ROS 2 names it on DDS (``sensor_msgs::msg::dds_::JointState_``), field for
field, so its XCDR1 serialisation is the ROS 2 CDR of the message (rmw_cyclonedds and
rmw_fastrtps both send plain CDR, little-endian, with the 4-byte
encapsulation header ``00 01 00 00``). :func:`to_idl` and :func:`to_dict`
convert between those messages and the dictionaries of
:mod:`armando_drake.messages.definitions`.

Its types need Cyclone DDS (the ``[ros2]`` extra).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

from armando_drake.messages.definitions import dds_type_name, fields, short_name


@functools.cache
def _primitives() -> dict[str, Any]:
    """The Cyclone DDS type of each ROS 2 primitive (rosidl's mapping). Cyclone DDS is
    the [ros2] extra, imported here on first use: importing this module loads none of it."""
    from cyclonedds.idl import types as t

    return {
        "bool": bool,
        "byte": t.byte,
        "char": t.uint8,
        "int8": t.int8,
        "uint8": t.uint8,
        "int16": t.int16,
        "uint16": t.uint16,
        "int32": t.int32,
        "uint32": t.uint32,
        "int64": t.int64,
        "uint64": t.uint64,
        "float32": t.float32,
        "float64": t.float64,
        "string": str,
    }


def _field_type(text: str) -> Any:
    from cyclonedds.idl import types as t  # the [ros2] extra, as in _primitives

    base, bracket, size = text.partition("[")
    element = _primitives().get(base) or idl_type(base)
    if not bracket:
        return element
    size = size.rstrip("]")
    if size == "":
        return t.sequence[element]
    if size.startswith("<="):
        return t.sequence[element, int(size[2:])]
    return t.array[element, int(size)]


@functools.cache
def idl_type(type_name: str) -> type:
    """The Cyclone DDS type of ``pkg/msg/Type`` (or ``pkg/Type``), generated once."""
    name = short_name(type_name)
    members = {field_name: _field_type(field_type) for field_type, field_name in fields(name)}
    from cyclonedds.idl import make_idl_struct  # the [ros2] extra, as in _primitives

    return make_idl_struct(name.replace("/", "_"), dds_type_name(name), members)


def _convert(field_text: str, value: Any) -> Any:
    base, bracket, _ = field_text.partition("[")
    if base in _primitives():
        if bracket and isinstance(value, (bytes, bytearray)):
            return bytes(value)  # uint8[] as bytes: Cyclone serialises it in one copy
        return list(value) if bracket else value
    if bracket:
        return [to_idl(base, item) for item in value]
    return to_idl(base, value)


def to_idl(type_name: str, message: Mapping[str, Any]) -> Any:
    """The DDS message of a message dictionary; a missing field is an error naming it."""
    kwargs = {}
    for field_text, field_name in fields(type_name):
        if field_name not in message:
            raise KeyError(f"{type_name}: field {field_name!r} missing from {sorted(message)}")
        kwargs[field_name] = _convert(field_text, message[field_name])
    return idl_type(type_name)(**kwargs)


def to_dict(type_name: str, message: Any) -> dict[str, Any]:
    """The dictionary of a received DDS message."""
    result = {}
    for field_text, field_name in fields(type_name):
        value = getattr(message, field_name)
        base, bracket, _ = field_text.partition("[")
        if base in _primitives():
            result[field_name] = list(value) if bracket else value
        elif bracket:
            result[field_name] = [to_dict(base, item) for item in value]
        else:
            result[field_name] = to_dict(base, value)
    return result
