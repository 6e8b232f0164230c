"""Verification of ``nao_arena.geometry.selection.select_acceleration``.

The chosen acceleration is checked against the definitions: it must lie in the
limit set (disc |a| <= a_max), and when the result is reported
feasible the robot x(t) = v t + a t^2 / 2 (speed-saturated at v_max) must keep
a forward-simulated clearance >= margin from every obstacle (``forward_sim``,
independent of the implementation). Optimality is compared with a dense grid
search (grid clearances from ``nao_clearance``, which ``test_clearance.py``
verifies against the same oracle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from nao_arena.geometry import selection
from nao_arena.geometry.clearance import nao_clearance, nao_query, sampled_path
from nao_arena.geometry.selection import AccelLimits, select_acceleration

try:  # tests/ as a rootdir-relative package or as a plain directory on sys.path
    from tests.forward_sim import Polyline, simulate
except ImportError:  # pragma: no cover
    from forward_sim import Polyline, simulate

FloatArray = NDArray[np.float64]

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
LIMIT_SLACK = 1e-9  # relative slack on the limit set
CLEAR_SLACK = 1e-9  # m, below the margin


@dataclass(frozen=True)
class Scene:
    v: FloatArray
    desired: FloatArray
    limits: AccelLimits
    margin: float
    v_max: float
    times: FloatArray
    centers: FloatArray  # (N, T, 2)
    radius: FloatArray  # (N,)

    def path(self):
        return sampled_path(self.times, self.centers, self.radius)

    def select(self, **kw):
        return select_acceleration(
            self.desired,
            self.v,
            self.path(),
            self.limits,
            margin=self.margin,
            v_max=self.v_max,
            **kw,
        )

    def forward_clearance(self, a: FloatArray) -> float:
        """min over obstacles of the brute-force clearance of acceleration a."""
        out = math.inf
        for c, r in zip(self.centers, self.radius, strict=True):
            res = simulate(self.v, a, Polyline.make(self.times, c), r, v_max=self.v_max)
            out = min(out, res.clearance)
        return out

    def forward_first_contact(self, a: FloatArray) -> float:
        out = math.inf
        for c, r in zip(self.centers, self.radius, strict=True):
            res = simulate(self.v, a, Polyline.make(self.times, c), r, v_max=self.v_max)
            out = min(out, res.time_of_first_contact)
        return out


def in_limits(a: FloatArray, limits: AccelLimits) -> bool:
    a = np.asarray(a, dtype=np.float64)
    ok = float(np.hypot(*a)) <= limits.a_max * (1 + LIMIT_SLACK) + 1e-12
    return bool(ok)


# ------------------------------------------------------------------ scenes


def floats(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def vec(bound: float) -> st.SearchStrategy[FloatArray]:
    return st.tuples(floats(-bound, bound), floats(-bound, bound)).map(np.array)


def obstacle_path(rng_draw, times: FloatArray, kind: str) -> FloatArray:
    t = times[:, None]
    p = rng_draw(vec(6.0))
    if kind == "line":
        return p + rng_draw(vec(2.0)) * t
    big_r = rng_draw(floats(0.5, 4.0))
    ang = rng_draw(floats(-1.5, 1.5)) * t + rng_draw(floats(-math.pi, math.pi))
    return p + big_r * np.concatenate([np.cos(ang), np.sin(ang)], axis=1)


@st.composite
def scenes(draw: st.DrawFn, n_max: int = 15) -> Scene:
    horizon = draw(floats(1.0, 4.0))
    n_t = draw(st.integers(2, 12))
    # (sub-normal first times raise: see the degenerate-input test)
    t0 = draw(st.one_of(st.just(0.0), floats(0.01, 0.3)))
    times = np.linspace(t0, horizon, n_t)
    n = draw(st.integers(1, n_max))
    centers = np.array(
        [obstacle_path(draw, times, draw(st.sampled_from(["line", "arc"]))) for _ in range(n)]
    )
    radius = np.array([draw(floats(0.2, 1.0)) for _ in range(n)])
    a_max = draw(floats(0.5, 5.0))
    limits = AccelLimits(a_max)
    v_max = draw(st.one_of(st.just(math.inf), floats(0.5, 3.0)))
    return Scene(
        v=draw(vec(2.0)),
        desired=draw(vec(1.3 * a_max)),
        limits=limits,
        margin=draw(st.one_of(st.just(0.0), floats(0.0, 0.3))),
        v_max=v_max,
        times=times,
        centers=centers,
        radius=radius,
    )


def random_scene(rng: np.random.Generator, n_max: int = 15) -> Scene:
    """A scene with obstacles placed so that many of them matter."""
    horizon = rng.uniform(1.0, 4.0)
    times = np.linspace(0.0, horizon, int(rng.integers(2, 12)))
    t = times[:, None]
    n = int(rng.integers(1, n_max + 1))
    centers = []
    for _ in range(n):
        p = rng.uniform(-5, 5, 2)
        if rng.random() < 0.5:
            centers.append(p + rng.uniform(-2, 2, 2) * t)
        else:
            ang = rng.uniform(-1.5, 1.5) * t + rng.uniform(-math.pi, math.pi)
            centers.append(p + rng.uniform(0.5, 4) * np.concatenate([np.cos(ang), np.sin(ang)], 1))
    a_max = rng.uniform(0.5, 5.0)
    d = rng.uniform(-a_max, a_max, 2)
    d *= min(1.0, a_max / max(float(np.hypot(*d)), 1e-12))  # desired inside the disc
    return Scene(
        v=rng.uniform(-2, 2, 2),
        desired=d,
        limits=AccelLimits(a_max),
        margin=float(rng.choice([0.0, rng.uniform(0.0, 0.3)])),
        v_max=float(rng.choice([math.inf, rng.uniform(0.5, 3.0)])),
        times=times,
        centers=np.array(centers),
        radius=rng.uniform(0.2, 1.0, n),
    )


# ------------------------------------------------------------------ 6. admissibility


@SETTINGS
@given(scenes())
def test_selection_is_in_limits_and_admissible(scene: Scene) -> None:
    """The result lies in the limit set; when feasible it keeps clearance >= margin."""
    sel = scene.select()
    a = np.asarray(sel.accel)
    assert a.shape == (2,) and np.all(np.isfinite(a))
    assert sel.status in {"desired", "adjusted", "infeasible"}
    assert in_limits(a, scene.limits), (a, scene.limits)
    if sel.feasible:
        clear = scene.forward_clearance(a)
        assert clear >= scene.margin - CLEAR_SLACK, (
            f"{sel.status} acceleration {a.tolist()} has forward clearance {clear:.3e} "
            f"< margin {scene.margin}"
        )


# ------------------------------------------------------------------ 7. near-optimality


def grid_best(scene: Scene, n: int = 61) -> tuple[float, float]:
    """(distance from desired to the nearest admissible grid point, grid spacing)."""
    a_max = scene.limits.a_max
    xs = np.linspace(-a_max, a_max, n)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    grid = grid[np.hypot(*grid.T) <= a_max]
    clear = nao_clearance(
        grid, scene.v, scene.times, scene.centers, scene.radius, v_max=scene.v_max
    ).reshape(len(grid), -1)
    ok = np.min(clear, axis=1) >= scene.margin
    if not np.any(ok):
        return math.inf, float(xs[1] - xs[0])
    return float(np.min(np.hypot(*(grid[ok] - scene.desired).T))), float(xs[1] - xs[0])


N_OPT_SCENES = 80


def test_selection_is_near_optimal() -> None:
    """|chosen - desired| <= grid best + spacing + 1e-3 in >= 90 % of random scenes,
    and never worse than the grid best by more than a_max / 4.

    Measured over the 80 scenes below (seed 7, 1..15 obstacles on straight/circular
    paths, desired inside the disc, half with finite v_max, grid spacing a_max / 30):
    47 "desired", 21 "adjusted", 12 "infeasible" with no admissible grid point
    either; of the 68 feasible ones, excess = |chosen - desired| - grid best is <= 0
    in 61 and <= spacing + 1e-3 in 65 (96 %); the largest, 1.33 m/s^2, has a finite
    v_max (with speed saturation only admissibility is promised).
    """
    rng = np.random.default_rng(7)
    excess, spacing, absurd = [], [], []
    for _ in range(N_OPT_SCENES):
        scene = random_scene(rng)
        sel = scene.select()
        best, h = grid_best(scene)
        spacing.append(h)
        if not sel.feasible:
            # missing an admissible grid point is a failure; both infeasible is fine
            excess.append(-math.inf if math.isinf(best) else math.inf)
            continue
        chosen = float(np.hypot(*(sel.accel - scene.desired)))
        excess.append(chosen - best)
        # with a finite v_max the disk picture ignores speed saturation, so only
        # admissibility (test 6) is promised there, not the nearest point
        if chosen > best + 0.25 * scene.limits.a_max and math.isinf(scene.v_max):
            absurd.append((round(chosen, 3), round(best, 3), scene.limits.a_max, scene.v_max))
    excess, spacing = np.asarray(excess), np.asarray(spacing)
    good = float(np.mean(excess <= spacing + 1e-3))
    assert good >= 0.9, f"only {good:.0%} near-optimal; worst excesses {np.sort(excess)[-8:]}"
    assert not absurd, f"(chosen, grid best, a_max, v_max) far from optimal: {absurd}"


def test_nearest_admissible_minimal_reproduction() -> None:
    """Regression (a fixed bug): one obstacle on a straight 2-sample path, v_max = inf.

    select_acceleration((3.46, 3.18), (0.95, -0.62), sampled_path([0, 3.14],
    [[2.43, 1.72], [2.87, 1.31]], 0.76), AccelLimits(4.7)) returned "adjusted"
    (-0.152, 0.813), 4.32 from the desired acceleration, while a = (3.6416, 2.8976)
    (|a| = 4.654 <= 4.7) has forward-simulated clearance +0.0039 and is 0.336 away.
    """
    desired, v = np.array([3.46, 3.18]), np.array([0.95, -0.62])
    times, centers = np.array([0.0, 3.14]), np.array([[[2.43, 1.72], [2.87, 1.31]]])
    scene = Scene(v, desired, AccelLimits(4.7), 0.0, math.inf, times, centers, np.array([0.76]))
    better = np.array([3.6416, 2.8976])
    assert in_limits(better, scene.limits)
    assert scene.forward_clearance(better) > 0.003
    sel = scene.select()
    assert sel.feasible
    chosen = float(np.hypot(*(sel.accel - desired)))
    # within tol and the slivers between sampled disks (selection._SLIVER_DEPTH a_max)
    slack = 1e-3 + selection._SLIVER_DEPTH * 4.7
    assert chosen <= float(np.hypot(*(better - desired))) + slack, (sel, chosen)


# ------------------------------------------------------------------ 8. desired kept


@SETTINGS
@given(scenes(n_max=6))
def test_admissible_desired_is_returned_unchanged(scene: Scene) -> None:
    """A desired acceleration inside the limits with clearance >= margin is kept as is."""
    d = scene.desired
    if not in_limits(d, scene.limits) or float(np.hypot(*d)) > scene.limits.a_max * (1 - 1e-9):
        return
    if scene.forward_clearance(d) < scene.margin + 1e-9:
        return
    sel = scene.select()
    assert sel.status == "desired"
    assert np.array_equal(sel.accel, d)


@given(vec(2.0), vec(6.0), floats(0.1, 5.0), st.booleans())
@settings(max_examples=20, deadline=None)
def test_no_obstacles_keeps_desired(v, desired, a_max, far) -> None:
    """Without (reachable) obstacles the desired acceleration, projected on the limits,
    is returned."""
    times = np.linspace(0.0, 2.0, 5)
    if far:  # one obstacle no acceleration within the limits can reach
        centers = np.broadcast_to(np.array([1e4, 0.0]), (1, 5, 2))
        radius = np.array([1.0])
    else:
        centers = np.zeros((0, 5, 2))
        radius = np.zeros(0)
    limits = AccelLimits(a_max)
    sel = select_acceleration(desired, v, sampled_path(times, centers, radius), limits)
    assert sel.status == "desired"
    norm = float(np.hypot(*desired))
    expect = desired if norm <= a_max else desired * (a_max / norm)
    np.testing.assert_allclose(sel.accel, expect, rtol=1e-12, atol=1e-12)
    if norm <= a_max:
        assert np.array_equal(sel.accel, desired)


# ------------------------------------------------------------------ 9. infeasible


def closing_ring(
    n: int = 12, start: float = 2.0, speed: float = 1.5, radius: float = 0.6, horizon: float = 2.0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    times = np.linspace(0.0, horizon, 9)
    ang = 2 * np.pi * np.arange(n) / n
    dirs = np.stack([np.cos(ang), np.sin(ang)], 1)
    dist = np.maximum(start - speed * times, 0.0)
    centers = dirs[:, None, :] * dist[None, :, None]
    return times, centers, np.full(n, radius)


def assert_maximises_first_contact(sel, v, times, centers, radius, a_max, v_max, seed=0):
    """The chosen first contact is within 1 % of the horizon of the best of 200 random
    accelerations in the limit disc."""
    rng = np.random.default_rng(seed)
    r = a_max * np.sqrt(rng.random(200))
    ang = rng.uniform(0, 2 * np.pi, 200)
    sample = np.stack([r * np.cos(ang), r * np.sin(ang)], 1)
    tfc = nao_query(sample, v, times, centers, radius, v_max=v_max).time_of_first_contact
    best = float(np.max(np.min(tfc.reshape(len(sample), -1), axis=1)))
    assert sel.time_of_first_contact >= best - 1e-2 * times[-1], (
        f"chosen first contact {sel.time_of_first_contact:.4f} s, a random limit-disc "
        f"acceleration reaches {best:.4f} s"
    )


@pytest.mark.parametrize("v", [(0.0, 0.0), (0.8, -0.3)])
@pytest.mark.parametrize("v_max", [math.inf, 1.0])
def test_boxed_in_is_infeasible_and_postpones_contact(v, v_max) -> None:
    """Obstacles closing in from all sides: infeasible, in limits, latest first contact."""
    times, centers, radius = closing_ring()
    a_max = 1.0
    v = np.asarray(v)
    sel = select_acceleration(
        (0.3, 0.2), v, sampled_path(times, centers, radius), AccelLimits(a_max), v_max=v_max
    )
    assert sel.status == "infeasible" and not sel.feasible
    assert np.all(np.isfinite(sel.accel)) and in_limits(sel.accel, AccelLimits(a_max))
    # reported first contact is the real one
    scene = Scene(v, np.zeros(2), AccelLimits(a_max), 0.0, v_max, times, centers, radius)
    fwd = scene.forward_first_contact(sel.accel)
    assert math.isclose(sel.time_of_first_contact, fwd, rel_tol=1e-6, abs_tol=1e-9)
    assert_maximises_first_contact(sel, v, times, centers, radius, a_max, v_max)


def test_overlapping_obstacle_is_infeasible() -> None:
    times = np.linspace(0.0, 2.0, 5)
    centers = np.broadcast_to(np.array([0.2, 0.1]), (1, 5, 2))
    sel = select_acceleration(
        (1.0, 0.0), (0.5, 0.0), sampled_path(times, centers, [1.0]), AccelLimits(2.0)
    )
    assert sel.status == "infeasible"
    assert np.all(np.isfinite(sel.accel)) and in_limits(sel.accel, AccelLimits(2.0))
    assert sel.time_of_first_contact == 0.0
    assert sel.clearance is not None and sel.clearance < 0


def test_missed_feasible_pocket_minimal_reproduction() -> None:
    """BUG: "infeasible" although an admissible acceleration exists.

    16 obstacles (r = 0.78) on a ring of radius 2.96 closing in at 0.99 m/s (times
    linspace(0, 2, 9)), v = (0.71, 0.31), desired (0.84, 1.81), a_max = 1.58: the
    selection returns "infeasible" (-1.446, -0.636) with first contact 1.53 s, while
    a = (-0.70, -0.32) keeps forward-simulated clearance +0.172 over the horizon (a
    small admissible pocket, ~0.4 % of the disc, which the 8 x 16 ring candidates miss).
    """
    times, centers, radii = closing_ring(16, 2.96, 0.99, 0.78)
    v, d, limits = np.array([0.71, 0.31]), np.array([0.84, 1.81]), AccelLimits(1.58)
    scene = Scene(v, d, limits, 0.0, math.inf, times, centers, radii)
    pocket = np.array([-0.70, -0.32])
    assert in_limits(pocket, limits) and scene.forward_clearance(pocket) > 0.17
    sel = scene.select()
    assert sel.feasible, f"reported {sel.status} at {sel.accel.tolist()}"
    assert scene.forward_clearance(sel.accel) >= -CLEAR_SLACK


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.integers(6, 16),
    floats(1.5, 3.0),
    floats(0.8, 2.5),
    floats(0.4, 0.8),
    floats(0.3, 2.0),
    vec(1.0),
    vec(2.0),
)
def test_random_closing_rings_maximise_first_contact(n, start, speed, radius, a_max, v, d):
    """Measured (150 random rings, seed 3, 2000 random disc samples): among infeasible
    results the shortfall of the chosen first contact behind the best sample is, as a
    fraction of the horizon, median 0.13 %, 75 % 1.6 %, 90 % 6.7 %, max 17.9 %; > 1 %
    in 32 % of the scenes; in 2 of 145 the samples contained an admissible
    acceleration (see test_missed_feasible_pocket_minimal_reproduction). So this test
    can fail on a new random example (BUG: the ring candidates do not maximise the
    first contact; deterministic reproduction below).
    """
    times, centers, radii = closing_ring(n, start, speed, radius)
    limits = AccelLimits(a_max)
    sel = select_acceleration(d, v, sampled_path(times, centers, radii), limits)
    assert np.all(np.isfinite(sel.accel)) and in_limits(sel.accel, limits)
    if sel.feasible:
        scene = Scene(v, d, limits, 0.0, math.inf, times, centers, radii)
        assert scene.forward_clearance(sel.accel) >= -CLEAR_SLACK
    else:
        assert_maximises_first_contact(sel, v, times, centers, radii, a_max, math.inf)


def test_first_contact_not_maximised_minimal_reproduction() -> None:
    """BUG: 11 obstacles (r = 0.71) on a ring of radius 2.46 closing at 1.17 m/s, v =
    (0.69, -0.09), desired (1.43, 0.27), a_max = 1.97: "infeasible" with first contact
    1.114 s, while a = (-0.96, 0.14) first touches an obstacle only at 1.47 s (18 % of
    the 2 s horizon later)."""
    times, centers, radii = closing_ring(11, 2.46, 1.17, 0.71)
    v, d, limits = np.array([0.69, -0.09]), np.array([1.43, 0.27]), AccelLimits(1.97)
    scene = Scene(v, d, limits, 0.0, math.inf, times, centers, radii)
    later = np.array([-0.96, 0.14])
    t_later = scene.forward_first_contact(later)
    assert in_limits(later, limits) and t_later > 1.46
    sel = scene.select()
    assert not sel.feasible
    assert sel.time_of_first_contact >= t_later - 1e-2 * times[-1], sel


# ------------------------------------------------------------------ 10. degenerate input


DEGENERATE = {
    "nan desired": dict(desired=(np.nan, 1.0)),
    "inf desired": dict(desired=(np.inf, -np.inf)),
    "nan velocity": dict(v=(np.nan, 0.0)),
    "zero velocity": dict(v=(0.0, 0.0)),
    "zero a_max": dict(limits=AccelLimits(0.0)),
    "tiny horizon": dict(times=np.array([0.0, 1e-12])),
    "single sample at t = 0": dict(times=np.array([0.0])),
    "obstacle at the robot": dict(centers=np.zeros((3, 4, 2))),
    # BUG: ZeroDivisionError in kernel.nao_disks (t^2 underflows to 0)
    "horizon 1e-170, obstacle at the robot": dict(
        times=np.array([0.0, 1e-170]), centers=np.zeros((1, 2, 2))
    ),
    "first sample at 5e-324, obstacle at the robot": dict(
        times=np.array([5e-324, 1.0]), centers=np.zeros((1, 2, 2))
    ),
    "zero radius at the robot": dict(centers=np.zeros((1, 4, 2)), radius=np.zeros(1)),
    "zero v_max": dict(v_max=0.0),
    "huge margin": dict(margin=1e6),
}


@pytest.mark.parametrize("name", list(DEGENERATE))
def test_degenerate_input_never_nan_never_raises(name: str) -> None:
    kw = dict(
        desired=(1.0, 0.5),
        v=(0.5, 0.0),
        limits=AccelLimits(2.0),
        times=np.linspace(0.0, 2.0, 4),
        centers=np.array([[[2.0, 0.0]] * 4]),
        radius=None,
        v_max=math.inf,
        margin=0.0,
    )
    kw.update(DEGENERATE[name])
    n, t = kw["centers"].shape[0], len(kw["times"])
    centers = np.ascontiguousarray(np.broadcast_to(kw["centers"][:, :1], (n, t, 2)))
    radius = kw["radius"] if kw["radius"] is not None else np.full(n, 0.5)
    limits = kw["limits"]
    sel = select_acceleration(
        kw["desired"],
        kw["v"],
        sampled_path(kw["times"], centers, radius),
        limits,
        margin=kw["margin"],
        v_max=kw["v_max"],
    )
    a = np.asarray(sel.accel)
    assert a.shape == (2,) and np.all(np.isfinite(a)), sel
    assert in_limits(a, limits)
    assert sel.status in {"desired", "adjusted", "infeasible"}
    assert sel.clearance is None or not math.isnan(sel.clearance)
    assert not math.isnan(sel.time_of_first_contact)


@example(desired=np.array([np.nan, np.nan]), a_max=0.0)
@given(st.tuples(st.floats(), st.floats()).map(np.array), floats(0.0, 3.0))
@settings(max_examples=30, deadline=None)
def test_arbitrary_desired_values(desired, a_max) -> None:
    times, centers, radius = closing_ring(6, 2.0, 0.5, 0.5)
    limits = AccelLimits(a_max)
    sel = select_acceleration(desired, (0.3, 0.0), sampled_path(times, centers, radius), limits)
    assert np.all(np.isfinite(sel.accel)) and in_limits(sel.accel, limits)


def test_fallback_when_nothing_is_admissible() -> None:
    """Obstacles all around a robot driving at 2 m/s towards them (0.6 m away; braking
    at a_max = 2 m/s^2 takes 1 m): nothing is admissible, the caller's fallback is
    returned (projected onto the limits) with status "infeasible"; its clearance and
    contact time are reported only when asked for."""
    times = np.linspace(0.0, 2.0, 21)
    ring = 1.5 * np.stack(
        [np.cos(np.arange(12) * np.pi / 6), np.sin(np.arange(12) * np.pi / 6)], axis=1
    )
    path = sampled_path(times, np.repeat(ring[:, None, :], len(times), 1), np.full(12, 0.9))
    limits = AccelLimits(2.0)
    quick = select_acceleration(
        (1.0, 0.0), (2.0, 0.0), path, limits, with_clearance=False, fallback=(-5.0, 0.0)
    )
    assert quick.status == "infeasible" and quick.clearance is None
    np.testing.assert_array_equal(quick.accel, (-2.0, 0.0))
    full = select_acceleration((1.0, 0.0), (2.0, 0.0), path, limits, fallback=(-5.0, 0.0))
    assert full.status == "infeasible" and full.clearance < 0.0
    assert full.time_of_first_contact < 2.0
    np.testing.assert_array_equal(full.accel, quick.accel)


@settings(max_examples=300, deadline=None)
@given(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.floats(0.0, 10.0),
)
@example(2.225073858507e-311, 2.225073858507e-311, 2.225073858507e-311)  # subnormal norm
def test_projecting_one_acceleration_is_projecting_a_row_of_them(x, y, a_max):
    """project((2,)) takes a scalar shortcut on the disc: bit for bit the batch result
    (non-finite components become 0, the result lies in the disc)."""
    limits = AccelLimits(a_max)
    one = limits.project(np.array([x, y]))
    row = limits.project(np.array([[x, y]]))[0]
    assert one.shape == (2,)
    assert np.array_equal(one, row) and np.array_equal(np.signbit(one), np.signbit(row))
    assert np.all(np.isfinite(one)) and math.hypot(*one) <= a_max * (1 + 1e-12)
