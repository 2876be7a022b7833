"""Support for the entry points: shared command-line arguments and error
reporting, and the private virtual display the OpenGL renderer uses."""
