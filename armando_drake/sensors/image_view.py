"""Live camera view in the browser (the ``rqt_image_view`` step) and frame saving.

:class:`ImageViewServer` is a small HTTP server on 127.0.0.1 (standard library
``http.server`` in a background thread; ``host``: where Meshcat listens, ``--host``) serving

- ``/``: a page showing every camera (colour, and depth if published),
  refreshed at the camera rate, with the camera name, image size and
  simulation time;
- ``/camera/<name>.png``: the latest colour frame;
- ``/camera/<name>/depth.png``: the latest depth frame as 8-bit grey (near =
  bright, no reading = black), scaled to the frame's own depth range;
- ``/camera/<name>.json`` and ``/cameras.json``: frame metadata.

:class:`ImageViewPublisher` is the Drake system that hands frames to it: a
periodic publish event at the view rate copies the images; PNG encoding
(Pillow) happens only when a browser asks, in the server thread.
:class:`FrameSaver` writes frames to a directory instead (colour PNG, depth as
16-bit PNG in millimetres or float32 ``.npy`` in metres).

Both systems publish a small fraction of a period after each camera sample, so
that they see the image sampled at that tick (Drake handles a publish event
due at time t before the updates due at t).
"""

from __future__ import annotations

import html
import io
import json
import logging
import os
import socket
import threading
import time as _time
import urllib.parse
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np
from PIL import Image
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.sensors import ImageDepth32F, ImageRgba8U

from armando_drake.sensors.camera import read_color
from armando_drake.tools.cli import server_url, server_urls

_logger = logging.getLogger(__name__)

# Publish this fraction of a period after the camera samples (see module doc).
PUBLISH_OFFSET_FRACTION = 1e-3
# zlib level of every PNG written or served: 1, the fastest. An 800 x 800 noisy colour
# frame: 107 ms and 880 KiB at level 1, 523 ms and 750 KiB at Pillow's default 6.
PNG_LEVEL = 1
# Depth PNG files store millimetres in 16 bits; 0 = no reading.
DEPTH_PNG_SCALE = 1000.0  # [units per m]


def color_png(rgba: np.ndarray) -> bytes:
    """PNG bytes of an RGBA8 image (alpha dropped)."""
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgba[:, :, :3])).save(
        buffer, format="PNG", compress_level=PNG_LEVEL
    )
    return buffer.getvalue()


