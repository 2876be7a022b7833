"""Live ROS 2: messages, the DDS bridge, Foxglove."""
