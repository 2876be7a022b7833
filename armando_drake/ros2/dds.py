"""A DDS participant that looks like a ROS 2 node on the wire (Cyclone DDS).

ROS 2 maps its graph onto DDS as follows, and :class:`DdsNode` does the same:

- topic ``/ns/name`` is the DDS topic ``rt/ns/name``;
- message ``pkg/msg/Type`` is the DDS type ``pkg::msg::dds_::Type_``, plain CDR
  (XCDR1, little-endian) with the encapsulation header ``00 01 00 00``
  (:mod:`armando_drake.ros2.idl`);
- the default QoS is reliable, keep last 10, volatile; ``/tf_static`` and
  ``/robot_description`` are transient local (a late subscriber still gets
  them), sensor data (images) is best effort (:data:`QOS`).

The participant is confined to the loopback interface unless an interface is
named: Cyclone DDS would otherwise join multicast groups on every interface and
announce itself to the LAN. :func:`cyclonedds_config` writes that
configuration; a ROS 2 node reaches the world with the same XML in its
``CYCLONEDDS_URI`` (:func:`reachability`).
"""

from __future__ import annotations

import contextlib
import functools
import ipaddress
import logging
import os
import socket
import threading
from collections.abc import Callable, Mapping
from types import SimpleNamespace
from typing import Any

from armando_drake.messages.definitions import resolve_topic
from armando_drake.ros2.idl import idl_type, to_dict, to_idl

_log = logging.getLogger("armando_drake.ros2")

# The highest participant index probed by unicast discovery on the loopback:
# that many DDS participants (the world, ROS 2 nodes, tools) can meet there.
MAX_PARTICIPANTS = 30


class Ros2Error(ValueError):
    """A ``ros2:`` setting that cannot be used; the message repeats the value."""


@functools.cache
def _cyclone() -> SimpleNamespace:
    """The parts of Cyclone DDS a node uses. Cyclone DDS is the [ros2] extra, imported
    here on first use so that a world without --ros2 loads none of it (and runs without
    the extra); without it, a one-line error naming the extra."""
    try:
        from cyclonedds.core import Listener, Policy, Qos
        from cyclonedds.domain import Domain, DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic
        from cyclonedds.util import duration
    except ModuleNotFoundError as error:
        raise Ros2Error(
            f"ros2.enabled needs Cyclone DDS ({error}): pip install 'armando-drake[ros2]'"
        ) from None
    xcdr1 = Policy.DataRepresentation(use_cdrv0_representation=True)
    reliable = Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100))
    qos = {
        # rclcpp::QoS(10): reliable, keep last 10, volatile
        "default": Qos(reliable, Policy.History.KeepLast(10), Policy.Durability.Volatile, xcdr1),
        # robot_state_publisher's /robot_description and tf2's static broadcaster: latched
        "latched": Qos(
            reliable, Policy.History.KeepLast(1), Policy.Durability.TransientLocal, xcdr1
        ),
        # rclcpp::SensorDataQoS(): best effort, keep last 5
        "sensor_data": Qos(
            Policy.Reliability.BestEffort,
            Policy.History.KeepLast(5),
            Policy.Durability.Volatile,
            xcdr1,
        ),
    }
    return SimpleNamespace(
        Listener=Listener,
        Domain=Domain,
        DomainParticipant=DomainParticipant,
        DataWriter=DataWriter,
        DataReader=DataReader,
        Topic=Topic,
        qos=qos,
    )


class _QosProfiles(Mapping):
    """QoS profiles by name, as rclcpp defines them (made on first use)."""

    def __getitem__(self, name: str):
        return _cyclone().qos[name]

    def __iter__(self):
        return iter(("default", "latched", "sensor_data"))

    def __len__(self) -> int:
        return 3


QOS = _QosProfiles()


def _interface_element(interface: str) -> str:
    try:
        ipaddress.ip_address(interface)
    except ValueError:
        return f"<NetworkInterface name='{interface}'/>"
    return f"<NetworkInterface address='{interface}'/>"


