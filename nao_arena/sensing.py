"""What an agent sees: its own state and its neighbours within sensing range.

All positions, velocities and accelerations are in the world frame (m,
m/s, m/s^2); times in s. Known paths (the true future centres of scripted
traffic) and shared plans (the acceleration a cooperative agent committed
to) are included where the map provides them. :class:`SensingBatch` holds
every robot's view of one step as bulk arrays (batched agents read it
directly; :meth:`SensingBatch.observation` gives one robot's
:class:`Observation`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = [
    "Neighbours",
    "Observation",
    "ReadOnlyRoutes",
    "SensingBatch",
    "neighbour_lists",
    "neighbours_in_range",
    "is_frozen",
    "read_only",
]


def _vec(n: int = 0) -> NDArray[np.float64]:
    return np.zeros((n, 2))


@dataclass(frozen=True)
class Neighbours:
    """The other bodies an agent senses, one row each.

    ids: body indices in the world; kinds: "robot" or "traffic";
    positions, velocities, accelerations: (n, 2); radii: (n,) m.
    known_paths: (n, T, 2) true future centres at ``path_times`` (NaN rows
    where unknown); plans: (n, 2) committed accelerations (NaN where the
    neighbour shares none).
    """

    ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    kinds: tuple[str, ...] = ()
    positions: NDArray[np.float64] = field(default_factory=_vec)
    velocities: NDArray[np.float64] = field(default_factory=_vec)
    accelerations: NDArray[np.float64] = field(default_factory=_vec)
    radii: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    path_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    known_paths: NDArray[np.float64] | None = None
    plans: NDArray[np.float64] | None = None

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(frozen=True)
class Observation:
    """One agent's view at one control step.

    time: simulated time (s); dt: control period (s); robot_id: the robot's index
    (robot order, 0 .. R - 1; its neighbours' ``ids`` are body indices in the
    world); own state in the world frame; goal (2,) m or None; route (M, 2)
    waypoints or None; limits a_max (m/s^2) and v_max (m/s); walls: (W, 2, 2)
    segment end points (m) within range, with their half-thickness
    ``wall_radius`` (W,) m.
    """

    time: float
    dt: float
    robot_id: int
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    radius: float
    a_max: float
    v_max: float
    goal: NDArray[np.float64] | None = None
    route: NDArray[np.float64] | None = None
    neighbours: Neighbours = field(default_factory=Neighbours)
    walls: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2, 2)))
    wall_radius: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    own_path: NDArray[np.float64] | None = None


def neighbours_in_range(
    me: int,
    positions: NDArray[np.float64],
    sensing_range: float,
    max_neighbours: int | None = None,
) -> NDArray[np.int64]:
    """Indices of bodies within ``sensing_range`` (m) of body ``me``, nearest first.

    Ties are broken by index so the order is deterministic.
    """
    rel = positions - positions[me]
    d = np.sqrt(rel[:, 0] * rel[:, 0] + rel[:, 1] * rel[:, 1])
    d[me] = np.inf
    idx = np.flatnonzero(d <= sensing_range)
    idx = idx[np.lexsort((idx, d[idx]))]
    if max_neighbours is not None:
        idx = idx[:max_neighbours]
    return idx.astype(np.int64)


def neighbour_lists(
    bodies: NDArray[np.int64],
    positions: NDArray[np.float64],
    sensing_range: float,
    max_neighbours: int | None = None,
    hypot: bool = False,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """:func:`neighbours_in_range` for every body of ``bodies`` at once (same lists, same order).

    Returns CSR arrays (start (B + 1,), index (E,)): the neighbours of
    bodies[k] are index[start[k]:start[k + 1]], nearest first, ties by index.
    hypot: distances (m) by ``math.hypot`` (the env's observations) instead of
    sqrt(dx^2 + dy^2) (what the agents sense); the two can differ in the last bit.
    """
    bodies = np.ascontiguousarray(bodies, dtype=np.int64)
    b = len(bodies)
    if b == 0 or len(positions) == 0:
        return np.zeros(b + 1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return _neighbour_lists(
        bodies,
        np.ascontiguousarray(positions, dtype=np.float64),
        float(sensing_range),
        -1 if max_neighbours is None else int(max_neighbours),
        bool(hypot),
    )


_MAX_CELLS_PER_BODY = 4  # a finer grid than this many cells per body costs more than it saves
# cells per body of the nearest-k search's grid: fine enough that a dense crowd's cell
# holds a few bodies though the grid spans the whole (mostly empty) extent
_KNN_CELLS_PER_BODY = 16


@njit(cache=True, inline="always")
def _distance_from(positions, j, me, mx, my, use_hypot):
    """Distance (m) from body me at (mx, my) to body j (inf for j == me: a body is not
    its own neighbour), as ``math.hypot`` (use_hypot) or the square root of the sum of
    squares."""
    if j == me:
        return math.inf
    dx = positions[j, 0] - mx
    dy = positions[j, 1] - my
    if use_hypot:
        return math.hypot(dx, dy)
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True)
def _neighbour_lists(bodies, positions, sensing_range, max_neighbours, use_hypot):
    """:func:`neighbour_lists` compiled: per body the others within range (the body
    itself counts at distance inf), by distance (a stable sort: ties by index), the
    first max_neighbours (-1: all).

    Candidates come from a uniform grid of cells at least sensing_range wide (the
    3 x 3 cells around the body), taken in index order, so the lists are those of a
    scan over all bodies; cells are widened so that there are at most about
    _MAX_CELLS_PER_BODY per body; an infinite range is one cell."""
    b = bodies.shape[0]
    n = positions.shape[0]
    # the grid: cell (cx, cy) of body j, bodies bucketed by cell in index order
    x0 = positions[0, 0]
    y0 = positions[0, 1]
    x1 = x0
    y1 = y0
    for j in range(n):
        x0 = min(x0, positions[j, 0])
        x1 = max(x1, positions[j, 0])
        y0 = min(y0, positions[j, 1])
        y1 = max(y1, positions[j, 1])
    gx = 1
    gy = 1
    h = 1.0
    if math.isfinite(sensing_range) and math.isfinite(x1 - x0) and math.isfinite(y1 - y0):
        # a little wider than the range: rounding cannot put a body in range two cells
        # away; wider still where the cells would outnumber the bodies many times
        cells = _MAX_CELLS_PER_BODY * n + 16
        h = max(sensing_range * (1.0 + 1e-9), 1e-9, 1.01 * math.sqrt((x1 - x0) * (y1 - y0) / cells))
        wx = math.floor((x1 - x0) / h) + 1.0
        wy = math.floor((y1 - y0) / h) + 1.0
        while wx * wy > cells:  # long thin extents: coarser until the cells fit
            h *= 2.0
            wx = math.floor((x1 - x0) / h) + 1.0
            wy = math.floor((y1 - y0) / h) + 1.0
        gx = int(wx)
        gy = int(wy)
    if max_neighbours >= 0:
        return _nearest_lists(
            bodies, positions, sensing_range, max_neighbours, use_hypot, x0, y0, x1, y1
        )
    cell, cell_start, members = _grid(positions, x0, y0, h, gx, gy)
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
        cx = cell[me] % gx
        cy = cell[me] // gx
        c_n = 0
        for yy in range(max(cy - 1, 0), min(cy + 2, gy)):
            for xx in range(max(cx - 1, 0), min(cx + 2, gx)):
                c = yy * gx + xx
                for i in range(cell_start[c], cell_start[c + 1]):
                    near[c_n] = members[i]
                    c_n += 1
        # index order, as a scan over all bodies (the cells' runs are each in order)
        if c_n <= 64:
            for i in range(1, c_n):
                x = near[i]
                j = i
                while j > 0 and near[j - 1] > x:
                    near[j] = near[j - 1]
                    j -= 1
                near[j] = x
        else:
            near[:c_n].sort()
        m = np.int64(0)  # not the literal 0 (see nao_arena.geometry._kernel)
        for i in range(c_n):
            j = near[i]
            dj = _distance_from(positions, j, me, mx, my, use_hypot)
            if dj <= sensing_range:
                d[m] = dj
                cand[m] = j
                m += 1
        _stable_order(d, m, order, scratch)
        if 0 <= max_neighbours < m:
            m = max_neighbours
        if start[k] + m > index.shape[0]:
            grown = np.empty(max(2 * index.shape[0], start[k] + m), dtype=np.int64)
            for c in range(start[k]):  # no broadcasting (its checks compile long)
                grown[c] = index[c]
            index = grown
        for i in range(m):
            index[start[k] + i] = cand[order[i]]
        start[k + 1] = start[k] + m
    return start, index[: start[b]].copy()


@njit(cache=True)
def _grid(positions, x0, y0, h, gx, gy):
    """Bodies bucketed by grid cell (cells h m wide from (x0, y0), gx x gy of them; the
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


@njit(cache=True)
def _typical_kth(bodies, positions, sensing_range, most):
    """The median over up to 32 of ``bodies`` (evenly spread in their order) of the
    distance (m) to its most-th nearest body within range (the range when fewer are in
    it; 0 when unknown): half of it makes cells that hold a few of a crowd's bodies."""
    b = bodies.shape[0]
    n = positions.shape[0]
    samples = min(b, 32)
    kth = np.empty(samples)
    buf = np.empty(most)
    found = 0
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
    return float(np.median(kth[:found]))


@njit(cache=True)
def _nearest_lists(bodies, positions, sensing_range, most, use_hypot, x0, y0, x1, y1):
    """:func:`_neighbour_lists` with a cap (``most`` >= 0): the ``most`` nearest within
    range, by (distance, index), found by visiting grid cells in square rings around
    each body until no cell left can hold a nearer one (the k-nearest search RVO2 does
    with its k-d tree). Cells are half as wide as the crowd's typical distance to its
    most-th neighbour (:func:`_typical_kth`; at least as wide as 16 cells per body over
    the extent allow), so a dense crowd's nearest 10 come from a few rings, not from
    every body within range."""
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
        cells = _KNN_CELLS_PER_BODY * n + 16
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
    cell, cell_start, members = _grid(positions, x0, y0, h, gx, gy)
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


@njit(cache=True)
def _stable_order(key, m, order, scratch):
    """order[:m] = the indices 0 .. m - 1 sorted by key (a stable sort: equal keys in
    index order), without allocating: insertion-sorted runs of 16, then merged."""
    run = 16
    for lo in range(0, m, run):
        hi = min(lo + run, m)
        for i in range(lo, hi):
            x = key[i]
            j = i
            while j > lo and key[order[j - 1]] > x:
                order[j] = order[j - 1]
                j -= 1
            order[j] = i
    width = run
    src = order
    dst = scratch
    in_scratch = False
    while width < m:
        for lo in range(0, m, 2 * width):
            mid = min(lo + width, m)
            hi = min(lo + 2 * width, m)
            i = lo
            j = mid
            for k in range(lo, hi):
                # take from the left run unless the right one is strictly smaller
                if i < mid and (j >= hi or key[src[i]] <= key[src[j]]):
                    dst[k] = src[i]
                    i += 1
                else:
                    dst[k] = src[j]
                    j += 1
        src, dst = dst, src
        in_scratch = not in_scratch
        width *= 2
    if in_scratch:
        for i in range(m):  # element by element: no broadcasting (its checks compile long)
            order[i] = scratch[i]


def read_only(array: NDArray) -> NDArray:
    """``array`` itself if no one can write into its memory, else a copy of it that no one
    can: read-only, in memory an immutable ``bytes`` object owns (``setflags(write=True)``
    raises ValueError on it and on every view of it, and no ``.base`` leads to writable
    memory). What agents sense is made of these: they share no writable memory with the
    arena."""
    if is_frozen(array):
        return array
    data = np.ascontiguousarray(array)
    frozen = np.frombuffer(data.tobytes(), dtype=data.dtype).reshape(data.shape)
    return frozen


def is_frozen(array: NDArray) -> bool:
    """Whether ``array`` is read-only and its memory belongs to a ``bytes`` object."""
    if array.flags.writeable:
        return False
    base = array.base
    while isinstance(base, np.ndarray):
        base = base.base
    return isinstance(base, bytes)


class ReadOnlyRoutes(tuple):
    """Routes (M, 2) m (or None) of the robots, each read-only (made by :meth:`of`)."""

    __slots__ = ()

    @classmethod
    def of(cls, routes: Sequence[NDArray[np.float64] | None]) -> ReadOnlyRoutes:
        """``routes`` as read-only views (no copy)."""
        if type(routes) is cls:
            return routes
        return cls(None if r is None else read_only(np.asarray(r)) for r in routes)


_BATCH_ARRAYS = (
    "positions",
    "velocities",
    "accelerations",
    "radii",
    "a_max",
    "v_max",
    "kinds",
    "plans",
    "known_paths",
    "path_times",
    "bodies",
    "goals",
    "walls",
    "wall_radius",
    "nb_start",
    "nb_index",
    "row_bodies",
)
"""The array fields of :class:`SensingBatch` (made read-only)."""


@dataclass(frozen=True)
class SensingBatch:
    """Every robot's view at one control step, as bulk arrays (world frame, m, m/s, m/s^2).

    Body arrays (N bodies): positions, velocities, accelerations (N, 2),
    radii, a_max, v_max (N,), kinds; plans (N, 2) and known_paths (N, T, 2)
    at ``path_times`` (s) as in :class:`Neighbours`. Robot arrays (R robots,
    robot order): bodies (R,) body indices, goals (R, 2), routes. The
    neighbours of robot k are ``nb_index[nb_start[k]:nb_start[k + 1]]``
    (nearest first). ``substeps``: the world's physics substeps per period dt (the
    stopping plans of :mod:`nao_arena.stopping` follow them). :meth:`observation`
    builds the :class:`Observation` a per-robot agent sees; batched agents read the
    arrays directly.

    Rows and bodies: row i of the body arrays is body i, unless ``row_bodies`` is set
    (then row i is what the batch holds of body ``row_bodies[i]``): with sensing noise
    (:func:`nao_arena.imperfection.with_neighbour_noise`) each (robot, neighbour) pair
    has a row of its own, appended after the bodies' rows, and the neighbour lists
    point at those rows. ``bodies``, ``nb_index`` and :meth:`neighbour_ids` are rows;
    :meth:`body_of` gives the bodies, and so do the ``ids`` of :meth:`observation`'s
    neighbours and of :meth:`everyone`.

    The batch is frozen (assigning an attribute raises), and every array it holds
    is read-only in memory no one can write (see :func:`read_only`: an array given
    to the constructor is copied unless it already is), and so is every view of it
    handed out (an observation's position, goal, walls ...): an agent that writes
    into what it senses gets an exception (a fault), whether it writes, calls
    ``setflags(write=True)`` on an array or on its ``.base``, or assigns an
    attribute; it cannot change the arena's state, another agent's senses or the
    episode's record. ``routes`` is a :class:`ReadOnlyRoutes` tuple.
    """

    time: float
    dt: float
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    radii: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]
    kinds: NDArray[np.str_]
    plans: NDArray[np.float64] | None
    known_paths: NDArray[np.float64] | None
    path_times: NDArray[np.float64]
    bodies: NDArray[np.int64]
    goals: NDArray[np.float64]
    routes: Sequence[NDArray[np.float64] | None]
    walls: NDArray[np.float64]
    wall_radius: NDArray[np.float64]
    nb_start: NDArray[np.int64]
    nb_index: NDArray[np.int64]
    substeps: int = 10
    row_bodies: NDArray[np.int64] | None = None
    _everyone: Neighbours | None = None

    def __post_init__(self) -> None:
        fields = self.__dict__
        for name in _BATCH_ARRAYS:
            value = fields[name]
            if value is not None:
                fields[name] = read_only(value)
        fields["routes"] = ReadOnlyRoutes.of(self.routes)

    @classmethod
    def of_observation(cls, obs: Observation) -> SensingBatch:
        """The one-robot batch of ``obs``: body 0 is the robot (robot 0), bodies 1 .. n its
        neighbours in their order (what it does not know of them, a_max and v_max, NaN);
        a goal of None is NaN; the robot senses every neighbour and the walls of ``obs``."""
        nb = obs.neighbours
        n = len(nb)

        def own_first(own: object, rows: object, width: tuple[int, ...]) -> NDArray[np.float64]:
            return np.concatenate(
                [
                    np.asarray(own, dtype=np.float64).reshape((1, *width)),
                    np.asarray(rows, dtype=np.float64).reshape((n, *width)),
                ]
            )

        unknown = np.full(n, np.nan)
        t = nb.known_paths.shape[1:] if nb.known_paths is not None else ()
        return cls(
            time=obs.time,
            dt=obs.dt,
            positions=own_first(obs.position, nb.positions, (2,)),
            velocities=own_first(obs.velocity, nb.velocities, (2,)),
            accelerations=own_first(obs.acceleration, nb.accelerations, (2,)),
            radii=own_first(obs.radius, nb.radii, ()),
            a_max=own_first(obs.a_max, unknown, ()),
            v_max=own_first(obs.v_max, unknown, ()),
            kinds=np.array(("robot", *nb.kinds)),
            plans=None if nb.plans is None else own_first(np.full(2, np.nan), nb.plans, (2,)),
            known_paths=(
                None if nb.known_paths is None else own_first(np.full(t, np.nan), nb.known_paths, t)
            ),
            path_times=np.asarray(nb.path_times, dtype=np.float64),
            bodies=np.zeros(1, dtype=np.int64),
            goals=(
                np.full((1, 2), np.nan)
                if obs.goal is None
                else np.asarray(obs.goal, dtype=np.float64).reshape(1, 2)
            ),
            routes=(obs.route,),
            walls=np.asarray(obs.walls, dtype=np.float64),
            wall_radius=np.asarray(obs.wall_radius, dtype=np.float64),
            nb_start=np.array([0, n], dtype=np.int64),
            nb_index=np.arange(1, n + 1, dtype=np.int64),
        )

    def neighbour_ids(self, k: int) -> NDArray[np.int64]:
        """The rows (body indices, unless ``row_bodies`` is set) of what robot k senses,
        nearest first."""
        return self.nb_index[self.nb_start[k] : self.nb_start[k + 1]]

    def body_of(self, rows: NDArray[np.int64]) -> NDArray[np.int64]:
        """The body index (in the world) of each of ``rows`` (rows of the body arrays)."""
        if self.row_bodies is None:
            return np.asarray(rows, dtype=np.int64)
        return self.row_bodies[rows]

    def everyone(self) -> Neighbours:
        """All rows as one :class:`Neighbours` (row i of the batch; its ``ids``: the
        bodies): predict once, index per robot."""
        everyone = self._everyone
        if everyone is None:
            everyone = Neighbours(
                ids=self.body_of(np.arange(len(self.positions), dtype=np.int64)),
                kinds=tuple(self.kinds),
                positions=self.positions,
                velocities=self.velocities,
                accelerations=self.accelerations,
                radii=self.radii,
                path_times=self.path_times,
                known_paths=self.known_paths,
                plans=self.plans,
            )
            self.__dict__["_everyone"] = everyone
        return everyone

    def observation(self, k: int) -> Observation:
        """Robot k's :class:`Observation` (robot order)."""
        idx = self.neighbour_ids(k)
        body = int(self.bodies[k])
        nb = Neighbours(
            ids=self.body_of(idx),
            kinds=tuple(self.kinds[idx]),
            positions=self.positions[idx],
            velocities=self.velocities[idx],
            accelerations=self.accelerations[idx],
            radii=self.radii[idx],
            path_times=self.path_times,
            known_paths=None if self.known_paths is None else self.known_paths[idx],
            plans=None if self.plans is None else self.plans[idx],
        )
        return Observation(
            time=self.time,
            dt=self.dt,
            robot_id=int(k),
            position=self.positions[body],
            velocity=self.velocities[body],
            acceleration=self.accelerations[body],
            radius=float(self.radii[body]),
            a_max=float(self.a_max[body]),
            v_max=float(self.v_max[body]),
            goal=self.goals[k],
            route=self.routes[k],
            neighbours=nb,
            walls=self.walls,
            wall_radius=self.wall_radius,
        )
