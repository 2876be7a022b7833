"""The error every subsystem raises for an input the run refuses.

A scenario file, an override, a description or a controller YAML that cannot be
used: the message is one line naming the value and where it came from; the command
lines print it as ``error: ...`` and exit with code 2. Defined here, below every
subsystem, so each can raise it without importing the layer that loads scenarios.
"""


class ScenarioError(ValueError):
    """A scenario file or override that cannot be read, or a value the run refuses."""
