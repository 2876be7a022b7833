"""JointStateLogger: CSV rows, console lines, flushing, and rows kept when a run is killed."""

import io
import math
import re
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem

from armando_drake.outputs.logger import JointStateLogger, csv_header, read_csv

JOINTS = ("j0", "j1")


def sample_at(time):
    """[q0, q1, v0, v1, effort0, effort1] at `time` [s], known in closed form."""
    return [math.sin(time), -2.0 * time, math.cos(time), -2.0, 0.5, time * time]


class Source(LeafSystem):
    """Outputs ``layout(sample_at(t))`` (a computed output of the current time)."""

    def __init__(self, layout=lambda sample: sample, size=6):
        super().__init__()
        self.DeclareVectorOutputPort(
            "y",
            BasicVector(size),
            lambda context, out: out.SetFromVector(layout(sample_at(context.get_time()))),
        )


def simulate(logger, end_time, source=None):
    """Runs ``source`` into ``logger`` to ``end_time``; returns the logger's context."""
    builder = DiagramBuilder()
    source = builder.AddSystem(source or Source())
    builder.AddSystem(logger)
    builder.Connect(source.get_output_port(), logger.get_input_port())
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(end_time)
    return logger.GetMyContextFromRoot(simulator.get_context())


def read_rows(path):
    lines = path.read_text().splitlines()
    return lines[0], [[float(value) for value in line.split(",")] for line in lines[1:]]


def test_header_names_three_columns_per_joint():
    assert csv_header(["j0", "j1"]) == (
        "time,j0_position,j0_velocity,j0_effort,j1_position,j1_velocity,j1_effort"
    )


def test_one_row_per_tick_from_time_zero_to_the_end(tmp_path):
    path = tmp_path / "joint_states.csv"
    logger = JointStateLogger(joint_names=JOINTS, update_rate=100.0, csv_path=path, quiet=True)
    simulate(logger, 2.0)  # flushed at 0, 1 and 2 s; the sample of 2 s is recorded first
    logger.close()
    header, rows = read_rows(path)
    assert header == csv_header(JOINTS)
    assert len(rows) == 2 * 100 + 1 == logger.rows_written
    for k, row in enumerate(rows):
        assert row[0] == pytest.approx(k / 100.0, abs=1e-6)
        q0, q1, v0, v1, e0, e1 = sample_at(row[0])
        assert row[1:] == pytest.approx([q0, v0, e0, q1, v1, e1], rel=1e-9, abs=1e-9)
    assert logger.last_row[0] == pytest.approx(2.0)


def test_flush_writes_what_was_recorded_since_the_last_flush_once(tmp_path):
    # A run stopped between two flushes (Ctrl-C): the world's close(context) calls flush.
    path = tmp_path / "joint_states.csv"
    logger = JointStateLogger(joint_names=JOINTS, update_rate=100.0, csv_path=path, quiet=True)
    context = simulate(logger, 1.555)
    assert len(read_rows(path)[1]) == 101  # flushed at 0 and 1 s: rows 0 .. 1.00 s
    logger.flush(context)
    logger.flush(context)  # nothing new: nothing written
    logger.close()
    _, rows = read_rows(path)
    assert [row[0] for row in rows] == pytest.approx([k / 100 for k in range(156)], abs=1e-6)


def test_rows_come_from_the_given_indices_and_missing_effort_is_nan(tmp_path):
    # Input [unused, q1, q0, v1, v0]: no effort.
    def layout(sample):
        q0, q1, v0, v1, _, _ = sample
        return [7.0, q1, q0, v1, v0]

    path = tmp_path / "joint_states.csv"
    with JointStateLogger(
        joint_names=JOINTS,
        update_rate=10.0,
        input_size=5,
        position_index=(2, 1),
        velocity_index=(4, 3),
        effort_index=(),
        csv_path=path,
        quiet=True,
    ) as logger:
        simulate(logger, 1.0, Source(layout, size=5))
    _, rows = read_rows(path)
    assert len(rows) == 11
    q0, q1, v0, v1, _, _ = sample_at(rows[5][0])
    assert rows[5][1:3] == pytest.approx([q0, v0]) and rows[5][4:6] == pytest.approx([q1, v1])
    assert math.isnan(rows[5][3]) and math.isnan(rows[5][6])