def check_interface_exists(interface: str) -> None:
    """Refuses an interface name or address this machine does not have, before
    Cyclone DDS prints its own line about it."""
    if not interface:
        return
    try:
        address = ipaddress.ip_address(interface)
    except ValueError:
        names = sorted(name for _, name in socket.if_nameindex())
        if interface not in names:
            raise Ros2Error(
                f"ros2.network_interface={interface!r}: this machine has no such network "
                f"interface (it has: {', '.join(names)})"
            ) from None
        return
    family = socket.AF_INET6 if address.version == 6 else socket.AF_INET
    with socket.socket(family, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind((str(address), 0))
        except OSError:
            raise Ros2Error(
                f"ros2.network_interface={interface!r}: no network interface of this machine "
                "has that address"
            ) from None


def cyclonedds_config(interface: str = "") -> str:
    """The Cyclone DDS XML configuration of a participant on ``interface``.

    ``""``: the loopback interface only (127.0.0.1), no multicast, peers found by
    unicast on 127.0.0.1 (participant indices 0 to :data:`MAX_PARTICIPANTS`).
    A name or address: that interface, with Cyclone's defaults (SPDP multicast).
    """
    if interface:
        return (
            "<CycloneDDS><Domain Id='any'><General><Interfaces>"
            f"{_interface_element(interface)}</Interfaces></General></Domain></CycloneDDS>"
        )
    return (
        "<CycloneDDS><Domain Id='any'><General><Interfaces>"
        "<NetworkInterface address='127.0.0.1' multicast='false'/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
        f"<MaxAutoParticipantIndex>{MAX_PARTICIPANTS}</MaxAutoParticipantIndex>"
        "<Peers><Peer address='127.0.0.1'/></Peers></Discovery>"
        "</Domain></CycloneDDS>"
    )


def reachability(domain_id: int, interface: str = "") -> str:
    """Where the world is reachable, and the environment a ROS 2 node needs there."""
    where = f"interface {interface}" if interface else "the loopback interface only (127.0.0.1)"
    return (
        f"ROS 2 on DDS domain {domain_id}, {where}; a ROS 2 node reaches it with\n"
        f"  export RMW_IMPLEMENTATION=rmw_cyclonedds_cpp ROS_DOMAIN_ID={domain_id}\n"
        f'  export CYCLONEDDS_URI="{cyclonedds_config(interface)}"'
    )


def dds_topic_name(topic: str, namespace: str = "") -> str:
    """``rt/...`` of a ROS 2 topic: absolute names as they are, relative ones in ``namespace``."""
    return "rt" + resolve_topic(topic, namespace)


def _socket_fds() -> set[int]:
    """The file descriptors of this process that are sockets."""
    fds = set()
    for name in os.listdir("/proc/self/fd") if os.path.isdir("/proc/self/fd") else ():
        with contextlib.suppress(OSError):
            if os.readlink(f"/proc/self/fd/{name}").startswith("socket:"):
                fds.add(int(name))
    return fds


def _confine_to_loopback(fds: set[int]) -> None:
    """Binds Cyclone's receive sockets among ``fds`` to the loopback device.

    Cyclone DDS binds its unicast receive sockets to every address (INADDR_ANY)
    whatever the configured interface, though it advertises and sends on
    127.0.0.1 only; ``SO_BINDTODEVICE lo`` makes them receive from the loopback
    only (Linux; allowed without privileges on a socket not yet bound to a
    device since Linux 5.7). Where that fails the log says so.
    """
    for fd in sorted(fds):
        try:
            sock = socket.socket(fileno=fd)
        except OSError:
            continue
        try:
            if sock.type == socket.SOCK_DGRAM and sock.getsockname()[0] in ("0.0.0.0", "::"):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_BINDTODEVICE, b"lo")
        except (OSError, AttributeError) as error:
            _log.warning(
                "DDS socket %s receives on every interface (cannot bind it to lo: %s); "
                "the world still announces and sends on 127.0.0.1 only",
                sock.getsockname(),
                error,
            )
        finally:
            sock.detach()


# One Cyclone DDS domain per id and process, kept for the process's lifetime:
# a domain's configuration is fixed when it is first created.
_domains: dict[int, tuple[Any, str]] = {}
_domains_lock = threading.Lock()


