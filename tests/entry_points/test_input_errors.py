"""Every class of bad input to ``python -m armando_drake.world``: one line, the source named,
exit code 2, no traceback, no Drake ``Failure at`` line; an internal error is one line and
exit 1 (the traceback with ``--debug``).

Most cases call the command's ``main`` in this process (an input error ends before any
simulation, so each takes milliseconds once pydrake is loaded); a few run it as a user
would, in a subprocess, to check what the shell sees.
"""

import math
import shlex
import subprocess
import sys
import textwrap

import pytest
from conftest import MINI_URDF

from armando_drake import DIAGRAMS_DIR, world

URDF = MINI_URDF.replace("</robot>", "  EXTRA\n</robot>")

FAST = ["--no-meshcat", "--realtime-rate", "0", "--duration", "0.05", "--quiet"]
POSITION = str(DIAGRAMS_DIR / "position.yaml")


def run_main(*args: str, capsys) -> tuple[int, str, str]:
    """``main(args)`` in this process: (exit code, stdout, stderr)."""
    try:
        code = world.main([*FAST, *args])
    except SystemExit as end:
        code = end.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_line(err: str, *needles: str) -> str:
    """``err`` is one ``error: ...`` line holding every needle, with no traceback."""
    assert "Traceback" not in err and "Failure at" not in err, err
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def set_(text: str) -> tuple[str, str]:
    return ("--set", text)


