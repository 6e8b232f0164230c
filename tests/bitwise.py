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
        return (
            isinstance(y, np.ndarray)
            and x.dtype == y.dtype
            and x.shape == y.shape
            and x.tobytes() == y.tobytes()
        )
    if isinstance(x, float):
        return isinstance(y, float) and np.float64(x).tobytes() == np.float64(y).tobytes()
    return type(x) is type(y) and x == y


def same_up_to_nan_sign(x: np.ndarray, y: np.ndarray) -> bool:
    """Float arrays equal to the bit where they are numbers (-0.0 is not 0.0) and NaN at
    the same places: IEEE 754 leaves the sign and payload of a NaN that an operation
    returns unspecified, and compiled code inlined elsewhere may set it otherwise."""
    if x.dtype != y.dtype or x.shape != y.shape:
        return False
    nan_x, nan_y = np.isnan(x), np.isnan(y)
    return bool(np.array_equal(nan_x, nan_y)) and (
        np.where(nan_x, 0.0, x).tobytes() == np.where(nan_y, 0.0, y).tobytes()
    )
