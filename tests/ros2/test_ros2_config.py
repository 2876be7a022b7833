"""The ros2: section: bad values named, the printed configuration the one the docs give."""

from pathlib import Path

import pytest

from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario

pytest.importorskip("cyclonedds")
ROS2_PAGE = Path(__file__).resolve().parents[2] / "docs" / "tutorials" / "ros2.md"


def test_the_docs_give_the_loopback_configuration_the_world_prints():
    from armando_drake.ros2.dds import cyclonedds_config, reachability

    xml = cyclonedds_config()
    assert f'export CYCLONEDDS_URI="{xml}"' in ROS2_PAGE.read_text()
    assert f'CYCLONEDDS_URI="{xml}"' in reachability(0)
    assert "127.0.0.1" in xml and "<AllowMulticast>false</AllowMulticast>" in xml
    assert "<NetworkInterface name='eth1'/>" in cyclonedds_config("eth1")


@pytest.mark.parametrize(
    "section, message",
    [
        ("{enabled: true, domain_id: 300}", "ros2.domain_id=300 must be an integer in [0, 232]"),
        ("{enabled: true, domain_id: 201, namespace: arm}", "ros2.namespace='arm' must start"),
        ("{foxglove: true, foxglove_port: 70000}", "ros2.foxglove_port=70000 on 127.0.0.1"),
    ],
)
def test_bad_ros2_settings_are_named(section, message):
    scenario = load_scenario("ros2", f"ros2: {section}\nlogging: {{console_rate: 0}}")
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[").replace("]", r"\]")):
        MakeWorld(scenario, quiet=True)


def test_topic_names_follow_the_ros2_dds_mapping():
    from armando_drake.ros2.dds import dds_topic_name

    assert dds_topic_name("joint_states") == "rt/joint_states"
    assert dds_topic_name("joint_states", "/arm") == "rt/arm/joint_states"
    assert dds_topic_name("position_controller/commands", "/arm/") == (
        "rt/arm/position_controller/commands"
    )
    assert dds_topic_name("/tf", "/arm") == "rt/tf"


@pytest.mark.parametrize(
    "override, key",
    [
        # A value that would be pasted into Cyclone DDS's XML (it enabled tracing once).
        (
            'ros2: {network_interface: "lo\'/><Tracing><OutputFile>/tmp/x</OutputFile>"}',
            "ros2.network_interface",
        ),
        ("ros2: {network_interface: eth0 eth1}", "ros2.network_interface"),
        ("ros2: {network_interface: averyveryverylongname}", "ros2.network_interface"),
        ("ros2: {namespace: 'bad ns'}", "ros2.namespace"),
        ("ros2: {namespace: arm}", "ros2.namespace"),
        ("ros2: {namespace: /1arm}", "ros2.namespace"),
        ("ros2: {foxglove_host: example.com}", "ros2.foxglove_host"),
    ],
)
def test_values_for_other_programs_are_refused_in_one_line_naming_the_key(override, key):
    from armando_drake.simulation.scenario import load_scenario
    from armando_drake.simulation.validation import InputError, check_scenario

    scenario = load_scenario("position", override)
    with pytest.raises(InputError) as error:
        check_scenario(scenario)
    message = str(error.value)
    assert f"{key}=" in message and "\n" not in message
    assert message.startswith("override ")  # the origin: the override that set it


@pytest.mark.parametrize(
    "override",
    [
        "ros2: {network_interface: lo}",
        "ros2: {network_interface: eth0.100}",
        "ros2: {network_interface: 127.0.0.1}",
        "ros2: {network_interface: '::1'}",
        "ros2: {namespace: /arm/left_2}",
        "ros2: {foxglove_host: '0.0.0.0'}",
        "ros2: {foxglove_host: localhost}",
    ],
)
def test_names_and_addresses_ros2_accepts_pass(override):
    from armando_drake.simulation.scenario import load_scenario
    from armando_drake.simulation.validation import check_scenario

    check_scenario(load_scenario("position", override))


@pytest.mark.parametrize(
    "interface, message",
    [
        ("nosuchif0", "this machine has no such network interface (it has: "),
        ("192.0.2.77", "no network interface of this machine has that address"),
    ],
)
def test_a_missing_network_interface_is_one_line_before_cyclone_says_anything(interface, message):
    import subprocess
    import sys

    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "armando_drake.world",
            "--scenario",
            "ros2",
            "--no-meshcat",
            "--duration",
            "0.1",
            "--set",
            f"ros2: {{enabled: true, network_interface: '{interface}'}}",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    (line,) = [line for line in result.stderr.splitlines() if line.strip()]
    assert line.startswith(f"error: ros2.network_interface={interface!r}: {message}")
    assert "cyclone" not in (result.stdout + result.stderr).lower()
