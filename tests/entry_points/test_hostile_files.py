"""Hostile files and values end in one line, exit 2, in bounded time and memory: a YAML
alias bomb (defined or used, in a file or a --set), a FIFO or a device as the controller
YAML, a directory, a file over the size limit. Each run is a process of its own under a
memory limit, killed if it outlives its time."""

import os
import resource
import subprocess
import sys
import time

import pytest

from armando_drake.tools.files import (
    MAX_YAML_BYTES,
    MAX_YAML_NODES,
    FileInputError,
    check_yaml_expansion,
    read_text_file,
)

MEMORY_LIMIT = 3 * 2**30  # [bytes] of address space: far above a run, far below a bomb
TIME_LIMIT = 60  # [s] a run here takes a few seconds


def alias_bomb(levels: int = 12, width: int = 9) -> str:
    """A "billion laughs" mapping: each level an alias list of the one before."""
    lines = [f"l0: &l0 [{', '.join(['lol'] * width)}]"]
    for level in range(1, levels):
        items = ", ".join([f"*l{level - 1}"] * width)
        lines.append(f"l{level}: &l{level} [{items}]")
    return "\n".join(lines) + "\n"


def world(*args, cwd) -> tuple[subprocess.CompletedProcess, float]:
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    start = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--realtime-rate", "0"]
        + ["--duration", "0.1", "--quiet", *args],
        capture_output=True,
        text=True,
        timeout=TIME_LIMIT,
        cwd=cwd,
        preexec_fn=limit,
    )
    return result, time.monotonic() - start


def one_line_error(result) -> str:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    return lines[0]


def test_an_alias_bomb_in_a_scenario_file_is_refused_before_it_expands(tmp_path):
    (tmp_path / "bomb.yaml").write_text(alias_bomb() + "robot: {}\n")
    result, seconds = world("--scenario", "bomb.yaml", cwd=tmp_path)
    line = one_line_error(result)
    assert "bomb.yaml" in line and "alias" in line
    assert seconds < 30


def test_an_alias_bomb_in_a_set_is_refused_and_its_text_cut(tmp_path):
    bomb = "{" + alias_bomb().strip().replace("\n", ", ") + "}"
    result, _ = world("--set", bomb, cwd=tmp_path)
    line = one_line_error(result)
    assert line.startswith("error: --set ") and "alias" in line
    assert len(line) < 600  # the override is cut in the message


@pytest.mark.parametrize("kind", ["fifo", "device", "directory"])
def test_a_controller_yaml_that_is_no_regular_file_is_refused_at_once(tmp_path, kind):
    if kind == "fifo":
        path = tmp_path / "controllers.fifo"
        os.mkfifo(path)  # opening it for reading would block for ever
    elif kind == "device":
        path = "/dev/zero"  # reading it would fill the memory
    else:
        path = tmp_path
    result, seconds = world("--set", f"controllers: {{config: '{path}'}}", cwd=tmp_path)
    line = one_line_error(result)
    assert str(path) in line and "must be a regular file" in line
    assert seconds < 30


