"""Earlier versions of the geometry kernels and the Python loops the compiled searches
replaced: the references tests/test_fast_path.py compares the production kernels against.

The kernels as they were before the fast paths (O(M^2) containment filter, exact angles
for every circle) are compiled without caching; the searches run over a tester with
Python admissibility tests (:class:`reference.selection_reference.CandidateTester`, ``ok1``) one
candidate at a time.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nao_arena.geometry import selection
from nao_arena.geometry.selection import AccelLimits, _Tester

TWO_PI = 2.0 * math.pi


@njit
def length(x: float, y: float) -> float:
    """sqrt(x^2 + y^2), the kernels' vector length (not math.hypot), for the references."""
    return math.sqrt(x * x + y * y)


@njit
def drop_contained_ref(disks):
    """The disks (M, 3) that no other disk contains (of identical ones, the first)."""
    M = disks.shape[0]
    keep = np.ones(M, dtype=np.bool_)
    for i in range(M):
        for j in range(M):
            if i == j or not keep[j]:
                continue
            d = length(disks[i, 0] - disks[j, 0], disks[i, 1] - disks[j, 1])
            if d + disks[i, 2] <= disks[j, 2] and (d + disks[i, 2] < disks[j, 2] or j < i):
                keep[i] = False
                break
    return disks[keep]


@njit
def free_arc_points_ref(cx, cy, rho, in_limit, q, circ, skip, a_max, out, k):
    """Append to ``out`` (from row k) the point nearest q of every free arc of the
    circle (cx, cy, rho): arcs no disk of ``circ`` (except row ``skip``) covers
    and, when ``in_limit``, inside the limit disc |a| <= a_max.
    Returns the new row count, or -1 when the whole circle is covered.
    """
    M = circ.shape[0]
    starts = np.empty(2 * M + 4)
    ends = np.empty(2 * M + 4)
    n = 0
    for j in range(M + 1):
        if j == M:
            if not in_limit:
                continue
            d = length(cx, cy)
            if d + rho <= a_max:
                continue
            if d >= rho + a_max or d + a_max <= rho:
                return -1
            cosb = (d * d + rho * rho - a_max * a_max) / (2.0 * d * rho)
            beta = math.acos(min(1.0, max(-1.0, cosb)))
            # allowed: the arc facing the origin, [alpha - beta, alpha + beta]
            lo = math.atan2(-cy, -cx) + beta
            width = TWO_PI - 2.0 * beta
        else:
            if j == skip:
                continue
            dx = circ[j, 0] - cx
            dy = circ[j, 1] - cy
            rj = circ[j, 2]
            d = length(dx, dy)
            if d + rho <= rj * (1.0 - 1e-12):
                return -1
            if d >= rho + rj or d + rj <= rho or d <= 0.0:
                continue
            cosb = (d * d + rho * rho - rj * rj) / (2.0 * d * rho)
            beta = math.acos(min(1.0, max(-1.0, cosb)))
            lo = math.atan2(dy, dx) - beta
            width = 2.0 * beta
        lo = lo % TWO_PI
        hi = lo + width
        if hi > TWO_PI:
            starts[n] = lo
            ends[n] = TWO_PI
            n += 1
            starts[n] = 0.0
            ends[n] = hi - TWO_PI
            n += 1
        else:
            starts[n] = lo
            ends[n] = hi
            n += 1
    phi_q = math.atan2(q[1] - cy, q[0] - cx) % TWO_PI
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
            hi = first_start + TWO_PI
            if hi <= lo:
                break
        # nearest point of the free arc [lo, hi] to q: phi_q if inside, else an end
        ph = phi_q if phi_q >= lo else phi_q + TWO_PI
        if ph <= hi:
            best = ph
        else:
            d_lo = ph - hi
            d_hi = lo + TWO_PI - ph
            best = hi if d_lo <= d_hi else lo
        out[k, 0] = cx + rho * math.cos(best)
        out[k, 1] = cy + rho * math.sin(best)
        k += 1
    return k


