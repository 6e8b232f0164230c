"""``goal``: drive to the goal with no avoidance at all (the lower bound)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.sensing import Observation

APPROACH_GAIN = 1.0  # 1/s: the target speed near the goal, per metre to go (see below)


def goal_target(obs: Observation) -> NDArray[np.float64] | None:
    """The point the robot heads for (m): its goal, else its route's last waypoint."""
    if obs.goal is not None:
        return obs.goal
    if obs.route is not None and len(obs.route):
        return obs.route[-1]
    return None


def goal_seeking_accel(
    obs: Observation, v_pref: float | None = None, time_constant: float = 0.5,
    braking: float = 0.5, heading_offset: float = 0.0, approach_gain: float = APPROACH_GAIN,
) -> NDArray[np.float64]:
    """Acceleration (m/s^2) that tracks a velocity toward the goal.

    Target velocity: towards the goal (turned by ``heading_offset`` rad,
    counter-clockwise positive) at min(v_pref, sqrt(2 b d + (b tau)^2) - b tau,
    k d) at distance d (m), with b = ``braking`` * a_max and tau =
    ``time_constant``: the speed from which the robot, lagging tau behind its
    target, stops at the goal braking at b; k = ``approach_gain`` (1/s): close
    to the goal the speed falls linearly with the distance (well damped:
    k tau = 1/2), so that the robot settles on the goal instead of overshooting
    or chattering around it. The acceleration closes the velocity error in
    tau s and is scaled to |a| <= a_max.
    """
    target = goal_target(obs)
    speed_cap = obs.v_max if v_pref is None else min(v_pref, obs.v_max)
    if target is None:
        v_target = np.zeros(2)
    else:
        to_goal = target - obs.position
        dist = float(np.hypot(*to_goal))
        if dist < 1e-9:
            v_target = np.zeros(2)
        else:
            lag = braking * obs.a_max * time_constant
            speed = min(speed_cap,
                        float(np.sqrt(2.0 * braking * obs.a_max * dist + lag * lag)) - lag,
                        approach_gain * dist)
            v_target = to_goal / dist * speed
            if heading_offset:
                c, s_ = np.cos(heading_offset), np.sin(heading_offset)
                v_target = np.array([c * v_target[0] - s_ * v_target[1],
                                     s_ * v_target[0] + c * v_target[1]])
    acc = (v_target - obs.velocity) / time_constant
    norm = float(np.hypot(*acc))
    if norm > obs.a_max:
        acc *= obs.a_max / norm
    return acc


class GoalAgent:
    """Goal seeking with no avoidance; options: v_pref (m/s), time_constant (s)."""

    def __init__(self, v_pref: float | None = None, time_constant: float = 0.5) -> None:
        self.v_pref = v_pref
        self.time_constant = time_constant

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """Nothing to reset: the controller is stateless."""

    def act(self, obs: Observation) -> NDArray[np.float64]:
        return goal_seeking_accel(obs, self.v_pref, self.time_constant)
