"""Shared fixtures: the course package in ../shared, headless Chromium, a tiny robot."""

import compileall
import os
import shutil
import textwrap
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# Hypothesis profiles (tests/simulation/test_properties.py): "default", run by every
# `pytest`, is derandomized (the same examples every run) and small; "long", for a
# nightly run (`pytest --hypothesis-profile long`), draws many more, at random.
_SLOW_OK = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large]
settings.register_profile(
    "default", max_examples=50, derandomize=True, deadline=None, suppress_health_check=_SLOW_OK
)
settings.register_profile(
    "long", max_examples=1000, derandomize=False, deadline=None, suppress_health_check=_SLOW_OK
)
settings.load_profile("default")

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
COURSE_PACKAGE = SHARED / "upstream" / "arm_description"
IIWA_PACKAGE = SHARED / "upstream" / "iiwa_description"
FRA2MO_PACKAGE = SHARED / "upstream" / "rl_fra2mo_description"
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"


def skip_or_fail(reason: str) -> None:
    """Skips a test for a missing resource, but fails under CI, where it must exist."""
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI is set, so this is an error)")
    pytest.skip(reason)


@pytest.fixture
def course_package() -> Path:
    """The course's arm_description package (read only, never copied)."""
    if not (COURSE_PACKAGE / "urdf" / "arm.urdf").is_file():
        skip_or_fail(f"the course package is not at {COURSE_PACKAGE}")
    return COURSE_PACKAGE


@pytest.fixture
def iiwa_package() -> Path:
    """The KUKA iiwa description of the course's later chapters (read only, never copied)."""
    if not (IIWA_PACKAGE / "urdf" / "iiwa14.urdf.xacro").is_file():
        skip_or_fail(f"the iiwa package is not at {IIWA_PACKAGE}")
    return IIWA_PACKAGE


@pytest.fixture
def fra2mo_package() -> Path:
    """The course's fra2mo mobile robot (rl_fra2mo_description; read only, never copied)."""
    if not (FRA2MO_PACKAGE / "urdf" / "fra2mo.urdf.xacro").is_file():
        skip_or_fail(f"the fra2mo package is not at {FRA2MO_PACKAGE}")
    return FRA2MO_PACKAGE


@pytest.fixture
def chromium() -> str:
    """Debian's headless Chromium."""
    if not os.path.exists(CHROMIUM):
        skip_or_fail("Debian's chromium is not installed (apt-get install chromium)")
    return CHROMIUM


@pytest.fixture(scope="module")
def module_page():
    """One page of Debian's headless Chromium for a whole test module (a browser takes
    seconds to start)."""
    from browser import browser_page

    if not os.path.exists(CHROMIUM):
        skip_or_fail("Debian's chromium is not installed (apt-get install chromium)")
    with browser_page(CHROMIUM) as page:
        yield page


# A two-joint URDF without xacro or package: the robot the input tests mutate.
MINI_URDF = """\
<?xml version="1.0"?>
<robot name="mini">
  <link name="base_link">
    <inertial><mass value="1"/>
      <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="upper">
    <visual><geometry><box size="0.03 0.03 0.2"/></geometry></visual>
    <inertial><mass value="0.1"/>
      <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="lower">
    <visual><geometry><box size="0.03 0.03 0.2"/></geometry></visual>
    <inertial><mass value="0.1"/>
      <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="q1" type="revolute">
    <parent link="base_link"/><child link="upper"/>
    <origin xyz="0 0 0.125"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/>
  </joint>
  <joint name="q2" type="revolute">
    <parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="10" velocity="3"/>
  </joint>
</robot>
"""


MINI_XACRO = """\
<?xml version="1.0"?>
<robot name="mini" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="prefix" default=""/>
  <xacro:property name="prefix" value="$(arg prefix)"/>
  <xacro:include filename="$(find mini_description)/urdf/parts.xacro"/>
  <xacro:box_link name="${prefix}base_link" size="0.1 0.1 0.05" rgba="0.2 0.2 0.2 1"/>
  <xacro:box_link name="${prefix}upper" size="0.03 0.03 0.2" rgba="0.9 0.1 0.1 1"/>
  <xacro:box_link name="${prefix}lower" size="0.03 0.03 0.2" rgba="0.1 0.9 0.1 1"/>
  <joint name="${prefix}q1" type="revolute">
    <parent link="${prefix}base_link"/><child link="${prefix}upper"/>
    <origin xyz="0 0 0.125"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/>
  </joint>
  <joint name="${prefix}q2" type="revolute">
    <parent link="${prefix}upper"/><child link="${prefix}lower"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="10" velocity="3"/>
  </joint>
  <joint name="${prefix}tip_joint" type="fixed">
    <parent link="${prefix}lower"/><child link="${prefix}tip"/><origin xyz="0 0 0.1"/>
  </joint>
  <link name="${prefix}tip"/>
  EXTRA
</robot>
"""

MINI_PARTS = """\
<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="box_link" params="name size rgba">
    <link name="${name}">
      <visual>
        <geometry><box size="${size}"/></geometry>
        <material name="${name}_color"><color rgba="${rgba}"/></material>
      </visual>
      <collision><geometry><box size="${size}"/></geometry></collision>
      <inertial>
        <mass value="0.1"/>
        <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/>
      </inertial>
    </link>
  </xacro:macro>
</robot>
"""


