"""The predicted obstacle set a robot avoids, as the NAO agent, the env's NAO features and
the viewer's acceleration panel all build it.

Robot-relative (m): each neighbour's predicted centres over the time grid with its radius
grown by the robot's own radius and a margin, and the walls within reach as exact static
segments (their half-thickness grown alike; :mod:`nao_arena.geometry._kernel.segment`).
With ``cut`` an obstacle or wall already closer than its grown radius (inside the margin,
or touching) counts with just under its current distance (``RADIUS_CUT``): the robot may
not close in further but may move away, instead of finding every acceleration
inadmissible.

The velocity-space baselines (``vo``, ``orca``) see walls as chains of discs instead
(:func:`wall_discs_memo`), the obstacle model those methods take.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.clearance import PiecewisePath, sampled_path
from nao_arena.geometry.kernels import RADIUS_CUT, nearby_walls
from nao_arena.geometry.walls import wall_discs

__all__ = [
    "NO_WALLS",
    "RADIUS_CUT",
    "obstacle_paths",
    "relative_walls",
    "wall_discs_memo",
    "within_reach",
]


def within_reach(radii: NDArray[np.float64], rel: NDArray[np.float64]) -> NDArray[np.float64]:
    """Grown radii (m) cut to just under the current distances of the centres ``rel``
    (n, 2) m (the same operations as the compiled keep test)."""
    dist = np.sqrt(rel[:, 0] * rel[:, 0] + rel[:, 1] * rel[:, 1])
    return np.minimum(radii, dist * RADIUS_CUT)


NO_WALLS = (np.zeros((0, 2)), np.zeros(0))
"""No wall discs: centres (0, 2) m and radii (0,) m (shared: do not write into them)."""
_WALL_CACHE: dict[tuple[bytes, bytes, float], tuple[NDArray[np.float64], NDArray[np.float64]]] = {}


def wall_discs_memo(
    walls: NDArray[np.float64], wall_radius: NDArray[np.float64], grow: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`~nao_arena.geometry.walls.wall_discs` of the segments ``walls`` (W, 2, 2) m
    (half-thickness ``wall_radius`` (W,) m) grown by ``grow`` (m): centres (M, 2) m and
    radii (M,) m, contiguous, memoised (walls do not move; the results are shared, do
    not write into them)."""
    if not len(walls):
        return NO_WALLS
    key = (
        np.ascontiguousarray(walls).tobytes(),
        np.ascontiguousarray(wall_radius).tobytes(),
        float(grow),
    )
    hit = _WALL_CACHE.get(key)
    if hit is None:
        if len(_WALL_CACHE) > 64:
            _WALL_CACHE.clear()
        wc, wr = wall_discs(walls, wall_radius, grow)
        hit = _WALL_CACHE[key] = (
            np.ascontiguousarray(wc, dtype=np.float64),
            np.ascontiguousarray(wr, dtype=np.float64),
        )
    return hit


def relative_walls(
    walls: NDArray[np.float64],
    grown_radii: NDArray[np.float64],
    position: NDArray[np.float64],
    reach: float = math.inf,
    cut: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The walls (W, 2, 2) m (world frame) within ``reach`` (m) + their grown radius
    ``grown_radii`` (W,) m of ``position`` (2,) m: ends relative to ``position`` (m) and
    radii (m), cut to just under the current distances with ``cut``."""
    walls = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 2, 2)
    return nearby_walls(
        walls,
        np.ascontiguousarray(grown_radii, dtype=np.float64),
        np.arange(len(walls), dtype=np.int64),
        np.ascontiguousarray(position, dtype=np.float64),
        0.0,
        float(reach),
        bool(cut),
    )


def obstacle_paths(
    times: NDArray[np.float64],
    centres: NDArray[np.float64],
    grown_radii: NDArray[np.float64],
    position: NDArray[np.float64],
    walls: NDArray[np.float64] | None = None,
    wall_radii: NDArray[np.float64] | None = None,
    wall_reach: float = math.inf,
    cut: bool = True,
) -> PiecewisePath:
    """The obstacles of a robot at ``position`` (2,) m over ``times`` (T,) s, robot-relative.

    centres: the neighbours' predicted centres (n, T, 2) m, world frame; grown_radii (n,)
    m: their radii grown by the robot's radius and margin; walls (W, 2, 2) m (world frame)
    with wall_radii (W,) m (half-thickness grown alike), of which those within
    ``wall_reach`` (m) + their radius of ``position`` count; cut: radii cut to just under
    the current distances (see the module docstring).
    """
    rel = centres - position
    radii = within_reach(grown_radii, rel[:, 0]) if cut else grown_radii
    path = sampled_path(times, rel, radii)
    if walls is None or wall_radii is None or not len(walls):
        return path
    w_rel, w_rad = relative_walls(walls, wall_radii, position, wall_reach, cut)
    return PiecewisePath(
        path.t, path.c, path.velocity, path.acceleration, path.radius, w_rel, w_rad
    )
