"""Selection: the admissible acceleration nearest a desired one.

An acceleration a (m/s^2, world axes) is *admissible* when it lies in the
limit set (the disc |a| <= a_max, optionally intersected with a box) and its
clearance against every obstacle over the horizon is >= ``margin`` (m), i.e.
it lies outside the union of the (grown) NAOs.

Method: if the desired acceleration (projected onto the limit set) is
admissible it is returned as is. Otherwise the NAO union is pictured as the
disks |a - m(t)| <= rho(t) sampled in t (see DESIGN.md); in the largest
ball around the desired acceleration whose disks stay within a cap (what a
doubling of the ball from max(a_max / 16, 4 tol) would find), the nearest point
outside the disks is found exactly (free arcs of the circles) and confirmed by the
exact clearance (a point in a sliver between samples is pushed outwards and
bisected back onto the boundary). Fallbacks, for box limits and very
crowded scenes: rings of candidates nearest-first, the nearest admissible
one bisected onto the boundary and slid along it towards the desired
acceleration. The result is always admissible (checked exactly) and
nearest to the desired acceleration within ``tol`` (m/s^2) plus the depth of
the slivers between sampled disks (1 % of a_max) when the robot cannot reach
v_max within the horizon; with speed
saturation the disks only approximate the NAO, and the result is admissible
but may not be the nearest. When no candidate is admissible, the one that
maximises the time to first contact (then the clearance, i.e. least
penetration), or the caller's ``fallback``, is returned with
``feasible=False``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.geometry._kernel.disks import (
    capped_disks,
    nao_disk_samples,
    nao_disks_within,
    radius_order,
)
from nao_arena.geometry._kernel.exact import admissible_kernel, latest_contact_kernel, piece_sweep
from nao_arena.geometry._kernel.outside import nearest_outside_disks
from nao_arena.geometry._kernel.relevance import relevant_obstacles
from nao_arena.geometry._kernel.search import (
    bisect_disc,
    outward_normal,
    repair_disc,
    select_disc,
    slide_disc,
    try_candidates_disc,
)
from nao_arena.geometry._kernel.segment import relevant_walls
from nao_arena.geometry.clearance import PiecewisePath, path_clearance
from nao_arena.geometry.outcome import Outcome
from nao_arena.motion import SMALLEST_NORMAL, project_onto_disc

__all__ = ["AccelLimits", "Selection", "repair_acceleration", "select_acceleration"]


@dataclass(frozen=True)
class AccelLimits:
    """The set of commandable accelerations (m/s^2, world axes).

    The disc |a| <= a_max, intersected with the box lo <= a <= hi when
    ``box_lo``/``box_hi`` are given (the box must contain the origin).
    """

    a_max: float
    box_lo: tuple[float, float] | None = None
    box_hi: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if not (self.a_max >= 0 and math.isfinite(self.a_max)):
            raise ValueError(f"a_max: expected a finite non-negative number, got {self.a_max}")
        if (self.box_lo is None) != (self.box_hi is None):
            raise ValueError("box_lo and box_hi: give both or neither")
        if self.box_lo is not None:
            lo = np.asarray(self.box_lo, float)
            hi = np.asarray(self.box_hi, float)
            if lo.shape != (2,) or hi.shape != (2,) or np.any(lo > 0) or np.any(hi < 0):
                raise ValueError(
                    f"box: expected (2,) bounds with box_lo <= 0 <= box_hi, got {lo}, {hi}"
                )

    def contains(self, a: NDArray[np.float64]) -> NDArray[np.bool_]:
        """(K,) mask of accelerations (K, 2) inside the limit set (with 1e-12 slack)."""
        ok = np.einsum("ij,ij->i", a, a) <= self.a_max**2 * (1 + 1e-12) + 1e-300
        if self.box_lo is not None:
            ok &= np.all(a >= np.asarray(self.box_lo) - 1e-12, axis=1)
            ok &= np.all(a <= np.asarray(self.box_hi) + 1e-12, axis=1)
        return ok

    def project(self, a: ArrayLike) -> NDArray[np.float64]:
        """Nearest point of the limit set to each acceleration ((2,) or (K, 2)). On the disc:
        :func:`nao_arena.motion.project_onto_disc` (non-finite components taken as 0)."""
        arr = np.asarray(a, dtype=np.float64)
        if self.box_lo is None and arr.shape == (2,):
            # one acceleration on the disc (the common call)
            x, y = project_onto_disc(float(arr[0]), float(arr[1]), float(self.a_max))
            return np.array([x, y])
        flat = np.atleast_2d(arr)
        if self.box_lo is None:
            # project_onto_disc row by row, in numpy (the same bits)
            clean = np.where(np.isfinite(flat), flat, 0.0)
            norm = np.hypot(clean[:, 0], clean[:, 1])
            outside = norm > self.a_max
            # outside the disc the norm exceeds a_max > 0: no division by zero
            scale = np.divide(self.a_max, norm, out=np.ones_like(norm), where=outside)
            tiny = outside & (scale < SMALLEST_NORMAL)
            out = clean * scale[:, None]
            if np.any(tiny):
                # subnormal scales lose digits: normalise first
                out[tiny] = clean[tiny] / norm[tiny, None] * self.a_max
        else:
            out = np.array([self._project_one(p) for p in flat]) if len(flat) else flat.copy()
        return out[0] if arr.ndim == 1 else out

    def _project_one(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        if not np.all(np.isfinite(p)):
            return np.zeros(2)
        if self.box_lo is None:
            n = math.hypot(p[0], p[1])
            return p * (self.a_max / n) if n > self.a_max else p.copy()
        lo = np.asarray(self.box_lo, float)
        hi = np.asarray(self.box_hi, float)
        q = np.clip(p, lo, hi)
        if math.hypot(q[0], q[1]) <= self.a_max:
            return q
        # the nearest point lies on the circle: its projection, or a circle-box corner
        cands = []
        n = math.hypot(p[0], p[1])
        if n > 0:
            cands.append(p * (self.a_max / n))
        for axis in (0, 1):
            for bound in (lo[axis], hi[axis]):
                rest = self.a_max**2 - bound**2
                if rest >= 0:
                    for sgn in (-1.0, 1.0):
                        c = np.empty(2)
                        c[axis] = bound
                        c[1 - axis] = sgn * math.sqrt(rest)
                        cands.append(c)
        cands = [c for c in cands if np.all(c >= lo - 1e-12) and np.all(c <= hi + 1e-12)]
        if not cands:
            return np.zeros(2)
        d = [float(np.hypot(*(c - p))) for c in cands]
        return cands[int(np.argmin(d))]


@dataclass(frozen=True)
class Selection:
    """Result of :func:`select_acceleration`.

    accel: chosen acceleration (2,) m/s^2. status: the :attr:`Outcome.label
    <nao_arena.geometry.outcome.Outcome.label>` "desired" (the desired
    acceleration was admissible), "adjusted" (nearest admissible one) or
    "infeasible" (nothing admissible found: the candidate that postpones
    contact longest). clearance: its exact clearance (m) to the obstacles
    that some acceleration within the limits could reach (inf if none; None
    when not asked for); time_of_first_contact: s, inf when feasible (or not
    asked for).
    evaluations: how many candidates were tested.
    """

    accel: NDArray[np.float64]
    status: str
    clearance: float | None
    time_of_first_contact: float
    evaluations: int

    @property
    def feasible(self) -> bool:
        return self.status != Outcome.INFEASIBLE.label


class _Tester:
    """Admissibility tests of candidate accelerations against a fixed set of obstacles."""

    def __init__(
        self,
        v: NDArray[np.float64],
        path: PiecewisePath,
        limits: AccelLimits,
        margin: float,
        v_max: float,
    ) -> None:
        keep = relevant_obstacles(v, limits.a_max, v_max, *path.moving_arrays, margin)
        walls, wall_r = relevant_walls(
            v,
            limits.a_max,
            v_max,
            path.horizon,
            np.ascontiguousarray(path.walls),
            np.ascontiguousarray(path.wall_radius),
            margin,
        )
        if (
            keep.all()
            and len(walls) == path.n_walls
            and all(a.flags.c_contiguous for a in path.arrays[1:])
        ):
            self.path = path  # already only the relevant obstacles (agents filter first)
        else:
            idx = np.flatnonzero(keep)
            self.path = PiecewisePath(
                path.t,
                np.ascontiguousarray(path.c[idx]),
                np.ascontiguousarray(path.velocity[idx]),
                np.ascontiguousarray(path.acceleration[idx]),
                np.ascontiguousarray(path.radius[idx]),
                walls,
                wall_r,
            )
        self.sweep = piece_sweep(self.path.t, self.path.velocity, self.path.acceleration)
        self.v = v
        self.limits = limits
        self.margin = margin
        self.v_max = v_max
        self.count = 0
        self._one = np.zeros((1, 2))
        self._v1 = np.ascontiguousarray(v.reshape(1, 2), dtype=np.float64)
        self._res1 = np.zeros(1, dtype=bool)

    def ok(self, a: NDArray[np.float64]) -> NDArray[np.bool_]:
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
        p = self.path
        admissible_kernel(
            np.ascontiguousarray(np.broadcast_to(self.v, cand.shape)),
            cand,
            self.v_max,
            *p.arrays,
            self.sweep,
            self.margin,
            res,
        )
        self.count += len(idx)
        out[idx] = res
        return out

    def latest_contact(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        """Earliest contact time (s) per candidate; exact for the latest one."""
        out = np.full(len(a), np.inf)
        if self.path.n_obstacles == 0:
            return out
        p = self.path
        latest_contact_kernel(
            np.ascontiguousarray(np.broadcast_to(self.v, a.shape)),
            a,
            self.v_max,
            *p.arrays,
            self.sweep,
            out,
        )
        return out

    def ok1(self, a: NDArray[np.float64]) -> bool:
        """Admissibility of one acceleration (2,), with little Python overhead."""
        x, y = float(a[0]), float(a[1])
        lim = self.limits
        if x * x + y * y > lim.a_max**2 * (1 + 1e-12) + 1e-300:
            return False
        if (
            lim.box_lo is not None
            and lim.box_hi is not None
            and not (
                lim.box_lo[0] - 1e-12 <= x <= lim.box_hi[0] + 1e-12
                and lim.box_lo[1] - 1e-12 <= y <= lim.box_hi[1] + 1e-12
            )
        ):
            return False
        self.count += 1
        if self.path.n_obstacles == 0:
            return True
        self._one[0, 0] = x
        self._one[0, 1] = y
        p = self.path
        admissible_kernel(
            self._v1, self._one, self.v_max, *p.arrays, self.sweep, self.margin, self._res1
        )
        return bool(self._res1[0])


_UNIT_RINGS: dict[tuple[int, float], NDArray[np.float64]] = {}


def _ring(center: NDArray[np.float64], radius: float, n: int, phase: float) -> NDArray[np.float64]:
    """n points on the circle (center, radius), the first at angle ``phase`` (rad)."""
    unit = _UNIT_RINGS.get((n, phase))
    if unit is None:
        ang = phase + 2.0 * np.pi * np.arange(n) / n
        unit = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        if len(_UNIT_RINGS) < 256:
            _UNIT_RINGS[(n, phase)] = unit
    return center + radius * unit


_RINGS, _RING_POINTS = 8, 16  # the fallback rings of select_acceleration by default
_RING_RADII: dict[tuple[float, int], NDArray[np.float64]] = {}


def _ring_radii(a_max: float, rings: int) -> NDArray[np.float64]:
    """Radii (m/s^2) of the fallback rings, innermost first: 2 a_max / 2^i, i = rings - 1
    .. 0; memoised (robots share a few limits; not to be modified)."""
    radii = _RING_RADII.get((a_max, rings))
    if radii is None:
        span = 2.0 * max(a_max, 1e-12)
        # float64 at run time (numpy's stubs say floating[Any])
        radii = cast("NDArray[np.float64]", span * 0.5 ** np.arange(rings - 1, -1, -1))
        if len(_RING_RADII) < 256:
            _RING_RADII[(a_max, rings)] = radii
    return radii


_RING_SETS: dict[tuple[int, int], NDArray[np.float64]] = {}


def _unit_rings(rings: int, points: int) -> NDArray[np.float64]:
    """(rings, points, 2) unit vectors of the fallback rings (ring i turned by 0.5 i rad)."""
    unit = _RING_SETS.get((rings, points))
    if unit is None:
        unit = np.ascontiguousarray(
            np.stack([_ring(np.zeros(2), 1.0, points, 0.5 * i) for i in range(rings)])
        )
        if len(_RING_SETS) < 64:
            _RING_SETS[(rings, points)] = unit
    return unit


def _ring_candidates(
    a_d: NDArray[np.float64], radii: NDArray[np.float64], points: int, limits: AccelLimits
) -> NDArray[np.float64]:
    """The fallback rings around a_d (m/s^2), radii innermost first, projected onto the
    limit set: (len(radii) * points, 2)."""
    return limits.project(
        np.concatenate([_ring(a_d, rad, points, 0.5 * i) for i, rad in enumerate(radii)])
    )


def _bisect(
    t: _Tester,
    bad: NDArray[np.float64],
    good: NDArray[np.float64],
    tol: float,
    give_up: float = math.inf,
):
    """Shrink [bad, good] to a boundary point within tol; returns the admissible end.
    ``give_up``: stop once bad is that far from where it started (see the kernel's
    ``_bisect_disc``; for box limits)."""
    if t.limits.box_lo is None:
        p = t.path
        gx, gy, count = bisect_disc(
            np.asarray(bad, dtype=np.float64),
            np.asarray(good, dtype=np.float64),
            tol,
            t.limits.a_max,
            t.v,
            t.v_max,
            *p.arrays,
            t.sweep,
            t.margin,
        )
        t.count += count
        return np.array([gx, gy])
    gap = float(np.hypot(*(good - bad)))
    origin = bad
    while gap > tol:
        if float(np.sum((bad - origin) ** 2)) >= give_up * give_up and give_up >= 0.0:
            return good
        mid = 0.5 * (bad + good)
        if t.ok1(mid):
            good = mid
        else:
            bad = mid
        gap *= 0.5
    return good


def select_acceleration(
    desired: ArrayLike,
    v: ArrayLike,
    path: PiecewisePath,
    limits: AccelLimits,
    *,
    margin: float = 0.0,
    v_max: float = np.inf,
    tol: float = 1e-3,
    rings: int = _RINGS,
    ring_points: int = _RING_POINTS,
    with_clearance: bool = True,
    fallback: ArrayLike | None = None,
) -> Selection:
    """Admissible acceleration nearest ``desired`` (m/s^2) for a robot with velocity v (m/s).

    path: the obstacles' predicted paths (robot-relative, see
    :func:`~nao_arena.geometry.clearance.sampled_path`); margin: required
    clearance (m); v_max: the robot's speed limit (m/s), part of its
    predicted path; tol: refinement tolerance (m/s^2); with_clearance:
    also compute the exact clearance of the result and, when infeasible, its
    time of first contact (skipped, and reported as None and inf, when
    False); fallback: when no
    acceleration is admissible, return this one (m/s^2, projected onto the
    limit set) instead of searching for the one that postpones contact
    longest. Never raises on degenerate input and never returns NaN.
    """
    v_arr = np.asarray(v, dtype=np.float64)
    if v_arr.shape != (2,) or not np.all(np.isfinite(v_arr)):
        v_arr = np.zeros(2) if v_arr.shape != (2,) else np.nan_to_num(v_arr)
    d_arr = np.asarray(desired, dtype=np.float64).reshape(-1)[:2]
    if d_arr.shape != (2,):
        d_arr = np.zeros(2)
    a_d = limits.project(d_arr)
    tol = max(float(tol), 1e-9 * max(limits.a_max, 1.0))
    radii = _ring_radii(limits.a_max, rings)
    if limits.box_lo is None:
        # steps 1-3 below, compiled for the limit disc
        status, x, y, count = select_disc(
            a_d,
            v_arr,
            limits.a_max,
            float(v_max),
            np.ascontiguousarray(path.t),
            np.ascontiguousarray(path.c),
            np.ascontiguousarray(path.velocity),
            np.ascontiguousarray(path.acceleration),
            np.ascontiguousarray(path.radius),
            np.ascontiguousarray(path.walls),
            np.ascontiguousarray(path.wall_radius),
            float(margin),
            tol,
            radii,
            _unit_rings(rings, ring_points),
            _MAX_DISKS,
            _DISKS_PER_PIECE,
            _DISKS_PER_SECOND,
            _SLIVER_DEPTH * limits.a_max,
        )
        found = a_d if status == Outcome.DESIRED else np.array([x, y])
        if status != Outcome.INFEASIBLE and not with_clearance:
            return Selection(found, Outcome(status).label, None, math.inf, count)
        if status == Outcome.INFEASIBLE and fallback is not None and not with_clearance:
            return Selection(
                _projected_fallback(fallback, limits), _INFEASIBLE, None, math.inf, count
            )
    tester = _Tester(v_arr, path, limits, float(margin), float(v_max))

    def done(a: NDArray[np.float64], status: str) -> Selection:
        if not with_clearance:
            return Selection(a, status, None, math.inf, tester.count)
        if tester.path.n_obstacles == 0:
            return Selection(a, status, math.inf, math.inf, tester.count)
        res = path_clearance(a, v_arr, tester.path, v_max=v_max)
        clear = float(np.min(res.clearance)) if res.clearance.size else math.inf
        first = float(np.min(res.time_of_first_contact)) if res.clearance.size else math.inf
        return Selection(
            a, status, clear, first if status == _INFEASIBLE else math.inf, tester.count
        )

    if limits.box_lo is None:
        tester.count = count
        if status != Outcome.INFEASIBLE:
            return done(found, Outcome(status).label)
    else:
        boxed = _search_boxed(tester, a_d, radii, ring_points, limits, tol)
        if boxed is not None:
            return done(boxed[0], boxed[1])

    # 4. nothing admissible: the caller's fallback, or postpone contact as long as
    #    possible, then least penetration
    if fallback is not None:
        return done(_projected_fallback(fallback, limits), _INFEASIBLE)
    cand = np.ascontiguousarray(
        np.concatenate(
            [a_d[None], _ring_candidates(a_d, radii, ring_points, limits), np.zeros((1, 2))]
        )
    )
    return done(_latest_contact_search(tester, cand, limits, v_arr, v_max), _INFEASIBLE)


_INFEASIBLE = Outcome.INFEASIBLE.label


def _projected_fallback(fallback: ArrayLike, limits: AccelLimits) -> NDArray[np.float64]:
    """The caller's fallback acceleration (m/s^2; not a 2-vector: zero) on the limit set."""
    fb = np.asarray(fallback, dtype=np.float64).reshape(-1)[:2]
    return limits.project(fb if fb.shape == (2,) else np.zeros(2))


