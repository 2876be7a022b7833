"""--record with perception on: /camera/points (PointCloud2) and /perception/clusters
(MarkerArray), read back with rosbags."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from armando_drake.outputs.recording import message_definition
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario


def test_message_definitions_are_those_of_ros2():
    store = get_typestore(Stores.ROS2_HUMBLE)
    for type_name in ("sensor_msgs/msg/PointCloud2", "visualization_msgs/msg/MarkerArray"):
        expected, _ = store.generate_msgdef(type_name, ros_version=2)
        assert message_definition(type_name) == expected, type_name


def test_recording_holds_the_cloud_and_the_clusters(tmp_path):
    path = tmp_path / "perception.mcap"
    scenario = load_scenario("perception", "logging: {console_rate: 0}")
    world = MakeWorld(scenario, quiet=True, record=path)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(1.05)
    context = simulator.get_context()
    result = world.diagram.GetOutputPort("perception.result").Eval(context)
    in_camera = world.diagram.GetOutputPort("camera.points_in_camera").Eval(context)
    world.close()
    topics = {}
    with AnyReader([path]) as reader:
        for connection, log_time, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append((log_time, connection.msgtype, message))
    points = topics["/camera/points"]
    assert [t for t, _, _ in points] == [0, 1_000_000_000]  # points_record_rate: 1 Hz
    _, kind, cloud = points[-1]
    assert kind == "sensor_msgs/msg/PointCloud2"
    assert (cloud.height, cloud.width, cloud.point_step) == (480, 640, 16)
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "rgb"]
    assert cloud.header.frame_id == "camera_link_optical"
    data = np.frombuffer(cloud.data.tobytes(), dtype=[("xyz", "<f4", 3), ("rgb", "<u4")])
    # The static scene: the recorded cloud is the camera-frame cloud of now.
    np.testing.assert_array_equal(data["xyz"], in_camera.xyzs().T)
    rgb = in_camera.rgbs().astype(np.uint32)
    np.testing.assert_array_equal(data["rgb"], (rgb[0] << 16) | (rgb[1] << 8) | rgb[2])
    clusters = topics["/perception/clusters"]
    assert [t for t, _, _ in clusters] == [k * 100_000_000 for k in range(11)]  # 10 Hz
    _, kind, markers = clusters[-1]
    assert kind == "visualization_msgs/msg/MarkerArray"
    assert markers.markers[0].action == 3  # DELETEALL, then a box and a centroid per cluster
    boxes = [m for m in markers.markers if m.ns == "boxes"]
    centroids = [m for m in markers.markers if m.ns == "centroids"]
    assert len(boxes) == len(centroids) == len(result.clusters) == 3
    for box, centroid, cluster in zip(boxes, centroids, result.clusters, strict=True):
        assert box.header.frame_id == "world" and box.type == 1
        centre = [box.pose.position.x, box.pose.position.y, box.pose.position.z]
        np.testing.assert_allclose(centre, (cluster.lower + cluster.upper) / 2, atol=1e-9)
        size = [box.scale.x, box.scale.y, box.scale.z]
        np.testing.assert_allclose(size, cluster.upper - cluster.lower, atol=1e-9)
        position = [centroid.pose.position.x, centroid.pose.position.y, centroid.pose.position.z]
        assert position == pytest.approx(list(cluster.centroid))