def test_a_file_over_the_size_limit_is_refused_naming_it(tmp_path):
    big = tmp_path / "big.yaml"
    with big.open("w") as stream:
        stream.write("# padding\n" * (MAX_YAML_BYTES // 10 + 1))
    with pytest.raises(FileInputError, match="big.yaml: over 8 MiB"):
        read_text_file(big, what="a controller file")


def test_the_expansion_count_is_linear_in_the_text_and_exact_below_the_limit():
    small = alias_bomb(levels=3, width=3)  # 3 + 9 + 27 leaves and their lists
    check_yaml_expansion(small, "small.yaml")  # far below the limit: passes
    start = time.monotonic()
    with pytest.raises(FileInputError, match=f"over {MAX_YAML_NODES:,} nodes"):
        check_yaml_expansion(alias_bomb(levels=40, width=9), "huge.yaml")  # 9^40 nodes
    assert time.monotonic() - start < 2.0
    with pytest.raises(FileInputError, match="contains it"):
        check_yaml_expansion("a: &a [1, *a]\n", "recursive.yaml")


def test_two_runs_given_one_output_folder_never_mix(tmp_path):
    """The second run is refused at once, naming the first's process; the first's files
    are its own, whole; once it ended, the folder takes a new run."""
    out = tmp_path / "out"
    first = subprocess.Popen(
        [sys.executable, "-m", "armando_drake.world", "--no-meshcat", "--quiet"]
        + ["--realtime-rate", "1", "--duration", "6", "--no-replay", "--output", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    lock = out / ".armando_drake.lock"
    deadline = time.monotonic() + TIME_LIMIT
    while not (lock.is_file() and lock.read_text().strip()) and time.monotonic() < deadline:
        time.sleep(0.05)
    result, seconds = world("--output", str(out), "--duration", "2", cwd=tmp_path)
    line = one_line_error(result)
    assert f"--output {out}: another run (process {first.pid})" in line
    assert seconds < 30
    _, stderr = first.communicate(timeout=TIME_LIMIT)
    assert first.returncode == 0, stderr
    assert not lock.exists()
    rows = (out / "joint_states.csv").read_text().splitlines()
    assert len(rows) == 1 + 601  # the header, and 0 to 6 s at 100 Hz: the first run's only
    result, _ = world("--output", str(out), cwd=tmp_path)  # the folder is free again
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize(
    "args, expected",
    [
        (["--set", "null"], "--set 'null': nothing to set (null)"),
        (["--set", "actuators: null"], "actuators: expected a mapping, got null"),
        (["--scenario", "a" * 100_000], "File name too long"),
    ],
    ids=["set-null", "section-null", "long-path"],
)
def test_remaining_error_paths_are_one_short_line(tmp_path, args, expected):
    result, _ = world(*args, cwd=tmp_path)
    line = one_line_error(result)
    assert expected in line and len(line) < 1200


def test_a_run_without_a_broadcaster_writes_its_summary_and_no_plots(tmp_path):
    out = tmp_path / "out"
    result, _ = world(
        "--set",
        "{controllers: {activate: []}, sequencer: null}",
        "--output",
        str(out),
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert (out / "summary.json").is_file() and not list(out.glob("*.png"))


@pytest.mark.parametrize(
    "command, expected",
    [
        (
            ["sweep", "--grid", "actuators.kp=linspace(1, 2, 100000000)", "--dry-run"],
            "100,000,000 values, over 100,000 for one axis",
        ),
        (
            [
                "sweep",
                "--grid",
                "actuators.kp=linspace(1, 2, 10000)",
                "--grid",
                "actuators.kd=linspace(0.1, 0.2, 10000)",
                "--dry-run",
            ],
            "100,000,000 variants, over 100,000",
        ),
        (
            ["dataset", "ik", "--samples", "1000000000000", "--output", "ik.parquet"],
            "over 10,000,000 rows (about 186,265 GiB",
        ),
    ],
    ids=["one-axis", "grid", "dataset"],
)
def test_work_sized_by_user_numbers_is_refused_with_its_estimate(tmp_path, command, expected):
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    start = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", f"armando_drake.{command[0]}", *command[1:]],
        capture_output=True,
        text=True,
        timeout=TIME_LIMIT,
        cwd=tmp_path,
        preexec_fn=limit,
    )
    assert expected in one_line_error(result)
    assert time.monotonic() - start < 30  # nothing was materialised


def test_a_data_set_written_to_a_folder_is_one_line_naming_it(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "armando_drake.dataset", "ik", "--samples", "5"]
        + ["--output", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=TIME_LIMIT,
        cwd=tmp_path,
    )
    assert f"--output {tmp_path}: a folder" in one_line_error(result)


LINK = (
    '<link name="{name}"><visual><geometry>{shape}</geometry></visual><inertial>'
    '<mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/>'
    "</inertial></link>\n"
)
JOINT = (
    '<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
    '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>\n'
)


def chain_urdf(shape: str = '<box size="0.1 0.1 0.1"/>', extra_joint: str = "") -> str:
    links = "".join(
        LINK.format(name=n, shape=shape if n == "b" else "<sphere radius='0.05'/>") for n in "abc"
    )
    joints = "".join(
        JOINT.format(name=f"j{i}", parent=p, child=c)
        for i, (p, c) in enumerate([("base_link", "a"), ("a", "b"), ("b", "c")])
    )
    return (
        '<?xml version="1.0"?>\n<robot name="chain">\n<link name="base_link"/>\n'
        f"{links}{joints}{extra_joint}</robot>\n"
    )


@pytest.mark.parametrize(
    "urdf, expected",
    [
        (
            chain_urdf(extra_joint=JOINT.format(name="j3", parent="c", child="a")),
            "chain.urdf:10: joint 'j3' makes link 'a' the child of a second joint (the first "
            "is 'j0', line 7): the joints form a kinematic loop",
        ),
        (
            chain_urdf(shape='<box size="0.1 -0.2 0.1"/>'),
            "chain.urdf:5: link 'b' <visual> <box size=\"0.1 -0.2 0.1\">: must be 3 positive "
            "lengths [m]",
        ),
        (
            chain_urdf(shape='<cylinder radius="0.05" length="nan"/>'),
            "chain.urdf:5: link 'b' <visual> <cylinder length=\"nan\">: must be 1 positive "
            "length [m]",
        ),
    ],
    ids=["kinematic loop", "negative box side", "cylinder length nan"],
)
def test_a_urdf_drake_cannot_build_is_one_line_naming_file_line_and_value(tmp_path, urdf, expected):
    (tmp_path / "chain.urdf").write_text(urdf)
    run, _ = world("--description", "chain.urdf", cwd=tmp_path)
    assert expected in one_line_error(run)
    display = subprocess.run(
        [sys.executable, "-m", "armando_drake.display", "--description", "chain.urdf"]
        + ["--loop-once"],
        capture_output=True,
        text=True,
        timeout=TIME_LIMIT,
        cwd=tmp_path,
    )
    assert display.returncode == 2 and "Traceback" not in display.stderr, display.stderr
    assert expected in display.stderr.strip().splitlines()[-1]


@pytest.mark.parametrize("name", ["joint_states.csv", "commands.csv", "summary.json", "run.mcap"])
def test_a_full_disk_is_one_line_naming_the_file_it_could_not_write(tmp_path, name):
    """/dev/full answers every write with ENOSPC, as a full disk does."""
    if not os.path.exists("/dev/full"):
        pytest.skip("this system has no /dev/full")
    output = tmp_path / "out"
    output.mkdir()
    (output / name).symlink_to("/dev/full")
    where = ["--record", str(output / name)] if name.endswith(".mcap") else ["--output", "out"]
    result, _ = world(*where, cwd=tmp_path)
    line = one_line_error(result)
    assert line == (
        f"error: {output / name if name.endswith('.mcap') else 'out/' + name}: cannot write: "
        "no space left on the device (the disk is full)"
    )
