"""The errors every subsystem raises for an input the run refuses.

A scenario file, an override, a description, a controller YAML or an option that
cannot be used: the message is one line naming the value and where it came from;
the command lines print it as ``error: ...`` and exit with code 2 (see
:func:`armando_drake.tools.cli.user_errors`). Defined here, below every subsystem, so
each can raise them without importing the layer that loads scenarios.
"""


class UserInputError(Exception):
    """A mistake in the user's input: every subsystem's own error class derives from it."""


class ConfigError(UserInputError, ValueError):
    """A config value that is refused; the message is one line naming the value, its key
    and where it came from (:func:`armando_drake.tools.schema.check_config`)."""


class ScenarioError(ConfigError):
    """A scenario file or override that cannot be read, or a value the run refuses."""