def depth_preview_png(depth: np.ndarray) -> bytes:
    """PNG bytes of a depth image [m] as 8-bit grey: near bright, no reading black."""
    depth = np.asarray(depth, dtype=np.float32).reshape(depth.shape[0], depth.shape[1])
    valid = np.isfinite(depth) & (depth > 0)
    grey = np.zeros(depth.shape, dtype=np.uint8)
    if valid.any():
        near, far = float(depth[valid].min()), float(depth[valid].max())
        span = max(far - near, 1e-6)
        grey[valid] = np.rint(255.0 - 200.0 * (depth[valid] - near) / span).astype(np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(grey).save(buffer, format="PNG", compress_level=PNG_LEVEL)
    return buffer.getvalue()


def depth_millimetres(depth: np.ndarray) -> np.ndarray:
    """A depth image [m] as uint16 millimetres; no reading (0, inf, nan) and > 65.535 m -> 0."""
    depth = np.asarray(depth, dtype=np.float64).reshape(depth.shape[0], depth.shape[1])
    mm = np.where(np.isfinite(depth) & (depth > 0), np.rint(depth * DEPTH_PNG_SCALE), 0.0)
    mm[mm > 65535] = 0
    return mm.astype(np.uint16)


@dataclass
class _Frame:
    """The latest frame of one camera, as kept by the server."""

    color: np.ndarray  # (height, width, 4) uint8
    depth: np.ndarray | None  # (height, width) float32 [m], or None
    time: float  # [s] simulation time of the publish
    count: int  # frames received so far
    rate: float  # [Hz] publish rate (the page refreshes at it)
    has_depth: bool = False  # whether the camera can publish depth (when a page asks)
    color_png: bytes | None = None  # encoded on first request
    depth_png: bytes | None = None


_PAGE = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: sans-serif; background: #222; color: #ddd; margin: 1em; }}
.camera {{ display: inline-block; margin: 0 1em 1em 0; vertical-align: top; }}
.camera img {{ display: inline-block; margin-right: 0.5em; background: #000;
  image-rendering: pixelated; }}
.info {{ font-family: monospace; }}
</style></head>
<body>
<h1>{title}</h1>
<div id="status">waiting for frames...</div>
<div id="cameras"></div>
<script>
"use strict";
const shown = {{}};
function add(camera) {{
  const box = document.createElement("div");
  box.className = "camera";
  box.id = "camera-" + camera.name;
  const title = document.createElement("h2");
  title.textContent = camera.name;
  const img = document.createElement("img");
  img.id = "image-" + camera.name;
  img.alt = camera.name;
  const info = document.createElement("div");
  info.className = "info";
  info.id = "info-" + camera.name;
  img.onload = () => {{
    const c = shown[camera.name];
    info.textContent = `${{img.naturalWidth}}x${{img.naturalHeight}} px, ` +
      `t = ${{c.time.toFixed(3)}} s, frame ${{c.count}}`;
    info.dataset.naturalWidth = img.naturalWidth;
    info.dataset.naturalHeight = img.naturalHeight;
  }};
  const depth = document.createElement("img");
  depth.id = "depth-" + camera.name;
  depth.alt = camera.name + " depth";
  depth.hidden = !camera.depth;
  box.append(title, img, depth, info);
  document.getElementById("cameras").append(box);
  shown[camera.name] = {{img: img, depth: depth, count: -1, time: 0}};
}}
async function poll() {{
  let period = 1000;
  try {{
    const response = await fetch("/cameras.json", {{cache: "no-store"}});
    const cameras = await response.json();
    document.getElementById("status").textContent =
      cameras.length ? `${{cameras.length}} camera(s)` : "waiting for frames...";
    for (const camera of cameras) {{
      if (!(camera.name in shown)) add(camera);
      const c = shown[camera.name];
      if (camera.count !== c.count) {{
        c.count = camera.count;
        c.time = camera.time;
        const base = `/camera/${{encodeURIComponent(camera.name)}}`;
        c.img.src = `${{base}}.png?frame=${{camera.count}}`;
        if (camera.depth) c.depth.src = `${{base}}/depth.png?frame=${{camera.count}}`;
      }}
      period = Math.min(period, 1000 / camera.rate);
    }}
  }} catch (error) {{
    document.getElementById("status").textContent = "simulation not reachable";
  }}
  setTimeout(poll, Math.max(period, 20));
}}
poll();
</script>
</body></html>
"""


class _HTTPServer6(ThreadingHTTPServer):
    address_family = socket.AF_INET6


class ImageViewServer:
    """Serves the latest camera frames over HTTP on ``host:port`` (0 = any free port).

    ``host``: an IP address (IPv4 or IPv6) of this machine; 127.0.0.1, this machine
    only, by default (see :func:`armando_drake.tools.cli.check_host`).
    Starts at construction; :meth:`close` (or ``with``) stops it.
    """

    def __init__(self, *, host: str = "127.0.0.1", port: int = 0, title: str = "Cameras"):
        if not 0 <= port <= 65535:
            raise ValueError(f"port={port!r} must be in 0..65535")
        self._lock = threading.Lock()
        self._frames: dict[str, _Frame] = {}
        self._depth_requests: dict[str, float] = {}  # camera -> monotonic time of last ask
        self._page = _PAGE.format(title=html.escape(title)).encode()
        self._host = host
        server_class = _HTTPServer6 if ":" in host else ThreadingHTTPServer
        self._httpd = server_class((host, port), self._handler_class())
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(
            target=self._httpd.serve_forever, name="image-view-server", daemon=True
        )
        self._thread.start()

    @property
    def url(self) -> str:
        """The page's address, e.g. ``http://127.0.0.1:8080/`` (on a wildcard address,
        0.0.0.0 or ::, the machine's host name: see :func:`~armando_drake.tools.cli.server_url`)."""

        return server_url(self._host, self._httpd.server_address[1])

    @property
    def urls(self) -> str:
        """What the log prints: :attr:`url`, and the loopback URL for a wildcard address."""

        return server_urls(self._host, self._httpd.server_address[1])

    def publish(
        self,
        name: str,
        color: np.ndarray,
        depth: np.ndarray | None = None,
        *,
        time: float = 0.0,
        rate: float = 30.0,
        has_depth: bool | None = None,
    ) -> None:
        """Makes ``color`` (H x W x 4 uint8) and ``depth`` (H x W [m]) camera ``name``'s frame.

        ``has_depth``: the camera can publish depth, even if this frame has none
        (depth is rendered only while a page asks for it); default: ``depth`` given.
        """
        color = np.array(color, dtype=np.uint8, copy=True)
        if color.ndim != 3 or color.shape[2] != 4:
            raise ValueError(f"color image shape {color.shape} is not (height, width, 4)")
        if depth is not None:
            depth = np.array(depth, dtype=np.float32, copy=True).reshape(color.shape[:2])
        with self._lock:
            previous = self._frames.get(name)
            count = previous.count + 1 if previous else 1
            capable = depth is not None if has_depth is None else has_depth
            self._frames[name] = _Frame(
                color, depth, float(time), count, float(rate), capable or depth is not None
            )

    def wants_depth(self, name: str, within: float = 2.0) -> bool:
        """Whether a page asked for camera ``name``'s depth in the last ``within`` seconds."""
        with self._lock:
            asked = self._depth_requests.get(name)
        return asked is not None and _time.monotonic() - asked <= within

    def frame_count(self, name: str) -> int:
        """How many frames camera ``name`` has published (0 if none)."""
        with self._lock:
            frame = self._frames.get(name)
            return frame.count if frame else 0

    def close(self) -> None:
        """Stops serving and frees the port."""
        self._httpd.shutdown()
        self._httpd.server_close()
        self._thread.join(timeout=5)

    def __enter__(self) -> ImageViewServer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ---- request handling (server thread) ----

    def _metadata(self, name: str, frame: _Frame) -> dict:
        height, width = frame.color.shape[:2]
        return {
            "name": name,
            "width": width,
            "height": height,
            "time": frame.time,
            "count": frame.count,
            "rate": frame.rate,
            "depth": frame.has_depth,
        }

    def _respond(self, path: str) -> tuple[int, str, bytes]:
        if path in ("/", "/index.html"):
            return 200, "text/html; charset=utf-8", self._page
        if path == "/cameras.json":
            with self._lock:
                cameras = [self._metadata(n, f) for n, f in sorted(self._frames.items())]
            return 200, "application/json", json.dumps(cameras).encode()
        if path.startswith("/camera/"):
            rest = urllib.parse.unquote(path[len("/camera/") :])
            for suffix, kind in (("/depth.png", "depth"), (".png", "color"), (".json", "json")):
                if rest.endswith(suffix):
                    return self._camera_file(rest[: -len(suffix)], kind)
        return 404, "text/plain", f"not found: {path}\n".encode()

    def _camera_file(self, name: str, kind: str) -> tuple[int, str, bytes]:
        with self._lock:
            frame = self._frames.get(name)
        if frame is None:
            known = ", ".join(sorted(self._frames)) or "none yet"
            return 404, "text/plain", f"no camera {name!r} (cameras: {known})\n".encode()
        if kind == "json":
            return 200, "application/json", json.dumps(self._metadata(name, frame)).encode()
        if kind == "depth":
            if not frame.has_depth:
                return 404, "text/plain", f"camera {name!r} publishes no depth\n".encode()
            with self._lock:
                self._depth_requests[name] = _time.monotonic()
            if frame.depth is None:  # rendered from the next frame on
                return 503, "text/plain", f"camera {name!r}: depth starts next frame\n".encode()
            if frame.depth_png is None:
                frame.depth_png = depth_preview_png(frame.depth)
            return 200, "image/png", frame.depth_png
        if frame.color_png is None:
            frame.color_png = color_png(frame.color)
        return 200, "image/png", frame.color_png

    def _handler_class(self):
        server = self

        class Handler(BaseHTTPRequestHandler):
            def handle(self):
                try:
                    super().handle()
                except ConnectionError:  # the page closed (BrokenPipe, ConnectionReset): fine
                    _logger.debug("image view: %s closed the connection", self.client_address)

            def do_GET(self):  # noqa: N802 (http.server's name)
                path = urllib.parse.urlsplit(self.path).path
                try:
                    status, kind, body = server._respond(path)
                except Exception as error:  # report, keep serving
                    _logger.exception("image view: %s failed", path)
                    status, kind, body = 500, "text/plain", f"{error}\n".encode()
                self.send_response(status)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, format, *args):  # noqa: A002 (http.server's signature)
                _logger.debug("image view: " + format, *args)

        return Handler


