"""ros2_control in Drake: controller YAML, the controller types, the controller
manager that runs them, the simulated hardware interfaces, the ROS message
layouts, and the command sequencer (the course's arm controller node)."""
