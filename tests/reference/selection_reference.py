"""Reference for :func:`nao_arena.geometry.selection.select_acceleration`: its steps 1-3
(the desired acceleration, the disk picture, the rings) run from Python, one candidate
at a time, as they ran before they were compiled into ``select_disc``, for the tests
that check the compiled search against them (tests/test_fast_path.py).

:class:`CandidateTester` is the selection's tester with the Python admissibility tests of
candidates; the disk picture's candidate loop runs compiled
(``try_candidates_disc``) or, with ``compiled=False``, in Python. Accelerations are
m/s^2 in the robot's frame of :mod:`nao_arena.geometry`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry._kernel.bundles import Limits, Obstacles, Paths, Walls
from nao_arena.geometry._kernel.disks import (
    capped_disks,
    nao_disk_samples,
    nao_disks_within,
    radius_order,
)
from nao_arena.geometry._kernel.exact import admissible_kernel
from nao_arena.geometry._kernel.outside import nearest_outside_disks
from nao_arena.geometry._kernel.search import (
    bisect_disc,
    outward_normal,
    slide_disc,
    try_candidates_disc,
)
from nao_arena.geometry.outcome import Outcome
from nao_arena.geometry.selection import (
    _DISKS_PER_PIECE,
    _DISKS_PER_SECOND,
    _MAX_DISKS,
    _SLIVER_DEPTH,
    _ring_candidates,
    _Tester,
)
from reference.kernels_reference import bisect_ref


class CandidateTester(_Tester):
    """The selection's tester with admissibility tests of candidates from Python
    (``count`` counts the candidates tested within the limits)."""

    def ok(self, a: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Admissibility of each acceleration (K, 2)."""
        a = np.ascontiguousarray(np.atleast_2d(a), dtype=np.float64)
        inside = self.limits.contains(a)
        out = np.zeros(len(a), dtype=bool)
        idx = np.flatnonzero(inside)
        if len(idx) == 0:
            return out
        if self.path.n_obstacles == 0:
            out[idx] = True
            return out
        cand = np.ascontiguousarray(a[idx])
        res = np.empty(len(idx), dtype=bool)
        admissible_kernel(
            np.ascontiguousarray(np.broadcast_to(self.v, cand.shape)),
            cand,
            self.v_max,
            self.obstacles,
            self.walls,
            self.margin,
            res,
        )
        self.count += len(idx)
        out[idx] = res
        return out

    def ok1(self, a: NDArray[np.float64]) -> bool:
        """Admissibility of one acceleration (2,)."""
        x, y = float(a[0]), float(a[1])
        if x * x + y * y > self.limits.a_max**2 * (1 + 1e-12) + 1e-300:
            return False
        self.count += 1
        if self.path.n_obstacles == 0:
            return True
        res = np.zeros(1, dtype=bool)
        admissible_kernel(
            np.ascontiguousarray(self.v.reshape(1, 2), dtype=np.float64),
            np.array([[x, y]]),
            self.v_max,
            self.obstacles,
            self.walls,
            self.margin,
            res,
        )
        return bool(res[0])


def bundles(t: _Tester, a_max: float | None = None) -> tuple[Limits, Obstacles, Walls]:
    """The tester's robot (its limits' a_max unless given), obstacles and walls as the
    compiled search takes them (:mod:`nao_arena.geometry._kernel.bundles`)."""
    return (
        Limits(t.limits.a_max if a_max is None else a_max, t.v[0], t.v[1], t.v_max),
        t.obstacles,
        t.walls,
    )


def bisect(
    t: CandidateTester, bad: NDArray[np.float64], good: NDArray[np.float64], tol: float
) -> NDArray[np.float64]:
    """Shrink [bad, good] to a boundary point within tol (compiled); the admissible end."""
    gx, gy, count = bisect_disc(
        np.asarray(bad, dtype=np.float64),
        np.asarray(good, dtype=np.float64),
        tol,
        *bundles(t),
        t.margin,
    )
    t.count += count
    return np.array([gx, gy])


def slide_towards(
    t: CandidateTester, a_d: NDArray[np.float64], best: NDArray[np.float64], tol: float
) -> NDArray[np.float64]:
    """Improve an admissible boundary point towards a_d (compiled)."""
    x, y, count = slide_disc(
        np.asarray(a_d, dtype=np.float64),
        np.asarray(best, dtype=np.float64),
        tol,
        *bundles(t),
        t.margin,
    )
    t.count += count
    return np.array([x, y])


