"""Replays: a run kept as a Meshcat animation, scrubbed live or saved as one HTML page.

While a run simulates, a :class:`ReplaySampler` keeps the plant's state (a
few dozen numbers) at :data:`REPLAY_RATE` frames per second, up to
:data:`MAX_REPLAY_FRAMES` frames: when the run outgrows them it drops every
other frame and samples half as often, so a run of any length keeps between
half and all of that many frames, evenly spaced (a 15 s run keeps every
1/32 s; a one-hour run one frame every 2 s). After the run,
:func:`publish_replay` sets each kept state in the diagram's context and
has Drake's visualizers draw it into Meshcat's recording
(``Meshcat.StartRecording`` without showing it), then ``PublishRecording``
turns it into Meshcat's animation (the *Animations* controls: play, pause,
time scrubber; three.js interpolates between frames), and
:func:`write_replay` saves the scene, its meshes and the animation with
:meth:`Meshcat.StaticHtml` as one file that plays offline in any browser.

During a run, Drake's geometry visualizers draw the scene once, at the start;
on a live Meshcat a :class:`MovedPoses` then sends only the poses that moved
(Drake's visualizers would resend every pose 64 times a second, more than a
browser without a graphics card keeps up with: the page would fall ever
further behind the run).

A run with a live Meshcat replays into it (the browser keeps the animation
after the run). A run without one (``--no-meshcat``) gets a
:class:`RecordingMeshcat` just for the replay: it listens on an ephemeral
port of localhost, and its visualizers draw nothing during the run (one
publish a simulated hour): the replay costs a run as fast as possible about
10 % more CPU time (the visualizers and the sampler in the diagram).
``python -m armando_drake.world --no-replay`` skips all of it.
"""

from __future__ import annotations

import copy
import logging
import time
from pathlib import Path

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import Meshcat, MeshcatParams, MeshcatVisualizer, QueryObject, Role
from pydrake.lcm import DrakeLcm
from pydrake.math import RigidTransform
from pydrake.systems.framework import LeafSystem
from pydrake.systems.lcm import LcmInterfaceSystem
from pydrake.visualization import ApplyVisualizationConfig

from armando_drake.outputs.follow import AddFollowCamera
from armando_drake.outputs.view import AddViewFramer
from armando_drake.tools.files import writing

REPLAY_FILE = "replay.html"
REPLAY_RATE = 32.0  # [frames/s] sampling rate of a replay until it outgrows its frames
MAX_REPLAY_FRAMES = 2048  # frames a replay keeps at most, whatever the run's length
REPLAY_LAYER = "illustration"  # the geometry layer the replay animates (the others stay)
RECORDING_ONLY_PUBLISH_PERIOD = 3600.0  # [s] the visualizers' period with nobody watching


class RecordingMeshcat(Meshcat):
    """A Meshcat nobody watches, for recording: localhost, ephemeral port, no log line.

    The world builder starts no camera live view for it (``recording_only``)
    and has its visualizers publish only once a simulated hour.
    """

    recording_only = True

    def __init__(self):
        drake_logger = logging.getLogger("drake")
        level = drake_logger.level
        drake_logger.setLevel(logging.WARNING)  # no "Meshcat listening for connections at"
        try:
            super().__init__(MeshcatParams(host="localhost", port=0))
        finally:
            drake_logger.setLevel(level)


