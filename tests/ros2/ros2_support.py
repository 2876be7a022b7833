"""Shared pieces of the live ROS 2 tests: a DDS domain of their own, subprocesses."""

import os
import random
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "arm_controller_node.py"
_used: set[int] = set()


def new_domain_id() -> int:
    """A DDS domain id no other test of this run (nor, likely, of another run) uses."""
    rng = random.Random(os.getpid() * 1_000_003 + time.monotonic_ns())
    while True:
        candidate = rng.randint(100, 230)
        if candidate not in _used:
            _used.add(candidate)
            return candidate


def python() -> str:
    return sys.executable


def subprocess_env() -> dict[str, str]:
    """The environment of a subprocess that sees this checkout first."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.pop("CYCLONEDDS_URI", None)  # every participant here configures its own domain
    return env
