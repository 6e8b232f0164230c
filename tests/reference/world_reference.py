"""The world's speed-limit model written out in numpy, without contacts: the reference
that :func:`nao_arena.world._plan_period` (the fused kernel of ``World.step``) and the
world's trajectories must match."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.motion import speed_limit_time
from nao_arena.world import clip_accelerations

FloatArray = NDArray[np.float64]


def substep_weights(tau: ArrayLike, dt: float, substeps: int) -> FloatArray:
    """Fraction (substeps, N) of each substep spent accelerating: clamp((tau - j h)/h, 0, 1)."""
    h = dt / substeps
    j = np.arange(substeps, dtype=float)[:, None]
    return np.clip((np.asarray(tau, float)[None, :] - j * h) / h, 0.0, 1.0)


def scale_to_vmax(v: FloatArray, v_max: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Rows of v (N, 2) m/s scaled to |v| <= v_max (N,) m/s, and which rows were scaled."""
    speed = np.hypot(v[:, 0], v[:, 1])
    over = speed > v_max
    if not np.any(over):
        return v, over
    scale = np.where(over, v_max / np.where(over, speed, 1.0), 1.0)
    return v * scale[:, None], over


def velocity_after_period(
    v: ArrayLike, a: ArrayLike, a_max: ArrayLike, v_max: ArrayLike, dt: float
) -> FloatArray:
    """The speed-limit model without contacts: v' + a' min(tau, dt), (N, 2) m/s.

    a' is a (m/s^2) scaled to |a'| <= a_max; v' is v (m/s) scaled to
    |v'| <= v_max; tau from :func:`speed_limit_time`.
    """
    a_c = clip_accelerations(a, a_max)
    v_c, _ = scale_to_vmax(np.asarray(v, float), np.asarray(v_max, float))
    tau = speed_limit_time(v_c, a_c, v_max)
    return v_c + a_c * np.minimum(tau, dt)[:, None]
