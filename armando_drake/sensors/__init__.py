"""What the robot sees and what it sees: camera sensors, their live view and
frame saver, and the static scene objects placed in front of them."""
