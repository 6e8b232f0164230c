"""The robot's own path under constant acceleration, as the world drives it.

Frame: the robot starts at the origin at t = 0 with velocity v (m/s). Path:
x(t) = v t + a t^2 / 2 until the speed |v + a t| reaches v_max (time tau, see
:mod:`nao_arena.motion`), then constant velocity. A robot already above
v_max starts from its velocity scaled down to v_max
(:func:`~nao_arena.motion.limit_norm_sqrt`).
"""

from __future__ import annotations

import math

from nao_arena.jit import inner_kernel
from nao_arena.motion import limit_norm_sqrt, saturation_time

__all__ = ["candidate_setup", "robot_state"]


@inner_kernel(error_model="numpy")
def robot_state(vx, vy, ax, ay, tau, ta):
    """Robot (acceleration, velocity, position) at time ta under the saturation model."""
    if ta < tau:
        return (
            ax,
            ay,
            vx + ax * ta,
            vy + ay * ta,
            vx * ta + 0.5 * ax * ta * ta,
            vy * ta + 0.5 * ay * ta * ta,
        )
    wx = vx + ax * tau
    wy = vy + ay * tau
    return (
        0.0,
        0.0,
        wx,
        wy,
        vx * tau + 0.5 * ax * tau * tau + wx * (ta - tau),
        vy * tau + 0.5 * ay * tau * tau + wy * (ta - tau),
    )


@inner_kernel(error_model="numpy")
def candidate_setup(vx, vy, ax, ay, v_max, horizon):
    """Speed-clamped initial velocity, saturation time and a bound on the speed (m/s)."""
    vx, vy, spd = limit_norm_sqrt(vx, vy, v_max)
    if spd > v_max:
        spd = v_max
    tau = saturation_time(vx, vy, ax, ay, v_max)
    amag = math.sqrt(ax * ax + ay * ay)
    # |v + a t| is convex in t, so up to tau it stays below max(|v|, v_max) = v_max
    bound = min(spd + amag * min(tau, horizon), v_max * (1.0 + 1e-9))
    return vx, vy, tau, bound