def _search_boxed(
    tester: _Tester,
    a_d: NDArray[np.float64],
    radii: NDArray[np.float64],
    ring_points: int,
    limits: AccelLimits,
    tol: float,
) -> tuple[NDArray[np.float64], str] | None:
    """Steps 1-3 of :func:`select_acceleration` (what :func:`select_disc` does for the
    limit disc) in Python, for box limits: (acceleration, status) or None."""
    if tester.ok1(a_d):
        return a_d, Outcome.DESIRED.label

    # 1. exact nearest point outside the sampled disks of the NAO union, in a small
    #    ball around the desired acceleration, then in the largest within the disk cap
    best = _nearest_by_disks(tester, a_d, tol)
    if best is not None:
        return best, Outcome.ADJUSTED.label

    # 2. speed saturation, very crowded scenes: the nearest admissible candidate on
    #    rings of growing radius (all tested in one call; the innermost ring with an
    #    admissible candidate wins), pulled onto the boundary and slid along it
    ring_cands = _ring_candidates(a_d, radii, ring_points, limits)
    ring_ok = tester.ok(ring_cands).reshape(len(radii), ring_points)
    for i in range(len(radii)):
        if np.any(ring_ok[i]):
            cand = ring_cands[i * ring_points : (i + 1) * ring_points]
            good = cand[ring_ok[i]]
            dist = np.hypot(*(good - a_d).T)
            start = _bisect(tester, a_d, good[int(np.argmin(dist))], tol)
            return _slide_towards(tester, a_d, start, limits, tol), Outcome.ADJUSTED.label

    # 3. before giving up: the disk search without its size cap (small pockets)
    best = _nearest_by_disks(tester, a_d, tol, max_disks=None)
    if best is not None:
        return best, Outcome.ADJUSTED.label
    return None