@njit
def nearest_outside_disks_ref(q, disks, a_max, max_out):
    """Points nearest q that lie outside every disk and inside |a| <= a_max.

    The nearest point of the complement of a union of disks (within the limit
    disc) is q itself or lies on a free arc of one of the circles, the limit
    circle included. Free arcs come from the angular intervals the other
    disks cover; on each, the nearest point to q is its radial projection or
    an end. Circles are visited in order of their distance from q and the
    search stops once no unvisited circle can beat the ``max_out``-th best
    candidate. Returns up to ``max_out`` candidates (rows x, y, distance) in
    increasing distance.
    """
    M = disks.shape[0]
    res = np.full((max_out, 3), math.inf)
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
        lower[i] = abs(length(q[0] - disks[i, 0], q[1] - disks[i, 1]) - disks[i, 2])
    lower[M] = abs(length(q[0], q[1]) - a_max)
    order = np.argsort(lower)
    cand = np.empty((2 * M + 8, 2))
    for i in order:
        if lower[i] >= res[max_out - 1, 2]:
            break
        if i < M:
            k = free_arc_points_ref(
                disks[i, 0], disks[i, 1], disks[i, 2], True, q, disks, i, a_max, cand, 0
            )
        else:
            k = free_arc_points_ref(0.0, 0.0, a_max, False, q, disks, -1, a_max, cand, 0)
        for c in range(max(k, 0)):
            d = length(cand[c, 0] - q[0], cand[c, 1] - q[1])
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
    while found < max_out and res[found, 2] < math.inf:
        found += 1
    return res[:found].copy()


def bisect_ref(t: _Tester, bad, good, tol, give_up=math.inf):
    """The bisection of select_acceleration (``bisect_disc``) as a Python loop over the
    tester's ``ok1``; it stops once bad is
    ``give_up`` from where it started."""
    gap = float(np.hypot(*(good - bad)))
    start = bad
    while gap > tol:
        if (bad[0] - start[0]) ** 2 + (bad[1] - start[1]) ** 2 >= give_up * give_up:
            return good
        mid = 0.5 * (bad + good)
        if t.ok1(mid):
            good = mid
        else:
            bad = mid
        gap *= 0.5
    return good


def slide_ref(t: _Tester, a_d, best, limits: AccelLimits, tol):
    """The sliding of select_acceleration (``slide_disc``) as a Python loop."""
    dist = float(np.hypot(*(best - a_d)))
    angle = 0.5
    while angle > 1e-3 and dist > tol:
        phi = math.atan2(best[1] - a_d[1], best[0] - a_d[0])
        moved = False
        for sgn in (1.0, -1.0):
            u = np.array([math.cos(phi + sgn * angle), math.sin(phi + sgn * angle)])
            far = limits.project(a_d + 1.5 * dist * u)
            if not t.ok1(far):
                continue
            p = bisect_ref(t, a_d, far, tol, dist - tol)
            d = float(np.hypot(*(p - a_d)))
            if d < dist - tol:
                best, dist, moved = p, d, True
                break
        if not moved:
            angle *= 0.5
    return best


def disk_samples_ref(v, path, margin, n_sub, q, reach, a_max, per_second):
    """nao_disk_samples without thinning, written out plainly: every sample time of
    every piece, kept when its disk meets the ball B(q, reach) and the limit disc."""
    rows = []
    t_all, S = path.t, path.c.shape[1]
    for n in range(path.c.shape[0]):
        rr = path.radius[n] + margin
        for j in range(S):
            t0, t1 = t_all[j], t_all[j + 1]
            k = max(n_sub, min(256, math.ceil(per_second * (t1 - t0))))
            times = [t0 + (t1 - t0) * i / k for i in range(k)]
            if j == 0:
                times = [t1 * 2.0 ** (i - 9) * 2.0 / k for i in range(8)] + times
            if j == S - 1:
                times.append(t1)
            for t in times:
                if t <= 0.0:
                    continue
                dt = t - t0
                c = (
                    path.c[n, j]
                    + path.velocity[n, j] * dt
                    + 0.5 * path.acceleration[n, j] * dt * dt
                )
                m = (c - v * t) * 2.0 / (t * t)
                rho = rr * 2.0 / (t * t)
                dq = math.hypot(*(m - q))
                if dq <= rho + reach and math.hypot(*m) <= rho + a_max:
                    rows.append((m[0], m[1], rho, dq))
    return np.array(rows).reshape(-1, 4)


def repair_ref(t: _Tester, prev, want):
    """repair_acceleration as numpy and a Python loop: rings around prev, projected onto
    the limit disc, nearest ``want`` first, the first admissible one."""
    cand = np.concatenate(
        [prev + t.limits.a_max * r * selection._REPAIR_UNIT for r in selection._REPAIR_STEPS]
    )
    cand = t.limits.project(cand)
    cand = cand[np.argsort(np.hypot(cand[:, 0] - want[0], cand[:, 1] - want[1]), kind="stable")]
    for a in cand:
        if t.ok1(a):
            return a
    return None
