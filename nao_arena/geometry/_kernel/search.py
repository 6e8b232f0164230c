"""The search for an admissible acceleration within the limit disc |a| <= a_max
(m/s^2): the whole selection (:func:`select_disc`: the desired acceleration, the disk
search in a capped ball, the rings, the disk search without a cap) and the repair of a
previous command (:func:`repair_disc`), each also for obstacles already found relevant
(:func:`select_relevant`, :func:`repair_relevant`). Their steps live in
:mod:`.boundary` (the admissibility test, bisection, sliding) and :mod:`.candidates`
(the disk picture's candidates, the ball search, the rings). Their arguments travel in
the bundles of :mod:`.bundles`: the obstacles as :class:`~.bundles.Paths` (the entry
points, which keep the relevant ones) or :class:`~.bundles.Obstacles` (with their
sweeps), the walls as :class:`~.bundles.Walls`, the search's parameters as
:class:`~.bundles.SearchSettings`.
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry._kernel.boundary import bisect_disc as bisect_disc

# the imports ``as`` themselves are re-exports: callers import these steps from here too
from nao_arena.geometry._kernel.boundary import ok_disc
from nao_arena.geometry._kernel.boundary import outward_normal as outward_normal
from nao_arena.geometry._kernel.boundary import slide_disc as slide_disc
from nao_arena.geometry._kernel.bundles import Limits, Obstacles, Paths, Scratch, Walls
from nao_arena.geometry._kernel.candidates import _try_ball_disc, ring_search_disc
from nao_arena.geometry._kernel.candidates import try_candidates_disc as try_candidates_disc
from nao_arena.geometry._kernel.disks import (
    capped_disks,
    disks_within,
    nao_disk_samples,
    radius_order,
)
from nao_arena.geometry._kernel.relevance import relevant_subset
from nao_arena.geometry._kernel.segment import relevant_walls
from nao_arena.geometry.borrow import borrowed, borrowed_fields
from nao_arena.geometry.outcome import Outcome
from nao_arena.jit import inner_kernel, kernel
from nao_arena.motion import onto_disc
from nao_arena.sorting import stable_argsort


@kernel(error_model="numpy")
def repair_disc(prev, want, a_max, steps, unit, v, v_max, paths, walls):
    """:func:`selection.repair_acceleration` compiled for the limit disc: the candidates
    prev + a_max * steps[i] * unit[k] (m/s^2), projected onto |a| <= a_max, tested
    nearest ``want`` first (a stable order) against the relevant obstacles (margin 0) of
    the :class:`~.bundles.Paths` and :class:`~.bundles.Walls` (robot velocity v (2,) m/s,
    speed limit v_max m/s); returns (found, x, y, candidates tested)."""
    seg_t = paths.seg_t
    seg_c, seg_w, seg_b, radius, sweep = relevant_subset(
        v, a_max, v_max, seg_t, paths.seg_c, paths.seg_w, paths.seg_b, paths.radius, 0.0
    )
    ends, wall_r = relevant_walls(v, a_max, v_max, seg_t[-1], walls.ends, walls.radius, 0.0)
    return repair_relevant(
        prev,
        want,
        a_max,
        steps,
        unit,
        v,
        v_max,
        Obstacles(seg_t, seg_c, seg_w, seg_b, radius, sweep),
        Walls(ends, wall_r),
    )


@inner_kernel(error_model="numpy")
def repair_relevant(prev, want, a_max, steps, unit, v, v_max, obstacles, walls):
    """:func:`repair_disc` for obstacles that are all relevant (as :func:`relevant_subset`
    keeps them, margin 0): the :class:`~.bundles.Obstacles`, with their
    :func:`piece_sweep`, and the :class:`~.bundles.Walls` (their arrays borrowed here)."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    K = steps.shape[0] * unit.shape[0]
    cand = np.empty((K, 2))
    dist = np.empty(K)
    k = 0
    for i in range(steps.shape[0]):
        s = a_max * steps[i]
        for u in range(unit.shape[0]):
            cand[k, 0], cand[k, 1] = onto_disc(
                prev[0] + s * unit[u, 0], prev[1] + s * unit[u, 1], a_max
            )
            dist[k] = math.hypot(cand[k, 0] - want[0], cand[k, 1] - want[1])
            k += 1
    order = stable_argsort(dist)
    return _first_admissible(
        cand,
        order,
        Limits(a_max, v[0], v[1], v_max),
        obstacles,
        walls,
        0.0,
        Scratch(np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64)),
    )


