"""Exact minimum distance on one piece: |A s^2 + B s + C|^2 over s in [0, h].

On every piece the relative position d(s) of robot and obstacle is a quadratic
in s, so |d|^2 is a quartic whose stationary points are the roots of a cubic.
:func:`piece_minimum` splits the piece at the roots of that cubic's derivative
into intervals where the cubic is monotone, locates its sign changes by
safeguarded Newton iteration, and so gets the exact minimum (and the first
time |d| <= r) to float precision, not just at sample times.
"""

from __future__ import annotations

import math

from nao_arena.jit import inner_kernel

_NEWTON_ITERS = 200


@inner_kernel(error_model="numpy")
def _cubic(s, c3, c2, c1, c0):
    return ((c3 * s + c2) * s + c1) * s + c0


@inner_kernel(error_model="numpy")
def _dist2(s, ax, ay, bx, by, cx, cy):
    dx = (ax * s + bx) * s + cx
    dy = (ay * s + by) * s + cy
    return dx * dx + dy * dy


@inner_kernel(error_model="numpy")
def _root_increasing(lo, hi, c3, c2, c1, c0):
    """Root of the cubic on [lo, hi] where it rises from < 0 to > 0."""
    s = 0.5 * (lo + hi)
    for _ in range(_NEWTON_ITERS):
        g = _cubic(s, c3, c2, c1, c0)
        if g > 0.0:
            hi = s
        else:
            lo = s
        dg = (3.0 * c3 * s + 2.0 * c2) * s + c1
        step_ok = False
        if dg > 0.0:
            sn = s - g / dg
            if lo < sn < hi:
                step_ok = True
        if not step_ok:
            sn = 0.5 * (lo + hi)
        if abs(sn - s) <= 1e-15 * (1.0 + abs(s)):
            return sn
        s = sn
    return s


@inner_kernel(error_model="numpy")
def _crossing(lo, hi, r2, ax, ay, bx, by, cx, cy):
    """First s in [lo, hi] with |d(s)|^2 <= r2, |d|^2 decreasing on the interval."""
    for _ in range(_NEWTON_ITERS):
        mid = 0.5 * (lo + hi)
        if _dist2(mid, ax, ay, bx, by, cx, cy) <= r2:
            hi = mid
        else:
            lo = mid
        if hi - lo <= 1e-14 * (1.0 + hi):
            break
    return hi


@inner_kernel(error_model="numpy")
def piece_minimum(ax, ay, bx, by, cx, cy, h, r2, want_first, out):
    """Minimum of |A s^2 + B s + C|^2 over s in [0, h] (h may be inf).

    Writes out[0] = min |d|^2, out[1] = its s, out[2] = first s with
    |d|^2 <= r2 (inf if none or if not wanted).
    """
    aa = ax * ax + ay * ay
    ab = ax * bx + ay * by
    bb = bx * bx + by * by
    ac = ax * cx + ay * cy
    bc = bx * cx + by * cy
    cc = cx * cx + cy * cy
    out[2] = math.inf
    if want_first and cc <= r2:
        out[2] = 0.0
    # d/ds |d|^2 = 2 g(s), g cubic
    c3 = 2.0 * aa
    c2 = 3.0 * ab
    c1 = bb + 2.0 * ac
    c0 = bc
    scale = aa + bb + cc
    if aa <= 1e-30 * scale:
        # linear relative motion: |d|^2 is a quadratic in s
        if bb <= 1e-300:
            out[0] = cc
            out[1] = 0.0
            return
        s = -bc / bb
        if s < 0.0:
            s = 0.0
        if s > h:
            s = h
        # from the components: the expanded form cancels to < 0 near a hit
        f = _dist2(s, 0.0, 0.0, bx, by, cx, cy)
        out[0] = f
        out[1] = s
        if want_first and out[2] > 0.0 and f <= r2:
            out[2] = _crossing(0.0, s, r2, 0.0, 0.0, bx, by, cx, cy)
        return
    hh = h
    if not math.isfinite(hh):
        # every root of g lies below the Cauchy bound
        hh = 1.0 + max(abs(c2), abs(c1), abs(c0)) / c3
        hh = hh * 2.0
    # breakpoints 0 <= b1 <= b2 <= hh: roots of g' = 3 c3 s^2 + 2 c2 s + c1
    b1 = 0.0
    b2 = 0.0
    qa = 3.0 * c3
    qb = 2.0 * c2
    qc = c1
    disc = qb * qb - 4.0 * qa * qc
    if disc > 0.0:
        sq = math.sqrt(disc)
        q = -0.5 * (qb + sq) if qb >= 0.0 else -0.5 * (qb - sq)
        r1 = q / qa
        r2_ = qc / q if q != 0.0 else r1
        b1 = min(max(min(r1, r2_), 0.0), hh)
        b2 = min(max(max(r1, r2_), 0.0), hh)
    best = cc
    best_s = 0.0
    fe = _dist2(hh, ax, ay, bx, by, cx, cy)
    if math.isfinite(h) and fe < best:
        best = fe
        best_s = hh
    first = out[2]
    for i in range(3):
        if i == 0:
            p = 0.0
            q = b1
        elif i == 1:
            p = b1
            q = b2
        else:
            p = b2
            q = hh
        if q <= p:
            continue
        gp = _cubic(p, c3, c2, c1, c0)
        gq = _cubic(q, c3, c2, c1, c0)
        if gp < 0.0 and gq > 0.0:
            m = _root_increasing(p, q, c3, c2, c1, c0)
            fm = _dist2(m, ax, ay, bx, by, cx, cy)
            if fm < best:
                best = fm
                best_s = m
            if want_first and first == math.inf and fm <= r2:
                first = _crossing(p, m, r2, ax, ay, bx, by, cx, cy)
        elif want_first and first == math.inf and gp <= 0.0 and gq <= 0.0:
            # |d|^2 non-increasing on [p, q]
            if _dist2(q, ax, ay, bx, by, cx, cy) <= r2:
                first = _crossing(p, q, r2, ax, ay, bx, by, cx, cy)
        elif want_first and first == math.inf and gp > 0.0 and gq < 0.0:
            # rises to a maximum, then falls: only the falling part can cross
            if _dist2(q, ax, ay, bx, by, cx, cy) <= r2:
                m = -_root_increasing(-q, -p, -c3, c2, -c1, c0)
                first = _crossing(m, q, r2, ax, ay, bx, by, cx, cy)
    if want_first and first == math.inf and math.isfinite(h) and fe <= r2:
        first = _crossing(0.0, hh, r2, ax, ay, bx, by, cx, cy)
    out[0] = best
    out[1] = best_s
    out[2] = first


@inner_kernel(error_model="numpy")
def end_dist2(ax, ay, bx, by, cx, cy, h):
    """The smaller of |A s^2 + B s + C|^2 at s = 0 and s = h (when finite): the minimum
    :func:`piece_minimum` finds is at most this (it starts from these same two values)."""
    d0 = cx * cx + cy * cy
    if not math.isfinite(h):
        return d0
    return min(d0, _dist2(h, ax, ay, bx, by, cx, cy))
