"""Predictors against the motions they model, integrated independently."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.predictors import (
    PREDICTORS,
    constant_acceleration,
    get_predictor,
    known_path,
    shared_plan,
    turn_rate,
)
from nao_arena.sensing import Neighbours

TIMES = np.linspace(0.0, 4.0, 41)


def one(p, v, a, **extra) -> Neighbours:
    return Neighbours(
        ids=np.array([0]),
        kinds=("traffic",),
        positions=np.array([p], float),
        velocities=np.array([v], float),
        accelerations=np.array([a], float),
        radii=np.array([1.0]),
        **extra,
    )


def euler_arc(p, v, a, times, steps=200_000):
    """Fine explicit integration of constant turn rate + tangential acceleration."""
    speed = np.hypot(*v)
    omega = (v[0] * a[1] - v[1] * a[0]) / speed**2
    a_t = (v @ a) / speed
    dt = times[-1] / steps
    pos = np.array(p, float)
    heading = np.arctan2(v[1], v[0])
    out, k = [], 0
    for i in range(steps + 1):
        t = i * dt
        while k < len(times) and times[k] <= t + 1e-12:
            out.append(pos.copy())
            k += 1
        s = max(speed + a_t * (t + 0.5 * dt), 0.0)
        h = heading + omega * (t + 0.5 * dt)
        pos = pos + s * dt * np.array([np.cos(h), np.sin(h)])
    return np.array(out)


@settings(max_examples=15, deadline=None)
@given(
    radius=st.floats(5.0, 50.0),
    speed=st.floats(1.0, 10.0),
    ccw=st.booleans(),
    phase=st.floats(0.0, 6.28),
)
def test_turn_rate_follows_a_circular_lane(radius, speed, ccw, phase):
    sgn = 1.0 if ccw else -1.0
    p = radius * np.array([np.cos(phase), np.sin(phase)])
    v = sgn * speed * np.array([-np.sin(phase), np.cos(phase)])
    a = -(speed**2 / radius) * p / radius
    pred = turn_rate(TIMES, one(p, v, a))[0]
    ang = phase + sgn * speed / radius * TIMES
    truth = radius * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    assert np.max(np.hypot(*(pred - truth).T)) < 1e-3 * radius


def test_turn_rate_with_braking_matches_fine_integration():
    p, v, a = np.array([1.0, 2.0]), np.array([4.0, 1.0]), np.array([-1.0, 0.8])
    pred = turn_rate(TIMES, one(p, v, a))[0]
    truth = euler_arc(p, v, a, TIMES)
    assert np.max(np.hypot(*(pred - truth).T)) < 1e-3


def test_known_path_uses_the_true_path_and_falls_back():
    truth = np.stack([np.linspace(0, 10, 11), np.zeros(11)], axis=1)[None]
    path_times = np.linspace(0.0, 5.0, 11)
    nb = one((0, 0), (1, 0), (0, 0), path_times=path_times, known_paths=truth)
    pred = known_path(TIMES, nb)[0]
    expected = np.stack([2.0 * TIMES, np.zeros_like(TIMES)], axis=1)
    np.testing.assert_allclose(pred, expected, atol=1e-12)
    unknown = one(
        (0, 0), (1, 0), (0, 0), path_times=path_times, known_paths=np.full_like(truth, np.nan)
    )
    np.testing.assert_allclose(
        known_path(TIMES, unknown)[0], np.stack([TIMES, 0 * TIMES], 1), atol=1e-9
    )


def test_shared_plan_uses_committed_acceleration():
    nb = one((0, 0), (1, 0), (5, 5), plans=np.array([[0.0, 2.0]]))
    pred = shared_plan(TIMES, nb)[0]
    np.testing.assert_allclose(pred[:, 1], TIMES**2, atol=1e-12)
    np.testing.assert_allclose(pred[:, 0], TIMES, atol=1e-12)


def test_every_predictor_handles_no_neighbours_and_standing_still():
    empty = Neighbours()
    still = one((3, 4), (0, 0), (0, 0))
    for name, fn in PREDICTORS.items():
        assert fn(TIMES, empty).shape == (0, len(TIMES), 2), name
        out = fn(TIMES, still)
        assert np.all(np.isfinite(out)), name
        np.testing.assert_allclose(out[0], np.tile([3.0, 4.0], (len(TIMES), 1)), atol=1e-12)


def test_turn_rate_keeps_a_neighbour_that_braked_to_rest_at_rest():
    # observed at rest after braking from (1, 0) m/s within the last period: a = (-10, 0)
    braked = one((3, 4), (0, 0), (-10, 0))
    np.testing.assert_array_equal(turn_rate(TIMES, braked)[0], np.tile([3.0, 4.0], (len(TIMES), 1)))
    # the AO's model extrapolates the braking into reversing
    assert constant_acceleration(TIMES, braked)[0, -1, 0] < 3.0 - 1.0


def test_unknown_predictor_names_the_choices():
    with pytest.raises(ValueError, match="turn_rate"):
        get_predictor("psychic")
