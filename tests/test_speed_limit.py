"""The speed-limit model (:mod:`nao_arena.motion`): one saturation time for the world
and the planner's kernels."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.geometry._kernel.exact import candidate_setup
from nao_arena.motion import saturation_time, speed_limit_time

finite = st.floats(-5.0, 5.0, allow_nan=False).filter(lambda x: abs(x) > 1e-6 or x == 0.0)


@st.composite
def motions(draw: st.DrawFn) -> tuple[float, float, float, float, float]:
    """(vx, vy, ax, ay, v_max) with |v| <= v_max, often exactly on the limit or a = 0."""
    v_max = draw(st.floats(0.1, 3.0))
    angle = draw(st.floats(0.0, 2.0 * math.pi))
    speed = draw(st.sampled_from([0.0, 1.0, 1.0, draw(st.floats(0.0, 1.0))])) * v_max
    vx, vy = speed * math.cos(angle), speed * math.sin(angle)
    v_max = max(v_max, math.sqrt(vx * vx + vy * vy))  # on the limit after rounding
    ax, ay = draw(st.sampled_from([(0.0, 0.0), (draw(finite), draw(finite))]))
    return vx, vy, ax, ay, v_max


@settings(max_examples=300, deadline=None)
@given(motions())
def test_planner_and_world_share_the_saturation_time_bit_for_bit(m) -> None:
    """The kernels' own-path model (candidate_setup) and the world's speed_limit_time give
    the same tau, down to the sign of a zero (at |v| = v_max they used to differ)."""
    vx, vy, ax, ay, v_max = m
    tau_plan = candidate_setup(vx, vy, ax, ay, v_max, 10.0)[2]
    tau_world = speed_limit_time([[vx, vy]], [[ax, ay]], [v_max])[0]
    assert np.array([tau_plan]).view(np.int64)[0] == np.array([tau_world]).view(np.int64)[0]


@settings(max_examples=300, deadline=None)
@given(motions())
def test_saturation_time_is_when_the_speed_reaches_v_max(m) -> None:
    vx, vy, ax, ay, v_max = m
    tau = saturation_time(vx, vy, ax, ay, v_max)
    if ax * ax + ay * ay == 0.0:  # no acceleration (or one too small to square)
        assert tau == math.inf
        return
    assert tau >= 0.0
    speed = math.hypot(vx + ax * tau, vy + ay * tau)
    assert speed == pytest.approx(v_max, rel=1e-9, abs=1e-9)
    # before tau the speed stays below v_max (|v + a t| is convex in t)
    half = math.hypot(vx + ax * tau / 2, vy + ay * tau / 2)
    assert half <= v_max * (1 + 1e-9)


def test_no_speed_limit_means_never_saturating() -> None:
    assert saturation_time(1.0, 0.0, 1.0, 0.0, math.inf) == math.inf


def test_the_world_steps_with_the_shared_model() -> None:
    """World.step and the planner use the one compiled saturation_time."""
    from nao_arena import world

    assert world.speed_limit_time is speed_limit_time
    assert "saturation_time" in world._plan_period.py_func.__code__.co_names


def test_speed_limit_time_rejects_bad_shapes() -> None:
    with pytest.raises(ValueError, match=r"shape \(N, 2\)"):
        speed_limit_time(np.zeros((3, 3)), np.zeros((3, 3)), 1.0)
