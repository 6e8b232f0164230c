"""Routes around walls: where a robot heads when a wall stands between it and its goal.

Avoidance (the NAO) is local: goal seeking toward a goal behind a wall drives a robot
into the wall, and its stand-off detours need not lead to the opening. A
:class:`NavigationGrid` covers the walls' surroundings with square cells (``cell`` m);
a cell is free when its centre lies farther than ``clearance`` (m: the robot's radius +
margin) + the wall's half-thickness from every wall segment. For each goal, a
distance field over the free cells (8-connected, shortest path lengths in m, exact on
the grid) is computed once and kept (:meth:`NavigationGrid.field`).

:func:`route_targets` gives each robot its heading target: its goal when the straight
line to it stays ``sight`` (m) + half-thickness clear of every wall (then nothing
changes), else the farthest point on the grid's shortest path from the robot's cell
(steepest descent of the field, up to ``lookahead`` m along it) that the robot sees
with that clearance; the goal where the grid has no path (a goal walled in).
Units: metres, world frame.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.kernels import segment_segment_dist2
from nao_arena.geometry.walls import segment_distances_xy
from nao_arena.jit import inner_kernel, kernel

__all__ = ["NavigationGrid", "navigation_grid", "route_targets", "segment_clear"]


@dataclass(eq=False)
class NavigationGrid:
    """Free cells around walls (W, 2, 2) m with half-thicknesses (W,) m.

    origin: the lower-left corner (2,) m; cell: the side (m); free: (nx, ny) bool, cell
    (i, j) centred at origin + ((i + 0.5) cell, (j + 0.5) cell); clearance: the robot's
    radius + margin (m) the free cells keep from every wall's surface."""

    walls: NDArray[np.float64]
    half: NDArray[np.float64]
    origin: NDArray[np.float64]
    cell: float
    free: NDArray[np.bool_]
    clearance: float
    _fields: dict[tuple[int, int], NDArray[np.float64]] = field(default_factory=dict)

    def cell_of(self, point: NDArray[np.float64]) -> tuple[int, int]:
        """The cell (i, j) containing ``point`` (2,) m, clipped to the grid."""
        ij = np.floor((np.asarray(point, dtype=np.float64) - self.origin) / self.cell)
        nx, ny = self.free.shape
        return int(min(max(ij[0], 0), nx - 1)), int(min(max(ij[1], 0), ny - 1))

    def field(self, goal: NDArray[np.float64]) -> NDArray[np.float64]:
        """Shortest path length (m) over free cells from each cell to the goal's cell
        ((nx, ny); inf where no path), computed once per goal cell."""
        key = self.cell_of(goal)
        hit = self._fields.get(key)
        if hit is None:
            if len(self._fields) > 256:
                self._fields.clear()
            hit = self._fields[key] = _dijkstra(self.free, key[0], key[1], self.cell)
        return hit


_GRIDS: dict[tuple[bytes, bytes, float, float, bytes], NavigationGrid] = {}


def navigation_grid(
    walls: NDArray[np.float64],
    half: NDArray[np.float64],
    clearance: float,
    extent: NDArray[np.float64],
    cell: float = 0.2,
) -> NavigationGrid:
    """The :class:`NavigationGrid` of the walls over ``extent`` ((2, 2) m: lower-left and
    upper-right corners, padded by 2 m), memoised (walls do not move). Points outside
    the grid count as in its nearest cell."""
    walls = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 2, 2)
    half = np.ascontiguousarray(half, dtype=np.float64)
    lo = np.floor(np.asarray(extent[0], dtype=np.float64) - 2.0)
    hi = np.ceil(np.asarray(extent[1], dtype=np.float64) + 2.0)
    key = (
        walls.tobytes(),
        half.tobytes(),
        float(clearance),
        float(cell),
        np.concatenate([lo, hi]).tobytes(),
    )
    grid = _GRIDS.get(key)
    if grid is None:
        if len(_GRIDS) > 16:
            _GRIDS.clear()
        nx, ny = (int(x) for x in np.ceil((hi - lo) / cell))
        xs = lo[0] + (np.arange(nx) + 0.5) * cell
        ys = lo[1] + (np.arange(ny) + 0.5) * cell
        gx = np.ascontiguousarray(np.repeat(xs, ny))
        gy = np.ascontiguousarray(np.tile(ys, nx))
        free = np.ones(nx * ny, dtype=bool)
        for segment, h in zip(walls, half, strict=True):
            free &= segment_distances_xy(gx, gy, segment) > clearance + h
        grid = _GRIDS[key] = NavigationGrid(
            walls, half, lo, float(cell), free.reshape(nx, ny), float(clearance)
        )
    return grid


