"""Verification of ``nao_arena.geometry._kernel.relevance.relevant_obstacles``.

The mask promises: an obstacle left out of it cannot be brought within
radius + margin (m) over the horizon by any constant acceleration |a| <= a_max,
for a robot that starts at the origin with velocity v (first clamped to speed
v_max), accelerates until its speed reaches v_max and then keeps its velocity.
Every left-out obstacle is checked against the brute-force forward simulation
of ``forward_sim`` (independent of the implementation) for 64 accelerations on
the circle |a| = a_max, random interior points and a = 0. The distance is
evaluated on a dense grid; a grid minimum within the Lipschitz slack of the
limit (relative speed x half the grid spacing) is re-checked with the refined
``simulate``, so a left-out obstacle passes only if its true minimum distance is
>= radius + margin - TOL for every sampled acceleration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, note, settings, target
from hypothesis import strategies as st
from numpy.typing import NDArray

from nao_arena.geometry._kernel.relevance import relevant_obstacles
from nao_arena.geometry.clearance import sampled_path

try:  # tests/ as a rootdir-relative package or as a plain directory on sys.path
    from tests.forward_sim import Polyline, Robot, screened_min_distance, simulate
    from tests.strategies import floats, unit, vec
except ImportError:  # pragma: no cover
    from forward_sim import Polyline, Robot, screened_min_distance, simulate
    from strategies import floats, unit, vec

FloatArray = NDArray[np.float64]

TOL = 1e-6  # m, below radius + margin
N_RIM = 64  # accelerations on the circle |a| = a_max
N_INTERIOR = 32  # random accelerations inside the disc
N_GRID = 2001  # screening grid over the horizon
RIM_ANGLES = 2 * np.pi * np.arange(N_RIM) / N_RIM


@dataclass(frozen=True)
class Case:
    v: FloatArray
    a_max: float
    v_max: float
    margin: float
    times: FloatArray  # (T,)
    centers: FloatArray  # (N, T, 2)
    radius: FloatArray  # (N,)
    seed: int

    def mask(self) -> NDArray[np.bool_]:
        path = sampled_path(self.times, self.centers, self.radius)
        return relevant_obstacles(
            np.ascontiguousarray(self.v, dtype=np.float64),
            float(self.a_max),
            float(self.v_max),
            *path.moving_arrays,
            float(self.margin),
        )

    def accelerations(self) -> FloatArray:
        """The rim circle, random interior points of the disc and a = 0."""
        rng = np.random.default_rng(self.seed)
        rim = self.a_max * np.stack([np.cos(RIM_ANGLES), np.sin(RIM_ANGLES)], 1)
        r = self.a_max * np.sqrt(rng.random(N_INTERIOR))
        ang = rng.uniform(0.0, 2 * np.pi, N_INTERIOR)
        inner = np.stack([r * np.cos(ang), r * np.sin(ang)], 1)
        return np.concatenate([rim, inner, np.zeros((1, 2))])


def forward_min_distances(case: Case, n: int, accels: FloatArray) -> FloatArray:
    """(K,) forward-simulated minimum centre distance to obstacle n for each acceleration
    (exact wherever it comes near radius + margin)."""
    return screened_min_distance(
        case.v,
        accels,
        case.v_max,
        case.a_max,
        case.times,
        case.centers[n],
        case.radius[n] + case.margin,
        N_GRID,
    )


def check_left_out(case: Case) -> list[float]:
    """Assert the property for every obstacle outside the mask; returns their gaps
    (minimum distance - radius - margin, m)."""
    mask = case.mask()
    assert mask.shape == (case.centers.shape[0],) and mask.dtype == np.bool_
    accels = case.accelerations()
    gaps = []
    for n in np.flatnonzero(~mask):
        dist = forward_min_distances(case, int(n), accels)
        limit = case.radius[n] + case.margin
        k = int(np.argmin(dist))
        gaps.append(dist[k] - limit)
        assert dist[k] >= limit - TOL, (
            f"obstacle {n} left out of the mask, but a = {accels[k].tolist()} (|a| = "
            f"{np.hypot(*accels[k]):.6g}, a_max = {case.a_max}) comes within {dist[k]:.9g} m "
            f"< radius + margin = {limit:.9g} m (v = {case.v.tolist()}, v_max = {case.v_max}, "
            f"margin = {case.margin}, times = {case.times.tolist()}, "
            f"centers = {case.centers[n].tolist()}, radius = {case.radius[n]})"
        )
    return gaps


# ------------------------------------------------------------------ cases


@st.composite
def sample_times(draw: st.DrawFn) -> FloatArray:
    horizon = draw(floats(0.5, 6.0))
    n_t = draw(st.integers(2, 12))
    t0 = horizon * draw(st.one_of(st.just(0.0), floats(0.0, 0.4)))
    gaps = np.array([draw(floats(0.05, 1.0)) for _ in range(n_t - 1)])
    times = t0 + (horizon - t0) * np.concatenate([[0.0], np.cumsum(gaps) / np.sum(gaps)])
    times[-1] = horizon
    return times


@st.composite
def cases(draw: st.DrawFn) -> Case:
    v_max = draw(st.one_of(st.just(math.inf), floats(0.2, 3.0)))
    speed_cap = 2 * v_max if math.isfinite(v_max) else 3.0
    speed = draw(st.one_of(st.just(0.0), floats(0.0, speed_cap)))
    v = speed * unit(draw(floats(-math.pi, math.pi)))
    a_max = draw(floats(0.1, 4.0))
    margin = draw(st.one_of(st.just(0.0), floats(0.0, 0.5)))
    times = draw(sample_times())
    h = float(times[-1])
    vc = Robot.make(v, (0.0, 0.0), v_max).v
    n = draw(st.integers(1, 5))
    centers, radius = [], []
    for _ in range(n):
        r = draw(floats(0.05, 1.5))
        kind = draw(st.sampled_from(["random", "line", "comoving", "static"]))
        if kind == "random":  # every sample anywhere in the +-15 m square
            c = np.array([draw(vec(15.0)) for _ in times])
        elif kind == "line":  # constant velocity between two points of the square
            p0, p1 = draw(vec(15.0)), draw(vec(15.0))
            s = (times - times[0]) / (times[-1] - times[0])
            c = p0 + s[:, None] * (p1 - p0)
        elif kind == "comoving":
            # moves with the (clamped) robot velocity, just beyond a_max h^2 / 2 along
            # a rim direction: the bound |x - v t| <= a_max t^2 / 2 is attained there
            u = unit(float(RIM_ANGLES[draw(st.integers(0, N_RIM - 1))]))
            delta = draw(st.one_of(st.just(0.0), floats(0.0, 0.05), floats(0.0, 3.0)))
            c = u * (r + margin + 0.5 * a_max * h * h + delta) + times[:, None] * vc
        else:  # static, around the distance the robot can reach
            ang = draw(st.one_of(st.just(math.atan2(vc[1], vc[0])), floats(-math.pi, math.pi)))
            reach = min(float(np.hypot(*vc)) * h + 0.5 * a_max * h * h, v_max * h)
            c = np.broadcast_to(
                unit(ang) * (r + margin + draw(floats(0.8, 1.3)) * reach), (times.size, 2)
            )
        centers.append(np.asarray(c, dtype=np.float64))
        radius.append(r)
    return Case(
        v,
        a_max,
        v_max,
        margin,
        times,
        np.array(centers),
        np.array(radius),
        draw(st.integers(0, 2**32 - 1)),
    )


# ------------------------------------------------------------------ tests


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases())
def test_left_out_obstacles_are_unreachable(case: Case) -> None:
    """No sampled acceleration of the limit disc brings a left-out obstacle within
    radius + margin over the horizon (forward simulation)."""
    gaps = check_left_out(case)
    note(f"mask {case.mask().tolist()}, gaps of left-out obstacles {gaps}")
    if gaps:
        target(-min(gaps), label="closest left-out obstacle")


def comoving_case(delta: float, v_max: float = math.inf, v=(0.8, -0.3)) -> Case:
    """One obstacle moving with the robot's velocity at a_max h^2 / 2 + delta beyond contact."""
    a_max, margin, r = 1.5, 0.2, 0.5
    times = np.linspace(0.0, 2.0, 5)
    vc = Robot.make(v, (0.0, 0.0), v_max).v
    c = unit(RIM_ANGLES[5]) * (r + margin + 0.5 * a_max * 4.0 + delta) + times[:, None] * vc
    return Case(
        np.asarray(v, dtype=np.float64), a_max, v_max, margin, times, c[None], np.array([r]), 0
    )


