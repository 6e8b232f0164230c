"""The disk picture: the NAO union near a query point, as sampled disks in
acceleration space (m/s^2), with containment filtering and the choice of the
largest ball whose disks stay within a cap. The obstacles arrive as
:class:`~.bundles.Paths`, the walls as :class:`~.bundles.Walls`.
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry.borrow import borrowed
from nao_arena.jit import inner_kernel
from nao_arena.sorting import stable_argsort


@inner_kernel(error_model="numpy")
def vector_norm(x, y):
    """sqrt(x^2 + y^2), without math.hypot's care for overflow (several times faster;
    the values here are accelerations and distances of ordinary size)."""
    return math.sqrt(x * x + y * y)


@inner_kernel(error_model="numpy")
def _farther(x, y, lim):
    """math.hypot(x, y) > lim, without the hypot unless the answer is close."""
    d2 = x * x + y * y
    l2 = lim * lim
    if d2 > l2 * (1.0 + 1e-9):
        return True
    if d2 < l2 * (1.0 - 1e-9):
        return False
    return math.hypot(x, y) > lim


@inner_kernel(error_model="numpy")
def _samples_in_piece(t0, t1, n_sub, per_second):
    if not math.isfinite(t1):
        return 12
    return max(n_sub, min(256, int(math.ceil(per_second * (t1 - t0)))))


@inner_kernel(error_model="numpy")
def _piece_schedule(j, S, t0, t1, n_sub, per_second):
    """(samples within piece j of S, geometric samples towards t = 0 before them, 1 if
    the piece's end is sampled too): when the disk picture samples piece [t0, t1] (s)."""
    k = _samples_in_piece(t0, t1, n_sub, per_second)
    head = 8 if (j == 0 and math.isfinite(t1)) else 0
    tail = 1 if (j == S - 1 and math.isfinite(t1)) else 0
    return k, head, tail


@inner_kernel(error_model="numpy")
def _sample_time(t0, t1, i, k, head):
    """The i-th sample time (s) of piece [t0, t1] (:func:`_piece_schedule`)."""
    if not math.isfinite(t1):
        return max(t0, 1e-3) * 2.0 ** (i + 1)
    if i < head:
        return t1 * 2.0 ** (i - 8 - 1) * 2.0 / k
    if i == k + head:
        return t1
    return t0 + (t1 - t0) * (i - head) / k


@inner_kernel(error_model="numpy")
def _put(out, row, x, y, rho, dq):
    """Write the disk (x, y, rho, dq) into out[row]; returns the next row."""
    out[row, 0] = x
    out[row, 1] = y
    out[row, 2] = rho
    out[row, 3] = dq
    return row + 1


@inner_kernel(error_model="numpy")
def nao_disk_samples(v, paths, walls, margin, n_sub, q, reach, a_max, per_second=16.0, thin=0.0):
    """The sampled disks of :func:`nao_disks` before containment is filtered:
    (M, 4) rows (m_x, m_y, rho, distance of m from q), m/s^2 — for
    :func:`nao_disks_within`, which gives nao_disks for any smaller reach.

    Sampled disks of the NAO union near q, in acceleration space (m/s^2).

    A constant acceleration a collides with an obstacle (of the :class:`~.bundles.Paths`)
    at time t iff |a - m(t)| <= rho(t), m(t) = 2 (c(t) - v t) / t^2, rho(t) = 2 r / t^2
    (v (2,) m/s the robot's velocity; no speed saturation). Samples every piece at
    max(n_sub, per_second * h) times (per_second 1/s; and the first piece also
    geometrically towards t = 0), grows r by ``margin`` (m) and keeps the disks that
    intersect both the ball B(q, reach) and the limit disc |a| <= a_max (m/s^2).

    thin (m/s^2): when > 0, a disk is left out while its centre lies within
    sqrt(8 thin rho) of the obstacle's last kept disk (whose radius is at least
    rho): two kept disks that far apart leave a sliver at most about ``thin``
    deep. The obstacle's last disk before a gap (a disk outside the ball or the
    limit disc) and at the end of the horizon is always kept.

    Walls (the :class:`~.bundles.Walls`: ends (W, 2, 2) m robot-relative, radii (W,) m):
    at time t a wall's
    NAO is the capsule of radius rho(t) around the segment from 2 (p - v t) / t^2 to
    2 (q - v t) / t^2; its part that meets the ball and the limit disc is covered by
    disks of radius rho(t) centred on the segment, close enough that the notches
    between them stay below ``thin`` deep (3 % of rho without thinning), at most 65
    per sample (then farther apart: deeper notches, which the exact tests of the
    candidates catch), at the same times as a static obstacle's, thinned out in time
    alike (see :func:`_wall_disks`).
    """
    seg_t, seg_c = paths.seg_t, paths.seg_c
    N = seg_c.shape[0]
    S = seg_c.shape[1]
    total = 0
    for j in range(S):
        total += _samples_in_piece(seg_t[j], seg_t[j + 1], n_sub, per_second) + 9
    rows = N * total
    if walls.ends.shape[0]:
        rows += _wall_disks(
            v,
            seg_t,
            walls,
            margin,
            n_sub,
            q,
            reach,
            a_max,
            per_second,
            thin,
            np.empty((0, 4)),
            np.int64(0),
        )  # not a literal
    out = np.empty((rows, 4))
    cnt = _fill_disk_samples(v, paths, margin, n_sub, q, reach, a_max, per_second, thin, out)
    if walls.ends.shape[0]:
        cnt = _wall_disks(
            v, seg_t, walls, margin, n_sub, q, reach, a_max, per_second, thin, out, cnt
        )
    return out[:cnt]


_WALL_DISKS_PER_SAMPLE = 64


@inner_kernel(error_model="numpy")
def _clip(px, py, dx, dy, cx, cy, big, lo, hi):
    """[lo, hi] cut to the u where |P + u D - c| <= big (an empty interval: lo > hi)."""
    dd = dx * dx + dy * dy
    ex = px - cx
    ey = py - cy
    c0 = ex * ex + ey * ey - big * big
    if dd == 0.0:
        return (lo, hi) if c0 <= 0.0 else (1.0, 0.0)
    half_b = dx * ex + dy * ey
    disc = half_b * half_b - dd * c0
    if disc < 0.0:
        return 1.0, 0.0
    sq = math.sqrt(disc)
    return max(lo, (-half_b - sq) / dd), min(hi, (-half_b + sq) / dd)


@inner_kernel(error_model="numpy")
def _put_capsule(out, cnt, write, ax, ay, bx, by, rho, thin, q):
    """Disks of radius rho along [a, b] (see :func:`nao_disk_samples`) into out[cnt:] (or
    only counted when not ``write``); returns the new count."""
    length = vector_norm(bx - ax, by - ay)
    spacing = min(math.sqrt(8.0 * thin * rho) if thin > 0.0 else 0.5 * rho, rho)
    n = 1 + min(_WALL_DISKS_PER_SAMPLE, int(math.ceil(length / spacing)) if spacing > 0.0 else 0)
    if not write:
        return cnt + n
    for m in range(n):
        u = 0.0 if n == 1 else m / (n - 1)
        mx = ax + u * (bx - ax)
        my = ay + u * (by - ay)
        cnt = _put(out, cnt, mx, my, rho, vector_norm(mx - q[0], my - q[1]))
    return cnt


@inner_kernel(error_model="numpy")
def _wall_disks(v, seg_t, walls, margin, n_sub, q, reach, a_max, per_second, thin, out, cnt):
    """The walls' disks of :func:`nao_disk_samples` (the :class:`~.bundles.Walls`, over the
    pieces of the times seg_t s) into out[cnt:]; returns the new count. With an empty
    ``out`` it only counts them (from cnt).

    Thinning (thin > 0), as for the obstacles' disks: a sample's capsule (its part within
    the ball and the limit disc) is left out while both its ends lie within
    sqrt(8 thin rho) of the last kept capsule's and its radius rho is at most that one's
    (every disk along it is then that close to one of the kept capsule's); the last
    capsule before a gap and at the end of the horizon is always kept."""
    ends, wall_r = walls
    write = out.shape[0] > 0
    S = seg_t.shape[0] - 1
    for w in range(ends.shape[0]):
        rr = wall_r[w] + margin
        kept = False  # a capsule is kept and no gap since
        pend = False  # a capsule was thinned out after it
        lax = lay = lbx = lby = lrho = 0.0  # the last kept capsule
        pax = pay = pbx = pby = prho = 0.0  # the last thinned-out one
        for j in range(S):
            t0 = seg_t[j]
            t1 = seg_t[j + 1]
            k, head, tail = _piece_schedule(j, S, t0, t1, n_sub, per_second)
            for i in range(k + head + tail):
                t = _sample_time(t0, t1, i, k, head)
                if t * t <= 0.0 or not math.isfinite(2.0 / (t * t)):
                    continue
                inv = 2.0 / (t * t)
                px = (ends[w, 0, 0] - v[0] * t) * inv
                py = (ends[w, 0, 1] - v[1] * t) * inv
                dx = (ends[w, 1, 0] - v[0] * t) * inv - px
                dy = (ends[w, 1, 1] - v[1] * t) * inv - py
                rho = rr * inv
                lo, hi = _clip(px, py, dx, dy, q[0], q[1], rho + reach, 0.0, 1.0)
                if lo <= hi:
                    lo, hi = _clip(px, py, dx, dy, 0.0, 0.0, rho + a_max, lo, hi)
                if lo > hi:
                    # a gap: the capsule meets neither the ball nor the limit disc
                    if pend:
                        cnt = _put_capsule(out, cnt, write, pax, pay, pbx, pby, prho, thin, q)
                        pend = False
                    kept = False
                    continue
                ax = px + lo * dx
                ay = py + lo * dy
                bx = px + hi * dx
                by = py + hi * dy
                if thin > 0.0 and kept and rho <= lrho:
                    lim = 8.0 * thin * rho
                    if (ax - lax) ** 2 + (ay - lay) ** 2 <= lim and (bx - lbx) ** 2 + (
                        by - lby
                    ) ** 2 <= lim:
                        pend = True
                        pax, pay, pbx, pby, prho = ax, ay, bx, by, rho
                        continue
                pend = False
                kept = True
                lax, lay, lbx, lby, lrho = ax, ay, bx, by, rho
                cnt = _put_capsule(out, cnt, write, ax, ay, bx, by, rho, thin, q)
        if pend:
            cnt = _put_capsule(out, cnt, write, pax, pay, pbx, pby, prho, thin, q)
    return cnt


@inner_kernel(error_model="numpy")
def _fill_disk_samples(v, paths, margin, n_sub, q, reach, a_max, per_second, thin, out):
    """:func:`nao_disk_samples` of the :class:`~.bundles.Paths` into the rows of ``out``;
    returns how many it wrote. Arrays borrowed here."""
    seg_t, seg_c, seg_w, seg_b, radius = paths
    v, seg_t, seg_c, seg_w = borrowed(v), borrowed(seg_t), borrowed(seg_c), borrowed(seg_w)
    seg_b, radius, q, out = borrowed(seg_b), borrowed(radius), borrowed(q), borrowed(out)
    N = seg_c.shape[0]
    S = seg_c.shape[1]
    cnt = np.int64(0)
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
                far = (
                    rr
                    + 0.5 * a_max * t1 * t1
                    + vector_norm(seg_w[n, j, 0] - v[0], seg_w[n, j, 1] - v[1]) * h
                    + 0.5 * vector_norm(seg_b[n, j, 0], seg_b[n, j, 1]) * h * h
                ) * (1.0 + 1e-6)
                if dx0 * dx0 + dy0 * dy0 > far * far:
                    if pend:
                        cnt = _put(out, cnt, px, py, prho, pdq)
                        pend = False
                    last = -1
                    continue
            k, head, tail = _piece_schedule(j, S, t0, t1, n_sub, per_second)
            for i in range(k + head + tail):
                t = _sample_time(t0, t1, i, k, head)
                if t * t <= 0.0 or not math.isfinite(2.0 / (t * t)):
                    continue
                dt = t - t0
                cx = seg_c[n, j, 0] + seg_w[n, j, 0] * dt + 0.5 * seg_b[n, j, 0] * dt * dt
                cy = seg_c[n, j, 1] + seg_w[n, j, 1] * dt + 0.5 * seg_b[n, j, 1] * dt * dt
                inv = 2.0 / (t * t)
                mx = (cx - v[0] * t) * inv
                my = (cy - v[1] * t) * inv
                rho = rr * inv
                if _farther(mx - q[0], my - q[1], rho + reach) or _farther(mx, my, rho + a_max):
                    if pend:
                        cnt = _put(out, cnt, px, py, prho, pdq)
                        pend = False
                    last = -1
                    continue
                dq = vector_norm(mx - q[0], my - q[1])
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


@inner_kernel(error_model="numpy")
def nao_disks(v, paths, walls, margin, n_sub, q, reach, a_max, per_second=16.0):
    """Sampled disks of the NAO union near q, in acceleration space (m/s^2).

    A constant acceleration a collides with an obstacle (of the :class:`~.bundles.Paths`;
    walls: the :class:`~.bundles.Walls`) at time t iff |a - m(t)| <= rho(t),
    m(t) = 2 (c(t) - v t) / t^2, rho(t) = 2 r / t^2 (v (2,) m/s the robot's velocity; no
    speed saturation). Samples every piece at max(n_sub, per_second * h) times (per_second
    1/s; and the first piece also geometrically towards t = 0), grows r by ``margin`` (m)
    and keeps the disks that intersect both the ball B(q, reach) and the limit disc
    |a| <= a_max (m/s^2); disks inside another are dropped. Returns (M, 3) rows
    (m_x, m_y, rho).
    """
    return drop_contained(
        np.ascontiguousarray(
            nao_disk_samples(v, paths, walls, margin, n_sub, q, reach, a_max, per_second)[:, :3]
        )
    )


@inner_kernel(error_model="numpy")
def nao_disks_within(samples, reach):
    """:func:`nao_disks` for ``reach`` (m/s^2) from the samples of
    :func:`nao_disk_samples` taken with a reach at least as large."""
    return disks_within(samples, radius_order(samples), reach)


@inner_kernel(error_model="numpy")
def radius_order(rows):
    """Rows (disks or samples) largest radius first, equal radii in row order (a stable
    sort): the visiting order of :func:`_uncontained_in`, for any subset of the rows."""
    return stable_argsort(-rows[:, 2])


@inner_kernel(error_model="numpy")
def disks_within(samples, order, reach):
    """:func:`nao_disks_within` with the samples' :func:`radius_order` given."""
    keep, _ = _uncontained_in(samples, order, reach, samples.shape[0])
    return np.ascontiguousarray(samples[keep][:, :3])


@inner_kernel(error_model="numpy")
def largest_capped_reach(samples, reach, limit, max_disks):
    """Double ``reach`` (m/s^2) while below ``limit``: the last doubled reach whose
    :func:`nao_disks_within` holds at most ``max_disks`` disks, stopping at the first
    that holds more; -1.0 when there is none."""
    return capped_disks(samples, radius_order(samples), reach, limit, max_disks)[0]


@inner_kernel(error_model="numpy")
def capped_disks(samples, order, reach, limit, max_disks):
    """:func:`largest_capped_reach` and its :func:`nao_disks_within` (empty when there
    is none), from the samples' :func:`radius_order`. Containment is only worked out
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


@inner_kernel(error_model="numpy")
def drop_contained(disks):
    """The disks (M, 3) that no other disk contains (of identical ones, the first).

    Only a disk at least as large can contain another, and containment is
    transitive, so the disks are visited largest first and each is tested
    against the disks kept so far only (few, typically), not against all M.
    """
    keep, _ = _uncontained_in(disks, radius_order(disks), math.inf, disks.shape[0])
    return disks[keep]


@inner_kernel(error_model="numpy")
def _uncontained_in(rows, order, reach, stop_after):
    """:func:`drop_contained`'s mask (over ``rows``) and count of kept disks, among the
    rows: disks (M, 3), or samples (M, 4) of which only those within ``reach`` (m/s^2)
    take part; visited in ``order`` (:func:`radius_order`). The visit stops as soon as
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
            d = vector_norm(xi - rows[j, 0], yi - rows[j, 1])
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
