"""JointStateLogger: CSV rows, console lines, and rows kept when the process is killed."""

import io
import math
import re
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from armando_drake.logger import JointStateLogger, csv_header
from armando_drake.messages import JointState

JOINTS = ("j0", "j1")


def sample_at(time):
    """A made-up JointState at `time` [s] (positions, velocities, efforts known in closed form)."""
    return JointState(
        stamp=time,
        name=JOINTS,
        position=(math.sin(time), -2.0 * time),
        velocity=(math.cos(time), -2.0),
        effort=(0.5, time * time),
    )


class FreshSource(LeafSystem):
    """Outputs the sample of the current time (a computed output, never stale)."""

    def __init__(self):
        super().__init__()
        self.DeclareAbstractOutputPort(
            "joint_states",
            lambda: AbstractValue.Make(JointState()),
            lambda context, value: value.set_value(sample_at(context.get_time())),
        )


class SampledSource(LeafSystem):
    """Like a joint state broadcaster: a discrete update at `rate` holds the sample."""

    def __init__(self, rate):
        super().__init__()
        state = self.DeclareAbstractState(AbstractValue.Make(JointState()))
        self.DeclareStateOutputPort("joint_states", state)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._UpdateSample)

    def _UpdateSample(self, context, state):
        state.get_mutable_abstract_state(0).set_value(sample_at(context.get_time()))


def simulate(source, logger, end_time):
    builder = DiagramBuilder()
    builder.AddSystem(source)
    builder.AddSystem(logger)
    builder.Connect(source.GetOutputPort("joint_states"), logger.GetInputPort("joint_states"))
    Simulator(builder.Build()).AdvanceTo(end_time)


def read_rows(path):
    lines = path.read_text().splitlines()
    return lines[0], [[float(value) for value in line.split(",")] for line in lines[1:]]


def test_header_names_three_columns_per_joint():
    assert csv_header(["j0", "j1"]) == (
        "time,j0_position,j0_velocity,j0_effort,j1_position,j1_velocity,j1_effort"
    )


def test_fresh_source_gives_one_row_per_tick_including_time_zero(tmp_path):
    path = tmp_path / "joint_states.csv"
    logger = JointStateLogger(joint_names=JOINTS, update_rate=100.0, csv_path=path, quiet=True)
    simulate(FreshSource(), logger, 2.0)
    logger.close()
    header, rows = read_rows(path)
    assert header == csv_header(JOINTS)
    assert len(rows) == 2 * 100 + 1 == logger.rows_written
    for k, row in enumerate(rows):
        time_ = k / 100.0
        assert row[0] == pytest.approx(time_, abs=1e-6)
        expected = sample_at(row[0])
        assert row[1:] == pytest.approx(
            [
                expected.position[0],
                expected.velocity[0],
                expected.effort[0],
                expected.position[1],
                expected.velocity[1],
                expected.effort[1],
            ],
            rel=1e-9,
            abs=1e-9,
        )
    assert logger.last_sample.stamp == pytest.approx(2.0)


def test_sampled_source_is_logged_once_per_sample_without_duplicates(tmp_path):
    # The broadcaster's sample of time t is visible to publish events from t + 1/R on,
    # so a 1 s run at 50 Hz holds the samples 0, 0.02, ..., 0.98.
    path = tmp_path / "joint_states.csv"
    logger = JointStateLogger(joint_names=JOINTS, update_rate=50.0, csv_path=path, quiet=True)
    simulate(SampledSource(rate=50.0), logger, 1.0)
    logger.close()
    _, rows = read_rows(path)
    times = [row[0] for row in rows]
    assert times == pytest.approx([k / 50.0 for k in range(50)], abs=1e-6)
    assert [row[4] for row in rows] == pytest.approx([-2.0 * t for t in times])