@kernel
def _dijkstra(free, gi, gj, cell):
    """8-connected shortest path lengths (m) over the free cells to cell (gi, gj) (which
    counts as free); diagonal steps only between free side neighbours (no corner
    cutting)."""
    nx, ny = free.shape
    dist = np.full((nx, ny), np.inf)
    dist[gi, gj] = 0.0
    heap = [(0.0, gi, gj)]
    diag = cell * 1.4142135623730951
    while heap:
        d, i, j = heapq.heappop(heap)
        if d > dist[i, j]:
            continue
        for di in range(-1, 2):
            for dj in range(-1, 2):
                if di == 0 and dj == 0:
                    continue
                a = i + di
                b = j + dj
                if a < 0 or b < 0 or a >= nx or b >= ny or not free[a, b]:
                    continue
                if di != 0 and dj != 0 and not (free[i + di, j] and free[i, j + dj]):
                    continue
                nd = d + (diag if di != 0 and dj != 0 else cell)
                if nd < dist[a, b]:
                    dist[a, b] = nd
                    heapq.heappush(heap, (nd, a, b))
    return dist


@inner_kernel
def segment_clear(ax, ay, bx, by, walls, half, sight):
    """Whether the segment [a, b] (m) stays farther than ``sight`` + half-thickness (m)
    from every wall (walls (W, 2, 2) m, half (W,) m)."""
    for w in range(walls.shape[0]):
        lim = sight + half[w]
        if (
            segment_segment_dist2(
                ax, ay, bx, by, walls[w, 0, 0], walls[w, 0, 1], walls[w, 1, 0], walls[w, 1, 1]
            )
            <= lim * lim
        ):
            return False
    return True


@inner_kernel
def _lowest_near(dist, i, j, span, below):
    """The cell (a, b) within ``span`` cells of (i, j) with the least ``dist`` under
    ``below`` (the first such in row order) and that value; (-1, -1, below) if none."""
    nx, ny = dist.shape
    bi = -1
    bj = -1
    for di in range(-span, span + 1):
        for dj in range(-span, span + 1):
            a = i + di
            b = j + dj
            if 0 <= a < nx and 0 <= b < ny and dist[a, b] < below:
                below = dist[a, b]
                bi = a
                bj = b
    return bi, bj, below


@kernel
def _descend(dist, ox, oy, cell, px, py, gx, gy, walls, half, sight, max_steps):
    """The heading target (x, y) of a robot at (px, py) whose goal (gx, gy) it does not
    see: along the steepest descent of ``dist`` (the goal's field over the grid of
    lower-left corner (ox, oy) and cells of side ``cell``) from its cell (or the best
    free cell next to it), the farthest cell centre it sees (a line of sight ``sight`` m
    clear of the walls (W, 2, 2) m of half-thicknesses ``half`` (W,) m), up to max_steps
    cells; the goal when the field has no path from there."""
    nx, ny = dist.shape
    i = min(max(int(math.floor((px - ox) / cell)), 0), nx - 1)
    j = min(max(int(math.floor((py - oy) / cell)), 0), ny - 1)
    # start from the best cell within 2 cells (the robot's own may be blocked)
    bi, bj, best = _lowest_near(dist, i, j, np.int64(2), math.inf)
    if bi < 0 or not math.isfinite(best):
        return gx, gy
    tx = ox + (bi + 0.5) * cell
    ty = oy + (bj + 0.5) * cell
    i = bi
    j = bj
    for _ in range(max_steps):
        if dist[i, j] == 0.0:
            break
        ni, nj, _ = _lowest_near(dist, i, j, np.int64(1), dist[i, j])
        if ni < 0:
            break
        i = ni
        j = nj
        cx = ox + (i + 0.5) * cell
        cy = oy + (j + 0.5) * cell
        if segment_clear(px, py, cx, cy, walls, half, sight):
            tx = cx
            ty = cy
    return tx, ty


@kernel
def _in_sight(positions, goals, walls, half, sight):
    """Per row: whether the goal is finite and in sight of the (finite) position."""
    n = positions.shape[0]
    out = np.ones(n, dtype=np.bool_)
    for k in range(n):
        px = positions[k, 0]
        py = positions[k, 1]
        gx = goals[k, 0]
        gy = goals[k, 1]
        if not (
            math.isfinite(px) and math.isfinite(py) and math.isfinite(gx) and math.isfinite(gy)
        ):
            continue
        out[k] = segment_clear(px, py, gx, gy, walls, half, sight[k])
    return out


def route_targets(
    grid: NavigationGrid,
    positions: NDArray[np.float64],
    goals: NDArray[np.float64],
    sight: NDArray[np.float64],
    lookahead: float = 6.0,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Heading targets (n, 2) m of robots at ``positions`` (n, 2) m with ``goals``
    (n, 2) m (see the module docstring), and which of them lead round a wall (n,);
    ``sight`` (n,) m: the clearance a line of sight keeps from the walls' surfaces (the
    robot's radius); ``lookahead`` (m): how far along the grid's path a target may lie.
    Rows with a non-finite position or goal keep the goal."""
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    goals = np.ascontiguousarray(goals, dtype=np.float64)
    out = goals.copy()
    around = ~_in_sight(
        positions, goals, grid.walls, grid.half, np.ascontiguousarray(sight, dtype=np.float64)
    )
    steps = max(1, int(lookahead / grid.cell))
    for k in np.flatnonzero(around).tolist():
        p, g = positions[k], goals[k]
        out[k] = _descend(
            grid.field(g),
            grid.origin[0],
            grid.origin[1],
            grid.cell,
            p[0],
            p[1],
            g[0],
            g[1],
            grid.walls,
            grid.half,
            float(sight[k]),
            steps,
        )
    return out, around