# (id, arguments, what the one line must hold: the value/key and the source)
SCENARIO_CASES = [
    ("duration-nan", ["--duration", "nan"], ["--duration nan", "finite"]),
    ("duration-inf", ["--duration", "inf"], ["--duration inf", "finite"]),
    (
        "inf-in-set",
        ["--set", "logging: {console_rate: .inf}"],
        ["logging.console_rate=inf", "--set 'logging: {console_rate: .inf}'"],
    ),
    (
        "contact-approximation",
        [*set_("plant_config: {discrete_contact_approximation: foo}")],
        ["discrete_contact_approximation='foo'", "--set 'plant_config"],
    ),
    ("kp-negative", [*set_("actuators: {kp: -1}")], ["actuators.kp=-1.0", "--set"]),
    ("kd-negative", [*set_("actuators: {kd: -0.5}")], ["actuators.kd=-0.5", "--set"]),
    ("kp-nan", [*set_("actuators: {kp: .nan}")], ["actuators.kp=nan", "--set"]),
    ("kp-huge", [*set_("actuators: {kp: 1e12}")], ["actuators.kp=1000000000000.0", "--set"]),
    ("gains-short", [*set_("actuators: {gains: {j0: [1]}}")], ["actuators.gains.j0=[1.0]"]),
    (
        "gains-unknown-joint",
        [*set_("actuators: {gains: {elbow: [1, 0.1]}}")],
        ["actuators.gains.elbow", "no actuated joint 'elbow'", "--set"],
    ),
    (
        "base-nan",
        [*set_("robot: {base_xyz: [.nan, 0, 0]}")],
        ["robot.base_xyz.0=nan", "--set"],
    ),
    ("base-two", [*set_("robot: {base_xyz: [0, 0]}")], ["robot.base_xyz=[0.0, 0.0]", "3"]),
    (
        "object",
        [*set_("objects: [{name: b, shape: !Box {size: [-1, 1, 1]}}]")],
        ["objects.0", "Box x=-1.0", "--set 'objects"],
    ),
    ("time-step-negative", [*set_("plant_config: {time_step: -0.001}")], ["time_step=-0.001"]),
    ("time-step-nan", [*set_("plant_config: {time_step: .nan}")], ["time_step=nan", "--set"]),
    (
        "time-step-above-controller-period",
        [*set_("plant_config: {time_step: 10}")],
        ["time_step=10.0", "controller period 1/100 s", "--set"],
    ),
    (
        "update-rate-above-plant",
        [*set_("controllers: {update_rate: 100000}")],
        ["update_rate=100000", "plant's rate 1000 Hz", "--set"],
    ),
    (
        "sequencer-period-below-controller",
        [*set_("sequencer: {period: 1e-9}")],
        ["sequencer.period=1e-09", "controller period", "--set"],
    ),
    (
        "console-rate",
        [*set_("logging: {console_rate: 1e9}")],
        ["logging.console_rate=1000000000.0", "--set"],
    ),
    (
        "sinusoid-frequency-above-nyquist",
        ["--controller", "sinusoid", *set_("sequencer: {frequency: 1000}")],
        ["sequencer.frequency=1000.0", "--set"],
    ),
    (
        "save-rate",
        [*set_("camera: {save_rate: -1}")],
        ["camera.save_rate=-1.0", "--set 'camera: {save_rate: -1}'"],
    ),
    ("save-rate-option", ["--save-rate", "-1"], ["--save-rate -1.0"]),
    ("camera-max-rate-option", ["--camera-max-rate", "-1"], ["--camera-max-rate -1.0"]),
    ("realtime-rate-nan", ["--realtime-rate", "nan"], ["--realtime-rate nan"]),
    (
        "integration-scheme",
        [*set_("simulator_config: {integration_scheme: rk9}")],
        ["integration_scheme='rk9'", "--set"],
    ),
    (
        "tiny-time-step",
        [*set_("plant_config: {time_step: 1e-9}")],
        ["plant_config.time_step=1e-09", "hours", "--set"],
    ),
    (
        "crawling-pacing",
        ["--realtime-rate", "1e-9"],
        ["target_realtime_rate=1e-09", "--realtime-rate"],
    ),
    (
        "publish-period",
        [*set_("visualization: {publish_period: 1e-9}")],
        ["visualization.publish_period=1e-09", "--set"],
    ),
    ("foxglove-port", ["--foxglove", "99999"], ["ros2.foxglove_port=99999"]),
    (
        "camera-size",
        [*set_("cameras: [{name: c, link: j0_link, width: -5}]")],
        ["width=-5", "--set 'cameras"],
    ),
    ("unknown-key", [*set_("actuators: {kq: 1}")], ["kq", "--set 'actuators: {kq: 1}'"]),
    ("wrong-type", [*set_("actuators: {kp: abc}")], ["abc", "--set"]),
    (
        "targets-wrong-length",
        [*set_("sequencer: {targets: [[0, 0]]}")],
        ["target 0 has 2 values", "--set 'sequencer"],
    ),
    (
        "unknown-controller",
        [*set_("controllers: {activate: [nope]}")],
        ["'nope'", "--set 'controllers"],
    ),
    (
        "duration-huge",
        ["--duration", "1e300"],
        ["simulation.duration=1e+300 s is over", "--duration"],
    ),
    (
        "duplicate-key-in-set",
        [*set_("{actuators: {kp: 3, kp: 4}}")],
        ["key 'kp' is given twice", "--set '{actuators"],
    ),
    ("save-frames-on-a-file", ["--save-frames", "/etc/passwd"], ["--save-frames /etc/passwd"]),
    ("empty-set", [*set_("")], ["--set ''", "nothing to set"]),
    (
        "task-beyond-reach",
        ["--scenario", "task_armando", *set_("task: {path: circular, radius: 2}")],
        ["beyond its reach of 0.326 m", "--set 'task: {path: circular, radius: 2}'"],
    ),
    (
        "base-far-away",
        [*set_("robot: {base_xyz: [1e308, 0, 0]}")],
        ["robot.base_xyz.0=1e+308 m is farther than", "--set 'robot"],
    ),
]


@pytest.mark.parametrize(
    "args, needles", [case[1:] for case in SCENARIO_CASES], ids=[c[0] for c in SCENARIO_CASES]
)
def test_a_bad_scenario_value_is_one_line_naming_its_source(args, needles, capsys):
    code, _, err = run_main(*args, capsys=capsys)
    assert code == 2, err
    assert_one_line(err, *needles)