def test_joint_order_follows_the_logger_and_missing_fields_are_nan(tmp_path):
    class Reordered(LeafSystem):
        def __init__(self):
            super().__init__()
            self.DeclareAbstractOutputPort(
                "joint_states",
                lambda: AbstractValue.Make(JointState()),
                lambda context, value: value.set_value(
                    JointState(stamp=context.get_time(), name=("j1", "j0"), position=(1.0, 2.0))
                ),
            )

    path = tmp_path / "joint_states.csv"
    with JointStateLogger(
        joint_names=JOINTS, update_rate=10.0, csv_path=path, quiet=True
    ) as logger:
        simulate(Reordered(), logger, 0.1)
    _, rows = read_rows(path)
    assert len(rows) == 2
    assert rows[1][0] == pytest.approx(0.1)
    assert rows[1][1] == 2.0 and rows[1][4] == 1.0  # j0, j1 positions
    assert all(math.isnan(value) for value in rows[1][2:4] + rows[1][5:7])


def test_a_sample_missing_a_joint_is_an_error():
    logger = JointStateLogger(joint_names=("j0", "j9"), update_rate=10.0, quiet=True)
    with pytest.raises(ValueError, match="has no joint 'j9'"):
        simulate(FreshSource(), logger, 0.1)


def test_console_prints_positions_once_a_second():
    stream = io.StringIO()
    logger = JointStateLogger(joint_names=JOINTS, update_rate=100.0, stream=stream)
    simulate(FreshSource(), logger, 2.5)
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
    simulate(
        FreshSource(),
        JointStateLogger(joint_names=JOINTS, update_rate=10.0, stream=stream, quiet=True),
        2.0,
    )
    assert stream.getvalue() == ""
    simulate(
        FreshSource(),
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
        simulate(FreshSource(), logger, 0.1)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(joint_names=(), update_rate=10.0), "joint_names=()"),
        (dict(joint_names=("j0", "j0"), update_rate=10.0), "has duplicates"),
        (dict(joint_names=JOINTS, update_rate=0.0), "update_rate=0.0 must be positive"),
        (dict(joint_names=JOINTS, update_rate=10.0, console_rate=-1.0), "console_rate=-1.0"),
    ],
)
def test_bad_arguments_are_rejected(kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        JointStateLogger(**kwargs)


KILLED_RUN = """
import sys
import time
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from armando_drake.logger import JointStateLogger
from armando_drake.messages import JointState


class Source(LeafSystem):
    def __init__(self):
        super().__init__()
        self.DeclareAbstractOutputPort(
            "joint_states",
            lambda: AbstractValue.Make(JointState()),
            lambda context, value: value.set_value(JointState(
                stamp=context.get_time(), name=("j0", "j1"),
                position=(0.123456789, -1.0), velocity=(2.0, 3.0), effort=(4.0, 5.0))),
        )


builder = DiagramBuilder()
source = builder.AddSystem(Source())
logger = builder.AddSystem(JointStateLogger(
    joint_names=("j0", "j1"), update_rate=1000.0, csv_path=sys.argv[1], quiet=True))
builder.Connect(source.get_output_port(), logger.get_input_port())
simulator = Simulator(builder.Build())
simulator.AdvanceTo(0.5)
print("at 0.5 s", flush=True)
if sys.argv[2] == "pause":
    time.sleep(600)  # killed while paused: rows 0 .. 0.5 s must all be on disk
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


def check_rows(path):
    """Every line complete, rows in order with the published values; returns the row count."""
    assert path.read_text().endswith("\n")
    header, rows = read_rows(path)
    assert header == csv_header(("j0", "j1"))
    for k, row in enumerate(rows):
        assert len(row) == 7
        assert row[0] == pytest.approx(k / 1000.0, abs=1e-6)
        assert row[1:] == [0.123456789, 2.0, 4.0, -1.0, 3.0, 5.0]
    return len(rows)


def test_a_run_killed_while_paused_keeps_every_row(tmp_path):
    assert check_rows(run_and_kill(tmp_path, "pause")) == 501  # 0, 0.001, ..., 0.5 s


def test_a_run_killed_while_writing_leaves_only_complete_rows(tmp_path):
    assert check_rows(run_and_kill(tmp_path, "run")) > 501