def test_console_prints_positions_once_a_second():
    stream = io.StringIO()
    logger = JointStateLogger(joint_names=JOINTS, update_rate=100.0, stream=stream)
    simulate(logger, 2.5)
    lines = stream.getvalue().splitlines()
    # t = 0, 1, 2: a header line and one line per joint each.
    assert len(lines) == 3 * 3
    headers = lines[0::3]
    assert headers == [
        "[t=0.000 s] Joint positions:",
        "[t=1.000 s] Joint positions:",
        "[t=2.000 s] Joint positions:",
    ]
    joint_lines = [line for k, line in enumerate(lines) if k % 3]
    for line in joint_lines:
        assert re.fullmatch(r"Joint j\d: -?\d+\.\d{3}", line), line
    assert lines[4:6] == [f"Joint j0: {math.sin(1.0):.3f}", "Joint j1: -2.000"]


def test_quiet_prints_nothing_and_console_rate_is_honoured():
    stream = io.StringIO()
    simulate(JointStateLogger(joint_names=JOINTS, update_rate=10.0, stream=stream, quiet=True), 2.0)
    assert stream.getvalue() == ""
    simulate(
        JointStateLogger(joint_names=JOINTS, update_rate=10.0, console_rate=4.0, stream=stream),
        1.0,
    )
    assert stream.getvalue().count("Joint positions:") == 5  # 0, 0.25, ..., 1.0


