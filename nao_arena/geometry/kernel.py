"""Compiled kernel: exact minimum distance between a robot driving a constant
acceleration and an obstacle on a piecewise-quadratic path.

Frame: the robot starts at the origin at t = 0. On every piece the relative
position d(s) = x(t0 + s) - c(t0 + s) is a quadratic in s, so |d|^2 is a
quartic whose stationary points are the roots of a cubic. The kernel splits
each piece at the roots of that cubic's derivative into intervals where the
cubic is monotone, locates its sign changes by safeguarded Newton iteration,
and so gets the exact minimum (and the first time |d| <= r) to float
precision, not just at sample times.

Robot path (the model the world implements): x(t) = v t + a t^2 / 2 until the
speed |v + a t| reaches v_max (time tau), then constant velocity. A robot
already above v_max starts from its velocity scaled down to v_max.

Everything here is numba-compiled; the public wrappers live in
:mod:`nao_arena.geometry.clearance`. The loops that run per candidate borrow
their array arguments (:mod:`nao_arena.geometry.borrow`: no reference counting
per call) and get their scratch arrays from thin wrappers.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nao_arena.geometry.borrow import borrowed

_NEWTON_ITERS = 200


@njit(cache=True, error_model="numpy", inline="always")
def _cubic(s, c3, c2, c1, c0):
    return ((c3 * s + c2) * s + c1) * s + c0


@njit(cache=True, error_model="numpy", inline="always")
def _dist2(s, ax, ay, bx, by, cx, cy):
    dx = (ax * s + bx) * s + cx
    dy = (ay * s + by) * s + cy
    return dx * dx + dy * dy


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _piece(ax, ay, bx, by, cx, cy, h, r2, want_first, out):
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


@njit(cache=True, error_model="numpy")
def _saturation_time(vx, vy, ax, ay, v_max):
    """Time at which |v + a t| reaches v_max (inf if never); |v| <= v_max."""
    if not math.isfinite(v_max):
        return math.inf
    a2 = ax * ax + ay * ay
    if a2 == 0.0:
        return math.inf
    va = vx * ax + vy * ay
    c = vx * vx + vy * vy - v_max * v_max
    if c > 0.0:
        c = 0.0
    # positive root of a2 t^2 + 2 va t + c = 0
    disc = va * va - a2 * c
    if disc < 0.0:
        disc = 0.0
    sq = math.sqrt(disc)
    if va >= 0.0:
        # numerically stable form of (-va + sq) / a2
        den = va + sq
        return -c / den if den > 0.0 else 0.0
    return (sq - va) / a2


@njit(cache=True, error_model="numpy", inline="always")
def _robot_state(vx, vy, ax, ay, tau, ta):
    """Robot (acceleration, velocity, position) at time ta under the saturation model."""
    if ta < tau:
        return (
            ax, ay, vx + ax * ta, vy + ay * ta,
            vx * ta + 0.5 * ax * ta * ta, vy * ta + 0.5 * ay * ta * ta,
        )
    wx = vx + ax * tau
    wy = vy + ay * tau
    return (
        0.0, 0.0, wx, wy,
        vx * tau + 0.5 * ax * tau * tau + wx * (ta - tau),
        vy * tau + 0.5 * ay * tau * tau + wy * (ta - tau),
    )


@njit(cache=True, error_model="numpy", inline="always")
def _scan(vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c, seg_w, seg_b, sweep, n, r,
          thresh, want_first, buf, out):
    """Scan obstacle n over all pieces for one robot candidate.

    With a finite ``thresh`` (m) the scan only decides whether the clearance
    falls below it: it prunes pieces that cannot come that close and returns
    at the first that does (out[0] is then some distance below thresh + r) with that
    piece's index (else -1). Otherwise out = (min squared distance, its time, first contact
    time), and it returns -1.
    """
    S = seg_c.shape[1]
    r2 = r * r
    best = math.inf
    best_t = 0.0
    first = math.inf
    decide = math.isfinite(thresh)
    reach = r + thresh if decide else 0.0
    reach2 = reach * reach
    for j in range(S):
        t0 = seg_t[j]
        t1 = seg_t[j + 1]
        if decide and _piece_out_of_reach(vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c,
                                          sweep, n, j, reach):
            continue
        ta = t0
        while ta < t1:
            tb = min(t1, tau) if ta < tau else t1
            Ax, Ay, Bx, By, Cx, Cy = _relative(vx, vy, ax, ay, tau, ta, t0, seg_c, seg_w,
                                               seg_b, n, j)
            hp = tb - ta
            skip = False
            if math.isfinite(hp) and not decide:
                lb = (
                    math.sqrt(Cx * Cx + Cy * Cy)
                    - math.sqrt(Bx * Bx + By * By) * hp
                    - math.sqrt(Ax * Ax + Ay * Ay) * hp * hp
                )
                if lb > 0.0:
                    lb2 = lb * lb
                    if lb2 >= best and (lb2 > r2 or first < math.inf):
                        skip = True
            end = _end_dist2(Ax, Ay, Bx, By, Cx, Cy, hp) if decide else math.inf
            if end < reach2:
                # an end of the sub-piece is already that close: no minimum needed
                out[0] = end
                out[1] = ta
                out[2] = first
                return j
            if not skip:
                _piece(Ax, Ay, Bx, By, Cx, Cy, hp, r2, want_first and first == math.inf, buf)
                if buf[0] < best:
                    best = buf[0]
                    best_t = ta + buf[1]
                if want_first and first == math.inf and buf[2] < math.inf:
                    first = ta + buf[2]
                if decide and best < reach2:
                    out[0] = best
                    out[1] = best_t
                    out[2] = first
                    return j
            ta = tb
    if best == math.inf and not decide:
        # an empty horizon [0, 0]: just the distance at the start
        best = seg_c[n, 0, 0] ** 2 + seg_c[n, 0, 1] ** 2
        if want_first and best <= r2:
            first = 0.0
    out[0] = best
    out[1] = best_t
    out[2] = first
    return -1


@njit(cache=True, error_model="numpy", inline="always")
def _piece_out_of_reach(vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c, sweep, n, j, reach):
    """Cheap prune: whether robot and obstacle n are so far apart at the start of piece j
    (finite) that they cannot come within ``reach`` (m) during it: the robot moves at most
    speed_bound (m/s) times the piece's length, the obstacle at most sweep[n, j] (m)."""
    h = seg_t[j + 1] - seg_t[j]
    if not math.isfinite(h):
        return False
    rax, ray, rvx, rvy, rpx, rpy = _robot_state(vx, vy, ax, ay, tau, seg_t[j])
    cx = rpx - seg_c[n, j, 0]
    cy = rpy - seg_c[n, j, 1]
    bound = (reach + sweep[n, j] + speed_bound * h) * (1.0 + 1e-9)
    return cx * cx + cy * cy > bound * bound


@njit(cache=True, error_model="numpy", inline="always")
def _relative(vx, vy, ax, ay, tau, ta, t0, seg_c, seg_w, seg_b, n, j):
    """Robot minus obstacle n from time ta within piece j (which starts at t0), as
    A s^2 + B s + C (s = time since ta): (Ax, Ay, Bx, By, Cx, Cy)."""
    rax, ray, rvx, rvy, rpx, rpy = _robot_state(vx, vy, ax, ay, tau, ta)
    dt0 = ta - t0
    obx = seg_b[n, j, 0]
    oby = seg_b[n, j, 1]
    return (0.5 * (rax - obx), 0.5 * (ray - oby),
            rvx - (seg_w[n, j, 0] + obx * dt0), rvy - (seg_w[n, j, 1] + oby * dt0),
            rpx - (seg_c[n, j, 0] + seg_w[n, j, 0] * dt0 + 0.5 * obx * dt0 * dt0),
            rpy - (seg_c[n, j, 1] + seg_w[n, j, 1] * dt0 + 0.5 * oby * dt0 * dt0))