class _FrameConsumer(LeafSystem):
    """What the image view publisher and the frame saver share: one camera's image
    inputs, read by ``handler`` a small fraction of a period after each sample at
    ``rate`` [Hz]."""

    def __init__(self, *, rate: float, depth: bool, handler):
        super().__init__()
        if not rate > 0:
            raise ValueError(f"rate={rate!r} must be positive")
        self._rate = float(rate)
        self._period = 1.0 / rate
        self._color = self.DeclareAbstractInputPort(
            "color_image", AbstractValue.Make(ImageRgba8U())
        )
        self._depth = None
        if depth:
            self._depth = self.DeclareAbstractInputPort(
                "depth_image", AbstractValue.Make(ImageDepth32F())
            )
        self.DeclarePeriodicPublishEvent(
            self._period, PUBLISH_OFFSET_FRACTION * self._period, handler
        )


class ImageViewPublisher(_FrameConsumer):
    """Hands one camera's frames to an :class:`ImageViewServer` at ``rate``.

    Creates its own server on ``port`` unless ``server`` is given (share one
    server between cameras).

    Ports:
      - input ``color_image`` (ImageRgba8U)
      - input ``depth_image`` (ImageDepth32F [m]), only if ``depth``
    """

    def __init__(
        self,
        *,
        camera_name: str,
        rate: float,
        server: ImageViewServer | None = None,
        port: int = 0,
        depth: bool = False,
    ):
        super().__init__(rate=rate, depth=depth, handler=self._Publish)
        if not camera_name:
            raise ValueError(f"camera_name={camera_name!r} must not be empty")
        self._camera_name = camera_name
        self._server = server if server is not None else ImageViewServer(port=port)

    @property
    def server(self) -> ImageViewServer:
        return self._server

    @property
    def url(self) -> str:
        """The browser address of the view."""
        return self._server.url

    def _Publish(self, context):
        color = self._color.Eval(context)
        if color.width() == 0 or color.height() == 0:
            return
        # Depth is rendered on demand: only while a page shows it.
        depth = None
        wanted = self._depth is not None and self._server.wants_depth(self._camera_name)
        if wanted and self._depth.HasValue(context):
            depth = self._depth.Eval(context).data[:, :, 0]
        self._server.publish(
            self._camera_name,
            color.data,
            depth,
            time=context.get_time(),
            rate=self._rate,
            has_depth=self._depth is not None,
        )


