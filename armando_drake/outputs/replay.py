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
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatParams, MeshcatVisualizer
from pydrake.lcm import DrakeLcm
from pydrake.systems.framework import LeafSystem
from pydrake.systems.lcm import LcmInterfaceSystem
from pydrake.visualization import ApplyVisualizationConfig

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
    default; ``ApplyVisualizationConfig`` names them ``meshcat_visualizer(illustration)``)."""
    return [
        system
        for system in diagram.GetSystems()
        if isinstance(system, MeshcatVisualizer) and system.get_name().endswith(f"({REPLAY_LAYER})")
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
    """``config`` (a ``VisualizationConfig``), for a :class:`RecordingMeshcat` with the
    visualizers publishing once a simulated hour (the replay draws its frames after the
    run); unchanged for any other Meshcat."""
    if not getattr(meshcat, "recording_only", False):
        return config
    config = copy.copy(config)
    config.publish_period = RECORDING_ONLY_PUBLISH_PERIOD
    return config


def AddVisualization(
    builder, config, *, plant, scene_graph, meshcat: Meshcat, robot_instances, ground: bool
):
    """Drake's visualization of ``plant`` in ``meshcat`` (``config``: a
    ``VisualizationConfig``), the collision layer hidden; the camera framed on the
    robots of ``robot_instances`` and (with ``ground``) the ground drawn to the scene's
    size when the run starts. Returns the :class:`ReplaySampler` of the plant's state
    at a bounded number of instants, for the replay after the run.

    Drake's visualization also publishes LCM messages (for Meldis); they go to an
    in-process bus, not to LCM's default UDP multicast group, which would join the
    machine's network interface: nothing leaves the loopback unless asked."""
    in_process = DrakeLcm("memq://")
    # The diagram owns the bus (its system keeps it alive as long as the diagram lives).
    builder.AddNamedSystem("lcm_in_process", LcmInterfaceSystem(in_process))
    ApplyVisualizationConfig(
        visualization_for(config, meshcat),
        builder,
        plant=plant,
        scene_graph=scene_graph,
        meshcat=meshcat,
        lcm=in_process,
    )
    meshcat.SetProperty("/drake/proximity", "visible", False)
    AddViewFramer(
        builder, plant, scene_graph, meshcat, robot_instances=robot_instances, ground=ground
    )
    return AddReplaySampler(builder, plant)
