"""The course's arm_controller_node as a plain DDS participant (no ROS 2 needed).

It does what the course's node does against a ROS 2 robot: prints the joint
states it receives on /joint_states once a second and publishes the seed
targets on /position_controller/commands, one every 3 s (of simulation time,
read from /clock, as a ROS 2 node with use_sim_time does). Before each new
target it prints how close the arm came to the previous one. With
--bad-command it ends by publishing a command of the wrong size, which the
controller must reject while the arm holds.

It speaks ROS 2's DDS mapping directly with Cyclone DDS (``pip install
cyclonedds``) and defines the few message types it needs itself, so it
shows what any DDS program needs to talk to the world. Start the world first:

    python -m armando_drake.world --scenario ros2 --no-meshcat
    python examples/arm_controller_node.py

Lines it prints (for a person and for the test that runs it):
    joint_states: N messages in W s of wall time (R Hz), S s of simulation time (R Hz)
    t=12.00 q=[...]
    target K [...] reached: max error E rad
    bad command [...] sent
"""

import argparse
import os
import sys
import threading
import time
from dataclasses import dataclass, field

from cyclonedds.core import Listener, Policy, Qos
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

SEED_TARGETS = [
    [0.0, 0.0, 0.0, 0.0],
    [1.2, -1.0, 1.2, 0.6],
    [-1.2, 1.0, -1.2, -0.6],
    [0.6, 0.0, -0.6, 1.0],
    [0.0, 0.0, 0.0, 0.0],
]


# The ROS 2 messages this node uses, as ROS 2 names them on DDS.
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
class Clock(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time = field(default_factory=Time)


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str = ""
    size: uint32 = 0
    stride: uint32 = 0


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: uint32 = 0


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: sequence[float64] = field(default_factory=list)


# ROS 2's default QoS: reliable, keep last 10, volatile.
QOS = Qos(
    Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
    Policy.History.KeepLast(10),
    Policy.Durability.Volatile,
)
# Loopback only: unicast discovery on 127.0.0.1, as the world is configured.
LOOPBACK = (
    "<CycloneDDS><Domain Id='any'><General><Interfaces>"
    "<NetworkInterface address='127.0.0.1'/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>"
    "<Peers><Peer address='127.0.0.1'/></Peers></Discovery></Domain></CycloneDDS>"
)


class Latest:
    """What the listeners received: the newest joint state and clock, and counts."""

    def __init__(self):
        self.lock = threading.Lock()
        self.joint_state: JointState | None = None
        self.joint_states_received = 0
        self.sim_time: float | None = None

    def on_joint_states(self, reader) -> None:
        samples = reader.take(N=100)
        with self.lock:
            for sample in samples:
                self.joint_states_received += 1
                self.joint_state = sample

    def on_clock(self, reader) -> None:
        samples = reader.take(N=100)
        with self.lock:
            for sample in samples:
                self.sim_time = sample.clock.sec + sample.clock.nanosec * 1e-9


def topic(namespace: str, name: str) -> str:
    """ROS 2's DDS topic name: rt/ + the namespaced name."""
    return "rt/" + "/".join(p for p in (namespace.strip("/"), name) if p)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--domain-id", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)
    )
    parser.add_argument("--namespace", default="", help="the world's ros2.namespace")
    parser.add_argument("--controller", default="position_controller")
    parser.add_argument("--period", type=float, default=3.0, help="[s] simulation time per target")
    parser.add_argument("--count-window", type=float, default=5.0, help="[s] wall time")
    parser.add_argument("--bad-command", action="store_true", help="end with a wrong-size command")
    parser.add_argument("--timeout", type=float, default=30.0, help="[s] to wait for the world")
    args = parser.parse_args(argv)

    # Every entity is kept referenced: Cyclone DDS deletes what Python collects.
    domain = Domain(args.domain_id, LOOPBACK)  # the domain's configuration, before the participant
    participant = DomainParticipant(args.domain_id)
    latest = Latest()
    joint_states_reader = DataReader(
        participant,
        Topic(participant, topic(args.namespace, "joint_states"), JointState),
        qos=QOS,
        listener=Listener(on_data_available=latest.on_joint_states),
    )
    clock_reader = DataReader(
        participant,
        Topic(participant, "rt/clock", Clock),
        qos=QOS,
        listener=Listener(on_data_available=latest.on_clock),
    )
    writer = DataWriter(
        participant,
        Topic(participant, topic(args.namespace, f"{args.controller}/commands"), Float64MultiArray),
        qos=QOS,
    )

    # Wait for the world: its joint states, its clock, and its subscription of our commands.
    deadline = time.monotonic() + args.timeout
    while (
        latest.joint_state is None
        or latest.sim_time is None
        or writer.get_publication_matched_status().current_count == 0
    ):
        if time.monotonic() > deadline:
            print("no world found on the DDS domain", args.domain_id, file=sys.stderr)
            return 1
        time.sleep(0.01)

    def now() -> float:
        with latest.lock:
            return latest.sim_time

    def positions() -> list[float]:
        with latest.lock:
            return list(latest.joint_state.position)

    def stamp() -> float:
        header = latest.joint_state.header
        return header.stamp.sec + header.stamp.nanosec * 1e-9

    # The joint states' rate over a window of wall time, and over the simulation time
    # their stamps span (the same when the world keeps up with real time).
    with latest.lock:
        count0, stamp0 = latest.joint_states_received, stamp()
    wall0 = time.monotonic()
    time.sleep(args.count_window)
    with latest.lock:
        received, simulated = latest.joint_states_received - count0, stamp() - stamp0
    wall = time.monotonic() - wall0
    print(
        f"joint_states: {received} messages in {wall:.2f} s of wall time "
        f"({received / wall:.1f} Hz), {simulated:.3f} s of simulation time "
        f"({received / max(simulated, 1e-9):.1f} Hz)",
        flush=True,
    )

    # The seed targets, one per period of simulation time; print at 1 Hz.
    next_print = now()
    for k, target in enumerate(SEED_TARGETS + ([None] if args.bad_command else [])):
        if target is None:
            target = [0.1, 0.2]  # two values for four joints: upstream rejects it
            writer.write(Float64MultiArray(data=target))
            print(f"bad command {target} sent", flush=True)
        else:
            writer.write(Float64MultiArray(data=list(target)))
        start = now()
        while now() < start + args.period:
            if now() >= next_print:
                q = " ".join(f"{v:+.3f}" for v in positions())
                print(f"t={now():.2f} q=[{q}]", flush=True)
                next_print += 1.0
            time.sleep(0.005)
        error = max(abs(q - t) for q, t in zip(positions(), SEED_TARGETS[min(k, 4)], strict=True))
        label = "bad command: holding target 4" if len(target) != 4 else f"target {k}"
        print(f"{label} {SEED_TARGETS[min(k, 4)]} reached: max error {error:.3e} rad", flush=True)
    del joint_states_reader, clock_reader, writer, participant, domain
    return 0


if __name__ == "__main__":
    sys.exit(main())
