"""Meshcat's world and the display join no multicast group: Drake's visualization
publishes its LCM messages (for Meldis) on an in-process bus, not on LCM's default UDP
multicast (239.255.76.67:7667), which would join the machine's network interface."""

import json
import subprocess
import sys

import pytest

LCM_DEFAULT_PORT = 7667

# Builds and runs a world drawn in Meshcat in a process of its own (nothing else there
# holds a socket), then prints (local address, port) of each UDP socket it holds.
WORLD = """
import json, os
from pathlib import Path
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

from armando_drake.description.viewer import make_display

if DISPLAY:
    visualizer, _ = make_display(meshcat=Meshcat())
else:
    world = MakeWorld(
        load_scenario("position", "logging: {console_rate: 0}"), meshcat=Meshcat(), quiet=True
    )
    Simulator(world.diagram).AdvanceTo(0.2)  # the visualizers published
inodes = set()
for fd in os.listdir("/proc/self/fd"):
    try:
        target = os.readlink(f"/proc/self/fd/{fd}")
    except OSError:
        continue
    if target.startswith("socket:["):
        inodes.add(target[len("socket:["):-1])
sockets = []
for table in ("/proc/net/udp", "/proc/net/udp6"):
    if Path(table).is_file():
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[9] in inodes:
                address, port = fields[1].split(":")
                sockets.append([address, int(port, 16)])
print(json.dumps(sockets))
"""


@pytest.mark.parametrize("display", [False, True], ids=["world", "display"])
def test_meshcat_opens_no_lcm_multicast_socket(display):
    code = f"DISPLAY = {display}\n{WORLD}"
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    sockets = json.loads(result.stdout.strip().splitlines()[-1])
    assert all(port != LCM_DEFAULT_PORT for _, port in sockets), sockets