@njit(cache=True, error_model="numpy", inline="always")
def _end_dist2(ax, ay, bx, by, cx, cy, h):
    """The smaller of |A s^2 + B s + C|^2 at s = 0 and s = h (when finite): the minimum
    :func:`_piece` finds is at most this (it starts from these same two values)."""
    d0 = cx * cx + cy * cy
    if not math.isfinite(h):
        return d0
    return min(d0, _dist2(h, ax, ay, bx, by, cx, cy))


@njit(cache=True, error_model="numpy", inline="always")
def _piece_within(vx, vy, ax, ay, tau, seg_t, seg_c, seg_w, seg_b, n, j, reach2, buf):
    """Whether the candidate (as in :func:`_scan`) comes closer than sqrt(reach2) (m) to
    obstacle n during piece j: the test :func:`_scan` makes there, without its prune."""
    t0 = seg_t[j]
    t1 = seg_t[j + 1]
    ta = t0
    while ta < t1:
        tb = min(t1, tau) if ta < tau else t1
        Ax, Ay, Bx, By, Cx, Cy = _relative(vx, vy, ax, ay, tau, ta, t0, seg_c, seg_w, seg_b,
                                           n, j)
        if _end_dist2(Ax, Ay, Bx, By, Cx, Cy, tb - ta) < reach2:
            return True
        _piece(Ax, Ay, Bx, By, Cx, Cy, tb - ta, 0.0, False, buf)
        if buf[0] < reach2:
            return True
        ta = tb
    return False


@njit(cache=True, error_model="numpy")
def _candidate_setup(vx, vy, ax, ay, v_max, horizon):
    """Speed-clamped initial velocity, saturation time and a bound on the speed (m/s)."""
    spd = math.sqrt(vx * vx + vy * vy)
    if spd > v_max:
        vx *= v_max / spd
        vy *= v_max / spd
        spd = v_max
    tau = _saturation_time(vx, vy, ax, ay, v_max)
    amag = math.sqrt(ax * ax + ay * ay)
    # |v + a t| is convex in t, so up to tau it stays below max(|v|, v_max) = v_max
    bound = min(spd + amag * min(tau, horizon), v_max * (1.0 + 1e-9))
    return vx, vy, tau, bound


@njit(cache=True, error_model="numpy")
def piece_sweep(seg_t, seg_w, seg_b):
    """(N, S) bound on how far each obstacle moves within each piece (m)."""
    out = np.empty((seg_w.shape[0], seg_w.shape[1]))
    _fill_sweep(seg_t, seg_w, seg_b, seg_w.shape[0], out)
    return out


@njit(cache=True, error_model="numpy", inline="always")
def _fill_sweep(seg_t, seg_w, seg_b, rows, out):
    """:func:`piece_sweep` of the first ``rows`` obstacles, into out[:rows]."""
    for n in range(rows):
        for j in range(seg_w.shape[1]):
            h = seg_t[j + 1] - seg_t[j]
            w = math.sqrt(seg_w[n, j, 0] ** 2 + seg_w[n, j, 1] ** 2)
            b = math.sqrt(seg_b[n, j, 0] ** 2 + seg_b[n, j, 1] ** 2)
            out[n, j] = w * h + 0.5 * b * h * h


@njit(cache=True, error_model="numpy")
def clearance_kernel(
    cand_v, cand_a, v_max, seg_t, seg_c, seg_w, seg_b, radius, out_clear, out_tmin, out_tfirst,
):
    """Exact clearance for K candidates x N obstacles.

    cand_v, cand_a: (K, 2) initial velocity (m/s) and constant acceleration
    (m/s^2) of the robot per candidate. seg_t: (S + 1,) piece boundaries (s),
    seg_t[0] = 0, last may be inf. seg_c, seg_w, seg_b: (N, S, 2) obstacle
    centre (m, relative to the robot's start), velocity and acceleration at
    the start of each piece. radius: (N,) combined radius (m).
    Outputs (K, N): clearance (m), time of closest approach (s), time of
    first contact (s, inf if none).
    """
    K = cand_a.shape[0]
    N = seg_c.shape[0]
    sweep = np.zeros((N, seg_c.shape[1]))
    buf = np.empty(3)
    out = np.empty(3)
    for k in range(K):
        vx, vy, tau, bound = _candidate_setup(
            cand_v[k, 0], cand_v[k, 1], cand_a[k, 0], cand_a[k, 1], v_max, seg_t[-1]
        )
        for n in range(N):
            _scan(vx, vy, cand_a[k, 0], cand_a[k, 1], tau, bound, seg_t, seg_c, seg_w, seg_b,
                  sweep, n, radius[n], math.inf, True, buf, out)
            out_clear[k, n] = math.sqrt(out[0]) - radius[n]
            out_tmin[k, n] = out[1]
            out_tfirst[k, n] = out[2]


@njit(cache=True, error_model="numpy")
def admissible_kernel(cand_v, cand_a, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep, margin,
                      out_ok):
    """out_ok[k] = True iff candidate k keeps clearance >= margin (m) from every obstacle.

    Prunes pieces with a conservative distance bound and stops at the first
    violation, so it is much cheaper than the exact clearance.
    """
    K = cand_a.shape[0]
    N = seg_c.shape[0]
    buf = np.empty(3)
    out = np.empty(3)
    for k in range(K):
        vx, vy, tau, bound = _candidate_setup(
            cand_v[k, 0], cand_v[k, 1], cand_a[k, 0], cand_a[k, 1], v_max, seg_t[-1]
        )
        ok = True
        for n in range(N):
            _scan(vx, vy, cand_a[k, 0], cand_a[k, 1], tau, bound, seg_t, seg_c, seg_w, seg_b,
                  sweep, n, radius[n], margin, False, buf, out)
            if out[0] < (radius[n] + margin) ** 2:
                ok = False
                break
        out_ok[k] = ok


@njit(cache=True, error_model="numpy", inline="always")
def _relevant(vx, vy, a_max, v_max, seg_t, seg_c, seg_w, seg_b, n, r):
    """Whether obstacle n (combined radius r, m) is within reach: see
    :func:`relevant_obstacles` (v already clamped to v_max)."""
    for j in range(seg_c.shape[1]):
        if _piece_relevant(seg_c[n, j, 0], seg_c[n, j, 1], seg_w[n, j, 0], seg_w[n, j, 1],
                           seg_b[n, j, 0], seg_b[n, j, 1], seg_t[j], seg_t[j + 1], vx, vy, a_max,
                           v_max, r):
            return True
    return False


@njit(cache=True, error_model="numpy", inline="always")
def _piece_relevant(cx, cy, wx, wy, bx, by, t0, t1, vx, vy, a_max, v_max, r):
    """Whether the robot (velocity v m/s, limits a_max, v_max) could come within r (m) of
    an obstacle during the piece [t0, t1] s that starts at (cx, cy) m with velocity
    (wx, wy) m/s and acceleration (bx, by) m/s^2: |x(t) - v t| <= a_max t^2 / 2 and
    |x(t)| <= v_max t must both allow it (see :func:`relevant_obstacles`). A piece of
    infinite length always may. Branch-free, so loops over pieces vectorise."""
    h = t1 - t0
    dx = cx - vx * t0
    dy = cy - vy * t0
    bb = math.sqrt(bx ** 2 + by ** 2)
    reach = r + 0.5 * a_max * t1 * t1 + math.sqrt((wx - vx) ** 2 + (wy - vy) ** 2) * h \
        + 0.5 * bb * h * h
    own = r + v_max * t1 + math.sqrt(wx ** 2 + wy ** 2) * h + 0.5 * bb * h * h
    near = not (dx * dx + dy * dy > reach * reach)
    close = cx * cx + cy * cy <= own * own
    return (not math.isfinite(h)) | (near & ((not math.isfinite(v_max)) | close))


@njit(cache=True, error_model="numpy", inline="always")
def _clamped(v, v_max):
    vx = v[0]
    vy = v[1]
    spd = math.sqrt(vx * vx + vy * vy)
    if spd > v_max:
        vx *= v_max / spd
        vy *= v_max / spd
    return vx, vy


