"""Exact clearance of constant-acceleration candidates against piecewise paths.

Frame: the robot starts at the origin at t = 0. Robot path (the model the world
implements): x(t) = v t + a t^2 / 2 until the speed |v + a t| reaches v_max
(time tau), then constant velocity. A robot already above v_max starts from its
velocity scaled down to v_max. Obstacles follow piecewise-quadratic paths
(times seg_t (S+1,) s; per obstacle and piece the start centre seg_c m,
velocity seg_w m/s and acceleration seg_b m/s^2); the minimum distance on each
piece comes from :func:`~nao_arena.geometry._kernel.quartic.piece_minimum`.

A candidate's motion travels as a :class:`~.bundles.Motion`; the kernels called from
Python take the obstacles as :class:`~.bundles.Paths` or :class:`~.bundles.Obstacles`
and the walls as :class:`~.bundles.Walls`.
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry._kernel.bundles import Motion
from nao_arena.geometry._kernel.quartic import end_dist2, piece_minimum
from nao_arena.geometry._kernel.robot_path import candidate_setup, robot_state
from nao_arena.geometry._kernel.segment import wall_first_contact, wall_scan, wall_violation
from nao_arena.geometry.borrow import borrowed_fields
from nao_arena.jit import inner_kernel, kernel


@inner_kernel(error_model="numpy")
def scan_obstacle(motion, seg_t, seg_c, seg_w, seg_b, sweep, n, r, thresh, want_first, buf, out):
    """Scan obstacle n (radius r m) over all pieces for one robot candidate (its
    :class:`~.bundles.Motion`). The obstacles' paths: seg_t (S+1,) s, seg_c, seg_w, seg_b
    (N, S, 2) m, m/s, m/s^2 and their sweep (N, S) m, as in :class:`~.bundles.Obstacles`
    (whose radii the callers grow or cut into r).

    With a finite ``thresh`` (m) the scan only decides whether the clearance
    falls below it: it prunes pieces that cannot come that close and returns
    at the first that does (out[0] is then some distance below thresh + r) with that
    piece's index (else -1). Otherwise out = (min squared distance, its time, first contact
    time), and it returns -1.
    """
    vx, vy, ax, ay, tau, speed_bound = motion
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
        if decide and piece_out_of_reach(
            vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c, sweep, n, j, reach
        ):
            continue
        ta = t0
        while ta < t1:
            tb = min(t1, tau) if ta < tau else t1
            Ax, Ay, Bx, By, Cx, Cy = _relative(
                vx, vy, ax, ay, tau, ta, t0, seg_c, seg_w, seg_b, n, j
            )
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
            end = end_dist2(Ax, Ay, Bx, By, Cx, Cy, hp) if decide else math.inf
            if end < reach2:
                # an end of the sub-piece is already that close: no minimum needed
                out[0] = end
                out[1] = ta
                out[2] = first
                return j
            if not skip:
                piece_minimum(Ax, Ay, Bx, By, Cx, Cy, hp, r2, want_first and first == math.inf, buf)
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


@inner_kernel(error_model="numpy")
def piece_out_of_reach(vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c, sweep, n, j, reach):
    """Cheap prune: whether robot and obstacle n are so far apart at the start of piece j
    (finite) that they cannot come within ``reach`` (m) during it: the robot moves at most
    speed_bound (m/s) times the piece's length, the obstacle at most sweep[n, j] (m)."""
    h = seg_t[j + 1] - seg_t[j]
    if not math.isfinite(h):
        return False
    rax, ray, rvx, rvy, rpx, rpy = robot_state(vx, vy, ax, ay, tau, seg_t[j])
    cx = rpx - seg_c[n, j, 0]
    cy = rpy - seg_c[n, j, 1]
    bound = (reach + sweep[n, j] + speed_bound * h) * (1.0 + 1e-9)
    return cx * cx + cy * cy > bound * bound


@inner_kernel(error_model="numpy")
def _relative(vx, vy, ax, ay, tau, ta, t0, seg_c, seg_w, seg_b, n, j):
    """Robot minus obstacle n from time ta within piece j (which starts at t0), as
    A s^2 + B s + C (s = time since ta): (Ax, Ay, Bx, By, Cx, Cy)."""
    rax, ray, rvx, rvy, rpx, rpy = robot_state(vx, vy, ax, ay, tau, ta)
    dt0 = ta - t0
    obx = seg_b[n, j, 0]
    oby = seg_b[n, j, 1]
    return (
        0.5 * (rax - obx),
        0.5 * (ray - oby),
        rvx - (seg_w[n, j, 0] + obx * dt0),
        rvy - (seg_w[n, j, 1] + oby * dt0),
        rpx - (seg_c[n, j, 0] + seg_w[n, j, 0] * dt0 + 0.5 * obx * dt0 * dt0),
        rpy - (seg_c[n, j, 1] + seg_w[n, j, 1] * dt0 + 0.5 * oby * dt0 * dt0),
    )


