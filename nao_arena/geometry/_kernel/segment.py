"""Exact clearance of a constant-acceleration robot against static line segments.

Frame: the robot starts at the origin at t = 0; segments [p, q] (m) are given
relative to it. Robot path (the model the world drives, see
:mod:`nao_arena.motion`): x(t) = v t + a t^2 / 2 until the speed |v + a t|
reaches v_max (time tau), then constant velocity; a robot already above v_max
starts from its velocity scaled down to v_max.

On each piece of the path (parabolic up to tau, straight after) the centre is
d(s) = A s^2 + B s + C. Its distance to the segment is, at every time, the
distance to the segment's line while the foot of the perpendicular lies within
[p, q], else the distance to the nearer end. So the minimum over the piece is the
smallest of

- the minimum distance to each end cap p and q over the whole piece (the point
  quartic, :func:`~nao_arena.geometry._kernel.quartic.piece_minimum`; the distance
  to an end is never below the distance to the segment, so unrestricted caps are
  safe, and they cover the times where the foot crosses an end, where the line
  distance equals the cap distance);
- the line distance |e(s)|, e(s) = n . (d(s) - p) a quadratic (n the unit
  normal), at the candidates where the foot lies within [p, q]: the piece's ends,
  the roots of e (the path crosses the line: distance 0) and the root of e'
  (|e| stationary). On the straight piece e is linear: this is the closed-form
  distance between the swept straight piece and the segment.

A degenerate segment (p == q) is a point: only its caps count.

The first contact with a grown segment (distance <= r) is the earliest of the caps'
first contacts and the roots of e(s)^2 = r^2 |q - p|^2 whose foot lies within [p, q]
(distances to the ends are never below the distance to the segment, and at the first
contact the distance is exactly r, reached at an end or at an interior foot).

Walls in the selection: a :class:`~.bundles.Walls` bundle, robot-relative ends (W, 2, 2)
m and their combined radii (W,) m (half-thickness + the robot's radius + its margin, cut
to just under the current distance like every obstacle's); an acceleration is
admissible against wall w when its path stays at least radius[w] + margin from the
segment (:func:`wall_violation`). The robot's path arrives as a :class:`~.bundles.Motion`;
a piece of it and a segment's line travel in :class:`PathPiece` and :class:`SegmentLine`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from nao_arena.geometry._kernel.bundles import Motion
from nao_arena.geometry._kernel.quartic import piece_minimum
from nao_arena.geometry._kernel.robot_path import candidate_setup
from nao_arena.geometry._kernel.sampled import RADIUS_CUT
from nao_arena.geometry.borrow import borrowed
from nao_arena.jit import inner_kernel, kernel

__all__ = [
    "PathPiece",
    "SegmentLine",
    "nearby_walls",
    "point_segment_dist2",
    "relevant_walls",
    "segment_admissible",
    "segment_min_distance",
    "segment_segment_dist2",
    "segments_admissible",
    "segment_within",
    "segments_min_distance",
    "wall_first_contact",
    "wall_scan",
    "wall_violation",
]


class PathPiece(NamedTuple):
    """One piece of the robot's path (frame of :mod:`nao_arena.geometry`), its centre
    d(s) = A s^2 + B s + C at the time s (s) since the piece's start: A = (ax, ay) m/s^2
    (half the acceleration), B = (bx, by) m/s (the velocity at s = 0), C = (cx, cy) m (the
    centre at s = 0)."""

    ax: float
    ay: float
    bx: float
    by: float
    cx: float
    cy: float


class SegmentLine(NamedTuple):
    """The segment [p, q] of a wall as the line scans take it (frame of
    :mod:`nao_arena.geometry`): its start p = (px, py) m, u = q - p = (ux, uy) m and
    ll = |q - p|^2 m^2 (> 0)."""

    px: float
    py: float
    ux: float
    uy: float
    ll: float


@inner_kernel(error_model="numpy")
def _path_segment_dist2(motion, horizon, px, py, qx, qy, buf, out):
    """Minimum squared distance (m^2) over t in [0, horizon] (s) from the robot's centre
    (its :class:`~.bundles.Motion`) to the segment [p, q] (m) (:func:`wall_scan`)."""
    wall_scan(motion, horizon, px, py, qx, qy, 0.0, np.bool_(False), buf, out)
    return out[0]


@inner_kernel(error_model="numpy")
def point_segment_dist2(px, py, qx, qy):
    """Squared distance (m^2) from the origin to the segment [p, q]."""
    ux = qx - px
    uy = qy - py
    ll = ux * ux + uy * uy
    u = 0.0
    if ll > 0.0:
        u = min(max(-(px * ux + py * uy) / ll, 0.0), 1.0)
    dx = px + u * ux
    dy = py + u * uy
    return dx * dx + dy * dy


@inner_kernel
def point_segment_distance(px, py, ax, ay, bx, by):
    """Distance (m) from the point p to the segment [a, b]: hypot(ap - t ab), t the
    foot's parameter clamped to [0, 1] (0 for a segment of zero length): the contact
    check's and occlusion's distance. :func:`nao_arena.geometry.walls.segment_distances_xy`
    is this in numpy (the same bits, but for segments shorter than 1e-150 m, which it
    guards otherwise; tests/test_point_segment.py). :func:`point_segment_dist2` is the
    squared distance of the planners' hot loops, with other arithmetic."""
    abx, aby = bx - ax, by - ay
    ll = abx * abx + aby * aby
    apx, apy = px - ax, py - ay
    t = min(max((apx * abx + apy * aby) / (ll if ll > 0 else 1.0), 0.0), 1.0)
    return math.hypot(apx - abx * t, apy - aby * t)


