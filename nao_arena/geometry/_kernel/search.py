"""The search for an admissible acceleration within the limit disc |a| <= a_max:
exact admissibility tests with hints, bisection onto the NAO boundary, the
disk-picture candidates, rings of candidates, sliding along the boundary,
repair of a previous command and the whole selection (:func:`select_disc`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nao_arena.geometry._kernel.disks import (
    capped_disks,
    disks_within,
    nao_disk_samples,
    radius_order,
)
from nao_arena.geometry._kernel.exact import candidate_setup, piece_within, scan_obstacle
from nao_arena.geometry._kernel.outside import _WORDS, outside_advance, outside_setup
from nao_arena.geometry._kernel.relevance import relevant_subset
from nao_arena.geometry._kernel.segment import relevant_walls, wall_violation
from nao_arena.geometry.borrow import borrowed
from nao_arena.geometry.outcome import Outcome
from nao_arena.motion import onto_disc


# inlined into the searches: a call would count references to its eleven arrays, once
# per candidate (see nao_arena.geometry.borrow)
@njit(cache=True, error_model="numpy", inline="always")
def ok_disc(
    x,
    y,
    a_max,
    vx,
    vy,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    buf,
    res,
    hint,
):
    """Admissibility of the acceleration (x, y) m/s^2 within the limit disc |a| <= a_max:
    returns (admissible, 1 if it was tested against the obstacles (inside the disc)).
    Obstacles: the N moving ones (seg_*, radius), then the W walls (walls, wall_r; see
    :func:`~nao_arena.geometry._kernel.segment.wall_violation`).

    hint: (obstacle, piece) that last rejected a candidate (-1: none; obstacle N + w:
    wall w). That piece (or wall) is tested first, then that obstacle, then the others (a
    rejection anywhere is the same answer, so the order does not change it); updated on a
    rejection.
    """
    if x * x + y * y > a_max * a_max * (1 + 1e-12) + 1e-300:
        return False, 0
    N = seg_c.shape[0]
    W = walls.shape[0]
    if N == 0 and W == 0:
        return True, 1
    cvx, cvy, tau, bound = candidate_setup(vx, vy, x, y, v_max, seg_t[-1])
    if W and N <= hint[0] < N + W:
        if (
            wall_violation(
                cvx, cvy, x, y, tau, bound, seg_t[-1], walls, wall_r, margin, hint[0] - N, buf, res
            )
            >= 0
        ):
            return False, 1
    first = hint[0] if 0 <= hint[0] < N else 0
    if N and first == hint[0] and 0 <= hint[1] < seg_c.shape[1]:
        reach = radius[first] + margin
        if piece_within(
            cvx, cvy, x, y, tau, seg_t, seg_c, seg_w, seg_b, first, hint[1], reach * reach, buf
        ):
            return False, 1
    for i in range(N):
        n = first if i == 0 else (i - 1 if i <= first else i)
        j = scan_obstacle(
            cvx,
            cvy,
            x,
            y,
            tau,
            bound,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            sweep,
            n,
            radius[n],
            margin,
            False,
            buf,
            res,
        )
        if res[0] < (radius[n] + margin) ** 2:
            hint[0] = n
            hint[1] = j
            return False, 1
    if W:
        w = wall_violation(
            cvx, cvy, x, y, tau, bound, seg_t[-1], walls, wall_r, margin, np.int64(-1), buf, res
        )
        if w >= 0:
            hint[0] = N + w
            hint[1] = -1
            return False, 1
    return True, 1


@njit(cache=True, error_model="numpy")
def _bisect_disc(
    bx,
    by,
    gx,
    gy,
    tol,
    a_max,
    vx,
    vy,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    buf,
    res,
    hint,
    give_up,
):
    """Shrink [b, g] (g admissible) onto the boundary within tol: (gx, gy, tests). When
    b starts at the origin of the caller's distances (the slide's a_d), ``give_up``
    stops the search as soon as b is that far from its start: every point left on the
    segment is farther (the caller then discards the result)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    walls, wall_r = borrowed(walls), borrowed(wall_r)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    gap = math.hypot(gx - bx, gy - by)
    ox = bx
    oy = by
    count = 0
    while gap > tol:
        if (bx - ox) ** 2 + (by - oy) ** 2 >= give_up * give_up and give_up >= 0.0:
            return gx, gy, count
        mx = 0.5 * (bx + gx)
        my = 0.5 * (by + gy)
        ok, c = ok_disc(
            mx,
            my,
            a_max,
            vx,
            vy,
            v_max,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            radius,
            walls,
            wall_r,
            sweep,
            margin,
            buf,
            res,
            hint,
        )
        count += c
        if ok:
            gx = mx
            gy = my
        else:
            bx = mx
            by = my
        gap *= 0.5
    return gx, gy, count