class ReplaySampler(LeafSystem):
    """Keeps the plant's state at a bounded number of evenly spaced instants.

    Input ports:
      plant_state: the plant's positions and velocities.

    Every ``1 / rate`` seconds (a publish event) it keeps the time and the
    state, if the time has reached the next sample; when it holds more than
    ``max_frames`` samples it drops every other one and doubles its sampling
    interval. :meth:`frames` returns what it kept.
    """

    def __init__(self, *, state_size: int, rate: float = REPLAY_RATE, max_frames=None):
        super().__init__()
        max_frames = MAX_REPLAY_FRAMES if max_frames is None else max_frames
        if not rate > 0:
            raise ValueError(f"rate={rate!r} must be positive [frames/s]")
        if max_frames < 2:
            raise ValueError(f"max_frames={max_frames!r} must be at least 2")
        self._state_port = self.DeclareVectorInputPort("plant_state", state_size)
        self._base_interval = 1.0 / rate
        self._max_frames = int(max_frames)
        self.DeclarePeriodicPublishEvent(self._base_interval, 0.0, self._Sample)
        self.DeclareInitializationPublishEvent(self._Start)
        self._reset()

    def _reset(self) -> None:
        self._interval = self._base_interval  # [s] between kept samples now
        self._next = 0.0  # [s] time of the next sample to keep
        self._times = np.empty(self._max_frames + 1)
        self._states = np.empty((self._max_frames + 1, self._state_port.size()))
        self._count = 0

    def _Start(self, context) -> None:
        self._reset()
        self._Sample(context)

    def _Sample(self, context) -> None:
        time = context.get_time()
        if time < self._next - 1e-9 * self._interval:
            return
        self._times[self._count] = time
        self._states[self._count] = self._state_port.Eval(context)
        self._count += 1
        self._next = time + self._interval
        if self._count > self._max_frames:
            # Keep the samples on the doubled grid (every other one, from the first).
            kept = (self._count + 1) // 2
            self._times[:kept] = self._times[: self._count : 2]
            self._states[:kept] = self._states[: self._count : 2]
            self._count = kept
            self._interval *= 2.0
            self._next = self._times[kept - 1] + self._interval

    @property
    def interval(self) -> float:
        """[s] between the samples kept now."""
        return self._interval

    def frames(self) -> tuple[np.ndarray, np.ndarray]:
        """The kept samples: times [s] (n,) and plant states (n, state size), copies."""
        return self._times[: self._count].copy(), self._states[: self._count].copy()


def AddReplaySampler(builder, plant, *, rate: float = REPLAY_RATE, max_frames=None):
    """Adds a :class:`ReplaySampler` of ``plant``'s state to ``builder``; returns it."""
    sampler = builder.AddSystem(
        ReplaySampler(state_size=plant.num_multibody_states(), rate=rate, max_frames=max_frames)
    )
    sampler.set_name("replay_sampler")
    builder.Connect(plant.get_state_output_port(), sampler.get_input_port())
    return sampler


def _visualizers(diagram) -> list:
    """The Meshcat visualizers of ``diagram``'s illustration layer (the one shown by
    default; ``ApplyVisualizationConfig`` names them ``meshcat_visualizer(illustration)``)
    and the views that animate themselves in a replay (``replayed``: a navigation's
    plans)."""
    return [
        system
        for system in diagram.GetSystems()
        if (
            isinstance(system, MeshcatVisualizer)
            and system.get_name().endswith(f"({REPLAY_LAYER})")
        )
        or getattr(system, "replayed", False)
    ]


def publish_replay(meshcat: Meshcat, diagram, plant, sampler: ReplaySampler, context) -> int:
    """Draws the sampler's frames into ``meshcat``'s recording and publishes it as the
    animation (the live page, if one is open, gets the *Animations* controls).

    ``context``: a root context of ``diagram`` (it is cloned; the run's is not
    changed). Returns the number of frames.
    """
    times, states = sampler.frames()
    if not len(times):
        return 0
    context = context.Clone()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    visualizers = [
        (system, system.GetMyContextFromRoot(context)) for system in _visualizers(diagram)
    ]
    meshcat.DeleteRecording()
    meshcat.StartRecording(
        frames_per_second=1.0 / sampler.interval, set_visualizations_while_recording=False
    )
    try:
        for time, state in zip(times, states, strict=True):
            context.SetTime(float(time))
            plant.SetPositionsAndVelocities(plant_context, state)
            for system, system_context in visualizers:
                system.ForcedPublish(system_context)
    finally:
        meshcat.StopRecording()
    meshcat.PublishRecording()  # Meshcat keeps the animation for the page and StaticHtml
    meshcat.DeleteRecording()  # the recording's frames themselves are no longer needed
    _release_freed_memory()
    return len(times)