@inner_kernel
def segment_segment_distance(p0x, p0y, p1x, p1y, ax, ay, bx, by):
    """Distance (m) between the segments [p0, p1] and [a, b] (0 if they cross): the
    smallest :func:`point_segment_distance` of an end point to the other segment."""
    ex, ey = p1x - p0x, p1y - p0y
    fx, fy = bx - ax, by - ay
    o1 = fx * (p0y - ay) - fy * (p0x - ax)
    o2 = fx * (p1y - ay) - fy * (p1x - ax)
    o3 = ex * (ay - p0y) - ey * (ax - p0x)
    o4 = ex * (by - p0y) - ey * (bx - p0x)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return 0.0
    return min(
        min(
            point_segment_distance(p0x, p0y, ax, ay, bx, by),
            point_segment_distance(p1x, p1y, ax, ay, bx, by),
        ),
        min(
            point_segment_distance(ax, ay, p0x, p0y, p1x, p1y),
            point_segment_distance(bx, by, p0x, p0y, p1x, p1y),
        ),
    )


@inner_kernel
def segment_segment_dist2(ax, ay, bx, by, px, py, qx, qy):
    """Squared distance (m^2) between the segments [a, b] and [p, q]."""
    best = math.inf
    for k in range(4):
        if k == 0:
            ox, oy, sx, sy, ex, ey = ax, ay, px, py, qx, qy
        elif k == 1:
            ox, oy, sx, sy, ex, ey = bx, by, px, py, qx, qy
        elif k == 2:
            ox, oy, sx, sy, ex, ey = px, py, ax, ay, bx, by
        else:
            ox, oy, sx, sy, ex, ey = qx, qy, ax, ay, bx, by
        ux = ex - sx
        uy = ey - sy
        ll = ux * ux + uy * uy
        u = 0.0
        if ll > 0.0:
            u = min(max(((ox - sx) * ux + (oy - sy) * uy) / ll, 0.0), 1.0)
        dx = sx + u * ux - ox
        dy = sy + u * uy - oy
        d2 = dx * dx + dy * dy
        if d2 < best:
            best = d2
    # a proper crossing: distance 0
    d1 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    d2_ = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
    d3 = (qx - px) * (ay - py) - (qy - py) * (ax - px)
    d4 = (qx - px) * (by - py) - (qy - py) * (bx - px)
    if ((d1 > 0.0) != (d2_ > 0.0)) and ((d3 > 0.0) != (d4 > 0.0)) and d1 != 0.0 and d2_ != 0.0:
        return 0.0
    return best


