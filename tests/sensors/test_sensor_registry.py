"""A new sensor type is one module plus its registration (docs/how-to/extending.md): the
guide's altimeter, installed by an entry point, measures a falling pendulum's link."""

import logging
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.sensors import registry
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario

EXTENDING = Path(__file__).resolve().parents[2] / "docs" / "how-to" / "extending.md"

# A pendulum: link "arm" (0.4 m, 1 kg at its end) on a revolute joint about 1 m up,
# starting horizontal, with an altimeter at its tip (<pose>) sampled at 50 Hz, and a sonar
# that no type simulates.
PENDULUM = """<?xml version="1.0"?>
<robot name="pendulum">
  <link name="base_link">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.4 0 0"/><mass value="1"/>
      <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="base_link"/><child link="arm"/><origin xyz="0 0 1.0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="10"/>
  </joint>
  <gazebo reference="arm">
    <sensor type="altimeter" name="altimeter">
      <update_rate>50</update_rate>
      <pose>0.4 0 0 0 0 0</pose>
    </sensor>
    <sensor type="sonar" name="front_sonar"><update_rate>10</update_rate></sensor>
  </gazebo>
</robot>
"""


def _sensor_example() -> tuple[str, dict[str, str]]:
    """The Extending guide's "A new sensor": the module's text and its entry points."""
    section = EXTENDING.read_text().split("\n## A new sensor\n", 1)[1].split("\n## ", 1)[0]
    blocks = dict(re.findall(r"```(python|toml)\n(.*?)```", section, re.S))
    assert blocks["toml"].startswith(f'[project.entry-points."{registry.ENTRY_POINT_GROUP}"]\n')
    return blocks["python"], dict(re.findall(r'^(\S+) = "(\S+)"$', blocks["toml"], re.M))


@pytest.fixture
def installed_altimeter(tmp_path, monkeypatch):
    """The guide's module and entry point in a folder on sys.path, as pip installs them."""
    text, entry_points = _sensor_example()
    assert entry_points == {"toy_sensors": "toy_sensors"}
    (tmp_path / "toy_sensors.py").write_text(text)
    dist_info = tmp_path / "toy_sensors-0.1.dist-info"
    dist_info.mkdir()
    (dist_info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy_sensors\nVersion: 0.1\n")
    (dist_info / "entry_points.txt").write_text(
        f"[{registry.ENTRY_POINT_GROUP}]\ntoy_sensors = toy_sensors\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "_entry_points_loaded", False)
    yield tmp_path
    registry.unregister_sensor("altimeter")
    sys.modules.pop("toy_sensors", None)
    registry._entry_points_loaded = False


def _pendulum_world(tmp_path):
    urdf = tmp_path / "pendulum.urdf"
    urdf.write_text(PENDULUM)
    scenario = load_scenario(
        "position",
        f"{{robot: {{description: '{urdf}'}}, sequencer: null, "
        "controllers: {activate: []}, logging: {console_rate: 0}}",
    )
    return MakeWorld(scenario, quiet=True)


def test_the_readme_altimeter_measures_the_link_it_is_mounted_on(installed_altimeter, caplog):
    with caplog.at_level(logging.WARNING, logger="armando_drake.world"):
        world = _pendulum_world(installed_altimeter)
    assert "altimeter" in registry.sensor_types()
    # The type nothing registers is named, with the file, and left out.
    warned = " ".join(r.getMessage() for r in caplog.records)
    assert "front_sonar (sonar on arm)" in warned and "pendulum.urdf" in warned
    assert not world.diagram.HasOutputPort("front_sonar.height")
    port = world.diagram.GetOutputPort("altimeter.height")
    simulator = Simulator(world.diagram)
    context = simulator.get_context()
    plant = world.plant
    arm = plant.GetBodyByName("arm")

    def tip_height() -> float:  # the tip's true height now
        X_WA = arm.EvalPoseInWorld(plant.GetMyContextFromRoot(context))
        return float((X_WA @ np.array([0.4, 0.0, 0.0]))[2])

    hinge = float(arm.EvalPoseInWorld(plant.GetMyContextFromRoot(context)).translation()[2])
    heights = []
    for k in range(1, 16):  # the 50 Hz samples while the pendulum falls
        t = k * 0.02
        simulator.AdvanceTo(t)
        sampled = tip_height()
        # Until the next sample the altimeter holds the height at this one.
        for after in (0.001, 0.01, 0.019):
            simulator.AdvanceTo(t + after)
            assert port.Eval(context)[0] == pytest.approx(sampled, abs=1e-12), (t, after)
        heights.append(sampled)
    # It starts level with the hinge (the link horizontal) and falls, as a pendulum does.
    assert heights[0] == pytest.approx(hinge, abs=0.005)
    assert heights[-1] < hinge - 0.1 and np.all(np.diff(heights) < 0)
    world.close(context)


def test_a_type_is_registered_once_and_never_as_a_camera():
    @registry.register_sensor("toy_barometer")
    class Barometer:
        @staticmethod
        def add(builder, block, *, plant, robot):
            return {}

    try:
        with pytest.raises(ValueError, match="toy_barometer.*already registered"):

            @registry.register_sensor("toy_barometer")
            class Other:
                add = Barometer.add

        with pytest.raises(ValueError, match="camera section"):
            registry.register_sensor("camera")(Barometer)
        with pytest.raises(TypeError, match=r"add\(builder, block"):
            registry.register_sensor("toy_thermometer")(type("NoAdd", (), {}))
    finally:
        registry.unregister_sensor("toy_barometer")


def test_without_the_type_the_altimeter_is_only_named(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="armando_drake.world"):
        world = _pendulum_world(tmp_path)
    warned = " ".join(r.getMessage() for r in caplog.records)
    assert "altimeter (altimeter on arm)" in warned
    assert not world.diagram.HasOutputPort("altimeter.height")
    world.close()


def test_add_sensors_alone_exports_each_output_by_sensor_name(tmp_path):
    """AddSensors in a bare DiagramBuilder: a registered type's outputs, named after the
    block; the camera types left to the camera section."""
    from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from armando_drake.description.loader import load_robot

    @registry.register_sensor("toy_rate")
    class Rate:
        @staticmethod
        def add(builder, block, *, plant, robot):
            source = builder.AddSystem(ConstantVectorSource([block.update_rate]))
            return {"rate": source.get_output_port()}

    try:
        urdf = tmp_path / "pendulum.urdf"
        urdf.write_text(PENDULUM.replace('type="altimeter"', 'type="toy_rate"'))
        builder = DiagramBuilder()
        plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.001), builder)
        robot = load_robot(plant, urdf)
        plant.Finalize()
        added = registry.AddSensors(builder, robot.sensors, plant=plant, robot=robot)
        assert list(added) == ["altimeter"]  # the block's name, its type toy_rate
        diagram = builder.Build()
        rate = diagram.GetOutputPort("altimeter.rate").Eval(diagram.CreateDefaultContext())
        assert rate[0] == 50.0  # its <update_rate>
    finally:
        registry.unregister_sensor("toy_rate")
