"""Arrays as the compiled baselines (``orca``, ``cbf``) take them: contiguous, typed,
and the robots' mask memoised for the arena's kinds array."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["f64", "i64", "robot_mask"]


def f64(a: Any) -> NDArray[np.float64]:
    """A contiguous float64 array (a copy only where needed: a batch's read-only arrays
    go to the kernel as they are)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def i64(a: Any) -> NDArray[np.int64]:
    """A contiguous int64 array (a copy only where needed, as :func:`f64`)."""
    return np.ascontiguousarray(a, dtype=np.int64)


_LAST_KINDS: list[Any] = [None, None]


def robot_mask(kinds: NDArray[np.str_]) -> NDArray[np.bool_]:
    """Which bodies are robots (they reciprocate), memoised for the last kinds array (the
    arena's: every step's batch shares it)."""
    if _LAST_KINDS[0] is not kinds:
        _LAST_KINDS[0], _LAST_KINDS[1] = kinds, np.asarray(kinds) == "robot"
    return _LAST_KINDS[1]