@njit(cache=True, error_model="numpy")
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
    vx, vy = _clamped(v, v_max)
    out = np.zeros(N, dtype=np.bool_)
    for n in range(N):
        out[n] = _relevant(vx, vy, a_max, v_max, seg_t, seg_c, seg_w, seg_b, n,
                           radius[n] + margin)
    return out


@njit(cache=True, error_model="numpy", inline="always")
def _moving_pieces(pred, body, px, py, times, c, w, row):
    """Write into c, w [row] the pieces of body's sampled centres pred[body] (T, 2) m,
    relative to (px, py): start centres (m) and velocities (m/s), as
    :func:`~nao_arena.geometry.clearance.sampled_path` builds them."""
    for j in range(times.shape[0] - 1):
        _moving_piece(pred, body, px, py, times, c, w, row, j)


@njit(cache=True, error_model="numpy", inline="always")
def _moving_piece(pred, body, px, py, times, c, w, row, j):
    """Piece j of :func:`_moving_pieces` into c, w [row, j]; returns it: (start centre m,
    velocity m/s)."""
    x0 = pred[body, j, 0] - px
    y0 = pred[body, j, 1] - py
    h = times[j + 1] - times[j]
    wx = (pred[body, j + 1, 0] - px - x0) / h
    wy = (pred[body, j + 1, 1] - py - y0) / h
    c[row, j, 0] = x0
    c[row, j, 1] = y0
    w[row, j, 0] = wx
    w[row, j, 1] = wy
    return x0, y0, wx, wy


@njit(cache=True, error_model="numpy", inline="always")
def _moving_relevant(pred, body, px, py, times, c, w, row, vx, vy, a_max, v_max, r):
    """:func:`_moving_pieces` into row ``row``, and whether one of those pieces is relevant
    (:func:`_piece_relevant`, radius r m: what :func:`_relevant` answers), in one pass with
    no early exit (the compiler vectorises it; most obstacles tested are not relevant)."""
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
        x0, y0, wx, wy = _moving_piece(pred, body, px, py, times, c, w, row, j)
        hit = hit | _piece_relevant(x0, y0, wx, wy, 0.0, 0.0, times[j], times[j + 1], vx, vy,
                                    a_max, v_max, r)
    return hit


@njit(cache=True, error_model="numpy", inline="always")
def _static_pieces(x0, y0, times, c, w, row):
    """Write into c, w [row] the pieces of a disc at rest at (x0, y0) m (robot-relative),
    as :func:`~nao_arena.geometry.clearance.sampled_path` builds them."""
    for j in range(times.shape[0] - 1):
        dt = times[j + 1] - times[j]
        c[row, j, 0] = x0
        c[row, j, 1] = y0
        w[row, j, 0] = (x0 - x0) / dt
        w[row, j, 1] = (y0 - y0) / dt


@njit(cache=True, error_model="numpy")
def relevant_sampled_paths(times, pred, idx, position, nb_radius, grow, wall_rel, wall_r, v,
                           a_max, v_max, excursion, finite_path):
    """The pieces :func:`~nao_arena.geometry.clearance.sampled_path` builds, of the
    obstacles :func:`relevant_obstacles` keeps (margin 0), in one pass.

    Obstacles: the bodies ``idx`` with world-frame centres pred[body] (T, 2) m at
    ``times`` (s; times[0] = 0, increasing, T >= 2) and radii nb_radius[body] + grow
    (m), then static discs at wall_rel (robot-relative, m) with radii wall_r (m); every
    radius cut to just under the obstacle's current distance (RADIUS_CUT). Centres
    are taken relative to ``position`` (m). Robot: velocity v (m/s), limits a_max,
    v_max. excursion, finite_path: :func:`path_excursions` of ``pred``.
    Returns (c, w, b, radius, finite): the pieces' start centres, velocities
    and accelerations (zero) (n, T - 1, 2) and radii (n,) of the kept obstacles in
    input order; finite is
    False (and nothing is kept) when a neighbour's centres are not all finite.
    """
    S = times.shape[0] - 1
    total = idx.shape[0] + wall_rel.shape[0]
    c = np.empty((total, S, 2))
    w = np.empty((total, S, 2))
    b = np.zeros((total, S, 2))
    rad = np.empty(total)
    n = _fill_relevant_paths(times, pred, idx, position, nb_radius, grow, wall_rel, wall_r, v,
                             a_max, v_max, excursion, finite_path, c, w, b, rad)
    if n < 0:
        return c[:0], w[:0], b[:0], rad[:0], False
    return c[:n], w[:n], b[:n], rad[:n], True


@njit(cache=True, error_model="numpy")
def _fill_relevant_paths(times, pred, idx, position, nb_radius, grow, wall_rel, wall_r, v, a_max,
                         v_max, excursion, finite_path, c, w, b, rad):
    """:func:`relevant_sampled_paths` into c, w, b, rad (rows for every obstacle given):
    returns how many rows it kept, -1 when a neighbour's centres are not all finite.
    Arrays borrowed here."""
    times, pred, idx, position = borrowed(times), borrowed(pred), borrowed(idx), borrowed(position)
    nb_radius, wall_rel = borrowed(nb_radius), borrowed(wall_rel)
    wall_r, v = borrowed(wall_r), borrowed(v)
    excursion, finite_path = borrowed(excursion), borrowed(finite_path)
    c, w, b, rad = borrowed(c), borrowed(w), borrowed(b), borrowed(rad)
    n_nb = idx.shape[0]
    total = n_nb + wall_rel.shape[0]
    for i in range(n_nb):
        if not finite_path[idx[i]]:
            return -1
    vx, vy = _clamped(v, v_max)
    px = position[0]
    py = position[1]
    # |x(t)| <= v_max t: an obstacle that stays farther than v_max times the horizon
    # (plus its radius) is dropped before its pieces are built
    travel = v_max * times[-1]
    n = 0
    for i in range(total):
        if i < n_nb:
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
            if _moving_relevant(pred, body, px, py, times, c, w, n, vx, vy, a_max, v_max, r):
                n += 1
        else:
            d = i - n_nb
            x0 = wall_rel[d, 0]
            y0 = wall_rel[d, 1]
            dist = math.sqrt(x0 * x0 + y0 * y0)
            r = min(wall_r[d], dist * RADIUS_CUT)
            if dist > (r + travel) * (1.0 + 1e-9) + 1e-12:
                continue
            _static_pieces(x0, y0, times, c, w, n)
            rad[n] = r
            if _relevant(vx, vy, a_max, v_max, times, c, w, b, n, r):
                n += 1
    return n


@njit(cache=True, error_model="numpy", inline="always")
def _norm(x, y):
    """sqrt(x^2 + y^2), without math.hypot's care for overflow (several times faster;
    the values here are accelerations and distances of ordinary size)."""
    return math.sqrt(x * x + y * y)


@njit(cache=True, error_model="numpy", inline="always")
def _farther(x, y, lim):
    """math.hypot(x, y) > lim, without the hypot unless the answer is close."""
    d2 = x * x + y * y
    l2 = lim * lim
    if d2 > l2 * (1.0 + 1e-9):
        return True
    if d2 < l2 * (1.0 - 1e-9):
        return False
    return math.hypot(x, y) > lim


@njit(cache=True, error_model="numpy")
def _samples_in_piece(t0, t1, n_sub, per_second):
    if not math.isfinite(t1):
        return 12
    return max(n_sub, min(256, int(math.ceil(per_second * (t1 - t0)))))


@njit(cache=True, error_model="numpy", inline="always")
def _put(out, row, x, y, rho, dq):
    """Write the disk (x, y, rho, dq) into out[row]; returns the next row."""
    out[row, 0] = x
    out[row, 1] = y
    out[row, 2] = rho
    out[row, 3] = dq
    return row + 1


