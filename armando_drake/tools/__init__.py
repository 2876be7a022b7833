"""Support for the entry points: shared command-line arguments and error
reporting, the private virtual display the OpenGL renderer uses, and the
package's version (with the git commit it runs from)."""
