"""Nearest points outside a union of disks (m/s^2) within the limit disc |a| <= a_max.

For every circle, the arcs not covered by the other disks are found (a bit set
of angular bins rules out fully covered circles cheaply); the point of each
free arc nearest the query is a candidate.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nao_arena.geometry._kernel.disks import vector_norm
from nao_arena.geometry.borrow import borrowed

_TWO_PI = 2.0 * math.pi


@njit(cache=True, error_model="numpy", inline="always")
def _add_interval(cx, cy, rho, in_limit, circ, skip, a_max, j, starts, ends, n):
    """Add the angular interval of the circle (cx, cy, rho) that disk j of ``circ``
    covers (j == len(circ): the outside of the limit disc, when ``in_limit``) to
    starts/ends from row n. Returns the new row count, or -1 when that disk covers
    the whole circle."""
    M = circ.shape[0]
    if j == M:
        if not in_limit:
            return n
        d = vector_norm(cx, cy)
        if d + rho <= a_max:
            return n
        if d >= rho + a_max or d + a_max <= rho:
            return -1
        cosb = (d * d + rho * rho - a_max * a_max) / (2.0 * d * rho)
        beta = math.acos(min(1.0, max(-1.0, cosb)))
        # allowed: the arc facing the origin, [alpha - beta, alpha + beta]
        lo = math.atan2(-cy, -cx) + beta
        width = _TWO_PI - 2.0 * beta
    else:
        if j == skip:
            return n
        dx = circ[j, 0] - cx
        dy = circ[j, 1] - cy
        rj = circ[j, 2]
        far = rho + rj
        if dx * dx + dy * dy > far * far * (1.0 + 1e-9):
            # clearly apart (the exact test below would skip it too)
            return n
        d = vector_norm(dx, dy)
        if d + rho <= rj * (1.0 - 1e-12):
            return -1
        if d >= rho + rj or d + rj <= rho or d <= 0.0:
            return n
        cosb = (d * d + rho * rho - rj * rj) / (2.0 * d * rho)
        beta = math.acos(min(1.0, max(-1.0, cosb)))
        lo = math.atan2(dy, dx) - beta
        width = 2.0 * beta
    lo = lo % _TWO_PI
    hi = lo + width
    if hi > _TWO_PI:
        starts[n] = lo
        ends[n] = _TWO_PI
        n += 1
        starts[n] = 0.0
        ends[n] = hi - _TWO_PI
        n += 1
    else:
        starts[n] = lo
        ends[n] = hi
        n += 1
    return n


_BINS = 256


@njit(cache=True, error_model="numpy", inline="always")
def _pseudo_angle(x, y):
    """A monotone stand-in for atan2(y, x) mod 2 pi, in [0, 4): no trigonometry.
    Its derivative with respect to the angle is at most 1."""
    s = abs(x) + abs(y)
    if s == 0.0:
        return 0.0
    if y >= 0.0:
        return 1.0 - x / s
    return 3.0 + x / s


_WORDS = _BINS // 64


_FULL = np.uint64(0xFFFFFFFFFFFFFFFF)


@njit(cache=True, error_model="numpy", inline="always")
def _set_bins(lo, hi, cover):
    """Set the bits of bins lo .. hi - 1 (0 <= lo < hi <= _BINS) in ``cover``."""
    for word in range(lo // 64, (hi - 1) // 64 + 1):
        a = max(lo - 64 * word, 0)
        b = min(hi - 64 * word, 64)
        if b - a == 64:
            cover[word] = _FULL
        else:
            cover[word] |= ((np.uint64(1) << np.uint64(b - a)) - np.uint64(1)) << np.uint64(a)


@njit(cache=True, error_model="numpy", inline="always")
def _cover_bins(p0, p1, shrink, cover):
    """Mark in the bit set ``cover`` the bins inside the ccw arc [p0, p1]
    (pseudo-angles) shrunk by ``shrink`` at both ends."""
    if p1 < p0:
        p1 += 4.0
    lo = p0 + shrink
    hi = p1 - shrink
    if not hi > lo:  # also NaN: mark nothing (leaving out can only fail to prove)
        return
    first = int(math.ceil(lo * (_BINS / 4.0)))
    last = int(math.floor(hi * (_BINS / 4.0)))  # bins first .. last - 1 lie inside
    if last - first >= _BINS:
        _set_bins(0, _BINS, cover)
        return
    if last <= first:
        return
    if last <= _BINS:
        _set_bins(first, last, cover)
    elif first >= _BINS:
        _set_bins(first - _BINS, last - _BINS, cover)
    else:
        _set_bins(first, _BINS, cover)
        _set_bins(0, last - _BINS, cover)


@njit(cache=True, error_model="numpy")
def _surely_covered(cx, cy, rho, in_limit, circ, skip, a_max, cover):
    """True only if the circle (cx, cy, rho) has no free arc for :func:`_free_arc_points`
    (a cheap proof; False means: not proven).

    The circle is cut into bins of pseudo-angle; each disk marks the bins its
    covered arc (from the two intersection points, no trigonometry) contains
    with a margin well above the rounding error of the exact angles, so every
    marked bin is covered in the exact computation too. All bins marked:
    covered. Disks near tangency or with ill-conditioned angles are left out
    (leaving out can only fail to prove).
    """
    M = circ.shape[0]
    for i in range(_WORDS):
        cover[i] = 0
    # visiting order: the limit disc, the rows next to ``skip`` (the same obstacle at
    # nearby times, which cover most), then the rest; stop as soon as all is proven
    lo_w = max(0, skip - 8) if skip >= 0 else 0
    hi_w = min(M, skip + 9) if skip >= 0 else 0
    width = hi_w - lo_w
    marked = 0
    checked = 0
    for step in range(M + 1):
        if step == 0:
            j = M
        elif step <= width:
            j = lo_w + step - 1
        else:
            j = step - 1 - width
            if j >= lo_w:
                j += width
        if step == width + 1 or marked > checked:
            checked = marked
            if _all_binned(cover):
                return True
        if j == M:
            if not in_limit:
                continue
            dx = -cx
            dy = -cy
            rj = a_max
        else:
            if j == skip:
                continue
            dx = circ[j, 0] - cx
            dy = circ[j, 1] - cy
            rj = circ[j, 2]
            far = rho + rj
            if dx * dx + dy * dy > far * far * (1.0 + 1e-9):
                continue
        d = math.sqrt(dx * dx + dy * dy)
        if j == M:
            if d + rho <= a_max * (1.0 - 1e-9):
                continue  # the circle lies inside the limit disc: nothing to cover
            if d >= (rho + a_max) * (1.0 + 1e-9) or d + a_max <= rho * (1.0 - 1e-9):
                return True  # the exact computation finds it all outside (-1)
        if not (d > 0.0 and d < (rho + rj) * (1.0 - 1e-9) and d + rj > rho * (1.0 + 1e-9)
                and d + rho > rj * (1.0 + 1e-9)):
            if j == M:
                return False
            continue
        scale = d * d + rho * rho + rj * rj
        a = (d * d + rho * rho - rj * rj) / (2.0 * d)
        h2 = rho * rho - a * a
        if h2 <= (1e-4 * rho) ** 2:
            continue
        h = math.sqrt(h2)
        sin_b = h / rho
        # bound on the angle error of the exact (acos, atan2) and of this computation
        err = 1e-15 * scale / (2.0 * d * rho) / sin_b + 1e-13
        if err > 1e-6:
            continue
        ux = dx / d
        uy = dy / d
        # intersection directions at angles alpha -/+ beta (alpha: towards the disk)
        p_minus = _pseudo_angle(a * ux + h * uy, a * uy - h * ux)
        p_plus = _pseudo_angle(a * ux - h * uy, a * uy + h * ux)
        shrink = 8.0 * err
        if j == M:
            _cover_bins(p_plus, p_minus, shrink, cover)  # outside the limit disc
        else:
            _cover_bins(p_minus, p_plus, shrink, cover)
        marked += 1
    return _all_binned(cover)


@njit(cache=True, error_model="numpy", inline="always")
def _all_binned(cover):
    """Whether the bit set ``cover`` marks every bin."""
    for i in range(_WORDS):
        if cover[i] != _FULL:
            return False
    return True


@njit(cache=True, error_model="numpy")
def _free_arc_points(cx, cy, rho, in_limit, q, circ, skip, a_max, out, k, starts, ends,
                     cover):
    """Append to ``out`` (from row k) the point nearest q of every free arc of the
    circle (cx, cy, rho): arcs no disk of ``circ`` (except row ``skip``) covers
    and, when ``in_limit``, inside the limit disc |a| <= a_max.
    Returns the new row count, or -1 when the whole circle is covered.
    starts/ends: scratch of at least 2 len(circ) + 4 rows; cover: _WORDS uint64.

    Most circles of a crowded picture are covered entirely: a cheap proof
    (:func:`_surely_covered`) skips the exact angles for them.
    """
    M = circ.shape[0]
    if _surely_covered(cx, cy, rho, in_limit, circ, skip, a_max, cover):
        return k
    n = 0
    for j in range(M + 1):
        n = _add_interval(cx, cy, rho, in_limit, circ, skip, a_max, j, starts, ends, n)
        if n < 0:
            return -1
    phi_q = math.atan2(q[1] - cy, q[0] - cx) % _TWO_PI
    if n == 0:
        out[k, 0] = cx + rho * math.cos(phi_q)
        out[k, 1] = cy + rho * math.sin(phi_q)
        return k + 1
    order = np.argsort(starts[:n])
    first_start = starts[order[0]]
    cur_end = ends[order[0]]
    for idx in range(1, n + 1):
        if idx < n:
            i = order[idx]
            if starts[i] <= cur_end:
                cur_end = max(cur_end, ends[i])
                continue
            lo = cur_end
            hi = starts[i]
            cur_end = ends[i]
        else:
            # the gap that wraps from the last covered end round to the first start
            lo = cur_end
            hi = first_start + _TWO_PI
            if hi <= lo:
                break
        # nearest point of the free arc [lo, hi] to q: phi_q if inside, else an end
        ph = phi_q if phi_q >= lo else phi_q + _TWO_PI
        if ph <= hi:
            best = ph
        else:
            d_lo = ph - hi
            d_hi = lo + _TWO_PI - ph
            best = hi if d_lo <= d_hi else lo
        out[k, 0] = cx + rho * math.cos(best)
        out[k, 1] = cy + rho * math.sin(best)
        k += 1
    return k


@njit(cache=True, error_model="numpy")
def nearest_outside_disks(q, disks, a_max, max_out, within=math.inf, covered=0.0):
    """Points nearest q that lie outside every disk and inside |a| <= a_max.

    The nearest point of the complement of a union of disks (within the limit
    disc) is q itself or lies on a free arc of one of the circles, the limit
    circle included. Free arcs come from the angular intervals the other
    disks cover; on each, the nearest point to q is its radial projection or
    an end. Circles are visited in order of their distance from q and the
    search stops once no unvisited circle can beat the ``max_out``-th best
    candidate. Returns up to ``max_out`` candidates (rows x, y, distance) in
    increasing distance, only those within distance ``within`` of q (m/s^2): circles
    that cannot come that close are not visited. ``covered`` (m/s^2): the caller
    knows that every point within that distance of q is covered (or outside the
    limit disc); circles that lie entirely that close are not visited.
    """
    M = disks.shape[0]
    res = np.full((max_out, 3), math.inf)
    found = _nearest_outside(q, disks, a_max, within, covered, res, np.empty((2 * M + 8, 2)),
                             np.empty(2 * M + 4), np.empty(2 * M + 4),
                             np.empty(_WORDS, dtype=np.uint64))
    return res[:found].copy()


@njit(cache=True, error_model="numpy")
def _nearest_outside(q, disks, a_max, within, covered, res, cand, starts, ends, cover):
    """:func:`nearest_outside_disks` into ``res`` (max_out, 3), filled with inf; returns how
    many rows hold candidates. Scratch arrays given (borrowed here)."""
    q, disks, res, cand = borrowed(q), borrowed(disks), borrowed(res), borrowed(cand)
    starts, ends, cover = borrowed(starts), borrowed(ends), borrowed(cover)
    max_out = res.shape[0]
    lower = np.empty(disks.shape[0] + 1)
    order, scale = outside_setup(q, disks, a_max, within, res, lower)
    outside_advance(q, disks, a_max, covered, res, lower, order, 0, max_out, scale, cand,
                    starts, ends, cover)
    return outside_found(res, within)


@njit(cache=True, error_model="numpy")
def outside_found(res, within):
    """How many leading rows of ``res`` hold candidates within ``within`` (m/s^2)."""
    found = 0
    while found < res.shape[0] and res[found, 2] <= within and res[found, 2] < math.inf:
        found += 1
    return found


@njit(cache=True, error_model="numpy")
def outside_setup(q, disks, a_max, within, res, lower):
    """Start :func:`nearest_outside_disks` (res (max_out, 3) filled with inf, lower (M + 1,)
    scratch): the candidate bound set just above ``within``, q itself as a candidate when
    no disk contains it, lower[i] the distance (m/s^2) from q to circle i (the limit
    circle last). Returns (the circles' visiting order, the scale (m/s^2) of the
    coordinates: a bound for rounding in :func:`outside_advance`)."""
    M = disks.shape[0]
    # candidates farther than ``within`` are never kept: start the bound just above it
    res[:, 2] = np.nextafter(within, math.inf)
    # q itself, when no disk contains it
    q_free = q[0] * q[0] + q[1] * q[1] <= a_max * a_max
    for i in range(M):
        if (q[0] - disks[i, 0]) ** 2 + (q[1] - disks[i, 1]) ** 2 < disks[i, 2] ** 2:
            q_free = False
            break
    if q_free:
        res[0, 0] = q[0]
        res[0, 1] = q[1]
        res[0, 2] = 0.0
    scale = abs(q[0]) + abs(q[1]) + abs(a_max)
    for i in range(M):
        lower[i] = abs(vector_norm(q[0] - disks[i, 0], q[1] - disks[i, 1]) - disks[i, 2])
        scale = max(scale, abs(q[0]) + abs(q[1]) + abs(disks[i, 0]) + abs(disks[i, 1])
                    + abs(disks[i, 2]))
    lower[M] = abs(vector_norm(q[0], q[1]) - a_max)
    order = np.argsort(lower)
    return order, scale


@njit(cache=True, error_model="numpy")
def outside_advance(q, disks, a_max, covered, res, lower, order, oi, row, scale, cand, starts,
                    ends, cover):
    """Visit the circles order[oi:] (:func:`outside_setup`) as :func:`nearest_outside_disks`
    does, inserting their free-arc points into ``res``, but only until row ``row`` of
    ``res`` is final: every circle left is farther from q than that row's candidate by
    far more than rounding (a point of a circle is at least its ``lower`` from q), so no
    later candidate can come before it (row >= max_out: until the end). Returns the
    position in ``order`` to resume from (len(order): nothing is left to visit)."""
    M = disks.shape[0]
    max_out = res.shape[0]
    while oi < order.shape[0]:
        i = order[oi]
        if lower[i] >= res[max_out - 1, 2]:
            return order.shape[0]
        if row < max_out and lower[i] > res[row, 2] + 1e-9 * (res[row, 2] + scale) + 1e-12:
            return oi
        oi += 1
        if covered > 0.0:
            if i < M:
                far = vector_norm(q[0] - disks[i, 0], q[1] - disks[i, 1]) + disks[i, 2]
            else:
                far = vector_norm(q[0], q[1]) + a_max
            if far < covered:
                continue
        if i < M:
            k = _free_arc_points(disks[i, 0], disks[i, 1], disks[i, 2], True, q, disks, i,
                                 a_max, cand, 0, starts, ends, cover)
        else:
            k = _free_arc_points(0.0, 0.0, a_max, False, q, disks, -1, a_max, cand, 0,
                                 starts, ends, cover)
        for c in range(max(k, 0)):
            d = vector_norm(cand[c, 0] - q[0], cand[c, 1] - q[1])
            if d < res[max_out - 1, 2]:
                # insert keeping res sorted by distance
                pos = max_out - 1
                while pos > 0 and res[pos - 1, 2] > d:
                    res[pos, 0] = res[pos - 1, 0]
                    res[pos, 1] = res[pos - 1, 1]
                    res[pos, 2] = res[pos - 1, 2]
                    pos -= 1
                res[pos, 0] = cand[c, 0]
                res[pos, 1] = cand[c, 1]
                res[pos, 2] = d
    return oi