@njit(cache=True, error_model="numpy")
def bisect_disc(
    bad,
    good,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
):
    """Shrink the segment [bad, good] (m/s^2; good admissible) onto the NAO boundary
    within tol (m/s^2), with the limit disc |a| <= a_max. Returns (the admissible end
    x, y, how many candidates were tested) — :func:`selection._bisect` compiled."""
    buf = np.empty(3)
    res = np.empty(3)
    hint = np.full(2, -1, dtype=np.int64)
    return _bisect_disc(
        bad[0],
        bad[1],
        good[0],
        good[1],
        tol,
        a_max,
        v[0],
        v[1],
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
        margin,
        buf,
        res,
        hint,
        math.inf,
    )


@njit(cache=True, error_model="numpy")
def _sliver_push(
    x,
    y,
    ux,
    uy,
    tol,
    a_max,
    vx,
    vy,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    buf,
    res,
    hint,
):
    """Push the inadmissible point (x, y) along the unit direction (ux, uy) by tol, 2 tol,
    4 tol, ... below a_max / 4; the first admissible push is bisected back onto the
    boundary within tol. Returns (found, x, y, candidates tested)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    walls, wall_r = borrowed(walls), borrowed(wall_r)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    count = 0
    step = tol
    while step < 0.25 * a_max:
        px = x + step * ux
        py = y + step * uy
        ok, c = ok_disc(
            px,
            py,
            a_max,
            vx,
            vy,
            v_max,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            radius,
            walls,
            wall_r,
            sweep,
            margin,
            buf,
            res,
            hint,
        )
        count += c
        if ok:
            hint[0] = -1
            hint[1] = -1
            gx, gy, c = _bisect_disc(
                x,
                y,
                px,
                py,
                tol,
                a_max,
                vx,
                vy,
                v_max,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                radius,
                walls,
                wall_r,
                sweep,
                margin,
                buf,
                res,
                hint,
                math.inf,
            )
            return True, gx, gy, count + c
        step *= 2.0
    return False, 0.0, 0.0, count


@njit(cache=True, error_model="numpy")
def outward_normal(x, y, disks):
    """Unit direction away from the disks whose circles pass through (x, y) (m/s^2): the
    mean of their outward normals; (0, 0) when none or they cancel."""
    nx = 0.0
    ny = 0.0
    for i in range(disks.shape[0]):
        dx = x - disks[i, 0]
        dy = y - disks[i, 1]
        d = math.sqrt(dx * dx + dy * dy)
        if d > 0.0 and abs(d - disks[i, 2]) <= 1e-9 * (disks[i, 2] + 1.0):
            nx += dx / d
            ny += dy / d
    norm = math.sqrt(nx * nx + ny * ny)
    if norm < 1e-6:
        return 0.0, 0.0
    return nx / norm, ny / norm


@njit(cache=True, error_model="numpy")
def try_candidates_disc(
    cands,
    start,
    reach,
    a_d,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    disks,
):
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
        a_max,
        v,
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
        margin,
        disks,
        np.empty(3),
        np.empty(3),
        np.full(2, -1, dtype=np.int64),
    )


@njit(cache=True, error_model="numpy")
def _try_candidates(
    cands,
    start,
    reach,
    a_d,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    disks,
    buf,
    res,
    hint,
):
    """:func:`try_candidates_disc` with its scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    walls, wall_r = borrowed(walls), borrowed(wall_r)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    cands, a_d, v, disks = borrowed(cands), borrowed(a_d), borrowed(v), borrowed(disks)
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
            a_max,
            v,
            v_max,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            radius,
            walls,
            wall_r,
            sweep,
            margin,
            disks,
            buf,
            res,
            hint,
        )
        count += c
        if found:
            return True, gx, gy, count, False
    return False, 0.0, 0.0, count, False


@njit(cache=True, error_model="numpy")
def _try_candidate(
    x,
    y,
    dist,
    a_d,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    disks,
    buf,
    res,
    hint,
):
    """One candidate (x, y) m/s^2 at ``dist`` from a_d of :func:`try_candidates_disc`: it,
    or its pushes out of a sliver, if admissible. Returns (found, x, y, candidates
    tested)."""
    vx = v[0]
    vy = v[1]
    count = 0
    ok, c = ok_disc(
        x,
        y,
        a_max,
        vx,
        vy,
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
        margin,
        buf,
        res,
        hint,
    )
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
            a_max,
            vx,
            vy,
            v_max,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            radius,
            walls,
            wall_r,
            sweep,
            margin,
            buf,
            res,
            hint,
        )
        count += c
        if found:
            return True, gx, gy, count
    ux, uy = outward_normal(x, y, disks)
    if ux != 0.0 or uy != 0.0:
        found, gx, gy, c = _sliver_push(
            x,
            y,
            ux,
            uy,
            tol,
            a_max,
            vx,
            vy,
            v_max,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            radius,
            walls,
            wall_r,
            sweep,
            margin,
            buf,
            res,
            hint,
        )
        count += c
        if found:
            return True, gx, gy, count
    return False, 0.0, 0.0, count


