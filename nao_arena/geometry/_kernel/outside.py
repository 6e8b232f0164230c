"""Nearest points outside a union of disks (m/s^2) within the limit disc |a| <= a_max.

For every circle, the arcs not covered by the other disks are found (a bit set
of angular bins rules out fully covered circles cheaply); the point of each
free arc nearest the query is a candidate. A search's state and scratch arrays travel
in an :class:`~.bundles.OutsideSearch`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from nao_arena.geometry._kernel.bundles import OutsideSearch
from nao_arena.geometry._kernel.disks import vector_norm
from nao_arena.geometry.borrow import borrowed
from nao_arena.jit import inner_kernel
from nao_arena.sorting import stable_argsort

_TWO_PI = 2.0 * math.pi


class Circle(NamedTuple):
    """A circle in acceleration space (frame of :mod:`nao_arena.geometry`): centre
    (cx, cy) m/s^2, radius rho m/s^2 (a disk's rim, or the limit circle)."""

    cx: float
    cy: float
    rho: float


@inner_kernel(error_model="numpy")
def _offset(cx, cy, rho, circ, j):
    """Disk j of ``circ`` seen from the circle (cx, cy, rho): (dx, dy) from the circle's
    centre to the disk's (m/s^2), its radius, and whether the two are clearly apart
    (farther than the sum of the radii by a relative 1e-9: every exact test skips
    such a disk too)."""
    dx = circ[j, 0] - cx
    dy = circ[j, 1] - cy
    rj = circ[j, 2]
    far = rho + rj
    return dx, dy, rj, dx * dx + dy * dy > far * far * (1.0 + 1e-9)


@inner_kernel(error_model="numpy")
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
        dx, dy, rj, apart = _offset(cx, cy, rho, circ, j)
        if apart:
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


@inner_kernel(error_model="numpy")
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


@inner_kernel(error_model="numpy")
def _set_bins(lo, hi, cover):
    """Set the bits of bins lo .. hi - 1 (0 <= lo < hi <= _BINS) in ``cover``."""
    for word in range(lo // 64, (hi - 1) // 64 + 1):
        a = max(lo - 64 * word, 0)
        b = min(hi - 64 * word, 64)
        if b - a == 64:
            cover[word] = _FULL
        else:
            cover[word] |= ((np.uint64(1) << np.uint64(b - a)) - np.uint64(1)) << np.uint64(a)


@inner_kernel(error_model="numpy")
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
        first, last = 0, _BINS
    elif first >= _BINS:
        first, last = first - _BINS, last - _BINS
    # the bins first .. last - 1, wrapping round past _BINS: at most two runs, marked by
    # one call site
    while last > first:
        end = min(last, _BINS)
        _set_bins(first, end, cover)
        first, last = 0, last - _BINS


# what :func:`_mark` did
_NOTHING, _MARKED, _ALL_OUTSIDE, _UNPROVABLE = 0, 1, 2, 3


@inner_kernel(error_model="numpy")
def _mark(cx, cy, rho, circ, j, a_max, cover):
    """Mark in the bit set ``cover`` the bins of the circle (cx, cy, rho) that disk j of
    ``circ`` covers (j == len(circ): the outside of the limit disc |a| <= a_max).

    A bin is marked only if it lies inside the covered arc (from the two intersection
    points, no trigonometry) by a margin well above the rounding error of the exact
    angles of :func:`_add_interval`, so every marked bin is covered in the exact
    computation too. Disks near tangency or with ill-conditioned angles mark nothing.
    Returns _MARKED, _NOTHING, or for the limit disc _ALL_OUTSIDE (the exact computation
    finds the whole circle outside it) or _UNPROVABLE (an ill-conditioned limit circle)."""
    M = circ.shape[0]
    if j == M:
        dx = -cx
        dy = -cy
        rj = a_max
    else:
        dx, dy, rj, apart = _offset(cx, cy, rho, circ, j)
        if apart:
            return _NOTHING
    d = math.sqrt(dx * dx + dy * dy)
    if j == M:
        if d + rho <= a_max * (1.0 - 1e-9):
            return _NOTHING  # the circle lies inside the limit disc: nothing to cover
        if d >= (rho + a_max) * (1.0 + 1e-9) or d + a_max <= rho * (1.0 - 1e-9):
            return _ALL_OUTSIDE
    if not (
        d > 0.0
        and d < (rho + rj) * (1.0 - 1e-9)
        and d + rj > rho * (1.0 + 1e-9)
        and d + rho > rj * (1.0 + 1e-9)
    ):
        return _UNPROVABLE if j == M else _NOTHING
    scale = d * d + rho * rho + rj * rj
    inv_d = 1.0 / d
    a = (d * d + rho * rho - rj * rj) * (0.5 * inv_d)
    h2 = rho * rho - a * a
    if h2 <= (1e-4 * rho) ** 2:
        return _NOTHING
    h = math.sqrt(h2)
    # bound on the angle error of the exact (acos, atan2) and of this computation:
    # 1e-15 scale / (2 d rho sin(beta)) + 1e-13, with rho sin(beta) = h
    err = 1e-15 * scale * (0.5 * inv_d) / h + 1e-13
    if err > 1e-6:
        return _NOTHING
    ux = dx * inv_d
    uy = dy * inv_d
    # intersection directions at angles alpha -/+ beta (alpha: towards the disk)
    p_minus = _pseudo_angle(a * ux + h * uy, a * uy - h * ux)
    p_plus = _pseudo_angle(a * ux - h * uy, a * uy + h * ux)
    if j == M:  # outside the limit disc
        p_minus, p_plus = p_plus, p_minus
    _cover_bins(p_minus, p_plus, 8.0 * err, cover)
    return _MARKED


#: de Bruijn sequence and table: the index of a word's lowest set bit in a few operations
_DE_BRUIJN = np.uint64(0x03F79D71B4CB0A89)
_DE_BRUIJN_INDEX = np.array(
    [
        0,
        1,
        48,
        2,
        57,
        49,
        28,
        3,
        61,
        58,
        50,
        42,
        38,
        29,
        17,
        4,
        62,
        55,
        59,
        36,
        53,
        51,
        43,
        22,
        45,
        39,
        33,
        30,
        24,
        18,
        12,
        5,
        63,
        47,
        56,
        27,
        60,
        41,
        37,
        16,
        54,
        35,
        52,
        21,
        44,
        32,
        23,
        11,
        46,
        26,
        40,
        15,
        34,
        20,
        31,
        10,
        25,
        14,
        19,
        9,
        13,
        8,
        7,
        6,
    ],
    dtype=np.int64,
)


@inner_kernel(error_model="numpy")
def _next_bin(cover, b, marked):
    """The first bin >= b (b < _BINS) that is marked in ``cover`` (``marked``) or not;
    _BINS when there is none."""
    w = b // 64
    x = cover[w] if marked else ~cover[w]
    x &= _FULL << np.uint64(b % 64)
    while x == np.uint64(0):
        w += 1
        if w == _WORDS:
            return _BINS
        x = cover[w] if marked else ~cover[w]
    low = x & (~x + np.uint64(1))
    return 64 * w + _DE_BRUIJN_INDEX[(low * _DE_BRUIJN) >> np.uint64(58)]


@inner_kernel(error_model="numpy")
def _on_circle(cx, cy, rho, p):
    """The point of the circle (cx, cy, rho) at pseudo-angle p (see :func:`_pseudo_angle`)."""
    p %= 4.0
    if p < 2.0:
        x = 1.0 - p
        y = 1.0 - abs(x)
    else:
        x = p - 3.0
        y = abs(x) - 1.0
    n = math.sqrt(x * x + y * y)
    return cx + rho * x / n, cy + rho * y / n


@inner_kernel(error_model="numpy")
def _inside(circ, j, x, y):
    """Whether (x, y) lies strictly inside disk j of ``circ``."""
    dx = circ[j, 0] - x
    dy = circ[j, 1] - y
    return dx * dx + dy * dy < circ[j, 2] * circ[j, 2]


@inner_kernel(error_model="numpy")
def _first_stretch(cover):
    """The first unmarked bin of ``cover`` after a marked one (bin 0 when none is marked)
    and the end of the stretch of unmarked bins from it, at most a quarter turn on (may
    pass _BINS: bins wrap round); (-1, -1) when every bin is marked."""
    first = 0
    some = _next_bin(cover, np.int64(0), np.bool_(True))
    if some < _BINS:
        first = _next_bin(cover, some, np.bool_(False))
        if first == _BINS:
            first = _next_bin(cover, np.int64(0), np.bool_(False))
            if first == _BINS:
                return -1, -1
    end = _next_bin(cover, first + 1, np.bool_(True)) if first + 1 < _BINS else _BINS
    if end == _BINS:
        end = _BINS + _next_bin(cover, np.int64(0), np.bool_(True))
    return first, min(end, first + _BINS // 4)


#: how many disks :func:`_surely_covered` chooses, and the probes of a stretch it looks at
_GAP_TRIES = 8
_PROBES = 5


# called by its one caller, _free_arc_points, once per circle visited
@inner_kernel(error_model="numpy")
def _surely_covered(cx, cy, rho, in_limit, circ, skip, a_max, cover, px, py):
    """True only if the circle (cx, cy, rho) has no free arc for :func:`_free_arc_points`
    (a cheap proof; False means: not proven).

    The circle is cut into bins of pseudo-angle; the disks mark the bins they surely
    cover (:func:`_mark`). All bins marked: covered. Deep in a crowded picture a circle
    meets dozens of disks, but two or three cover it, so the disks are chosen: the
    limit disc and the rows next to ``skip`` (the same obstacle at the neighbouring
    times) first, then, one at a time, the disk that holds the start of the first
    unmarked stretch (at most a quarter turn) and the most of its probe points after
    it. A stretch whose start lies in no disk, or whose first bin no disk spans, is
    left unproven (False at once: part of it is free, most likely); when a chosen disk
    marks nothing new, or after _GAP_TRIES disks, every disk in turn is marked until
    all bins are. Which disks are marked decides only how fast a covered circle is
    proven, never whether a circle with a free arc is called covered. px, py: scratch
    for the probe points (with fewer than _PROBES values, no disk is chosen).
    """
    M = circ.shape[0]
    for i in range(_WORDS):
        cover[i] = 0
    if in_limit:
        done = _mark(cx, cy, rho, circ, M, a_max, cover)
        if done == _ALL_OUTSIDE:
            return True
        if done == _UNPROVABLE:
            return False
    if skip >= 0:
        if skip >= 1:
            _mark(cx, cy, rho, circ, skip - 1, a_max, cover)
        if skip + 1 < M:
            _mark(cx, cy, rho, circ, skip + 1, a_max, cover)
    unit = 4.0 / _BINS
    for _ in range(_GAP_TRIES if min(px.shape[0], py.shape[0]) >= _PROBES else 0):
        first, end = _first_stretch(cover)
        if first < 0:
            return True
        # probes: the stretch's start, the end of its first bin, then on to its end
        px[0], py[0] = _on_circle(cx, cy, rho, first * unit)
        for k in range(1, _PROBES):
            at = first + 1 + (end - first - 1) * (k - 1) / (_PROBES - 2)
            px[k], py[k] = _on_circle(cx, cy, rho, at * unit)
        # the disk that holds the stretch's start and the most probes after it
        chosen = -1
        reach = 0
        for j in range(M):
            if j == skip or not _inside(circ, j, px[0], py[0]):
                continue
            k = 1
            while k < _PROBES and _inside(circ, j, px[k], py[k]):
                k += 1
            if k > reach:
                chosen = j
                reach = k
                if k == _PROBES:
                    break
        if chosen < 0:
            return False  # the start is free (or within rounding of a circle)
        if reach < 2:
            return False  # no disk spans the first bin: part of it is free, most likely
        if _mark(cx, cy, rho, circ, chosen, a_max, cover) != _MARKED:
            break
        if _next_bin(cover, first, np.bool_(True)) != first:
            break
    if _all_binned(cover):
        return True
    # every disk in turn (marking a bin twice changes nothing); stop once all is proven
    for j in range(M):
        if j == skip:
            continue
        if _mark(cx, cy, rho, circ, j, a_max, cover) == _MARKED and _all_binned(cover):
            return True
    return False


@inner_kernel(error_model="numpy")
def _all_binned(cover):
    """Whether the bit set ``cover`` marks every bin."""
    for i in range(_WORDS):
        if cover[i] != _FULL:
            return False
    return True


@inner_kernel(error_model="numpy")
def _free_arc_points(circle, in_limit, q, circ, skip, a_max, out, k, starts, ends, cover):
    """Append to ``out`` (from row k) the point nearest q of every free arc of the
    :class:`Circle` ``circle``: arcs no disk of ``circ`` (except row ``skip``) covers
    and, when ``in_limit``, inside the limit disc |a| <= a_max (m/s^2).
    Returns the new row count, or -1 when the whole circle is covered.
    starts/ends: scratch of at least 2 len(circ) + 4 rows; cover: _WORDS uint64.

    Most circles of a crowded picture are covered entirely: a cheap proof
    (:func:`_surely_covered`) skips the exact angles for them.
    """
    cx, cy, rho = circle
    q, circ, out = borrowed(q), borrowed(circ), borrowed(out)
    starts, ends, cover = borrowed(starts), borrowed(ends), borrowed(cover)
    M = circ.shape[0]
    if _surely_covered(cx, cy, rho, in_limit, circ, skip, a_max, cover, starts, ends):
        return k
    n = np.int64(0)
    for j in range(M + 1):
        n = _add_interval(cx, cy, rho, in_limit, circ, skip, a_max, j, starts, ends, n)
        if n < 0:
            return -1
    phi_q = math.atan2(q[1] - cy, q[0] - cx) % _TWO_PI
    if n == 0:
        out[k, 0] = cx + rho * math.cos(phi_q)
        out[k, 1] = cy + rho * math.sin(phi_q)
        return k + 1
    order = stable_argsort(starts[:n])
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


@inner_kernel(error_model="numpy")
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
    found = _nearest_outside(
        q,
        disks,
        a_max,
        within,
        covered,
        res,
        np.empty((2 * M + 8, 2)),
        np.empty(2 * M + 4),
        np.empty(2 * M + 4),
        np.empty(_WORDS, dtype=np.uint64),
    )
    return res[:found].copy()


@inner_kernel(error_model="numpy")
def _nearest_outside(q, disks, a_max, within, covered, res, cand, starts, ends, cover):
    """:func:`nearest_outside_disks` into ``res`` (max_out, 3), filled with inf; returns how
    many rows hold candidates. Scratch arrays given (borrowed here)."""
    q, disks, res, cand = borrowed(q), borrowed(disks), borrowed(res), borrowed(cand)
    starts, ends, cover = borrowed(starts), borrowed(ends), borrowed(cover)
    max_out = res.shape[0]
    lower = np.empty(disks.shape[0] + 1)
    order, scale = outside_setup(q, disks, a_max, within, res, lower)
    outside_advance(
        q,
        disks,
        a_max,
        covered,
        OutsideSearch(res, lower, order, scale, cand, starts, ends, cover),
        np.int64(0),
        max_out,
    )
    return outside_found(res, within)


@inner_kernel(error_model="numpy")
def outside_found(res, within):
    """How many leading rows of ``res`` hold candidates within ``within`` (m/s^2)."""
    found = 0
    while found < res.shape[0] and res[found, 2] <= within and res[found, 2] < math.inf:
        found += 1
    return found


@inner_kernel(error_model="numpy")
def outside_setup(q, disks, a_max, within, res, lower):
    """Start :func:`nearest_outside_disks` (res (max_out, 3) filled with inf, lower (M + 1,)
    scratch): the candidate bound set just above ``within``, q itself as a candidate when
    no disk contains it, lower[i] the distance (m/s^2) from q to circle i (the limit
    circle last). Returns (the circles' visiting order, the scale (m/s^2) of the
    coordinates: a bound for rounding in :func:`outside_advance`)."""
    M = disks.shape[0]
    # candidates farther than ``within`` are never kept: start the bound just above it
    above = np.nextafter(within, math.inf)
    for k in range(res.shape[0]):
        res[k, 2] = above
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
        scale = max(
            scale, abs(q[0]) + abs(q[1]) + abs(disks[i, 0]) + abs(disks[i, 1]) + abs(disks[i, 2])
        )
    lower[M] = abs(vector_norm(q[0], q[1]) - a_max)
    order = stable_argsort(lower)
    return order, scale


@inner_kernel(error_model="numpy")
def outside_advance(q, disks, a_max, covered, search, oi, row):
    """Visit the circles order[oi:] of the :class:`~.bundles.OutsideSearch` ``search``
    (:func:`outside_setup`; q (2,) m/s^2, disks (M, 3) m/s^2, a_max m/s^2, covered m/s^2
    as :func:`nearest_outside_disks` takes them) as :func:`nearest_outside_disks` does,
    inserting their free-arc points into its rows ``res`` = search.out, but only until
    row ``row`` of ``res`` is final: every circle left is farther from q than that row's
    candidate by far more than rounding (a point of a circle is at least its ``lower``
    from q), so no later candidate can come before it (row >= max_out: until the end).
    Returns the position in ``order`` to resume from (len(order): nothing is left to
    visit)."""
    res, lower, order, scale, cand, starts, ends, cover = search
    q, disks, res, lower, order = (
        borrowed(q),
        borrowed(disks),
        borrowed(res),
        borrowed(lower),
        borrowed(order),
    )
    cand, starts, ends, cover = borrowed(cand), borrowed(starts), borrowed(ends), borrowed(cover)
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
        # circle i: disk i, or (i = M) the limit circle, which skips no disk
        cx, cy, rho, skip = (
            (disks[i, 0], disks[i, 1], disks[i, 2], i) if i < M else (0.0, 0.0, a_max, -1)
        )
        k = _free_arc_points(
            Circle(cx, cy, rho),
            i < M,
            q,
            disks,
            skip,
            a_max,
            cand,
            np.int64(0),
            starts,
            ends,
            cover,
        )
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
