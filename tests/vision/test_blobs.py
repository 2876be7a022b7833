"""The blob detector's shortcut (OpenCV once per distinct binary image) against OpenCV's
SimpleBlobDetector over every threshold: the same keypoints on rendered frames and on
synthetic images with every grey level, and far fewer OpenCV runs on a rendered frame."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario
from armando_drake.vision.blobs import LevelBlobDetector
from armando_drake.vision.detectors import BlobDetector

cv2 = pytest.importorskip("cv2")

QUIET = "logging: {console_rate: 0}\ncamera: {live_view: false}\n"
DISC = "{name: %s, shape: !Cylinder {radius: %g, length: 0.05}, xyz: [%g, %g, 0.025], "
DISC += "color: [%g, %g, %g, 1.0], collision: false}"
SCENES = {
    "disc": [DISC % ("disc", 0.15, 0.45, 0.05, 0.05, 0.15, 0.9)],
    "moved": [DISC % ("disc", 0.15, 0.30, -0.12, 0.05, 0.15, 0.9)],
    "occluded": [
        DISC % ("disc", 0.15, 0.45, 0.0, 0.05, 0.15, 0.9),
        "{name: cube, shape: !Box {size: [0.03, 0.03, 0.03]}, xyz: [0.45, 0.15, 0.065],"
        " color: [0.95, 0.8, 0.1, 1.0]}",
    ],
    "three_discs_and_a_marker": [
        DISC % ("a", 0.15, 0.30, 0.15, 0.05, 0.15, 0.9),
        DISC % ("b", 0.08, 0.62, -0.15, 0.6, 0.1, 0.1),
        DISC % ("c", 0.05, 0.30, -0.2, 0.3, 0.3, 0.3),
        "{name: marker, shape: !ArucoMarker {}, xyz: [0.6, 0.15, 0.0025]}",
    ],
}


def _detectors(**params) -> tuple[BlobDetector, BlobDetector]:
    """(shortcut, SimpleBlobDetector as it is) with the seed's parameters."""
    common = dict(width=640, height=480, frame_rate=30.0, **params)
    return (
        BlobDetector(skip_repeated_thresholds=True, **common),
        BlobDetector(skip_repeated_thresholds=False, **common),
    )


def _same(fast, plain) -> float:
    """Largest difference [px] between two keypoint lists in the same order."""
    assert len(fast) == len(plain), (fast, plain)
    if not fast:
        return 0.0
    a = np.array([[k.u, k.v, k.diameter] for k in fast])
    b = np.array([[k.u, k.v, k.diameter] for k in plain])
    return float(np.abs(a - b).max())


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_shortcut_gives_simple_blob_detectors_keypoints_on_rendered_frames(scene):
    world = MakeWorld(
        load_scenario("vision_blob", QUIET + f"objects: [{', '.join(SCENES[scene])}]"),
        quiet=True,
    )
    try:
        simulator = Simulator(world.diagram)
        simulator.AdvanceTo(0.05)
        rgba = world.diagram.GetOutputPort("top_camera.color_image").Eval(simulator.get_context())
        bgr = cv2.cvtColor(np.asarray(rgba.data), cv2.COLOR_RGBA2BGR)
    finally:
        world.close()
    fast, plain = _detectors()
    found, expected = fast.detect(bgr), plain.detect(bgr)
    assert expected  # the scene's discs are found
    assert _same(found, expected) <= 0.01
    # A rendered frame has few grey levels: OpenCV ran on a few of the 249 thresholds.
    assert fast._levels.binary_images <= 25, fast._levels.binary_images


def _synthetic(seed: int, posterise: bool) -> np.ndarray:
    """Blurred discs of random greys on a light ground, with noise (every grey level)
    or posterised to 12 levels."""
    rng = np.random.default_rng(seed)
    grey = np.full((480, 640), 220, np.uint8)
    for _ in range(8):
        centre = (int(rng.integers(40, 600)), int(rng.integers(40, 440)))
        cv2.circle(grey, centre, int(rng.integers(8, 50)), int(rng.integers(0, 180)), -1)
    grey = cv2.GaussianBlur(grey, (0, 0), float(rng.uniform(0.5, 3.0)))
    if posterise:
        return (grey // 20 * 20).astype(np.uint8)
    return np.clip(grey + rng.normal(0.0, 1.0, grey.shape), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("posterise", [False, True], ids=["noisy", "posterised"])
def test_shortcut_groups_centres_as_opencv_does(posterise):
    fast, plain = _detectors()
    counts = []
    for seed in range(4):
        grey = _synthetic(seed, posterise)
        found, expected = fast.detect(grey), plain.detect(grey)
        counts.append(len(expected))
        assert _same(found, expected) <= 0.01, seed
    assert sum(counts) >= 12  # several blobs per image, grouped over many thresholds


def test_shortcut_follows_other_thresholds_and_repeatability():
    """Fractional thresholds, a coarse step and minRepeatability 4 / minDistBetweenBlobs 25."""
    params = cv2.SimpleBlobDetector_Params()
    params.minThreshold, params.maxThreshold, params.thresholdStep = 10.5, 200.0, 7.25
    params.minRepeatability, params.minDistBetweenBlobs = 4, 25.0
    params.filterByArea, params.minArea = True, 50.0
    params.filterByInertia = False
    plain = cv2.SimpleBlobDetector_create(params)
    fast = LevelBlobDetector(params)
    for seed in range(3):
        for posterise in (False, True):
            grey = _synthetic(seed, posterise)
            expected = [(k.pt[0], k.pt[1], k.size) for k in plain.detect(grey)]
            found = fast.detect(grey)
            assert len(found) == len(expected)
            if expected:
                assert np.abs(np.array(found) - np.array(expected)).max() <= 0.01


def test_a_frame_equal_to_the_last_one_reuses_its_keypoints_and_annotated_image():
    from pydrake.systems.sensors import ImageRgba8U

    detector = BlobDetector(width=64, height=48, frame_rate=30.0, min_area=10.0)
    image = ImageRgba8U(64, 48)
    image.mutable_data[:] = 255
    cv2.circle(image.mutable_data, (30, 20), 8, (0, 0, 0, 255), -1)
    simulator = Simulator(detector)
    context = simulator.get_mutable_context()
    detector.get_input_port(0).FixValue(context, image)
    simulator.AdvanceTo(0.1)  # frames at 1e-4, 1/30 + 1e-4, 2/30 + 1e-4
    assert detector.frames == 3 and detector.last_frame.hits == 2
    (first,) = detector.history[0].keypoints
    grey = cv2.cvtColor(image.data, cv2.COLOR_RGBA2GRAY)
    assert first == detector.detect(grey)[0]
    assert all(d.keypoints == (first,) for d in detector.history)
    assert [d.stamp for d in detector.history] == pytest.approx(
        [1e-4, 1 / 30 + 1e-4, 2 / 30 + 1e-4]
    )
    moved = ImageRgba8U(64, 48)
    moved.mutable_data[:] = 255
    cv2.circle(moved.mutable_data, (20, 25), 8, (0, 0, 0, 255), -1)
    detector.get_input_port(0).FixValue(context, moved)
    simulator.AdvanceTo(0.11)  # a new frame: detected anew
    assert detector.frames == 4 and detector.last_frame.hits == 2
    (second,) = detector.history[-1].keypoints
    assert (second.u, second.v) == pytest.approx((20.0, 25.0), abs=0.5)
    annotated = detector.GetOutputPort("annotated_image").Eval(context).data
    assert np.any(annotated != moved.data)  # the keypoint drawn
