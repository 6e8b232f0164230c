"""Exact boundaries of the BAO, AO and NAO in acceleration space (m/s^2).

Frame: the robot is at the origin with velocity ``v`` (m/s); obstacle
centres are robot-relative (m); ``radius`` is grown by the robot's radius.

Every boundary point is a constant acceleration whose path grazes the
obstacle: its minimum distance over the horizon equals the radius, and
nothing earlier is inside. The constructions (the paper's normal/tangent
construction for the AO, the envelope of the disks |a - m(t)| <= rho(t) for
the NAO) also produce tangencies that are not boundary points (e.g. on the
far side of the obstacle, reached only after passing through it); those are
removed by checking every point's exact clearance (see
:mod:`nao_arena.geometry.clearance`).

Polylines are (M, 2) arrays; separate pieces are split by rows of NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.geometry.clearance import PiecewisePath, ao_path, path_clearance, sampled_path

__all__ = [
    "ObstacleBoundary",
    "ao_boundary",
    "ao_boundary_paper",
    "bao_boundary",
    "grazing_filter",
    "nao_boundary",
    "path_boundary",
    "vo_cone",
]


def _empty() -> NDArray[np.float64]:
    return np.empty((0, 2))


@dataclass(frozen=True)
class ObstacleBoundary:
    """Boundary of one acceleration obstacle.

    left, right: the two boundary branches (robot passes the obstacle with
    the obstacle on its left / right at the grazing time); arc: the closing
    arc of the last disk at the horizon (empty for an infinite horizon);
    corners: arcs of disks at kinks of a sampled path. *_times: grazing
    time (s) of each point (NaN on separator rows). overlapping: the
    obstacle already overlaps the robot (every acceleration collides).
    """

    left: NDArray[np.float64] = field(default_factory=_empty)
    right: NDArray[np.float64] = field(default_factory=_empty)
    arc: NDArray[np.float64] = field(default_factory=_empty)
    corners: NDArray[np.float64] = field(default_factory=_empty)
    left_times: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    right_times: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    overlapping: bool = False

    def points(self) -> NDArray[np.float64]:
        """All boundary points (K, 2), separators removed."""
        allp = np.concatenate([self.left, self.right, self.arc, self.corners])
        return allp[np.all(np.isfinite(allp), axis=1)]


def _split_runs(
    points: NDArray[np.float64], keep: NDArray[np.bool_], extra: NDArray[np.float64] | None = None
):
    """Keep the rows in ``keep``; insert NaN rows where runs of kept rows break."""
    rows: list[NDArray[np.float64]] = []
    extras = []
    prev = False
    for i in range(len(points)):
        if keep[i]:
            if not prev and rows:
                rows.append(np.full(2, np.nan))
                extras.append(np.nan)
            rows.append(points[i])
            extras.append(np.nan if extra is None else extra[i])
        prev = bool(keep[i])
    if not rows:
        return _empty(), np.empty(0)
    return np.asarray(rows), np.asarray(extras)


def _obstacle_on_left(rel_vel: NDArray[np.float64], normal: NDArray[np.float64]):
    """True where the obstacle is on the robot's left at contact.

    rel_vel: robot velocity relative to the obstacle at contact; normal:
    unit vector from the obstacle centre to the robot.
    """
    # the obstacle lies along -normal: on the left where rel_vel x (-normal) > 0
    return rel_vel[:, 0] * normal[:, 1] - rel_vel[:, 1] * normal[:, 0] < 0


def grazing_filter(
    accels: NDArray[np.float64],
    v: NDArray[np.float64],
    path: PiecewisePath,
    rel_tol: float = 1e-6,
) -> NDArray[np.bool_]:
    """(K,) mask: accelerations whose exact clearance is 0 within rel_tol (grazing).

    rel_tol is relative to the problem's length scale (radius + distance).
    """
    if len(accels) == 0:
        return np.zeros(0, dtype=bool)
    finite = np.all(np.isfinite(accels), axis=1)
    ok = np.zeros(len(accels), dtype=bool)
    if not np.any(finite):
        return ok
    res = path_clearance(np.ascontiguousarray(accels[finite]), v, path)
    clear = res.clearance.reshape(-1)
    scale = float(path.radius[0]) + float(np.max(np.abs(path.c[0, 0]))) + 1.0
    ok[finite] = np.abs(clear) <= rel_tol * scale
    return ok


def bao_boundary(
    obstacle_pos: ArrayLike,
    radius: float,
    obstacle_acc: ArrayLike = (0.0, 0.0),
    extent: float = 10.0,
    n: int = 200,
) -> ObstacleBoundary:
    """BAO (zero initial velocities): the cone from a_B along the tangents to the obstacle.

    Points are a_B + s d for s in [0, extent] (m/s^2) along each tangent
    direction d. Grazing time along a ray: t = sqrt(2 L / s), L the tangent length.
    """
    q = np.asarray(obstacle_pos, dtype=np.float64)
    a_b = np.asarray(obstacle_acc, dtype=np.float64)
    dist = float(np.hypot(*q))
    if dist <= radius:
        return ObstacleBoundary(overlapping=True)
    half = math.asin(radius / dist)
    base = math.atan2(q[1], q[0])
    tangent_len = math.sqrt(dist * dist - radius * radius)
    s = np.linspace(0.0, extent, n)
    out = {}
    # passing clockwise of the obstacle (angle base - half) leaves it on the left
    for name, ang in (("left", base - half), ("right", base + half)):
        d = np.array([math.cos(ang), math.sin(ang)])
        pts = a_b + s[:, None] * d
        with np.errstate(divide="ignore"):
            times = np.sqrt(2.0 * tangent_len / s)
        out[name] = (pts, times)
    return ObstacleBoundary(
        left=out["left"][0],
        right=out["right"][0],
        left_times=out["left"][1],
        right_times=out["right"][1],
    )


def _horizon_arc(
    v: NDArray[np.float64], path: PiecewisePath, n: int, extent: float
) -> NDArray[np.float64]:
    """Grazing part of the last disk D(t_h) (empty for an infinite horizon)."""
    t_h = path.horizon
    if not math.isfinite(t_h) or t_h <= 0:
        return _empty()
    c_h = _centre_at(path, t_h)
    m = 2.0 * (c_h - v * t_h) / t_h**2
    rho = 2.0 * float(path.radius[0]) / t_h**2
    ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    pts = m + rho * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    keep = grazing_filter(pts, v, path) & (np.hypot(*pts.T) <= extent)
    # start the run at a rejected point so that a kept run is not cut in two
    if np.any(~keep):
        shift = int(np.argmax(~keep))
        pts, keep = np.roll(pts, -shift, axis=0), np.roll(keep, -shift)
    arc, _ = _split_runs(pts, keep)
    return arc


def _centre_at(path: PiecewisePath, t: float) -> NDArray[np.float64]:
    j = int(np.clip(np.searchsorted(path.t, t, side="right") - 1, 0, len(path.t) - 2))
    dt = t - path.t[j]
    return path.c[0, j] + path.velocity[0, j] * dt + 0.5 * path.acceleration[0, j] * dt * dt


def ao_boundary(
    v: ArrayLike,
    obstacle_pos: ArrayLike,
    radius: float,
    obstacle_vel: ArrayLike = (0.0, 0.0),
    obstacle_acc: ArrayLike = (0.0, 0.0),
    horizon: float = np.inf,
    extent: float = 10.0,
    per_piece: int = 400,
) -> ObstacleBoundary:
    """AO boundary (obstacle with constant velocity and acceleration), as polylines.

    Computed as the envelope of the disks D(t) (see :func:`path_boundary`)
    sampled in the grazing time, which spaces points evenly along the whole
    boundary; :func:`ao_boundary_paper` gives the same points by the paper's
    construction. horizon (s) may be inf; |a| <= extent (m/s^2).
    """
    path = ao_path(obstacle_pos, radius, obstacle_vel, obstacle_acc, horizon)
    return path_boundary(v, path, extent, per_piece)


def ao_boundary_paper(
    v: ArrayLike,
    obstacle_pos: ArrayLike,
    radius: float,
    obstacle_vel: ArrayLike = (0.0, 0.0),
    obstacle_acc: ArrayLike = (0.0, 0.0),
    horizon: float = np.inf,
    extent: float = 10.0,
    n: int = 2000,
) -> ObstacleBoundary:
    """AO boundary points by the paper's normal/tangent construction, far-side
    tangencies removed (points of each branch ordered by grazing time).

    For a contact point p = q + r n(theta) the robot (relative velocity
    w = v - v_B) reaches p with zero normal velocity: a_n = -w_n^2 / (2 p_n),
    t_p = 2 p_n / w_n > 0, a_t = 2 (q_t - w_t t_p) / t_p^2; a = a_B + a_n n + a_t t.
    Only points whose exact clearance is 0 (they graze, nothing earlier
    inside) and with t_p <= horizon are kept; |a| <= extent (m/s^2).
    """
    v = np.asarray(v, dtype=np.float64)
    q = np.asarray(obstacle_pos, dtype=np.float64)
    w = v - np.asarray(obstacle_vel, dtype=np.float64)
    a_b = np.asarray(obstacle_acc, dtype=np.float64)
    path = ao_path(q, radius, obstacle_vel, obstacle_acc, horizon)
    if float(np.hypot(*q)) <= radius:
        return ObstacleBoundary(overlapping=True)
    if float(np.hypot(*w)) <= 1e-12 * (1.0 + float(np.hypot(*v))):
        # no relative velocity: the construction degenerates (t_p = 2 p_n / w_n);
        # the AO is then the BAO cone, given by the envelope
        return ao_boundary(v, q, radius, obstacle_vel, obstacle_acc, horizon, extent)
    # uniform in theta, refined geometrically towards the angles where p_n = 0
    # (t_p -> 0, |a| -> inf) and w_n = 0 (t_p -> inf, a -> a_B)
    base_q = math.atan2(q[1], q[0])
    tip = math.acos(max(-1.0, min(1.0, -radius / float(np.hypot(*q)))))
    base_w = math.atan2(w[1], w[0])
    critical = [base_q + tip, base_q - tip, base_w + 0.5 * np.pi, base_w - 0.5 * np.pi]
    offsets = np.geomspace(1e-7, 0.2, n // 16)
    theta = np.concatenate(
        [np.linspace(-np.pi, np.pi, n, endpoint=False)]
        + [c + sgn * offsets for c in critical for sgn in (-1.0, 1.0)]
    )
    theta = np.sort(np.mod(theta + np.pi, 2.0 * np.pi) - np.pi)
    nrm = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    tan = np.stack([-np.sin(theta), np.cos(theta)], axis=1)
    p = q + radius * nrm
    p_n = np.einsum("ij,ij->i", p, nrm)
    q_t = tan @ q
    w_n = nrm @ w
    w_t = tan @ w
    valid = p_n * w_n > 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # inf: not valid
        t_p = np.where(valid, 2.0 * p_n / w_n, np.nan)
        a_n = -(w_n**2) / (2.0 * p_n)
        a_t = 2.0 * (q_t - w_t * t_p) / t_p**2
    acc = a_b + a_n[:, None] * nrm + a_t[:, None] * tan
    valid &= np.isfinite(t_p) & (t_p <= horizon) & np.all(np.isfinite(acc), axis=1)
    valid &= np.hypot(*acc.T) <= extent
    valid[valid] = grazing_filter(acc[valid], v, path)
    with np.errstate(invalid="ignore"):
        rel_vel = w + (acc - a_b) * t_p[:, None]
    left = _obstacle_on_left(rel_vel, nrm)
    branches = {}
    for name, mask in (("left", valid & left), ("right", valid & ~left)):
        idx = np.flatnonzero(mask)
        idx = idx[np.argsort(-t_p[idx])]
        branches[name] = (acc[idx], t_p[idx])
    return ObstacleBoundary(
        left=branches["left"][0],
        right=branches["right"][0],
        left_times=branches["left"][1],
        right_times=branches["right"][1],
        arc=_horizon_arc(v, path, 720, extent),
    )


def _envelope_times(path: PiecewisePath, per_piece: int) -> NDArray[np.float64]:
    t = path.t
    t_end = t[-1] if math.isfinite(t[-1]) else max(t[-2], 1.0) * 1e3
    pieces = []
    for j in range(len(t) - 1):
        hi = min(t[j + 1], t_end)
        lo = t[j]
        if j == 0:
            first = hi if math.isfinite(t[1]) else 1.0
            # geometric towards t = 0, where the disks run off to infinity
            pieces.append(first * np.geomspace(1e-4, 1.0, 4 * per_piece, endpoint=False))
            if not math.isfinite(t[1]):
                lo = first
        if not math.isfinite(t[j + 1]):
            pieces.append(np.geomspace(lo, t_end, 8 * per_piece))
        elif hi > lo:
            # at least per_piece samples a piece and 400 over the horizon
            count = max(per_piece, math.ceil(400 * (hi - lo) / t_end))
            pieces.append(np.linspace(lo, hi, count + 1)[:-1] + 1e-9 * (hi - lo))
    pieces.append([t_end - 1e-9 * t_end])
    ts = np.unique(np.concatenate(pieces))
    # below 1e-100 s, t^3 underflows; the disks there lie far outside any extent
    return ts[ts > _SHORTEST_TIME]


_SHORTEST_TIME = 1e-100  # s: earliest time sampled on the envelope


def _disk_centres(path: PiecewisePath, v: NDArray[np.float64], ts: NDArray[np.float64]):
    """Disk centres m(t), their derivative m'(t) and the obstacle velocity c'(t) at ts."""
    j = np.clip(np.searchsorted(path.t, ts, side="right") - 1, 0, len(path.t) - 2)
    dt = (ts - path.t[j])[:, None]
    c = path.c[0, j] + path.velocity[0, j] * dt + 0.5 * path.acceleration[0, j] * dt**2
    cd = path.velocity[0, j] + path.acceleration[0, j] * dt
    tt = ts[:, None]
    m = 2.0 * (c - v * tt) / tt**2
    dm = 2.0 * (cd - v) / tt**2 - 4.0 * (c - v * tt) / tt**3
    return m, dm, cd


def _refine_existence(
    path: PiecewisePath, v: NDArray[np.float64], r: float, ts: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Add the times where the envelope starts or stops existing (|m'| = |rho'|).

    There the two branches meet (the tip of the obstacle); sampling alone
    would stop short of it. Bisection, vectorised over all sign changes.
    """

    def margin(t: NDArray[np.float64]) -> NDArray[np.float64]:
        _, dm, _ = _disk_centres(path, v, t)
        return np.hypot(*dm.T) - 4.0 * r / t**3

    with np.errstate(all="ignore"):
        g = margin(ts)
        flips = np.flatnonzero((g[:-1] >= 0) != (g[1:] >= 0))
        if len(flips) == 0:
            return ts
        lo, hi = ts[flips].copy(), ts[flips + 1].copy()
        lo_exists = g[flips] >= 0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            same = (margin(mid) >= 0) == lo_exists
            lo = np.where(same, mid, lo)
            hi = np.where(same, hi, mid)
    edge = np.where(lo_exists, lo, hi)
    edge = edge[np.isfinite(edge) & (edge > 0)]
    return np.unique(np.concatenate([ts, edge]))