def _release_freed_memory() -> None:
    """Hands the heap's free pages back to the system (glibc's ``malloc_trim``): the
    recording is many small blocks, which ``free`` keeps in the process otherwise."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        ctypes.CDLL(name).malloc_trim(0)
    except (OSError, AttributeError, TypeError):  # not glibc: nothing to do
        pass


def write_replay(meshcat: Meshcat, path: str | Path) -> Path:
    """Writes the scene with the published animation to ``path``, one self-contained page."""
    path = Path(path)
    with writing(path):
        path.write_text(meshcat.StaticHtml(), encoding="utf-8")
    _release_freed_memory()  # the page's text, built and copied in pieces
    return path


def visualization_for(config, meshcat: Meshcat):
    """``config`` (a ``VisualizationConfig``) for Drake's visualizers on ``meshcat``: the
    geometry layers publish once a simulated hour (they draw the scene at the start, and
    the replay's frames after the run); on a live Meshcat a :class:`MovedPoses` streams
    what moves and the contact forces keep ``config``'s period (they are published by
    :func:`contacts_only`), on a :class:`RecordingMeshcat` they are drawn no more often
    than the layers."""
    live = not getattr(meshcat, "recording_only", False)
    config = copy.copy(config)
    config.publish_period = RECORDING_ONLY_PUBLISH_PERIOD
    config.publish_contacts = config.publish_contacts and not live
    return config


def contacts_only(config):
    """``config`` with only the contact forces published, at its own period: they
    appear and vanish, which :class:`MovedPoses` does not stream."""
    config = copy.copy(config)
    config.publish_illustration = False
    config.publish_proximity = False
    config.publish_inertia = False
    return config


# Meshcat layers of Drake's visualization: (name, role, whether geometry that names no
# layer in its ("meshcat", "accepting") property is drawn there).
LAYERS = (
    ("illustration", Role.kIllustration, True),
    ("proximity", Role.kProximity, True),
    ("inertia", Role.kIllustration, False),
)
LAYER_PREFIX = "/drake"  # Meshcat path of the layers (Drake's default prefix)
CONTACT_FORCES_PATH = f"{LAYER_PREFIX}/contact_forces"  # Drake's ContactVisualizer's
POSE_TOLERANCE = 1e-6  # [m] (and [rad] about) a frame moved less is not sent again
RATE_INTERVAL = 1.0  # [s] of wall-clock time between real-time rates sent to the page


def layer_paths(inspector, config) -> dict:
    """Meshcat paths of the moving frames of each layer ``config`` (a
    ``VisualizationConfig``) publishes, as Drake's ``MeshcatVisualizer`` names them
    (the layer's prefix, then the frame's name with ``::`` as ``/``): {frame id:
    [path, ...]}. Frames fixed to the world are left out."""
    published = {
        "illustration": config.publish_illustration,
        "proximity": config.publish_proximity,
        "inertia": config.publish_inertia,
    }
    paths: dict = {}
    world = inspector.world_frame_id()
    for layer, role, unspecified in LAYERS:
        if not published[layer]:
            continue
        frames = set()
        for geometry in inspector.GetAllGeometryIds(role):
            properties = inspector.GetProperties(geometry, role)
            accepting = properties.GetPropertyOrDefault("meshcat", "accepting", "")
            if accepting == layer or (not accepting and unspecified):
                frames.add(inspector.GetFrameId(geometry))
        for frame in frames - {world}:
            name = inspector.GetName(frame).replace("::", "/")
            paths.setdefault(frame, []).append(f"{LAYER_PREFIX}/{layer}/{name}")
    return paths


class MovedPoses(LeafSystem):
    """Streams to a live Meshcat the poses of the frames that moved.

    Drake's ``MeshcatVisualizer`` sends every frame's pose at each publish, moved or
    not: about 40 messages 64 times a second for Armando's three layers, more than a
    browser without a graphics card draws, so the page falls ever further behind the
    run (it shows the start while the arm has long moved). This system sends, every
    ``period``, only the poses that changed by more than :data:`POSE_TOLERANCE` since
    they were last sent, at the paths Drake's visualizers drew them
    (:func:`layer_paths`): a still robot costs the page nothing, a jog only the links
    it moves. It also sends the real-time rate (the page's plot) once a second.

    Input ports:
      query: the SceneGraph's query object.
    """

    def __init__(self, *, meshcat: Meshcat, paths: dict, period: float):
        super().__init__()
        if not period > 0:
            raise ValueError(f"period={period!r} must be positive [s]")
        self._meshcat = meshcat
        self._paths = dict(paths)
        self._query_port = self.DeclareAbstractInputPort("query", Value[QueryObject]())
        self.DeclareInitializationPublishEvent(self._Start)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._Send)
        self._sent = {}  # frame id -> the pose last sent (X_WF)
        self._rate_mark = None  # (wall-clock time, simulated time) of the last rate sent
        self.messages = 0  # poses sent since the start

    def _Start(self, context) -> None:
        # Drake's visualizers draw every pose at the start (their initialization).
        query = self._query_port.Eval(context)
        # Copies: the query's poses are views of a cache the next step overwrites.
        self._sent = {frame: RigidTransform(query.GetPoseInWorld(frame)) for frame in self._paths}
        self._rate_mark = (time.monotonic(), context.get_time())
        self.messages = 0

    def _Send(self, context) -> None:
        query = self._query_port.Eval(context)
        for frame, paths in self._paths.items():
            X_WF = RigidTransform(query.GetPoseInWorld(frame))
            if X_WF.IsNearlyEqualTo(self._sent[frame], POSE_TOLERANCE):
                continue
            self._sent[frame] = X_WF
            for path in paths:
                self._meshcat.SetTransform(path, X_WF)
            self.messages += len(paths)
        now = time.monotonic()
        wall, simulated = self._rate_mark
        if now - wall >= RATE_INTERVAL:
            self._meshcat.SetRealtimeRate((context.get_time() - simulated) / (now - wall))
            self._rate_mark = (now, context.get_time())


def AddVisualization(
    builder,
    config,
    *,
    plant,
    scene_graph,
    meshcat: Meshcat,
    robot_instances,
    ground: bool,
    mobile_bases=(),
):
    """Drake's visualization of ``plant`` in ``meshcat`` (``config``: a
    ``VisualizationConfig``), the collision layer hidden; the camera framed on the
    robots of ``robot_instances`` and the objects, and (with ``ground``) the ground drawn
    to the scene's size when the run starts. Drake's geometry visualizers draw the scene
    at the start (and the replay after the run); on a live Meshcat a
    :class:`MovedPoses` streams what moves at ``config.publish_period``. Returns the
    :class:`ReplaySampler` of the plant's state at a bounded number of instants, for the
    replay after the run.

    Drake's visualization also publishes LCM messages (for Meldis); they go to an
    in-process bus, not to LCM's default UDP multicast group, which would join the
    machine's network interface: nothing leaves the loopback unless asked."""
    in_process = DrakeLcm("memq://")
    # The diagram owns the bus (its system keeps it alive as long as the diagram lives).
    builder.AddNamedSystem("lcm_in_process", LcmInterfaceSystem(in_process))
    live = not getattr(meshcat, "recording_only", False)
    parts = [visualization_for(config, meshcat)]
    parts += [contacts_only(config)] if live and config.publish_contacts else []
    for part in parts:
        ApplyVisualizationConfig(
            part, builder, plant=plant, scene_graph=scene_graph, meshcat=meshcat, lcm=in_process
        )
    meshcat.SetProperty("/drake/proximity", "visible", False)
    if live:
        paths = layer_paths(scene_graph.model_inspector(), config)
        poses = builder.AddNamedSystem(
            "meshcat_moved_poses",
            MovedPoses(meshcat=meshcat, paths=paths, period=config.publish_period),
        )
        builder.Connect(scene_graph.get_query_output_port(), poses.get_input_port())
    framer = AddViewFramer(
        builder,
        plant,
        scene_graph,
        meshcat,
        robot_instances=robot_instances,
        ground=ground,
        arena=bool(mobile_bases),
    )
    if mobile_bases and live:  # (a recording draws no contact forces)
        hidden = [CONTACT_FORCES_PATH]
        AddFollowCamera(builder, plant, meshcat, mobile_bases, framer=framer, hidden=hidden)
    return AddReplaySampler(builder, plant)