@inner_kernel(error_model="numpy")
def segment_min_distance(
    vx: float,
    vy: float,
    ax: float,
    ay: float,
    v_max: float,
    px: float,
    py: float,
    qx: float,
    qy: float,
    horizon: float,
) -> float:
    """Exact minimum over t in [0, horizon] (s) of the distance (m) from the robot's centre
    (velocity (vx, vy) m/s, acceleration (ax, ay) m/s^2, speed limit v_max m/s) to the
    static segment [p, q] (m, robot-relative). 0 when the robot starts on the segment."""
    buf = np.empty(3)
    out = np.empty(3)
    vx, vy, tau, bound = candidate_setup(vx, vy, ax, ay, v_max, horizon)
    motion = Motion(vx, vy, ax, ay, tau, bound)
    return math.sqrt(_path_segment_dist2(motion, horizon, px, py, qx, qy, buf, out))


@inner_kernel(error_model="numpy")
def segment_admissible(
    v: np.ndarray,
    a: np.ndarray,
    v_max: float,
    p: np.ndarray,
    q: np.ndarray,
    half_thickness: float,
    radius: float,
    margin: float,
    horizon: float,
) -> bool:
    """Whether the robot (v (2,) m/s, a (2,) m/s^2, v_max m/s, radius m) stays farther than
    radius + half_thickness + margin (m) from the wall [p, q] ((2,) m each, robot-relative)
    over t in [0, horizon] (s)."""
    v, a, p, q = borrowed(v), borrowed(a), borrowed(p), borrowed(q)
    d = segment_min_distance(v[0], v[1], a[0], a[1], v_max, p[0], p[1], q[0], q[1], horizon)
    return d > radius + half_thickness + margin


@inner_kernel(error_model="numpy")
def _fill_segments(v, a, v_max, walls, half_thickness, horizon, stop_below, buf, out):
    """(min over walls of distance - half_thickness (m), its wall index); stops at the first
    wall below ``stop_below`` (m; -inf: never). Prunes walls the robot cannot reach closer than
    the best so far. Arrays borrowed here."""
    v, a, walls = borrowed(v), borrowed(a), borrowed(walls)
    half_thickness, buf, out = borrowed(half_thickness), borrowed(buf), borrowed(out)
    vx, vy, tau, bound = candidate_setup(v[0], v[1], a[0], a[1], v_max, horizon)
    motion = Motion(vx, vy, a[0], a[1], tau, bound)
    reach = bound * horizon  # the path stays within this distance of the origin (m)
    best = math.inf
    index = -1
    for w in range(walls.shape[0]):
        px = walls[w, 0, 0]
        py = walls[w, 0, 1]
        qx = walls[w, 1, 0]
        qy = walls[w, 1, 1]
        if index >= 0 and math.isfinite(reach):
            lower = math.sqrt(point_segment_dist2(px, py, qx, qy)) - reach - half_thickness[w]
            if lower - 1e-9 * (1.0 + abs(lower)) > best:
                continue
        d = (
            math.sqrt(_path_segment_dist2(motion, horizon, px, py, qx, qy, buf, out))
            - half_thickness[w]
        )
        if d < best or index < 0:
            best = d
            index = w
        if best < stop_below:
            break
    return best, index


@inner_kernel(error_model="numpy")
def segments_min_distance(
    v: np.ndarray,
    a: np.ndarray,
    v_max: float,
    walls: np.ndarray,
    half_thickness: np.ndarray,
    horizon: float,
) -> tuple[float, int]:
    """Minimum over the walls (W, 2, 2) (m, robot-relative ends) of the exact minimum distance
    from the robot's centre to the wall minus its half_thickness (W,) (m), over t in
    [0, horizon] (s), and the index of that closest wall (-1 and inf when W = 0)."""
    return _fill_segments(
        v, a, v_max, walls, half_thickness, horizon, -math.inf, np.empty(3), np.empty(3)
    )


@inner_kernel(error_model="numpy")
def segments_admissible(
    v: np.ndarray,
    a: np.ndarray,
    v_max: float,
    walls: np.ndarray,
    half_thickness: np.ndarray,
    radius: float,
    margin: float,
    horizon: float,
) -> bool:
    """:func:`segment_admissible` against every wall (W, 2, 2) with half_thickness (W,) (m);
    stops at the first wall that is too close."""
    limit = radius + margin
    d, index = _fill_segments(
        v, a, v_max, walls, half_thickness, horizon, limit, np.empty(3), np.empty(3)
    )
    return d > limit