def make_mini_package(root: Path, extra: str = "") -> Path:
    """Writes a two-joint ROS package ``mini_description`` under ``root``; returns its dir."""
    package = root / "mini_description"
    (package / "urdf").mkdir(parents=True)
    (package / "package.xml").write_text(
        '<package format="3"><name>mini_description</name></package>\n'
    )
    (package / "urdf" / "parts.xacro").write_text(MINI_PARTS)
    (package / "urdf" / "mini.urdf.xacro").write_text(
        MINI_XACRO.replace("EXTRA", textwrap.indent(extra, "  ").strip())
    )
    return package


@pytest.fixture
def mini_package(tmp_path) -> Path:
    return make_mini_package(tmp_path)


NOTEBOOKS = REPO / "notebooks"


def run_notebook(name: str, monkeypatch, timeout: int = 120) -> tuple[str, int]:
    """Runs notebooks/<name>.ipynb top to bottom in short mode (``ARMANDO_DRAKE_SHORT=1``,
    the ``python3`` kernel, from the notebooks folder): the text its cells printed and its
    image count. A notebook committed with outputs, or a cell that raises, fails."""
    import nbclient
    import nbformat

    monkeypatch.setenv("ARMANDO_DRAKE_SHORT", "1")
    notebook = nbformat.read(NOTEBOOKS / f"{name}.ipynb", as_version=4)
    assert all(
        not cell.get("outputs") and cell.get("execution_count") is None
        for cell in notebook.cells
        if cell.cell_type == "code"
    ), f"{name}.ipynb is committed with outputs; clear them"
    nbclient.NotebookClient(
        notebook,
        kernel_name="python3",
        timeout=timeout,
        resources={"metadata": {"path": str(NOTEBOOKS)}},
    ).execute()
    outputs = [output for cell in notebook.cells for output in cell.get("outputs", [])]
    text = "\n".join(output.text for output in outputs if output.output_type == "stream")
    pictures = sum("image/png" in output.get("data", {}) for output in outputs)
    return text, pictures


# The files that take longest (a few percent of the suite each, measured), heaviest first: they
# start first, so that under ``--dist loadfile`` (a file per worker, handed out in collection
# order, ``--no-loadscope-reorder``) no long file is left alone on one core at the end while
# the others idle. The other files follow in their usual order.
HEAVY_FIRST = [
    "tests/test_docs.py",
    "tests/simulation/test_every_scenario.py",
    "tests/entry_points/test_world_cli.py",
    "tests/reliability/test_hostile_inputs_3.py",
    "tests/entry_points/test_notebooks.py",
    "tests/entry_points/test_bench.py",
    "tests/sweeps/test_sweep.py",
    "tests/test_packaging.py",
    "tests/description/test_robot_packages.py",
    "tests/control/test_ros1_controllers.py",
    "tests/description/test_patterns.py",
    "tests/entry_points/test_hostile_files.py",
    "tests/entry_points/test_viewer.py",
    "tests/control/test_task_space_controllers.py",
    "tests/task/test_closed_loop.py",
    "tests/ros2/test_live_world.py",
    "tests/entry_points/test_framing.py",
    "tests/outputs/test_follow_view.py",
    "tests/entry_points/test_input_errors.py",
    "tests/vision/test_dynamic_look_at.py",
]


def pytest_collection_modifyitems(config, items):
    """Runs the files of HEAVY_FIRST first (a file's tests keep their order)."""
    missing = [path for path in HEAVY_FIRST if not (REPO / path).is_file()]
    if missing:
        raise pytest.UsageError(f"tests/conftest.py: HEAVY_FIRST names no file at {missing}")
    rank = {path: index for index, path in enumerate(HEAVY_FIRST)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))


def pytest_configure(config):
    """Compiles the package to bytecode (its __pycache__ folders) once, before the tests
    start: the hundreds of ``python -m armando_drake...`` subprocesses the tests run then
    load it instead of each compiling its ~170 modules again (half a second of CPU each),
    also where PYTHONDONTWRITEBYTECODE keeps every process from writing it. A worker of
    pytest-xdist finds it done by the process that started it."""
    if not hasattr(config, "workerinput"):
        compileall.compile_dir(REPO / "armando_drake", quiet=2)


def pytest_xdist_auto_num_workers(config):
    """``-n auto``: a worker per CPU this process may use, at most 4 (the tests start
    simulations, browsers and servers of their own)."""
    return max(1, min(4, len(os.sched_getaffinity(0))))


def refused_in_one_line(call, error: type[Exception], names, watchdog: float) -> str:
    """``call()`` raises ``error`` whose message is one line naming each of ``names``,
    within ``watchdog`` seconds (more is a hang: SIGALRM ends it)."""
    import signal

    def expired(signum, frame):
        raise TimeoutError(f"still running after {watchdog} s: a hang")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(int(watchdog))
    try:
        with pytest.raises(error) as raised:
            call()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    message = str(raised.value)
    assert "\n" not in message.strip(), message
    for name in names:
        assert name in message, (name, message)
    return message