@njit(cache=True, error_model="numpy")
def repair_disc(
    prev, want, a_max, steps, unit, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, walls, wall_r
):
    """:func:`selection.repair_acceleration` compiled for the limit disc: the candidates
    prev + a_max * steps[i] * unit[k] (m/s^2), projected onto |a| <= a_max, tested
    nearest ``want`` first (a stable order) against the relevant obstacles (margin 0);
    returns (found, x, y, candidates tested)."""
    seg_c, seg_w, seg_b, radius, sweep = relevant_subset(
        v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, 0.0
    )
    walls, wall_r = relevant_walls(v, a_max, v_max, seg_t[-1], walls, wall_r, 0.0)
    return repair_relevant(
        prev,
        want,
        a_max,
        steps,
        unit,
        v,
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
    )


@njit(cache=True, error_model="numpy")
def repair_relevant(
    prev,
    want,
    a_max,
    steps,
    unit,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
):
    """:func:`repair_disc` for obstacles that are all relevant (as :func:`relevant_subset`
    keeps them, margin 0), with their :func:`piece_sweep`."""
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
    order = np.argsort(dist, kind="mergesort")
    return _first_admissible(
        cand,
        order,
        a_max,
        v,
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
        0.0,
        np.empty(3),
        np.empty(3),
        np.full(2, -1, dtype=np.int64),
    )


@njit(cache=True, error_model="numpy")
def _first_admissible(
    cand,
    order,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    buf,
    res,
    hint,
):
    """The first admissible row of ``cand`` (K, 2) m/s^2 in ``order``: (found, x, y,
    candidates tested); scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    walls, wall_r = borrowed(walls), borrowed(wall_r)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    cand, order, v = borrowed(cand), borrowed(order), borrowed(v)
    count = 0
    for o in range(order.shape[0]):
        k = order[o]
        ok, c = ok_disc(
            cand[k, 0],
            cand[k, 1],
            a_max,
            v[0],
            v[1],
            v_max,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            radius,
            walls,
            wall_r,
            sweep,
            margin,
            buf,
            res,
            hint,
        )
        count += c
        if ok:
            return True, cand[k, 0], cand[k, 1], count
    return False, 0.0, 0.0, count


@njit(cache=True, error_model="numpy")
def ring_search_disc(
    a_d,
    radii,
    unit,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
):
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
        a_max,
        v,
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
        margin,
        np.empty(3),
        np.empty(3),
        np.full(2, -1, dtype=np.int64),
        np.empty((unit.shape[1], 2)),
    )


@njit(cache=True, error_model="numpy")
def _ring_search(
    a_d,
    radii,
    unit,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    buf,
    res,
    hint,
    cand,
):
    """:func:`ring_search_disc` with its scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    walls, wall_r = borrowed(walls), borrowed(wall_r)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    a_d, radii, unit = borrowed(a_d), borrowed(radii), borrowed(unit)
    v, cand = borrowed(v), borrowed(cand)
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
            ok, c = ok_disc(
                x,
                y,
                a_max,
                v[0],
                v[1],
                v_max,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                radius,
                walls,
                wall_r,
                sweep,
                margin,
                buf,
                res,
                hint,
            )
            count += c
            if ok:
                best = k
                best_d = d
        if best >= 0:
            gx, gy, c = bisect_disc(
                a_d,
                cand[best],
                tol,
                a_max,
                v,
                v_max,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                radius,
                walls,
                wall_r,
                sweep,
                margin,
            )
            count += c
            start = np.empty(2)
            start[0] = gx
            start[1] = gy
            x, y, c = slide_disc(
                a_d,
                start,
                tol,
                a_max,
                v,
                v_max,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                radius,
                walls,
                wall_r,
                sweep,
                margin,
            )
            return True, x, y, count + c
    return False, 0.0, 0.0, count