def path_boundary(
    v: ArrayLike,
    path: PiecewisePath,
    extent: float = 10.0,
    per_piece: int = 40,
) -> ObstacleBoundary:
    """NAO boundary of the first obstacle of ``path``: envelope of the disks
    D(t) = {a : |a - m(t)| <= rho(t)}, m = 2 (c - v t) / t^2, rho = 2 r / t^2.

    On the envelope n . m'(t) = -rho'(t) for the unit normal n = (a - m) / rho,
    i.e. the relative velocity at contact is tangent to the obstacle. Both
    roots give the two branches; points that are not grazing (exact clearance
    != 0) are dropped. Kinks of a sampled path add arcs of their disks.
    """
    v = np.asarray(v, dtype=np.float64)
    r = float(path.radius[0])
    if float(np.hypot(*path.c[0, 0])) <= r:
        return ObstacleBoundary(overlapping=True)
    ts = _refine_existence(path, v, r, _envelope_times(path, per_piece))
    tt = ts[:, None]
    m, dm, cd = _disk_centres(path, v, ts)
    rho = 2.0 * r / ts**2
    drho = -4.0 * r / ts**3
    dm_norm = np.hypot(*dm.T)
    with np.errstate(divide="ignore", invalid="ignore"):
        along = -drho / dm_norm
        across = np.sqrt(np.clip(1.0 - along**2, 0.0, None))
        u = dm / dm_norm[:, None]
    perp = np.stack([-u[:, 1], u[:, 0]], axis=1)
    exists = np.isfinite(along) & (np.abs(along) <= 1.0)
    branches = []
    for sgn in (1.0, -1.0):
        nrm = along[:, None] * u + sgn * across[:, None] * perp
        pts = m + rho[:, None] * nrm
        keep = exists & np.all(np.isfinite(pts), axis=1) & (np.hypot(*pts.T) <= extent)
        keep[keep] = grazing_filter(pts[keep], v, path)
        rel_vel = v + pts * tt - cd
        votes = _obstacle_on_left(rel_vel[keep], nrm[keep])
        branches.append((float(np.mean(votes)) if len(votes) else 0.5, _split_runs(pts, keep, ts)))
    branches.sort(key=lambda b: -b[0])
    out = {"left": branches[0][1], "right": branches[1][1]}
    corners = []
    if len(path.t) > 2:
        ang = np.linspace(0.0, 2.0 * np.pi, 180, endpoint=False)
        circle = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        for tk in path.t[1:-1]:
            if not math.isfinite(tk) or tk <= _SHORTEST_TIME:
                continue
            ck = _centre_at(path, tk)
            pts = 2.0 * (ck - v * tk) / tk**2 + (2.0 * r / tk**2) * circle
            keep = np.hypot(*pts.T) <= extent
            keep[keep] = grazing_filter(pts[keep], v, path)
            if np.any(keep):
                piece, _ = _split_runs(pts, keep)
                corners.append(piece)
                corners.append(np.full((1, 2), np.nan))
    return ObstacleBoundary(
        left=out["left"][0],
        right=out["right"][0],
        left_times=out["left"][1],
        right_times=out["right"][1],
        arc=_horizon_arc(v, path, 720, extent),
        corners=np.concatenate(corners[:-1]) if corners else _empty(),
    )


