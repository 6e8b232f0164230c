"""numpy references of the statistics' compiled geometry (nao_arena.stats.kernel): the
same float operations in the same order, so the kernel's distances equal these bit for
bit (tests/test_stats.py checks both)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def swept_disc_distances(d0: FloatArray, d1: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Minimum centre distance over a step and its time fraction, for linear relative motion.

    d0, d1: (K, 2) relative positions (m) at the start and end of the step;
    d(t) = d0 + (d1 - d0) t, t in [0, 1]. Returns (min |d(t)| (K,) m, argmin t (K,)).
    """
    w = d1 - d0
    ww = w[:, 0] * w[:, 0] + w[:, 1] * w[:, 1]
    dw = d0[:, 0] * w[:, 0] + d0[:, 1] * w[:, 1]
    t = np.clip(-dw / np.where(ww > 0.0, ww, 1.0), 0.0, 1.0)
    m = d0 + w * t[:, None]
    return np.hypot(m[:, 0], m[:, 1]), t


def point_segment(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Distances (K,) m from points p to segments a-b, all (K, 2) m."""
    ab = b - a
    ll = ab[:, 0] * ab[:, 0] + ab[:, 1] * ab[:, 1]
    ap = p - a
    t = np.clip((ap[:, 0] * ab[:, 0] + ap[:, 1] * ab[:, 1]) / np.where(ll > 0, ll, 1.0), 0, 1)
    d = ap - ab * t[:, None]
    return np.hypot(d[:, 0], d[:, 1])


def cross(u: FloatArray, v: FloatArray) -> FloatArray:
    """z of the cross products of rows of u and v (K, 2)."""
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def segment_distances(p0: FloatArray, p1: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Minimum distance (K,) m between segments p0-p1 and a-b, all (K, 2) m.

    With p0-p1 a centre's linear path over a step, this is the exact
    minimum over the step of the distance from the centre to wall a-b.
    """
    e = p1 - p0
    f = b - a
    o1, o2 = cross(f, p0 - a), cross(f, p1 - a)
    o3, o4 = cross(e, a - p0), cross(e, b - p0)
    crossing = (o1 * o2 < 0) & (o3 * o4 < 0)
    d = np.minimum(
        np.minimum(point_segment(p0, a, b), point_segment(p1, a, b)),
        np.minimum(point_segment(a, p0, p1), point_segment(b, p0, p1)),
    )
    return np.where(crossing, 0.0, d)
