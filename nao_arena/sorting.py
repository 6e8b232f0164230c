"""Compiled sorting for the kernels: a stable argsort and a median.

numba compiles its own ``np.argsort`` and ``np.median`` in every process that calls
them, and never caches them (about a second each per process, and the compile-ahead
processes each pay it). These are ordinary cached kernels instead, with numpy's
results: :func:`stable_argsort` is ``np.argsort(keys, kind="stable")`` (NaN last, ties in
their input order) and :func:`median` is ``np.median`` of finite values.
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.jit import inner_kernel

__all__ = ["median", "stable_argsort"]

_RUN = 16
"""Runs of this many keys are sorted by insertion, then merged pairwise."""


@inner_kernel(error_model="numpy")
def _before(a, b):
    """Whether key a sorts strictly before key b (NaN after every number)."""
    return a < b or (math.isnan(b) and not math.isnan(a))


@inner_kernel(error_model="numpy")
def stable_argsort(keys):
    """The indices (int64) that sort the 1-d array ``keys`` ascending, ties in their
    input order and NaN last: ``np.argsort(keys, kind="stable")``."""
    n = keys.shape[0]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[i] = i
    for lo in range(0, n, _RUN):
        hi = min(lo + _RUN, n)
        for i in range(lo + 1, hi):
            k = order[i]
            key = keys[k]
            j = i - 1
            while j >= lo and _before(key, keys[order[j]]):
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = k
    if n <= _RUN:
        return order
    src = order
    dst = np.empty(n, dtype=np.int64)
    width = _RUN
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i = lo
            j = mid
            k = lo
            while i < mid and j < hi:
                # the right run's key goes first only when strictly before: stable
                if _before(keys[src[j]], keys[src[i]]):
                    dst[k] = src[j]
                    j += 1
                else:
                    dst[k] = src[i]
                    i += 1
                k += 1
            while i < mid:
                dst[k] = src[i]
                i += 1
                k += 1
            while j < hi:
                dst[k] = src[j]
                j += 1
                k += 1
        src, dst = dst, src
        width *= 2
    return src


@inner_kernel(error_model="numpy")
def median(values, n):
    """``np.median(values[:n])`` of n >= 1 finite values (the mean of the middle two
    when n is even); values is not changed."""
    order = stable_argsort(values[:n])
    half = n >> 1
    if n & 1:
        return values[order[half]]
    return (values[order[half - 1]] + values[order[half]]) / 2
