"""Nothing is exposed by default: Meshcat and the camera's live view listen on 127.0.0.1
unless --host says otherwise; then both listen there, and the printed URLs work."""

import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import skip_or_fail


def _listening(pid: int, options: str = "-ltnpH") -> list[str]:
    """The local addresses the process ``pid`` listens on (TCP), from ``ss``."""
    out = subprocess.run(["ss", options], capture_output=True, text=True, check=True).stdout
    return [line.split()[3] for line in out.splitlines() if f"pid={pid}," in line]


def _multicast_groups() -> set[tuple[str, str]]:
    """(interface, group) of every IPv4 and IPv6 multicast membership of the machine."""
    groups = set()
    device = ""
    for line in Path("/proc/net/igmp").read_text().splitlines()[1:]:
        if not line.startswith("\t"):
            device = line.split()[1]
        else:
            groups.add((device, line.split()[0]))
    igmp6 = Path("/proc/net/igmp6")
    for line in igmp6.read_text().splitlines() if igmp6.is_file() else []:
        groups.add((line.split()[1], line.split()[2]))
    return groups


def _world_sockets(*extra: str, servers: int = 1, during=None) -> tuple[list[str], str]:
    """The addresses a world run listens on once ``servers`` servers are up, and what it
    printed until then; ``during(pid)`` is called then, while it runs."""
    if shutil.which("ss") is None:
        skip_or_fail("iproute2's ss is not installed (apt-get install iproute2)")
    process = subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", "--duration", "20", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        deadline = time.monotonic() + 90
        addresses: list[str] = []
        while time.monotonic() < deadline and len(addresses) < servers:
            time.sleep(0.5)
            assert process.poll() is None, process.communicate()[0]
            addresses = _listening(process.pid)
        time.sleep(1.0)  # every server of the run is up by now
        addresses = _listening(process.pid)
        if during is not None:
            during(process.pid)
    finally:
        process.kill()
        output = process.communicate()[0]
    return addresses, output


def test_meshcat_listens_on_loopback_only_by_default():
    addresses, output = _world_sockets()
    assert addresses, "the world with Meshcat listens on no socket"
    assert all(a.startswith("127.0.0.1:") for a in addresses), addresses


def test_meshcat_and_the_camera_view_listen_on_loopback_only_by_default():
    addresses, output = _world_sockets("--scenario", "camera", servers=2)
    assert len(addresses) >= 2, addresses  # Meshcat and the camera view
    assert all(a.startswith("127.0.0.1:") for a in addresses), addresses
    assert re.search(r"^Meshcat: http://127\.0\.0\.1:\d+$", output, re.M), output
    assert re.search(r"^Camera view: http://127\.0\.0\.1:\d+/$", output, re.M), output


def test_the_camera_view_alone_listens_on_loopback_only():
    addresses, output = _world_sockets("--scenario", "camera", "--no-meshcat", "--camera-view")
    assert addresses, "the camera view listens on no socket"
    assert all(a.startswith("127.0.0.1:") for a in addresses), addresses


def test_host_opens_meshcat_and_the_camera_view_on_purpose():
    addresses, output = _world_sockets("--scenario", "camera", "--host", "0.0.0.0", servers=2)
    assert len(addresses) >= 2, addresses
    assert all(a.startswith(("0.0.0.0:", "*:")) for a in addresses), addresses
    # The log says so, and prints a URL that works from elsewhere, once per server.
    assert "--host 0.0.0.0: Meshcat is reachable from other machines" in output, output
    assert "--host 0.0.0.0: the camera view is reachable from other machines" in output
    name = re.escape(socket.gethostname())
    for server, path in (("Meshcat", ""), ("Camera view", "/")):
        lines = [line for line in output.splitlines() if line.startswith(f"{server}: ")]
        assert len(lines) == 1, output
        assert re.fullmatch(
            rf"{server}: http://{name}:(\d+){path} \(on this machine: "
            rf"http://127\.0\.0\.1:\1{path}\)",
            lines[0],
        ), lines[0]
        assert "0.0.0.0" not in lines[0]


def test_every_server_at_once_stays_on_the_loopback_and_joins_no_multicast_group():
    """Meshcat, the camera view, ROS 2 over DDS and Foxglove together, without --host:
    no TCP or UDP socket outside the loopback, and no multicast membership on any other
    interface (the machine's memberships, read from /proc/net/igmp and igmp6, unchanged)."""
    pytest.importorskip("cyclonedds")
    pytest.importorskip("foxglove")
    before = _multicast_groups()
    seen = {}

    def during(pid):
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not seen.get("udp"):
            time.sleep(0.5)  # until the DDS participant is up
            seen["udp"] = _listening(pid, "-lunpH") + _listening(pid, "-unpH")
        time.sleep(1.0)  # its discovery under way
        seen["groups"] = _multicast_groups()

    extra = ("--scenario", "camera", "--ros2", "--foxglove", "0", "--camera-view")
    addresses, output = _world_sockets(*extra, servers=3, during=during)
    assert len(addresses) >= 3, (addresses, output)  # Meshcat, camera view, Foxglove
    assert all(a.startswith("127.0.0.1:") for a in addresses), addresses
    assert seen["udp"], "the DDS participant holds no UDP socket"
    assert all(a.startswith(("127.0.0.1:", "0.0.0.0%lo:")) for a in seen["udp"]), seen["udp"]
    joined = {(device, group) for device, group in seen["groups"] - before if device != "lo"}
    assert not joined, joined
