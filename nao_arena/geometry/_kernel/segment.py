"""Exact clearance of a constant-acceleration robot against static line segments.

Frame: the robot starts at the origin at t = 0; segments [p, q] (m) are given
relative to it. Robot path (the model the world drives, see
:mod:`nao_arena.speed_limit`): x(t) = v t + a t^2 / 2 until the speed |v + a t|
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

Not yet used by the agents, so not listed in :data:`nao_arena.cli.KERNEL_MODULES` (the
modules every episode compiles): listed before an episode compiles it, its cache would
stay cold and the first-run compilation note would show on every trial.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nao_arena.geometry._kernel.exact import candidate_setup
from nao_arena.geometry._kernel.quartic import piece_minimum
from nao_arena.geometry.borrow import borrowed

__all__ = [
    "segment_admissible",
    "segment_min_distance",
    "segments_admissible",
    "segments_min_distance",
]


@njit(cache=True, error_model="numpy", inline="always")
def _line_candidate(s, ax, ay, bx, by, cx, cy, px, py, ux, uy, ll, best):
    """min(best, squared distance from d(s) to the segment's line) when the foot of d(s)
    lies within the segment (ux, uy = q - p, ll = |q - p|^2 > 0), else best."""
    if not math.isfinite(s):
        return best
    dx = (ax * s + bx) * s + cx - px
    dy = (ay * s + by) * s + cy - py
    along = dx * ux + dy * uy
    if along < 0.0 or along > ll:
        return best
    cross = dx * uy - dy * ux
    e2 = cross * cross / ll
    return e2 if e2 < best else best


@njit(cache=True, error_model="numpy", inline="always")
def _piece_segment_dist2(ax, ay, bx, by, cx, cy, h, px, py, qx, qy, buf):
    """Minimum over s in [0, h] of the squared distance from A s^2 + B s + C to [p, q] (m^2)."""
    piece_minimum(ax, ay, bx, by, cx - px, cy - py, h, 0.0, False, buf)
    best = buf[0]
    ux = qx - px
    uy = qy - py
    ll = ux * ux + uy * uy
    if ll == 0.0:
        return best
    piece_minimum(ax, ay, bx, by, cx - qx, cy - qy, h, 0.0, False, buf)
    if buf[0] < best:
        best = buf[0]
    if best == 0.0:
        return best
    # e(s) = ea s^2 + eb s + ec, the distance to the line times |q - p| (signed)
    ea = ax * uy - ay * ux
    eb = bx * uy - by * ux
    ec = (cx - px) * uy - (cy - py) * ux
    best = _line_candidate(0.0, ax, ay, bx, by, cx, cy, px, py, ux, uy, ll, best)
    if math.isfinite(h):
        best = _line_candidate(h, ax, ay, bx, by, cx, cy, px, py, ux, uy, ll, best)
    # roots of e within [0, h]
    if ea == 0.0:
        if eb != 0.0:
            s = -ec / eb
            if 0.0 <= s <= h:
                best = _line_candidate(s, ax, ay, bx, by, cx, cy, px, py, ux, uy, ll, best)
    else:
        disc = eb * eb - 4.0 * ea * ec
        if disc >= 0.0:
            sq = math.sqrt(disc)
            qq = -0.5 * (eb + sq) if eb >= 0.0 else -0.5 * (eb - sq)
            s1 = qq / ea
            if 0.0 <= s1 <= h:
                best = _line_candidate(s1, ax, ay, bx, by, cx, cy, px, py, ux, uy, ll, best)
            if qq != 0.0:
                s2 = ec / qq
                if 0.0 <= s2 <= h:
                    best = _line_candidate(s2, ax, ay, bx, by, cx, cy, px, py, ux, uy, ll,
                                           best)
        # |e| stationary: e' = 0
        s = -eb / (2.0 * ea)
        if 0.0 <= s <= h:
            best = _line_candidate(s, ax, ay, bx, by, cx, cy, px, py, ux, uy, ll, best)
    return best


@njit(cache=True, error_model="numpy", inline="always")
def _path_segment_dist2(vx, vy, ax, ay, tau, horizon, px, py, qx, qy, buf):
    """Minimum squared distance (m^2) over t in [0, horizon] from the robot's centre (speed
    already clamped, saturation time tau) to the segment [p, q]."""
    h1 = min(tau, horizon)
    best = _piece_segment_dist2(0.5 * ax, 0.5 * ay, vx, vy, 0.0, 0.0, h1, px, py, qx, qy, buf)
    if tau < horizon and best > 0.0:
        wx = vx + ax * tau
        wy = vy + ay * tau
        cx = vx * tau + 0.5 * ax * tau * tau
        cy = vy * tau + 0.5 * ay * tau * tau
        lin = _piece_segment_dist2(0.0, 0.0, wx, wy, cx, cy, horizon - tau, px, py, qx, qy, buf)
        if lin < best:
            best = lin
    return best


@njit(cache=True, error_model="numpy", inline="always")
def _point_segment_dist2(px, py, qx, qy):
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


@njit(cache=True, error_model="numpy")
def segment_min_distance(vx: float, vy: float, ax: float, ay: float, v_max: float,
                         px: float, py: float, qx: float, qy: float, horizon: float) -> float:
    """Exact minimum over t in [0, horizon] (s) of the distance (m) from the robot's centre
    (velocity (vx, vy) m/s, acceleration (ax, ay) m/s^2, speed limit v_max m/s) to the
    static segment [p, q] (m, robot-relative). 0 when the robot starts on the segment."""
    buf = np.empty(3)
    vx, vy, tau, bound = candidate_setup(vx, vy, ax, ay, v_max, horizon)
    return math.sqrt(_path_segment_dist2(vx, vy, ax, ay, tau, horizon, px, py, qx, qy, buf))


@njit(cache=True, error_model="numpy")
def segment_admissible(v: np.ndarray, a: np.ndarray, v_max: float, p: np.ndarray,
                       q: np.ndarray, half_thickness: float, radius: float, margin: float,
                       horizon: float) -> bool:
    """Whether the robot (v (2,) m/s, a (2,) m/s^2, v_max m/s, radius m) stays farther than
    radius + half_thickness + margin (m) from the wall [p, q] ((2,) m each, robot-relative)
    over t in [0, horizon] (s)."""
    v, a, p, q = borrowed(v), borrowed(a), borrowed(p), borrowed(q)
    d = segment_min_distance(v[0], v[1], a[0], a[1], v_max, p[0], p[1], q[0], q[1], horizon)
    return d > radius + half_thickness + margin


@njit(cache=True, error_model="numpy")
def _fill_segments(v, a, v_max, walls, half_thickness, horizon, stop_below, buf):
    """(min over walls of distance - half_thickness (m), its wall index); stops at the first
    wall below ``stop_below`` (m; -inf: never). Prunes walls the robot cannot reach closer than
    the best so far. Arrays borrowed here."""
    v, a, walls = borrowed(v), borrowed(a), borrowed(walls)
    half_thickness, buf = borrowed(half_thickness), borrowed(buf)
    vx, vy, tau, bound = candidate_setup(v[0], v[1], a[0], a[1], v_max, horizon)
    reach = bound * horizon  # the path stays within this distance of the origin (m)
    best = math.inf
    index = -1
    for w in range(walls.shape[0]):
        px = walls[w, 0, 0]
        py = walls[w, 0, 1]
        qx = walls[w, 1, 0]
        qy = walls[w, 1, 1]
        if index >= 0 and math.isfinite(reach):
            lower = math.sqrt(_point_segment_dist2(px, py, qx, qy)) - reach - half_thickness[w]
            if lower - 1e-9 * (1.0 + abs(lower)) > best:
                continue
        d = math.sqrt(_path_segment_dist2(vx, vy, a[0], a[1], tau, horizon, px, py, qx, qy,
                                          buf)) - half_thickness[w]
        if d < best or index < 0:
            best = d
            index = w
        if best < stop_below:
            break
    return best, index


@njit(cache=True, error_model="numpy")
def segments_min_distance(v: np.ndarray, a: np.ndarray, v_max: float, walls: np.ndarray,
                          half_thickness: np.ndarray, horizon: float) -> tuple[float, int]:
    """Minimum over the walls (W, 2, 2) (m, robot-relative ends) of the exact minimum distance
    from the robot's centre to the wall minus its half_thickness (W,) (m), over t in
    [0, horizon] (s), and the index of that closest wall (-1 and inf when W = 0)."""
    buf = np.empty(3)
    return _fill_segments(v, a, v_max, walls, half_thickness, horizon, -math.inf, buf)


@njit(cache=True, error_model="numpy")
def segments_admissible(v: np.ndarray, a: np.ndarray, v_max: float, walls: np.ndarray,
                        half_thickness: np.ndarray, radius: float, margin: float,
                        horizon: float) -> bool:
    """:func:`segment_admissible` against every wall (W, 2, 2) with half_thickness (W,) (m);
    stops at the first wall that is too close."""
    buf = np.empty(3)
    limit = radius + margin
    d, index = _fill_segments(v, a, v_max, walls, half_thickness, horizon, limit, buf)
    return d > limit
