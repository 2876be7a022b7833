"""The ``ros2:`` section of a scenario: the world live on DDS and Foxglove."""

import dataclasses as dc
import ipaddress
import re

from armando_drake.tools.schema import Refusal, param

# A Linux network interface name (at most 15 characters, no space, quote or slash):
# the value goes into Cyclone DDS's XML configuration, so nothing else is accepted.
INTERFACE_NAME = re.compile(r"[A-Za-z0-9_.:-]{1,15}")
# A ROS 2 namespace: absolute, tokens of letters, digits and underscores, none starting
# with a digit (rcl's rules).
NAMESPACE = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")


def _is_address(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
    except ValueError:
        return False
    return True


@dc.dataclass
class Ros2Config:
    """Where the running world appears as a ROS 2 robot (``--ros2``, ``--foxglove``)."""

    # Whether the world publishes its topics and subscribes its controllers'
    # command topics on DDS, as a ROS 2 robot (ros2_control + robot_state_publisher).
    enabled: bool = False
    # The ROS_DOMAIN_ID [0, 232] of the DDS domain.
    domain_id: int = param(0, unit="-")
    # ROS namespace of the robot's topics, e.g. "/arm" (joint_states, robot_description,
    # controllers, camera); "" = none. /tf, /tf_static and /clock stay global, as in ROS 2.
    namespace: str = ""
    # Network interface for DDS, by name ("eth0") or address; "" = loopback only
    # (127.0.0.1, unicast discovery, no multicast). Naming one puts the world on that
    # network, discovery by multicast as ROS 2 does by default.
    network_interface: str = ""
    # Whether the same topics are served over Foxglove's WebSocket protocol.
    foxglove: bool = False
    # TCP port of the Foxglove WebSocket server; 0 = any free port (logged).
    foxglove_port: int = param(8765, unit="-")
    # Address the Foxglove server listens on; "127.0.0.1" = this machine only,
    # "0.0.0.0" = every interface.
    foxglove_host: str = "127.0.0.1"
    # Rate of /clock [Hz]; 0 = the controller manager's update_rate.
    clock_rate: float = param(0.0, unit="Hz", ge=0)

    def check(self) -> None:
        """The names that go into other programs' configuration, and the namespace,
        as ROS 2 accepts them."""
        interface = self.network_interface
        if interface and not (_is_address(interface) or INTERFACE_NAME.fullmatch(interface)):
            raise Refusal(
                "network_interface",
                f"={interface!r} is neither an interface name (letters, digits, _ . : -; at "
                "most 15) nor an IP address",
            )
        if self.namespace and not self.namespace.startswith("/"):
            raise Refusal(
                "namespace", f"={self.namespace!r} must start with '/' (a ROS 2 namespace: '/arm')"
            )
        if self.namespace and not NAMESPACE.fullmatch(self.namespace):
            raise Refusal(
                "namespace",
                f"={self.namespace!r} is not a ROS 2 namespace (e.g. '/arm': '/'-separated "
                "names of letters, digits and _, none starting with a digit)",
            )
        host = self.foxglove_host
        if host != "localhost" and not _is_address(host):
            raise Refusal(
                "foxglove_host", f"={host!r} must be an IP address of this machine or localhost"
            )
