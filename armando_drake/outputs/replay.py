"""Replays: a run saved as one self-contained HTML page that plays offline.

While a run simulates, Meshcat records every pose the visualizer sends
(``Meshcat.StartRecording``); afterwards the recording becomes Meshcat's
animation (``PublishRecording``) and :meth:`Meshcat.StaticHtml` writes the
scene, its meshes, the animation and the viewer's JavaScript into one file.
Opened from disk in any browser (no server, no network) it shows the world
and plays the run with Meshcat's "Animations" controls (play, pause, time
scrubber).

A run with a live Meshcat records into it (what the browser shows is
unchanged). A run without one (``--no-meshcat``) gets a private Meshcat
just for recording: it listens on an ephemeral port of localhost and sends
nothing while recording; it costs about 30 % more wall time in a run as
fast as possible (Drake's visualizer drawing at 64 frames per second).
``python -m armando_drake.world --no-replay`` skips all of it.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pydrake.geometry import Meshcat, MeshcatParams

REPLAY_FILE = "replay.html"


class RecordingMeshcat(Meshcat):
    """A Meshcat nobody watches, for recording: localhost, ephemeral port, no log line.

    The world builder starts no camera live view for it (``recording_only``).
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


def start_replay(meshcat: Meshcat, *, live: bool = True) -> None:
    """Starts recording what the visualizer sends; ``live``: keep showing it too."""
    meshcat.StartRecording(set_visualizations_while_recording=live)


def write_replay(meshcat: Meshcat, path: str | Path) -> Path:
    """Stops recording and writes the scene with the recorded animation to ``path``.

    The animation also plays in the live Meshcat page, if one is open.
    """
    meshcat.StopRecording()
    meshcat.PublishRecording()
    path = Path(path)
    path.write_text(meshcat.StaticHtml(), encoding="utf-8")
    return path