_REPAIR_STEPS = np.array([0.05, 0.1, 0.2, 0.4])  # ring radii around the previous choice, x a_max
_REPAIR_POINTS = 12
_REPAIR_ANGLES = 2.0 * np.pi * np.arange(_REPAIR_POINTS) / _REPAIR_POINTS
_REPAIR_UNIT = np.stack([np.cos(_REPAIR_ANGLES), np.sin(_REPAIR_ANGLES)], axis=1)


def repair_acceleration(
    previous: ArrayLike,
    desired: ArrayLike,
    v: ArrayLike,
    path: PiecewisePath,
    limits: AccelLimits,
    *,
    v_max: float = np.inf,
) -> NDArray[np.float64] | None:
    """A cheap local fix of an acceleration that has just become inadmissible (m/s^2).

    Tests rings of candidates around ``previous`` (radii 0.05, 0.1, 0.2, 0.4
    a_max, 12 points each, projected onto the limit set) exactly, in one
    compiled call, and returns the admissible one nearest ``desired``; None
    when none is admissible. Unlike :func:`select_acceleration` the result is
    admissible but not the nearest to ``desired`` over the whole limit set: a
    warm start, for re-using a recent avoidance choice between full selections.
    """
    prev = np.asarray(previous, dtype=np.float64).reshape(2)
    want = np.asarray(desired, dtype=np.float64).reshape(2)
    v_arr = np.asarray(v, dtype=np.float64).reshape(2)
    if not all(math.isfinite(x) for x in (*prev, *want, *v_arr)):
        return None
    if limits.box_lo is None:
        # the loop below, compiled
        found, x, y, _ = repair_disc(
            prev,
            want,
            limits.a_max,
            _REPAIR_STEPS,
            _REPAIR_UNIT,
            v_arr,
            float(v_max),
            np.ascontiguousarray(path.t),
            np.ascontiguousarray(path.c),
            np.ascontiguousarray(path.velocity),
            np.ascontiguousarray(path.acceleration),
            np.ascontiguousarray(path.radius),
            np.ascontiguousarray(path.walls),
            np.ascontiguousarray(path.wall_radius),
        )
        return np.array([x, y]) if found else None
    tester = _Tester(v_arr, path, limits, 0.0, float(v_max))
    cand = np.concatenate([prev + limits.a_max * r * _REPAIR_UNIT for r in _REPAIR_STEPS])
    cand = limits.project(cand)
    # nearest the desired acceleration first: the first admissible one wins
    cand = np.ascontiguousarray(
        cand[np.argsort(np.hypot(cand[:, 0] - want[0], cand[:, 1] - want[1]), kind="stable")]
    )
    ok = tester.ok(cand)
    hits = np.flatnonzero(ok)
    return cand[hits[0]].copy() if len(hits) else None