class FrameSaver(_FrameConsumer):
    """Writes one camera's frames to ``directory`` at ``rate``.

    Files: ``<camera>_<index>.png`` (colour) and ``<camera>_<index>_depth.png``
    (uint16 millimetres, 0 = no reading) or ``<camera>_<index>_depth.npy``
    (float32 metres); ``index`` counts periods from time 0 (six digits).

    Ports:
      - input ``color_image`` (ImageRgba8U)
      - input ``depth_image`` (ImageDepth32F [m]), only if ``depth``
    """

    def __init__(
        self,
        *,
        directory: str | os.PathLike,
        camera_name: str,
        rate: float,
        depth: bool = False,
        depth_format: str = "png",
    ):
        super().__init__(rate=rate, depth=depth, handler=self._Save)
        if depth_format not in ("png", "npy"):
            raise ValueError(f"depth_format={depth_format!r} must be 'png' or 'npy'")
        self._directory = Path(directory)
        self._directory.mkdir(parents=True, exist_ok=True)
        self._camera_name = camera_name
        self._depth_format = depth_format

    @property
    def rate(self) -> float:
        """The frames saved per second [Hz]."""
        return self._rate

    @property
    def directory(self) -> Path:
        return self._directory

    def _Save(self, context):
        color = self._color.Eval(context)
        if color.width() == 0 or color.height() == 0:
            return
        index = int(round(context.get_time() / self._period))
        stem = self._directory / f"{self._camera_name}_{index:06d}"
        Image.fromarray(np.ascontiguousarray(color.data[:, :, :3])).save(
            f"{stem}.png", compress_level=PNG_LEVEL
        )
        if self._depth is not None:
            depth = self._depth.Eval(context).data[:, :, 0]
            if self._depth_format == "npy":
                np.save(f"{stem}_depth.npy", np.asarray(depth, dtype=np.float32))
            else:
                Image.fromarray(depth_millimetres(depth)).save(
                    f"{stem}_depth.png", compress_level=PNG_LEVEL
                )


