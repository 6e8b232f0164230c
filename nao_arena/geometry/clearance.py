"""Clearance queries: how close does a constant-acceleration robot come to an obstacle?

Frame and units: the robot is at the origin at t = 0 with velocity ``v``
(m/s, world axes); obstacle centres are given relative to the robot's current
position (m); times in seconds; accelerations in m/s^2. ``radius`` is the
obstacle radius already grown by the robot's radius (m).

The robot drives x(t) = v t + a t^2 / 2 for a constant acceleration a. With a
finite ``v_max`` its speed saturates: once |v + a t| = v_max it continues at
constant velocity (the world enforces exactly this model).

Static walls (segments, exact: :mod:`~nao_arena.geometry._kernel.segment`) ride along
in a path as ``walls`` (W, 2, 2) robot-relative ends (m) with combined radii
``wall_radius`` (W,) (m: half-thickness + the robot's radius and margin).

Clearance = min over the horizon of |x(t) - c(t)| - radius. Negative means
a collision within the horizon. Minima are exact for the stated obstacle
path model (piecewise-linear interpolation of samples, or constant
acceleration), not just at the sample times.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.geometry._kernel.bundles import Paths, Walls
from nao_arena.geometry._kernel.exact import clearance_kernel

__all__ = [
    "Clearance",
    "PiecewisePath",
    "ao_clearance",
    "ao_path",
    "grown_with_time",
    "nao_clearance",
    "nao_query",
    "path_clearance",
    "sampled_path",
    "vo_clearance",
]


@dataclass(frozen=True)
class PiecewisePath:
    """Obstacle paths as quadratic pieces on a common time grid.

    t: (S + 1,) piece boundaries (s), t[0] = 0, increasing; t[-1] may be inf.
    c, velocity, acceleration: (N, S, 2) centre (m, robot-relative), velocity (m/s)
    and acceleration (m/s^2) of each obstacle at the start of each piece.
    radius: (N,) combined radius (m).
    walls: (W, 2, 2) static segments' ends (m, robot-relative); wall_radius: (W,)
    their combined radii (m; half-thickness + the robot's radius and margin).
    """

    t: NDArray[np.float64]
    c: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    radius: NDArray[np.float64]
    walls: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2, 2)))
    wall_radius: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        if self.walls.ndim != 3 or self.walls.shape[1:] != (2, 2):
            raise ValueError(f"walls: expected shape (W, 2, 2), got {self.walls.shape}")
        if self.wall_radius.shape != (self.walls.shape[0],):
            raise ValueError(
                f"wall_radius: expected shape ({self.walls.shape[0]},), "
                f"got {self.wall_radius.shape}"
            )

    @property
    def arrays(
        self,
    ) -> tuple[
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
    ]:
        """(t, c, velocity, acceleration, radius, walls, wall_radius): the path as the
        compiled kernels take it (their arguments seg_t, seg_c, seg_w, seg_b, radius,
        walls, wall_r)."""
        return (
            self.t,
            self.c,
            self.velocity,
            self.acceleration,
            self.radius,
            self.walls,
            self.wall_radius,
        )

    @property
    def moving_arrays(
        self,
    ) -> tuple[
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
        NDArray[np.float64],
    ]:
        """(t, c, velocity, acceleration, radius): the moving obstacles alone, for the
        kernels that take no walls."""
        return self.t, self.c, self.velocity, self.acceleration, self.radius

    @property
    def n_obstacles(self) -> int:
        """Moving obstacles and walls."""
        return self.c.shape[0] + self.walls.shape[0]

    @property
    def n_walls(self) -> int:
        return self.walls.shape[0]

    @property
    def horizon(self) -> float:
        return float(self.t[-1])


@dataclass(frozen=True)
class Clearance:
    """Result of a clearance query, arrays of shape (K,) or (K, N).

    clearance: min distance minus radius over the horizon (m).
    time_of_closest_approach: the time of that minimum (s).
    time_of_first_contact: first time the distance reaches the radius (s), inf if never.
    """

    clearance: NDArray[np.float64]
    time_of_closest_approach: NDArray[np.float64]
    time_of_first_contact: NDArray[np.float64]


def _as_vectors(x: ArrayLike, name: str) -> tuple[NDArray[np.float64], bool]:
    arr = np.asarray(x, dtype=np.float64)
    single = arr.ndim == 1
    arr = np.atleast_2d(arr)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name}: expected shape (2,) or (K, 2), got {np.shape(x)}")
    return np.ascontiguousarray(arr), single


def _broadcast(x: ArrayLike, shape: tuple[int, ...], name: str) -> NDArray[np.float64]:
    arr = np.asarray(x, dtype=np.float64)
    try:
        return np.ascontiguousarray(np.broadcast_to(arr, shape))
    except ValueError:
        raise ValueError(
            f"{name}: expected shape {shape} or broadcastable to it, got {arr.shape}"
        ) from None


def _radius_array(radius: ArrayLike, n: int) -> NDArray[np.float64]:
    r = _broadcast(radius, (n,), "radius").copy()
    if np.any(r < 0) or not np.all(np.isfinite(r)):
        raise ValueError(f"radius: expected finite non-negative values, got {radius!s}")
    return r


def sampled_path(times: ArrayLike, centers: ArrayLike, radius: ArrayLike) -> PiecewisePath:
    """Piecewise-linear obstacle paths through sampled centres.

    times: (T,) increasing, times[0] >= 0 (s). centers: (T, 2) for one
    obstacle or (N, T, 2), robot-relative (m). Between samples the centre
    moves linearly; before times[0] the first segment is extended backwards
    to t = 0 (exact for constant velocity); with a single sample the
    obstacle is static on [0, times[0]].
    """
    t = np.asarray(times, dtype=np.float64)
    c = np.asarray(centers, dtype=np.float64)
    if c.ndim == 2:
        c = c[None]
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"times: expected a non-empty 1-D array, got shape {t.shape}")
    if c.ndim != 3 or c.shape[1:] != (t.size, 2):
        raise ValueError(
            f"centers: expected shape ({t.size}, 2) or (N, {t.size}, 2), got {np.shape(centers)}"
        )
    if t[0] < 0 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise ValueError("times: expected finite, strictly increasing values >= 0")
    if not np.all(np.isfinite(c)):
        raise ValueError("centers: expected finite values")
    n = c.shape[0]
    if t.size == 1:
        w0 = np.zeros((n, 2))
    else:
        w0 = (c[:, 1] - c[:, 0]) / (t[1] - t[0])
    if t[0] > 0:
        c = np.concatenate([(c[:, 0] - w0 * t[0])[:, None], c], axis=1)
        t = np.concatenate([[0.0], t])
    if t.size == 1:
        # a single sample at t = 0: a static obstacle over an empty horizon
        t = np.array([0.0, 0.0])
        c = np.concatenate([c, c], axis=1)
    w = np.diff(c, axis=1) / np.diff(t)[None, :, None] if t[-1] > 0 else np.zeros_like(c[:, 1:])
    return PiecewisePath(
        t=np.ascontiguousarray(t),
        c=np.ascontiguousarray(c[:, :-1]),
        velocity=np.ascontiguousarray(w),
        acceleration=np.zeros_like(w),
        radius=_radius_array(radius, n),
    )


UNCERTAINTY_WINDOWS = (1.0, 2.0)
"""The prediction times (s) at which :func:`grown_with_time` steps the radii up."""

_ABSENT = 1.0e4
"""Where (m, robot-relative) a copy of an obstacle waits outside its window."""


def grown_with_time(
    path: PiecewisePath, growth: float, windows: Sequence[float] = UNCERTAINTY_WINDOWS
) -> PiecewisePath:
    """``path`` with the moving obstacles' radii grown with prediction time: a prediction
    is less certain the further ahead it looks. The horizon is cut at ``windows`` (s,
    increasing) into [0, w1), [w1, w2), ..., [wk, end); each obstacle becomes one copy
    per window that holds a piece's start, present on those pieces only (elsewhere
    standing 10 km away) with its radius grown by ``growth`` (m/s) times the latest end
    (s) of those pieces (an unbounded last piece counts as ending 1 s after its start).
    An acceleration admissible against the result keeps each obstacle, at every time t,
    at least its radius plus ``growth`` times the end of t's window away. Walls are
    unchanged; ``growth`` 0 returns ``path`` itself."""
    if not (math.isfinite(growth) and growth >= 0.0):
        raise ValueError(f"growth: expected a number >= 0 (m/s), got {growth!r}")
    if growth == 0.0 or path.c.shape[0] == 0:
        return path
    starts, ends = path.t[:-1], path.t[1:]
    ends = np.where(np.isfinite(ends), ends, starts + 1.0)
    cs, vs, accs, radii = [], [], [], []
    for lo, hi in pairwise([0.0, *windows, math.inf]):
        inside = (starts >= lo) & (starts < hi)
        if not inside.any():
            continue
        cs.append(np.where(inside[None, :, None], path.c, _ABSENT))
        vs.append(np.where(inside[None, :, None], path.velocity, 0.0))
        accs.append(np.where(inside[None, :, None], path.acceleration, 0.0))
        radii.append(path.radius + growth * float(ends[inside].max()))
    f = np.ascontiguousarray
    return PiecewisePath(
        path.t,
        f(np.concatenate(cs)),
        f(np.concatenate(vs)),
        f(np.concatenate(accs)),
        f(np.concatenate(radii)),
        path.walls,
        path.wall_radius,
    )


def ao_path(
    obstacle_pos: ArrayLike,
    radius: ArrayLike,
    obstacle_vel: ArrayLike = (0.0, 0.0),
    obstacle_acc: ArrayLike = (0.0, 0.0),
    horizon: float = np.inf,
) -> PiecewisePath:
    """Obstacles with constant velocity and acceleration, one quadratic piece each.

    obstacle_pos (m, robot-relative), obstacle_vel (m/s), obstacle_acc
    (m/s^2): (2,) or (N, 2), world axes. horizon (s) may be inf.
    """
    p, _ = _as_vectors(obstacle_pos, "obstacle_pos")
    n = p.shape[0]
    vel = _broadcast(obstacle_vel, (n, 2), "obstacle_vel")
    acc = _broadcast(obstacle_acc, (n, 2), "obstacle_acc")
    if not (horizon > 0):
        raise ValueError(f"horizon: expected a positive number of seconds, got {horizon}")
    return PiecewisePath(
        t=np.array([0.0, float(horizon)]),
        c=np.ascontiguousarray(p[:, None, :]),
        velocity=np.ascontiguousarray(vel[:, None, :]),
        acceleration=np.ascontiguousarray(acc[:, None, :]),
        radius=_radius_array(radius, n),
    )


def path_clearance(
    accels: ArrayLike,
    v: ArrayLike | None,
    path: PiecewisePath,
    *,
    v_max: float = np.inf,
    velocities: ArrayLike | None = None,
) -> Clearance:
    """Clearance of K candidate accelerations against every obstacle of ``path``.

    accels: (K, 2) or (2,) m/s^2. v: (2,) robot velocity (m/s), or pass
    ``velocities`` (K, 2) for one initial velocity per candidate. Returns
    arrays of shape (K, N + W) (the obstacles, then the walls; leading/trailing axes
    dropped for a single acceleration or a single obstacle the way the inputs were given).
    """
    a, single_a = _as_vectors(accels, "accels")
    if velocities is None:
        v_arr = np.asarray(v, dtype=np.float64)
        if v_arr.shape != (2,):
            raise ValueError(f"v: expected shape (2,), got {v_arr.shape}")
        cand_v = np.ascontiguousarray(np.broadcast_to(v_arr, a.shape))
    else:
        cand_v, _ = _as_vectors(velocities, "velocities")
        cand_v = np.ascontiguousarray(np.broadcast_to(cand_v, a.shape))
    k, n = a.shape[0], path.n_obstacles
    clear = np.empty((k, n))
    tmin = np.empty((k, n))
    tfirst = np.empty((k, n))
    clearance_kernel(
        cand_v,
        a,
        float(v_max),
        Paths(*path.moving_arrays),
        Walls(path.walls, path.wall_radius),
        clear,
        tmin,
        tfirst,
    )
    if single_a:
        clear, tmin, tfirst = clear[0], tmin[0], tfirst[0]
    return Clearance(clear, tmin, tfirst)


def _squeeze_obstacles(result: Clearance, single: bool) -> Clearance:
    if not single:
        return result
    return Clearance(
        result.clearance[..., 0],
        result.time_of_closest_approach[..., 0],
        result.time_of_first_contact[..., 0],
    )


def nao_query(
    accels: ArrayLike,
    v: ArrayLike,
    times: ArrayLike,
    centers: ArrayLike,
    radius: ArrayLike,
    *,
    v_max: float = np.inf,
) -> Clearance:
    """Clearance, time of closest approach and time of first contact against sampled paths.

    Same arguments as :func:`nao_clearance`.
    """
    single = np.ndim(centers) == 2
    path = sampled_path(times, centers, radius)
    return _squeeze_obstacles(path_clearance(accels, v, path, v_max=v_max), single)


@overload
def nao_clearance(
    accels: ArrayLike,
    v: ArrayLike,
    times: ArrayLike,
    centers: ArrayLike,
    radius: ArrayLike,
    *,
    v_max: float = ...,
    return_time: Literal[False] = ...,
) -> NDArray[np.float64]: ...
@overload
def nao_clearance(
    accels: ArrayLike,
    v: ArrayLike,
    times: ArrayLike,
    centers: ArrayLike,
    radius: ArrayLike,
    *,
    v_max: float = ...,
    return_time: Literal[True],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
@overload
def nao_clearance(
    accels: ArrayLike,
    v: ArrayLike,
    times: ArrayLike,
    centers: ArrayLike,
    radius: ArrayLike,
    *,
    v_max: float = ...,
    return_time: bool = ...,
) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def nao_clearance(
    accels: ArrayLike,
    v: ArrayLike,
    times: ArrayLike,
    centers: ArrayLike,
    radius: ArrayLike,
    *,
    v_max: float = np.inf,
    return_time: bool = False,
) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Minimum over the horizon of (distance - radius) for each candidate acceleration.

    accels: (K, 2) m/s^2; v: (2,) m/s; times: (T,) increasing in [0, t_h] s;
    centers: (T, 2) or (N, T, 2) predicted obstacle centres relative to the
    robot's current position (m), linearly interpolated between samples
    (see :func:`sampled_path`); radius: float or (N,) m, grown by the robot's
    radius. Returns (K,) for one obstacle or (K, N); with ``return_time``
    also the time of closest approach (s). Negative means collision.
    """
    q = nao_query(accels, v, times, centers, radius, v_max=v_max)
    if return_time:
        return q.clearance, q.time_of_closest_approach
    return q.clearance