def _slide_towards(
    tester: _Tester,
    a_d: NDArray[np.float64],
    best: NDArray[np.float64],
    limits: AccelLimits,
    tol: float,
) -> NDArray[np.float64]:
    """Improve an admissible boundary point: rotate its ray about a_d by shrinking
    angles and pull each admissible probe back onto the boundary by bisection."""
    if limits.box_lo is None:
        p = tester.path
        x, y, count = slide_disc(
            np.asarray(a_d, dtype=np.float64),
            np.asarray(best, dtype=np.float64),
            tol,
            limits.a_max,
            tester.v,
            tester.v_max,
            *p.arrays,
            tester.sweep,
            tester.margin,
        )
        tester.count += count
        return np.array([x, y])
    dist = float(np.hypot(*(best - a_d)))
    angle = 0.5
    while angle > 1e-3 and dist > tol:
        phi = math.atan2(best[1] - a_d[1], best[0] - a_d[0])
        moved = False
        for sgn in (1.0, -1.0):
            u = np.array([math.cos(phi + sgn * angle), math.sin(phi + sgn * angle)])
            far = limits.project(a_d + 1.5 * dist * u)
            if not tester.ok1(far):
                continue
            p = _bisect(tester, a_d, far, tol, dist - tol)
            d = float(np.hypot(*(p - a_d)))
            if d < dist - tol:
                best, dist, moved = p, d, True
                break
        if not moved:
            angle *= 0.5
    return best


