"""The exact admissibility test of one acceleration within the limit disc |a| <= a_max
(m/s^2), with a hint of what rejected the last one, and the steps onto and along the
NAO boundary: bisection, pushes out of slivers between sampled disks, and sliding
along the boundary towards the desired acceleration a_d.

The test's arguments travel in the named bundles of :mod:`.bundles` (:class:`~.bundles.Limits`,
:class:`~.bundles.Obstacles`, :class:`~.bundles.Walls`, :class:`~.bundles.Scratch`), the
candidate's motion in :class:`~.bundles.Motion`. A function that borrows its arrays
(see :mod:`nao_arena.geometry.borrow`) builds the bundles again from the borrowed fields.
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry._kernel.bundles import Motion, Scratch
from nao_arena.geometry._kernel.exact import candidate_setup, piece_within, scan_obstacle
from nao_arena.geometry._kernel.segment import wall_violation
from nao_arena.geometry.borrow import borrowed, borrowed_fields
from nao_arena.jit import inner_kernel
from nao_arena.motion import onto_disc


# called by the searches once per candidate: its callers pass borrowed arrays, so the
# call counts no references (see nao_arena.geometry.borrow)
@inner_kernel(error_model="numpy")
def ok_disc(x, y, limits, obstacles, walls, margin, scratch):
    """Admissibility of the acceleration (x, y) m/s^2 within the limit disc |a| <= a_max:
    returns (admissible, 1 if it was tested against the obstacles (inside the disc)).
    Obstacles: the N moving ones (``obstacles``), then the W walls (``walls``; see
    :func:`~nao_arena.geometry._kernel.segment.wall_violation`); clearance margin m.

    scratch.hint: (obstacle, piece) that last rejected a candidate (-1: none; obstacle
    N + w: wall w). That piece (or wall) is tested first, then that obstacle, then the
    others (a rejection anywhere is the same answer, so the order does not change it);
    updated on a rejection.
    """
    a_max = limits.a_max
    if x * x + y * y > a_max * a_max * (1 + 1e-12) + 1e-300:
        return False, 0
    seg_t, seg_c, seg_w, seg_b, radius, sweep = obstacles
    buf, res, hint = scratch
    N = seg_c.shape[0]
    W = walls.ends.shape[0]
    if N == 0 and W == 0:
        return True, 1
    cvx, cvy, tau, bound = candidate_setup(limits.vx, limits.vy, x, y, limits.v_max, seg_t[-1])
    motion = Motion(cvx, cvy, x, y, tau, bound)
    if W and N <= hint[0] < N + W:
        if wall_violation(motion, seg_t[-1], walls, margin, hint[0] - N, buf, res) >= 0:
            return False, 1
    first = hint[0] if 0 <= hint[0] < N else 0
    if N and first == hint[0] and 0 <= hint[1] < seg_c.shape[1]:
        reach = radius[first] + margin
        if piece_within(motion, seg_t, seg_c, seg_w, seg_b, first, hint[1], reach * reach, buf):
            return False, 1
    for i in range(N):
        n = first if i == 0 else (i - 1 if i <= first else i)
        j = scan_obstacle(
            motion,
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
        w = wall_violation(motion, seg_t[-1], walls, margin, np.int64(-1), buf, res)
        if w >= 0:
            hint[0] = N + w
            hint[1] = -1
            return False, 1
    return True, 1


@inner_kernel(error_model="numpy")
def _bisect_disc(bx, by, gx, gy, tol, limits, obstacles, walls, margin, scratch, give_up):
    """Shrink [b, g] (g admissible) onto the boundary within tol: (gx, gy, tests). When
    b starts at the origin of the caller's distances (the slide's a_d), ``give_up``
    stops the search as soon as b is that far from its start: every point left on the
    segment is farther (the caller then discards the result). Borrows the bundles'
    arrays."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    scratch = borrowed_fields(scratch)
    gap = math.hypot(gx - bx, gy - by)
    ox = bx
    oy = by
    count = 0
    while gap > tol:
        if (bx - ox) ** 2 + (by - oy) ** 2 >= give_up * give_up and give_up >= 0.0:
            return gx, gy, count
        mx = 0.5 * (bx + gx)
        my = 0.5 * (by + gy)
        ok, c = ok_disc(mx, my, limits, obstacles, walls, margin, scratch)
        count += c
        if ok:
            gx = mx
            gy = my
        else:
            bx = mx
            by = my
        gap *= 0.5
    return gx, gy, count


@inner_kernel(error_model="numpy")
def bisect_disc(bad, good, tol, limits, obstacles, walls, margin):
    """Shrink the segment [bad, good] (m/s^2; good admissible) onto the NAO boundary
    within tol (m/s^2), with the limit disc |a| <= a_max. Returns (the admissible end
    x, y, how many candidates were tested) — :func:`selection._bisect` compiled."""
    return _bisect_disc(
        bad[0],
        bad[1],
        good[0],
        good[1],
        tol,
        limits,
        obstacles,
        walls,
        margin,
        Scratch(np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64)),
        math.inf,
    )


@inner_kernel(error_model="numpy")
def _sliver_push(x, y, ux, uy, tol, limits, obstacles, walls, margin, scratch):
    """Push the inadmissible point (x, y) along the unit direction (ux, uy) by tol, 2 tol,
    4 tol, ... below a_max / 4; the first admissible push is bisected back onto the
    boundary within tol. Returns (found, x, y, candidates tested). Borrows the bundles'
    arrays."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    hint = borrowed(scratch.hint)
    scratch = Scratch(borrowed(scratch.buf), borrowed(scratch.res), hint)
    count = 0
    step = tol
    while step < 0.25 * limits.a_max:
        px = x + step * ux
        py = y + step * uy
        ok, c = ok_disc(px, py, limits, obstacles, walls, margin, scratch)
        count += c
        if ok:
            hint[0] = -1
            hint[1] = -1
            gx, gy, c = _bisect_disc(
                x, y, px, py, tol, limits, obstacles, walls, margin, scratch, math.inf
            )
            return True, gx, gy, count + c
        step *= 2.0
    return False, 0.0, 0.0, count


@inner_kernel(error_model="numpy")
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


@inner_kernel(error_model="numpy")
def slide_disc(a_d, best, tol, limits, obstacles, walls, margin):
    """Rotate the admissible boundary point ``best`` about a_d (m/s^2) by shrinking angles,
    pulling each admissible probe back onto the boundary, while it gets nearer a_d by
    more than tol (m/s^2). Returns (x, y, candidates tested) —
    :func:`selection._slide_towards` compiled for the limit disc."""
    return _slide(
        a_d,
        best,
        tol,
        limits,
        obstacles,
        walls,
        margin,
        Scratch(np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64)),
    )


@inner_kernel(error_model="numpy")
def _slide(a_d, best, tol, limits, obstacles, walls, margin, scratch):
    """:func:`slide_disc` with its scratch arrays given (the bundles' arrays borrowed
    here)."""
    obstacles = borrowed_fields(obstacles)
    walls = borrowed_fields(walls)
    scratch = borrowed_fields(scratch)
    a_max = limits.a_max
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
            ok, c = ok_disc(fx, fy, limits, obstacles, walls, margin, scratch)
            count += c
            if not ok:
                continue
            px, py, c = _bisect_disc(
                ax, ay, fx, fy, tol, limits, obstacles, walls, margin, scratch, dist - tol
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