def nao_boundary(
    v: ArrayLike,
    times: ArrayLike,
    centers: ArrayLike,
    radius: float,
    extent: float = 10.0,
    per_piece: int = 40,
) -> ObstacleBoundary:
    """NAO boundary of one obstacle on a sampled path (times (T,) s, centers (T, 2) m).

    The path is interpolated linearly between samples, as in
    :func:`~nao_arena.geometry.clearance.nao_clearance`.
    """
    return path_boundary(v, sampled_path(times, centers, radius), extent, per_piece)


def vo_cone(
    obstacle_pos: ArrayLike, radius: float, obstacle_vel: ArrayLike = (0.0, 0.0)
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None:
    """Velocity obstacle of a constant-velocity obstacle: (apex, left_dir, right_dir).

    The VO is apex + the cone between the two unit directions (velocities in
    m/s); None when the obstacle already overlaps the robot.
    """
    q = np.asarray(obstacle_pos, dtype=np.float64)
    dist = float(np.hypot(*q))
    if dist <= radius:
        return None
    half = math.asin(radius / dist)
    base = math.atan2(q[1], q[0])
    left = np.array([math.cos(base + half), math.sin(base + half)])
    right = np.array([math.cos(base - half), math.sin(base - half)])
    return np.asarray(obstacle_vel, dtype=np.float64).copy(), left, right
