"""The ``turn_rate`` predictor integrated with numpy: the reference that the compiled
integration (:func:`nao_arena.predictors.turn_rate`) must match bit for bit."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from nao_arena.predictors import hold_still, turn_rate_motion
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
