"""Nothing of the live world listens or sends outside the loopback unless asked.

The world runs with --ros2 and --foxglove under strace, which logs every network
system call of every thread: each address it sends to or connects to must be a
loopback address, and ss shows each of its sockets bound to 127.0.0.1 or to the
loopback device. One exception is checked rather than ignored: at start-up
Cyclone DDS probes whether the loopback interface can multicast (it joins
239.255.0.1 on 127.0.0.1 and sends 16 bytes to itself); that send must go out of
the loopback interface (IP_MULTICAST_IF 127.0.0.1) with a time to live of 0, so
it cannot leave the machine.
"""

import ipaddress
import re
import shutil
import subprocess
import time

import pytest
from conftest import skip_or_fail
from ros2_support import new_domain_id, python, subprocess_env

pytest.importorskip("cyclonedds")
pytest.importorskip("foxglove")

ADDRESS = re.compile(r'inet_addr\("([\d.]+)"\)|inet_pton\(AF_INET6, "([0-9a-f:.]+)"')
SENDS = ("sendto(", "sendmsg(", "sendmmsg(", "connect(")


def _loopback(address: str) -> bool:
    return address.startswith("127.") or address in ("::1", "::ffff:127.0.0.1")


def test_world_sends_and_listens_on_the_loopback_only(tmp_path):
    domain_id = new_domain_id()
    for tool in ("strace", "ss"):
        if shutil.which(tool) is None:
            skip_or_fail(f"{tool} is not installed (apt-get install strace iproute2)")
    log = tmp_path / "strace.log"
    world = subprocess.Popen(
        [
            "strace",
            "-f",
            "-qq",
            "-e",
            "trace=%network",
            "-o",
            str(log),
            python(),
            "-m",
            "armando_drake.world",
            "--scenario",
            "ros2",
            "--no-meshcat",
            "--duration",
            "6",
            "--foxglove",
            "0",
            "--set",
            f"ros2: {{domain_id: {domain_id}}}",
        ],  # fmt: skip
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=subprocess_env(),
    )
    try:
        # Wait until the world runs (the bridge logs the subscription), then read its sockets.
        deadline = time.monotonic() + 60
        output = []
        for line in world.stdout:
            output.append(line)
            if "subscribed /position_controller/commands" in line or time.monotonic() > deadline:
                break
        time.sleep(1.0)
        children = subprocess.run(
            ["pgrep", "-P", str(world.pid)], capture_output=True, text=True
        ).stdout.split()
        sockets = subprocess.run(["ss", "-tuanpH"], capture_output=True, text=True).stdout
        output += world.stdout.readlines()
        world.wait(60)
    finally:
        world.kill()
    assert world.returncode == 0, "".join(output)
    ours = [line for line in sockets.splitlines() if any(f"pid={pid}," in line for pid in children)]
    assert ours, f"no sockets of the world ({children}) in:\n{sockets}"
    for line in ours:
        local = line.split()[4]
        assert local.startswith(("127.0.0.1:", "0.0.0.0%lo:", "[::1]:", "[::]%lo:")), line

    calls = log.read_text().splitlines()
    sends = [call for call in calls if any(name in call for name in SENDS)]
    assert len(sends) > 10, "strace saw no traffic: the test would prove nothing"
    multicast: dict[tuple[str, str], dict[str, str]] = {}  # (thread, fd) -> options set
    for call in calls:
        option = re.match(r"(\d+)\s+setsockopt\((\d+), SOL_IP, (IP_MULTICAST_\w+), (\S+),", call)
        if option:
            thread, fd, name, value = option.groups()
            multicast.setdefault((thread, fd), {})[name] = value
        if "MEMBERSHIP" in call:
            assert 'imr_interface=inet_addr("127.0.0.1")' in call, call
        if not any(name in call for name in SENDS):
            continue
        for v4, v6 in ADDRESS.findall(call):
            address = v4 or v6
            if _loopback(address):
                continue
            assert ipaddress.ip_address(address).is_multicast, call
            where = re.match(r"(\d+)\s+\w+\((\d+),", call)
            assert where, call
            thread, fd = where.groups()
            options = multicast.get((thread, fd), {})
            loopback_if = str(int.from_bytes(bytes([127, 0, 0, 1]), "little"))
            assert options.get("IP_MULTICAST_IF") == f"[{loopback_if}]", (call, options)
            assert options.get("IP_MULTICAST_TTL") in ('"\\0"', "[0]"), (call, options)
