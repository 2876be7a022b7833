"""The ``ros2:`` section of a scenario: the world live on DDS and Foxglove."""

import dataclasses as dc

from armando_drake.tools.schema import param


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
