"""Compiled sorting for the kernels: a stable argsort and a median.

numba compiles its own ``np.argsort`` and ``np.median`` in every process that calls
them, and never caches them (about a second each per process, and the compile-ahead
processes each pay it). These are ordinary cached kernels instead, with numpy's
results: :func:`stable_argsort` is ``np.argsort(keys, kind="stable")`` (NaN last, ties in
their input order; :func:`stable_order` the same into arrays the caller gives),
:func:`median` is ``np.median`` of finite values and :func:`sort_in_place` is
``values[:n].sort()`` of integers (numba's own ``sort`` is another uncached quicksort).
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.jit import inner_kernel

__all__ = ["median", "sort_in_place", "stable_argsort", "stable_order"]

_RUN = 16
"""Runs of this many keys are sorted by insertion, then merged pairwise."""


@inner_kernel(error_model="numpy")
def _before(a, b):
    """Whether key a sorts strictly before key b (NaN after every number)."""
    return a < b or (math.isnan(b) and not math.isnan(a))


@inner_kernel(error_model="numpy")
def stable_order(keys, m, order, scratch):
    """order[:m] = the indices 0 .. m - 1 sorted by keys[:m] ascending, ties in index
    order and NaN last (``np.argsort(keys[:m], kind="stable")``), without allocating:
    runs of 16 sorted by insertion, then merged pairwise through ``scratch`` (int64,
    at least m long)."""
    for lo in range(0, m, _RUN):
        hi = min(lo + _RUN, m)
        for i in range(lo, hi):
            key = keys[i]
            j = i
            while j > lo and _before(key, keys[order[j - 1]]):
                order[j] = order[j - 1]
                j -= 1
            order[j] = i
    src = order
    dst = scratch
    in_scratch = False
    width = _RUN
    while width < m:
        for lo in range(0, m, 2 * width):
            mid = min(lo + width, m)
            hi = min(lo + 2 * width, m)
            i = lo
            j = mid
            for k in range(lo, hi):
                # the right run's key goes first only when strictly before: stable
                if i < mid and (j >= hi or not _before(keys[src[j]], keys[src[i]])):
                    dst[k] = src[i]
                    i += 1
                else:
                    dst[k] = src[j]
                    j += 1
        src, dst = dst, src
        in_scratch = not in_scratch
        width *= 2
    if in_scratch:
        for i in range(m):  # element by element: no broadcasting (its checks compile long)
            order[i] = scratch[i]


@inner_kernel(error_model="numpy")
def stable_argsort(keys):
    """The indices (int64) that sort the 1-d array ``keys`` ascending, ties in their
    input order and NaN last: ``np.argsort(keys, kind="stable")``."""
    n = keys.shape[0]
    order = np.empty(n, dtype=np.int64)
    stable_order(keys, n, order, np.empty(n, dtype=np.int64))
    return order


@inner_kernel(error_model="numpy")
def median(values, n):
    """``np.median(values[:n])`` of n >= 1 finite values (the mean of the middle two
    when n is even); values is not changed."""
    order = stable_argsort(values[:n])
    half = n >> 1
    if n & 1:
        return values[order[half]]
    return (values[order[half - 1]] + values[order[half]]) / 2


@inner_kernel
def _sift_down(values, root, end):
    """Restore the max-heap of values[:end] below ``root`` (heapsort's step)."""
    while True:
        child = 2 * root + 1
        if child >= end:
            return
        if child + 1 < end and values[child] < values[child + 1]:
            child += 1
        if not values[root] < values[child]:
            return
        values[root], values[child] = values[child], values[root]
        root = child


@inner_kernel
def sort_in_place(values, n):
    """Sort the integers values[:n] ascending in place (``values[:n].sort()``; integers
    that are equal cannot be told apart, so any correct order is numpy's), by heapsort:
    no allocation, n log n steps."""
    for root in range(n // 2 - 1, -1, -1):
        _sift_down(values, root, n)
    for end in range(n - 1, 0, -1):
        values[0], values[end] = values[end], values[0]
        _sift_down(values, np.int64(0), end)