def test_close_is_safe_twice_and_writing_after_close_is_an_error(tmp_path):
    path = tmp_path / "out" / "joint_states.csv"
    logger = JointStateLogger(joint_names=JOINTS, update_rate=10.0, csv_path=path, quiet=True)
    logger.close()
    logger.close()
    assert path.read_text() == csv_header(JOINTS) + "\n"
    with pytest.raises(RuntimeError, match="was closed"):
        simulate(logger, 0.1)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(joint_names=(), update_rate=10.0), "joint_names=()"),
        (dict(joint_names=("j0", "j0"), update_rate=10.0), "has duplicates"),
        (dict(joint_names=JOINTS, update_rate=0.0), "update_rate=0.0 must be positive"),
        (dict(joint_names=JOINTS, update_rate=10.0, console_rate=-1.0), "console_rate=-1.0"),
        (dict(joint_names=JOINTS, update_rate=10.0, flush_rate=0), "flush_rate=0 must be"),
        (
            dict(joint_names=JOINTS, update_rate=10.0, position_index=(0,)),
            "position_index=[0] must give one row in [0, 6) per joint",
        ),
        (
            dict(joint_names=JOINTS, update_rate=10.0, input_size=4, velocity_index=(2, 4)),
            "velocity_index=[2, 4] must give one row in [0, 4)",
        ),
    ],
)
def test_bad_arguments_are_rejected(kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        JointStateLogger(**kwargs)


KILLED_RUN = """
import sys
import time
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource
from armando_drake.outputs.logger import JointStateLogger

builder = DiagramBuilder()
source = builder.AddSystem(ConstantVectorSource([0.123456789, -1.0, 2.0, 3.0, 4.0, 5.0]))
logger = builder.AddSystem(JointStateLogger(
    joint_names=("j0", "j1"), update_rate=1000.0, flush_rate=10.0, csv_path=sys.argv[1],
    quiet=True))
builder.Connect(source.get_output_port(), logger.get_input_port())
simulator = Simulator(builder.Build())
simulator.AdvanceTo(0.5)
print("at 0.5 s", flush=True)
if sys.argv[2] == "pause":
    time.sleep(600)  # killed while paused: rows 0 .. 0.5 s (flushed at 0.5 s) are on disk
else:
    simulator.AdvanceTo(1e6)  # killed while writing rows
"""


def run_and_kill(tmp_path, how):
    """Runs a 1 kHz logger in a subprocess, SIGKILLs it after 0.5 s of simulation."""
    script = tmp_path / "killed_run.py"
    script.write_text(textwrap.dedent(KILLED_RUN))
    path = tmp_path / "joint_states.csv"
    process = subprocess.Popen(
        [sys.executable, str(script), str(path), how], stdout=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout.readline().strip() == "at 0.5 s"
        time.sleep(0.3)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=30)
        process.stdout.close()
    assert process.returncode == -signal.SIGKILL
    return path


def check_rows(path, cut_short=False):
    """Every line complete, rows in order with the published values; returns the row count.

    ``cut_short``: the process was killed inside a write, which the kernel may stop
    between two pages of the file, so the last line may be cut short: it must then be
    the beginning of the next row, and ``read_csv`` must skip it."""
    text = path.read_text()
    if cut_short and not text.endswith("\n"):
        cut = text[text.rfind("\n") + 1 :]
        complete = text[: len(text) - len(cut)]
        k = complete.count("\n") - 1  # the row it began
        assert f"{k / 1000.0:.6f},0.123456789,2,4,-1,3,5\n".startswith(cut), cut
        path.write_text(complete)
        assert read_csv(path)[1].shape == (k, 7)
        path.write_text(text)
        assert read_csv(path)[1].shape == (k, 7)  # the cut line skipped
        path.write_text(complete)
    assert path.read_text().endswith("\n")
    header, rows = read_rows(path)
    assert header == csv_header(("j0", "j1"))
    for k, row in enumerate(rows):
        assert len(row) == 7
        assert row[0] == pytest.approx(k / 1000.0, abs=1e-6)
        assert row[1:] == [0.123456789, 2.0, 4.0, -1.0, 3.0, 5.0]
    return len(rows)


def test_a_run_killed_while_paused_keeps_every_flushed_row(tmp_path):
    assert check_rows(run_and_kill(tmp_path, "pause")) == 501  # 0, 0.001, ..., 0.5 s


def test_a_run_killed_while_writing_leaves_only_complete_rows(tmp_path):
    assert check_rows(run_and_kill(tmp_path, "run"), cut_short=True) > 501


@pytest.mark.parametrize(
    "cut",
    ["0.00", "0.002000,0.1", "0.002000,0.123456789,2,4,-1,3,", "0.002000,0.123456789,2,4,-1,3,5"],
)
def test_a_last_line_cut_short_is_skipped_by_the_reader(tmp_path, cut):
    # Where a kill inside a write may leave the file: the complete rows are read, the
    # unterminated last line (even one with every field, the last one cut) is not.
    path = tmp_path / "joint_states.csv"
    rows = "".join(f"{t:.6f},0.123456789,2,4,-1,3,5\n" for t in (0.0, 0.001))
    path.write_text(csv_header(("j0", "j1")) + "\n" + rows + cut)
    header, data = read_csv(path)
    assert header == csv_header(("j0", "j1")).split(",")
    assert data.shape == (2, 7)
    assert data[:, 0].tolist() == [0.0, 0.001]


def test_a_simulation_slower_than_real_time_flushes_at_least_every_half_second(tmp_path):
    """At a tenth of real time a simulated second (flush_rate's flush) is ten seconds of
    wall time: the rows reach the file every half second of wall time instead."""
    path = tmp_path / "states.csv"
    logger = JointStateLogger(
        joint_names=JOINTS, update_rate=100.0, csv_path=path, stream=io.StringIO()
    )
    builder = DiagramBuilder()
    source = builder.AddSystem(Source())
    builder.AddSystem(logger)
    builder.Connect(source.get_output_port(), logger.get_input_port())
    simulator = Simulator(builder.Build())
    simulator.set_target_realtime_rate(0.1)
    simulator.AdvanceTo(0.3)  # 3 s of wall time, no flush_rate flush since t = 0
    _, rows = read_rows(path)  # without a flush or a close: what a kill would leave
    assert rows[-1][0] >= 0.2 - 1e-9
    assert [row[0] for row in rows] == pytest.approx([k / 100 for k in range(len(rows))])


def test_a_negative_zero_prints_as_zero():
    from armando_drake.outputs.logger import rounded
    from armando_drake.simulation.run import StepResult, format_table

    assert f"{rounded(-0.0001):.3f}" == "0.000" and f"{rounded(-0.0006):.3f}" == "-0.001"
    step = StepResult(
        start=0.0,
        end=3.0,
        target=[0.0, -0.0],
        reached=[-0.0002, 0.0],
        final_error=0.0002,
        largest_error_after_settling=None,
        settling_time=None,
    )
    table = format_table(["a", "b"], [step])
    assert "-0.000" not in table
    assert table.splitlines()[1].split()[2:6] == ["0.000"] * 4


def test_the_base_headline_prints_no_negative_zero():
    from armando_drake.outputs.headlines import base_line

    line = base_line(
        {
            "final_pose": {"x": 0.392, "y": -0.0000004, "yaw": -0.0001},
            "distance_travelled": 0.39,
            "odometry_drift": {"final_position": 0.004, "final_heading": -0.0002},
        }
    )
    assert "-0.000" not in line
    assert line.startswith("base: at (0.392, 0.000) m, yaw 0.000 rad, after 0.39 m driven")
