"""A robot described in SDFormat whose element names repeat across links (they are
unique within their link only, as SDFormat requires) loads as written."""

from pydrake.multibody.plant import MultibodyPlant

from armando_drake.description.loader import expand_description, load_robot

LINK = """
    <link name="{name}">
      <pose>{x} 0 0.1 0 0 0</pose>
      <inertial><mass>1</mass>
        <inertia><ixx>0.01</ixx><iyy>0.01</iyy><izz>0.01</izz></inertia></inertial>
      <visual name="visual">
        <geometry><box><size>0.1 0.1 0.1</size></box></geometry>
        <material><diffuse>{rgba}</diffuse></material>
      </visual>
      <collision name="collision">
        <geometry><box><size>0.1 0.1 0.1</size></box></geometry>
      </collision>
    </link>"""


def test_visuals_named_alike_on_two_links_keep_their_own_colours(tmp_path):
    # gz-sim's vehicle_blue (examples/worlds/visualize_lidar.sdf) names every visual
    # "visual", each with its own colour.
    links = LINK.format(name="chassis", x=0, rgba="0.5 0.5 1.0 1") + LINK.format(
        name="wheel", x=0.3, rgba="0.2 0.2 0.2 1"
    )
    joint = (
        '<joint name="wheel_joint" type="revolute"><parent>chassis</parent>'
        "<child>wheel</child><axis><xyz>0 1 0</xyz></axis></joint>"
    )
    folder = tmp_path / "two_links"
    folder.mkdir()
    (folder / "model.config").write_text(
        "<model><name>two_links</name><sdf version='1.8'>model.sdf</sdf></model>"
    )
    (folder / "model.sdf").write_text(
        f'<sdf version="1.8"><model name="two_links">{links}{joint}</model></sdf>'
    )
    urdf = expand_description(folder / "model.sdf")
    assert 'name="chassis_visual_color"' in urdf and 'name="wheel_visual_color"' in urdf
    plant = MultibodyPlant(0.001)
    robot = load_robot(plant, folder / "model.sdf")
    plant.Finalize()
    assert plant.HasBodyNamed("wheel", robot.model_instance)
