"""Scripted traffic: lanes with an arc-length parametrization and lane followers.

A lane is a centreline in the world frame (m): a circle driven clockwise or
counter-clockwise, or a polyline (open or closed). Arc length ``s`` (m) runs
along the driving direction; ``point_at(s)`` and ``tangent_at(s)`` give the
centre and the unit driving direction there, ``curvature_at(s)`` the signed
curvature (1/m, positive when the lane turns left), and ``project(points)``
the arc length of the nearest centreline point and the signed lateral
offset (m, positive to the left of the driving direction). Open polylines
are continued straight beyond both ends, so a vehicle that drives off the
end keeps going.

A lane follower drives a vehicle along the centreline at a set speed with
car following (the free-road term tracks the set speed exactly, the
interaction term is the Intelligent Driver Model's, so that a lane never
rear-ends itself), and its acceleration respects |a| <= a_max (m/s^2).
Undisturbed, a vehicle drives its lane at its cruise speed, so its true
future centres are ``lane.point_at(s + speed * t)``
(:func:`future_path`), which the ``known_path`` predictor uses.

This module is pure numpy: it knows nothing of pymunk or of map files
(:mod:`nao_arena.maps` builds its lanes; :class:`TrafficMap` is what
:meth:`LaneTraffic.from_map` reads from a loaded map).
:class:`LaneTraffic` drives all traffic of a map at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.motion import clip_accelerations

__all__ = [
    "CircleLane",
    "FollowerParams",
    "Lane",
    "LaneTraffic",
    "PolylineLane",
    "TrafficMap",
    "follower_accel",
    "follower_accels",
    "future_path",
    "leader_gaps",
]

FloatArray = NDArray[np.float64]


class Lane(Protocol):
    """A lane centreline parametrized by arc length s (m) in the driving direction."""

    @property
    def length(self) -> float: ...

    @property
    def closed(self) -> bool: ...

    def point_at(self, s: ArrayLike) -> FloatArray: ...

    def tangent_at(self, s: ArrayLike) -> FloatArray: ...

    def curvature_at(self, s: ArrayLike) -> FloatArray: ...

    def project(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]: ...


@dataclass(frozen=True)
class CircleLane:
    """A circular lane: centre (m), radius (m), direction "ccw" or "cw".

    s = 0 at the angle ``start_angle`` (rad, from the +x axis).
    """

    center: tuple[float, float]
    radius: float
    direction: Literal["ccw", "cw"] = "ccw"
    start_angle: float = 0.0

    @property
    def closed(self) -> bool:
        return True

    @property
    def length(self) -> float:
        """Circumference (m)."""
        return 2.0 * math.pi * self.radius

    @property
    def _sign(self) -> float:
        return 1.0 if self.direction == "ccw" else -1.0

    def _angle(self, s: ArrayLike) -> FloatArray:
        return self.start_angle + self._sign * np.asarray(s, dtype=float) / self.radius

    def point_at(self, s: ArrayLike) -> FloatArray:
        """Centreline point(s) (..., 2) m at arc length(s) s (m)."""
        th = self._angle(s)
        c = np.asarray(self.center, dtype=float)
        return c + self.radius * np.stack([np.cos(th), np.sin(th)], axis=-1)

    def tangent_at(self, s: ArrayLike) -> FloatArray:
        """Unit driving direction(s) (..., 2) at arc length(s) s (m)."""
        th = self._angle(s)
        return self._sign * np.stack([-np.sin(th), np.cos(th)], axis=-1)

    def curvature_at(self, s: ArrayLike) -> FloatArray:
        """Signed curvature (1/m): +1/R counter-clockwise, -1/R clockwise."""
        return np.full(np.shape(s), self._sign / self.radius)

    def project(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Arc length s in [0, length) (m) and signed lateral offset (m, + = left)."""
        p = np.asarray(points, dtype=float) - np.asarray(self.center, dtype=float)
        th = np.arctan2(p[..., 1], p[..., 0])
        s = np.mod(self._sign * (th - self.start_angle) * self.radius, self.length)
        rho = np.hypot(p[..., 0], p[..., 1])
        return s, -self._sign * (rho - self.radius)


