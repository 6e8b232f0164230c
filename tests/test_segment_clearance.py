"""Exact robot-path vs static segment distance (nao_arena.geometry._kernel.segment),
checked against forward simulation: the robot's path sampled densely (tests/forward_sim.py's
Robot, written from the model only) and plain numpy point-to-segment distances."""

from __future__ import annotations

import math

import numpy as np
import pytest
from forward_sim import Robot
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.geometry._kernel.segment import (
    segment_admissible,
    segment_min_distance,
    segments_admissible,
    segments_min_distance,
)
from nao_arena.geometry.clearance import ao_clearance
from nao_arena.geometry.walls import wall_discs

N_SAMPLES = 20000
TOL = 1e-9
CLAMP = 3e-8
"""A speed exactly at v_max after the clamp (rounded) can give a saturation time of order
sqrt(float eps) / |a| instead of 0, a velocity off by up to about sqrt(eps) v_max: the
bounds allow CLAMP * v_max * horizon (m) for it."""


def point_segment_distance(x: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distances (M,) m from the points x (M, 2) to the segment [p, q]."""
    u = q - p
    ll = float(u @ u)
    s = np.zeros(len(x)) if ll == 0.0 else np.clip((x - p) @ u / ll, 0.0, 1.0)
    return np.hypot(*(x - p - s[:, None] * u).T)


def simulated(v, a, v_max, p, q, horizon):
    """(sampled minimum distance m, bound on its excess over the true minimum m): the path
    at N_SAMPLES times over [0, horizon] plus the saturation time; every time lies within
    dt / 2 of a sample and the robot moves at most speed * dt / 2 in between."""
    robot = Robot.make(v, a, v_max)
    t = np.linspace(0.0, horizon, N_SAMPLES)
    if 0.0 < robot.tau < horizon:
        t = np.sort(np.append(t, robot.tau))
    d = point_segment_distance(robot.position(t), np.asarray(p, float), np.asarray(q, float))
    speed = max(
        float(np.hypot(*robot.v)), float(np.hypot(*(robot.v + robot.a * min(robot.tau, horizon))))
    )
    return float(d.min()), speed * horizon / (N_SAMPLES - 1) / 2.0


def kernel(v, a, v_max, p, q, horizon):
    return segment_min_distance(v[0], v[1], a[0], a[1], v_max, p[0], p[1], q[0], q[1], horizon)


def assert_matches_simulation(v, a, v_max, p, q, horizon):
    d = kernel(v, a, v_max, p, q, horizon)
    sampled, err = simulated(v, a, v_max, p, q, horizon)
    tol = TOL + CLAMP * v_max * horizon
    assert d <= sampled + tol, (d, sampled)
    assert d >= sampled - err - tol, (d, sampled, err)
    return d


coord = st.floats(-4.0, 4.0, allow_nan=False)


@settings(deadline=None, max_examples=200)
@given(
    vx=st.floats(-2.0, 2.0),
    vy=st.floats(-2.0, 2.0),
    ax=st.floats(-3.0, 3.0),
    ay=st.floats(-3.0, 3.0),
    v_max=st.floats(0.2, 2.5),
    px=coord,
    py=coord,
    angle=st.floats(0.0, 2.0 * math.pi),
    length=st.floats(0.0, 4.0),
    horizon=st.floats(0.05, 5.0),
)
def test_min_distance_matches_forward_simulation(
    vx, vy, ax, ay, v_max, px, py, angle, length, horizon
):
    """Kernel minimum within [sampled min - sampling error, sampled min] for random paths
    (saturating or not, starting above v_max or not) and segments (including points)."""
    p = (px, py)
    q = (px + length * math.cos(angle), py + length * math.sin(angle))
    assert_matches_simulation((vx, vy), (ax, ay), v_max, p, q, horizon)


@settings(deadline=None, max_examples=200)
@given(
    vx=st.floats(-1.0, 1.0),
    vy=st.floats(-1.0, 1.0),
    ax=st.floats(-2.0, 2.0),
    ay=st.floats(-2.0, 2.0),
    px=st.floats(-1.5, 1.5),
    py=st.floats(-1.5, 1.5),
    qx=st.floats(-1.5, 1.5),
    qy=st.floats(-1.5, 1.5),
)
def test_min_distance_near_walls(vx, vy, ax, ay, px, py, qx, qy):
    """Segments close to the start (often crossed or touched): same bounds."""
    assert_matches_simulation((vx, vy), (ax, ay), 1.2, (px, py), (qx, qy), 2.0)


def test_grazing_straight():
    """A straight path parallel to a wall at distance r: minimum exactly r, so a robot of
    radius r is not admissible (the test is strict) and one just smaller is."""
    r = 0.35
    d = assert_matches_simulation((1.0, 0.0), (0.0, 0.0), 2.0, (1.0, r), (3.0, r), 3.0)
    assert d == pytest.approx(r, abs=1e-14)
    v, a = np.array([1.0, 0.0]), np.zeros(2)
    p, q = np.array([1.0, r]), np.array([3.0, r])
    assert not segment_admissible(v, a, 2.0, p, q, 0.0, r, 0.0, 3.0)
    assert segment_admissible(v, a, 2.0, p, q, 0.0, r - 1e-9, 0.0, 3.0)


def test_grazing_parabola():
    """The parabola y = 0.5 t - 0.25 t^2 peaks at 0.25 (t = 1, x = 1) under a wall at
    y = 0.25 + r: the minimum is r at that one instant, found exactly (sampling misses it)."""
    r = 0.3
    d = assert_matches_simulation(
        (1.0, 0.5), (0.0, -0.5), 5.0, (0.0, 0.25 + r), (2.0, 0.25 + r), 3.0
    )
    assert d == pytest.approx(r, abs=1e-12)


def test_end_cap():
    """Driving past the lower end of a wall across the path's side: the closest point is
    the end p, 0.5 m away at t = 2."""
    d = assert_matches_simulation((1.0, 0.0), (0.0, 0.0), 2.0, (2.0, 0.5), (2.0, 3.0), 4.0)
    assert d == pytest.approx(0.5, abs=1e-14)


def test_end_cap_on_parabola():
    """A curving path whose closest approach is to an end (not the interior)."""
    d = assert_matches_simulation((1.0, 0.0), (0.0, 0.6), 3.0, (1.5, 0.2), (3.0, -1.0), 3.0)
    assert d > 0.0


def test_already_touching():
    """The robot starts on the wall: 0, whatever it does next."""
    for a in ((0.0, 0.0), (0.0, -2.0), (1.0, 1.0)):
        assert kernel((0.0, 1.0), a, 1.0, (-1.0, 0.0), (1.0, 0.0), 2.0) == 0.0
    assert kernel((0.0, 0.0), (0.0, 0.0), 1.0, (0.0, 0.0), (0.0, 0.0), 1.0) == 0.0


def test_parallel_motion():
    """Moving along a wall (constant and accelerating, saturating): the distance stays 0.7."""
    for a, v_max in (((0.0, 0.0), 2.0), ((1.0, 0.0), 1.5)):
        d = assert_matches_simulation((1.0, 0.0), a, v_max, (-1.0, 0.7), (8.0, 0.7), 3.0)
        assert d == pytest.approx(0.7, abs=1e-14)


def test_motion_along_the_line_toward_an_end():
    """On the wall's own line toward its end p = (2, 0): 1 m short at T = 1, on it by T = 3."""
    assert kernel((1.0, 0.0), (0.0, 0.0), 2.0, (2.0, 0.0), (4.0, 0.0), 1.0) == pytest.approx(1.0)
    assert kernel((1.0, 0.0), (0.0, 0.0), 2.0, (2.0, 0.0), (4.0, 0.0), 3.0) == 0.0
    assert_matches_simulation((1.0, 0.0), (0.5, 0.0), 2.0, (4.0, 0.0), (2.0, 0.0), 1.5)


def test_zero_length_segment_is_a_point():
    """p == q: the distance to that point (1 m at t = 2), as for a static disc centre."""
    d = assert_matches_simulation((1.0, 0.0), (0.0, 0.0), 2.0, (2.0, 1.0), (2.0, 1.0), 4.0)
    assert d == pytest.approx(1.0, abs=1e-14)
    d = assert_matches_simulation((0.5, 0.2), (0.3, -0.4), 1.0, (1.0, -0.5), (1.0, -0.5), 4.0)
    c = ao_clearance(np.array([[0.3, -0.4]]), (0.5, 0.2), (1.0, -0.5), 0.0, horizon=4.0, v_max=1.0)
    assert d == pytest.approx(float(c.clearance[0]), abs=1e-12)


def test_saturating_mid_horizon():
    """v = 0.5, a = 1, v_max = 1: saturates at 0.5 s, reaches x = 1.875 at 2 s, so a wall at
    x = 2 is 0.125 away (an unsaturated path, x = 3, would cross it)."""
    d = assert_matches_simulation((0.5, 0.0), (1.0, 0.0), 1.0, (2.0, -1.0), (2.0, 1.0), 2.0)
    assert d == pytest.approx(0.125, abs=1e-14)


def test_already_above_v_max():
    """Starting at 3 m/s with v_max = 1: the path starts at 1 m/s, x(2) = 2, wall at 2.5."""
    d = assert_matches_simulation((3.0, 0.0), (0.0, 0.0), 1.0, (2.5, -1.0), (2.5, 1.0), 2.0)
    assert d == pytest.approx(0.5, abs=1e-14)
    assert_matches_simulation((2.0, 1.0), (-1.0, 0.5), 1.0, (1.5, -1.0), (0.5, 2.0), 3.0)


def test_zero_acceleration():
    """a = 0 (a_max = 0): a straight line forever (tau = inf); x(t) = (t, t) passes the end
    (2, 0) at sqrt(2) (t = 1), and the wall (1, -1)-(1, -3) at its end (1, -1): sqrt(2)."""
    d = assert_matches_simulation((1.0, 1.0), (0.0, 0.0), 2.0, (2.0, 0.0), (3.0, 0.0), 3.0)
    assert d == pytest.approx(math.sqrt(2.0), abs=1e-14)
    d = assert_matches_simulation((1.0, 1.0), (0.0, 0.0), 2.0, (1.0, -1.0), (1.0, -3.0), 3.0)
    assert d == pytest.approx(math.sqrt(2.0), abs=1e-14)


def test_batched_minimum_and_index():
    """The batched form: the minimum over walls of (distance - half_thickness), the index of
    that wall, and admissibility against all walls, agreeing with the scalar form."""
    rng = np.random.default_rng(3)
    walls = rng.uniform(-4.0, 4.0, (12, 2, 2))
    half = rng.uniform(0.0, 0.2, 12)
    for _ in range(20):
        v = rng.uniform(-1.0, 1.0, 2)
        a = rng.uniform(-2.0, 2.0, 2)
        each = np.array([kernel(v, a, 1.5, w[0], w[1], 3.0) for w in walls]) - half
        d, index = segments_min_distance(v, a, 1.5, walls, half, 3.0)
        assert d == each.min()
        assert index == int(np.argmin(each))
        for limit in (d - 1e-6, d + 1e-6):
            assert segments_admissible(v, a, 1.5, walls, half, limit, 0.0, 3.0) == (limit < d)
    d, index = segments_min_distance(
        np.zeros(2), np.zeros(2), 1.0, np.zeros((0, 2, 2)), np.zeros(0), 1.0
    )
    assert (d, index) == (math.inf, -1)


def test_exact_wall_admits_what_the_disc_chain_rejects():
    """A robot passing under a wall curves up to 0.4 m from it, more than radius +
    half_thickness = 0.35: forward simulation confirms it clears, the exact kernel admits the
    acceleration, while the disc chain the agents use (wall_discs grown by the radius, default
    slack) rejects it."""
    radius, half, horizon, v_max = 0.3, 0.05, 3.0, 2.0
    v = np.array([1.0, 0.5])
    a = np.array([0.0, -0.125 / 0.6])  # peak height 0.6 at t = 2.4
    p, q = np.array([-1.0, 1.0]), np.array([5.0, 1.0])
    sampled, err = simulated(v, a, v_max, p, q, horizon)
    assert sampled - err > radius + half
    assert kernel(v, a, v_max, p, q, horizon) == pytest.approx(0.4, abs=1e-12)
    assert segment_admissible(v, a, v_max, p, q, half, radius, 0.0, horizon)
    centres, radii = wall_discs(np.array([[p, q]]), np.array([half]), radius)
    chain = ao_clearance(a[None], v, centres, radii, horizon=horizon, v_max=v_max)
    assert chain.clearance.min() < 0.0
