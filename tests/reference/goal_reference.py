"""Reference goal seeking: :func:`nao_arena.agents.goal.goal_seeking_accels` in plain
numpy, for the tests that check the compiled one bit for bit."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

APPROACH_GAIN = 1.0


def goal_seeking_accels_reference(
    targets: NDArray[np.float64],
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64],
    a_max: NDArray[np.float64],
    speed_cap: NDArray[np.float64],
    heading_offset: Sequence[float] | None = None,
    time_constant: float | NDArray[np.float64] = 0.5,
    braking: float = 0.5,
    approach_gain: float = APPROACH_GAIN,
    has_target: NDArray[np.bool_] | None = None,
) -> NDArray[np.float64]:
    """goal_seeking_accels in vectorised numpy, as it was before it was compiled."""
    to_goal = targets - positions
    dist = np.hypot(to_goal[:, 0], to_goal[:, 1])
    still = dist < 1e-9
    if has_target is not None:
        still |= ~has_target
    lag = braking * a_max * time_constant
    # min(cap, stopping speed, k d), the first of equals (Python's min, also with NaN)
    stop = np.sqrt(2.0 * braking * a_max * dist + lag * lag) - lag
    speed = np.where(stop < speed_cap, stop, speed_cap)
    near = approach_gain * dist
    speed = np.where(near < speed, near, speed)
    if np.any(still):  # standing still: no direction (and no division by 0)
        dist = np.where(still, 1.0, dist)
        speed[still] = 0.0
    v_target = to_goal / dist[:, None] * speed[:, None]
    if np.any(still):
        v_target[still] = 0.0
    if heading_offset is not None:
        for i in np.flatnonzero(~still).tolist():
            turn = heading_offset[i]
            if turn:
                c, s_ = np.cos(turn), np.sin(turn)
                vt = v_target[i].copy()
                v_target[i] = (c * vt[0] - s_ * vt[1], s_ * vt[0] + c * vt[1])
    tau = np.asarray(time_constant, dtype=np.float64)
    acc = (v_target - velocities) / (tau[:, None] if tau.ndim else tau)
    norm = np.hypot(acc[:, 0], acc[:, 1])
    over = norm > a_max
    if np.any(over):
        acc[over] *= (a_max[over] / norm[over])[:, None]
    return acc
