"""Static walls: distances from points to wall segments, and segments covered by chains of
discs (as obstacles)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["point_segment_distances", "segment_distances_xy", "wall_discs"]


def wall_discs(
    walls: NDArray[np.float64],
    half_thickness: NDArray[np.float64],
    grow: float,
    slack: float = 0.1,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Cover wall segments (W, 2, 2) m with static discs.

    A disc of radius rho0 + slack every 2 sqrt((rho0 + slack)^2 - rho0^2)
    along a segment covers every point within rho0 = half_thickness + grow
    of it. Returns centres (M, 2) and radii (M,) m.
    """
    centres, radii = [], []
    for (p, q), half in zip(walls, half_thickness, strict=True):
        rho0 = float(half) + grow
        rho = rho0 + slack
        spacing = 2.0 * math.sqrt(rho * rho - rho0 * rho0)
        length = float(np.hypot(*(q - p)))
        n = max(1, math.ceil(length / spacing)) + 1
        s = np.linspace(0.0, 1.0, n)[:, None]
        centres.append(p + s * (q - p))
        radii.append(np.full(n, rho))
    if not centres:
        return np.zeros((0, 2)), np.zeros(0)
    return np.concatenate(centres), np.concatenate(radii)


def segment_distances_xy(
    xs: NDArray[np.float64], ys: NDArray[np.float64], segment: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distances m from the points (xs, ys) m (any equal shapes) to one segment (2, 2) m,
    one coordinate at a time (contiguous arrays: the viewer's panel grids). The contact
    check's distance (:mod:`nao_arena.stats.kernel`, compiled) in numpy: the same bits but
    for segments shorter than 1e-150 m (here divided by 1e-300 rather than their squared
    length; tests/test_point_segment.py)."""
    (ax, ay), (bx, by) = segment
    abx, aby = bx - ax, by - ay
    ll = max(abx * abx + aby * aby, 1e-300)
    relx = xs - ax
    rely = ys - ay
    t = relx * abx
    t += rely * aby
    t /= ll
    np.clip(t, 0.0, 1.0, out=t)
    dx = relx - t * abx
    dy = rely - t * aby
    return np.hypot(dx, dy)


def point_segment_distances(
    points: NDArray[np.float64], segments: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distances (n, W) m from points (n, 2) m to segments (W, 2, 2) m."""
    points = np.asarray(points, dtype=float)
    xs, ys = np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1])
    out = np.empty((len(points), len(segments)))
    for k, segment in enumerate(np.asarray(segments, dtype=float)):
        out[:, k] = segment_distances_xy(xs, ys, segment)
    return out