def _latest_contact_search(
    tester: _Tester,
    cand: NDArray[np.float64],
    limits: AccelLimits,
    v: NDArray[np.float64],
    v_max: float,
) -> NDArray[np.float64]:
    """Acceleration with the latest first contact (then the largest clearance): the best
    of ``cand``, improved by a pattern search of shrinking rings around it."""

    def pick(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
        points = np.ascontiguousarray(points)
        first = tester.latest_contact(points)
        latest = float(first.max())
        slack = 0.0 if math.isinf(latest) else 1e-9 * max(1.0, abs(latest))
        top = np.flatnonzero(first >= latest - slack)
        if len(top) > 1 and tester.path.n_obstacles:
            res = path_clearance(points[top], v, tester.path, v_max=v_max)
            clear = np.min(np.atleast_2d(res.clearance), axis=1)
            top = top[[int(np.argmax(clear))]]
        return points[top[0]], latest

    best, best_t = pick(cand)
    step = 0.25 * limits.a_max
    while step > 1e-3 * max(limits.a_max, 1e-12) and not math.isinf(best_t):
        ring = limits.project(_ring(best, step, 12, 0.0))
        point, t_first = pick(np.concatenate([best[None], ring]))
        if t_first > best_t:
            best, best_t = point, t_first
        else:
            step *= 0.5
    return best


_MAX_DISKS = 96
# the disk picture: one disk per piece of the obstacle paths (0.1 s for the agents'
# default grid), at least _DISKS_PER_SECOND per second of a longer piece; finer pictures
# cost more disks than they save in sliver pushes (100-robot swap: 2 per piece, 25 %
# slower, the same outcome)
_DISKS_PER_PIECE = 2
_DISKS_PER_SECOND = 16.0
# consecutive disks of an obstacle are thinned out while the sliver they leave stays below
# this fraction of a_max (late in the horizon the disks are small and close together: the
# 100-robot swap's pictures hold about half the disks, with the same outcome)
_SLIVER_DEPTH = 0.01


def _nearest_by_disks(
    tester: _Tester, a_d: NDArray[np.float64], tol: float, max_disks: int | None = _MAX_DISKS
) -> NDArray[np.float64] | None:
    """Nearest admissible acceleration found from the disk picture of the NAO, or None.

    In a ball B(a_d, D) only the disks that meet the ball matter, so the
    nearest point outside them at distance <= D is the nearest point
    outside the whole sampled union. Each candidate is confirmed by the
    exact clearance; one that falls in a sliver between samples is pushed
    outwards along its ray by tol, 2 tol, 4 tol, ...
    """
    p = tester.path
    a_max = tester.limits.a_max
    reach = max(a_max / 16.0, 4.0 * tol)
    limit = float(np.hypot(*a_d)) + a_max
    if max_disks is None:
        # Without a cap every ball's candidates within its radius are a prefix of the
        # next ball's (nearest first, the same points), and a failed candidate fails
        # again: the doubling would end as the largest ball alone does.
        while reach < limit:
            reach *= 2.0
    # sample once for the largest ball the doubling can reach; each ball keeps its part
    last = reach
    while last < limit:
        last *= 2.0
    samples = nao_disk_samples(
        tester.v,
        *p.arrays,
        tester.margin,
        _DISKS_PER_PIECE,
        a_d,
        last,
        a_max,
        _DISKS_PER_SECOND,
        _SLIVER_DEPTH * a_max,
    )
    if max_disks is None:
        return _try_ball(tester, a_d, nao_disks_within(samples, reach), reach, tol)
    # Ball by ball, every ball's candidates within a smaller ball are that ball's
    # (nearest first, the same points) and fail again, so the largest ball within
    # the disk cap alone decides as a doubling from the smallest would.
    chosen, disks = capped_disks(
        samples, radius_order(samples), 0.5 * reach, max(limit, reach), max_disks
    )
    if chosen < 0.0:
        return None
    return _try_ball(tester, a_d, disks, chosen, tol)


def _try_ball(
    tester: _Tester,
    a_d: NDArray[np.float64],
    disks: NDArray[np.float64],
    reach: float,
    tol: float,
) -> NDArray[np.float64] | None:
    """The nearest candidate outside ``disks`` within ``reach`` of a_d that is admissible
    (or pushed out of a sliver and bisected back onto the boundary), or None."""
    p = tester.path
    a_max = tester.limits.a_max
    # the nearest 8 candidates, tried in order
    cands = nearest_outside_disks(a_d, disks, a_max, 8, reach)
    if tester.limits.box_lo is None:
        # the loop below, compiled
        found, x, y, count, _ = try_candidates_disc(
            cands,
            0,
            reach,
            a_d,
            tol,
            a_max,
            tester.v,
            tester.v_max,
            *p.arrays,
            tester.sweep,
            tester.margin,
            disks,
        )
        tester.count += count
        return np.array([x, y]) if found else None
    for x, y, dist in cands:
        if dist > reach:
            break
        point = np.array([x, y])
        if tester.ok1(point):
            return point
        directions = [(point - a_d) / dist] if dist > 0.0 else []
        normal = np.array(outward_normal(x, y, disks))
        if np.any(normal != 0.0):
            directions.append(normal)
        for u in directions:
            step = tol
            while step < 0.25 * a_max:
                pushed = point + step * u
                if tester.ok1(pushed):
                    return _bisect(tester, point, pushed, tol)
                step *= 2.0
    return None