@pytest.mark.parametrize(
    "duration, needle",
    [("-1", "simulation.duration=-1.0 must be zero or positive"), ("1e300", "1e+300 s is over")],
)
def test_a_bad_duration_in_a_set_is_refused(duration, needle, capsys):
    """(--duration, which FAST gives, would win over the --set: run without it.)"""
    override = f"simulation: {{duration: {duration}}}"
    try:
        code = world.main([*FAST[:3], "--quiet", "--set", override])
    except SystemExit as end:
        code = end.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert_one_line(err, needle, f"--set {override!r}")


def test_a_key_given_twice_in_a_scenario_file_names_the_file_and_line(tmp_path, capsys):
    scenario = tmp_path / "twice.yaml"
    scenario.write_text("actuators:\n  kp: 8.0\n  kp: 9.0\n")
    code, _, err = run_main("--scenario", str(scenario), capsys=capsys)
    assert code == 2, err
    assert_one_line(err, f"{scenario}:3:", "key 'kp' is given twice (first at line 2)")


def test_an_initial_value_outside_the_limits_is_clamped_with_a_warning(capsys, caplog):
    code, out, err = run_main("--set", "robot: {xacro_args: {initial_j1: '50'}}", capsys=capsys)
    assert code == 0, err
    warnings = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any(
        "joint 'j1': initial_value 50 is outside its limits [-3.14, 3.14]; it starts at 3.14" in w
        for w in warnings
    ), warnings


def test_a_value_from_the_file_names_the_file(tmp_path, capsys):
    scenario = tmp_path / "mine.yaml"
    scenario.write_text(
        (DIAGRAMS_DIR / "position.yaml")
        .read_text()
        .replace("  gravity_feedforward: true", "  kp: -8.0\n  gravity_feedforward: true")
    )
    code, _, err = run_main("--scenario", str(scenario), capsys=capsys)
    assert code == 2
    assert_one_line(err, f"{scenario}: actuators.kp=-8.0 must be positive")
    # The same value given with --set is blamed on --set, not on the file.
    code, _, err = run_main("--set", "actuators: {kp: -8}", capsys=capsys)
    assert code == 2
    line = assert_one_line(err, "--set 'actuators: {kp: -8}': actuators.kp=-8.0")
    assert "position.yaml" not in line


def test_controller_then_set_edits_the_chosen_sinusoid(tmp_path, capsys):
    """--controller sinusoid --set 'sequencer: {frequency, amplitude}' runs that wave."""
    code, out, err = run_main(
        "--controller",
        "sinusoid",
        "--set",
        "sequencer: {frequency: 0.5, amplitude: [0.1, 0.2, 0.3, 0.4]}",
        "--output",
        str(tmp_path),
        "--no-replay",
        capsys=capsys,
    )
    assert code == 0, err
    from armando_drake.simulation.scenario import load_scenario

    ran = load_scenario(tmp_path / "scenario.yaml").robots["robot"]  # its one robot
    assert type(ran.sequencer).__name__ == "Sinusoid"
    assert ran.sequencer.frequency == 0.5
    assert ran.sequencer.amplitude == [0.1, 0.2, 0.3, 0.4]


def write(path, text: str):
    path.write_text(textwrap.dedent(text))
    return path


def controllers_yaml(update_rate="100", joints="[j0, j1, j2, j3]") -> str:
    return f"""\
        controller_manager:
          ros__parameters:
            update_rate: {update_rate}
            jsb: {{type: joint_state_broadcaster/JointStateBroadcaster}}
            pc: {{type: position_controllers/JointGroupPositionController}}
        pc:
          ros__parameters:
            joints: {joints}
        """


