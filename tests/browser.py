"""Headless Chromium driven by Playwright, for tests of the pages the project serves."""

import contextlib
import dataclasses
import re
import subprocess
import sys
import time
from collections.abc import Iterator

CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]

# Every path of the Meshcat scene tree, from the page's global `viewer`.
SCENE_PATHS_JS = """() => {
  const out = [];
  function walk(node, path) {
    for (const [name, child] of Object.entries(node.children || {})) {
      out.push(path + "/" + name);
      walk(child, path + "/" + name);
    }
  }
  walk(viewer.scene_tree, "");
  return out;
}"""


@contextlib.contextmanager
def browser_page(chromium: str) -> Iterator:
    """A Playwright page in Debian's headless Chromium."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 720})
            yield page
        finally:
            browser.close()


def open_url(page, url: str, attempts: int = 3) -> None:
    """Opens ``url`` in ``page`` from a blank page.

    A page still showing an earlier run's Meshcat reloads itself when its server goes away,
    and that reload can interrupt the next navigation to a reused port: leaving the old page
    first stops it, and an interrupted navigation is tried again.
    """
    page.goto("about:blank")
    for attempt in range(attempts):
        try:
            page.goto(url)
            return
        except Exception as error:  # playwright's Error, imported lazily with the browser
            if "interrupted by another navigation" not in str(error) or attempt == attempts - 1:
                raise
            page.wait_for_timeout(500)


def wait_for_scene_paths(page, predicate, timeout: float = 20.0) -> list[str]:
    """Polls the Meshcat scene tree until ``predicate(paths)`` holds or time runs out."""
    deadline = time.monotonic() + timeout
    paths: list[str] = []
    while time.monotonic() < deadline:
        paths = page.evaluate(SCENE_PATHS_JS)
        if predicate(paths):
            break
        page.wait_for_timeout(250)
    return paths


@contextlib.contextmanager
def running(args: list[str], url_pattern: str, timeout: float = 120.0) -> Iterator[tuple]:
    """Runs ``python -m args...`` until the context ends; yields (process, url)."""
    process = subprocess.Popen(
        [sys.executable, "-m", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines = []
    try:
        deadline = time.monotonic() + timeout
        url = None
        for line in process.stdout:
            lines.append(line)
            match = re.search(url_pattern, line)
            if match:
                url = match.group(1)
                break
            if time.monotonic() > deadline:
                break
        if url is None:
            raise AssertionError("no URL printed:\n" + "".join(lines))
        yield process, url
    finally:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()


# Drawn by Meshcat around the content: hidden while the content is measured, so that
# neither they nor the shadows the content casts on them count as content.
SURROUNDINGS = ("Grid", "Axes", "ground")

# The page's overlays (the real-time rate plot, the controls), which change on their own.
SET_OVERLAYS_JS = """(visibility) => {
  for (const element of document.querySelectorAll('#stats-plot, .dg.main'))
    element.style.visibility = visibility;
}"""
SET_VISIBLE_JS = """([paths, visible]) => {
  for (const path of paths) viewer.scene_tree.find(path).set_property('visible', visible);
  viewer.set_dirty();
}"""


@dataclasses.dataclass
class Framing:
    """Where the content lies in a screenshot of the view [pixels]: rows top..bottom,
    columns left..right (inclusive), of a view ``height`` x ``width``."""

    top: int
    bottom: int
    left: int
    right: int
    height: int
    width: int

    @property
    def fill(self) -> float:
        """The content's larger extent on the screen over the view's smaller dimension."""
        extent = max(self.bottom - self.top + 1, self.right - self.left + 1)
        return extent / min(self.height, self.width)

    @property
    def cut(self) -> bool:
        """Whether the content touches an edge of the view (is cut off there)."""
        return (
            self.top <= 0
            or self.left <= 0
            or self.bottom >= self.height - 1
            or self.right >= self.width - 1
        )

    @property
    def centre(self) -> tuple[float, float]:
        """The content box's centre over the view's height and width (0.5: in the middle)."""
        return (
            (self.top + self.bottom + 1) / 2 / self.height,
            (self.left + self.right + 1) / 2 / self.width,
        )

    def __str__(self) -> str:
        return (
            f"fill {self.fill:.1%} of the view's {min(self.height, self.width)} px "
            f"(rows {self.top}-{self.bottom} of {self.height}, "
            f"columns {self.left}-{self.right} of {self.width})"
        )


SCREENSHOTS = "ARMANDO_DRAKE_SCREENSHOTS"  # a folder: the tests save their pages there
SCREENSHOT_WIDTH = 960  # [px] of the saved screenshots (the page is 1280 x 720): < 150 kB


def save_screenshot(page, name: str) -> None:
    """With the environment variable ARMANDO_DRAKE_SCREENSHOTS set to a folder, saves the
    page as it is there as ``name.png`` (for the docs: what the code draws today)."""
    import io
    import os
    from pathlib import Path

    from PIL import Image

    folder = os.environ.get(SCREENSHOTS)
    if not folder:
        return
    page.wait_for_timeout(500)
    image = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
    height = round(image.height * SCREENSHOT_WIDTH / image.width)
    image = image.resize((SCREENSHOT_WIDTH, height), Image.Resampling.LANCZOS)
    Path(folder).mkdir(parents=True, exist_ok=True)
    image.save(Path(folder) / f"{name}.png", optimize=True)


def scene_children(page, parent: str) -> list[str]:
    """The Meshcat paths just below ``parent`` (e.g. ``/drake/illustration``)."""
    return [
        path
        for path in page.evaluate(SCENE_PATHS_JS)
        if path.startswith(parent + "/") and "/" not in path[len(parent) + 1 :]
    ]


def _split(path: str) -> list[str]:
    return [part for part in path.split("/") if part]


def measure_framing(page, content, hidden=()) -> Framing | None:
    """Where the Meshcat objects at ``content`` (paths) lie in the view: a screenshot
    with them, one without, and the box around the pixels that differ. The grid, the
    axes and the drawn ground (:data:`SURROUNDINGS`) and ``hidden`` (paths) are hidden
    in both, and so are the page's overlays (:data:`SET_OVERLAYS_JS`). None when the
    content draws no pixel."""
    import io

    import numpy as np
    from PIL import Image

    def shot():
        page.wait_for_timeout(400)  # a frame drawn after the change
        image = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
        return np.asarray(image).astype(int)

    content = [_split(path) for path in content]
    hidden = [[name] for name in SURROUNDINGS] + [_split(path) for path in hidden]
    page.evaluate("() => viewer.animator.pause && viewer.animator.pause()")
    page.evaluate(SET_VISIBLE_JS, [hidden, False])
    page.evaluate(SET_OVERLAYS_JS, "hidden")
    try:
        page.evaluate(SET_VISIBLE_JS, [content, True])
        with_content = shot()
        page.evaluate(SET_VISIBLE_JS, [content, False])
        without = shot()
    finally:
        page.evaluate(SET_VISIBLE_JS, [content + hidden, True])
        page.evaluate(SET_OVERLAYS_JS, "")
    rows, columns = np.nonzero(np.abs(with_content - without).sum(axis=2) > 30)
    if not len(rows):
        return None
    height, width = with_content.shape[:2]
    return Framing(
        top=int(rows.min()),
        bottom=int(rows.max()),
        left=int(columns.min()),
        right=int(columns.max()),
        height=height,
        width=width,
    )


def robot_span(page, path=("drake", "illustration", "armando")) -> tuple[float, float]:
    """Share of the view's height and width that the Meshcat object at ``path`` covers
    (:func:`measure_framing` of it alone)."""
    framing = measure_framing(page, ["/" + "/".join(path)])
    if framing is None:
        return 0.0, 0.0
    return (
        (framing.bottom - framing.top + 1) / framing.height,
        (framing.right - framing.left + 1) / framing.width,
    )