def nearest_by_disks(
    t: CandidateTester,
    a_d: NDArray[np.float64],
    tol: float,
    max_disks: int | None = _MAX_DISKS,
    compiled: bool = True,
) -> NDArray[np.float64] | None:
    """Nearest admissible acceleration found from the disk picture of the NAO, or None.

    In a ball B(a_d, D) only the disks that meet the ball matter, so the nearest point
    outside them at distance <= D is the nearest point outside the whole sampled union.
    Each candidate is confirmed by the exact clearance; one that falls in a sliver
    between samples is pushed outwards along its ray by tol, 2 tol, 4 tol, ...
    """
    p = t.path
    a_max = t.limits.a_max
    reach = max(a_max / 16.0, 4.0 * tol)
    limit = float(np.hypot(*a_d)) + a_max
    if max_disks is None:
        while reach < limit:
            reach *= 2.0
    last = reach
    while last < limit:
        last *= 2.0
    samples = nao_disk_samples(
        t.v,
        Paths(*p.moving_arrays),
        t.walls,
        t.margin,
        _DISKS_PER_PIECE,
        a_d,
        last,
        a_max,
        _DISKS_PER_SECOND,
        _SLIVER_DEPTH * a_max,
    )
    if max_disks is None:
        return try_ball(t, a_d, nao_disks_within(samples, reach), reach, tol, compiled)
    chosen, disks = capped_disks(
        samples, radius_order(samples), 0.5 * reach, max(limit, reach), max_disks
    )
    if chosen < 0.0:
        return None
    return try_ball(t, a_d, disks, chosen, tol, compiled)


def try_ball(
    t: CandidateTester,
    a_d: NDArray[np.float64],
    disks: NDArray[np.float64],
    reach: float,
    tol: float,
    compiled: bool = True,
) -> NDArray[np.float64] | None:
    """The nearest candidate outside ``disks`` within ``reach`` of a_d that is admissible
    (or pushed out of a sliver and bisected back onto the boundary), or None."""
    a_max = t.limits.a_max
    cands = nearest_outside_disks(a_d, disks, a_max, 8, reach)
    if compiled:
        found, x, y, count, _ = try_candidates_disc(
            cands, 0, reach, a_d, tol, *bundles(t, a_max), t.margin, disks
        )
        t.count += count
        return np.array([x, y]) if found else None
    for x, y, dist in cands:
        if dist > reach:
            break
        point = np.array([x, y])
        if t.ok1(point):
            return point
        directions = [(point - a_d) / dist] if dist > 0.0 else []
        normal = np.array(outward_normal(x, y, disks))
        if np.any(normal != 0.0):
            directions.append(normal)
        for u in directions:
            step = tol
            while step < 0.25 * a_max:
                pushed = point + step * u
                if t.ok1(pushed):
                    return bisect_ref(t, point, pushed, tol)
                step *= 2.0
    return None


def search(
    t: CandidateTester,
    a_d: NDArray[np.float64],
    radii: NDArray[np.float64],
    ring_points: int,
    tol: float,
) -> tuple[NDArray[np.float64], str] | None:
    """Steps 1-3 of select_acceleration (what ``select_disc`` does) from Python:
    (acceleration, status) or None when nothing admissible is found."""
    if t.ok1(a_d):
        return a_d, Outcome.DESIRED.label
    # 1. exact nearest point outside the sampled disks of the NAO union
    best = nearest_by_disks(t, a_d, tol)
    if best is not None:
        return best, Outcome.ADJUSTED.label
    # 2. the nearest admissible candidate on rings of growing radius, pulled onto the
    #    boundary and slid along it
    ring_cands = _ring_candidates(a_d, radii, ring_points, t.limits)
    ring_ok = t.ok(ring_cands).reshape(len(radii), ring_points)
    for i in range(len(radii)):
        if np.any(ring_ok[i]):
            cand = ring_cands[i * ring_points : (i + 1) * ring_points]
            good = cand[ring_ok[i]]
            dist = np.hypot(*(good - a_d).T)
            start = bisect(t, a_d, good[int(np.argmin(dist))], tol)
            return slide_towards(t, a_d, start, tol), Outcome.ADJUSTED.label
    # 3. the disk search without its size cap (small pockets)
    best = nearest_by_disks(t, a_d, tol, max_disks=None)
    if best is not None:
        return best, Outcome.ADJUSTED.label
    return None
