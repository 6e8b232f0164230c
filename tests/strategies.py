"""Hypothesis strategies and small vector helpers shared by the geometry tests."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def floats(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Finite floats in [lo, hi]."""
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def vec(bound: float) -> st.SearchStrategy[FloatArray]:
    """(2,) vectors with both components in [-bound, bound]."""
    return st.tuples(floats(-bound, bound), floats(-bound, bound)).map(np.array)


def unit(angle: float) -> FloatArray:
    """The unit vector at ``angle`` (rad)."""
    return np.array([math.cos(angle), math.sin(angle)])
