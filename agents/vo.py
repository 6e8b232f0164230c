"""``vo``: velocity obstacles with a velocity-tracking acceleration law.

Each step: the velocity obstacles of all neighbours (constant-velocity
predictions, truncated at ``horizon`` s) and walls; the candidate velocity
(on a polar grid in |u| <= v_max, plus the preferred and current
velocities) outside all of them and nearest the preferred velocity; the
acceleration that reaches it in ``time_constant`` s, within a_max. When every
candidate collides, the one with the largest clearance. This is the classic
VO: the acceleration limit is not part of its prediction.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.agent import PanelAgent
from nao_arena.geometry import vo_clearance
from nao_arena.sensing import Observation

from ._obstacles import Discs, observed_discs, preferred_velocity, track_velocity


def reachable(discs: Discs, speed: float, horizon: float) -> NDArray[np.bool_]:
    """Which discs a robot moving at up to ``speed`` m/s could touch within ``horizon`` s:
    the others stay farther than their radius all along (their centre is farther than
    (speed + their speed) x horizon + radius, by a margin far above rounding), so their
    clearance is positive for every candidate and they decide nothing. A disc with a
    non-finite entry counts as reachable."""
    dist = np.hypot(*discs.positions.T)
    reach = (np.hypot(*discs.velocities.T) + speed) * horizon + discs.radii
    return ~(dist - reach > 1e-9 * (1.0 + dist))


class VOAgent:
    """Options: horizon (s), margin (m), v_pref (m/s), rings/angles of the velocity grid,
    time_constant (s), sensing_range (m)."""

    def __init__(
        self,
        horizon: float = 3.0,
        margin: float = 0.05,
        v_pref: float | None = None,
        rings: int = 8,
        angles: int = 32,
        time_constant: float = 0.3,
        sensing_range: float = 30.0,
    ) -> None:
        self.times = np.linspace(0.0, horizon, 2)
        self.margin = margin
        self.v_pref = v_pref
        self.rings = rings
        self.angles = angles
        self.time_constant = time_constant
        self.sensing_range = sensing_range

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """Stateless."""

    def candidates(self, obs: Observation, pref: NDArray[np.float64]) -> NDArray[np.float64]:
        r = obs.v_max * np.arange(1, self.rings + 1) / self.rings
        ang = 2 * np.pi * np.arange(self.angles) / self.angles
        grid = (r[:, None, None] * np.stack([np.cos(ang), np.sin(ang)], -1)[None]).reshape(-1, 2)
        return np.concatenate([pref[None], obs.velocity[None], np.zeros((1, 2)), grid])

    def panel(self) -> PanelAgent:
        """What the viewer's acceleration panel shows of this agent: margin and v_pref."""
        return PanelAgent(margin=float(self.margin), v_pref=self.v_pref)

    def act(self, obs: Observation) -> NDArray[np.float64]:
        pref = preferred_velocity(obs, self.v_pref)
        discs = observed_discs(obs, self.margin, self.sensing_range)
        cand = self.candidates(obs, pref)
        near = reachable(discs, float(np.max(np.hypot(*cand.T))), float(self.times[-1]))
        if not near.any():
            # nothing within reach of any candidate: every one is clear, pref the nearest
            return track_velocity(obs, pref, self.time_constant)
        positions, velocities, radii = (
            discs.positions[near],
            discs.velocities[near],
            discs.radii[near],
        )
        t = self.times[None, :, None]
        centers = positions[:, None, :] + velocities[:, None, :] * t
        clear = np.min(np.atleast_2d(vo_clearance(cand, self.times, centers, radii)), axis=1)
        ok = clear >= 0.0
        if np.any(ok):
            dist = np.hypot(*(cand - pref).T)
            best = cand[np.flatnonzero(ok)[int(np.argmin(dist[ok]))]]
        else:
            best = cand[int(np.argmax(clear))]
        return track_velocity(obs, best, self.time_constant)
