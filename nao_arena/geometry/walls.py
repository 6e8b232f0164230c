"""Static walls as obstacles: segments covered by chains of discs."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["wall_discs"]


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
