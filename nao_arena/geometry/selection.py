"""Selection: the admissible acceleration nearest a desired one.

An acceleration a (m/s^2, world axes) is *admissible* when it lies in the
limit set (the disc |a| <= a_max) and its
clearance against every obstacle over the horizon is >= ``margin`` (m), i.e.
it lies outside the union of the (grown) NAOs.

Method: if the desired acceleration (projected onto the limit set) is
admissible it is returned as is. Otherwise the NAO union is pictured as the
disks |a - m(t)| <= rho(t) sampled in t (see DESIGN.md); in the largest
ball around the desired acceleration whose disks stay within a cap (what a
doubling of the ball from max(a_max / 16, 4 tol) would find), the nearest point
outside the disks is found exactly (free arcs of the circles) and confirmed by the
exact clearance (a point in a sliver between samples is pushed outwards and
bisected back onto the boundary). Fallback, for very
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

from nao_arena.geometry._kernel.bundles import Obstacles, Paths, SearchSettings, Walls
from nao_arena.geometry._kernel.exact import latest_contact_kernel, piece_sweep
from nao_arena.geometry._kernel.relevance import relevant_obstacles
from nao_arena.geometry._kernel.search import repair_disc, select_disc
from nao_arena.geometry._kernel.segment import relevant_walls
from nao_arena.geometry.clearance import PiecewisePath, path_clearance
from nao_arena.geometry.outcome import Outcome
from nao_arena.motion import SMALLEST_NORMAL, project_onto_disc

__all__ = ["AccelLimits", "Selection", "repair_acceleration", "select_acceleration"]


@dataclass(frozen=True)
class AccelLimits:
    """The set of commandable accelerations (m/s^2, world axes): the disc |a| <= a_max."""

    a_max: float

    def __post_init__(self) -> None:
        if not (self.a_max >= 0 and math.isfinite(self.a_max)):
            raise ValueError(f"a_max: expected a finite non-negative number, got {self.a_max}")

    def contains(self, a: NDArray[np.float64]) -> NDArray[np.bool_]:
        """(K,) mask of accelerations (K, 2) inside the limit set (with 1e-12 slack)."""
        ok: NDArray[np.bool_] = np.einsum("ij,ij->i", a, a) <= self.a_max**2 * (1 + 1e-12) + 1e-300
        return ok

    def project(self, a: ArrayLike) -> NDArray[np.float64]:
        """Nearest point of the limit set to each acceleration ((2,) or (K, 2)):
        :func:`nao_arena.motion.project_onto_disc` (non-finite components taken as 0)."""
        arr = np.asarray(a, dtype=np.float64)
        if arr.shape == (2,):
            # one acceleration (the common call)
            x, y = project_onto_disc(float(arr[0]), float(arr[1]), float(self.a_max))
            return np.array([x, y])
        flat = np.atleast_2d(arr)
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
        return out[0] if arr.ndim == 1 else out


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
    """The obstacles of ``path`` that some acceleration within ``limits`` can reach
    (robot velocity v m/s, speed limit v_max m/s, clearance margin m), against which a
    selection's result is measured and its latest contact searched; ``count``: the
    candidates tested so far. ``obstacles`` and ``walls``: those of ``path`` kept, as
    the compiled tests take them (:class:`~nao_arena.geometry._kernel.bundles.Obstacles`
    with their ``sweep``, :class:`~nao_arena.geometry._kernel.bundles.Walls`)."""

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
        p = self.path
        self.obstacles = Obstacles(p.t, p.c, p.velocity, p.acceleration, p.radius, self.sweep)
        self.walls = Walls(p.walls, p.wall_radius)
        self.v = v
        self.limits = limits
        self.margin = margin
        self.v_max = v_max
        self.count = 0

    def latest_contact(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        """Earliest contact time (s) per candidate; exact for the latest one."""
        out = np.full(len(a), np.inf)
        if self.path.n_obstacles == 0:
            return out
        latest_contact_kernel(
            np.ascontiguousarray(np.broadcast_to(self.v, a.shape)),
            a,
            self.v_max,
            self.obstacles,
            self.walls,
            out,
        )
        return out


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


def _contiguous_paths(path: PiecewisePath) -> Paths:
    """The moving obstacles of ``path`` as the compiled search takes them: contiguous
    :class:`~nao_arena.geometry._kernel.bundles.Paths`."""
    return Paths(
        np.ascontiguousarray(path.t),
        np.ascontiguousarray(path.c),
        np.ascontiguousarray(path.velocity),
        np.ascontiguousarray(path.acceleration),
        np.ascontiguousarray(path.radius),
    )


def _contiguous_walls(path: PiecewisePath) -> Walls:
    """The walls of ``path`` as the compiled search takes them: contiguous
    :class:`~nao_arena.geometry._kernel.bundles.Walls`."""
    return Walls(np.ascontiguousarray(path.walls), np.ascontiguousarray(path.wall_radius))


def _ring_candidates(
    a_d: NDArray[np.float64], radii: NDArray[np.float64], points: int, limits: AccelLimits
) -> NDArray[np.float64]:
    """The fallback rings around a_d (m/s^2), radii innermost first, projected onto the
    limit set: (len(radii) * points, 2)."""
    return limits.project(
        np.concatenate([_ring(a_d, rad, points, 0.5 * i) for i, rad in enumerate(radii)])
    )


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
    # steps 1-3, compiled: the desired acceleration, the disk picture, the rings
    status, x, y, count = select_disc(
        a_d,
        v_arr,
        limits.a_max,
        float(v_max),
        _contiguous_paths(path),
        _contiguous_walls(path),
        float(margin),
        SearchSettings(
            tol,
            radii,
            _unit_rings(rings, ring_points),
            _MAX_DISKS,
            _DISKS_PER_PIECE,
            _DISKS_PER_SECOND,
            _SLIVER_DEPTH * limits.a_max,
        ),
    )
    found = a_d if status == Outcome.DESIRED else np.array([x, y])
    if status != Outcome.INFEASIBLE and not with_clearance:
        return Selection(found, Outcome(status).label, None, math.inf, count)
    if status == Outcome.INFEASIBLE and fallback is not None and not with_clearance:
        return Selection(_projected_fallback(fallback, limits), _INFEASIBLE, None, math.inf, count)
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

    tester.count = count
    if status != Outcome.INFEASIBLE:
        return done(found, Outcome(status).label)

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
    found, x, y, _ = repair_disc(
        prev,
        want,
        limits.a_max,
        _REPAIR_STEPS,
        _REPAIR_UNIT,
        v_arr,
        float(v_max),
        _contiguous_paths(path),
        _contiguous_walls(path),
    )
    return np.array([x, y]) if found else None


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
