"""What a run leaves behind: joint-state and command logs, ROS 2 bags (MCAP),
the Meshcat replay, plots and the system graph."""
