"""The motion rules (:mod:`nao_arena.motion`): each compiled function gives the bits of the
arithmetic it replaced in its callers (written out here with numpy's scalars, whose hypot
is the C library's, as the compiled one is), and each numpy twin the compiled function's
bits row by row."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.geometry import AccelLimits
from nao_arena.motion import (
    SMALLEST_NORMAL,
    brake_factor,
    braking,
    clip_accelerations,
    clip_norm,
    limit_norm,
    limit_norm_sqrt,
    limit_norms,
    onto_disc,
    project_onto_disc,
)

finite = st.one_of(
    st.floats(-10.0, 10.0),
    st.sampled_from([0.0, -0.0, 1e-310, -1e-200, 1e-160, 3e200, -1e308]),
    st.floats(allow_nan=False, allow_infinity=False),
)
anything = st.one_of(finite, st.sampled_from([math.inf, -math.inf, math.nan]))
limits = st.one_of(
    st.floats(0.0, 10.0), st.sampled_from([0.0, 1e-310, 1e-301, 1e-5, 1e300, math.inf])
)


def same(a: float, b: float) -> bool:
    """The same float64 bits (any NaN equal to any NaN)."""
    a, b = float(a), float(b)
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return np.array([a]).view(np.int64)[0] == np.array([b]).view(np.int64)[0]


def same_all(got, want) -> bool:
    return len(got) == len(want) and all(same(g, w) for g, w in zip(got, want, strict=True))


def _hypot(x: float, y: float) -> np.float64:
    with np.errstate(all="ignore"):
        return np.hypot(np.float64(x), np.float64(y))


@settings(max_examples=400, deadline=None)
@given(finite, finite, limits)
def test_clip_norm_is_the_worlds_clip_and_its_rows(x, y, limit) -> None:
    """The world's and the stopping plans' arithmetic (World.step, applied_plans,
    _fill_plan, the lane followers); clip_accelerations row by row (finite rows)."""
    with np.errstate(all="ignore"):
        scale = min(1.0, np.float64(limit) / max(_hypot(x, y), 1e-300))
        want = (x * scale, y * scale)
        rows = clip_accelerations(np.array([[x, y], [y, x]]), np.array([limit, limit]))
    assert same_all(clip_norm(x, y, limit), want)
    assert same_all(rows[0], want)
    assert same_all(rows[1], clip_norm(y, x, limit))


@settings(max_examples=400, deadline=None)
@given(anything, anything, limits)
def test_limit_norm_scales_only_above_the_limit(x, y, limit) -> None:
    """The speed limit of the world and the stopping plans, the goal, ORCA and VO agents'
    tracking accelerations; limit_norms row by row, non-finite rows included."""
    with np.errstate(all="ignore"):
        norm = _hypot(x, y)
        want = (x, y)
        if norm > limit:
            f = np.float64(limit) / norm
            want = (x * f, y * f)
        rows = limit_norms(np.array([[[x, y]], [[y, x]]]), np.array([limit]))
    got = limit_norm(x, y, limit)
    assert same_all(got, (*want, norm))
    assert same_all(rows[0, 0], want)
    assert same_all(rows[1, 0], limit_norm(y, x, limit)[:2])


@settings(max_examples=400, deadline=None)
@given(anything, anything, limits)
def test_limit_norm_sqrt_is_the_planners_speed_limit(x, y, limit) -> None:
    """candidate_setup, relevance pruning and the CBF agent: |v| as sqrt(x^2 + y^2)."""
    with np.errstate(all="ignore"):
        norm = np.sqrt(np.float64(x) * x + np.float64(y) * y)
        want = (x, y)
        if norm > limit:
            want = (x * (np.float64(limit) / norm), y * (np.float64(limit) / norm))
    assert same_all(limit_norm_sqrt(x, y, limit), (*want, norm))


@settings(max_examples=400, deadline=None)
@given(anything, anything, limits)
def test_onto_disc_is_the_compiled_selections_projection(x, y, limit) -> None:
    with np.errstate(all="ignore"):
        norm = _hypot(x, y)
        scale = np.float64(limit) / max(norm, 1e-300) if norm > limit else 1.0
        want = (x * scale, y * scale)
    assert same_all(onto_disc(x, y, limit), want)


@settings(max_examples=400, deadline=None)
@given(anything, anything, st.one_of(st.floats(0.0, 10.0), st.sampled_from([0.0, 1e-5, 1e-300])))
def test_project_onto_disc_is_accel_limits_project(x, y, limit) -> None:
    """AccelLimits.project on the disc: one acceleration (the compiled function) and many
    (numpy) give the same bits, the subnormal-scale branch included."""
    limits_ = AccelLimits(limit)
    got = project_onto_disc(x, y, limit)
    assert same_all(limits_.project(np.array([x, y])), got)
    rows = limits_.project(np.array([[x, y], [y, x], [0.0, 0.0]]))
    assert same_all(rows[0], got)
    assert same_all(rows[1], project_onto_disc(y, x, limit))
    # the arithmetic project had on one acceleration, and apply_braking (its inputs never
    # reach the subnormal branch)
    cx = np.float64(x) if math.isfinite(x) else np.float64(0.0)
    cy = np.float64(y) if math.isfinite(y) else np.float64(0.0)
    norm = _hypot(cx, cy)
    if norm <= limit:
        assert same_all(got, (cx, cy))
        return
    scale = limit / norm
    if scale < SMALLEST_NORMAL:
        assert same_all(got, (cx / norm * limit, cy / norm * limit))
    else:
        assert same_all(got, (cx * scale, cy * scale))


def test_project_onto_disc_normalises_first_where_the_scale_is_subnormal() -> None:
    x, y = project_onto_disc(1e308, 0.0, 1e-5)
    assert x == 1e-5 and y == 0.0


@settings(max_examples=400, deadline=None)
@given(finite, finite, st.floats(0.0, 10.0), st.sampled_from([0.01, 0.05, 0.1, 0.25]))
def test_braking_is_each_callers_braking(vx, vy, a_max, dt) -> None:
    """The stopping plans' -b v, apply_braking's v f (f = -min(a_max, |v| / dt) / |v|) and
    the agent's fallback: the same bits."""
    speed = _hypot(vx, vy)
    got = braking(vx, vy, a_max, dt)
    if speed == 0.0:
        assert same_all(got, (0.0, 0.0))
        return
    with np.errstate(all="ignore"):
        b = min(np.float64(a_max), speed / dt) / speed
        f = -min(np.float64(a_max), speed / dt) / speed
        assert same(brake_factor(float(speed), a_max, dt), b)
        assert same_all(got, (-b * vx, -b * vy))
        assert same_all(got, (vx * f, vy * f))
        assert same_all(got, np.array([vx, vy]) * f)
