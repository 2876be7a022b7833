"""Robot descriptions: ROS package search, xacro expansion, the ``<ros2_control>``
block, mesh conversion and repair, loading into a MultibodyPlant, and the
Meshcat viewer of a description (the RViz step)."""
