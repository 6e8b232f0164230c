"""Candidates within the limit disc |a| <= a_max (m/s^2), tried nearest the desired
acceleration a_d first: the disk picture's candidates (pushed out of slivers when
inadmissible), the ball search that tries the nearest points outside the disks as each
becomes final, and rings of candidates around a_d.

The robot, obstacles, walls and scratch arrays travel in the bundles of :mod:`.bundles`
(:class:`~.bundles.Limits`, :class:`~.bundles.Obstacles`, :class:`~.bundles.Walls`,
:class:`~.bundles.Scratch`).
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry._kernel.boundary import (
    _sliver_push,
    bisect_disc,
    ok_disc,
    outward_normal,
    slide_disc,
)
from nao_arena.geometry._kernel.bundles import OutsideSearch, Scratch
from nao_arena.geometry._kernel.outside import _WORDS, outside_advance, outside_setup
from nao_arena.geometry.borrow import borrowed, borrowed_fields
from nao_arena.jit import inner_kernel
from nao_arena.motion import onto_disc


@inner_kernel(error_model="numpy")
def try_candidates_disc(cands, start, reach, a_d, tol, limits, obstacles, walls, margin, disks):
    """Confirm disk-picture candidates exactly, nearest first (limit disc |a| <= a_max).

    cands: (K, 3) rows (x, y, distance from a_d) m/s^2 in increasing distance, tried
    from row ``start`` while the distance is <= reach: a candidate that is admissible
    is the answer; one that is not (it lies in a sliver between sampled disks) is
    pushed outwards along its ray from a_d by tol, 2 tol, 4 tol, ... below a_max / 4,
    then, if none of those is admissible, away from the ``disks`` (M, 3) whose circles
    pass through it (a notch between two disks opens that way); the first admissible
    push is bisected back onto the boundary within tol.
    Returns (found, x, y, candidates tested, stopped at a row beyond reach) —
    :func:`selection._nearest_by_disks`'s candidate loop compiled.
    """
    return _try_candidates(
        cands,
        start,
        reach,
        a_d,
        tol,
        limits,
        obstacles,
        walls,
        margin,
        disks,
        Scratch(np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64)),
    )


@inner_kernel(error_model="numpy")
def _try_candidates(
    cands, start, reach, a_d, tol, limits, obstacles, walls, margin, disks, scratch
):
    """:func:`try_candidates_disc` with its scratch arrays given (the arrays borrowed
    here)."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    scratch = borrowed_fields(scratch)
    cands, a_d, disks = borrowed(cands), borrowed(a_d), borrowed(disks)
    count = 0
    for i in range(start, cands.shape[0]):
        dist = cands[i, 2]
        if dist > reach:
            return False, 0.0, 0.0, count, True
        found, gx, gy, c = _try_candidate(
            cands[i, 0],
            cands[i, 1],
            dist,
            a_d,
            tol,
            limits,
            obstacles,
            walls,
            margin,
            disks,
            scratch,
        )
        count += c
        if found:
            return True, gx, gy, count, False
    return False, 0.0, 0.0, count, False


@inner_kernel(error_model="numpy")
def _try_candidate(x, y, dist, a_d, tol, limits, obstacles, walls, margin, disks, scratch):
    """One candidate (x, y) m/s^2 at ``dist`` from a_d of :func:`try_candidates_disc`: it,
    or its pushes out of a sliver, if admissible. Returns (found, x, y, candidates
    tested)."""
    count = 0
    ok, c = ok_disc(x, y, limits, obstacles, walls, margin, scratch)
    count += c
    if ok:
        return True, x, y, count
    if dist > 0.0:
        found, gx, gy, c = _sliver_push(
            x,
            y,
            (x - a_d[0]) / dist,
            (y - a_d[1]) / dist,
            tol,
            limits,
            obstacles,
            walls,
            margin,
            scratch,
        )
        count += c
        if found:
            return True, gx, gy, count
    ux, uy = outward_normal(x, y, disks)
    if ux != 0.0 or uy != 0.0:
        found, gx, gy, c = _sliver_push(
            x, y, ux, uy, tol, limits, obstacles, walls, margin, scratch
        )
        count += c
        if found:
            return True, gx, gy, count
    return False, 0.0, 0.0, count