@njit(cache=True, error_model="numpy")
def nao_disk_samples(v, seg_t, seg_c, seg_w, seg_b, radius, margin, n_sub, q, reach, a_max,
              per_second=16.0, thin=0.0):
    """The sampled disks of :func:`nao_disks` before containment is filtered:
    (M, 4) rows (m_x, m_y, rho, distance of m from q), m/s^2 — for
    :func:`nao_disks_within`, which gives nao_disks for any smaller reach.

    Sampled disks of the NAO union near q, in acceleration space (m/s^2).

    A constant acceleration a collides with an obstacle at time t iff
    |a - m(t)| <= rho(t), m(t) = 2 (c(t) - v t) / t^2, rho(t) = 2 r / t^2
    (no speed saturation). Samples every piece at max(n_sub, per_second * h)
    times (and the first piece also geometrically towards t = 0), grows r by
    ``margin`` and keeps the disks that intersect both the ball B(q, reach)
    and the limit disc |a| <= a_max.

    thin (m/s^2): when > 0, a disk is left out while its centre lies within
    sqrt(8 thin rho) of the obstacle's last kept disk (whose radius is at least
    rho): two kept disks that far apart leave a sliver at most about ``thin``
    deep. The obstacle's last disk before a gap (a disk outside the ball or the
    limit disc) and at the end of the horizon is always kept.
    """
    N = seg_c.shape[0]
    S = seg_c.shape[1]
    total = 0
    for j in range(S):
        total += _samples_in_piece(seg_t[j], seg_t[j + 1], n_sub, per_second) + 9
    out = np.empty((N * total, 4))
    return out[:_fill_disk_samples(v, seg_t, seg_c, seg_w, seg_b, radius, margin, n_sub, q,
                                   reach, a_max, per_second, thin, out)]


@njit(cache=True, error_model="numpy")
def _fill_disk_samples(v, seg_t, seg_c, seg_w, seg_b, radius, margin, n_sub, q, reach, a_max,
                       per_second, thin, out):
    """:func:`nao_disk_samples` into the rows of ``out``; returns how many it wrote.
    Arrays borrowed here."""
    v, seg_t, seg_c, seg_w = borrowed(v), borrowed(seg_t), borrowed(seg_c), borrowed(seg_w)
    seg_b, radius, q, out = borrowed(seg_b), borrowed(radius), borrowed(q), borrowed(out)
    N = seg_c.shape[0]
    S = seg_c.shape[1]
    cnt = 0
    for n in range(N):
        rr = radius[n] + margin
        last = -1  # row of the obstacle's last kept disk; -1: none (or a gap since)
        pend = False  # a disk was thinned out after it
        px = 0.0
        py = 0.0
        prho = 0.0
        pdq = 0.0
        for j in range(S):
            t0 = seg_t[j]
            t1 = seg_t[j + 1]
            if math.isfinite(t1):
                # a piece that no acceleration within a_max reaches: every sample of it
                # lies outside the limit disc (|c(t) - v t| > rr + a_max t^2 / 2), which
                # ends a run of disks (as the test below does for each sample)
                h = t1 - t0
                dx0 = seg_c[n, j, 0] - v[0] * t0
                dy0 = seg_c[n, j, 1] - v[1] * t0
                far = (rr + 0.5 * a_max * t1 * t1
                       + _norm(seg_w[n, j, 0] - v[0], seg_w[n, j, 1] - v[1]) * h
                       + 0.5 * _norm(seg_b[n, j, 0], seg_b[n, j, 1]) * h * h) * (1.0 + 1e-6)
                if dx0 * dx0 + dy0 * dy0 > far * far:
                    if pend:
                        cnt = _put(out, cnt, px, py, prho, pdq)
                        pend = False
                    last = -1
                    continue
            k = _samples_in_piece(t0, t1, n_sub, per_second)
            head = 8 if (j == 0 and math.isfinite(t1)) else 0
            tail = 1 if (j == S - 1 and math.isfinite(t1)) else 0
            for i in range(k + head + tail):
                if not math.isfinite(t1):
                    t = max(t0, 1e-3) * 2.0 ** (i + 1)
                elif i < head:
                    t = t1 * 2.0 ** (i - 8 - 1) * 2.0 / k
                elif i == k + head:
                    t = t1
                else:
                    t = t0 + (t1 - t0) * (i - head) / k
                if t * t <= 0.0 or not math.isfinite(2.0 / (t * t)):
                    continue
                dt = t - t0
                cx = seg_c[n, j, 0] + seg_w[n, j, 0] * dt + 0.5 * seg_b[n, j, 0] * dt * dt
                cy = seg_c[n, j, 1] + seg_w[n, j, 1] * dt + 0.5 * seg_b[n, j, 1] * dt * dt
                inv = 2.0 / (t * t)
                mx = (cx - v[0] * t) * inv
                my = (cy - v[1] * t) * inv
                rho = rr * inv
                if (_farther(mx - q[0], my - q[1], rho + reach)
                        or _farther(mx, my, rho + a_max)):
                    if pend:
                        cnt = _put(out, cnt, px, py, prho, pdq)
                        pend = False
                    last = -1
                    continue
                dq = _norm(mx - q[0], my - q[1])
                if thin > 0.0 and last >= 0:
                    ex = mx - out[last, 0]
                    ey = my - out[last, 1]
                    if ex * ex + ey * ey <= 8.0 * thin * rho:
                        pend = True
                        px = mx
                        py = my
                        prho = rho
                        pdq = dq
                        continue
                pend = False
                last = cnt
                cnt = _put(out, cnt, mx, my, rho, dq)
        if pend:
            cnt = _put(out, cnt, px, py, prho, pdq)
    return cnt


@njit(cache=True, error_model="numpy")
def nao_disks(v, seg_t, seg_c, seg_w, seg_b, radius, margin, n_sub, q, reach, a_max,
              per_second=16.0):
    """Sampled disks of the NAO union near q, in acceleration space (m/s^2).

    A constant acceleration a collides with an obstacle at time t iff
    |a - m(t)| <= rho(t), m(t) = 2 (c(t) - v t) / t^2, rho(t) = 2 r / t^2
    (no speed saturation). Samples every piece at max(n_sub, per_second * h)
    times (and the first piece also geometrically towards t = 0), grows r by
    ``margin`` and keeps the disks that intersect both the ball B(q, reach)
    and the limit disc |a| <= a_max; disks inside another are dropped.
    Returns (M, 3) rows (m_x, m_y, rho).
    """
    return _drop_contained(np.ascontiguousarray(nao_disk_samples(
        v, seg_t, seg_c, seg_w, seg_b, radius, margin, n_sub, q, reach, a_max, per_second,
    )[:, :3]))


@njit(cache=True, error_model="numpy")
def nao_disks_within(samples, reach):
    """:func:`nao_disks` for ``reach`` (m/s^2) from the samples of
    :func:`nao_disk_samples` taken with a reach at least as large."""
    return _disks_within(samples, _radius_order(samples), reach)


@njit(cache=True, error_model="numpy")
def _radius_order(rows):
    """Rows (disks or samples) largest radius first, equal radii in row order (a stable
    sort): the visiting order of :func:`_uncontained_in`, for any subset of the rows."""
    return np.argsort(-rows[:, 2], kind="mergesort")


@njit(cache=True, error_model="numpy")
def _disks_within(samples, order, reach):
    """:func:`nao_disks_within` with the samples' :func:`_radius_order` given."""
    keep, _ = _uncontained_in(samples, order, reach, samples.shape[0])
    return np.ascontiguousarray(samples[keep][:, :3])


@njit(cache=True, error_model="numpy")
def largest_capped_reach(samples, reach, limit, max_disks):
    """Double ``reach`` (m/s^2) while below ``limit``: the last doubled reach whose
    :func:`nao_disks_within` holds at most ``max_disks`` disks, stopping at the first
    that holds more; -1.0 when there is none."""
    return _capped_disks(samples, _radius_order(samples), reach, limit, max_disks)[0]