@inner_kernel(error_model="numpy")
def piece_within(motion, seg_t, seg_c, seg_w, seg_b, n, j, reach2, buf):
    """Whether the candidate (its :class:`~.bundles.Motion`, as in :func:`scan_obstacle`)
    comes closer than sqrt(reach2) (m) to obstacle n during piece j: the test
    :func:`scan_obstacle` makes there, without its prune."""
    vx, vy, ax, ay, tau, _ = motion
    t0 = seg_t[j]
    t1 = seg_t[j + 1]
    ta = t0
    while ta < t1:
        tb = min(t1, tau) if ta < tau else t1
        Ax, Ay, Bx, By, Cx, Cy = _relative(vx, vy, ax, ay, tau, ta, t0, seg_c, seg_w, seg_b, n, j)
        if end_dist2(Ax, Ay, Bx, By, Cx, Cy, tb - ta) < reach2:
            return True
        piece_minimum(Ax, Ay, Bx, By, Cx, Cy, tb - ta, 0.0, False, buf)
        if buf[0] < reach2:
            return True
        ta = tb
    return False


@kernel(error_model="numpy")
def piece_sweep(seg_t, seg_w, seg_b):
    """(N, S) bound on how far each obstacle moves within each piece (m)."""
    out = np.empty((seg_w.shape[0], seg_w.shape[1]))
    fill_sweep(seg_t, seg_w, seg_b, seg_w.shape[0], out)
    return out


@inner_kernel(error_model="numpy")
def fill_sweep(seg_t, seg_w, seg_b, rows, out):
    """:func:`piece_sweep` of the first ``rows`` obstacles, into out[:rows]."""
    for n in range(rows):
        for j in range(seg_w.shape[1]):
            h = seg_t[j + 1] - seg_t[j]
            w = math.sqrt(seg_w[n, j, 0] ** 2 + seg_w[n, j, 1] ** 2)
            b = math.sqrt(seg_b[n, j, 0] ** 2 + seg_b[n, j, 1] ** 2)
            out[n, j] = w * h + 0.5 * b * h * h


@kernel(error_model="numpy")
def clearance_kernel(cand_v, cand_a, v_max, paths, walls, out_clear, out_tmin, out_tfirst):
    """Exact clearance for K candidates x (N obstacles, then W walls).

    cand_v, cand_a: (K, 2) initial velocity (m/s) and constant acceleration
    (m/s^2) of the robot per candidate; v_max: its speed limit (m/s). paths: the
    :class:`~.bundles.Paths` (seg_t (S + 1,) piece boundaries (s), seg_t[0] = 0, last
    may be inf; seg_c, seg_w, seg_b (N, S, 2) obstacle centre (m, relative to the
    robot's start), velocity and acceleration at the start of each piece; radius (N,)
    combined radius (m)). walls: the :class:`~.bundles.Walls` (ends (W, 2, 2) static
    segments (m, robot-relative), radius (W,) their combined radii (m)).
    Outputs (K, N + W): clearance (m), time of closest approach (s), time of
    first contact (s, inf if none).
    """
    seg_t, seg_c, seg_w, seg_b, radius = paths
    ends, wall_r = walls
    K = cand_a.shape[0]
    N = seg_c.shape[0]
    W = ends.shape[0]
    sweep = np.zeros((N, seg_c.shape[1]))
    buf = np.empty(3)
    out = np.empty(3)
    horizon = seg_t[-1]
    for k in range(K):
        vx, vy, tau, bound = candidate_setup(
            cand_v[k, 0], cand_v[k, 1], cand_a[k, 0], cand_a[k, 1], v_max, horizon
        )
        motion = Motion(vx, vy, cand_a[k, 0], cand_a[k, 1], tau, bound)
        for n in range(N):
            scan_obstacle(
                motion,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                sweep,
                n,
                radius[n],
                math.inf,
                np.bool_(True),
                buf,
                out,
            )
            out_clear[k, n] = math.sqrt(out[0]) - radius[n]
            out_tmin[k, n] = out[1]
            out_tfirst[k, n] = out[2]
        for w in range(W):
            wall_scan(
                motion,
                horizon,
                ends[w, 0, 0],
                ends[w, 0, 1],
                ends[w, 1, 0],
                ends[w, 1, 1],
                wall_r[w],
                np.bool_(True),
                buf,
                out,
            )
            out_clear[k, N + w] = math.sqrt(out[0]) - wall_r[w]
            out_tmin[k, N + w] = out[1]
            out_tfirst[k, N + w] = out[2]


