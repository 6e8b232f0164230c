"""The acceleration panel's labels by their definition, without pruning: every neighbour's
exact clearance at every panel acceleration (:func:`path_clearance`), and the walls' region
either as first written (the robot's path sampled at 41 times, every wall against every
sample) or exact (:func:`segments_min_distance` at every acceleration, every wall)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry._kernel.relevance import relevant_obstacles
from nao_arena.geometry._kernel.segment import segments_min_distance
from nao_arena.geometry.clearance import PiecewisePath, path_clearance
from nao_arena.geometry.walls import point_segment_distances
from nao_arena.world import speed_limit_time

Walls = tuple[NDArray[np.float64], NDArray[np.float64]]


def _own_paths(
    v: NDArray[np.float64], accels: NDArray[np.float64], v_max: float, times: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Displacements (K, T, 2) m under constant accelerations (K, 2), speed saturating at
    v_max."""
    vv = np.broadcast_to(v, accels.shape)
    tau = speed_limit_time(vv, accels, np.full(len(accels), v_max))
    t = np.minimum(times[None, :], tau[:, None])[..., None]
    x = v * t + 0.5 * accels[:, None, :] * t * t
    v_sat = v + accels * np.where(np.isfinite(tau), tau, 0.0)[:, None]
    extra = np.maximum(times[None, :] - tau[:, None], 0.0)[..., None]
    return x + v_sat[:, None, :] * extra


def wall_clearance_sampled(
    grid: NDArray[np.float64],
    velocity: NDArray[np.float64],
    v_max: float,
    horizon: float,
    walls: Walls,
) -> NDArray[np.float64]:
    """Least clearance (G,) m of the own path under each acceleration of ``grid`` to the
    walls, the path sampled at 41 times (the walls' region as first written)."""
    times = np.linspace(0.0, horizon, 41)
    own = _own_paths(velocity, grid, v_max, times)
    pts = own.reshape(-1, 2)
    wall_clear = np.full(len(grid), np.inf)
    for seg, grown in zip(walls[0], walls[1], strict=True):
        d = point_segment_distances(pts, seg[None])[:, 0].reshape(len(grid), len(times))
        wall_clear = np.minimum(wall_clear, np.min(d, axis=1) - grown)
    return wall_clear


def wall_clearance_exact(
    grid: NDArray[np.float64],
    velocity: NDArray[np.float64],
    v_max: float,
    horizon: float,
    walls: Walls,
) -> NDArray[np.float64]:
    """Least clearance (G,) m of the own path under each acceleration of ``grid`` to the
    walls: the exact segment kernel at every acceleration against every wall."""
    segs = np.ascontiguousarray(walls[0], dtype=float)
    grown = np.ascontiguousarray(walls[1], dtype=float)
    v = np.ascontiguousarray(velocity, dtype=float)
    return np.array(
        [
            segments_min_distance(
                v, np.ascontiguousarray(a), float(v_max), segs, grown, float(horizon)
            )[0]
            for a in grid
        ]
    )


WallClearance = Callable[
    [NDArray[np.float64], NDArray[np.float64], float, float, Walls], NDArray[np.float64]
]


def panel_labels_reference(
    grid: NDArray[np.float64],
    obs: object,
    path: PiecewisePath,
    walls: Walls | None,
    reach: float,
    wall_clearance: WallClearance = wall_clearance_exact,
) -> tuple[NDArray[np.int64], int]:
    """Labels (G,) of the panel's accelerations (-1 free, -2 walls, j the neighbour of
    ``path`` with the least clearance) and the number of obstacles within reach, as
    :meth:`nao_arena.render.Viewer._panel_labels` defines them: the neighbour of least
    exact clearance where it is negative, the walls where their clearance is negative and
    below that."""
    velocity, v_max = obs.velocity, obs.v_max  # type: ignore[attr-defined]
    lab = np.full(len(grid), -1, dtype=np.int64)
    best = np.zeros(len(grid))
    shown = 0
    if path.n_obstacles:
        idx = np.flatnonzero(relevant_obstacles(velocity, reach, v_max, *path.moving_arrays, 0.0))
        if len(idx):
            shown += len(idx)
            sub = PiecewisePath(
                path.t, path.c[idx], path.velocity[idx], path.acceleration[idx], path.radius[idx]
            )
            clear = path_clearance(grid, velocity, sub, v_max=v_max).clearance
            owner = np.argmin(clear, axis=1)
            best = clear[np.arange(len(grid)), owner]
            lab[best < 0] = idx[owner[best < 0]]
    if walls is not None:
        wall_clear = wall_clearance(grid, velocity, v_max, float(path.t[-1]), walls)
        lab[(wall_clear < 0) & (wall_clear < best)] = -2
        shown += len(walls[1])
    return lab, shown