@njit(cache=True, error_model="numpy")
def _capped_disks(samples, order, reach, limit, max_disks):
    """:func:`largest_capped_reach` and its :func:`nao_disks_within` (empty when there
    is none), from the samples' :func:`_radius_order`. Containment is only worked out
    for a ball whose samples alone exceed the cap (and for the chosen one)."""
    M = samples.shape[0]
    chosen = -1.0
    chosen_keep = np.zeros(M, dtype=np.bool_)
    known = False  # chosen_keep holds the chosen ball's disks
    while reach < limit:
        reach *= 2.0
        raw = 0
        for i in range(M):
            if not (samples[i, 3] > samples[i, 2] + reach):
                raw += 1
        if raw > max_disks:
            keep, n_kept = _uncontained_in(samples, order, reach, max_disks)
            if n_kept > max_disks:
                break
            chosen_keep = keep  # the visit ran to the end: the whole mask
            known = True
        else:
            known = False
        chosen = reach
    if chosen < 0.0:
        return chosen, np.empty((0, 3))
    if not known:
        chosen_keep, _ = _uncontained_in(samples, order, chosen, M)
    return chosen, np.ascontiguousarray(samples[chosen_keep][:, :3])


@njit(cache=True, error_model="numpy")
def _drop_contained(disks):
    """The disks (M, 3) that no other disk contains (of identical ones, the first).

    Only a disk at least as large can contain another, and containment is
    transitive, so the disks are visited largest first and each is tested
    against the disks kept so far only (few, typically), not against all M.
    """
    keep, _ = _uncontained_in(disks, _radius_order(disks), math.inf, disks.shape[0])
    return disks[keep]


@njit(cache=True, error_model="numpy")
def _uncontained_in(rows, order, reach, stop_after):
    """:func:`_drop_contained`'s mask (over ``rows``) and count of kept disks, among the
    rows: disks (M, 3), or samples (M, 4) of which only those within ``reach`` (m/s^2)
    take part; visited in ``order`` (:func:`_radius_order`). The visit stops as soon as
    more than ``stop_after`` are kept (the mask is then partial)."""
    M = rows.shape[0]
    sampled = rows.shape[1] > 3
    keep = np.zeros(M, dtype=np.bool_)
    kept = np.empty(M, dtype=np.int64)
    n_kept = 0
    for oi in range(M):
        i = order[oi]
        if sampled and rows[i, 3] > rows[i, 2] + reach:
            continue
        xi = rows[i, 0]
        yi = rows[i, 1]
        ri = rows[i, 2]
        inside = False
        for kk in range(n_kept):
            j = kept[kk]
            rj = rows[j, 2]
            dx = rows[j, 0] - xi
            dy = rows[j, 1] - yi
            lim = rj - ri + 1e-9 * rj
            # cheap reject: clearly further apart than rj - ri (the exact test would fail)
            if rj < ri or dx * dx + dy * dy > lim * lim:
                continue
            d = _norm(xi - rows[j, 0], yi - rows[j, 1])
            if d + ri <= rj and (d + ri < rj or j < i):
                inside = True
                break
        if not inside:
            keep[i] = True
            kept[n_kept] = i
            n_kept += 1
            if n_kept > stop_after:
                break
    return keep, n_kept


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
        d = _norm(cx, cy)
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
        d = _norm(dx, dy)
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
    M = disks.shape[0]
    max_out = res.shape[0]
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
    lower = np.empty(M + 1)
    for i in range(M):
        lower[i] = abs(_norm(q[0] - disks[i, 0], q[1] - disks[i, 1]) - disks[i, 2])
    lower[M] = abs(_norm(q[0], q[1]) - a_max)
    order = np.argsort(lower)
    for i in order:
        if lower[i] >= res[max_out - 1, 2]:
            break
        if covered > 0.0:
            if i < M:
                far = _norm(q[0] - disks[i, 0], q[1] - disks[i, 1]) + disks[i, 2]
            else:
                far = _norm(q[0], q[1]) + a_max
            if far < covered:
                continue
        if i < M:
            k = _free_arc_points(disks[i, 0], disks[i, 1], disks[i, 2], True, q, disks, i,
                                 a_max, cand, 0, starts, ends, cover)
        else:
            k = _free_arc_points(0.0, 0.0, a_max, False, q, disks, -1, a_max, cand, 0,
                                 starts, ends, cover)
        for c in range(max(k, 0)):
            d = _norm(cand[c, 0] - q[0], cand[c, 1] - q[1])
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
    found = 0
    while found < max_out and res[found, 2] <= within and res[found, 2] < math.inf:
        found += 1
    return found


@njit(cache=True, error_model="numpy")
def _first_contact(vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c, seg_w, seg_b, sweep, n, r,
                   t_stop, buf):
    """First time (s) the robot comes within r of obstacle n, if before t_stop; else inf."""
    S = seg_c.shape[1]
    r2 = r * r
    for j in range(S):
        t0 = seg_t[j]
        if t0 >= t_stop:
            break
        t1 = seg_t[j + 1]
        if _piece_out_of_reach(vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c, sweep, n, j, r):
            continue
        ta = t0
        while ta < t1:
            tb = min(t1, tau) if ta < tau else t1
            rax, ray, rvx, rvy, rpx, rpy = _robot_state(vx, vy, ax, ay, tau, ta)
            dt0 = ta - t0
            obx = seg_b[n, j, 0]
            oby = seg_b[n, j, 1]
            _piece(
                0.5 * (rax - obx), 0.5 * (ray - oby),
                rvx - (seg_w[n, j, 0] + obx * dt0), rvy - (seg_w[n, j, 1] + oby * dt0),
                rpx - (seg_c[n, j, 0] + seg_w[n, j, 0] * dt0 + 0.5 * obx * dt0 * dt0),
                rpy - (seg_c[n, j, 1] + seg_w[n, j, 1] * dt0 + 0.5 * oby * dt0 * dt0),
                tb - ta, r2, True, buf,
            )
            if buf[2] < math.inf:
                return ta + buf[2]
            ta = tb
    return math.inf


@njit(cache=True, error_model="numpy")
def latest_contact_kernel(cand_v, cand_a, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep,
                          out_first):
    """Earliest first contact (s) over all obstacles per candidate, for picking the latest.

    A candidate's scan stops as soon as its earliest contact falls below the
    best (latest) found so far among earlier candidates; its entry is then
    an upper bound below that best (it cannot win), not the exact value.
    """
    K = cand_a.shape[0]
    N = seg_c.shape[0]
    buf = np.empty(3)
    best = -math.inf
    for k in range(K):
        vx, vy, tau, bound = _candidate_setup(
            cand_v[k, 0], cand_v[k, 1], cand_a[k, 0], cand_a[k, 1], v_max, seg_t[-1]
        )
        tf = math.inf
        for n in range(N):
            f = _first_contact(vx, vy, cand_a[k, 0], cand_a[k, 1], tau, bound, seg_t, seg_c,
                               seg_w, seg_b, sweep, n, radius[n], tf, buf)
            if f < tf:
                tf = f
            if tf < best:
                break
        out_first[k] = tf
        if tf > best:
            best = tf


# An obstacle already closer than its grown radius counts with (just under) its current
# distance: the robot may not close in further but may move away (see agents/nao.py).
RADIUS_CUT = 1.0 - 1e-9


@njit(cache=True, error_model="numpy")
def path_excursions(pred):
    """Per body of ``pred`` (n, T, 2) m: the largest distance (m) of a sampled centre from
    the first one, and whether all its centres are finite."""
    n = pred.shape[0]
    T = pred.shape[1]
    excursion = np.zeros(n)
    finite = np.ones(n, dtype=np.bool_)
    for body in range(n):
        ex = 0.0
        for j in range(1, T):
            dx = pred[body, j, 0] - pred[body, 0, 0]
            dy = pred[body, j, 1] - pred[body, 0, 1]
            e2 = dx * dx + dy * dy
            if not math.isfinite(e2):
                finite[body] = False
            elif e2 > ex:
                ex = e2
        if not (math.isfinite(pred[body, 0, 0]) and math.isfinite(pred[body, 0, 1])):
            finite[body] = False
        excursion[body] = math.sqrt(ex)
    return excursion, finite


