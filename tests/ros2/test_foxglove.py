"""Foxglove live: a WebSocket client subscribes /joint_states and decodes what it receives."""

import json
import struct
import threading
import time

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.ros2.bridge import FoxgloveServer, referenced_files
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

pytest.importorskip("foxglove")
ASSETS = (
    "package://armando_description/package.xml",
    "package://armando_description/../../../../etc/hostname",
    "file:///etc/hostname",
)
websockets_client = pytest.importorskip("websockets.sync.client")
rosbags_typesys = pytest.importorskip("rosbags.typesys")


def test_websocket_client_receives_decoded_joint_states():
    scenario = load_scenario(
        "position",
        "ros2: {foxglove: true, foxglove_port: 0}\nlogging: {console_rate: 0}",
    )
    world = MakeWorld(scenario, quiet=True)
    bridge = world.diagram.GetSubsystemByName("ros2_bridge")
    (server,) = bridge.sinks  # Foxglove only: no DDS without ros2.enabled
    assert server.url.startswith("ws://127.0.0.1:")
    simulator = Simulator(world.diagram)
    simulator.set_target_realtime_rate(1.0)
    simulator.Initialize()

    channels: dict[str, dict] = {}
    received: list[tuple[int, bytes]] = []  # (log time [ns], CDR payload)
    assets: dict[str, tuple[int, bytes]] = {}  # uri -> (status, data)
    connected = threading.Event()

    def client():
        with websockets_client.connect(
            server.url, subprotocols=["foxglove.sdk.v1"], open_timeout=10
        ) as socket:
            deadline = time.monotonic() + 20
            subscribed = False
            while time.monotonic() < deadline and len(received) < 50:
                frame = socket.recv(timeout=5)
                if isinstance(frame, str):
                    message = json.loads(frame)
                    if message["op"] == "advertise":
                        channels.update({c["topic"]: c for c in message["channels"]})
                    if "/joint_states" in channels and not subscribed:
                        channel = channels["/joint_states"]["id"]
                        request = {
                            "op": "subscribe",
                            "subscriptions": [{"id": 7, "channelId": channel}],
                        }
                        socket.send(json.dumps(request))
                        subscribed = True
                        connected.set()
                elif frame[0] == 0x01:  # message data: subscription id, log time, payload
                    subscription, log_time = struct.unpack_from("<IQ", frame, 1)
                    assert subscription == 7
                    received.append((log_time, bytes(frame[13:])))
            # The URDF's package:// files (meshes) for the 3-D panel, nothing outside them.
            for request, uri in enumerate(ASSETS, start=1):
                socket.send(json.dumps({"op": "fetchAsset", "uri": uri, "requestId": request}))
                while True:
                    frame = socket.recv(timeout=5)
                    if isinstance(frame, bytes) and frame[0] == 0x04:  # fetch asset response
                        request_id, status, length = struct.unpack_from("<IBI", frame, 1)
                        assert request_id == request
                        assets[uri] = (status, bytes(frame[10 + length :]))
                        break

    thread = threading.Thread(target=client, daemon=True)
    thread.start()
    assert connected.wait(20), f"no /joint_states channel advertised: {sorted(channels)}"
    while thread.is_alive() and simulator.get_context().get_time() < 20:
        simulator.AdvanceTo(simulator.get_context().get_time() + 0.05)
    thread.join(5)
    world.close(simulator.get_context())

    channel = channels["/joint_states"]
    assert channel["encoding"] == "cdr" and channel["schemaEncoding"] == "ros2msg"
    assert channel["schemaName"] == "sensor_msgs/msg/JointState"
    assert {"/tf", "/tf_static", "/clock", "/robot_description"} <= set(channels)
    assert len(received) >= 50
    typestore = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_JAZZY)
    stamps = []
    for log_time, payload in received:
        message = typestore.deserialize_cdr(payload, "sensor_msgs/msg/JointState")
        assert list(message.name) == world.robot().stack.hardware.joint_names
        assert len(message.position) == len(message.velocity) == len(message.name)
        assert np.all(np.isfinite(message.position))
        stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
        assert stamp == log_time
        stamps.append(stamp)
    # One message per tick of the broadcaster (100 Hz), in order.
    assert np.allclose(np.diff(stamps), 1e9 / world.robot().stack.update_rate, atol=1e3)
    # Armando's URDF references no file: every request is refused, even one naming
    # a file inside its package.
    assert [assets[uri][0] for uri in ASSETS] == [1, 1, 1]


def test_asset_handler_serves_exactly_the_files_the_urdf_references(course_package):
    urdf = (course_package / "urdf" / "arm.urdf").read_text()
    referenced = referenced_files(urdf)
    assert referenced and all(uri.startswith("package://arm_description/") for uri in referenced)
    server = FoxgloveServer(port=0, packages={"arm_description": course_package}, assets=referenced)
    try:
        for uri in referenced:
            relative = uri[len("package://arm_description/") :]
            assert server._asset(uri) == (course_package / relative).read_bytes()
        refused = [
            "package://arm_description/package.xml",  # in the package, not referenced
            "package://arm_description/urdf/arm.urdf",
            referenced[0].replace("meshes/", "meshes/../meshes/"),  # same file, other URI
            "file://" + str(course_package / referenced[0].split("/", 3)[-1]),
            "file:///etc/hostname",
        ]
        assert [server._asset(uri) for uri in refused] == [None] * len(refused)
    finally:
        server.close()