def AddImageView(
    builder: DiagramBuilder,
    cameras: dict,
    *,
    server: ImageViewServer | None = None,
    host: str = "127.0.0.1",
    port: int = 0,
    depth: bool = True,
) -> ImageViewServer:
    """Adds an :class:`ImageViewPublisher` per camera (from ``AddCameraSensors``).

    All cameras share one server (``server``, or a new one on ``host:port``); each
    is published at its own frame rate. Returns the server (``.url``).
    """
    if server is None:
        server = ImageViewServer(host=host, port=port)
    for name, camera in cameras.items():
        with_depth = depth and camera.depth_image is not None
        publisher = builder.AddNamedSystem(
            f"image_view_{name}",
            ImageViewPublisher(
                camera_name=name, rate=camera.info.frame_rate, server=server, depth=with_depth
            ),
        )
        builder.Connect(camera.color_image, publisher.GetInputPort("color_image"))
        rate = camera.info.frame_rate
        read_color(camera, rate, PUBLISH_OFFSET_FRACTION / rate)
        if with_depth:
            builder.Connect(camera.depth_image, publisher.GetInputPort("depth_image"))
    return server


def AddFrameSaver(
    builder: DiagramBuilder,
    camera,
    directory: str | os.PathLike,
    *,
    rate: float | None = None,
    depth: bool = True,
    depth_format: str = "png",
) -> FrameSaver:
    """Adds a :class:`FrameSaver` for one camera (from ``AddCameraSensors``).

    ``rate`` defaults to the camera's frame rate.
    """
    with_depth = depth and camera.depth_image is not None
    saver = builder.AddNamedSystem(
        f"frame_saver_{camera.info.name}",
        FrameSaver(
            directory=directory,
            camera_name=camera.info.name,
            rate=rate or camera.info.frame_rate,
            depth=with_depth,
            depth_format=depth_format,
        ),
    )
    builder.Connect(camera.color_image, saver.GetInputPort("color_image"))
    read_color(camera, saver.rate, PUBLISH_OFFSET_FRACTION / saver.rate)
    if with_depth:
        builder.Connect(camera.depth_image, saver.GetInputPort("depth_image"))
    return saver
