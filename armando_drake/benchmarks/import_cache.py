"""How much the mesh cache saves: the course's arm loaded cold, then warm.

Each load runs in a fresh Python process (so nothing is shared in memory)
with ``XDG_CACHE_HOME`` pointing at a new temporary folder: the first process
finds the cache empty and converts every STL, the second finds it full. The
figure is the wall time of ``load_robot`` into a ``MultibodyPlant`` (imports
excluded); the target is a second load at least 5 times faster.

    python -m armando_drake.benchmarks.import_cache [path/to/arm_description] [--repeat N]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

DEFAULT_PACKAGE = Path(__file__).resolve().parents[2] / "shared" / "upstream" / "arm_description"

# Runs in the child process; prints the load time and how many meshes it converted.
_CHILD = """
import logging, sys, time
logging.disable(logging.WARNING)
from pydrake.multibody.plant import MultibodyPlant
from armando_drake.description.loader import find_packages, load_robot
from armando_drake.description.importer import prepare_urdf
plant = MultibodyPlant(0.001)
start = time.perf_counter()
robot = load_robot(plant, sys.argv[1])
elapsed = time.perf_counter() - start
search = find_packages(near=robot.source)
converted = len(prepare_urdf(robot.urdf, search, source=robot.source).converted)
print(f"{elapsed:.6f} {converted}")
"""


def load_once(package: Path, cache: Path) -> tuple[float, int]:
    """(seconds spent in load_robot, meshes converted afterwards) in a fresh process."""
    environment = dict(os.environ, XDG_CACHE_HOME=str(cache))
    output = subprocess.run(
        [sys.executable, "-c", _CHILD, str(package)],
        env=environment,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    return float(output[0]), int(output[1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("package", nargs="?", type=Path, default=DEFAULT_PACKAGE)
    parser.add_argument("--repeat", type=int, default=3, help="cold/warm pairs to run")
    args = parser.parse_args()
    if not args.package.is_dir():
        sys.exit(f"{args.package}: no such package directory")
    cold_times, warm_times = [], []
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory(prefix="armando-cache-") as cache:
            cold, _ = load_once(args.package, Path(cache))
            warm, left = load_once(args.package, Path(cache))
        assert left == 0, f"the warm load left {left} meshes unconverted"
        cold_times.append(cold)
        warm_times.append(warm)
        print(f"cold {cold * 1e3:8.1f} ms   warm {warm * 1e3:8.1f} ms   ratio {cold / warm:5.1f}")
    cold, warm = min(cold_times), min(warm_times)
    verdict = "meets" if cold / warm >= 5 else "MISSES"
    print(
        f"best of {args.repeat}: cold {cold * 1e3:.1f} ms, warm {warm * 1e3:.1f} ms, "
        f"ratio {cold / warm:.1f} ({verdict} the 5x target)"
    )


if __name__ == "__main__":
    main()
