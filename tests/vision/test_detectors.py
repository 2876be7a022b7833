"""The OpenCV detectors in the world: blob centres against the disc's projection with the
camera's true pose and intrinsics, ArUco poses against the marker's true pose, and the
one-line errors of bad vision input."""

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario
from armando_drake.vision.detectors import intrinsic_matrix

QUIET = "logging: {console_rate: 0}\ncamera: {live_view: false}\n"
DISC = "{name: %s, shape: !Cylinder {radius: 0.15, length: 0.05}, xyz: [%g, %g, 0.025], "
DISC += "color: [0.05, 0.15, 0.9, 1.0], collision: false}"


def _world(name: str, override: str, until: float = 0.05):
    scenario = load_scenario(name, QUIET + override)
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.AdvanceTo(until)
    return scenario, world, simulator.get_context()


def X_WC(world, context, camera: str) -> RigidTransform:
    """The camera's true pose in the world."""
    info = world.robot().cameras[camera].info
    plant = world.plant
    X_WL = plant.GetBodyByName(info.link).EvalPoseInWorld(plant.GetMyContextFromRoot(context))
    return X_WL @ info.X_LC()


def project(world, context, camera: str, p_W) -> np.ndarray:
    """Pixel (u, v) of a world point, with the camera's true pose and Drake's intrinsics."""
    p_C = X_WC(world, context, camera).inverse() @ np.asarray(p_W, dtype=float)
    uvw = intrinsic_matrix(world.robot().cameras[camera]) @ p_C
    return uvw[:2] / uvw[2]


@pytest.mark.parametrize(
    "objects, discs",
    [
        ([DISC % ("disc", 0.45, 0.05)], [(0.45, 0.05)]),  # the scenario's
        ([DISC % ("disc", 0.30, -0.12)], [(0.30, -0.12)]),  # moved
        (  # partly occluded by a yellow cube on its rim
            [
                DISC % ("disc", 0.45, 0.0),
                "{name: cube, shape: !Box {size: [0.03, 0.03, 0.03]}, xyz: [0.45, 0.15, 0.065],"
                " color: [0.95, 0.8, 0.1, 1.0]}",
            ],
            [(0.45, 0.0)],
        ),
        ([DISC % ("a", 0.30, 0.15), DISC % ("b", 0.60, -0.15)], [(0.30, 0.15), (0.60, -0.15)]),
    ],
    ids=["disc", "moved", "occluded", "two_discs"],
)
def test_blob_centres_are_the_projected_disc_centres(objects, discs):
    scenario, world, context = _world("vision_blob", f"objects: [{', '.join(objects)}]")
    detection = world.diagram.GetOutputPort("top_camera.keypoints").Eval(context)
    assert len(detection.keypoints) == len(discs), detection
    found = np.array([[k.u, k.v] for k in detection.keypoints])
    for x, y in discs:
        expected = project(world, context, "top_camera", [x, y, 0.05])  # the top face's centre
        distance = np.linalg.norm(found - expected, axis=1).min()
        assert distance <= 2.0, (expected, found)
    diameters = [k.diameter for k in detection.keypoints]
    # The disc's 0.3 m at the camera's 1.18 m: about 0.3 * f / 1.18 px.
    f = intrinsic_matrix(world.robot().cameras["top_camera"])[0, 0]
    assert np.allclose(diameters, 0.3 * f / 1.18, rtol=0.05), diameters
    annotated = world.diagram.GetOutputPort("top_camera.annotated_image").Eval(context).data
    raw = world.diagram.GetOutputPort("top_camera.color_image").Eval(context).data
    assert np.any(annotated[..., :3] != raw[..., :3])  # the keypoints are drawn
    assert world.robot().detectors.blob.frames == 2 and world.robot().detectors.blob.detections == 2
    world.close()


MARKER = "{name: marker, shape: !ArucoMarker {id: %d, side_length: %g}, xyz: [%g, %g, 0.03], "
MARKER += "rpy: [%g, 0.0, %g]}"
# A camera 0.5 m above the marker's face, looking down (on Armando's base_link, 31.3 mm up).
ARUCO = "vision: {blob: null, aruco: {camera: top_camera, marker_id: %d, side_length: %g}}\n"
ARUCO += "cameras: [{name: top_camera, link: base_link, xyz: [0.45, 0.0, %g], rpy: [0, 1.5708, 0]}]"


def _marker_world(x, y, roll=0.0, yaw=0.0, side=0.1, height=0.5, marker_id=201):
    z = 0.0325 + height - 0.0313  # the face's centre 32.5 mm up (above the ground if tilted)
    override = f"objects: [{MARKER % (marker_id, side, x, y, roll, yaw)}]\n"
    override += ARUCO % (marker_id, side, z)
    return _world("vision_blob", override)


