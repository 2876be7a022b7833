"""An X display for Drake's OpenGL renderer on a machine without a screen.

Drake has two renderers for cameras: ``RenderEngineVtk``, which renders
headless through EGL, and ``RenderEngineGl``, which needs an X display (GLX)
but is much faster on a CPU-only machine (about 95 against 37 frames/s at
640 x 480 on our 2-core machines: the VTK path antialiases every frame).
:func:`ensure_display` gives the GL renderer a display: the user's own when
``DISPLAY`` is set, otherwise a private ``Xvfb`` (Debian package ``xvfb``)
started for this process and stopped with it.
"""

from __future__ import annotations

import ctypes
import logging
import os
import select
import shutil
import signal
import socket
import subprocess
import time

_logger = logging.getLogger(__name__)

XVFB_SCREEN = "1280x1024x24"  # the virtual screen; cameras render off-screen anyway
START_TIMEOUT = 10.0  # [s] for Xvfb to report its display number
START_ATTEMPTS = 3  # Xvfb servers tried before giving up on the OpenGL renderer

_started: subprocess.Popen | None = None  # the Xvfb this process started, if any
_gl_works: dict[str, bool] = {}  # by DISPLAY value


class DisplayError(RuntimeError):
    """No X display could be found or started; the message says what to install."""


def _die_with_parent() -> None:
    """In the child, before exec: ask Linux to SIGTERM it when its parent dies."""
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def start_xvfb() -> str:
    """Starts ``Xvfb`` on a free display number; returns it (e.g. ``":1"``).

    The server stops when this process ends, however it ends: Linux sends it
    SIGTERM when its parent dies. (Not at ``atexit``: Drake's OpenGL context
    still talks to the display while the process tears down, and Xlib ends a
    process whose display went away with exit status 1.)
    """
    global _started
    executable = shutil.which("Xvfb")
    if executable is None:
        raise DisplayError("Xvfb is not installed (Debian: apt install xvfb)")
    read_end, write_end = os.pipe()
    try:
        process = subprocess.Popen(
            [executable, "-displayfd", str(write_end), "-screen", "0", XVFB_SCREEN]
            + ["-nolisten", "tcp", "-noreset"],
            pass_fds=(write_end,),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=_die_with_parent,
        )
        os.close(write_end)
        write_end = -1
        number = _read_line(read_end, time.monotonic() + START_TIMEOUT)
    finally:
        os.close(read_end)
        if write_end >= 0:
            os.close(write_end)
    if not number.isdigit() or not _accepts_clients(int(number), process):
        process.kill()
        raise DisplayError(f"Xvfb did not start a display within {START_TIMEOUT:g} s")
    _started = process
    display = f":{number}"
    _logger.info("started Xvfb on display %s for the OpenGL camera renderer", display)
    return display


def _read_line(fd: int, deadline: float) -> str:
    """The first line written to ``fd`` before ``deadline``, without its newline. Xvfb
    writes the number and the newline apart, and exits if the second write finds the
    pipe closed, so the reader must wait for the whole line."""
    data = b""
    while b"\n" not in data:
        ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        chunk = os.read(fd, 64) if ready else b""
        if not chunk:
            break
        data += chunk
    return data.decode(errors="replace").strip()


def _accepts_clients(number: int, process: subprocess.Popen) -> bool:
    """Waits until display ``number`` accepts connections on its Unix socket (Xvfb
    reports the number a moment before that)."""
    path = f"/tmp/.X11-unix/X{number}"
    deadline = time.monotonic() + START_TIMEOUT
    while time.monotonic() < deadline and process.poll() is None:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
            try:
                client.connect(path)
                return True
            except OSError:
                time.sleep(0.02)
    return False


def stop_xvfb() -> None:
    """Stops the Xvfb :func:`start_xvfb` started, if it runs."""
    global _started
    if _started is not None and _started.poll() is None:
        _started.terminate()
        try:
            _started.wait(timeout=5)
        except subprocess.TimeoutExpired:
            _started.kill()
    _started = None


def gl_renderer_works() -> bool:
    """Whether Drake's ``RenderEngineGl`` can be made on the current ``DISPLAY``."""
    display = os.environ.get("DISPLAY", "")
    if not display:
        return False
    if display not in _gl_works:
        from pydrake.geometry import MakeRenderEngineGl, RenderEngineGlParams

        try:
            MakeRenderEngineGl(RenderEngineGlParams())
            _gl_works[display] = True
        except RuntimeError as error:
            _logger.debug("RenderEngineGl on DISPLAY=%s: %s", display, error)
            _gl_works[display] = False
    return _gl_works[display]


def ensure_display() -> str:
    """An X display on which ``RenderEngineGl`` works: ``DISPLAY`` if it does, else a
    private Xvfb (``DISPLAY`` is set to it). Raises :class:`DisplayError` otherwise."""
    if gl_renderer_works():
        return os.environ["DISPLAY"]
    if _started is not None and _started.poll() is None:
        raise DisplayError(f"RenderEngineGl does not work on Xvfb {os.environ.get('DISPLAY')}")
    previous = os.environ.get("DISPLAY")
    # A server can stop right after reporting its number (it did, when the number was
    # read before its newline: see _read_line); a fresh one is tried before giving up.
    for attempt in range(1, START_ATTEMPTS + 1):
        display = start_xvfb()
        os.environ["DISPLAY"] = display
        deadline = time.monotonic() + 2.0
        while True:
            _gl_works.pop(display, None)
            if gl_renderer_works():
                return display
            if time.monotonic() > deadline:
                break
            time.sleep(0.1)
        _logger.debug("RenderEngineGl failed on Xvfb %s (attempt %d)", display, attempt)
        stop_xvfb()
    if previous is None:
        del os.environ["DISPLAY"]
    else:
        os.environ["DISPLAY"] = previous
    raise DisplayError(
        f"RenderEngineGl does not work on Xvfb (tried {START_ATTEMPTS} times; is Mesa's "
        "libgl1-mesa-dri installed?)"
    )
