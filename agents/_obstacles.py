"""Obstacles as a velocity-space baseline sees them: discs with constant velocity."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.walls import wall_discs
from nao_arena.motion import limit_norm
from nao_arena.sensing import Observation


@dataclass(frozen=True)
class Discs:
    """Obstacle discs relative to the robot: positions (n, 2) m, velocities (n, 2) m/s
    (world frame), combined radii (n,) m, and which of them react (other robots)."""

    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    radii: NDArray[np.float64]
    reactive: NDArray[np.bool_]


def observed_discs(obs: Observation, margin: float, sensing_range: float) -> Discs:
    """Neighbours and wall discs within range, radii grown by the robot's radius + margin."""
    nb = obs.neighbours
    pos = [nb.positions - obs.position]
    vel = [nb.velocities]
    rad = [nb.radii + obs.radius + margin]
    reactive = [np.array([k == "robot" for k in nb.kinds], dtype=bool)]
    if len(obs.walls):
        wc, wr = wall_discs(obs.walls, obs.wall_radius, obs.radius + margin)
        near = np.hypot(*(wc - obs.position).T) <= sensing_range + wr
        pos.append(wc[near] - obs.position)
        vel.append(np.zeros((int(near.sum()), 2)))
        rad.append(wr[near])
        reactive.append(np.zeros(int(near.sum()), dtype=bool))
    return Discs(
        np.concatenate(pos).reshape(-1, 2),
        np.concatenate(vel).reshape(-1, 2),
        np.concatenate(rad),
        np.concatenate(reactive),
    )


def track_velocity(obs: Observation, v_new: NDArray[np.float64], time_constant: float):
    """Acceleration (m/s^2) that reaches v_new in time_constant s, scaled to |a| <= a_max."""
    acc = (v_new - obs.velocity) / time_constant
    x, y, _ = limit_norm(float(acc[0]), float(acc[1]), float(obs.a_max))
    return np.array([x, y])


def preferred_velocity(obs: Observation, v_pref: float | None) -> NDArray[np.float64]:
    """Velocity toward the goal (m/s), slowing down to stop at it."""
    from .goal import goal_target

    target = goal_target(obs)
    if target is None:
        return np.zeros(2)
    to_goal = target - obs.position
    dist = float(np.hypot(*to_goal))
    if dist < 1e-9:
        return np.zeros(2)
    cap = obs.v_max if v_pref is None else min(v_pref, obs.v_max)
    return to_goal / dist * min(cap, float(np.sqrt(obs.a_max * dist)))