@njit(cache=True, error_model="numpy")
def slide_disc(
    a_d,
    best,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
):
    """Rotate the admissible boundary point ``best`` about a_d (m/s^2) by shrinking angles,
    pulling each admissible probe back onto the boundary, while it gets nearer a_d by
    more than tol (m/s^2). Returns (x, y, candidates tested) —
    :func:`selection._slide_towards` compiled for the limit disc."""
    return _slide(
        a_d,
        best,
        tol,
        a_max,
        v,
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
        margin,
        np.empty(3),
        np.empty(3),
        np.full(2, -1, dtype=np.int64),
    )


@njit(cache=True, error_model="numpy")
def _slide(
    a_d,
    best,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    buf,
    res,
    hint,
):
    """:func:`slide_disc` with its scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    walls, wall_r = borrowed(walls), borrowed(wall_r)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    ax = a_d[0]
    ay = a_d[1]
    bx = best[0]
    by = best[1]
    count = 0
    dist = math.hypot(bx - ax, by - ay)
    angle = 0.5
    while angle > 1e-3 and dist > tol:
        phi = math.atan2(by - ay, bx - ax)
        moved = False
        for side in range(2):
            sgn = 1.0 if side == 0 else -1.0
            ux = math.cos(phi + sgn * angle)
            uy = math.sin(phi + sgn * angle)
            fx = ax + 1.5 * dist * ux
            fy = ay + 1.5 * dist * uy
            # projection onto the limit disc, as AccelLimits.project
            if not math.isfinite(fx):
                fx = 0.0
            if not math.isfinite(fy):
                fy = 0.0
            fx, fy = onto_disc(fx, fy, a_max)
            ok, c = ok_disc(
                fx,
                fy,
                a_max,
                v[0],
                v[1],
                v_max,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                radius,
                walls,
                wall_r,
                sweep,
                margin,
                buf,
                res,
                hint,
            )
            count += c
            if not ok:
                continue
            px, py, c = _bisect_disc(
                ax,
                ay,
                fx,
                fy,
                tol,
                a_max,
                v[0],
                v[1],
                v_max,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                radius,
                walls,
                wall_r,
                sweep,
                margin,
                buf,
                res,
                hint,
                dist - tol,
            )
            count += c
            d = math.hypot(px - ax, py - ay)
            if d < dist - tol:
                bx = px
                by = py
                dist = d
                moved = True
                break
        if not moved:
            angle *= 0.5
    return bx, by, count


@njit(cache=True, error_model="numpy")
def _try_ball_disc(
    a_d,
    disks,
    reach,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    covered,
):
    """:func:`selection._try_ball` for the limit disc: (found, x, y, candidates tested,
    whether the disks cover the whole ball). ``covered``: see
    :func:`nearest_outside_disks`."""
    M = disks.shape[0]
    out = np.full((8, 3), math.inf)
    lower = np.empty(M + 1)
    order, scale = outside_setup(a_d, disks, a_max, reach, out, lower)
    return _ball_search(
        a_d,
        disks,
        reach,
        tol,
        a_max,
        v,
        v_max,
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        radius,
        walls,
        wall_r,
        sweep,
        margin,
        covered,
        out,
        lower,
        order,
        scale,
        np.empty((2 * M + 8, 2)),
        np.empty(2 * M + 4),
        np.empty(2 * M + 4),
        np.empty(_WORDS, dtype=np.uint64),
        np.empty(3),
        np.empty(3),
        np.full(2, -1, dtype=np.int64),
    )


@njit(cache=True, error_model="numpy")
def _ball_search(
    a_d,
    disks,
    reach,
    tol,
    a_max,
    v,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    sweep,
    margin,
    covered,
    out,
    lower,
    order,
    scale,
    cand,
    starts,
    ends,
    cover,
    buf,
    res,
    hint,
):
    """:func:`_try_ball_disc` after :func:`outside_setup`, with its scratch arrays given
    (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    walls, wall_r = borrowed(walls), borrowed(wall_r)
    a_d, disks, v = borrowed(a_d), borrowed(disks), borrowed(v)
    out, lower, order, cand = borrowed(out), borrowed(lower), borrowed(order), borrowed(cand)
    starts, ends, cover = borrowed(starts), borrowed(ends), borrowed(cover)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    # nearest_outside_disks(a_d, disks, a_max, 8, reach, covered) tried with
    # try_candidates_disc, each candidate as soon as it is final: the circles farther
    # than the admissible one are never visited (same candidates, same order)
    count = 0
    oi = np.int64(0)  # not the literal 0 (see nao_arena.geometry._kernel)
    for row in range(8):
        oi = outside_advance(
            a_d, disks, a_max, covered, out, lower, order, oi, row, scale, cand, starts, ends, cover
        )
        dist = out[row, 2]
        if not (dist <= reach and dist < math.inf):
            return False, 0.0, 0.0, count, row == 0
        found, x, y, c = _try_candidate(
            out[row, 0],
            out[row, 1],
            dist,
            a_d,
            tol,
            a_max,
            v,
            v_max,
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            radius,
            walls,
            wall_r,
            sweep,
            margin,
            disks,
            buf,
            res,
            hint,
        )
        count += c
        if found:
            return True, x, y, count, False
    return False, 0.0, 0.0, count, False


@njit(cache=True, error_model="numpy")
def select_disc(
    a_d,
    v,
    a_max,
    v_max,
    seg_t,
    seg_c,
    seg_w,
    seg_b,
    radius,
    walls,
    wall_r,
    margin,
    tol,
    ring_radii,
    unit_rings,
    max_disks,
    n_sub,
    per_second,
    thin,
):
    """The search of :func:`selection.select_acceleration` for the limit disc, compiled:
    a_d (the desired acceleration, inside the disc) if admissible, else the disk search
    in the largest ball (radius max(a_max / 16, 4 tol) doubled) within ``max_disks``
    disks, the rings, and the disk search without a cap. Returns (status, x, y,
    candidates tested): status the :class:`~nao_arena.geometry.outcome.Outcome` DESIRED,
    ADJUSTED or INFEASIBLE (nothing admissible found: the caller falls back)."""
    c, w, b, r, sweep = relevant_subset(v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, margin)
    walls, wall_r = relevant_walls(v, a_max, v_max, seg_t[-1], walls, wall_r, margin)
    return select_relevant(
        a_d,
        v,
        a_max,
        v_max,
        seg_t,
        c,
        w,
        b,
        r,
        walls,
        wall_r,
        sweep,
        margin,
        tol,
        ring_radii,
        unit_rings,
        max_disks,
        n_sub,
        per_second,
        thin,
    )


@njit(cache=True, error_model="numpy")
def select_relevant(
    a_d,
    v,
    a_max,
    v_max,
    seg_t,
    c,
    w,
    b,
    r,
    walls,
    wall_r,
    sweep,
    margin,
    tol,
    ring_radii,
    unit_rings,
    max_disks,
    n_sub,
    per_second,
    thin,
):
    """:func:`select_disc` for obstacles that are all relevant (as :func:`relevant_subset`
    keeps them for this margin), with their :func:`piece_sweep` ``sweep``."""
    buf = np.empty(3)
    res = np.empty(3)
    hint = np.full(2, -1, dtype=np.int64)
    ok, count = ok_disc(
        a_d[0],
        a_d[1],
        a_max,
        v[0],
        v[1],
        v_max,
        seg_t,
        c,
        w,
        b,
        r,
        walls,
        wall_r,
        sweep,
        margin,
        buf,
        res,
        hint,
    )
    if ok:
        return Outcome.DESIRED, a_d[0], a_d[1], count
    reach = max(a_max / 16.0, 4.0 * tol)
    limit = math.hypot(a_d[0], a_d[1]) + a_max
    last = reach
    while last < limit:
        last *= 2.0
    samples = nao_disk_samples(
        v, seg_t, c, w, b, r, walls, wall_r, margin, n_sub, a_d, last, a_max, per_second, thin
    )
    order = radius_order(samples)
    # 1. the disk search in the largest ball, doubled from ``reach``, within the cap
    covered = 0.0  # the disks are known to cover the ball of this radius around a_d
    chosen, disks = capped_disks(samples, order, 0.5 * reach, max(limit, reach), max_disks)
    if chosen >= 0.0:
        found, x, y, k, empty = _try_ball_disc(
            a_d,
            disks,
            chosen,
            tol,
            a_max,
            v,
            v_max,
            seg_t,
            c,
            w,
            b,
            r,
            walls,
            wall_r,
            sweep,
            margin,
            0.0,
        )
        count += k
        if found:
            return Outcome.ADJUSTED, x, y, count
        if empty:
            covered = chosen
    # 2. rings of candidates
    found, x, y, k = ring_search_disc(
        a_d,
        ring_radii,
        unit_rings,
        tol,
        a_max,
        v,
        v_max,
        seg_t,
        c,
        w,
        b,
        r,
        walls,
        wall_r,
        sweep,
        margin,
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
        a_max,
        v,
        v_max,
        seg_t,
        c,
        w,
        b,
        r,
        walls,
        wall_r,
        sweep,
        margin,
        covered,
    )
    count += k
    if found:
        return Outcome.ADJUSTED, x, y, count
    return Outcome.INFEASIBLE, 0.0, 0.0, count
