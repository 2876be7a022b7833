"""The sweep commands' input errors: one line on stderr and exit code 2, as the world's."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator


class SweepError(ValueError):
    """A sweep or data set specification that cannot be used; the message names the bad item."""


@contextlib.contextmanager
def reported() -> Iterator[None]:
    """Turns a :class:`SweepError` into ``error: ...`` on stderr and exit code 2."""
    try:
        yield
    except SweepError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)