@inner_kernel(error_model="numpy")
def ring_search_disc(a_d, radii, unit, tol, limits, obstacles, walls, margin):
    """The ring fallback of :func:`selection.select_acceleration` compiled for the limit
    disc: rings a_d + radii[i] * unit[i] (m/s^2, projected onto |a| <= a_max), innermost
    first; the admissible candidate of the first ring that has one, nearest a_d, is
    bisected back towards a_d onto the boundary within tol and slid along it
    (:func:`bisect_disc`, :func:`slide_disc`). Returns (found, x, y, candidates tested)."""
    return _ring_search(
        a_d,
        radii,
        unit,
        tol,
        limits,
        obstacles,
        walls,
        margin,
        Scratch(np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64)),
        np.empty((unit.shape[1], 2)),
    )


@inner_kernel(error_model="numpy")
def _ring_search(a_d, radii, unit, tol, limits, obstacles, walls, margin, scratch, cand):
    """:func:`ring_search_disc` with its scratch arrays given (the arrays borrowed
    here)."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    scratch = borrowed_fields(scratch)
    a_d, radii, unit = borrowed(a_d), borrowed(radii), borrowed(unit)
    cand = borrowed(cand)
    a_max = limits.a_max
    P = unit.shape[1]
    count = 0
    for i in range(radii.shape[0]):
        best = -1
        best_d = math.inf
        for k in range(P):
            x, y = onto_disc(
                a_d[0] + radii[i] * unit[i, k, 0], a_d[1] + radii[i] * unit[i, k, 1], a_max
            )
            cand[k, 0] = x
            cand[k, 1] = y
            d = math.hypot(x - a_d[0], y - a_d[1])
            if d >= best_d:
                continue  # cannot become the nearest admissible one of this ring
            ok, c = ok_disc(x, y, limits, obstacles, walls, margin, scratch)
            count += c
            if ok:
                best = k
                best_d = d
        if best >= 0:
            gx, gy, c = bisect_disc(a_d, cand[best], tol, limits, obstacles, walls, margin)
            count += c
            start = np.empty(2)
            start[0] = gx
            start[1] = gy
            x, y, c = slide_disc(a_d, start, tol, limits, obstacles, walls, margin)
            return True, x, y, count + c
    return False, 0.0, 0.0, count


@inner_kernel(error_model="numpy")
def _try_ball_disc(a_d, disks, reach, tol, limits, obstacles, walls, margin, covered):
    """:func:`selection._try_ball` for the limit disc: (found, x, y, candidates tested,
    whether the disks cover the whole ball). ``covered``: see
    :func:`nearest_outside_disks`."""
    M = disks.shape[0]
    out = np.full((8, 3), math.inf)
    lower = np.empty(M + 1)
    order, scale = outside_setup(a_d, disks, limits.a_max, reach, out, lower)
    return _ball_search(
        a_d,
        disks,
        reach,
        tol,
        limits,
        obstacles,
        walls,
        margin,
        covered,
        OutsideSearch(
            out,
            lower,
            order,
            scale,
            np.empty((2 * M + 8, 2)),
            np.empty(2 * M + 4),
            np.empty(2 * M + 4),
            np.empty(_WORDS, dtype=np.uint64),
        ),
        Scratch(np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64)),
    )


@inner_kernel(error_model="numpy")
def _ball_search(
    a_d, disks, reach, tol, limits, obstacles, walls, margin, covered, search, scratch
):
    """:func:`_try_ball_disc` after :func:`outside_setup`, with its scratch arrays given
    (the arrays borrowed here)."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    scratch = borrowed_fields(scratch)
    a_d, disks = borrowed(a_d), borrowed(disks)
    out, lower, order, scale, cand, starts, ends, cover = search
    out, lower, order, cand = borrowed(out), borrowed(lower), borrowed(order), borrowed(cand)
    starts, ends, cover = borrowed(starts), borrowed(ends), borrowed(cover)
    search = OutsideSearch(out, lower, order, scale, cand, starts, ends, cover)
    a_max = limits.a_max
    # nearest_outside_disks(a_d, disks, a_max, 8, reach, covered) tried with
    # try_candidates_disc, each candidate as soon as it is final: the circles farther
    # than the admissible one are never visited (same candidates, same order)
    count = 0
    oi = np.int64(0)  # not the literal 0 (see nao_arena.geometry._kernel)
    for row in range(8):
        oi = outside_advance(a_d, disks, a_max, covered, search, oi, row)
        dist = out[row, 2]
        if not (dist <= reach and dist < math.inf):
            return False, 0.0, 0.0, count, row == 0
        found, x, y, c = _try_candidate(
            out[row, 0],
            out[row, 1],
            dist,
            a_d,
            tol,
            limits,
            obstacles,
            walls,
            margin,
            disks,
            scratch,
        )
        count += c
        if found:
            return True, x, y, count, False
    return False, 0.0, 0.0, count, False