CONTROLLER_CASES = [
    ("random-bytes", None, ["not a text (UTF-8) YAML file"]),
    ("update-rate-negative", controllers_yaml(update_rate="-5"), ["update_rate=-5"]),
    ("update-rate-nan", controllers_yaml(update_rate=".nan"), ["update_rate=nan"]),
    ("update-rate-above-plant", controllers_yaml(update_rate="5000"), ["1/5000 s"]),
    ("unknown-joint", controllers_yaml(joints="[j0, j9]"), ["unknown joint 'j9'"]),
    ("a-list", "- 1\n- 2\n", ["expected a mapping"]),
    (
        "broadcaster-interface-not-simulated",
        controllers_yaml().rstrip(" ")
        + "        jsb:\n          ros__parameters:\n            interfaces: [torque]\n",
        [
            "jsb.ros__parameters.interfaces",
            "interfaces.0='torque' is not one of 'position', 'velocity', 'effort': the state "
            "interfaces of the simulated joints",
        ],
    ),
    # A key given twice is merged as ROS merges it (tests/control/test_param_files.py).
]


@pytest.mark.parametrize(
    "text, needles", [c[1:] for c in CONTROLLER_CASES], ids=[c[0] for c in CONTROLLER_CASES]
)
def test_a_bad_controller_yaml_is_one_line_naming_the_file(tmp_path, capsys, text, needles):
    path = tmp_path / "controllers.yaml"
    if text is None:
        path.write_bytes(bytes(range(128, 256)) * 4)
    else:
        write(path, text)
    override = f"controllers: {{config: {path}, activate: [jsb, pc]}}"
    code, _, err = run_main("--set", override, capsys=capsys)
    assert code == 2, err
    assert_one_line(err, str(path), *needles)


HARDWARE = "<hardware><plugin>mock_components/GenericSystem</plugin></hardware>"
JOINT = '<joint name="{}"><command_interface name="position"/>{}</joint>'

DESCRIPTION_CASES = [
    ("random-bytes", None, ["not a text (UTF-8) file"]),
    (
        "kinematic-loop",
        URDF.replace(
            "EXTRA",
            '<joint name="q3" type="revolute"><parent link="lower"/><child link="upper"/>'
            '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>',
        ),
        ["q3"],
    ),
    (
        "ros2-control-without-joints",
        URDF.replace("EXTRA", f'<ros2_control name="hw" type="system">{HARDWARE}</ros2_control>'),
        ["actuates no joint"],
    ),
    (
        "initial-value-nan",
        URDF.replace(
            "EXTRA",
            f'<ros2_control name="hw" type="system">{HARDWARE}'
            + JOINT.format(
                "q1",
                '<state_interface name="position"><param name="initial_value">nan</param>'
                "</state_interface>",
            )
            + "</ros2_control>",
        ),
        ["initial_value='nan'", "q1"],
    ),
    (
        "duplicate-ros2-control-joint",
        URDF.replace(
            "EXTRA",
            f'<ros2_control name="hw" type="system">{HARDWARE}'
            + JOINT.format("q1", "")
            + JOINT.format("q1", "")
            + "</ros2_control>",
        ),
        ["joint 'q1' is given twice"],
    ),
    ("bad-number", URDF.replace('lower="-2"', 'lower="abc"'), ["joint 'q1'", "'abc'"]),
    ("truncated", URDF[:300], ["not valid XML"]),
    (
        "missing-collision-mesh-package",
        URDF.replace(
            '<visual><geometry><box size="0.03 0.03 0.2"/></geometry></visual>',
            '<collision><geometry><mesh filename="package://nowhere/a.stl"/></geometry>'
            "</collision>",
            1,
        ),
        ["unknown package 'nowhere'"],
    ),
]


@pytest.mark.parametrize(
    "text, needles", [c[1:] for c in DESCRIPTION_CASES], ids=[c[0] for c in DESCRIPTION_CASES]
)
def test_a_bad_description_is_one_line_naming_the_file(tmp_path, capsys, text, needles):
    path = tmp_path / "robot.urdf"
    if text is None:
        path.write_bytes(bytes(range(128, 256)) * 4)
    else:
        path.write_text(text)
    code, _, err = run_main("--description", str(path), capsys=capsys)
    assert code == 2, err
    assert_one_line(err, str(path), *needles)


