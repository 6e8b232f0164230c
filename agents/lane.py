"""``lane``: the scripted lane follower (the controller of traffic) driving a robot.

The robot's lane is the polyline from its start through its route (or to
its goal). It tracks the lane centreline at ``speed`` (m/s, default its
v_max / 1.5, slowing down to stop at its goal) and keeps its distance to
the nearest sensed body ahead in the lane with the same car-following law
as traffic (:func:`nao_arena.traffic.follower_accel`). It does not avoid
anything else.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.sensing import Observation
from nao_arena.traffic import FollowerParams, PolylineLane, follower_accel


class LaneAgent:
    """Options: speed (m/s), time_headway (s), min_gap (m), lane_width (m): bodies whose
    centre is within lane_width / 2 of the centreline count as in the lane."""

    def __init__(
        self,
        speed: float | None = None,
        time_headway: float = 1.0,
        min_gap: float = 2.0,
        lane_width: float = 3.0,
    ) -> None:
        self.speed = speed
        self.time_headway = time_headway
        self.min_gap = min_gap
        self.lane_width = lane_width
        self.lane: PolylineLane | None = None

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        self.lane = None

    def _setup(self, obs: Observation) -> PolylineLane:
        points = [obs.position]
        if obs.route is not None:
            points.extend(obs.route)
        elif obs.goal is not None:
            points.append(obs.goal)
        pts = np.asarray(points, dtype=float)
        keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-9])
        pts = pts[keep]
        if len(pts) < 2:
            pts = np.stack([obs.position, obs.position + np.array([1.0, 0.0])])
        return PolylineLane(pts)

    def act(self, obs: Observation) -> NDArray[np.float64]:
        if self.lane is None:
            self.lane = self._setup(obs)
        lane = self.lane
        speed = self.speed if self.speed is not None else obs.v_max / 1.5
        if obs.goal is not None:
            # slow down to stop at the goal (braking at half a_max)
            speed = min(speed, float(np.sqrt(obs.a_max * np.hypot(*(obs.goal - obs.position)))))
        params = FollowerParams(
            speed=max(min(speed, obs.v_max), 1e-6),
            a_max=obs.a_max,
            time_headway=self.time_headway,
            min_gap=self.min_gap,
        )
        nb = obs.neighbours
        leader = None
        if len(nb):
            s, lateral = lane.project(np.vstack([obs.position[None], nb.positions]))
            ahead = (s[1:] > s[0]) & (np.abs(lateral[1:]) <= 0.5 * self.lane_width)
            if np.any(ahead):
                k = np.flatnonzero(ahead)[int(np.argmin(s[1:][ahead]))]
                leader = k
        if leader is None:
            return follower_accel(lane, params, obs.dt, obs.position, obs.velocity, obs.radius)
        return follower_accel(
            lane,
            params,
            obs.dt,
            obs.position,
            obs.velocity,
            obs.radius,
            nb.positions[leader],
            nb.velocities[leader],
            float(nb.radii[leader]),
        )
