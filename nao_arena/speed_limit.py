"""The speed-limit model, shared by the world and the planner's kernels.

A body commanded a constant acceleration a (m/s^2) from a velocity v (m/s) with
|v| <= v_max accelerates until its speed |v + a t| reaches v_max (m/s), at the
saturation time tau (s), and coasts at constant velocity from then on.
:class:`nao_arena.world.World` drives exactly this model (up to contacts), and the
geometry kernels predict the robot's own path with it, so the planner predicts the
path the world drives by construction: both call :func:`saturation_time`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = ["saturation_time", "speed_limit_time"]


@njit(cache=True, error_model="numpy")
def saturation_time(vx: float, vy: float, ax: float, ay: float, v_max: float) -> float:
    """Time tau (s) at which |v + a tau| reaches v_max: the positive root, inf if never.

    v = (vx, vy) m/s must satisfy |v| <= v_max (m/s; rounding tolerated, inf allowed);
    a = (ax, ay) m/s^2. At |v| = v_max, tau = 0 unless a points backwards (a . v < 0),
    when tau = -2 a.v / |a|^2.
    """
    if not math.isfinite(v_max):
        return math.inf
    aa = ax * ax + ay * ay
    if aa == 0.0:
        return math.inf
    b = ax * vx + ay * vy
    c = min(vx * vx + vy * vy - v_max * v_max, 0.0)
    # positive root of aa t^2 + 2 b t + c = 0 (c <= 0)
    root = math.sqrt(b * b - aa * c)
    if b >= 0.0:
        # numerically stable form of (root - b) / aa
        forward = b + root
        return (0.0 - c) / (forward if forward > 0.0 else 1.0)
    return (root - b) / aa


@njit(cache=True, error_model="numpy")
def _saturation_times(
    v: NDArray[np.float64], a: NDArray[np.float64], v_max: NDArray[np.float64]
) -> NDArray[np.float64]:
    out = np.empty(v.shape[0])
    for i in range(v.shape[0]):
        out[i] = saturation_time(v[i, 0], v[i, 1], a[i, 0], a[i, 1], v_max[i])
    return out


def speed_limit_time(v: ArrayLike, a: ArrayLike, v_max: ArrayLike) -> NDArray[np.float64]:
    """:func:`saturation_time` per row: tau (N,) s for v (N, 2) m/s, a (N, 2) m/s^2 and
    v_max (N,) m/s (or one v_max for all rows)."""
    v = np.ascontiguousarray(v, dtype=float)
    a = np.ascontiguousarray(a, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2 or a.shape != v.shape:
        raise ValueError(f"expected v and a of shape (N, 2), got {v.shape} and {a.shape}")
    limit = np.ascontiguousarray(np.broadcast_to(np.asarray(v_max, dtype=float), v.shape[:1]))
    return _saturation_times(v, a, limit)