def test_an_off_multiple_controller_period_runs_with_a_warning(tmp_path, capsys, caplog):
    path = write(tmp_path / "controllers.yaml", controllers_yaml(update_rate="300"))
    override = f"controllers: {{config: {path}, activate: [jsb, pc]}}"
    with caplog.at_level("WARNING"):
        code, _, err = run_main("--set", override, capsys=capsys)
    assert code == 0, err
    warnings = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any(
        "controller period 1/300 s is not a multiple of the plant step 0.001 s" in w
        for w in warnings
    ), warnings


def test_no_controller_with_output_writes_the_logs(tmp_path, capsys):
    """world.yaml has no command controller (the arm falls): --output still works."""
    code, _, err = run_main("--scenario", "world", "--output", str(tmp_path), capsys=capsys)
    assert code == 0, err
    assert (tmp_path / "joint_states.csv").is_file()
    assert (tmp_path / "summary.json").is_file()
    assert (tmp_path / "positions.png").is_file()


def test_duration_3_lists_no_step_that_never_ran(tmp_path, capsys):
    code, out, err = run_main("--duration", "3", "--output", str(tmp_path), capsys=capsys)
    assert code == 0, err
    import json

    steps = json.loads((tmp_path / "summary.json").read_text())["steps"]
    assert [step["start"] for step in steps] == [0.0]


