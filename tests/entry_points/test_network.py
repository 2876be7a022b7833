"""Nothing is exposed by default: Meshcat listens on 127.0.0.1 unless --host says otherwise."""

import shutil
import subprocess
import sys
import time

from conftest import skip_or_fail


def _listening(pid: int) -> list[str]:
    """The local addresses the process ``pid`` listens on (TCP), from ``ss``."""
    out = subprocess.run(["ss", "-ltnpH"], capture_output=True, text=True, check=True).stdout
    return [line.split()[3] for line in out.splitlines() if f"pid={pid}," in line]


def _world_sockets(*extra: str) -> list[str]:
    if shutil.which("ss") is None:
        skip_or_fail("iproute2's ss is not installed (apt-get install iproute2)")
    process = subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", "--duration", "20", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        addresses: list[str] = []
        while time.monotonic() < deadline and not addresses:
            time.sleep(0.5)
            addresses = _listening(process.pid)
        time.sleep(1.0)  # every server of the run is up by now
        return _listening(process.pid)
    finally:
        process.kill()
        process.wait()


def test_meshcat_listens_on_loopback_only_by_default():
    addresses = _world_sockets()
    assert addresses, "the world with Meshcat listens on no socket"
    assert all(a.startswith("127.0.0.1:") for a in addresses), addresses


def test_host_opens_meshcat_on_purpose():
    addresses = _world_sockets("--host", "0.0.0.0")
    assert any(a.startswith(("0.0.0.0:", "*:")) for a in addresses), addresses