@kernel(error_model="numpy")
def admissible_kernel(cand_v, cand_a, v_max, obstacles, walls, margin, out_ok):
    """out_ok[k] = True iff candidate k (cand_v, cand_a, v_max: see
    :func:`clearance_kernel`) keeps clearance >= margin (m) from every obstacle (the
    :class:`~.bundles.Obstacles`: the paths with their sweeps) and wall (the
    :class:`~.bundles.Walls`: ends (W, 2, 2) m, radii (W,) m).

    Prunes pieces with a conservative distance bound and stops at the first
    violation, so it is much cheaper than the exact clearance. The walls' arrays are
    borrowed here.
    """
    seg_t, seg_c, seg_w, seg_b, radius, sweep = obstacles
    walls = borrowed_fields(walls)
    K = cand_a.shape[0]
    N = seg_c.shape[0]
    buf = np.empty(3)
    out = np.empty(3)
    horizon = seg_t[-1]
    for k in range(K):
        vx, vy, tau, bound = candidate_setup(
            cand_v[k, 0], cand_v[k, 1], cand_a[k, 0], cand_a[k, 1], v_max, horizon
        )
        motion = Motion(vx, vy, cand_a[k, 0], cand_a[k, 1], tau, bound)
        ok = True
        for n in range(N):
            scan_obstacle(
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
                out,
            )
            if out[0] < (radius[n] + margin) ** 2:
                ok = False
                break
        if (
            ok
            and walls.ends.shape[0]
            and wall_violation(motion, horizon, walls, margin, -1, buf, out) >= 0
        ):
            ok = False
        out_ok[k] = ok


@inner_kernel(error_model="numpy")
def _first_contact(motion, seg_t, seg_c, seg_w, seg_b, sweep, n, r, t_stop, buf):
    """First time (s) the robot (its :class:`~.bundles.Motion`) comes within r (m) of
    obstacle n (paths and sweeps as :func:`scan_obstacle` takes them), if before t_stop
    (s); else inf."""
    vx, vy, ax, ay, tau, speed_bound = motion
    S = seg_c.shape[1]
    r2 = r * r
    for j in range(S):
        t0 = seg_t[j]
        if t0 >= t_stop:
            break
        t1 = seg_t[j + 1]
        if piece_out_of_reach(vx, vy, ax, ay, tau, speed_bound, seg_t, seg_c, sweep, n, j, r):
            continue
        ta = t0
        while ta < t1:
            tb = min(t1, tau) if ta < tau else t1
            rax, ray, rvx, rvy, rpx, rpy = robot_state(vx, vy, ax, ay, tau, ta)
            dt0 = ta - t0
            obx = seg_b[n, j, 0]
            oby = seg_b[n, j, 1]
            piece_minimum(
                0.5 * (rax - obx),
                0.5 * (ray - oby),
                rvx - (seg_w[n, j, 0] + obx * dt0),
                rvy - (seg_w[n, j, 1] + oby * dt0),
                rpx - (seg_c[n, j, 0] + seg_w[n, j, 0] * dt0 + 0.5 * obx * dt0 * dt0),
                rpy - (seg_c[n, j, 1] + seg_w[n, j, 1] * dt0 + 0.5 * oby * dt0 * dt0),
                tb - ta,
                r2,
                np.bool_(True),
                buf,
            )
            if buf[2] < math.inf:
                return ta + buf[2]
            ta = tb
    return math.inf


@kernel(error_model="numpy")
def latest_contact_kernel(cand_v, cand_a, v_max, obstacles, walls, out_first):
    """Earliest first contact (s) over all obstacles (the :class:`~.bundles.Obstacles`) and
    walls (the :class:`~.bundles.Walls`) per candidate (see :func:`admissible_kernel`),
    for picking the latest.

    A candidate's scan stops as soon as its earliest contact falls below the
    best (latest) found so far among earlier candidates; its entry is then
    an upper bound below that best (it cannot win), not the exact value. The walls'
    arrays are borrowed here.
    """
    seg_t, seg_c, seg_w, seg_b, radius, sweep = obstacles
    walls = borrowed_fields(walls)
    K = cand_a.shape[0]
    N = seg_c.shape[0]
    buf = np.empty(3)
    out = np.empty(3)
    best = -math.inf
    horizon = seg_t[-1]
    for k in range(K):
        vx, vy, tau, bound = candidate_setup(
            cand_v[k, 0], cand_v[k, 1], cand_a[k, 0], cand_a[k, 1], v_max, horizon
        )
        motion = Motion(vx, vy, cand_a[k, 0], cand_a[k, 1], tau, bound)
        tf = math.inf
        for n in range(N):
            f = _first_contact(
                motion,
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                sweep,
                n,
                radius[n],
                tf,
                buf,
            )
            if f < tf:
                tf = f
            if tf < best:
                break
        if walls.ends.shape[0] and not tf < best:
            f = wall_first_contact(motion, horizon, walls, tf, buf, out)
            if f < tf:
                tf = f
        out_first[k] = tf
        if tf > best:
            best = tf
