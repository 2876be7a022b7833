"""The scenario's ``camera:`` section: the description's cameras, their view and frames."""

import dataclasses as dc

from armando_drake.description.camera_sensors import RENDERERS
from armando_drake.tools.schema import param

# No `from __future__ import annotations` here: yaml_load_typed reads the dataclass
# field types at run time and does not resolve string annotations.


@dc.dataclass
class CameraSettings:
    """The camera sensors described in the robot's URDF."""

    # Whether the <sensor type="camera"> blocks become Drake RgbdSensors.
    enabled: bool = False
    # Whether depth images are rendered too.
    depth: bool = True
    # Whether the live view of the camera is served on localhost without Meshcat too
    # (with Meshcat on it always is; the CLI's --camera-view sets it).
    live_view: bool = False
    # Folder where colour frames (PNG) and depth (16-bit PNG, millimetres) are
    # saved; "" = not saved.
    save_frames: str = ""
    # Rate at which frames are saved [Hz]; 0 = the camera's own rate.
    save_rate: float = param(0.0, unit="Hz", ge=0)
    # Renderer: "gl" (Drake's OpenGL engine, on DISPLAY or a private Xvfb), "vtk"
    # (VTK through EGL, no display needed) or "auto" (gl when possible, else vtk).
    renderer: str = param("auto", choices=RENDERERS)
    # For interactive runs only: every camera renders at most at this rate [Hz] instead
    # of its own (its detectors and readers follow); 0 = the cameras' own rates, the
    # default. What the detectors see then differs from the scenario's, so the run's log
    # warns and summary.json's "interactive" says it (the CLI's --camera-max-rate).
    max_rate: float = param(0.0, unit="Hz", ge=0)
    # Whether VTK cameras antialias their colour frames with VTK's FXAA pass, as Drake's
    # RenderEngineVtk does. Off by default: the pass costs about 43 ms of CPU per 640 x
    # 480 frame on a machine without a GPU, and OpenGL cameras have no antialiasing, so
    # both renderers give the same hard edges (armando_drake/sensors/antialiasing.py).
    # summary.json's "cameras" says which was used.
    antialiasing: bool = False
