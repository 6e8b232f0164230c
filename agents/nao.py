"""``nao`` and ``ao``: choose a constant acceleration outside every neighbour's NAO.

Each step the agent predicts its neighbours' centres over the horizon
(predictor option), builds their NAOs (grown by both radii and a safety
margin, walls as chains of static discs), and

1. keeps its current acceleration while that stays admissible and within
   ``keep_band`` (m/s^2) of the desired one (the paper's premise: few
   adjustments);
2. otherwise takes the admissible acceleration nearest the desired one
   (goal seeking, see :func:`nao_arena.agents.goal.goal_seeking_accel`);
3. if none is admissible, the one that postpones contact longest.

With ``replan=False`` the agent selects once, at its first step, and
holds that acceleration for the whole episode (the paper's open-loop
crossing; choose a horizon that covers the manoeuvre).

Liveness: a robot that has crawled (speed below a quarter of v_max) for
``detour_after`` s while away from its goal turns its goal direction to the
right by a random angle in [30, 60] degrees (drawn from its own generator)
until it has moved freely again for as long; symmetric stand-offs then
resolve like traffic keeping right.

Its own predicted path includes its speed limit, so "admissible" means
collision-free for the world's real dynamics over the horizon (up to the
physics integration error, covered by the margin).
``ao`` is the same agent with constant-acceleration predictions (the AO).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.agents.goal import goal_seeking_accel
from nao_arena.geometry import AccelLimits, PiecewisePath, sampled_path, select_acceleration
from nao_arena.geometry.kernel import admissible_kernel, piece_sweep
from nao_arena.geometry.walls import wall_discs
from nao_arena.predictors import get_predictor
from nao_arena.sensing import Observation


class NAOAgent:
    """NAO avoidance. Options: horizon (s), samples (per horizon), predictor name,
    margin (m), keep_band (m/s^2), v_pref (m/s), sensing_range (m), detour_after (s),
    replan."""

    def __init__(
        self,
        horizon: float = 3.0,
        samples: int = 31,
        predictor: str | None = None,
        margin: float = 0.15,
        keep_band: float = 0.3,
        v_pref: float | None = None,
        sensing_range: float = 30.0,
        detour_after: float = 1.0,
        replan: bool = True,
    ) -> None:
        self.replan = bool(replan)
        self.horizon = float(horizon)
        self.detour_after = float(detour_after)
        self.times = np.linspace(0.0, self.horizon, int(samples))
        self.predictor_name = predictor or "turn_rate"
        self.predict = get_predictor(self.predictor_name)
        self.margin = float(margin)
        self.keep_band = float(keep_band)
        self.v_pref = v_pref
        self.sensing_range = float(sensing_range)
        self.reset(None, np.random.default_rng(0))

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        self.current = np.zeros(2)
        self.last_selection = None
        self.rng = rng
        self.crawl_time = 0.0
        self.free_time = 0.0
        self.detour = 0.0

    def _update_detour(self, obs: Observation) -> None:
        """Track crawling away from the goal; start or end a detour to the right."""
        speed = float(np.hypot(*obs.velocity))
        far = obs.goal is not None and float(np.hypot(*(obs.goal - obs.position))) > 4 * obs.radius
        if far and speed < 0.25 * obs.v_max:
            self.crawl_time += obs.dt
            self.free_time = 0.0
        else:
            self.free_time += obs.dt
            self.crawl_time = 0.0
        if self.detour == 0.0 and self.crawl_time >= self.detour_after:
            self.detour = -float(self.rng.uniform(np.pi / 6, np.pi / 3))
        elif self.detour != 0.0 and self.free_time >= self.detour_after:
            self.detour = 0.0

    def obstacle_paths(self, obs: Observation) -> PiecewisePath:
        """Neighbours' predicted paths and wall discs, robot-relative (m)."""
        nb = obs.neighbours
        centres = [self.predict(self.times, nb) - obs.position] if len(nb) else []
        radii = [nb.radii + obs.radius + self.margin] if len(nb) else []
        if len(obs.walls):
            wc, wr = wall_discs(obs.walls, obs.wall_radius, obs.radius + self.margin)
            near = np.hypot(*(wc - obs.position).T) <= self.sensing_range + wr
            centres.append(np.repeat((wc[near] - obs.position)[:, None, :], len(self.times), 1))
            radii.append(wr[near])
        if not centres:
            return sampled_path(self.times, np.zeros((0, len(self.times), 2)), np.zeros(0))
        return sampled_path(self.times, np.concatenate(centres), np.concatenate(radii))

    def _admissible(self, a: NDArray[np.float64], obs: Observation, path: PiecewisePath) -> bool:
        if float(np.hypot(*a)) > obs.a_max * (1 + 1e-9):
            return False
        if path.n_obstacles == 0:
            return True
        ok = np.empty(1, dtype=bool)
        admissible_kernel(
            obs.velocity[None].copy(), a[None].copy(), obs.v_max, path.t, path.c, path.w,
            path.b, path.radius, piece_sweep(path.t, path.w, path.b), 0.0, ok,
        )
        return bool(ok[0])

    def act(self, obs: Observation) -> NDArray[np.float64]:
        if not self.replan and self.last_selection is not None:
            return self.current
        self._update_detour(obs)
        desired = goal_seeking_accel(obs, self.v_pref, heading_offset=self.detour)
        path = self.obstacle_paths(obs)
        if (
            float(np.hypot(*(self.current - desired))) <= self.keep_band
            and self._admissible(self.current, obs, path)
        ):
            return self.current
        sel = select_acceleration(desired, obs.velocity, path, AccelLimits(obs.a_max),
                                  v_max=obs.v_max, with_clearance=False)
        self.last_selection = sel
        self.current = np.asarray(sel.accel, dtype=np.float64)
        return self.current


class AOAgent(NAOAgent):
    """The same selection with constant-acceleration predictions (the AO); it takes
    every option of :class:`NAOAgent` except the predictor."""

    def __init__(
        self,
        horizon: float = 3.0,
        samples: int = 31,
        margin: float = 0.15,
        keep_band: float = 0.3,
        v_pref: float | None = None,
        sensing_range: float = 30.0,
        detour_after: float = 1.0,
        replan: bool = True,
    ) -> None:
        super().__init__(horizon, samples, "constant_acceleration", margin, keep_band, v_pref,
                         sensing_range, detour_after, replan)