def ao_clearance(
    accels: ArrayLike,
    v: ArrayLike,
    obstacle_pos: ArrayLike,
    radius: ArrayLike,
    obstacle_vel: ArrayLike = (0.0, 0.0),
    obstacle_acc: ArrayLike = (0.0, 0.0),
    horizon: float = np.inf,
    *,
    v_max: float = np.inf,
) -> Clearance:
    """Clearance against obstacles moving with constant velocity and acceleration (AO).

    Exact over a finite or infinite horizon (the squared distance is a
    quartic in t). obstacle_pos (m, robot-relative), obstacle_vel (m/s),
    obstacle_acc (m/s^2): (2,) or (N, 2). Returns a :class:`Clearance`
    with arrays (K,) for a single obstacle or (K, N).
    """
    single = np.ndim(obstacle_pos) == 1
    path = ao_path(obstacle_pos, radius, obstacle_vel, obstacle_acc, horizon)
    return _squeeze_obstacles(path_clearance(accels, v, path, v_max=v_max), single)


def vo_clearance(
    velocities: ArrayLike,
    times: ArrayLike,
    centers: ArrayLike,
    radius: ArrayLike,
) -> NDArray[np.float64]:
    """Velocity-obstacle (NLVO) clearance: the robot keeps a constant velocity.

    velocities: (K, 2) candidate robot velocities (m/s). With a straight
    constant-velocity obstacle path this is the truncated VO; with a curved
    path it is the NLVO. Returns (K,) or (K, N) clearance (m).
    """
    u, single_u = _as_vectors(velocities, "velocities")
    single = np.ndim(centers) == 2
    path = sampled_path(times, centers, radius)
    res = path_clearance(np.zeros_like(u), None, path, velocities=u)
    res = _squeeze_obstacles(res, single)
    return res.clearance[0] if single_u else res.clearance