def test_obstacle_on_the_path_is_relevant() -> None:
    """A static obstacle ahead of the robot, hit at a = 0, is in the mask."""
    times = np.linspace(0.0, 3.0, 4)
    centers = np.array([[[2.0, 0.0]] * 4, [[40.0, 40.0]] * 4])
    case = Case(np.array([1.0, 0.0]), 0.5, math.inf, 0.1, times, centers, np.array([0.3, 0.3]), 0)
    res = simulate(case.v, (0.0, 0.0), Polyline.make(times, centers[0]), 0.3)
    assert res.clearance < 0  # the forward simulation collides
    assert case.mask().tolist() == [True, False]
    check_left_out(case)


@pytest.mark.parametrize("delta", [0.01, 1e-4])
def test_obstacle_at_the_full_speed_reach_is_relevant(delta) -> None:
    """Already at v_max towards a static obstacle whose grown disc the robot's straight
    run (a = 0) just enters at the horizon: the speed bound |x(t)| <= v_max t is sharp."""
    v_max, h, r = 1.5, 2.0, 0.3
    times = np.linspace(0.0, h, 5)
    centers = np.array([[[v_max * h + r - delta, 0.0]] * 5])
    case = Case(np.array([v_max, 0.0]), 1.0, v_max, 0.0, times, centers, np.array([r]), 0)
    res = simulate(case.v, (0.0, 0.0), Polyline.make(times, centers[0]), r, v_max=v_max)
    assert res.clearance < 0  # the forward simulation enters the disc
    assert case.mask().tolist() == [True]