@inner_kernel(error_model="numpy")
def _first_admissible(cand, order, limits, obstacles, walls, margin, scratch):
    """The first admissible row of ``cand`` (K, 2) m/s^2 in ``order``: (found, x, y,
    candidates tested); scratch arrays given (the arrays borrowed here)."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    scratch = borrowed_fields(scratch)
    cand, order = borrowed(cand), borrowed(order)
    count = 0
    for o in range(order.shape[0]):
        k = order[o]
        ok, c = ok_disc(cand[k, 0], cand[k, 1], limits, obstacles, walls, margin, scratch)
        count += c
        if ok:
            return True, cand[k, 0], cand[k, 1], count
    return False, 0.0, 0.0, count


@kernel(error_model="numpy")
def select_disc(a_d, v, a_max, v_max, paths, walls, margin, settings):
    """The search of :func:`selection.select_acceleration` for the limit disc, compiled:
    a_d (2,) m/s^2 (the desired acceleration, inside the disc |a| <= a_max) if admissible
    (robot velocity v (2,) m/s, speed limit v_max m/s, clearance margin m, against the
    :class:`~.bundles.Paths` and :class:`~.bundles.Walls` relevant for that margin), else
    the disk search in the largest ball (radius max(a_max / 16, 4 tol) doubled) within
    ``max_disks`` disks, the rings, and the disk search without a cap (tol, max_disks and
    the rings: the :class:`~.bundles.SearchSettings`). Returns (status, x, y, candidates
    tested): status the :class:`~nao_arena.geometry.outcome.Outcome` DESIRED, ADJUSTED
    or INFEASIBLE (nothing admissible found: the caller falls back)."""
    seg_t = paths.seg_t
    c, w, b, r, sweep = relevant_subset(
        v, a_max, v_max, seg_t, paths.seg_c, paths.seg_w, paths.seg_b, paths.radius, margin
    )
    ends, wall_r = relevant_walls(v, a_max, v_max, seg_t[-1], walls.ends, walls.radius, margin)
    return select_relevant(
        a_d,
        v,
        a_max,
        v_max,
        Obstacles(seg_t, c, w, b, r, sweep),
        Walls(ends, wall_r),
        margin,
        settings,
    )


@inner_kernel(error_model="numpy")
def select_relevant(a_d, v, a_max, v_max, obstacles, walls, margin, settings):
    """:func:`select_disc` for obstacles that are all relevant (as :func:`relevant_subset`
    keeps them for this margin): the :class:`~.bundles.Obstacles`, with their
    :func:`piece_sweep`, and the :class:`~.bundles.Walls` (their arrays, and the
    settings', borrowed here)."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    tol, ring_radii, unit_rings, max_disks, n_sub, per_second, thin = settings
    ring_radii, unit_rings = borrowed(ring_radii), borrowed(unit_rings)
    seg_t, c, w, b, r, _ = obstacles
    buf = np.empty(3)
    res = np.empty(3)
    hint = np.full(2, -1, dtype=np.int64)
    limits = Limits(a_max, v[0], v[1], v_max)
    ok, count = ok_disc(a_d[0], a_d[1], limits, obstacles, walls, margin, Scratch(buf, res, hint))
    if ok:
        return Outcome.DESIRED, a_d[0], a_d[1], count
    reach = max(a_max / 16.0, 4.0 * tol)
    limit = math.hypot(a_d[0], a_d[1]) + a_max
    last = reach
    while last < limit:
        last *= 2.0
    samples = nao_disk_samples(
        v, Paths(seg_t, c, w, b, r), walls, margin, n_sub, a_d, last, a_max, per_second, thin
    )
    order = radius_order(samples)
    # 1. the disk search in the largest ball, doubled from ``reach``, within the cap
    covered = 0.0  # the disks are known to cover the ball of this radius around a_d
    chosen, disks = capped_disks(samples, order, 0.5 * reach, max(limit, reach), max_disks)
    if chosen >= 0.0:
        found, x, y, k, empty = _try_ball_disc(
            a_d, disks, chosen, tol, limits, obstacles, walls, margin, 0.0
        )
        count += k
        if found:
            return Outcome.ADJUSTED, x, y, count
        if empty:
            covered = chosen
    # 2. rings of candidates
    found, x, y, k = ring_search_disc(
        a_d, ring_radii, unit_rings, tol, limits, obstacles, walls, margin
    )
    count += k
    if found:
        return Outcome.ADJUSTED, x, y, count
    # 3. the disk search without a cap, in the largest ball
    found, x, y, k, _ = _try_ball_disc(
        a_d,
        disks_within(samples, order, last),
        last,
        tol,
        limits,
        obstacles,
        walls,
        margin,
        covered,
    )
    count += k
    if found:
        return Outcome.ADJUSTED, x, y, count
    return Outcome.INFEASIBLE, 0.0, 0.0, count