@pytest.mark.parametrize(
    "x, y, roll, yaw",
    [(0.45, 0.0, 0.0, 0.0), (0.50, 0.08, 0.0, 0.7), (0.40, -0.05, 0.3, -0.4)],
    ids=["below", "off_centre_turned", "tilted"],
)
def test_marker_pose_within_5_mm_and_2_degrees_at_half_a_metre(x, y, roll, yaw):
    scenario, world, context = _marker_world(x, y, roll, yaw)
    published = world.diagram.GetOutputPort("top_camera.cam_T_marker").Eval(context)
    assert published.count == 2  # a pose per frame (t = 0 and 1/30 s)
    (marker,) = scenario.objects
    X_WM = marker.X_WO() @ marker.shape.X_OM()
    truth = X_WC(world, context, "top_camera").inverse() @ X_WM
    estimate = published.message.pose
    assert 0.45 <= np.linalg.norm(truth.translation()) <= 0.55
    position_error = np.linalg.norm(estimate.translation() - truth.translation())
    angle_error = truth.rotation().inverse().multiply(estimate.rotation()).ToAngleAxis().angle()
    assert position_error <= 0.005, position_error
    assert angle_error <= math.radians(2.0), math.degrees(angle_error)
    in_world = world.diagram.GetOutputPort("top_camera.marker_in_world").Eval(context)
    world_error = np.linalg.norm(in_world.message.pose.translation() - X_WM.translation())
    assert world_error <= 0.005, world_error
    assert in_world.message.frame_id == "world" and published.message.frame_id == "top_camera"
    world.close()


@pytest.mark.parametrize(
    "x, y, side, height",
    [(1.5, 0.0, 0.1, 0.5), (0.45, 0.0, 0.01, 3.0)],
    ids=["out_of_view", "too_far"],
)
def test_marker_out_of_view_or_too_far_publishes_nothing(x, y, side, height):
    scenario, world, context = _marker_world(x, y, side=side, height=height)
    assert world.diagram.GetOutputPort("top_camera.cam_T_marker").Eval(context).count == 0
    assert world.diagram.GetOutputPort("top_camera.marker_in_world").Eval(context).count == 0
    assert (
        world.robot().detectors.aruco.frames == 2 and world.robot().detectors.aruco.detections == 0
    )
    world.close()


@pytest.mark.parametrize(
    "override, message",
    [
        (
            "cameras: [{name: c, link: no_such_link}]",
            "link 'no_such_link' is not a body of model",
        ),
        (
            "objects: [{name: m, shape: !ArucoMarker {dictionary: DICT_4X4_50, id: 50}}]",
            "object 'm': ArucoMarker: id=50 is outside dictionary DICT_4X4_50 (ids 0..49)",
        ),
        (
            "objects: [{name: m, shape: !ArucoMarker {dictionary: DICT_9X9}}]",
            "dictionary='DICT_9X9' is not an OpenCV ArUco dictionary",
        ),
        (
            "cameras: []\nvision: {blob: {camera: top_camera}}",
            "vision.blob.camera='top_camera' is not a camera of the world (none: is "
            "camera.enabled on",
        ),
        (
            "vision: {blob: null, aruco: {camera: top_camera, marker_id: 5000}}",
            "vision.aruco: marker_id=5000 is outside dictionary DICT_ARUCO_ORIGINAL",
        ),
    ],
    ids=["no_link", "id_outside", "no_dictionary", "camera_off", "detector_id_outside"],
)
def test_bad_vision_input_is_a_one_line_error(override, message):
    scenario = load_scenario("vision_blob", QUIET + override)
    with pytest.raises(ScenarioError) as raised:
        MakeWorld(scenario, quiet=True)
    text = str(raised.value)
    assert message in text and "\n" not in text, text


def test_live_view_serves_the_annotated_image_beside_the_raw_one():
    import json
    import urllib.request

    scenario = load_scenario("vision_blob", "logging: {console_rate: 0}\ncamera: {live_view: true}")
    world = MakeWorld(scenario, quiet=True)
    try:
        Simulator(world.diagram).AdvanceTo(0.1)
        with urllib.request.urlopen(f"{world.image_view_url}cameras.json", timeout=5) as page:
            names = [camera["name"] for camera in json.load(page)]
        assert names == ["top_camera", "top_camera_annotated"]
        assert world.image_view.frame_count("top_camera_annotated") >= 3
    finally:
        world.close()