@njit(cache=True, error_model="numpy")
def sampled_admissible_batch(times, pred, nb_start, nb_index, nb_radius, wall_c, wall_r,
                             wall_start, wall_index, rows, pos, vel, acc, v_max, radius, margin,
                             excursion, finite_path, out):
    """Admissibility of one acceleration per robot against sampled obstacle paths.

    For each robot k of ``rows``: its obstacles are the bodies
    nb_index[nb_start[k]:nb_start[k + 1]] with world-frame centres pred[body]
    (T, 2) m at ``times`` (s, times[0] = 0, T >= 2), radii nb_radius[body] +
    radius[k] + margin[k] (m), then the static discs wall_index[...] of
    wall_c (m) with radii wall_r (m). The paths are built exactly as
    :func:`~nao_arena.geometry.clearance.sampled_path` builds them from the
    robot-relative centres (a radius larger than the distance at t = 0 is cut to
    that distance times 1 - 1e-9), and acc[k] (m/s^2) is tested as
    :func:`admissible_kernel` tests it (velocity vel[k] m/s, speed limit
    v_max[k] m/s, margin 0). excursion, finite_path: :func:`path_excursions` of
    ``pred``. out[k] = 1 admissible, 0 not, -1 non-finite centres (left to the
    caller).
    """
    S = times.shape[0] - 1
    most = 0  # the most obstacles a robot has: the scratch rows
    for k in rows:
        most = max(most, nb_start[k + 1] - nb_start[k] + wall_start[k + 1] - wall_start[k])
    _admissible_rows(times, pred, nb_start, nb_index, nb_radius, wall_c, wall_r, wall_start,
                     wall_index, rows, pos, vel, acc, v_max, radius, margin, excursion,
                     finite_path, out, np.empty(most, dtype=np.int64), np.empty(most),
                     np.empty((most, S, 2)), np.empty((most, S, 2)), np.zeros((most, S, 2)),
                     np.empty((most, S)), np.empty(3), np.empty(3))


@njit(cache=True, error_model="numpy")
def _admissible_rows(times, pred, nb_start, nb_index, nb_radius, wall_c, wall_r, wall_start,
                     wall_index, rows, pos, vel, acc, v_max, radius, margin, excursion,
                     finite_path, out, keep, keep_r, c, w, b, sweep, buf, res):
    """:func:`sampled_admissible_batch` with its scratch arrays given (rows enough for
    every robot's obstacles; b zero). Arrays borrowed here."""
    times, pred = borrowed(times), borrowed(pred)
    nb_start, nb_index = borrowed(nb_start), borrowed(nb_index)
    nb_radius, wall_c, wall_r = borrowed(nb_radius), borrowed(wall_c), borrowed(wall_r)
    wall_start, wall_index, rows = borrowed(wall_start), borrowed(wall_index), borrowed(rows)
    pos, vel, acc, v_max = borrowed(pos), borrowed(vel), borrowed(acc), borrowed(v_max)
    radius, margin, excursion = borrowed(radius), borrowed(margin), borrowed(excursion)
    finite_path, out = borrowed(finite_path), borrowed(out)
    keep, keep_r = borrowed(keep), borrowed(keep_r)
    c, w, b, sweep = borrowed(c), borrowed(w), borrowed(b), borrowed(sweep)
    buf, res = borrowed(buf), borrowed(res)
    horizon = times[-1]
    for k in rows:
        n_nb = nb_start[k + 1] - nb_start[k]
        n_w = wall_start[k + 1] - wall_start[k]
        ax = acc[k, 0]
        ay = acc[k, 1]
        vx, vy, tau, bound = _candidate_setup(vel[k, 0], vel[k, 1], ax, ay, v_max[k], horizon)
        px = pos[k, 0]
        py = pos[k, 1]
        # skip the obstacles that stay far: |x(t)| <= bound t for the robot (and it stays
        # within bound * horizon / 2 of where it is halfway), and a sampled path stays
        # within its largest sample excursion from its start
        travel = bound * horizon
        _, _, _, _, mx, my = _robot_state(vx, vy, ax, ay, tau, 0.5 * horizon)
        half = 0.5 * travel
        n = 0
        finite = True
        for i in range(n_nb + n_w):
            if i < n_nb:
                body = nb_index[nb_start[k] + i]
                x0 = pred[body, 0, 0] - px
                y0 = pred[body, 0, 1] - py
                r = min(nb_radius[body] + radius[k] + margin[k],
                        math.sqrt(x0 * x0 + y0 * y0) * RADIUS_CUT)
                if not finite_path[body]:
                    finite = False
                    break
                ex = excursion[body]
            else:
                d = wall_index[wall_start[k] + i - n_nb]
                x0 = wall_c[d, 0] - px
                y0 = wall_c[d, 1] - py
                r = min(wall_r[d], math.sqrt(x0 * x0 + y0 * y0) * RADIUS_CUT)
                ex = 0.0
            gap = max(math.sqrt(x0 * x0 + y0 * y0) - travel,
                      math.sqrt((x0 - mx) ** 2 + (y0 - my) ** 2) - half) - ex
            if gap > (r + 1e-9) * (1.0 + 1e-9):
                continue
            keep[n] = i
            keep_r[n] = r
            n += 1
        if not finite:
            out[k] = -1
            continue
        if n == 0:
            out[k] = 1
            continue
        for q in range(n):
            i = keep[q]
            if i < n_nb:
                _moving_pieces(pred, nb_index[nb_start[k] + i], px, py, times, c, w, q)
            else:
                d = wall_index[wall_start[k] + i - n_nb]
                _static_pieces(wall_c[d, 0] - px, wall_c[d, 1] - py, times, c, w, q)
        _fill_sweep(times, w, b, n, sweep)
        ok = 1
        for q in range(n):
            _scan(vx, vy, ax, ay, tau, bound, times, c, w, b, sweep, q, keep_r[q], 0.0, False,
                  buf, res)
            if res[0] < (keep_r[q] + 0.0) ** 2:
                ok = 0
                break
        out[k] = ok


@njit(cache=True, error_model="numpy")
def _ok_disc(x, y, a_max, vx, vy, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep, margin,
             buf, res, hint):
    """Admissibility of the acceleration (x, y) m/s^2 within the limit disc |a| <= a_max:
    returns (admissible, 1 if it was tested against the obstacles (inside the disc)).

    hint: (obstacle, piece) that last rejected a candidate (-1: none). That piece is
    tested first, then that obstacle, then the others (a rejection anywhere is the
    same answer, so the order does not change it); updated on a rejection.
    """
    if x * x + y * y > a_max * a_max * (1 + 1e-12) + 1e-300:
        return False, 0
    N = seg_c.shape[0]
    if N == 0:
        return True, 1
    cvx, cvy, tau, bound = _candidate_setup(vx, vy, x, y, v_max, seg_t[-1])
    first = hint[0] if 0 <= hint[0] < N else 0
    if first == hint[0] and 0 <= hint[1] < seg_c.shape[1]:
        reach = radius[first] + margin
        if _piece_within(cvx, cvy, x, y, tau, seg_t, seg_c, seg_w, seg_b, first, hint[1],
                         reach * reach, buf):
            return False, 1
    for i in range(N):
        n = first if i == 0 else (i - 1 if i <= first else i)
        j = _scan(cvx, cvy, x, y, tau, bound, seg_t, seg_c, seg_w, seg_b, sweep, n,
                  radius[n], margin, False, buf, res)
        if res[0] < (radius[n] + margin) ** 2:
            hint[0] = n
            hint[1] = j
            return False, 1
    return True, 1


