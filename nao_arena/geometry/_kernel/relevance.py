"""Relevance pruning: which obstacles a robot could reach at all within the horizon.

An obstacle is kept when some acceleration |a| <= a_max (speed capped at
v_max) could bring the robot within its combined radius plus a margin (m) on
some piece; the others cannot affect admissibility and are dropped before the
exact tests. The robot travels as a :class:`~.bundles.Limits` (its velocity already
scaled down to v_max), the sampled paths as :class:`~.bundles.Predictions`.
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry._kernel.bundles import Limits, Predictions
from nao_arena.geometry._kernel.exact import piece_sweep
from nao_arena.geometry._kernel.sampled import RADIUS_CUT, moving_piece
from nao_arena.geometry.borrow import borrowed
from nao_arena.jit import inner_kernel, kernel
from nao_arena.motion import limit_norm_sqrt


@inner_kernel(error_model="numpy")
def _relevant(limits, seg_t, seg_c, seg_w, seg_b, n, r):
    """Whether obstacle n (combined radius r, m; paths as in :class:`~.bundles.Paths`) is
    within reach of the robot (its :class:`~.bundles.Limits`, velocity already clamped
    to v_max): see :func:`relevant_obstacles`."""
    for j in range(seg_c.shape[1]):
        if _piece_relevant(
            seg_c[n, j, 0],
            seg_c[n, j, 1],
            seg_w[n, j, 0],
            seg_w[n, j, 1],
            seg_b[n, j, 0],
            seg_b[n, j, 1],
            seg_t[j],
            seg_t[j + 1],
            limits,
            r,
        ):
            return True
    return False


@inner_kernel(error_model="numpy")
def _piece_relevant(cx, cy, wx, wy, bx, by, t0, t1, limits, r):
    """Whether the robot (its :class:`~.bundles.Limits`: velocity v m/s, a_max m/s^2,
    v_max m/s) could come within r (m) of an obstacle during the piece [t0, t1] s that
    starts at (cx, cy) m with velocity (wx, wy) m/s and acceleration (bx, by) m/s^2:
    |x(t) - v t| <= a_max t^2 / 2 and |x(t)| <= v_max t must both allow it (see
    :func:`relevant_obstacles`). A piece of infinite length always may. Branch-free, so
    loops over pieces vectorise."""
    a_max, vx, vy, v_max = limits
    h = t1 - t0
    dx = cx - vx * t0
    dy = cy - vy * t0
    bb = math.sqrt(bx**2 + by**2)
    reach = (
        r
        + 0.5 * a_max * t1 * t1
        + math.sqrt((wx - vx) ** 2 + (wy - vy) ** 2) * h
        + 0.5 * bb * h * h
    )
    own = r + v_max * t1 + math.sqrt(wx**2 + wy**2) * h + 0.5 * bb * h * h
    near = not (dx * dx + dy * dy > reach * reach)
    close = cx * cx + cy * cy <= own * own
    return (not math.isfinite(h)) | (near & ((not math.isfinite(v_max)) | close))


@kernel(error_model="numpy")
def relevant_obstacles(v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, margin):
    """(N,) mask of obstacles that some acceleration with |a| <= a_max could come within
    radius + margin (m) of over the horizon.

    Uses |x(t) - v t| <= a_max t^2 / 2, which also holds under speed
    saturation, and |x(t)| <= v_max t (the speed never exceeds v_max); v is
    first clamped to v_max. Obstacles outside the mask can be dropped from
    any selection with those limits.
    """
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius = borrowed(radius)
    N = seg_c.shape[0]
    vx, vy, _ = limit_norm_sqrt(v[0], v[1], v_max)
    limits = Limits(a_max, vx, vy, v_max)
    out = np.zeros(N, dtype=np.bool_)
    for n in range(N):
        out[n] = _relevant(limits, seg_t, seg_c, seg_w, seg_b, n, radius[n] + margin)
    return out


@inner_kernel(error_model="numpy")
def _moving_relevant(pred, body, px, py, times, c, w, row, limits, r):
    """:func:`moving_pieces` into row ``row``, and whether one of those pieces is relevant
    to the robot (its :class:`~.bundles.Limits`; :func:`_piece_relevant`, radius r m: what
    :func:`_relevant` answers), in one pass with no early exit (the compiler vectorises
    it; most obstacles tested are not relevant)."""
    v_max = limits.v_max
    if math.isfinite(v_max) and math.isfinite(times[0]) and math.isfinite(times[-1]):
        # first a cheap proof that no piece passes the v_max test: |w| h <= |dx| + |dy|
        # (no division, no square root); the factor covers the rounding of the exact test
        maybe = False
        for j in range(times.shape[0] - 1):
            x0 = pred[body, j, 0] - px
            y0 = pred[body, j, 1] - py
            dx = pred[body, j + 1, 0] - px - x0
            dy = pred[body, j + 1, 1] - py - y0
            own = (r + v_max * times[j + 1] + abs(dx) + abs(dy)) * (1.0 + 1e-9) + 1e-12
            maybe = maybe | (x0 * x0 + y0 * y0 <= own * own)
        if not maybe:
            return False
    hit = False
    for j in range(times.shape[0] - 1):
        x0, y0, wx, wy = moving_piece(pred, body, px, py, times, c, w, row, j)
        hit = hit | _piece_relevant(x0, y0, wx, wy, 0.0, 0.0, times[j], times[j + 1], limits, r)
    return hit


@kernel(error_model="numpy")
def relevant_sampled_paths(
    times, pred, idx, position, nb_radius, grow, v, a_max, v_max, excursion, finite_path
):
    """The pieces :func:`~nao_arena.geometry.clearance.sampled_path` builds, of the
    obstacles :func:`relevant_obstacles` keeps (margin 0), in one pass.

    Obstacles: the bodies ``idx`` with world-frame centres pred[body] (T, 2) m at
    ``times`` (s; times[0] = 0, increasing, T >= 2) and radii nb_radius[body] + grow
    (m), every radius cut to just under the obstacle's current distance (RADIUS_CUT)
    (walls are not paths: see :func:`~nao_arena.geometry._kernel.segment.nearby_walls`). Centres
    are taken relative to ``position`` (m). Robot: velocity v (m/s), limits a_max,
    v_max. excursion, finite_path: :func:`path_excursions` of ``pred``.
    Returns (c, w, b, radius, finite): the pieces' start centres, velocities
    and accelerations (zero) (n, T - 1, 2) and radii (n,) of the kept obstacles in
    input order; finite is
    False (and nothing is kept) when a neighbour's centres are not all finite.
    """
    S = times.shape[0] - 1
    total = idx.shape[0]
    c = np.empty((total, S, 2))
    w = np.empty((total, S, 2))
    rad = np.empty(total)
    # the pieces' accelerations are zero: only the kept rows are allocated (and zeroed)
    # the arguments' views are borrowed (nao_arena.geometry.borrow) for the one call
    n = _fill_relevant_paths(
        Predictions(
            borrowed(times),
            borrowed(pred),
            borrowed(nb_radius),
            borrowed(excursion),
            borrowed(finite_path),
        ),
        idx,
        position,
        grow,
        v,
        a_max,
        v_max,
        c,
        w,
        c[:0],
        rad,
    )
    if n < 0:
        return c[:0], w[:0], np.zeros((0, S, 2)), rad[:0], False
    return c[:n], w[:n], np.zeros((n, S, 2)), rad[:n], True


@inner_kernel(error_model="numpy")
def _fill_relevant_paths(predictions, idx, position, grow, v, a_max, v_max, c, w, b, rad):
    """:func:`relevant_sampled_paths` into c, w, rad (rows for every obstacle given; b, the
    zero accelerations, is not written): the bodies ``idx`` of the
    :class:`~.bundles.Predictions`, relative to ``position`` (2,) m, radii grown by
    ``grow`` m; the robot's velocity v (2,) m/s, limits a_max m/s^2 and v_max m/s.
    Returns how many rows it kept, -1 when a neighbour's centres are not all finite.
    Arrays borrowed here."""
    times, pred, nb_radius, excursion, finite_path = predictions
    times, pred, idx, position = borrowed(times), borrowed(pred), borrowed(idx), borrowed(position)
    nb_radius, v = borrowed(nb_radius), borrowed(v)
    excursion, finite_path = borrowed(excursion), borrowed(finite_path)
    c, w, b, rad = borrowed(c), borrowed(w), borrowed(b), borrowed(rad)
    n_nb = idx.shape[0]
    for i in range(n_nb):
        if not finite_path[idx[i]]:
            return -1
    vx, vy, _ = limit_norm_sqrt(v[0], v[1], v_max)
    limits = Limits(a_max, vx, vy, v_max)
    px = position[0]
    py = position[1]
    # |x(t)| <= v_max t: an obstacle that stays farther than v_max times the horizon
    # (plus its radius) is dropped before its pieces are built
    travel = v_max * times[-1]
    n = np.int64(0)
    for i in range(n_nb):
        body = idx[i]
        x0 = pred[body, 0, 0] - px
        y0 = pred[body, 0, 1] - py
        r = nb_radius[body] + grow
        dist = math.sqrt(x0 * x0 + y0 * y0)
        r = min(r, dist * RADIUS_CUT)
        if math.isfinite(travel):
            ex = excursion[body]
            # every piece starts within ex of the first centre and moves at most 2 ex
            if dist - ex > (r + travel + 2.0 * ex) * (1.0 + 1e-9) + 1e-12:
                continue
        rad[n] = r
        if _moving_relevant(pred, body, px, py, times, c, w, n, limits, r):
            n += 1
    return n


@inner_kernel(error_model="numpy")
def relevant_subset(v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, margin):
    """The obstacles :func:`relevant_obstacles` keeps, as contiguous arrays (the inputs
    themselves when all are kept), and their :func:`piece_sweep`:
    (c, w, b, radius, sweep)."""
    keep = relevant_obstacles(v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, margin)
    n = np.int64(0)
    for i in range(keep.shape[0]):
        if keep[i]:
            n += 1
    if n == keep.shape[0]:
        c = np.ascontiguousarray(seg_c)
        w = np.ascontiguousarray(seg_w)
        b = np.ascontiguousarray(seg_b)
        r = np.ascontiguousarray(radius)
    else:
        S = seg_c.shape[1]
        c = np.empty((n, S, 2))
        w = np.empty((n, S, 2))
        b = np.empty((n, S, 2))
        r = np.empty(n)
        k = 0
        for i in range(keep.shape[0]):
            if keep[i]:
                for s in range(S):
                    for d in range(2):
                        c[k, s, d] = seg_c[i, s, d]
                        w[k, s, d] = seg_w[i, s, d]
                        b[k, s, d] = seg_b[i, s, d]
                r[k] = radius[i]
                k += 1
    return c, w, b, r, piece_sweep(seg_t, w, b)