@inner_kernel(error_model="numpy")
def _line_scan(s, h, piece, line, best, best_s):
    """(min(best, squared distance (m^2) from d(s) (the :class:`PathPiece`) to the
    segment's line), its s) when s lies in [0, h] (s) and the foot of d(s) within the
    segment (the :class:`SegmentLine`), else (best, best_s)."""
    if not (0.0 <= s <= h) or not math.isfinite(s):
        return best, best_s
    ax, ay, bx, by, cx, cy = piece
    px, py, ux, uy, ll = line
    dx = (ax * s + bx) * s + cx - px
    dy = (ay * s + by) * s + cy - py
    along = dx * ux + dy * uy
    if along < 0.0 or along > ll:
        return best, best_s
    cross = dx * uy - dy * ux
    e2 = cross * cross / ll
    if e2 < best:
        return e2, s
    return best, best_s


@inner_kernel(error_model="numpy")
def _foot_within(s, piece, line):
    """Whether the foot of d(s) (the :class:`PathPiece`) on the segment's line lies within
    the segment (the :class:`SegmentLine`)."""
    ax, ay, bx, by, cx, cy = piece
    px, py, ux, uy, ll = line
    dx = (ax * s + bx) * s + cx - px
    dy = (ay * s + by) * s + cy - py
    along = dx * ux + dy * uy
    return 0.0 <= along <= ll


@inner_kernel(error_model="numpy")
def _roots_within(qa, qb, qc, h):
    """The roots s in [0, h] of qa s^2 + qb s + qc, smaller first (inf for a missing one)."""
    s1 = math.inf
    s2 = math.inf
    if qa == 0.0:
        if qb != 0.0:
            s = -qc / qb
            if 0.0 <= s <= h:
                s1 = s
        return s1, s2
    disc = qb * qb - 4.0 * qa * qc
    if disc < 0.0:
        return s1, s2
    sq = math.sqrt(disc)
    qq = -0.5 * (qb + sq) if qb >= 0.0 else -0.5 * (qb - sq)
    r1 = qq / qa
    r2 = qc / qq if qq != 0.0 else math.inf
    if r2 < r1:
        r1, r2 = r2, r1
    if 0.0 <= r1 <= h:
        s1 = r1
        if 0.0 <= r2 <= h:
            s2 = r2
    elif 0.0 <= r2 <= h:
        s1 = r2
    return s1, s2


@inner_kernel(error_model="numpy")
def _piece_scan(piece, h, px, py, qx, qy, r, want_first, buf, out):
    """Over s in [0, h] (s) of d(s) = A s^2 + B s + C (the :class:`PathPiece`) and the
    segment [p, q] (m): out = (minimum squared distance (m^2), its s, the first s with
    distance <= r (m) (inf: none; computed when want_first))."""
    ax, ay, bx, by, cx, cy = piece
    piece_minimum(ax, ay, bx, by, cx - px, cy - py, h, r * r, want_first, buf)
    best = buf[0]
    best_s = buf[1]
    first = buf[2] if want_first else math.inf
    ux = qx - px
    uy = qy - py
    ll = ux * ux + uy * uy
    if ll > 0.0:
        piece_minimum(ax, ay, bx, by, cx - qx, cy - qy, h, r * r, want_first, buf)
        if buf[0] < best:
            best = buf[0]
            best_s = buf[1]
        if want_first and buf[2] < first:
            first = buf[2]
        ea = ax * uy - ay * ux
        eb = bx * uy - by * ux
        ec = (cx - px) * uy - (cy - py) * ux
        line = SegmentLine(px, py, ux, uy, ll)
        best, best_s = _line_scan(0.0, h, piece, line, best, best_s)
        if math.isfinite(h):
            best, best_s = _line_scan(h, h, piece, line, best, best_s)
        if ea == 0.0:
            if eb != 0.0:
                best, best_s = _line_scan(-ec / eb, h, piece, line, best, best_s)
        else:
            disc = eb * eb - 4.0 * ea * ec
            if disc >= 0.0:
                sq = math.sqrt(disc)
                qq = -0.5 * (eb + sq) if eb >= 0.0 else -0.5 * (eb - sq)
                best, best_s = _line_scan(qq / ea, h, piece, line, best, best_s)
                if qq != 0.0:
                    best, best_s = _line_scan(ec / qq, h, piece, line, best, best_s)
            best, best_s = _line_scan(-eb / (2.0 * ea), h, piece, line, best, best_s)
        if best_s > h:
            best_s = h
        if want_first:
            # e(s)^2 = r^2 ll where the foot is within the segment: e = -r sqrt(ll) and
            # e = +r sqrt(ll); at s = 0 already within r
            rl = r * math.sqrt(ll)
            if ec * ec <= rl * rl and _foot_within(0.0, piece, line):
                first = 0.0
            for sign in (-1.0, 1.0):
                s1, s2 = _roots_within(ea, eb, ec - sign * rl, min(h, first))
                if s1 < first and _foot_within(s1, piece, line):
                    first = s1
                elif s2 < first and _foot_within(s2, piece, line):
                    first = s2
    out[0] = best
    out[1] = best_s
    out[2] = first


