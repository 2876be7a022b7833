"""The last result of a deterministic computation, kept with a copy of its input.

A detector or a pipeline whose result is a function of its input alone (an image, a
point cloud and a viewpoint) need not run again on an input equal to the last one, bit
for bit (a camera on a still scene): :class:`LastResult` answers it from the last run.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def _bits(array: np.ndarray) -> np.ndarray:
    """The array's elements as unsigned integers of the same size: equal bits compare
    equal (NaNs included), different bits (0.0 and -0.0) differ."""
    array = np.ascontiguousarray(array)
    return array.view(np.dtype(f"u{array.itemsize}"))


class LastResult:
    """The result computed from the last input (a sequence of arrays), and that input.

    :meth:`get` returns the result for an input equal, bit for bit, to the last one kept
    (None for a new input); :meth:`put` keeps an input (copied) and its result. ``hits``
    counts the inputs answered from here.
    """

    def __init__(self):
        self._key: list[np.ndarray] | None = None
        self._result: Any = None
        self.hits = 0

    def get(self, *key: np.ndarray) -> Any:
        arrays = [np.asarray(a) for a in key]
        last = self._key
        if last is None or len(arrays) != len(last):
            return None
        for a, b in zip(arrays, last, strict=True):
            if a.shape != b.shape or a.dtype != b.dtype or not np.array_equal(_bits(a), _bits(b)):
                return None
        self.hits += 1
        return self._result

    def put(self, result: Any, *key: np.ndarray) -> None:
        self._key = [np.array(a, copy=True) for a in key]
        self._result = result
