"""Headless Chromium driven by Playwright, for tests of the pages the project serves."""

import contextlib
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


def robot_span(page, path=("drake", "illustration", "armando")) -> tuple[float, float]:
    """Share of the view's height and width that the Meshcat object at ``path`` covers:
    a screenshot of the page as it is, one with that object hidden (the scene without
    it), and the box around the pixels that differ."""
    import io

    import numpy as np
    from PIL import Image

    def shot():
        page.wait_for_timeout(500)  # a frame drawn after the change
        image = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
        return np.asarray(image).astype(int)

    import json

    hide = (
        "(visible) => { viewer.scene_tree.find("
        + json.dumps(list(path))
        + ").set_property('visible', visible); viewer.set_dirty(); }"
    )
    page.evaluate("() => viewer.animator.pause && viewer.animator.pause()")
    with_robot = shot()
    page.evaluate(hide, False)
    without = shot()
    page.evaluate(hide, True)
    rows, columns = np.nonzero(np.abs(with_robot - without).sum(axis=2) > 30)
    if not len(rows):
        return 0.0, 0.0
    height, width = with_robot.shape[:2]
    return (rows.max() - rows.min() + 1) / height, (columns.max() - columns.min() + 1) / width