@dataclass(frozen=True)
class PolylineLane:
    """A polyline lane through ``points`` (M, 2) m, driven from the first point on.

    A closed lane returns from the last point to the first; an open lane is
    continued straight beyond both ends.
    """

    points: FloatArray
    closed: bool = False
    _starts: FloatArray = field(init=False, repr=False, compare=False)
    _dirs: FloatArray = field(init=False, repr=False, compare=False)
    _lens: FloatArray = field(init=False, repr=False, compare=False)
    _cum: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=float).reshape(-1, 2)
        ends = np.roll(pts, -1, axis=0) if self.closed else pts[1:]
        starts = pts if self.closed else pts[:-1]
        seg = ends - starts
        lens = np.hypot(seg[:, 0], seg[:, 1])
        if len(lens) == 0 or np.any(lens <= 0.0):
            raise ValueError("a polyline lane needs >= 2 points and no repeated consecutive points")
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "_starts", starts)
        object.__setattr__(self, "_dirs", seg / lens[:, None])
        object.__setattr__(self, "_lens", lens)
        object.__setattr__(self, "_cum", np.concatenate([[0.0], np.cumsum(lens)]))

    @property
    def length(self) -> float:
        """Total centreline length (m), including the closing segment if closed."""
        return float(self._cum[-1])

    def _segment(self, s: ArrayLike) -> tuple[FloatArray, NDArray[np.intp]]:
        arc = np.asarray(s, dtype=float)
        if self.closed:
            arc = np.mod(arc, self.length)
        k = np.clip(np.searchsorted(self._cum, arc, side="right") - 1, 0, len(self._lens) - 1)
        return arc, k

    def point_at(self, s: ArrayLike) -> FloatArray:
        """Centreline point(s) (..., 2) m at arc length(s) s (m)."""
        s, k = self._segment(s)
        return self._starts[k] + (s - self._cum[k])[..., None] * self._dirs[k]

    def tangent_at(self, s: ArrayLike) -> FloatArray:
        """Unit driving direction(s) (..., 2) of the segment containing s."""
        _, k = self._segment(s)
        return self._dirs[k]

    def curvature_at(self, s: ArrayLike) -> FloatArray:
        """Zero: the segments are straight (turns happen at the vertices)."""
        return np.zeros(np.shape(s))

    def project(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Arc length s (m) of the nearest centreline point and signed lateral offset (m)."""
        p = np.asarray(points, dtype=float)
        flat = p.reshape(-1, 2)
        rel = flat[:, None, :] - self._starts[None, :, :]
        u = np.einsum("psk,sk->ps", rel, self._dirs)
        lo = np.zeros(len(self._lens))
        hi = self._lens.copy()
        if not self.closed:
            lo[0] = -np.inf
            hi[-1] = np.inf
        u = np.clip(u, lo, hi)
        foot = self._starts[None] + u[..., None] * self._dirs[None]
        d2 = np.sum((flat[:, None, :] - foot) ** 2, axis=-1)
        k = np.argmin(d2, axis=1)
        rows = np.arange(len(flat))
        s = self._cum[k] + u[rows, k]
        off = flat - foot[rows, k]
        d = self._dirs[k]
        lateral = d[:, 0] * off[:, 1] - d[:, 1] * off[:, 0]
        if self.closed:
            s = np.mod(s, self.length)
        return s.reshape(p.shape[:-1]), lateral.reshape(p.shape[:-1])


@dataclass(frozen=True)
class FollowerParams:
    """A lane follower's settings.

    speed: cruise speed (m/s); a_max: acceleration bound (m/s^2);
    time_headway (s), min_gap (m, bumper to bumper at standstill) and
    comfort_decel (m/s^2): the IDM interaction term; speed_time_constant (s):
    how fast the speed error closes on a free road; lateral_time_constant
    (s): how fast a lateral offset from the centreline closes.
    """

    speed: float
    a_max: float
    time_headway: float = 1.0
    min_gap: float = 2.0
    comfort_decel: float = 2.0
    speed_time_constant: float = 1.0
    lateral_time_constant: float = 1.0


def follower_accels(
    lane: Lane,
    params: FollowerParams,
    dt: float,
    positions: ArrayLike,
    velocities: ArrayLike,
    gaps: ArrayLike,
    leader_speeds: ArrayLike,
) -> FloatArray:
    """Accelerations (n, 2) m/s^2 of n vehicles in one lane, world frame.

    positions, velocities: (n, 2) m, m/s; gaps: (n,) bumper-to-bumper
    distance to each vehicle's leader along the lane (m, inf for none);
    leader_speeds: (n,) the leaders' speeds along the lane (m/s). dt: the
    control period (s) over which the acceleration is held.

    Longitudinal: min(free-road term (v0 - u) / T_v, IDM interaction term
    a (1 - (s*/gap)^2), s* = s0 + u T + u (u - u_lead) / (2 sqrt(a b))), so
    that a free vehicle holds exactly its cruise speed. Lateral: the
    velocity at the end of the period points along the tangent at the
    arc length reached then, plus -offset / T_lat towards the centreline.
    The result is scaled to |a| <= a_max as the world scales commands
    (:func:`nao_arena.motion.clip_accelerations`).
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 2)
    v = np.asarray(velocities, dtype=float).reshape(-1, 2)
    gaps = np.asarray(gaps, dtype=float).reshape(-1)
    u_lead = np.asarray(leader_speeds, dtype=float).reshape(-1)
    s, lateral = lane.project(p)
    t_here = lane.tangent_at(s)
    u = np.einsum("nk,nk->n", v, t_here)
    a_max = params.a_max
    a_free = (params.speed - u) / max(params.speed_time_constant, dt)
    s_star = params.min_gap + np.maximum(
        0.0,
        u * params.time_headway
        + u * (u - u_lead) / (2.0 * math.sqrt(a_max * params.comfort_decel)),
    )
    safe_gap = np.maximum(gaps, 1e-3)
    a_follow = np.where(np.isfinite(gaps), a_max * (1.0 - (s_star / safe_gap) ** 2), np.inf)
    a_long = np.clip(np.minimum(a_free, a_follow), -a_max, a_max)
    u_next = np.maximum(u + a_long * dt, 0.0)
    s_next = s + 0.5 * (u + u_next) * dt
    t_next = lane.tangent_at(s_next)
    n_next = np.stack([-t_next[:, 1], t_next[:, 0]], axis=-1)
    v_target = (
        u_next[:, None] * t_next
        - (lateral / max(params.lateral_time_constant, dt))[:, None] * n_next
    )
    return clip_accelerations((v_target - v) / dt, a_max)