@njit(cache=True, error_model="numpy")
def _bisect_disc(bx, by, gx, gy, tol, a_max, vx, vy, v_max, seg_t, seg_c, seg_w, seg_b,
                 radius, sweep, margin, buf, res, hint, give_up=math.inf):
    """Shrink [b, g] (g admissible) onto the boundary within tol: (gx, gy, tests). When
    b starts at the origin of the caller's distances (the slide's a_d), ``give_up``
    stops the search as soon as b is that far from its start: every point left on the
    segment is farther (the caller then discards the result)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
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
        ok, c = _ok_disc(mx, my, a_max, vx, vy, v_max, seg_t, seg_c, seg_w, seg_b, radius,
                         sweep, margin, buf, res, hint)
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
def bisect_disc(bad, good, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep,
                margin):
    """Shrink the segment [bad, good] (m/s^2; good admissible) onto the NAO boundary
    within tol (m/s^2), with the limit disc |a| <= a_max. Returns (the admissible end
    x, y, how many candidates were tested) — :func:`selection._bisect` compiled."""
    buf = np.empty(3)
    res = np.empty(3)
    hint = np.full(2, -1, dtype=np.int64)
    return _bisect_disc(bad[0], bad[1], good[0], good[1], tol, a_max, v[0], v[1], v_max,
                        seg_t, seg_c, seg_w, seg_b, radius, sweep, margin, buf, res, hint)


@njit(cache=True, error_model="numpy")
def _sliver_push(x, y, ux, uy, tol, a_max, vx, vy, v_max, seg_t, seg_c, seg_w, seg_b, radius,
                 sweep, margin, buf, res, hint):
    """Push the inadmissible point (x, y) along the unit direction (ux, uy) by tol, 2 tol,
    4 tol, ... below a_max / 4; the first admissible push is bisected back onto the
    boundary within tol. Returns (found, x, y, candidates tested)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    count = 0
    step = tol
    while step < 0.25 * a_max:
        px = x + step * ux
        py = y + step * uy
        ok, c = _ok_disc(px, py, a_max, vx, vy, v_max, seg_t, seg_c, seg_w, seg_b, radius,
                         sweep, margin, buf, res, hint)
        count += c
        if ok:
            hint[0] = -1
            hint[1] = -1
            gx, gy, c = _bisect_disc(x, y, px, py, tol, a_max, vx, vy, v_max, seg_t,
                                     seg_c, seg_w, seg_b, radius, sweep, margin, buf, res,
                                     hint)
            return True, gx, gy, count + c
        step *= 2.0
    return False, 0.0, 0.0, count


@njit(cache=True, error_model="numpy")
def _outward_normal(x, y, disks):
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
def try_candidates_disc(cands, start, reach, a_d, tol, a_max, v, v_max, seg_t, seg_c, seg_w,
                        seg_b, radius, sweep, margin, disks):
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
    return _try_candidates(cands, start, reach, a_d, tol, a_max, v, v_max, seg_t, seg_c, seg_w,
                           seg_b, radius, sweep, margin, disks, np.empty(3), np.empty(3),
                           np.full(2, -1, dtype=np.int64))


@njit(cache=True, error_model="numpy")
def _try_candidates(cands, start, reach, a_d, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b,
                    radius, sweep, margin, disks, buf, res, hint):
    """:func:`try_candidates_disc` with its scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    cands, a_d, v, disks = borrowed(cands), borrowed(a_d), borrowed(v), borrowed(disks)
    vx = v[0]
    vy = v[1]
    count = 0
    for i in range(start, cands.shape[0]):
        x = cands[i, 0]
        y = cands[i, 1]
        dist = cands[i, 2]
        if dist > reach:
            return False, 0.0, 0.0, count, True
        ok, c = _ok_disc(x, y, a_max, vx, vy, v_max, seg_t, seg_c, seg_w, seg_b, radius,
                         sweep, margin, buf, res, hint)
        count += c
        if ok:
            return True, x, y, count, False
        if dist > 0.0:
            found, gx, gy, c = _sliver_push(x, y, (x - a_d[0]) / dist, (y - a_d[1]) / dist,
                                            tol, a_max, vx, vy, v_max, seg_t, seg_c, seg_w,
                                            seg_b, radius, sweep, margin, buf, res, hint)
            count += c
            if found:
                return True, gx, gy, count, False
        ux, uy = _outward_normal(x, y, disks)
        if ux != 0.0 or uy != 0.0:
            found, gx, gy, c = _sliver_push(x, y, ux, uy, tol, a_max, vx, vy, v_max, seg_t,
                                            seg_c, seg_w, seg_b, radius, sweep, margin, buf,
                                            res, hint)
            count += c
            if found:
                return True, gx, gy, count, False
    return False, 0.0, 0.0, count, False


@njit(cache=True, error_model="numpy", inline="always")
def _onto_disc(x, y, a_max):
    """(x, y) m/s^2 projected onto |a| <= a_max, as AccelLimits.project does it."""
    norm = math.hypot(x, y)
    scale = a_max / max(norm, 1e-300) if norm > a_max else 1.0
    return x * scale, y * scale


@njit(cache=True, error_model="numpy")
def repair_disc(prev, want, a_max, steps, unit, v, v_max, seg_t, seg_c, seg_w, seg_b,
                radius):
    """:func:`selection.repair_acceleration` compiled for the limit disc: the candidates
    prev + a_max * steps[i] * unit[k] (m/s^2), projected onto |a| <= a_max, tested
    nearest ``want`` first (a stable order) against the relevant obstacles (margin 0);
    returns (found, x, y, candidates tested)."""
    seg_c, seg_w, seg_b, radius, sweep = relevant_subset(v, a_max, v_max, seg_t, seg_c, seg_w,
                                                         seg_b, radius, 0.0)
    return repair_relevant(prev, want, a_max, steps, unit, v, v_max, seg_t, seg_c, seg_w,
                           seg_b, radius, sweep)


@njit(cache=True, error_model="numpy")
def repair_relevant(prev, want, a_max, steps, unit, v, v_max, seg_t, seg_c, seg_w, seg_b,
                    radius, sweep):
    """:func:`repair_disc` for obstacles that are all relevant (as :func:`relevant_subset`
    keeps them, margin 0), with their :func:`piece_sweep`."""
    K = steps.shape[0] * unit.shape[0]
    cand = np.empty((K, 2))
    dist = np.empty(K)
    k = 0
    for i in range(steps.shape[0]):
        s = a_max * steps[i]
        for u in range(unit.shape[0]):
            cand[k, 0], cand[k, 1] = _onto_disc(prev[0] + s * unit[u, 0],
                                                prev[1] + s * unit[u, 1], a_max)
            dist[k] = math.hypot(cand[k, 0] - want[0], cand[k, 1] - want[1])
            k += 1
    order = np.argsort(dist, kind="mergesort")
    return _first_admissible(cand, order, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius,
                             sweep, 0.0, np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64))


@njit(cache=True, error_model="numpy")
def _first_admissible(cand, order, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep,
                      margin, buf, res, hint):
    """The first admissible row of ``cand`` (K, 2) m/s^2 in ``order``: (found, x, y,
    candidates tested); scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    cand, order, v = borrowed(cand), borrowed(order), borrowed(v)
    count = 0
    for o in range(order.shape[0]):
        k = order[o]
        ok, c = _ok_disc(cand[k, 0], cand[k, 1], a_max, v[0], v[1], v_max, seg_t, seg_c,
                         seg_w, seg_b, radius, sweep, margin, buf, res, hint)
        count += c
        if ok:
            return True, cand[k, 0], cand[k, 1], count
    return False, 0.0, 0.0, count


@njit(cache=True, error_model="numpy")
def ring_search_disc(a_d, radii, unit, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b,
                     radius, sweep, margin):
    """The ring fallback of :func:`selection.select_acceleration` compiled for the limit
    disc: rings a_d + radii[i] * unit[i] (m/s^2, projected onto |a| <= a_max), innermost
    first; the admissible candidate of the first ring that has one, nearest a_d, is
    bisected back towards a_d onto the boundary within tol and slid along it
    (:func:`bisect_disc`, :func:`slide_disc`). Returns (found, x, y, candidates tested)."""
    return _ring_search(a_d, radii, unit, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b,
                        radius, sweep, margin, np.empty(3), np.empty(3),
                        np.full(2, -1, dtype=np.int64), np.empty((unit.shape[1], 2)))


