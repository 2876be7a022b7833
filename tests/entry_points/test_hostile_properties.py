"""Properties of the guarded readers and the output-folder lock, over generated hostile
inputs: whatever kind of file is given as a scenario or a controller YAML (a FIFO, a
directory, a device, a file over the size limit, YAML whose aliases expand beyond the
bound, at any depth and width), the reader refuses it in one line naming the file, and
never blocks or expands it; however many runs start on one output folder at once, exactly
one holds it and each other is told which process does."""

import contextlib
import os
import signal
import threading
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armando_drake.control.config import load_controller_config
from armando_drake.outputs.folder_lock import OutputFolderBusy, output_folder_lock
from armando_drake.simulation.scenario import load_scenario
from armando_drake.tools.errors import UserInputError
from armando_drake.tools.files import MAX_YAML_BYTES, MAX_YAML_NODES

WATCHDOG = 20  # [s] a refusal takes milliseconds; a read that blocks is a hang


@contextlib.contextmanager
def watchdog(seconds: int = WATCHDOG):
    """Fails the example (instead of hanging the suite) if the block outlives ``seconds``."""

    def expired(signum, frame):
        raise TimeoutError(f"still running after {seconds} s: a hang")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def alias_yaml(levels: int, width: int, used: bool) -> str:
    """Aliases of aliases: ``width ** levels`` nodes once expanded."""
    lines = [f"l0: &l0 [{', '.join(['x'] * width)}]"]
    for level in range(1, levels):
        lines.append(f"l{level}: &l{level} [{', '.join([f'*l{level - 1}'] * width)}]")
    if used:
        lines.append(f"use: *l{levels - 1}")
    return "\n".join(lines) + "\n"


@st.composite
def hostile_files(draw):
    """(kind, writer): a kind of file and a function making one at a path."""
    kind = draw(st.sampled_from(["fifo", "directory", "device", "huge", "aliases"]))
    if kind == "aliases":
        width = draw(st.integers(2, 12))
        # Deep enough that the expansion passes the bound, whatever the width.
        levels = 1
        while width**levels <= MAX_YAML_NODES:
            levels += 1
        levels += draw(st.integers(0, 4))
        used = draw(st.booleans())
        return kind, lambda path: path.write_text(alias_yaml(levels, width, used))
    if kind == "huge":
        extra = draw(st.integers(1, 2**20))

        def huge(path: Path) -> None:
            with open(path, "wb") as stream:  # sparse: no disk used
                stream.truncate(MAX_YAML_BYTES + extra)

        return kind, huge
    if kind == "fifo":
        return kind, lambda path: os.mkfifo(path)
    if kind == "directory":
        return kind, lambda path: path.mkdir()
    device = draw(st.sampled_from(["/dev/zero", "/dev/urandom", "/dev/null"]))
    return kind, lambda path: path.symlink_to(device)


EXPECTED = {
    "fifo": "a FIFO, not a file",
    "directory": "a directory, not a file",
    "device": "a character device, not a file",
    "huge": "over 8 MiB: too large",
    "aliases": "200,000",
}


@settings(max_examples=40)
@given(
    case=hostile_files(),
    reader=st.sampled_from(["scenario", "controller"]),
    name=st.sampled_from(["s.yaml", "with space.yaml", "ünï.yaml", "x.yml"]),
)
def test_a_hostile_file_is_refused_in_one_line_naming_it(case, reader, name, tmp_path_factory):
    kind, make = case
    path = tmp_path_factory.mktemp("hostile") / name
    make(path)
    load = load_scenario if reader == "scenario" else load_controller_config
    with watchdog(), pytest.raises(UserInputError) as raised:
        load(path)
    message = str(raised.value)
    assert "\n" not in message and len(message) < 1000, message
    assert str(path) in message, message
    if kind == "aliases":
        assert f"{MAX_YAML_NODES:,}" in message or str(MAX_YAML_NODES) in message, message
    else:
        assert EXPECTED[kind] in message, message


@settings(max_examples=15)
@given(runs=st.integers(2, 8))
def test_of_runs_starting_at_once_on_one_folder_exactly_one_holds_it(runs, tmp_path_factory):
    folder = tmp_path_factory.mktemp("out")
    start = threading.Barrier(runs)
    holding = threading.Barrier(runs)  # every attempt made while the winner holds the lock
    outcomes: list[str] = []
    lock = threading.Lock()

    def run() -> None:
        start.wait()
        try:
            with output_folder_lock(folder):
                with lock:
                    outcomes.append("held")
                holding.wait(WATCHDOG)
        except OutputFolderBusy as busy:
            with lock:
                outcomes.append(str(busy))
            holding.wait(WATCHDOG)

    threads = [threading.Thread(target=run) for _ in range(runs)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(WATCHDOG)
    assert outcomes.count("held") == 1, outcomes
    refusals = [o for o in outcomes if o != "held"]
    assert len(refusals) == runs - 1
    for refusal in refusals:
        assert refusal == (
            f"--output {folder}: another run (process {os.getpid()}) is writing there; "
            "give each run a folder of its own"
        )
    # The lock went with its holder: the next run takes the folder.
    with output_folder_lock(folder):
        pass
