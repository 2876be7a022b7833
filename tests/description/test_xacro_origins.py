"""Warnings about a URDF expanded from xacro name the xacro's line of the element (found by
its name, written there once), or say that a line is the expanded URDF's: never a line of
the expanded text as if it were the xacro's."""

from armando_drake.description.importer import prepare_urdf
from armando_drake.description.loader import expand_description
from armando_drake.description.packages import find_packages

XACRO = """<?xml version="1.0"?>
<robot name="probe" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="segment" params="id">
    <link name="seg_${id}">
      <inertial><mass value="0"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>
      </inertial>
    </link>
  </xacro:macro>
  <link name="base_link"/>
  <xacro:segment id="a"/>
  <link name="written_out">
    <inertial>
      <mass value="0"/>
      <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="seg_a"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="seg_a"/><child link="written_out"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def test_a_warning_names_the_xacro_line_of_a_named_element_or_the_expanded_urdf(tmp_path):
    path = tmp_path / "probe.urdf.xacro"
    path.write_text(XACRO)
    urdf = expand_description(path)
    prepared = prepare_urdf(urdf, find_packages(near=path), source=path)
    mass = [w for w in prepared.warnings if "has no mass" in w]
    written = next(w for w in mass if "'written_out'" in w)
    # line 11 of the xacro: <link name="written_out">
    assert written.startswith(f"{path}:11 (<link name='written_out'>): "), written
    # seg_a is made by a macro: its name is not written in the xacro, so no xacro line.
    generated = next(w for w in mass if "'seg_a'" in w)
    assert generated.startswith(f"{path} (<link name='seg_a'>, line "), generated
    assert "of the expanded URDF)" in generated