def domain(domain_id: int, interface: str = "") -> Any:
    """The process's DDS domain ``domain_id`` on ``interface`` (created once)."""
    if isinstance(domain_id, bool) or not isinstance(domain_id, int) or not 0 <= domain_id <= 232:
        raise Ros2Error(f"ros2.domain_id={domain_id!r} must be an integer in [0, 232]")
    check_interface_exists(interface)
    config = cyclonedds_config(interface)
    with _domains_lock:
        existing = _domains.get(domain_id)
        if existing is None:
            before = _socket_fds()
            existing = (_cyclone().Domain(domain_id, config), config)
            _domains[domain_id] = existing
            if not interface:
                _confine_to_loopback(_socket_fds() - before)
        elif existing[1] != config:
            raise Ros2Error(
                f"ros2.network_interface={interface!r}: DDS domain {domain_id} already runs "
                "in this process with another interface"
            )
    return existing[0]


class DdsNode:
    """One DDS participant with ROS 2 topic names, types and QoS.

    ``publish(topic, type_name, message)`` writes a message dictionary
    (:mod:`armando_drake.messages.definitions`); ``subscribe(topic, type_name,
    callback)`` calls ``callback(message_dict)`` on Cyclone's receive thread
    for every message. Topics are ROS 2 names, resolved in ``namespace``.
    """

    def __init__(self, *, domain_id: int = 0, namespace: str = "", interface: str = ""):
        _cyclone()  # Cyclone DDS, or the error naming the extra
        if namespace and not namespace.startswith("/"):
            raise Ros2Error(f"ros2.namespace={namespace!r} must start with '/'")
        self.domain_id = domain_id
        self.namespace = namespace
        self.interface = interface
        self._domain = domain(domain_id, interface)
        self._participant = _cyclone().DomainParticipant(domain_id)
        self._topics: dict[str, Any] = {}
        self._writers: dict[str, tuple[str, Any]] = {}
        self._readers: list[Any] = []

    def resolve(self, topic: str) -> str:
        """The ROS 2 name of ``topic`` in this node's namespace."""
        return resolve_topic(topic, self.namespace)

    def _topic(self, topic: str, type_name: str) -> Any:
        name = dds_topic_name(topic, self.namespace)
        if name not in self._topics:
            self._topics[name] = _cyclone().Topic(self._participant, name, idl_type(type_name))
        return self._topics[name]

    def advertise(self, topic: str, type_name: str, qos: str = "default") -> None:
        """Creates the writer of ``topic`` (``publish`` does it on first use)."""
        if topic not in self._writers:
            writer = _cyclone().DataWriter(
                self._participant, self._topic(topic, type_name), qos=QOS[qos]
            )
            self._writers[topic] = (type_name, writer)

    def publish(
        self, topic: str, type_name: str, message: dict[str, Any], stamp: float = 0.0
    ) -> None:
        """Writes ``message`` on ``topic`` (``stamp`` [s] is in its header; DDS does not
        carry it separately)."""
        self.advertise(topic, type_name)
        self._writers[topic][1].write(to_idl(type_name, message))

    def writer(self, topic: str) -> Any:
        return self._writers[topic][1]

    def subscribe(
        self,
        topic: str,
        type_name: str,
        callback: Callable[[dict[str, Any]], None],
        qos: str = "default",
    ) -> Any:
        reader = _cyclone().DataReader(
            self._participant, self._topic(topic, type_name), qos=QOS[qos]
        )

        def drain(_entity=None):
            # Cyclone's receive thread; the listener's own argument can be None while the
            # reader is being registered, so the reader is taken from here.
            for sample in reader.take(N=64):
                info = getattr(sample, "sample_info", None)
                if info is not None and not info.valid_data:
                    continue
                try:
                    callback(to_dict(type_name, sample))
                except Exception:  # a listener must not die; the log says why
                    _log.exception("could not handle a message on %s", topic)

        # The listener is attached once the reader exists; what arrived before (a latched
        # topic's history) is taken right after.
        reader.set_listener(_cyclone().Listener(on_data_available=drain))
        drain()
        self._readers.append(reader)
        return reader

    def close(self) -> None:
        """Deletes the participant with its readers and writers; safe to call twice."""
        if self._participant is None:
            return
        entities = [*self._readers, *(writer for _, writer in self._writers.values())]
        entities += [*self._topics.values(), self._participant]
        for entity in entities:
            entity.__del__()  # dds_delete now, not when Python collects it; idempotent
        self._readers.clear()
        self._writers.clear()
        self._topics.clear()
        self._participant = None