@pytest.mark.parametrize("v", [(0.0, 0.0), (0.8, -0.3)])
def test_comoving_obstacle_within_reach_is_relevant(v) -> None:
    """0.01 m inside the attainable a_max h^2 / 2: in the mask, and the rim acceleration
    towards it really comes within radius + margin."""
    case = comoving_case(-0.01, v=v)
    assert case.mask().tolist() == [True]
    dist = forward_min_distances(case, 0, case.accelerations()[5:6])
    assert dist[0] < case.radius[0] + case.margin


@example(delta=1e-3)
@given(floats(1e-4, 1.0))
@settings(max_examples=10, deadline=None)
def test_unreachable_obstacles_are_left_out(delta: float) -> None:
    """The mask is not trivially all True: an obstacle just beyond the attainable
    co-moving distance, and a far one, are left out (and really unreachable)."""
    case = comoving_case(delta)
    assert case.mask().tolist() == [False]
    check_left_out(case)
    far = Case(
        np.array([1.0, 0.0]),
        2.0,
        math.inf,
        0.0,
        np.linspace(0.0, 2.0, 3),
        np.full((1, 3, 2), 100.0),
        np.array([1.0]),
        0,
    )
    assert far.mask().tolist() == [False]


def test_zero_length_horizon_without_speed_limit_keeps_an_overlapping_obstacle():
    # t = [0, 0]: no time to move; an obstacle already overlapping stays relevant
    path = sampled_path([0.0], np.array([[0.1, 0.0]]), np.array([0.5]))
    for v_max in (math.inf, 2.0):
        mask = relevant_obstacles(np.zeros(2), 1.0, v_max, *path.moving_arrays, 0.0)
        assert mask.tolist() == [True]
