"""When and how a contact started, for the rare steps in which one does: the first
touching substep, the time of first touch within it (closed form) and the contact normal."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["first_disc_touch", "first_touching_substep", "first_wall_touch"]

FloatArray = NDArray[np.float64]


def _first_root(px: float, py: float, ex: float, ey: float, reach: float) -> float:
    """First t in [0, 1] with |(px, py) + (ex, ey) t| <= reach (inf if none)."""
    c = px * px + py * py - reach * reach
    if c <= 0.0:
        return 0.0
    b = px * ex + py * ey
    a = ex * ex + ey * ey
    disc = b * b - a * c
    if b >= 0.0 or disc < 0.0:
        return math.inf
    t = c / (math.sqrt(disc) - b)
    return t if t <= 1.0 else math.inf


def first_wall_touch(
    p0: np.ndarray, p1: np.ndarray, a: np.ndarray, b: np.ndarray, reach: float
) -> tuple[float, np.ndarray]:
    """First t in [0, 1] at which the moving point p0 + (p1 - p0) t comes within reach (m)
    of segment a-b (closed form: the end discs and the side lines of the capsule), and
    the unit contact normal from the wall to the point then."""
    x0, y0, x1, y1 = float(p0[0]), float(p0[1]), float(p1[0]), float(p1[1])
    ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    ex, ey = x1 - x0, y1 - y0
    dx, dy = bx - ax, by - ay
    length = math.hypot(dx, dy)
    if length > 0.0:
        dx, dy = dx / length, dy / length
    nx, ny = -dy, dx

    def gap(t: float) -> tuple[float, float]:
        px, py = x0 + ex * t - ax, y0 + ey * t - ay
        u = min(max(px * dx + py * dy, 0.0), length)
        return px - u * dx, py - u * dy

    ox, oy = gap(0.0)
    if ox * ox + oy * oy <= reach * reach:
        t = 0.0
    else:
        t = min(
            _first_root(x0 - ax, y0 - ay, ex, ey, reach),
            _first_root(x0 - bx, y0 - by, ex, ey, reach),
        )
        side0 = (x0 - ax) * nx + (y0 - ay) * ny
        rate = ex * nx + ey * ny
        if rate != 0.0 and length > 0.0:
            ts = (math.copysign(reach, side0) - side0) / rate
            if 0.0 <= ts <= 1.0:
                u = (x0 + ex * ts - ax) * dx + (y0 + ey * ts - ay) * dy
                if 0.0 <= u <= length:
                    t = min(t, ts)
        t = min(t, 1.0)
    ox, oy = gap(t)
    norm = math.hypot(ox, oy)
    if norm > 1e-12:
        return t, np.array([ox / norm, oy / norm])
    side = (x0 - ax) * nx + (y0 - ay) * ny
    return t, np.array([nx, ny]) if side >= 0 else np.array([-nx, -ny])


def first_touching_substep(distances: FloatArray, reach: float) -> int:
    """The first substep whose minimum distance (m) is below reach (m); if none (rounding),
    the closest one."""
    below = np.flatnonzero(distances < reach)
    return int(below[0]) if len(below) else int(np.argmin(distances))


def first_disc_touch(d0: np.ndarray, d1: np.ndarray, reach: float) -> tuple[float, np.ndarray]:
    """First t in [0, 1] with |d0 + (d1 - d0) t| <= reach, and the unit normal there (a to b)."""
    px, py = float(d0[0]), float(d0[1])
    wx, wy = float(d1[0]) - px, float(d1[1]) - py
    t = min(_first_root(px, py, wx, wy, reach), 1.0)
    if t == 1.0:  # the sampled minimum said "touching": take the closest approach
        ww = wx * wx + wy * wy
        t = min(max(-(px * wx + py * wy) / ww, 0.0), 1.0) if ww > 0 else 0.0
    mx, my = px + wx * t, py + wy * t
    norm = math.hypot(mx, my)
    if norm > 1e-12:
        return t, np.array([mx / norm, my / norm])
    wn = math.hypot(wx, wy)
    return t, (np.array([-wx / wn, -wy / wn]) if wn > 0 else np.array([1.0, 0.0]))
