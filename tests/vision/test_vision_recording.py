"""--record with an ArUco detector: the annotated image, the marker's pose in the camera
and in the world, and the scenario camera's camera_info, read back with rosbags."""

import numpy as np
from pydrake.systems.analysis import Simulator
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from armando_drake.outputs.recording import message_definition
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario
from armando_drake.vision.detectors import intrinsic_matrix

OVERRIDE = """logging: {console_rate: 0}
camera: {live_view: false}
objects: [{name: marker, shape: !ArucoMarker {}, xyz: [0.45, 0.02, 0.0025], rpy: [0, 0, 0.3]}]
cameras: [{name: top_camera, link: base_link, xyz: [0.45, 0.0, 0.4762], rpy: [0, 1.5708, 0]}]
vision: {blob: null, aruco: {camera: top_camera}}
"""


def test_pose_stamped_definition_is_that_of_ros2():
    store = get_typestore(Stores.ROS2_HUMBLE)
    expected, _ = store.generate_msgdef("geometry_msgs/msg/PoseStamped", ros_version=2)
    assert message_definition("geometry_msgs/msg/PoseStamped") == expected


def test_recording_holds_the_annotated_image_the_poses_and_the_intrinsics(tmp_path):
    path = tmp_path / "vision.mcap"
    scenario = load_scenario("vision_blob", OVERRIDE)
    world = MakeWorld(scenario, quiet=True, record=path)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(0.11)  # frames at 0, 1/30, 2/30 and 3/30 s
    context = simulator.get_context()
    latest = world.diagram.GetOutputPort("top_camera.cam_T_marker").Eval(context).message
    K = intrinsic_matrix(world.robot().cameras["top_camera"])
    world.close()
    topics = {}
    with AnyReader([path]) as reader:
        for connection, _, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append((connection.msgtype, message))
    poses = topics["/aruco_single/pose"]
    assert len(poses) == 4 and poses[0][0] == "geometry_msgs/msg/PoseStamped"
    pose = poses[-1][1]
    assert pose.header.frame_id == "top_camera"
    position = [pose.pose.position.x, pose.pose.position.y, pose.pose.position.z]
    np.testing.assert_allclose(position, latest.pose.translation(), atol=1e-12)
    assert abs(position[2] - 0.5) < 0.01  # [m] the camera is 0.5 m above the face
    assert len(topics["/aruco_single/pose_world"]) == 4
    kind, image = topics["/image_converter/output_video"][-1]
    assert kind == "sensor_msgs/msg/Image" and (image.width, image.height) == (640, 480)
    _, info = topics["/top_camera/camera_info"][-1]
    np.testing.assert_allclose(np.reshape(info.k, (3, 3)), K)
