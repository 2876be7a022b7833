"""The scenario's ``logging:`` section: the joint-state logger."""

import dataclasses as dc

from armando_drake.tools.schema import param

# No `from __future__ import annotations` here: yaml_load_typed reads the dataclass
# field types at run time and does not resolve string annotations.


@dc.dataclass
class LoggingConfig:
    """The joint-state logger."""

    # How often the joint positions are printed to the console [Hz]; 0 = never.
    console_rate: float = param(1.0, unit="Hz", ge=0)
