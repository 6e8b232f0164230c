"""The ``turn_rate`` predictor integrated with numpy: the reference that the compiled
integration (:func:`nao_arena.predictors.turn_rate`) must match bit for bit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nao_arena.sensing import Neighbours


def turn_rate_numpy(times: NDArray[np.float64], nb: Neighbours) -> NDArray[np.float64]:
    """:func:`nao_arena.predictors.turn_rate` with the arcs integrated by numpy (midpoint
    rule on 8 fine steps per sample interval), (n, T, 2) m."""
    n = len(nb)
    if n == 0:
        return np.zeros((0, len(times), 2))
    m = turn_rate_motion(times, nb)
    th = m.heading[:, None] + m.omega[:, None] * m.mid[None]
    s = np.maximum(m.speed[:, None] + m.a_t[:, None] * m.mid[None], 0.0)
    step = s[..., None] * np.stack([np.cos(th), np.sin(th)], -1) * m.fine[None, :, None]
    pos = nb.positions[:, None, :] + np.concatenate(
        [np.zeros((n, 1, 2)), np.cumsum(step, axis=1)], axis=1
    )
    return hold_still(pos[:, 8::8][:, : len(times)], nb, m.moving)


@dataclass(frozen=True)
class TurnRateMotion:
    """Per neighbour: speed (m/s), omega (rad/s), a_t (m/s^2), heading (rad), moving
    (speed above 1e-6 m/s); the fine grid's midpoints ``mid`` (s) and steps ``fine`` (s),
    8 per sample interval."""

    speed: NDArray[np.float64]
    omega: NDArray[np.float64]
    a_t: NDArray[np.float64]
    heading: NDArray[np.float64]
    moving: NDArray[np.bool_]
    mid: NDArray[np.float64]
    fine: NDArray[np.float64]


def turn_rate_motion(times: NDArray[np.float64], nb: Neighbours) -> TurnRateMotion:
    """The motion :func:`turn_rate` integrates, from the neighbours' observed state."""
    v = nb.velocities
    a = nb.accelerations
    speed = np.hypot(v[:, 0], v[:, 1])
    moving = speed > 1e-6
    safe = np.where(moving, speed, 1.0)
    omega = np.where(moving, (v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0]) / safe**2, 0.0)
    a_t = np.where(moving, (v[:, 0] * a[:, 0] + v[:, 1] * a[:, 1]) / safe, 0.0)
    heading = np.arctan2(v[:, 1], v[:, 0])
    fine = np.concatenate([[0.0], np.repeat(np.diff(np.concatenate([[0.0], times])) / 8, 8)])
    t_fine = np.cumsum(fine)
    mid = t_fine[:-1] + 0.5 * fine[1:]
    return TurnRateMotion(speed, omega, a_t, heading, moving, mid, fine[1:])


def hold_still(
    out: NDArray[np.float64], nb: Neighbours, moving: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """``out`` (n, T, 2) m with the neighbours at rest held at their positions: a
    neighbour at rest (no heading) stays at rest, its observed acceleration, the mean over
    the last period, being the braking that stopped it (one that sets off from rest is
    already moving when observed)."""
    still = ~moving
    if np.any(still):
        out[still] = nb.positions[still][:, None, :]
    return out