@njit(cache=True, error_model="numpy")
def _ring_search(a_d, radii, unit, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius,
                 sweep, margin, buf, res, hint, cand):
    """:func:`ring_search_disc` with its scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
    buf, res, hint = borrowed(buf), borrowed(res), borrowed(hint)
    a_d, radii, unit = borrowed(a_d), borrowed(radii), borrowed(unit)
    v, cand = borrowed(v), borrowed(cand)
    P = unit.shape[1]
    count = 0
    for i in range(radii.shape[0]):
        best = -1
        best_d = math.inf
        for k in range(P):
            x, y = _onto_disc(a_d[0] + radii[i] * unit[i, k, 0],
                              a_d[1] + radii[i] * unit[i, k, 1], a_max)
            cand[k, 0] = x
            cand[k, 1] = y
            d = math.hypot(x - a_d[0], y - a_d[1])
            if d >= best_d:
                continue  # cannot become the nearest admissible one of this ring
            ok, c = _ok_disc(x, y, a_max, v[0], v[1], v_max, seg_t, seg_c, seg_w, seg_b,
                             radius, sweep, margin, buf, res, hint)
            count += c
            if ok:
                best = k
                best_d = d
        if best >= 0:
            gx, gy, c = bisect_disc(a_d, cand[best], tol, a_max, v, v_max, seg_t, seg_c,
                                    seg_w, seg_b, radius, sweep, margin)
            count += c
            start = np.empty(2)
            start[0] = gx
            start[1] = gy
            x, y, c = slide_disc(a_d, start, tol, a_max, v, v_max, seg_t, seg_c, seg_w,
                                 seg_b, radius, sweep, margin)
            return True, x, y, count + c
    return False, 0.0, 0.0, count


@njit(cache=True, error_model="numpy")
def slide_disc(a_d, best, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep,
               margin):
    """Rotate the admissible boundary point ``best`` about a_d (m/s^2) by shrinking angles,
    pulling each admissible probe back onto the boundary, while it gets nearer a_d by
    more than tol (m/s^2). Returns (x, y, candidates tested) —
    :func:`selection._slide_towards` compiled for the limit disc."""
    return _slide(a_d, best, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep,
                  margin, np.empty(3), np.empty(3), np.full(2, -1, dtype=np.int64))


@njit(cache=True, error_model="numpy")
def _slide(a_d, best, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep, margin,
           buf, res, hint):
    """:func:`slide_disc` with its scratch arrays given (borrowed here)."""
    seg_t, seg_c, seg_w, seg_b = borrowed(seg_t), borrowed(seg_c), borrowed(seg_w), borrowed(seg_b)
    radius, sweep = borrowed(radius), borrowed(sweep)
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
            norm = math.hypot(fx, fy)
            if norm > a_max:
                scale = a_max / max(norm, 1e-300)
                fx = fx * scale
                fy = fy * scale
            ok, c = _ok_disc(fx, fy, a_max, v[0], v[1], v_max, seg_t, seg_c, seg_w, seg_b,
                             radius, sweep, margin, buf, res, hint)
            count += c
            if not ok:
                continue
            px, py, c = _bisect_disc(ax, ay, fx, fy, tol, a_max, v[0], v[1], v_max, seg_t,
                                     seg_c, seg_w, seg_b, radius, sweep, margin, buf, res,
                                     hint, dist - tol)
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
def relevant_subset(v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, margin):
    """The obstacles :func:`relevant_obstacles` keeps, as contiguous arrays (the inputs
    themselves when all are kept), and their :func:`piece_sweep`:
    (c, w, b, radius, sweep)."""
    keep = relevant_obstacles(v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, margin)
    n = 0
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
                c[k] = seg_c[i]
                w[k] = seg_w[i]
                b[k] = seg_b[i]
                r[k] = radius[i]
                k += 1
    return c, w, b, r, piece_sweep(seg_t, w, b)


@njit(cache=True, error_model="numpy")
def _try_ball_disc(a_d, disks, reach, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b,
                   radius, sweep, margin, covered):
    """:func:`selection._try_ball` for the limit disc: (found, x, y, candidates tested,
    whether the disks cover the whole ball). ``covered``: see
    :func:`nearest_outside_disks`."""
    cands = nearest_outside_disks(a_d, disks, a_max, 8, reach, covered)
    found, x, y, count, beyond = try_candidates_disc(
        cands, 0, reach, a_d, tol, a_max, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep,
        margin, disks)
    return found, x, y, count, cands.shape[0] == 0


@njit(cache=True, error_model="numpy")
def select_disc(a_d, v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius, margin, tol,
                ring_radii, unit_rings, max_disks, n_sub, per_second, thin):
    """The search of :func:`selection.select_acceleration` for the limit disc, compiled:
    a_d (the desired acceleration, inside the disc) if admissible, else the disk search
    in the largest ball (radius max(a_max / 16, 4 tol) doubled) within ``max_disks``
    disks, the rings, and the disk search without a cap. Returns (status, x, y,
    candidates tested): status 0 desired, 1 adjusted, 2 nothing admissible found (the
    caller falls back)."""
    c, w, b, r, sweep = relevant_subset(v, a_max, v_max, seg_t, seg_c, seg_w, seg_b, radius,
                                        margin)
    return select_relevant(a_d, v, a_max, v_max, seg_t, c, w, b, r, sweep, margin, tol,
                           ring_radii, unit_rings, max_disks, n_sub, per_second, thin)


@njit(cache=True, error_model="numpy")
def select_relevant(a_d, v, a_max, v_max, seg_t, c, w, b, r, sweep, margin, tol, ring_radii,
                    unit_rings, max_disks, n_sub, per_second, thin):
    """:func:`select_disc` for obstacles that are all relevant (as :func:`relevant_subset`
    keeps them for this margin), with their :func:`piece_sweep` ``sweep``."""
    buf = np.empty(3)
    res = np.empty(3)
    hint = np.full(2, -1, dtype=np.int64)
    ok, count = _ok_disc(a_d[0], a_d[1], a_max, v[0], v[1], v_max, seg_t, c, w, b, r, sweep,
                         margin, buf, res, hint)
    if ok:
        return 0, a_d[0], a_d[1], count
    reach = max(a_max / 16.0, 4.0 * tol)
    limit = math.hypot(a_d[0], a_d[1]) + a_max
    last = reach
    while last < limit:
        last *= 2.0
    samples = nao_disk_samples(v, seg_t, c, w, b, r, margin, n_sub, a_d, last, a_max,
                               per_second, thin)
    order = _radius_order(samples)
    # 1. the disk search in the largest ball, doubled from ``reach``, within the cap
    covered = 0.0  # the disks are known to cover the ball of this radius around a_d
    chosen, disks = _capped_disks(samples, order, 0.5 * reach, max(limit, reach), max_disks)
    if chosen >= 0.0:
        found, x, y, k, empty = _try_ball_disc(a_d, disks, chosen, tol, a_max, v, v_max,
                                               seg_t, c, w, b, r, sweep, margin, 0.0)
        count += k
        if found:
            return 1, x, y, count
        if empty:
            covered = chosen
    # 2. rings of candidates
    found, x, y, k = ring_search_disc(a_d, ring_radii, unit_rings, tol, a_max, v, v_max,
                                      seg_t, c, w, b, r, sweep, margin)
    count += k
    if found:
        return 1, x, y, count
    # 3. the disk search without a cap, in the largest ball
    found, x, y, k, _ = _try_ball_disc(a_d, _disks_within(samples, order, last), last, tol, a_max,
                                       v, v_max, seg_t, c, w, b, r, sweep, margin, covered)
    count += k
    if found:
        return 1, x, y, count
    return 2, 0.0, 0.0, count
