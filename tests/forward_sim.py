"""Brute-force forward simulation of a robot/obstacle encounter (test oracle).

Written from the model definitions only (no code shared with
``nao_arena.geometry``):

* Robot: starts at the origin at t = 0 with velocity v and drives a constant
  acceleration a, x(t) = v t + a t^2 / 2. With a finite ``v_max`` an initial
  speed above v_max is first scaled down to v_max; the robot accelerates until
  |v + a t| = v_max (tau, the positive root) and then keeps the velocity
  v + a tau.
* Obstacle centre c(t) (robot-relative): a polyline through samples (linear
  between samples, first segment extended backwards to t = 0, static if there
  is a single sample, horizon = last sample time) or a constant-acceleration
  path p + w t + b t^2 / 2 on a finite horizon.

The oracle evaluates the distance on a dense grid that contains every kink
(sample times, tau), then refines the cells around the best grid minima and
next to every kink by repeated local dense re-gridding of the squared
distance, which is smooth between kinks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Robot:
    """Constant-acceleration robot with optional speed saturation."""

    v: FloatArray
    a: FloatArray
    v_max: float = math.inf

    @staticmethod
    def make(v: ArrayLike, a: ArrayLike, v_max: float = math.inf) -> Robot:
        """Build a robot, applying the initial speed clamp of the model."""
        v_arr = np.asarray(v, dtype=np.float64).reshape(2).copy()
        speed = float(np.hypot(*v_arr))
        if speed > v_max:
            v_arr *= v_max / speed
        return Robot(v_arr, np.asarray(a, dtype=np.float64).reshape(2).copy(), float(v_max))

    @property
    def tau(self) -> float:
        """Time at which the speed reaches v_max (inf if never)."""
        if not math.isfinite(self.v_max):
            return math.inf
        a2 = float(self.a @ self.a)
        if a2 == 0.0:
            return math.inf
        # |v + a t|^2 = v_max^2  <=>  a2 t^2 + 2 (v.a) t + (|v|^2 - v_max^2) = 0.
        # |v| <= v_max, so the roots have opposite signs (or one is 0): take the larger.
        va = float(self.v @ self.a)
        c = min(float(self.v @ self.v) - self.v_max**2, 0.0)
        return max((-va + math.sqrt(max(va * va - a2 * c, 0.0))) / a2, 0.0)

    def position(self, t: FloatArray) -> FloatArray:
        """(M, 2) positions at times t (M,)."""
        t = np.asarray(t, dtype=np.float64)
        ta = np.minimum(t, self.tau)[:, None]
        x = self.v * ta + 0.5 * self.a * ta**2
        if math.isfinite(self.tau):
            v_sat = self.v + self.a * self.tau
            x = x + v_sat * np.maximum(t - self.tau, 0.0)[:, None]
        return x


class ObstaclePath(Protocol):
    """Obstacle centre as a function of time on [0, horizon]."""

    @property
    def horizon(self) -> float: ...

    @property
    def kinks(self) -> FloatArray: ...

    def position(self, t: FloatArray) -> FloatArray: ...


@dataclass(frozen=True)
class Polyline:
    """Piecewise-linear obstacle path through (times, centers)."""

    times: FloatArray
    centers: FloatArray

    @staticmethod
    def make(times: ArrayLike, centers: ArrayLike) -> Polyline:
        """Build a polyline from (T,) times and (T, 2) centres."""
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        c = np.asarray(centers, dtype=np.float64).reshape(t.size, 2)
        return Polyline(t, c)

    @property
    def horizon(self) -> float:
        return float(self.times[-1])

    @property
    def kinks(self) -> FloatArray:
        return self.times

    def position(self, t: FloatArray) -> FloatArray:
        """(M, 2) centres at times t (M,); linear extrapolation before times[0]."""
        t = np.asarray(t, dtype=np.float64)
        ts, cs = self.times, self.centers
        if ts.size == 1:
            return np.broadcast_to(cs[0], (t.size, 2)).copy()
        # segment index j with ts[j] <= t < ts[j + 1], clipped to the valid range
        j = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, ts.size - 2)
        frac = (t - ts[j]) / (ts[j + 1] - ts[j])
        return cs[j] + frac[:, None] * (cs[j + 1] - cs[j])


@dataclass(frozen=True)
class Parabola:
    """Obstacle path p + w t + b t^2 / 2 on [0, horizon]."""

    p: FloatArray
    w: FloatArray
    b: FloatArray
    horizon: float

    @staticmethod
    def make(p: ArrayLike, w: ArrayLike, b: ArrayLike, horizon: float) -> Parabola:
        """Build a constant-acceleration path."""

        def vec(x: ArrayLike) -> FloatArray:
            return np.asarray(x, dtype=np.float64).reshape(2).copy()

        return Parabola(vec(p), vec(w), vec(b), float(horizon))

    @property
    def kinks(self) -> FloatArray:
        return np.array([0.0, self.horizon])

    def position(self, t: FloatArray) -> FloatArray:
        """(M, 2) centres at times t (M,)."""
        t = np.asarray(t, dtype=np.float64)[:, None]
        return self.p + self.w * t + 0.5 * self.b * t**2


@dataclass(frozen=True)
class ForwardResult:
    """Brute-force clearance and the evaluation grid it came from."""

    clearance: float
    time_of_closest_approach: float
    time_of_first_contact: float
    grid: FloatArray = field(repr=False)
    distance: FloatArray = field(repr=False)


@dataclass(frozen=True)
class Encounter:
    """A robot, an obstacle path and a combined radius."""

    robot: Robot
    path: ObstaclePath
    radius: float

    @property
    def horizon(self) -> float:
        return float(self.path.horizon)

    def distance(self, t: ArrayLike) -> FloatArray:
        """Centre distance |x(t) - c(t)| at times t."""
        t_arr = np.atleast_1d(np.asarray(t, dtype=np.float64))
        d = self.robot.position(t_arr) - self.path.position(t_arr)
        return np.hypot(d[:, 0], d[:, 1])

    def _dist2(self, t: float) -> float:
        d = self.robot.position(np.array([t])) - self.path.position(np.array([t]))
        return float(d[0] @ d[0])

    def kinks(self) -> FloatArray:
        """Times in [0, horizon] where the relative motion may be non-smooth."""
        k = [0.0, self.horizon, *self.path.kinks.tolist()]
        if self.robot.tau < self.horizon:
            k.append(self.robot.tau)
        arr = np.unique(np.asarray(k))
        return arr[(arr >= 0.0) & (arr <= self.horizon)]

    def _dist2(self, t: FloatArray) -> FloatArray:
        """Squared centre distance at times t of any shape."""
        flat = np.asarray(t, dtype=np.float64).reshape(-1)
        d = self.robot.position(flat) - self.path.position(flat)
        return (d[:, 0] ** 2 + d[:, 1] ** 2).reshape(np.shape(t))

    def _zoom(self, lo: FloatArray, hi: FloatArray, n: int = 33, rounds: int = 14) -> FloatArray:
        """Minimise |d|^2 on each cell [lo_i, hi_i] by repeated local dense re-gridding.

        Each round evaluates n points per cell and shrinks the bracket to the two
        spacings around the best one (factor (n - 1) / 2), so 14 rounds reach far
        below float resolution. Cells contain no kink, so |d|^2 is smooth there.
        Returns the best time found in each cell.
        """
        u = np.linspace(0.0, 1.0, n)
        best = lo.copy()
        for _ in range(rounds):
            ts = lo[:, None] + (hi - lo)[:, None] * u
            f = self._dist2(ts)
            i = np.argmin(f, axis=1)
            rows = np.arange(lo.size)
            best = ts[rows, i]
            lo = np.maximum(ts[rows, np.maximum(i - 1, 0)], lo)
            hi = np.minimum(ts[rows, np.minimum(i + 1, n - 1)], hi)
        return best

    def _crossing(self, lo: float, hi: float) -> float:
        """First-contact time by bisection; distance > r at lo and <= r at hi."""
        r = self.radius
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            if self.distance(mid)[0] <= r:
                hi = mid
            else:
                lo = mid
        return hi

    def simulate(self, n_grid: int = 4001, n_refine: int = 16) -> ForwardResult:
        """Brute-force clearance, time of closest approach and first contact."""
        h = self.horizon
        grid = np.unique(np.concatenate([np.linspace(0.0, h, n_grid), self.kinks()]))
        dist = self.distance(grid)
        # refine the cells around the best discrete local minima and on both sides
        # of every kink (a dip right after a kink need not show up on the grid)
        m = dist.size
        is_min = np.ones(m, dtype=bool)
        is_min[1:] &= dist[1:] <= dist[:-1]
        is_min[:-1] &= dist[:-1] <= dist[1:]
        cands = np.flatnonzero(is_min)
        cands = cands[np.argsort(dist[cands], kind="stable")][:n_refine]
        cands = np.union1d(cands, np.searchsorted(grid, self.kinks()))
        cells = np.union1d(cands - 1, cands)
        cells = cells[(cells >= 0) & (cells < m - 1)]
        extra_t = self._zoom(grid[cells], grid[cells + 1]) if cells.size else np.empty(0)
        all_t = np.unique(np.concatenate([grid, extra_t]))
        all_d = self.distance(all_t)
        i_best = int(np.argmin(all_d))
        # first contact: first evaluated point at or inside the radius, then bisect back
        inside = np.flatnonzero(all_d <= self.radius)
        if inside.size == 0:
            first = math.inf
        elif inside[0] == 0:
            first = 0.0
        else:
            first = self._crossing(float(all_t[inside[0] - 1]), float(all_t[inside[0]]))
        return ForwardResult(
            clearance=float(all_d[i_best]) - self.radius,
            time_of_closest_approach=float(all_t[i_best]),
            time_of_first_contact=first,
            grid=all_t,
            distance=all_d,
        )


def simulate(
    v: ArrayLike,
    a: ArrayLike,
    path: ObstaclePath,
    radius: float,
    v_max: float = math.inf,
    n_grid: int = 4001,
) -> ForwardResult:
    """Convenience wrapper: forward-simulate one robot against one obstacle path."""
    return Encounter(Robot.make(v, a, v_max), path, float(radius)).simulate(n_grid=n_grid)


def screened_min_distance(
    v: ArrayLike,
    accels: ArrayLike,
    v_max: float,
    a_max: float,
    times: ArrayLike,
    centers: ArrayLike,
    near: float,
    n_grid: int = 2001,
) -> FloatArray:
    """(K,) minimum centre distance (m) between the robot driving each acceleration of
    ``accels`` (K, 2) and the polyline through ``centers`` (T, 2) at ``times`` (T,).

    A dense grid over the horizon screens every acceleration; where the grid
    minimum is within its Lipschitz slack (relative speed bound x half the grid
    spacing; a_max bounds |a|) of ``near`` (m), the refined :func:`simulate`
    minimum is taken instead, so the result is exact wherever it is compared
    with ``near``.
    """
    times = np.asarray(times, dtype=float)
    centers = np.asarray(centers, dtype=float)
    accels = np.atleast_2d(np.asarray(accels, dtype=float))
    path = Polyline.make(times, centers)
    h = float(times[-1])
    grid = np.unique(np.concatenate([np.linspace(0.0, h, n_grid), times]))
    spacing = float(np.max(np.diff(grid)))
    obs = path.position(grid)
    seg_v = np.diff(centers, axis=0) / np.diff(times)[:, None]
    obs_speed = float(np.max(np.hypot(*seg_v.T))) if len(seg_v) else 0.0
    start_speed = float(np.hypot(*Robot.make(v, (0.0, 0.0), v_max).v))
    robot_speed = min(start_speed + a_max * h, v_max)
    slack = (robot_speed + obs_speed) * spacing / 2 + 1e-9
    out = np.empty(len(accels))
    for k, a in enumerate(accels):
        d = Robot.make(v, a, v_max).position(grid) - obs
        out[k] = float(np.min(np.hypot(d[:, 0], d[:, 1])))
        if out[k] - slack < near:
            res = simulate(v, a, path, near, v_max=v_max)
            out[k] = min(out[k], res.clearance + near)
    return out


def turning_walker(
    times: ArrayLike, start: ArrayLike, velocity: ArrayLike, turn_rate: float
) -> FloatArray:
    """(T, 2) centres (m) at ``times`` (T,) s of a walker that starts at ``start`` (m)
    with ``velocity`` (m/s) and keeps its speed while its heading turns at ``turn_rate``
    (rad/s), stepping straight between the times."""
    v = np.asarray(velocity, dtype=np.float64)
    heading = math.atan2(v[1], v[0])
    speed = float(np.hypot(*v))
    out = [np.asarray(start, dtype=np.float64)]
    for dt in np.diff(np.asarray(times, dtype=np.float64)):
        q = heading + turn_rate * (len(out) - 1) * dt
        out.append(out[-1] + speed * dt * np.array([math.cos(q), math.sin(q)]))
    return np.array(out)
