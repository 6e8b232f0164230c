"""Bit-for-bit comparison of nested results (observations, rewards, infos) for the tests."""

from __future__ import annotations

import numpy as np


def same(x, y) -> bool:
    """Equal to the bit (floats and arrays by their bytes), recursively."""
    if isinstance(x, dict):
        return type(y) is dict and x.keys() == y.keys() and all(same(x[k], y[k]) for k in x)
    if isinstance(x, list | tuple):
        return len(x) == len(y) and all(same(a, b) for a, b in zip(x, y, strict=True))
    if isinstance(x, np.ndarray):
        return (isinstance(y, np.ndarray) and x.dtype == y.dtype and x.shape == y.shape
                and x.tobytes() == y.tobytes())
    if isinstance(x, float):
        return isinstance(y, float) and np.float64(x).tobytes() == np.float64(y).tobytes()
    return type(x) is type(y) and x == y
