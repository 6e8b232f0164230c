"""The acceleration panel's walls' region as first written: every wall against every
sampled point of every panel acceleration's path (the viewer prunes by bounding boxes)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from nao_arena.maps.loader import point_segment_distances
from nao_arena.world import speed_limit_time


def _own_paths(v: NDArray[np.float64], accels: NDArray[np.float64], v_max: float,
               times: NDArray[np.float64]) -> NDArray[np.float64]:
    """Displacements (K, T, 2) m under constant accelerations (K, 2), speed saturating at
    v_max."""
    vv = np.broadcast_to(v, accels.shape)
    tau = speed_limit_time(vv, accels, np.full(len(accels), v_max))
    t = np.minimum(times[None, :], tau[:, None])[..., None]
    x = v * t + 0.5 * accels[:, None, :] * t * t
    v_sat = v + accels * np.where(np.isfinite(tau), tau, 0.0)[:, None]
    extra = np.maximum(times[None, :] - tau[:, None], 0.0)[..., None]
    return x + v_sat[:, None, :] * extra


def wall_clearance_reference(grid: NDArray[np.float64], velocity: NDArray[np.float64],
                             v_max: float, horizon: float,
                             walls: tuple[NDArray[np.float64], NDArray[np.float64]],
                             ) -> NDArray[np.float64]:
    """Least clearance (G,) m of the own path under each acceleration of ``grid`` to the walls."""
    times = np.linspace(0.0, horizon, 41)
    own = _own_paths(velocity, grid, v_max, times)
    pts = own.reshape(-1, 2)
    wall_clear = np.full(len(grid), np.inf)
    for seg, grown in zip(walls[0], walls[1], strict=True):
        d = point_segment_distances(pts, seg[None])[:, 0].reshape(len(grid), len(times))
        wall_clear = np.minimum(wall_clear, np.min(d, axis=1) - grown)
    return wall_clear