@inner_kernel(error_model="numpy")
def wall_scan(motion, horizon, px, py, qx, qy, r, want_first, buf, out):
    """The robot's path (its :class:`~.bundles.Motion`: speed already clamped, saturation
    time tau s, see :func:`~nao_arena.geometry._kernel.robot_path.candidate_setup`; its
    bound is not used) against the static segment [p, q] (m, robot-relative) over t in
    [0, horizon] (s): out = (minimum squared distance (m^2), its time (s), the first time
    the distance is <= r (m) (s; inf: never, or not computed unless want_first))."""
    vx, vy, ax, ay, tau, _ = motion
    h1 = min(tau, horizon)
    _piece_scan(
        PathPiece(0.5 * ax, 0.5 * ay, vx, vy, 0.0, 0.0), h1, px, py, qx, qy, r, want_first, buf, out
    )
    if tau < horizon:
        best = out[0]
        best_t = out[1]
        first = out[2]
        if best > 0.0 or (want_first and first == math.inf):
            wx = vx + ax * tau
            wy = vy + ay * tau
            cx = vx * tau + 0.5 * ax * tau * tau
            cy = vy * tau + 0.5 * ay * tau * tau
            _piece_scan(
                PathPiece(0.0, 0.0, wx, wy, cx, cy),
                horizon - tau,
                px,
                py,
                qx,
                qy,
                r,
                want_first and first == math.inf,
                buf,
                out,
            )
            if out[0] < best:
                best = out[0]
                best_t = tau + out[1]
            if want_first and first == math.inf and out[2] < math.inf:
                first = tau + out[2]
        out[0] = best
        out[1] = best_t
        out[2] = first


@inner_kernel(error_model="numpy")
def _out_of_reach(px, py, qx, qy, travel, reach):
    """Cheap prune: the segment stays farther than ``reach`` (m) from every point within
    ``travel`` (m) of the origin."""
    if not math.isfinite(travel):
        return False
    lower = math.sqrt(point_segment_dist2(px, py, qx, qy)) - travel
    return lower > reach * (1.0 + 1e-9) + 1e-12


@inner_kernel(error_model="numpy")
def segment_within(motion, travel, horizon, px, py, qx, qy, reach, buf, out):
    """Whether the robot's path (its :class:`~.bundles.Motion`; it stays within ``travel``
    m of the origin) comes closer than ``reach`` (m) to the segment [p, q] (m,
    robot-relative) within ``horizon`` (s)."""
    if _out_of_reach(px, py, qx, qy, travel, reach):
        return False
    return _path_segment_dist2(motion, horizon, px, py, qx, qy, buf, out) < reach * reach


@inner_kernel(error_model="numpy")
def wall_violation(motion, horizon, walls, margin, first, buf, out):
    """The index of a wall (the :class:`~.bundles.Walls`: ends (W, 2, 2) m, robot-relative;
    radii (W,) m) that the robot's path (its :class:`~.bundles.Motion`) comes closer to
    than radius + margin (m) within ``horizon`` (s), or -1 when none does. Wall ``first``
    (if a valid index) is tested first."""
    ends, wall_r = walls
    W = ends.shape[0]
    travel = motion.bound * horizon
    for i in range(W):
        if i == 0 and 0 <= first < W:
            w = first
        elif 0 <= first < W:
            w = i - 1 if i <= first else i
        else:
            w = i
        if segment_within(
            motion,
            travel,
            horizon,
            ends[w, 0, 0],
            ends[w, 0, 1],
            ends[w, 1, 0],
            ends[w, 1, 1],
            wall_r[w] + margin,
            buf,
            out,
        ):
            return w
    return -1