def subprocess_world(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.world", *FAST, *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_the_shell_sees_exit_2_and_one_line():
    result = subprocess_world("--set", "plant_config: {time_step: .nan}")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1, result.stderr
    assert_one_line(result.stderr, "plant_config.time_step=nan", "--set")


def test_an_internal_error_is_one_line_and_its_traceback_is_behind_debug(tmp_path, monkeypatch):
    """An error the program did not foresee: one line, exit 1, and --debug shows where."""
    # A sitecustomize that breaks the builder, as a bug would.
    (tmp_path / "sitecustomize.py").write_text(
        "import armando_drake.simulation.builder as b\n"
        "def broken(*args, **kwargs):\n"
        "    raise ZeroDivisionError('a bug')\n"
        "b.MakeWorld = broken\n"
        "import armando_drake.simulation.run as r\n"
        "r.MakeWorld = broken\n"
    )
    import os

    env = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    command = [sys.executable, "-m", "armando_drake.world", *FAST]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip() == (
        "error: ZeroDivisionError: a bug (run with --debug for the traceback)"
    )
    result = subprocess.run(
        [*command, "--debug"], capture_output=True, text=True, timeout=120, env=env
    )
    assert result.returncode == 1
    assert "Traceback" in result.stderr and "in broken" in result.stderr
    assert result.stderr.strip().endswith("error: ZeroDivisionError: a bug")


def test_a_drake_failure_reaching_the_handler_is_one_line_without_failure_at(capsys):
    from armando_drake.tools.cli import user_errors

    with pytest.raises(SystemExit) as end, user_errors():
        raise RuntimeError(
            "Failure at external/drake+/multibody/plant/multibody_plant.cc:323 in "
            "MultibodyPlant(): condition 'time_step >= 0' failed."
        )
    assert end.value.code == 1
    err = capsys.readouterr().err
    assert "Failure at" not in err
    assert "condition 'time_step >= 0' failed" in err


@pytest.mark.parametrize("value", [math.nan, math.inf, -1.0])
def test_the_numbers_of_objects_cameras_and_tasks_are_checked_too(value):
    from armando_drake.simulation.scenario import load_scenario, merge_overrides
    from armando_drake.simulation.validation import InputError, check_scenario

    for override, key in [
        (f"cameras: [{{name: c, link: j0_link, near: {value!r}}}]", "cameras.0.near"),
        (f"task: {{radius: {value!r}}}", "task.radius"),
    ]:
        text = override.replace("nan", ".nan").replace("inf", ".inf")
        scenario = merge_overrides(load_scenario("position"), [text])
        with pytest.raises(InputError) as error:
            check_scenario(scenario)
        assert f"--set {text!r}: {key}=" in str(error.value)


def test_a_sequence_that_would_never_end_is_refused_unless_a_duration_is_given():
    from armando_drake.simulation.scenario import load_scenario, merge_overrides
    from armando_drake.simulation.validation import InputError, check_scenario

    scenario = merge_overrides(load_scenario("position"), ["sequencer: {period: 1e300}"])
    with pytest.raises(InputError) as error:
        check_scenario(scenario)
    assert str(error.value) == (
        "--set 'sequencer: {period: 1e300}': sequencer: one pass lasts 5e+300 s, over 3600 s; "
        "give simulation.duration (or --duration) to run that long"
    )
    check_scenario(merge_overrides(scenario, ["simulation: {duration: 2}"]))  # asked for


def test_controller_none_wins_over_a_set_sequencer_with_a_warning(tmp_path, capsys, caplog):
    with caplog.at_level("WARNING"):
        code, _, err = run_main(
            "--controller", "none", "--set", "sequencer: {period: 2}", "--output", str(tmp_path),
            "--no-replay", capsys=capsys,
        )  # fmt: skip
    assert code == 0, err
    import json

    assert json.loads((tmp_path / "summary.json").read_text())["controller"] == "none"
    assert "--controller none: the sequencer that --set describes is not run" in caplog.text


# ---- options checked at the door: --host, argparse's usage errors, --wait, --package-path


@pytest.mark.parametrize(
    "host, needles",
    [
        ("999.1.1.1", ["--host 999.1.1.1", "not an IP address"]),
        ("not a host", ["--host 'not a host'", "not an IP address"]),
        ("example.org", ["--host example.org", "names are not looked up"]),
        ("10.255.255.1", ["--host 10.255.255.1", "not an address of this machine"]),
        ("224.0.0.1", ["--host 224.0.0.1", "multicast"]),
    ],
)
def test_a_bad_host_is_one_line_naming_it(host, needles, capsys):
    code, _, err = run_main("--host", host, capsys=capsys)
    assert code == 2, err
    assert_one_line(err, *needles)


def test_a_bad_host_fails_fast_with_meshcat_on():
    """Drake's Meshcat() never returned for a name it could not look up: --host is
    checked before Meshcat starts."""
    for host in ("999.1.1.1", "not a host"):
        result = subprocess.run(
            [sys.executable, "-m", "armando_drake.world", "--host", host, "--no-wait"]
            + ["--exit-when-done", "--realtime-rate", "0", "--duration", "0.5"],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert result.returncode == 2, result.stderr
        assert result.stderr.count("\n") == 1, result.stderr
        assert_one_line(result.stderr, f"--host {shlex.quote(host)}: not an IP address")


def test_addresses_of_this_machine_are_accepted():
    from armando_drake.tools.cli import check_host, server_urls

    assert check_host("localhost") == "127.0.0.1"
    assert check_host("127.0.0.1") == "127.0.0.1"
    assert check_host("0.0.0.0") == "0.0.0.0"
    import socket

    hostname = socket.gethostname()
    assert server_urls("0.0.0.0", 7000) == (
        f"http://{hostname}:7000/ (on this machine: http://127.0.0.1:7000/)"
    )
    assert server_urls("::1", 7000, "") == "http://[::1]:7000"
    assert server_urls("127.0.0.1", 7000) == "http://127.0.0.1:7000/"


USAGE_CASES = [
    ("--duration", "abc", "argument --duration: invalid float value: 'abc'"),
    ("--foxglove", "abc", "argument --foxglove: invalid int value: 'abc'"),
    ("--renderer", "metal", "argument --renderer: invalid choice: 'metal'"),
    ("--controller", "foo", "argument --controller: invalid choice: 'foo'"),
    ("--frobnicate", None, "unrecognized arguments: --frobnicate"),
    ("--wait", "nan", "argument --wait: nan must be a number of seconds from 0 to 3600"),
    ("--wait", "1e300", "argument --wait: 1e300 must be"),
    ("--wait", "-1", "argument --wait: -1 must be"),
    ("--package-path", "/nonexistent", "argument --package-path: /nonexistent: no such folder"),
    ("--package-path", "/etc/passwd", "argument --package-path: /etc/passwd: not a folder"),
]


@pytest.mark.parametrize(
    "option, value, message", USAGE_CASES, ids=[f"{c[0]}-{c[1]}" for c in USAGE_CASES]
)
def test_a_usage_error_is_one_line(option, value, message, capsys):
    code, out, err = run_main(option, *([value] if value is not None else []), capsys=capsys)
    assert code == 2, err
    assert err.startswith(f"error: {message}"), err
    assert err.count("\n") == 1 and err.rstrip().endswith("(see --help)"), err
    assert "usage:" not in err + out


@pytest.mark.parametrize(
    "module", ["world", "display", "graph", "sweeps.sweep", "benchmarks.suite"]
)
def test_every_entry_point_reports_a_usage_error_in_one_line(module, capsys):
    import importlib

    main = importlib.import_module(f"armando_drake.{module}").main
    with pytest.raises(SystemExit) as end:
        main(["--frobnicate"])
    assert end.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert err.rstrip().endswith("(see --help)"), err


def test_dataset_subcommand_errors_are_one_line_too(capsys):
    from armando_drake.sweeps.dataset import main

    with pytest.raises(SystemExit) as end:
        main(["ik", "--samples", "1", "--output", "x", "--package-path", "/nonexistent"])
    assert end.value.code == 2
    err = capsys.readouterr().err
    assert_one_line(err, "--package-path: /nonexistent: no such folder", "(see --help)")
    assert err.count("\n") == 1


def test_help_still_works(capsys):
    code, out, err = run_main("--help", capsys=capsys)
    assert code == 0
    assert out.startswith("usage: python -m armando_drake.world") and "--host" in out
    assert not err


def test_display_checks_package_path_too(capsys):
    from armando_drake import display

    with pytest.raises(SystemExit) as end:
        display.main(["--package-path", "/etc/passwd", "--loop-once"])
    assert end.value.code == 2
    assert_one_line(capsys.readouterr().err, "--package-path: /etc/passwd: not a folder")


def test_a_joint_of_several_degrees_of_freedom_is_named_as_not_actuated(tmp_path, capsys, caplog):
    """A planar joint has no joint command interface: the run goes on and says which
    joint moves freely, instead of leaving it out without a word."""
    path = tmp_path / "planar.urdf"
    path.write_text(URDF.replace("EXTRA", "").replace('type="revolute"', 'type="planar"', 1))
    code, _, err = run_main("--description", str(path), capsys=capsys)
    assert code == 0, err
    warnings = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("not actuated: q1 (planar)" in w and str(path) in w for w in warnings), warnings


def test_cli_flags_are_checked_by_the_scenario_schema():
    """A flag that sets a scenario field is checked as the field is: --save-rate 0 is
    the schema's 0 (the camera's own rate), a negative one names the flag and the key."""
    from armando_drake.simulation.command import scenario_from_arguments, world_parser
    from armando_drake.simulation.scenario import load_scenario
    from armando_drake.simulation.validation import InputError

    args = world_parser("").parse_args(["--save-rate", "0", "--realtime-rate", "0"])
    scenario = scenario_from_arguments(load_scenario(POSITION), args)
    assert scenario.camera.save_rate == 0.0
    args = world_parser("").parse_args(["--save-rate", "-2"])
    with pytest.raises(InputError) as error:
        scenario_from_arguments(load_scenario(POSITION), args)
    assert (
        str(error.value) == "--save-rate -2.0: camera.save_rate=-2.0 must be zero or positive [Hz]"
    )