def follower_accel(
    lane: Lane,
    params: FollowerParams,
    dt: float,
    position: ArrayLike,
    velocity: ArrayLike,
    radius: float,
    leader_position: ArrayLike | None = None,
    leader_velocity: ArrayLike | None = None,
    leader_radius: float = 0.0,
) -> FloatArray:
    """Acceleration (2,) m/s^2 of one vehicle given its leader in the same lane (or none).

    Positions (m) and velocities (m/s) in the world frame; the gap is the
    bumper-to-bumper distance along the lane (m): arc length ahead minus
    both radii (modulo the length on a closed lane).
    """
    if leader_position is None:
        gap, u_lead = np.inf, 0.0
    else:
        s_pair, _ = lane.project(np.array([position, leader_position], dtype=float))
        ahead = s_pair[1] - s_pair[0]
        if lane.closed:
            ahead = ahead % lane.length
        gap = ahead - radius - leader_radius
        lv = np.zeros(2) if leader_velocity is None else np.asarray(leader_velocity, float)
        u_lead = float(lv @ lane.tangent_at(s_pair[1]))
    out = follower_accels(
        lane,
        params,
        dt,
        np.asarray(position, float)[None],
        np.asarray(velocity, float)[None],
        np.array([gap]),
        np.array([u_lead]),
    )
    return out[0]


def leader_gaps(lane: Lane, s: ArrayLike, radii: ArrayLike) -> tuple[NDArray[np.intp], FloatArray]:
    """Leader index (-1 for none) and bumper gap (m, inf for none) of each vehicle.

    s: (n,) arc lengths (m) of the vehicles in one lane; radii: (n,) m. On a
    closed lane the leader of the front vehicle is the rearmost one (a
    lone vehicle has none); on an open lane the front vehicle has none.
    Ties in s are broken by index.
    """
    s = np.asarray(s, dtype=float)
    radii = np.asarray(radii, dtype=float)
    n = len(s)
    leader = np.full(n, -1, dtype=np.intp)
    gap = np.full(n, np.inf)
    if n < 2:
        return leader, gap
    order = np.lexsort((np.arange(n), s))
    ahead = np.roll(order, -1)
    ds = s[ahead] - s[order]
    if lane.closed:
        ds = np.mod(ds, lane.length)
    leader[order] = ahead
    gap[order] = ds - radii[order] - radii[ahead]
    if not lane.closed:
        leader[order[-1]] = -1
        gap[order[-1]] = np.inf
    return leader, gap


