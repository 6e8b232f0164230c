"""The neighbour index: a uniform grid over the bodies' centres and the queries on it.

Centres are in the world frame (m). The grid buckets the bodies by cell in index
order (:func:`grid`); its cell width h (m) is chosen by the caller's query:

- :func:`range_grid` makes cells at least as wide as a reach (m), so that every
  body within the reach of a body lies in the 3 x 3 cells around it
  (:func:`around`); sensing's full scan (:func:`in_range_lists`) and the stopping
  plans' pair search (:mod:`nao_arena.stopping`) use it, each with its own reach
  (the sensing range; the largest distance at which two plans can meet);
- the nearest-k search (:func:`nearest_lists`) makes cells a fraction of the
  crowd's typical distance to its k-th neighbour and visits them in square rings.

Every query lists the same bodies, in the same order, as a scan over all bodies
would (candidates are taken in index order), whatever the cell width.

The statistics' broad phase (:mod:`nao_arena.stats.kernel`) is not a query of this
index: it pairs boxes of each body's own size (its swept step, its look-ahead and the
separation range) and the walls' boxes by a sort and sweep on x, whose order, kept
from step to step, is the order in which contact events are applied.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from nao_arena.jit import inner_kernel, kernel
from nao_arena.sorting import median, sort_in_place, stable_order

__all__ = [
    "around",
    "extent",
    "grid",
    "in_range_lists",
    "nearest_lists",
    "range_grid",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

MAX_CELLS_PER_BODY = 4
"""A finer grid than this many cells per body costs more than it saves."""
KNN_CELLS_PER_BODY = 16
"""Cells per body of the nearest-k search's grid: fine enough that a dense crowd's cell
holds a few bodies though the grid spans the whole (mostly empty) extent."""


@kernel
def extent(positions: FloatArray) -> tuple[float, float, float, float]:
    """The bounding box (x0, y0, x1, y1) m of the centres positions (n >= 1, 2) m."""
    x0 = positions[0, 0]
    y0 = positions[0, 1]
    x1 = x0
    y1 = y0
    for j in range(positions.shape[0]):
        x0 = min(x0, positions[j, 0])
        x1 = max(x1, positions[j, 0])
        y0 = min(y0, positions[j, 1])
        y1 = max(y1, positions[j, 1])
    return x0, y0, x1, y1


@inner_kernel
def range_grid(
    reach: float, n: int, x0: float, y0: float, x1: float, y1: float
) -> tuple[float, int, int]:
    """Cell width h (m) and cell counts (gx, gy) of a grid over the box (x0, y0, x1, y1)
    m whose cells are at least ``reach`` (m) wide, so that bodies within reach of each
    other lie in neighbouring cells: a little wider than the reach (rounding cannot
    put a body within reach two cells away), wider still where the cells would
    outnumber the n bodies more than :data:`MAX_CELLS_PER_BODY` times. An infinite
    reach or extent is one cell."""
    gx = 1
    gy = 1
    h = 1.0
    if math.isfinite(reach) and math.isfinite(x1 - x0) and math.isfinite(y1 - y0):
        cells = MAX_CELLS_PER_BODY * n + 16
        h = max(reach * (1.0 + 1e-9), 1e-9, 1.01 * math.sqrt((x1 - x0) * (y1 - y0) / cells))
        wx = math.floor((x1 - x0) / h) + 1.0
        wy = math.floor((y1 - y0) / h) + 1.0
        while wx * wy > cells:  # long thin extents: coarser until the cells fit
            h *= 2.0
            wx = math.floor((x1 - x0) / h) + 1.0
            wy = math.floor((y1 - y0) / h) + 1.0
        gx = int(wx)
        gy = int(wy)
    return h, gx, gy


@kernel
def grid(
    positions: FloatArray, x0: float, y0: float, h: float, gx: int, gy: int
) -> tuple[IntArray, IntArray, IntArray]:
    """Bodies bucketed by grid cell (cells h m wide from (x0, y0) m, gx x gy of them; the
    last row and column take what lies on their far border): (cell of each body,
    cell_start (gx gy + 1,), members: the bodies of cell c, in index order, are
    members[cell_start[c]:cell_start[c + 1]])."""
    n = positions.shape[0]
    cell = np.zeros(n, dtype=np.int64)
    if gx * gy > 1:
        for j in range(n):
            cx = min(int(math.floor((positions[j, 0] - x0) / h)), gx - 1)
            cy = min(int(math.floor((positions[j, 1] - y0) / h)), gy - 1)
            cell[j] = cy * gx + cx
    cell_start = np.zeros(gx * gy + 1, dtype=np.int64)
    for j in range(n):
        cell_start[cell[j] + 1] += 1
    for c in range(gx * gy):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:-1].copy()
    members = np.empty(n, dtype=np.int64)
    for j in range(n):
        members[fill[cell[j]]] = j
        fill[cell[j]] += 1
    return cell, cell_start, members


@kernel
def around(
    c0: int, cell_start: IntArray, members: IntArray, gx: int, gy: int, near: IntArray
) -> int:
    """The bodies of the 3 x 3 cells around cell c0 of a :func:`grid`, in index order (as
    a scan over all bodies would take them), into near[:count]; returns count."""
    cx = c0 % gx
    cy = c0 // gx
    c_n = 0
    for yy in range(max(cy - 1, 0), min(cy + 2, gy)):
        for xx in range(max(cx - 1, 0), min(cx + 2, gx)):
            c = yy * gx + xx
            for i in range(cell_start[c], cell_start[c + 1]):
                near[c_n] = members[i]
                c_n += 1
    # index order (the cells' runs are each in order)
    if c_n <= 64:
        for i in range(1, c_n):
            x = near[i]
            j = i
            while j > 0 and near[j - 1] > x:
                near[j] = near[j - 1]
                j -= 1
            near[j] = x
    else:
        sort_in_place(near, c_n)
    return c_n


@inner_kernel
def _distance_from(
    positions: FloatArray, j: int, me: int, mx: float, my: float, use_hypot: bool
) -> float:
    """Distance (m) from body me at (mx, my) m to body j (inf for j == me: a body is not
    its own neighbour), as ``math.hypot`` (use_hypot) or the square root of the sum of
    squares."""
    if j == me:
        return math.inf
    dx = positions[j, 0] - mx
    dy = positions[j, 1] - my
    if use_hypot:
        return math.hypot(dx, dy)
    return math.sqrt(dx * dx + dy * dy)


@kernel
def in_range_lists(
    bodies: IntArray,
    positions: FloatArray,
    sensing_range: float,
    max_neighbours: int,
    use_hypot: bool,
) -> tuple[IntArray, IntArray]:
    """Per body of ``bodies`` the others within sensing_range (m) of it (the body itself
    counts at distance inf), by distance (a stable sort: ties by index), the first
    max_neighbours (-1: all; >= 0: :func:`nearest_lists`), as CSR arrays (start
    (B + 1,), index (E,)). positions (n >= 1, 2) m.

    Candidates come from a :func:`range_grid` of cells at least sensing_range wide (the
    3 x 3 cells around the body, :func:`around`), so the lists are those of a scan over
    all bodies."""
    b = bodies.shape[0]
    n = positions.shape[0]
    x0, y0, x1, y1 = extent(positions)
    if max_neighbours >= 0:
        return nearest_lists(
            bodies, positions, sensing_range, max_neighbours, use_hypot, x0, y0, x1, y1
        )
    h, gx, gy = range_grid(sensing_range, n, x0, y0, x1, y1)
    cell, cell_start, members = grid(positions, x0, y0, h, gx, gy)
    start = np.zeros(b + 1, dtype=np.int64)
    index = np.empty(16 * b + 16, dtype=np.int64)
    d = np.empty(n)
    cand = np.empty(n, dtype=np.int64)
    near = np.empty(n, dtype=np.int64)
    order = np.empty(n, dtype=np.int64)
    scratch = np.empty(n, dtype=np.int64)
    for k in range(b):
        me = bodies[k]
        mx = positions[me, 0]
        my = positions[me, 1]
        c_n = around(cell[me], cell_start, members, gx, gy, near)
        m = np.int64(0)  # not the literal 0 (see nao_arena.geometry._kernel)
        for i in range(c_n):
            j = near[i]
            dj = _distance_from(positions, j, me, mx, my, use_hypot)
            if dj <= sensing_range:
                d[m] = dj
                cand[m] = j
                m += 1
        stable_order(d, m, order, scratch)
        if start[k] + m > index.shape[0]:
            grown = np.empty(max(2 * index.shape[0], start[k] + m), dtype=np.int64)
            for c in range(start[k]):  # no broadcasting (its checks compile long)
                grown[c] = index[c]
            index = grown
        for i in range(m):
            index[start[k] + i] = cand[order[i]]
        start[k + 1] = start[k] + m
    return start, index[: start[b]].copy()


@inner_kernel
def _typical_kth(bodies: IntArray, positions: FloatArray, sensing_range: float, most: int) -> float:
    """The median over up to 32 of ``bodies`` (evenly spread in their order) of the
    distance (m) to its most-th nearest body within range (the range when fewer are in
    it; 0 when unknown): half of it makes cells that hold a few of a crowd's bodies."""
    b = bodies.shape[0]
    n = positions.shape[0]
    samples = min(b, 32)
    kth = np.empty(samples)
    buf = np.empty(most)
    found = np.int64(0)
    for s in range(samples):
        me = bodies[(s * b) // samples]
        m = 0
        for j in range(n):
            if j == me:
                continue
            dx = positions[j, 0] - positions[me, 0]
            dy = positions[j, 1] - positions[me, 1]
            d = math.sqrt(dx * dx + dy * dy)
            if not d <= sensing_range or (m == most and d >= buf[m - 1]):
                continue
            pos = m if m < most else most - 1
            while pos > 0 and buf[pos - 1] > d:
                buf[pos] = buf[pos - 1]
                pos -= 1
            buf[pos] = d
            if m < most:
                m += 1
        d = buf[most - 1] if m == most else sensing_range
        if math.isfinite(d):
            kth[found] = d
            found += 1
    if found == 0:
        return 0.0
    return median(kth, found)


@inner_kernel
def nearest_lists(
    bodies: IntArray,
    positions: FloatArray,
    sensing_range: float,
    most: int,
    use_hypot: bool,
    x0: float,
    y0: float,
    x1: float,
    y1: float,
) -> tuple[IntArray, IntArray]:
    """:func:`in_range_lists` with a cap (``most`` >= 0; (x0, y0, x1, y1) m: the
    :func:`extent` of positions): the ``most`` nearest within range, by (distance,
    index), found by visiting grid cells in square rings around each body until no cell
    left can hold a nearer one (the k-nearest search RVO2 does with its k-d tree). Cells
    are half as wide as the crowd's typical distance to its most-th neighbour
    (:func:`_typical_kth`; at least as wide as :data:`KNN_CELLS_PER_BODY` cells per body
    over the extent allow), so a dense crowd's nearest 10 come from a few rings, not
    from every body within range."""
    b = bodies.shape[0]
    n = positions.shape[0]
    start = np.zeros(b + 1, dtype=np.int64)
    if most == 0:
        return start, np.zeros(0, dtype=np.int64)
    gx = 1
    gy = 1
    h = 1.0
    span = max(abs(x0), abs(x1), abs(y0), abs(y1))
    if math.isfinite(x1 - x0) and math.isfinite(y1 - y0) and n > 1:
        cells = KNN_CELLS_PER_BODY * n + 16
        h = max(
            1e-9,
            1.01 * math.sqrt((x1 - x0) * (y1 - y0) / cells),
            1.01 * max(x1 - x0, y1 - y0) / cells,
            0.5 * _typical_kth(bodies, positions, sensing_range, most),
        )
        wx = math.floor((x1 - x0) / h) + 1.0
        wy = math.floor((y1 - y0) / h) + 1.0
        while wx * wy > 4 * cells:  # long thin extents: coarser until the cells fit
            h *= 2.0
            wx = math.floor((x1 - x0) / h) + 1.0
            wy = math.floor((y1 - y0) / h) + 1.0
        gx = int(wx)
        gy = int(wy)
    cell, cell_start, members = grid(positions, x0, y0, h, gx, gy)
    # rounding of the cell arithmetic, as a distance (m): bounds are lowered by it
    slack = 1e-9 * (span + h)
    index = np.empty(most * b + 1, dtype=np.int64)
    best_d = np.empty(most + 1)
    best_j = np.empty(most + 1, dtype=np.int64)
    for k in range(b):
        me = bodies[k]
        mx = positions[me, 0]
        my = positions[me, 1]
        cx = cell[me] % gx
        cy = cell[me] // gx
        m = 0
        r = 0
        while True:
            y_lo = cy - r
            y_hi = cy + r
            for yy in range(max(y_lo, 0), min(y_hi, gy - 1) + 1):
                edge = yy == y_lo or yy == y_hi
                xx = cx - r
                while xx <= cx + r:
                    if 0 <= xx < gx:
                        c = yy * gx + xx
                        for i in range(cell_start[c], cell_start[c + 1]):
                            j = members[i]
                            dj = _distance_from(positions, j, me, mx, my, use_hypot)
                            if not dj <= sensing_range:
                                continue
                            if m == most and not (
                                dj < best_d[m - 1] or (dj == best_d[m - 1] and j < best_j[m - 1])
                            ):
                                continue
                            # insert keeping (distance, index) order
                            pos = m if m < most else most - 1
                            while pos > 0 and (
                                best_d[pos - 1] > dj
                                or (best_d[pos - 1] == dj and best_j[pos - 1] > j)
                            ):
                                best_d[pos] = best_d[pos - 1]
                                best_j[pos] = best_j[pos - 1]
                                pos -= 1
                            best_d[pos] = dj
                            best_j[pos] = j
                            if m < most:
                                m += 1
                    # the ring's inner rows only have their two end cells
                    if edge:
                        xx += 1
                    elif xx == cx - r:
                        xx = cx + r
                    else:
                        break
            # every body of the cells beyond ring r is at least r h away
            bound = r * h - slack
            if m == most and best_d[m - 1] < bound:
                break
            if bound > sensing_range:
                break
            if cx - r <= 0 and cy - r <= 0 and cx + r >= gx - 1 and cy + r >= gy - 1:
                break
            r += 1
        for i in range(m):
            index[start[k] + i] = best_j[i]
        start[k + 1] = start[k] + m
    return start, index[: start[b]].copy()
