"""Makes the pictures of docs/images/ from the code, so they show what the code does.

    python docs/make_images.py            # needs Debian's chromium and Playwright (test extra)

- ``armando.png``: the position scenario run headless with ``--output``; its
  ``replay.html`` opened in headless Chromium, the animation paused at ``POSE_TIME``
  (the arm at the seed's second target), and the page's screenshot;
- ``positions.png``: the same run's plot of measured against commanded positions, as
  ``--output`` drew it.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

IMAGES = Path(__file__).resolve().parent / "images"
REPO = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
POSE_TIME = 4.5  # [s] of the run: the seed's second target (1.2, -1.0, 1.2, 0.6) reached
VIEWPORT = {"width": 1200, "height": 700}
# In the page: the animation paused at time t, the world axes and the controls hidden.
SHOW_POSE = """(t) => {
  viewer.animator.play();
  viewer.animator.pause();
  viewer.animator.seek(t);
  viewer.scene_tree.find(["Axes"]).set_property("visible", false);
  document.querySelectorAll(".dg.main").forEach((e) => { e.style.display = "none"; });
  viewer.set_dirty();
}"""


def run_world(output: Path) -> None:
    """The position scenario, headless and as fast as it goes, its outputs in ``output``."""
    command = [
        sys.executable,
        "-m",
        "armando_drake.world",
        "--no-meshcat",
        "--realtime-rate",
        "0",
        "--quiet",
        "--output",
        str(output),
    ]
    subprocess.run(command, cwd=REPO, check=True)


def screenshot(page_file: Path, png: Path) -> None:
    """``page_file`` (a replay.html) in headless Chromium, paused at POSE_TIME, as a PNG."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM, args=["--no-sandbox", "--disable-gpu"]
        )
        try:
            page = browser.new_page(viewport=VIEWPORT)
            page.goto(page_file.as_uri())
            page.wait_for_function("() => window.viewer && viewer.animator.duration > 0")
            page.evaluate(SHOW_POSE, POSE_TIME)
            page.wait_for_timeout(1000)  # frames drawn after the seek
            page.screenshot(path=str(png))
        finally:
            browser.close()


def main() -> int:
    IMAGES.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as folder:
        output = Path(folder) / "run"
        run_world(output)
        screenshot(output / "replay.html", IMAGES / "armando.png")
        shutil.copyfile(output / "positions.png", IMAGES / "positions.png")
    for name in ("armando.png", "positions.png"):
        print(IMAGES / name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