def future_path(lane: Lane, s0: float, speed: float, times: ArrayLike) -> FloatArray:
    """True future centres (T, 2) m of an undisturbed vehicle at arc length s0 (m).

    It drives the centreline at its cruise speed (m/s); times (T,) s from now.
    """
    t = np.asarray(times, dtype=float)
    return lane.point_at(s0 + speed * t)


class _Body(Protocol):
    @property
    def index(self) -> int: ...

    @property
    def radius(self) -> float: ...

    @property
    def group(self) -> int: ...


class _Group(Protocol):
    def lane_geometry(self) -> Lane: ...

    def follower_params(self) -> FollowerParams: ...


class _Physics(Protocol):
    @property
    def dt(self) -> float: ...


class TrafficMap(Protocol):
    """What :meth:`LaneTraffic.from_map` reads from a loaded map
    (:class:`nao_arena.maps.MapSpec`): its bodies in world order (index, radius in m,
    traffic group or -1), its traffic groups and the control period ``physics.dt`` (s)."""

    def bodies(self) -> Sequence[_Body]: ...

    @property
    def traffic(self) -> Sequence[_Group]: ...

    @property
    def physics(self) -> _Physics: ...


@dataclass
class LaneTraffic:
    """All scripted vehicles of a map, one lane follower each.

    lanes[g], params[g]: lane and follower settings of traffic group g;
    members[g]: world body indices of its vehicles; radii: (N,) radii of all
    world bodies (m); dt: control period (s).
    """

    lanes: Sequence[Lane]
    params: Sequence[FollowerParams]
    members: Sequence[NDArray[np.intp]]
    radii: FloatArray
    dt: float

    @classmethod
    def from_map(cls, spec: TrafficMap) -> LaneTraffic:
        """The followers of every traffic group of a loaded map, in map body order."""
        bodies = spec.bodies()
        radii = np.array([b.radius for b in bodies])
        lanes, params, members = [], [], []
        for g, group in enumerate(spec.traffic):
            lanes.append(group.lane_geometry())
            params.append(group.follower_params())
            members.append(np.array([b.index for b in bodies if b.group == g], dtype=np.intp))
        return cls(lanes, params, members, radii, spec.physics.dt)

    @property
    def indices(self) -> NDArray[np.intp]:
        """World body indices of all vehicles, group by group (M,)."""
        if not self.members:
            return np.zeros(0, dtype=np.intp)
        return np.concatenate(list(self.members)).astype(np.intp)

    def accelerations(self, positions: ArrayLike, velocities: ArrayLike) -> FloatArray:
        """Accelerations (M, 2) m/s^2 of all vehicles, rows ordered as :attr:`indices`.

        positions, velocities: (N, 2) of all world bodies (m, m/s).
        """
        pos = np.asarray(positions, dtype=float)
        vel = np.asarray(velocities, dtype=float)
        out = []
        for lane, prm, idx in zip(self.lanes, self.params, self.members, strict=True):
            if len(idx) == 0:
                continue
            p, v = pos[idx], vel[idx]
            s, _ = lane.project(p)
            leader, gap = leader_gaps(lane, s, self.radii[idx])
            has = leader >= 0
            lead = np.where(has, leader, 0)
            u_lead = np.einsum("nk,nk->n", v[lead], lane.tangent_at(s[lead]))
            u_lead = np.where(has, u_lead, 0.0)
            out.append(follower_accels(lane, prm, self.dt, p, v, gap, u_lead))
        return np.concatenate(out) if out else np.zeros((0, 2))

    def future_paths(self, positions: ArrayLike, times: ArrayLike) -> FloatArray:
        """True future centres (M, T, 2) m of all vehicles at their cruise speeds.

        Rows ordered as :attr:`indices`; times (T,) s from now.
        """
        pos = np.asarray(positions, dtype=float)
        t = np.asarray(times, dtype=float)
        out = []
        for lane, prm, idx in zip(self.lanes, self.params, self.members, strict=True):
            if len(idx) == 0:
                continue
            s, _ = lane.project(pos[idx])
            out.append(lane.point_at(s[:, None] + prm.speed * t[None, :]))
        return np.concatenate(out) if out else np.zeros((0, len(t), 2))
