"""Runtime inputs a running world refuses: a message or a page key whose values cannot
be used (NaN, inf, out of range) is dropped with a logged reason and counted per topic,
and the last good command stays in force.

:class:`RejectedMessage` is what a message's conversion raises; :class:`Rejections`
counts them per topic for ``summary.json``'s ``rejected_messages``.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Iterable

_log = logging.getLogger("armando_drake.inputs")

# Reasons logged per topic before only every LOG_EVERY-th one is (a flood stays readable).
LOG_FIRST = 5
LOG_EVERY = 1000


class RejectedMessage(ValueError):
    """A received message that is dropped; the text says which field and why."""


def require_finite(fields: Iterable[tuple[str, float]]) -> None:
    """Raises :class:`RejectedMessage` naming the first field that is not a finite number."""
    for name, value in fields:
        try:
            number = float(value)
        except (TypeError, ValueError) as error:
            raise RejectedMessage(f"{name}={value!r} is not a number") from error
        if not math.isfinite(number):
            raise RejectedMessage(f"{name}={number!r} is not finite")


def require_within(fields: Iterable[tuple[str, float]], limit: float, unit: str = "") -> None:
    """Raises :class:`RejectedMessage` for a field that is not finite or whose size is above
    ``limit``."""
    fields = list(fields)
    require_finite(fields)
    for name, value in fields:
        if abs(float(value)) > limit:
            raise RejectedMessage(
                f"{name}={float(value)!r} is out of range (|value| <= {limit:g}{unit})"
            )


class Rejections:
    """Inputs refused so far, by topic (thread-safe: DDS delivers on its own thread)."""

    def __init__(self, source: str = "") -> None:
        self._source = source
        self._counts: dict[str, int] = {}
        self._lock = threading.Lock()

    def reject(self, topic: str, reason: str) -> None:
        """Counts one refused input on ``topic`` and logs why (the first few, then every
        LOG_EVERY-th)."""
        with self._lock:
            n = self._counts.get(topic, 0) + 1
            self._counts[topic] = n
        if n <= LOG_FIRST or n % LOG_EVERY == 0:
            where = f"{self._source}: " if self._source else ""
            _log.warning("%s%s: message dropped (%d so far): %s", where, topic, n, reason)

    @property
    def counts(self) -> dict[str, int]:
        """Refused inputs per topic (only topics with at least one)."""
        with self._lock:
            return dict(self._counts)


def merged_counts(*sources) -> dict[str, int]:
    """The counts of several :class:`Rejections` (or None) added per topic."""
    total: dict[str, int] = {}
    for source in sources:
        if source is None:
            continue
        for topic, n in source.counts.items():
            total[topic] = total.get(topic, 0) + n
    return total