@inner_kernel(error_model="numpy")
def wall_first_contact(motion, horizon, walls, t_stop, buf, out):
    """The earliest first contact (s) of the robot's path (its :class:`~.bundles.Motion`, as
    :func:`wall_violation`) with any wall (:class:`~.bundles.Walls`; distance <= its
    radius), if before t_stop (s); else inf."""
    ends, wall_r = walls
    travel = motion.bound * horizon
    best = math.inf
    for w in range(ends.shape[0]):
        px = ends[w, 0, 0]
        py = ends[w, 0, 1]
        qx = ends[w, 1, 0]
        qy = ends[w, 1, 1]
        if _out_of_reach(px, py, qx, qy, travel, wall_r[w]):
            continue
        wall_scan(
            motion,
            min(horizon, t_stop, best),
            px,
            py,
            qx,
            qy,
            wall_r[w],
            np.bool_(True),
            buf,
            out,
        )
        if out[2] < best:
            best = out[2]
    return best if best < t_stop else math.inf


@kernel(error_model="numpy")
def relevant_walls(v, a_max, v_max, horizon, walls, wall_r, margin):
    """The walls (walls (W, 2, 2) m robot-relative, radii wall_r (W,) m) that some
    acceleration with |a| <= a_max (m/s^2) could bring the robot (velocity v (2,) m/s,
    speed limit v_max m/s) within wall_r + margin (m) of within ``horizon`` (s): the robot
    stays within min(v_max T, |v| T + a_max T^2 / 2) of its start. Returns contiguous
    (walls, wall_r) of those kept, in input order (the inputs themselves when all are)."""
    W = walls.shape[0]
    speed = math.sqrt(v[0] * v[0] + v[1] * v[1])
    if speed > v_max:
        speed = v_max
    travel = min(v_max * horizon, speed * horizon + 0.5 * a_max * horizon * horizon)
    keep = np.zeros(W, dtype=np.bool_)
    n = 0
    for w in range(W):
        if not _out_of_reach(
            walls[w, 0, 0],
            walls[w, 0, 1],
            walls[w, 1, 0],
            walls[w, 1, 1],
            travel,
            wall_r[w] + margin,
        ):
            keep[w] = True
            n += 1
    if n == W:
        return np.ascontiguousarray(walls), np.ascontiguousarray(wall_r)
    out_w = np.empty((n, 2, 2))
    out_r = np.empty(n)
    k = 0
    for w in range(W):
        if keep[w]:
            for e in range(2):  # element by element: no broadcasting (its checks compile long)
                out_w[k, e, 0] = walls[w, e, 0]
                out_w[k, e, 1] = walls[w, e, 1]
            out_r[k] = wall_r[w]
            k += 1
    return out_w, out_r


@kernel(error_model="numpy")
def nearby_walls(walls, half_thickness, index, position, grow, reach, cut):
    """The walls walls[index] ((M, 2, 2) m, world frame) within ``reach`` (m) + their radius
    of ``position`` (2,) m, relative to it, with radii half_thickness + grow (m), with
    ``cut`` cut to just under their current distance (RADIUS_CUT: the robot may not close
    in further but may move away): (walls (W, 2, 2) m, radii (W,) m), in index order."""
    n = index.shape[0]
    rel = np.empty((n, 2, 2))
    rad = np.empty(n)
    px = position[0]
    py = position[1]
    k = 0
    for i in range(n):
        w = index[i]
        ax = walls[w, 0, 0] - px
        ay = walls[w, 0, 1] - py
        bx = walls[w, 1, 0] - px
        by = walls[w, 1, 1] - py
        r = half_thickness[w] + grow
        dist = math.sqrt(point_segment_dist2(ax, ay, bx, by))
        if dist > reach + r:
            continue
        rel[k, 0, 0] = ax
        rel[k, 0, 1] = ay
        rel[k, 1, 0] = bx
        rel[k, 1, 1] = by
        rad[k] = min(r, dist * RADIUS_CUT) if cut else r
        k += 1
    return rel[:k], rad[:k]
