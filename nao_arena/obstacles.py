"""The predicted obstacle set a robot avoids, as the NAO agent, the env's NAO features and
the viewer's acceleration panel all build it.

Robot-relative (m): each neighbour's predicted centres over the time grid with its radius
grown by the robot's own radius and a margin, then the wall discs (static, already grown,
see :func:`nao_arena.geometry.walls.wall_discs`) within reach. With ``cut`` an obstacle
already closer than its grown radius (inside the margin, or touching) counts with just
under its current distance (``RADIUS_CUT``): the robot may not close in further but may
move away, instead of finding every acceleration inadmissible.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry._kernel.sampled import RADIUS_CUT
from nao_arena.geometry.clearance import PiecewisePath, sampled_path
from nao_arena.geometry.walls import wall_discs

__all__ = ["NO_WALLS", "RADIUS_CUT", "obstacle_paths", "wall_discs_memo", "walls_within",
           "within_reach"]


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
    key = (np.ascontiguousarray(walls).tobytes(), np.ascontiguousarray(wall_radius).tobytes(),
           float(grow))
    hit = _WALL_CACHE.get(key)
    if hit is None:
        if len(_WALL_CACHE) > 64:
            _WALL_CACHE.clear()
        wc, wr = wall_discs(walls, wall_radius, grow)
        hit = _WALL_CACHE[key] = (np.ascontiguousarray(wc, dtype=np.float64),
                                  np.ascontiguousarray(wr, dtype=np.float64))
    return hit


def walls_within(
    wall_centres: NDArray[np.float64], wall_radii: NDArray[np.float64],
    position: NDArray[np.float64], reach: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The wall discs whose centre lies within ``reach`` (m) + their radius of ``position``
    (2,) m: centres relative to ``position`` (m) and radii (m)."""
    near = np.hypot(*(wall_centres - position).T) <= reach + wall_radii
    return wall_centres[near] - position, wall_radii[near]


def obstacle_paths(
    times: NDArray[np.float64],
    centres: NDArray[np.float64],
    grown_radii: NDArray[np.float64],
    position: NDArray[np.float64],
    wall_centres: NDArray[np.float64] | None = None,
    wall_radii: NDArray[np.float64] | None = None,
    wall_reach: float = math.inf,
    cut: bool = True,
) -> PiecewisePath:
    """The obstacles of a robot at ``position`` (2,) m over ``times`` (T,) s, robot-relative.

    centres: the neighbours' predicted centres (n, T, 2) m, world frame; grown_radii (n,)
    m: their radii grown by the robot's radius and margin; wall_centres (W, 2) m and
    wall_radii (W,) m: wall discs (grown alike), of which those whose centre lies within
    ``wall_reach`` (m) + their radius of ``position`` count, after the neighbours;
    cut: radii cut to just under the current distances (see the module docstring).
    """
    rel = centres - position
    parts = [rel]
    radii = [within_reach(grown_radii, rel[:, 0]) if cut else grown_radii]
    if wall_centres is not None and wall_radii is not None and len(wall_centres):
        wall_rel, wall_r = walls_within(wall_centres, wall_radii, position, wall_reach)
        parts.append(np.repeat(wall_rel[:, None, :], len(times), 1))
        radii.append(within_reach(wall_r, wall_rel) if cut else wall_r)
    return sampled_path(times, np.concatenate(parts), np.concatenate(radii))
