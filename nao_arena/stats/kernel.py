"""The compiled per-step kernel of the statistics: the broad phase (sort and sweep),
robot metrics, time to collision, exact swept distances (disc-disc and disc-wall) and the
contact and proximity episode flags, for all pairs in one numba call per step."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.kernels import point_segment_distance, segment_segment_distance
from nao_arena.jit import inner_kernel, kernel
from nao_arena.sorting import stable_argsort

__all__ = [
    "EV_DEEPER",
    "EV_END",
    "EV_START",
    "EpisodeArrays",
    "StatsArrays",
    "liveness_kernel",
    "step_kernel",
    "sweep_pairs",
    "swept_distances",
    "swept_wall_distances",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def sweep_pairs(lo: FloatArray, hi: FloatArray) -> tuple[IntArray, IntArray]:
    """All pairs (i < j) of overlapping axis-aligned boxes lo, hi (n, 2): sort and sweep on x.

    Deterministic order: by the boxes' rank in a stable sort on lo x, first of the pair,
    then second (i, j are the pair's smaller and larger index); cost O(n log n + pairs).
    Compiled with numba.
    """
    lo = np.ascontiguousarray(lo, dtype=float).reshape(-1, 2)
    hi = np.ascontiguousarray(hi, dtype=float).reshape(-1, 2)
    return _sweep_pairs_kernel(lo, hi)


# --------------------------------------------------------------------------- compiled step
#
# A step's work (robot metrics, broad phase, TTC, swept distances, episode flags)
# runs in one numba kernel, pairs in the broad phase's order; where it computes a
# value it uses the same float operations in the same order as the numpy formulas of
# tests/reference/stats_reference.py (no fastmath), so its results are bit-identical
# to them. Cheap squared-distance
# tests with a wide margin skip work whose outcome is certain. Rare events (contacts
# starting, getting deeper, ending) come back as a short list of rows that Python
# turns into ContactEvent objects.

EV_DEEPER, EV_START, EV_END = 0, 1, 2  # + 3 for the wall family
_MARGIN = 1.0 + 1e-9  # relative margin of squared-distance pre-tests before hypot


@kernel
def _sweep_pairs_kernel(lo: FloatArray, hi: FloatArray) -> tuple[IntArray, IntArray]:
    """sweep_pairs, compiled: the same pairs in the same order."""
    n = lo.shape[0]
    if n < 2:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    order = stable_argsort(lo[:, 0])
    slo_x = np.empty(n)
    for r in range(n):
        slo_x[r] = lo[order[r], 0]
    total = 0
    for r in range(n):
        top = hi[order[r], 0]
        s = r + 1
        while s < n and slo_x[s] <= top:
            s += 1
        total += s - r - 1
    out_a = np.empty(total, dtype=np.intp)
    out_b = np.empty(total, dtype=np.intp)
    k = 0
    for r in range(n):
        a = order[r]
        top = hi[a, 0]
        lo_y, hi_y = lo[a, 1], hi[a, 1]
        s = r + 1
        while s < n and slo_x[s] <= top:
            b = order[s]
            if lo[b, 1] <= hi_y and lo_y <= hi[b, 1]:
                out_a[k] = min(a, b)
                out_b[k] = max(a, b)
                k += 1
            s += 1
    return out_a[:k], out_b[:k]


@inner_kernel
def _end_separation(
    p1: FloatArray, radii: FloatArray, i: int, j: int, out: FloatArray, q: int
) -> None:
    """out[q] = separation (m) of bodies i, j at positions p1, unless already computed."""
    if math.isnan(out[q]):
        out[q] = math.hypot(p1[j, 0] - p1[i, 0], p1[j, 1] - p1[i, 1]) - (radii[i] + radii[j])


@inner_kernel
def _sorts_after(xa: float, a: int, xb: float, b: int) -> bool:
    """Whether key (xa, a) comes after (xb, b) in a stable sort on x (NaN last, as numpy)."""
    if xa > xb:
        return True
    if xa < xb:
        return False
    if xa == xb:
        return a > b
    na, nb = math.isnan(xa), math.isnan(xb)
    return (na and not nb) or (na and nb and a > b)


@inner_kernel
def _clip01(x: float) -> float:
    return min(max(x, 0.0), 1.0)


@inner_kernel
def _swept_path_distance(path: FloatArray, i: int, j: int) -> float:
    """Minimum distance (m) between the centres of bodies i and j over the substep path
    (S + 1, N, 2), each moving in a straight line between rows: per substep the closest
    point as in :func:`swept_distances`, the square root of the smallest squared norm."""
    best = math.inf
    for s in range(path.shape[0] - 1):
        d0x, d0y = path[s, j, 0] - path[s, i, 0], path[s, j, 1] - path[s, i, 1]
        d1x, d1y = path[s + 1, j, 0] - path[s + 1, i, 0], path[s + 1, j, 1] - path[s + 1, i, 1]
        wx, wy = d1x - d0x, d1y - d0y
        ww = wx * wx + wy * wy
        dw = d0x * wx + d0y * wy
        tt = _clip01(-dw / (ww if ww > 0.0 else 1.0))
        mx, my = d0x + wx * tt, d0y + wy * tt
        best = min(best, mx * mx + my * my)
    return math.sqrt(best)


@kernel
def swept_distances(rel: FloatArray) -> FloatArray:
    """Minimum distance (S,) m to the origin of the relative centre path rel (S + 1, 2) m,
    substep by substep (a straight line each): hypot of the closest point."""
    out = np.empty(rel.shape[0] - 1)
    for s in range(rel.shape[0] - 1):
        d0x, d0y = rel[s, 0], rel[s, 1]
        wx, wy = rel[s + 1, 0] - d0x, rel[s + 1, 1] - d0y
        ww = wx * wx + wy * wy
        dw = d0x * wx + d0y * wy
        tt = _clip01(-dw / (ww if ww > 0.0 else 1.0))
        out[s] = math.hypot(d0x + wx * tt, d0y + wy * tt)
    return out


@kernel
def swept_wall_distances(path: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Minimum distance (S,) m between a centre's path (S + 1, 2) m, substep by substep
    (a straight line each), and the segment a-b (m)."""
    out = np.empty(path.shape[0] - 1)
    for s in range(path.shape[0] - 1):
        out[s] = segment_segment_distance(
            path[s, 0], path[s, 1], path[s + 1, 0], path[s + 1, 1], a[0], a[1], b[0], b[1]
        )
    return out


class EpisodeArrays(NamedTuple):
    """The arrays :func:`step_kernel` works on that stay the same objects from step to
    step (world frame; N bodies, W walls). Read only, fixed for the episode: radii (N,)
    m the bodies' radii; is_robot (N,) bool which bodies are robots; cfg (5,) =
    (separation_range m, ttc_horizon s, near_miss_distance m, hysteresis m,
    adjustment_threshold m/s^2); wall_lo, wall_hi (W, 2) m the walls' broad-phase boxes
    (grown by the half-thickness and half the separation range); wall_segs (W, 2, 2) m
    the walls' segments; wall_radii (W,) m their half-thicknesses; wall_normals (W, 2)
    their unit normals. Kept between steps and updated in place: order (N + W,) intp
    the broad phase's order of the boxes at the previous step; the contact episode
    flags touch_bb (N, N) bool (upper triangle) and touch_bw (N, W) bool, and each open
    episode's deepest penetration so far depth_bb (N, N) m and depth_bw (N, W) m (read
    where the flag is set); the proximity
    episode flags prox (N, N) bool and prox_contact (N, N) bool (whether the episode
    touched); per body (N,): path_length m and adjustments (int64 count) until the
    goal, reached (bool) and time_to_goal s, the least separation min_sep m and time to
    collision min_ttc s, near_misses (int64 count)."""

    radii: FloatArray
    is_robot: NDArray[np.bool_]
    cfg: FloatArray
    wall_lo: FloatArray
    wall_hi: FloatArray
    wall_segs: FloatArray
    wall_radii: FloatArray
    wall_normals: FloatArray
    order: IntArray
    touch_bb: NDArray[np.bool_]
    touch_bw: NDArray[np.bool_]
    depth_bb: FloatArray
    depth_bw: FloatArray
    prox: NDArray[np.bool_]
    prox_contact: NDArray[np.bool_]
    path_length: FloatArray
    adjustments: NDArray[np.int64]
    reached: NDArray[np.bool_]
    time_to_goal: FloatArray
    min_sep: FloatArray
    min_ttc: FloatArray
    near_misses: NDArray[np.int64]


class StatsArrays(NamedTuple):
    """What one control period of :class:`~nao_arena.stats.EpisodeStats` reads and
    updates in place when it runs in compiled code (:func:`nao_arena.period.control_period`):
    the very arrays of the statistics (N bodies). a_prev (N, 2) m/s^2 the last step's
    commands (:func:`step_kernel`); episode the step kernel's :class:`EpisodeArrays`;
    the liveness (:func:`liveness_kernel`): goals (N, 2) m by body, or (0, 2) when not
    tracked, is_robot (N,), goal_dist (window, N) m the ring of goal distances, window
    (steps), stuck_progress m, at_goal (N,) bool, time_away (N,) s, stuck_time (N,) s."""

    a_prev: FloatArray
    episode: EpisodeArrays
    goals: FloatArray
    is_robot: NDArray[np.bool_]
    goal_dist: FloatArray
    window: int
    stuck_progress: float
    at_goal: NDArray[np.bool_]
    time_away: FloatArray
    stuck_time: FloatArray


@kernel(error_model="numpy")
def step_kernel(
    t: float,
    dt: float,
    path: FloatArray,
    v1: FloatArray,
    acc: FloatArray,
    a_prev: FloatArray,
    has_prev: bool,
    goal: NDArray[np.bool_],
    n_prox: int,
    arrays: EpisodeArrays,
) -> tuple[NDArray[np.int64], FloatArray, int]:
    """One control step of EpisodeStats (see EpisodeStats.update); arrays updated in place.

    The step [t, t + dt] (s): path (S + 1, N, 2) m the centres after each substep; v1
    (N, 2) m/s the velocities at its end; acc (N, 2) m/s^2 the commanded accelerations,
    a_prev (N, 2) m/s^2 the previous step's (read if has_prev; overwritten with acc);
    goal (N,) bool whether each body is within its goal's tolerance at the end; n_prox:
    the number of open proximity episodes; the bodies, walls and the state kept
    between steps (:class:`EpisodeArrays`). Returns the contact events
    as rows (code, a, b) with a value each (code EV_DEEPER: the new deepest penetration
    m; EV_START: the separation m; EV_END: unused; +3 for walls, b the wall index), in
    the order to apply them, and the new proximity count.
    """
    radii, is_robot, cfg = arrays.radii, arrays.is_robot, arrays.cfg
    wall_lo, wall_hi, wall_segs = arrays.wall_lo, arrays.wall_hi, arrays.wall_segs
    wall_radii, wall_normals = arrays.wall_radii, arrays.wall_normals
    order, touch_bb, touch_bw = arrays.order, arrays.touch_bb, arrays.touch_bw
    depth_bb, depth_bw = arrays.depth_bb, arrays.depth_bw
    prox, prox_contact = arrays.prox, arrays.prox_contact
    path_length, adjustments = arrays.path_length, arrays.adjustments
    reached, time_to_goal = arrays.reached, arrays.time_to_goal
    min_sep, min_ttc, near_misses = arrays.min_sep, arrays.min_ttc, arrays.near_misses
    sep_range, ttc_h, near_d, hyst, adj = cfg[0], cfg[1], cfg[2], cfg[3], cfg[4]
    n = radii.shape[0]
    nw = wall_radii.shape[0]
    last = path.shape[0] - 1  # substeps: the bodies move in straight lines between rows
    p0 = path[0]
    p1 = path[last]
    # per robot: path length and adjustments until the goal, time to goal
    for k in range(n):
        active = is_robot[k] and not reached[k]
        if active:
            path_length[k] += math.hypot(p1[k, 0] - p0[k, 0], p1[k, 1] - p0[k, 1])
            if has_prev:
                dax, day = acc[k, 0] - a_prev[k, 0], acc[k, 1] - a_prev[k, 1]
                sq = dax * dax + day * day  # hypot is slow: decided by sq unless close
                if adj >= 0.0 and sq > adj * adj * _MARGIN:
                    adjustments[k] += 1
                elif (adj < 0.0 or sq >= adj * adj / _MARGIN) and math.hypot(dax, day) > adj:
                    adjustments[k] += 1
            if goal[k]:
                time_to_goal[k] = t + dt
                reached[k] = True
        a_prev[k, 0] = acc[k, 0]
        a_prev[k, 1] = acc[k, 1]

    # broad phase: sort and sweep (as in sweep_pairs, same order) over boxes that cover
    # each body's swept step, its look-ahead path and the separation range, and the
    # wall boxes; each pair is handled where the sweep finds it
    pad = 0.5 * sep_range
    total = n + nw
    lo_x = np.empty(total)
    hi_x = np.empty(total)
    lo_y = np.empty(total)
    hi_y = np.empty(total)
    # step boxes grown by radius + pad + tol: bodies whose step boxes do not overlap
    # are surely beyond the separation range (tol >> rounding of the exact distance)
    scale = pad
    for k in range(n):
        scale = max(scale, radii[k])
        for s in range(last + 1):
            scale = max(scale, abs(path[s, k, 0]), abs(path[s, k, 1]))
    tol = 1e-9 * (1.0 + 4.0 * scale)
    # dev[k]: how far (m) body k's substep path strays from the chord p0 -> p1 (at equal
    # times), plus tol; a pair's distance on the substep paths differs from its distance
    # on the chords by at most dev[i] + dev[j] at every instant
    dev = np.zeros(n)
    step_box = np.empty((n, 4))
    for k in range(n):
        grow = radii[k] + pad
        x0, x1 = min(p0[k, 0], p1[k, 0]), max(p0[k, 0], p1[k, 0])
        y0, y1 = min(p0[k, 1], p1[k, 1]), max(p0[k, 1], p1[k, 1])
        if last > 1:
            ex, ey = p1[k, 0] - p0[k, 0], p1[k, 1] - p0[k, 1]
            worst = 0.0
            for s in range(1, last):
                px, py = path[s, k, 0], path[s, k, 1]
                x0, x1 = min(x0, px), max(x1, px)
                y0, y1 = min(y0, py), max(y1, py)
                f = s / last
                ox, oy = px - (p0[k, 0] + ex * f), py - (p0[k, 1] + ey * f)
                worst = max(worst, ox * ox + oy * oy)
            dev[k] = math.sqrt(worst) * _MARGIN + tol
        ax = p1[k, 0] + v1[k, 0] * ttc_h
        ay = p1[k, 1] + v1[k, 1] * ttc_h
        lo_x[k], hi_x[k] = min(x0, ax) - grow, max(x1, ax) + grow
        lo_y[k], hi_y[k] = min(y0, ay) - grow, max(y1, ay) + grow
        step_box[k, 0], step_box[k, 1] = x0 - grow - tol, x1 + grow + tol
        step_box[k, 2], step_box[k, 3] = y0 - grow - tol, y1 + grow + tol
    for w in range(nw):
        lo_x[n + w], hi_x[n + w] = wall_lo[w, 0], wall_hi[w, 0]
        lo_y[n + w], hi_y[n + w] = wall_lo[w, 1], wall_hi[w, 1]
    # the stable order of lo_x (as np.argsort(kind="stable")): insertion sort from the
    # previous step's order, which the boxes change little
    for r in range(1, total):
        o = order[r]
        x = lo_x[o]
        s = r - 1
        while s >= 0 and _sorts_after(lo_x[order[s]], order[s], x, o):
            order[s + 1] = order[s]
            s -= 1
        order[s + 1] = o
    slo_x = lo_x[order]
    shi_x = hi_x[order]
    slo_y = lo_y[order]
    shi_y = hi_y[order]
    # x overlaps: box r meets boxes r + 1 .. ends[r] - 1 (in sorted order)
    ends = np.empty(total, dtype=np.intp)
    count = 0
    for r in range(total):
        top = shi_x[r]
        s = r + 1
        while s < total and slo_x[s] <= top:
            s += 1
        ends[r] = s
        count += s - r - 1
    # those whose y ranges overlap too (branch-free: unpredictable tests are costly)
    pa = np.empty(count, dtype=np.intp)
    pb = np.empty(count, dtype=np.intp)
    m = 0
    for r in range(total):
        y_lo, y_hi, first = slo_y[r], shi_y[r], order[r]
        for s in range(r + 1, ends[r]):
            pa[m] = min(first, order[s])
            pb[m] = max(first, order[s])
            m += (slo_y[s] <= y_hi) & (y_lo <= shi_y[s])

    # body pairs: constant-velocity TTC at the step's end (pairs with a robot); those
    # whose step boxes meet are candidates for the exact swept separation
    cand = np.empty(m, dtype=np.intp)
    wall_pairs = np.empty(m, dtype=np.intp)
    nc = 0
    nwp = 0
    for q in range(m):
        i, j = pa[q], pb[q]
        if j >= n:
            wall_pairs[nwp] = q
            nwp += i < n
            continue
        reach = radii[i] + radii[j]
        d1x, d1y = p1[j, 0] - p1[i, 0], p1[j, 1] - p1[i, 1]
        wx, wy = v1[j, 0] - v1[i, 0], v1[j, 1] - v1[i, 1]
        aa = wx * wx + wy * wy
        bb = d1x * wx + d1y * wy
        cc = d1x * d1x + d1y * d1y - reach * reach
        disc = bb * bb - aa * cc
        # first root of |d + w t| = reach, stable form c / (-b + sqrt(disc)); 0 if overlapping
        ttc = cc / max(math.sqrt(max(disc, 0.0)) - bb, 1e-300)
        ttc = 0.0 if cc <= 0.0 else ttc
        hit = (((bb < 0.0) & (disc >= 0.0)) | (cc <= 0.0)) & (is_robot[i] | is_robot[j])
        ttc = ttc if hit & (ttc <= ttc_h) else math.inf
        min_ttc[i] = min(min_ttc[i], ttc)
        min_ttc[j] = min(min_ttc[j], ttc)
        cand[nc] = q
        nc += (
            (step_box[i, 0] <= step_box[j, 1])
            & (step_box[j, 0] <= step_box[i, 1])
            & (step_box[i, 2] <= step_box[j, 3])
            & (step_box[j, 2] <= step_box[i, 3])
        )

    # exact minimum separation over the step; the pairs within range are kept. hypot is
    # slow: it is skipped where squared distances (with a margin far above rounding)
    # show that the pair is beyond the range, or within it but with a separation that
    # changes nothing (not below either minimum, the near-miss distance or 0; then inf
    # is stored). The separation at the step's end (bend) is computed when needed.
    bi = np.empty(nc, dtype=np.intp)
    bj = np.empty(nc, dtype=np.intp)
    bsep = np.empty(nc)
    bend = np.full(nc, np.nan)
    nb = 0
    any_near = False
    for c in range(nc):
        i, j = pa[cand[c]], pb[cand[c]]
        reach = radii[i] + radii[j]
        d0x, d0y = p0[j, 0] - p0[i, 0], p0[j, 1] - p0[i, 1]
        d1x, d1y = p1[j, 0] - p1[i, 0], p1[j, 1] - p1[i, 1]
        wx, wy = d1x - d0x, d1y - d0y
        ww = wx * wx + wy * wy
        dw = d0x * wx + d0y * wy
        tt = _clip01(-dw / (ww if ww > 0.0 else 1.0))
        mx, my = d0x + wx * tt, d0y + wy * tt
        msq = mx * mx + my * my  # on the chords
        slack = dev[i] + dev[j]
        far = (reach + sep_range + slack) * (reach + sep_range + slack)
        if msq > far * _MARGIN:
            continue  # surely beyond the range
        low = max(max(min_sep[i], min_sep[j]), max(near_d, 0.0))
        near = (reach + low + slack) * (reach + low + slack)
        inner = max(reach + sep_range - slack, 0.0)
        if low < sep_range and msq < inner * inner / _MARGIN and msq > near * _MARGIN:
            sep = math.inf  # surely within the range, and surely >= low
        else:
            exact = math.hypot(mx, my) if last == 1 else _swept_path_distance(path, i, j)
            sep = exact - reach
            if not sep < sep_range:
                continue
            min_sep[i] = min(min_sep[i], sep)
            min_sep[j] = min(min_sep[j], sep)
            any_near |= sep < near_d
        bi[nb], bj[nb], bsep[nb] = i, j, sep
        nb += 1

    # body-wall pairs: cheap bound by the wall's supporting line, then the exact
    # distance; open contacts stay candidates until they end
    wi = np.empty(nwp, dtype=np.intp)
    wj = np.empty(nwp, dtype=np.intp)
    wsep = np.empty(nwp)
    wend = np.empty(nwp)
    nwc = 0
    for c in range(nwp):
        i, w = pa[wall_pairs[c]], pb[wall_pairs[c]] - n
        reach = radii[i] + wall_radii[w]
        ax, ay = wall_segs[w, 0, 0], wall_segs[w, 0, 1]
        bx, by = wall_segs[w, 1, 0], wall_segs[w, 1, 1]
        nx, ny = wall_normals[w, 0], wall_normals[w, 1]
        side0 = (p0[i, 0] - ax) * nx + (p0[i, 1] - ay) * ny
        side1 = (p1[i, 0] - ax) * nx + (p1[i, 1] - ay) * ny
        bound = 0.0 if side0 * side1 <= 0.0 else min(abs(side0), abs(side1))
        if bound - dev[i] < reach or touch_bw[i, w]:
            wi[nwc], wj[nwc] = i, w
            dist = math.inf
            for s in range(last):
                dist = min(
                    dist,
                    segment_segment_distance(
                        path[s, i, 0],
                        path[s, i, 1],
                        path[s + 1, i, 0],
                        path[s + 1, i, 1],
                        ax,
                        ay,
                        bx,
                        by,
                    ),
                )
            wsep[nwc] = dist - reach
            wend[nwc] = point_segment_distance(p1[i, 0], p1[i, 1], ax, ay, bx, by) - reach
            nwc += 1

    # contact episodes of both families -> event rows
    codes = np.empty((2 * (nb + nwc), 3), dtype=np.int64)
    vals = np.empty(2 * (nb + nwc))
    ne = 0
    for fam in range(2):
        cnt = nb if fam == 0 else nwc
        ii = bi if fam == 0 else wi
        jj = bj if fam == 0 else wj
        ss = bsep if fam == 0 else wsep
        ee = bend if fam == 0 else wend
        state = touch_bb if fam == 0 else touch_bw
        depth = depth_bb if fam == 0 else depth_bw
        base = 3 * fam
        for q in range(cnt):  # open episodes that got deeper than ever
            if state[ii[q], jj[q]] and ss[q] < 0.0 and -ss[q] > depth[ii[q], jj[q]]:
                depth[ii[q], jj[q]] = -ss[q]
                codes[ne, 0], codes[ne, 1], codes[ne, 2] = base + EV_DEEPER, ii[q], jj[q]
                vals[ne] = -ss[q]
                ne += 1
        start = ne
        for q in range(cnt):  # new episodes
            if ss[q] < 0.0 and not state[ii[q], jj[q]]:
                codes[ne, 0], codes[ne, 1], codes[ne, 2] = base + EV_START, ii[q], jj[q]
                vals[ne] = ss[q]
                ne += 1
                depth[ii[q], jj[q]] = -ss[q]
        for q in range(cnt):  # ended episodes (a new one may end at once)
            live = state[ii[q], jj[q]] or ss[q] < 0.0
            if live and fam == 0:
                _end_separation(p1, radii, ii[q], jj[q], ee, q)
            if live and ee[q] > hyst:
                codes[ne, 0], codes[ne, 1], codes[ne, 2] = base + EV_END, ii[q], jj[q]
                vals[ne] = 0.0
                ne += 1
                depth[ii[q], jj[q]] = 0.0
        for r in range(start, ne):
            if codes[r, 0] == base + EV_START:
                state[codes[r, 1], codes[r, 2]] = True
        for r in range(start, ne):
            if codes[r, 0] == base + EV_END:
                state[codes[r, 1], codes[r, 2]] = False

    # proximity episodes (near misses)
    if nb > 0 and (n_prox != 0 or any_near):
        limit = near_d + hyst
        n_prox = 0
        for q in range(nb):
            i, j = bi[q], bj[q]
            live = prox[i, j] or bsep[q] < near_d
            had = prox_contact[i, j] or bsep[q] < 0.0
            if live:
                _end_separation(p1, radii, i, j, bend, q)
            ended = live and bend[q] > limit
            if ended and not had:
                near_misses[i] += 1
                near_misses[j] += 1
            keep = live and not ended
            prox[i, j] = keep
            prox_contact[i, j] = had and keep
            n_prox += keep
    return codes[:ne], vals[:ne], n_prox


@kernel(error_model="numpy")
def liveness_kernel(
    dt: float,
    p1: FloatArray,
    goals: FloatArray,
    goal: NDArray[np.bool_],
    robots: NDArray[np.bool_],
    reached: NDArray[np.bool_],
    goal_dist: FloatArray,
    slot: int,
    stuck_progress: float,
    at_goal: NDArray[np.bool_],
    time_away: FloatArray,
    stuck_time: FloatArray,
) -> bool:
    """The liveness bookkeeping of one step of dt (s) that ends with the bodies at p1
    (N, 2) m, goal[i] within the goal tolerance, for the robots: at_goal (written),
    time_away (s, added to: reached before and not at the goal now), and, with goals
    (N, 2) m (empty: none): the distance to the goal written into goal_dist[slot] (the
    ring of distances one stuck window apart), stuck_time (s, added to: away from the goal
    and not stuck_progress m closer than one window ago). Returns whether every robot
    away from its goal is stuck (and one is)."""
    n = p1.shape[0]
    for i in range(n):
        at_goal[i] = goal[i] and robots[i]
        if reached[i] and not goal[i] and robots[i]:
            time_away[i] += dt
    if goals.shape[0] == 0:
        return False
    some_away = False
    all_stuck = True
    for i in range(n):
        dist = math.hypot(p1[i, 0] - goals[i, 0], p1[i, 1] - goals[i, 1])
        away = robots[i] and not goal[i]
        stuck = away and goal_dist[slot, i] - dist < stuck_progress
        goal_dist[slot, i] = dist
        if stuck:
            stuck_time[i] += dt
        some_away = some_away or away
        all_stuck = all_stuck and stuck == away
    return some_away and all_stuck
