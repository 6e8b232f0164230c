"""PettingZoo environments over the arena's control loop.

``parallel_env(map="roundabout", **kwargs)`` returns a
:class:`pettingzoo.ParallelEnv`; ``env(...)`` the AEC version (PettingZoo's
``parallel_to_aec`` converter). Keyword arguments that name a field of
:class:`EnvOptions` set that option (``rewards`` and ``arena`` also accept
plain dicts); every other keyword is a map parameter (``n=20``, ``seed=3``,
see :mod:`nao_arena.maps`), as is everything in ``map_params={...}``.
Unknown map parameters raise :class:`~nao_arena.maps.MapError` naming the
declared ones.

Agents
------
One agent per *controlled* robot (option ``controlled``: ``"all"`` or a list
of robot names or indices), named by the robot's name. Every other robot is
driven by its own agent (the map's, or ``arena.agent``) and traffic by its
lane followers, inside :meth:`nao_arena.arena.Arena.step`; the env has no
control loop of its own. An agent is removed from ``agents`` when it
terminates (goal reached, or a collision with ``terminate_on_collision``)
or is truncated (time limit). Its robot stays in the world: with
``after_done="agent"`` (default) the robot's own built-in agent drives it
from then on (e.g. the NAO agent holding it at its goal); with
``after_done="hold"`` it brakes to a stop (acceleration -v/dt, clipped to
a_max) and stays there.

Agents that finish
------------------
With ``keep_finished=True`` every agent stays in ``agents`` until the
episode ends, which vector envs (SuperSuit's ``pettingzoo_env_to_vec_env_v1``)
need. An agent finishes when it terminates as above; from then on its
actions are still required and checked but ignored, its robot is driven as
``after_done`` says (by default its own built-in agent: the NAO agent holds
it at its goal), its observation's ``finished`` entry is 1, its reward is 0
and its terminated and truncated flags stay False. The episode ends at the
time limit or when every agent has finished: then every agent leaves
``agents``, the finished ones terminated, the others truncated. Infos get
``finished`` (bool); :attr:`NaoArenaParallelEnv.finished_agents` lists them.

Actions
-------
A float32 Box of shape (2,) in [-1, 1]: the acceleration command in the
world frame, normalized by the robot's a_max. Components outside [-1, 1]
are clipped to it; the command a_max * action (m/s^2) is then scaled by the
world to |a| <= a_max (a corner such as (1, 1) gives a_max in the diagonal
direction), and the speed limit v_max applies as in :mod:`nao_arena.world`.
An action of the wrong shape, NaN or inf, or not made of real numbers
(booleans, complex numbers, strings) raises ``ValueError``, as does a
missing action for a live agent, an unknown agent name, or actions that are
not a dict; actions for agents that are no longer live are ignored (the AEC
converter sends None).

Observations
------------
A float32 vector per agent (layout from :func:`observation_layout`), world
frame, units m, m/s, m/s^2, s:

- ``own`` (16): goal - position (2, m), velocity (2, m/s), measured
  acceleration (2, m/s^2, mean over the last control period, contacts
  included), last commanded acceleration (2, m/s^2, after clipping to a_max),
  a_max (m/s^2), v_max (m/s), radius (m), position (2, m), goal (2, m),
  time left until the time limit (s);
- ``neighbours`` (K x 9, K = ``max_neighbours``): the K nearest bodies
  within the arena's sensing range, nearest first (ties by body index), one
  row each: mask (1 = present), relative position (2, m), relative velocity
  (2, m/s), acceleration (2, m/s^2), radius (m), is_traffic (0/1: 1 for
  traffic and people, the bodies that are not robots); absent rows are all
  zero;
- ``nao`` (optional, ``nao_features=True``): the exact clearance (m, see
  :func:`nao_arena.geometry.nao_clearance`) of fixed candidate accelerations
  against the K neighbours' predicted paths (``nao_predictor``, default
  turn rate, over ``nao_horizon`` s; radii grown by the robot's radius and
  ``nao_margin``) and the nearby walls, the minimum over obstacles, clipped
  to [-nao_clip, nao_clip]; candidates on a polar grid in the world frame:
  for each ring fraction f of ``nao_rings`` (a = f a_max), ``nao_angles``
  directions starting at +x counter-clockwise (a single candidate for f =
  0). Negative clearance: that constant acceleration collides within the
  horizon if the predictions hold; nao_clip: nothing within reach;
- ``finished`` (1, only with ``keep_finished``): 1 once the agent has
  finished, else 0.

What a robot observes is what it senses: with the imperfect world's sensing
models on (noise, dropout, latency, field of view, occlusion; see
:mod:`nao_arena.imperfection`), the own and neighbour blocks and the NAO
block come from :meth:`~nao_arena.arena.Arena.sensed`, the batch the map's
own agents act on in the same period (its own state as old as the latency,
neighbours noisy, missed or hidden as the models say); the statistics and
rewards keep using the truth.

Observation bounds
------------------
The observation Box is finite wherever the quantity is bounded, with bounds
common to all agents (the maxima over the controlled robots, or over all
bodies for neighbour rows): velocities |v| <= v_max and relative velocities
<= v_max + the neighbour's v_max (speeds are capped at the end of every
period), measured accelerations <= 2 v_max / dt, commanded ones <= a_max,
a_max, v_max, radius >= 0, time left in [0, time limit], neighbour offsets
within the sensing range, goals within the map's bounds, masks and flags in
[0, 1], the NAO block in [-nao_clip, nao_clip]; dynamic bounds are widened
by a relative 1e-6 against rounding. Positions (x, y, and the goal offset)
are bounded by the map's bounds when walls close them (``bounds.walls``);
on open maps they are unbounded (inf) unless ``position_margin`` (m) is
set: then they are clipped to the bounds grown by that margin. Every
observation is clipped to its Box (a no-op except for positions clipped by
``position_margin``), so ``observation_space(a).contains(obs)`` always
holds. SuperSuit's ``normalize_obs_v0`` needs every bound finite: a walled
map, or ``position_margin``.

Rewards, terminations, truncations, infos
-----------------------------------------
Per step, with the weights of :class:`RewardWeights`: ``progress`` x the
decrease of the distance to the goal (m) - ``collision`` x the contact
episodes the robot started this step (bodies and walls) - ``accel_change``
x |a_t - a_(t-1)| / a_max of the commanded accelerations - ``step`` +
``goal`` on the step the goal is reached. Terminated: goal reached (within
the map's goal tolerance), or a collision if ``terminate_on_collision``.
Truncated: the time limit (``time_limit`` s, default the map's). Infos hold
numbers only, so that every RL library can stack them (TorchRL, RLlib,
SB3's VecEnv): ``collisions`` (int: the contact events of this robot that
started in the step), ``reached`` (bool), ``time`` (s), ``faults`` (int: its
agent's faults in the step), and with ``keep_finished`` ``finished`` (bool).
The events themselves, as dicts (see :class:`nao_arena.stats.ContactEvent`),
are in :attr:`NaoArenaParallelEnv.events` after each reset and step: agent ->
``{"collisions": [...], "faults": [...]}``.

Seeding
-------
``reset(seed=s)`` loads the map with ``seed=s`` when it declares a ``seed``
parameter (unless ``reseed_map=False``) and calls ``Arena.reset(s)``; a
reset without a seed draws the episode's seed from a generator seeded by
the last seeded reset (fresh entropy if never seeded). Same seed, same
actions: identical observations, rewards and infos.

``state()`` is the global state (layout in :meth:`NaoArenaParallelEnv.state`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike, NDArray
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from nao_arena.arena import Arena, StepResult
from nao_arena.env_actions import actions_array
from nao_arena.env_observations import ObservedRows, nao_block, observation_bounds, observation_rows
from nao_arena.env_options import (
    NEIGHBOUR_FEATURES,
    OWN_FEATURES,
    EnvOptions,
    RewardWeights,
    _split_kwargs,
    grouped_names,
    nao_candidates,
    observation_layout,
)
from nao_arena.env_step import (
    StepArrays,
    _Period,
    clipped_float32,
    period_rewards,
    settle_finished,
)
from nao_arena.kernels import ensure_env_compiled
from nao_arena.maps import MapSpec, load_map, with_time_limit
from nao_arena.neighbours import in_range_lists
from nao_arena.stats.records import ContactEvent
from nao_arena.world import WorldState, clip_accelerations

_EventDicts = dict[int, list[dict[str, Any]]]
"""Event dicts (contact events, or faults) by body index."""

__all__ = [
    "NEIGHBOUR_FEATURES",
    "OWN_FEATURES",
    "EnvOptions",
    "NaoArenaParallelEnv",
    "RewardWeights",
    "env",
    "nao_candidates",
    "observation_layout",
    "parallel_env",
]


def _events_by_body(contacts: Sequence[ContactEvent]) -> _EventDicts:
    """The contacts of a step as event dicts by body: each under its first body, and
    under its second unless that is a wall."""
    events: _EventDicts = {}
    for ev in contacts:
        events.setdefault(ev.a, []).append(ev.to_dict())
        if ev.kind_b != "wall":
            events.setdefault(ev.b, []).append(ev.to_dict())
    return events


class NaoArenaParallelEnv(ParallelEnv):
    """A map's arena as a PettingZoo parallel env (see the module docstring)."""

    metadata: dict[str, Any] = {
        "name": "nao_arena_v0",
        "render_modes": ["human", "rgb_array"],
        "is_parallelizable": True,
        "render_fps": 10,
    }

    def __init__(
        self,
        map: str | Path = "roundabout",  # noqa: A002 - the issue's public keyword
        render_mode: str | None = None,
        options: EnvOptions | None = None,
        map_params: Mapping[str, Any] | None = None,
        **kwargs: Any,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode: expected one of {self.metadata['render_modes']} "
                f"or None, got {render_mode!r}"
            )
        self.options, self.map_params = _split_kwargs(options, map_params, kwargs)
        self.map_source = map
        self.render_mode = render_mode
        spec = self._load(self.map_params)
        self._declared = frozenset(spec.parameters)
        ensure_env_compiled(map)  # what its first steps call, on every core
        self._install(spec)
        # the robots under test (people, after them, keep their own agents)
        robot_names = [r.name or f"robot{i}" for i, r in enumerate(spec.robots[: spec.n_robots])]
        self._controlled = self._resolve_controlled(self.options.controlled, robot_names)
        self._controlled_array = np.array(self._controlled, dtype=np.intp)
        self._all_rows = np.arange(len(self._controlled), dtype=np.intp)
        w = self.options.rewards
        self._reward_weights = np.array([w.progress, w.accel_change, w.step, w.goal])
        names = [robot_names[k] for k in self._controlled]
        self.possible_agents: list[str] = (
            grouped_names(names) if self.options.agent_names == "grouped" else names
        )
        self._row = {name: i for i, name in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        self.metadata = {**self.metadata, "render_fps": 1.0 / spec.physics.dt}
        self._cand = nao_candidates(self.options) if self.options.nao_features else None
        self._build_spaces()
        self._rng = np.random.default_rng()
        self._viewer: Any = None
        self.last_result: StepResult | None = None
        self._event_rows: tuple[list[str], list[int], _EventDicts, _EventDicts] = (
            [],
            [],
            {},
            {},
        )
        self._events: dict[str, dict[str, list[dict[str, Any]]]] | None = None

    def __getstate__(self) -> dict[str, Any]:
        """Everything but the viewer (pygame objects; a copy opens its own on render)."""
        state = self.__dict__.copy()
        state["_viewer"] = None
        return state

    # ------------------------------------------------------------------ setup

    def _load(self, params: Mapping[str, Any]) -> MapSpec:
        spec = load_map(
            self.map_source,
            trusted=self.options.trust_map,
            agents=self.options.named_agents,
            **params,
        )
        if self.options.time_limit is not None:
            spec = with_time_limit(spec, self.options.time_limit)
        return spec

    def _install(self, spec: MapSpec) -> None:
        """A fresh arena for ``spec`` and the per-robot constants derived from it."""
        self.spec = spec
        self._time_limit = float(spec.episode.time_limit)
        self.arena = Arena(spec, self.options.arena)
        world = self.arena.world
        # is_traffic: 1 for the bodies that are not robots (traffic and people)
        self._kinds = np.array([k != "robot" for k in world.kinds], dtype=float)
        self._world_a_max = np.ascontiguousarray(world.a_max, dtype=np.float64)
        self._world_v_max = np.ascontiguousarray(world.v_max, dtype=np.float64)
        self._sensing_range = float(self.arena.sensing_range)
        k = min(self.options.max_neighbours, world.n - 1)
        if self.arena.max_neighbours is not None:
            k = min(k, int(self.arena.max_neighbours))
        self._k = max(k, 0)
        self._walls = None
        if self.options.nao_features and self.options.nao_walls and len(self.arena.walls):
            self._walls = (
                np.ascontiguousarray(self.arena.walls, dtype=np.float64),
                np.ascontiguousarray(self.arena.wall_radius, dtype=np.float64),
            )

    @staticmethod
    def _resolve_controlled(controlled: str | Sequence[str | int], names: list[str]) -> list[int]:
        if isinstance(controlled, str):
            if controlled == "all":
                out = list(range(len(names)))
            elif controlled in names:
                out = [names.index(controlled)]
            else:
                raise ValueError(
                    f"controlled: expected 'all', robot names or indices; unknown "
                    f"robot {controlled!r} (robots: {', '.join(names)})"
                )
        else:
            out = []
            for c in controlled:
                if isinstance(c, int | np.integer) and not isinstance(c, bool):
                    if not 0 <= int(c) < len(names):
                        raise ValueError(
                            f"controlled: robot index {c} out of range (0..{len(names) - 1})"
                        )
                    out.append(int(c))
                elif isinstance(c, str) and c in names:
                    out.append(names.index(c))
                else:
                    raise ValueError(
                        f"controlled: unknown robot {c!r} (robots: {', '.join(names)})"
                    )
            out = sorted(set(out))
        if not out:
            raise ValueError(
                "controlled: expected at least one robot; the map has none"
                if not names
                else "controlled: expected at least one robot"
            )
        return out

    def _build_spaces(self) -> None:
        lay = observation_layout(self.options)
        self._layout = lay
        self._finished_column = lay["finished"].start
        dim = lay["finished"].stop
        low, high = self._observation_bounds(lay)
        self._obs_dim = dim
        self._observation_spaces = {
            a: spaces.Box(
                low.astype(np.float32), high.astype(np.float32), shape=(dim,), dtype=np.float32
            )
            for a in self.possible_agents
        }
        box = self._observation_spaces[self.possible_agents[0]]
        # observations are clipped to the float32 bounds themselves (see _observe)
        self._obs_low = box.low.astype(np.float64)
        self._obs_high = box.high.astype(np.float64)
        self._action_spaces = {
            a: spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32) for a in self.possible_agents
        }
        n, r = self.arena.world.n, len(self.arena.robots)
        sdim = 1 + 8 * n + 2 * r
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(sdim,), dtype=np.float32)

    def _observation_bounds(
        self, lay: dict[str, slice]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper bounds (D,) of the observation entries (module docstring,
        "Observation bounds"; :func:`~nao_arena.env_observations.observation_bounds`)."""
        return observation_bounds(
            self.arena.world,
            self.arena.robot_ids[self._controlled],
            self.spec.bounds,
            self.options,
            self._sensing_range,
            self.time_limit,
            lay,
        )

    def observation_space(self, agent: str) -> spaces.Box:
        """The agent's observation space (the same object on every call)."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        """The agent's action space: normalized acceleration (2,) in [-1, 1]."""
        return self._action_spaces[agent]

    # ------------------------------------------------------------------ episode

    @property
    def time_limit(self) -> float:
        """The episode's time limit (s)."""
        return float(self.spec.episode.time_limit)

    @property
    def max_steps(self) -> int:
        """The control steps of an episode that runs to its time limit (every agent is
        truncated in that step at the latest)."""
        return math.ceil(self.time_limit / self.arena.world.dt - 1e-9)

    def reset(
        self, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float32]], dict[str, dict[str, Any]]]:
        """Start an episode; ``options`` is accepted for API compatibility and ignored."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
            episode_seed = int(seed)
        else:
            episode_seed = int(self._rng.integers(2**31 - 1))
        if self.options.reseed_map and "seed" in self._declared:
            if self.spec.parameters.get("seed") != episode_seed:
                spec = self._load({**self.map_params, "seed": episode_seed})
                old = [r.name for r in self.spec.robots]
                if [r.name for r in spec.robots] != old:
                    raise ValueError(
                        "the map's robots changed with its seed; expected the same "
                        "robot names in every episode"
                    )
                self._install(spec)
        self.arena.reset(episode_seed)
        self.agents = list(self.possible_agents)
        self._alive = np.ones(len(self.possible_agents), dtype=bool)
        self._all_alive = True  # every agent unfinished (kept by _keep_arrays)
        self._bodies = self.arena.robot_ids[self._controlled].astype(np.int64)
        self._body_list = self._bodies.tolist()
        self._goals = self.arena.goals[self._controlled]
        self._a_max = self.arena.world.a_max[self._bodies]
        self._prev_cmd = np.zeros((len(self._controlled), 2))
        # observation_rows' bundle for every row and the truth, built once per episode
        self._observed_rows = ObservedRows(
            self._bodies,
            self._goals,
            self._prev_cmd,
            self._kinds,
            self._world_a_max,
            self._world_v_max,
        )
        state = self.arena.state
        assert state is not None
        self._dist = np.hypot(*(state.positions[self._bodies] - self._goals).T)
        self.last_result = None
        rows = np.arange(len(self.possible_agents))
        obs = self._observe(rows)
        infos: dict[str, dict[str, Any]] = {
            a: {"collisions": 0, "reached": False, "time": 0.0, "faults": 0} for a in self.agents
        }
        self._set_events(list(self.agents), self._bodies.tolist(), {}, {})
        if self.options.keep_finished:
            for info in infos.values():
                info["finished"] = False
        if self.render_mode == "human":
            self.render()
        return {a: obs[i] for i, a in enumerate(self.agents)}, infos

    def _actions_array(self, actions: Mapping[str, Any], live: list[str]) -> NDArray[np.float64]:
        """Validated actions (m, 2) of the live agents, in ``live`` order, clipped to [-1, 1]
        (:func:`~nao_arena.env_actions.actions_array`)."""
        return actions_array(actions, live, self._row, self.possible_agents)

    @property
    def events(self) -> dict[str, dict[str, list[dict[str, Any]]]]:
        """The last reset's or step's events by agent: ``{"collisions": [contact event
        dicts], "faults": [fault dicts]}`` (the infos hold their counts)."""
        if self._events is None:
            names, bodies, contacts, faults = self._event_rows
            self._events = {
                a: {"collisions": contacts.get(b, []), "faults": faults.get(b, [])}
                for a, b in zip(names, bodies, strict=True)
            }
        return self._events

    def _set_events(
        self, names: list[str], bodies: list[int], contacts: _EventDicts, faults: _EventDicts
    ) -> None:
        """The events of the agents ``names`` (robots ``bodies``) for :attr:`events`,
        from the event dicts by body (built when first read)."""
        self._event_rows = (names, bodies, contacts, faults)
        self._events = None

    def step(
        self, actions: Mapping[str, Any]
    ) -> tuple[
        dict[str, NDArray[np.float32]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """One control period: the live agents' normalized accelerations -> the usual five dicts
        over the agents live at the start of the step."""
        if self.arena.stats is None:
            raise RuntimeError("call reset() before step()")
        live = self.agents
        if not live:
            return {}, {}, {}, {}, {}
        live_rows = np.fromiter((self._row[a] for a in live), dtype=np.intp, count=len(live))
        period = self._advance(live_rows, self._actions_array(actions, live))
        if self.options.keep_finished:
            out = self._keep_arrays(period)
            rows = live_rows
        else:
            out = self._leaving_arrays(period)
            rows = period.rows
        self._set_events(live, self._bodies[rows].tolist(), period.events, period.faults)
        obs, rew, term, trunc = out.observations, out.rewards, out.terminated, out.truncated
        rew_l, term_l, trunc_l = rew.tolist(), term.tolist(), trunc.tolist()
        reached_l, col_l, fault_l = (
            out.reached.tolist(),
            out.collisions.tolist(),
            out.faults.tolist(),
        )
        fin_l = out.finished.tolist()
        out_obs, out_rew, out_term, out_trunc, out_info = {}, {}, {}, {}, {}
        for i, a in enumerate(live):
            out_obs[a] = obs[i]
            out_rew[a] = rew_l[i]
            out_term[a] = term_l[i]
            out_trunc[a] = trunc_l[i]
            info = {
                "collisions": col_l[i],
                "reached": reached_l[i],
                "time": out.time,
                "faults": fault_l[i],
            }
            if self.options.keep_finished:
                info["finished"] = fin_l[i]
            out_info[a] = info
        if self.render_mode == "human":
            self.render()
        return out_obs, out_rew, out_term, out_trunc, out_info

    def step_arrays(self, actions: ArrayLike) -> StepArrays:
        """One control period of an env with ``keep_finished`` (every agent live until
        the episode ends), in arrays: ``actions`` (agents, 2), normalized accelerations in
        ``possible_agents`` order (finite; clipped to [-1, 1]). Returns what :meth:`step`
        returns as arrays in the same order (:class:`StepArrays`); :attr:`events` is set
        as by :meth:`step`. The vector env (:mod:`nao_arena.vector`) steps its copies
        with this."""
        if not self.options.keep_finished:
            raise ValueError("step_arrays: expected an env with keep_finished=True")
        if self.arena.stats is None:
            raise RuntimeError("call reset() before step()")
        if not self.agents:
            raise RuntimeError("step_arrays: the episode has ended; call reset()")
        cmd = np.asarray(actions, dtype=np.float64)
        rows = self._all_rows
        if cmd.shape != (len(rows), 2) or not np.isfinite(cmd).all():
            raise ValueError(
                f"actions: expected finite numbers of shape ({len(rows)}, 2), got "
                f"{'shape ' + str(cmd.shape) if cmd.shape != (len(rows), 2) else 'NaN or inf'}"
            )
        return self._step_clipped(np.clip(cmd, -1.0, 1.0))

    def _step_clipped(self, actions: NDArray[np.float64]) -> StepArrays:
        """:meth:`step_arrays` with its checks done: ``actions`` (agents, 2) finite, in
        [-1, 1], the episode running (the vector env checks all its copies at once)."""
        period = self._advance(self._all_rows, actions)
        out = self._keep_arrays(period)
        self._set_events(self.possible_agents, self._body_list, period.events, period.faults)
        if self.render_mode == "human":
            self.render()
        return out

    def _advance(self, live_rows: NDArray[np.intp], actions: NDArray[np.float64]) -> _Period:
        """The arena's control period with the live agents' (``live_rows``) normalized
        actions (in [-1, 1]), and what every ending of a step shares (:class:`_Period`)."""
        everyone = live_rows is self._all_rows and self._all_alive
        if everyone:
            # every agent acts (the common case, without indexing)
            rows, cmd = live_rows, actions * self._a_max[:, None]
            robots, accs = self._controlled_array, cmd
        else:
            cmd = actions * self._a_max[live_rows, None]
            if self.options.keep_finished:
                # finished agents stay live; their actions are ignored
                acting = self._alive[live_rows]
                rows, cmd = live_rows[acting], cmd[acting]
            else:
                rows = live_rows
            robots, accs = self._controlled_array[rows], cmd
        if not everyone and self.options.after_done == "hold" and not np.all(self._alive):
            dead = np.flatnonzero(~self._alive)
            assert self.arena.state is not None  # reset() set it, with the stats
            v = self.arena.state.velocities[self._bodies[dead]]
            brake = clip_accelerations(-v / self.arena.world.dt, self._a_max[dead])
            robots = np.concatenate([robots, self._controlled_array[dead]])
            accs = np.concatenate([accs, brake])
        res = self.arena.step_robots(robots, accs)
        self.last_result = res
        state = res.state
        w = self.options.rewards
        bodies = self._bodies if everyone else self._bodies[rows]
        assert self.arena.stats is not None  # step() checked it
        reached = self.arena.stats.reached[bodies]
        reward = np.empty(len(rows))
        period_rewards(
            state.positions,
            bodies,
            rows,
            cmd,
            self._goals,
            self._a_max,
            self._prev_cmd,
            self._dist,
            reached,
            self._reward_weights,
            reward,
        )
        events = _events_by_body(res.contacts)
        n_col = np.array([len(events.get(int(b), ())) for b in bodies]) if events else None
        if n_col is not None:
            reward = reward - w.collision * n_col
        faults: dict[int, list[dict[str, Any]]] = {}
        for f in res.faults:
            faults.setdefault(int(self.arena.robot_ids[f.robot]), []).append(dataclasses.asdict(f))
        terminated = reached.copy()
        if self.options.terminate_on_collision and n_col is not None:
            terminated |= n_col > 0
        time_up = res.time >= self._time_limit - 1e-9
        return _Period(live_rows, rows, reward, terminated, time_up, events, faults, res)

    def adopt_period(self, result: StepResult, all_alive: bool) -> None:
        """Take the last control period of every agent, which ran in a batch
        (:mod:`nao_arena.vector_step`; the arena's ``result``), before which the episode
        did not end: what :meth:`step_arrays` keeps of its own, but the arrays it
        returns (the batch wrote them), given whether every agent is still unfinished."""
        self.last_result = result
        self._all_alive = all_alive
        events = _events_by_body(result.contacts)
        self._set_events(self.possible_agents, self._body_list, events, {})

    def _counts(
        self, events: dict[int, list[dict[str, Any]]], bodies: NDArray[np.int64]
    ) -> NDArray[np.int64]:
        """Number of events (len(bodies),) of each body in ``events``."""
        if not events:
            return np.zeros(len(bodies), dtype=np.int64)
        return np.array([len(events.get(int(b), ())) for b in bodies], dtype=np.int64)

    def _leaving_arrays(self, period: _Period) -> StepArrays:
        """The end of :meth:`step` without ``keep_finished``: agents leave ``agents``
        when they terminate or are truncated; the arrays are over ``period.rows``."""
        rows = period.rows
        obs = self._observe(rows)
        bodies = self._bodies[rows]
        assert self.arena.stats is not None  # step() checked it
        reached = self.arena.stats.reached[bodies]
        done = period.terminated | period.time_up
        if np.any(done):
            self._alive[rows[done]] = False
            self._all_alive = False
            self.agents = [a for a, d in zip(self.agents, done.tolist(), strict=True) if not d]
        return StepArrays(
            observations=obs,
            rewards=period.reward,
            terminated=period.terminated,
            truncated=np.full(len(rows), period.time_up),
            reached=reached.copy(),
            collisions=self._counts(period.events, bodies),
            faults=self._counts(period.faults, bodies),
            finished=np.zeros(len(rows), dtype=bool),
            time=float(period.result.time),
        )

    def _keep_arrays(self, period: _Period) -> StepArrays:
        """The end of :meth:`step` with ``keep_finished``: ``period.rows`` (the acting
        agents among the live ones) got ``period.reward`` and ``period.terminated``; every
        live agent stays live until the time limit or until all have finished."""
        live_rows = period.live_rows
        m = len(live_rows)
        finished_before = np.empty(m, dtype=np.bool_)
        finished = np.empty(m, dtype=np.bool_)
        rew = np.empty(m)
        someone_left, some_finished_before, self._all_alive = settle_finished(
            self._alive, live_rows, period.terminated, period.reward, finished_before, finished, rew
        )
        if some_finished_before:
            # what drove the finished robots (their agent, or braking), as the world applied it
            held = live_rows[finished_before]
            self._prev_cmd[held] = clip_accelerations(
                period.result.commanded[self._bodies[held]], self._a_max[held]
            )
        obs = self._observe(live_rows)
        end = period.time_up or not someone_left
        assert self.arena.stats is not None  # step() checked it
        bodies = self._bodies if live_rows is self._all_rows else self._bodies[live_rows]
        reached = self.arena.stats.reached[bodies]
        if end:
            self._alive[live_rows] = False
            self._all_alive = False
            self.agents = []
        return StepArrays(
            observations=obs,
            rewards=rew,
            terminated=finished & end,
            truncated=~finished & (end and period.time_up),
            reached=reached,
            collisions=self._counts(period.events, bodies),
            faults=self._counts(period.faults, bodies),
            finished=finished,
            time=float(period.result.time),
        )

    @property
    def finished_agents(self) -> list[str]:
        """The agents in ``agents`` that have finished (``keep_finished``: their actions
        are ignored; always empty without it, as finished agents leave ``agents``)."""
        return [a for a in self.agents if not self._alive[self._row[a]]]

    # ------------------------------------------------------------------ observations

    def observations(self) -> dict[str, NDArray[np.float32]]:
        """The live agents' observations of the current state (as returned by the last
        reset or step)."""
        if self.arena.state is None:
            raise RuntimeError("call reset() first")
        rows = np.fromiter(
            (self._row[a] for a in self.agents), dtype=np.intp, count=len(self.agents)
        )
        obs = self._observe(rows)
        return {a: obs[i] for i, a in enumerate(self.agents)}

    def _observe(self, rows: NDArray[np.intp]) -> NDArray[np.float32]:
        """Observation vectors (len(rows), D) of the controlled robots ``rows``."""
        state = self.arena.state
        assert state is not None
        opts = self.options
        m = len(rows)
        out = np.zeros((m, self._obs_dim), dtype=np.float64)
        if m == 0:
            return out.astype(np.float32)
        everyone = rows is self._all_rows
        bodies = self._bodies if everyone else self._bodies[rows]
        k = self._k
        idx = np.zeros((m, k), dtype=np.int64)
        present = np.zeros((m, k), dtype=np.bool_)
        sensed = state
        if self.arena.senses_the_truth:
            p, v, acc, rad = state.positions, state.velocities, state.accelerations, state.radii
            observed_rows = self._observed_rows
            if not everyone:
                observed_rows = observed_rows._replace(
                    bodies=bodies, goals=self._goals[rows], prev_cmd=self._prev_cmd[rows]
                )
            # the sensing's neighbour search, with the env's distances (math.hypot)
            nb_start, nb_index = in_range_lists(bodies, p, self._sensing_range, k, True)
        else:
            # what the robots sense through the imperfect world's models: rows of the batch
            batch = self.arena.sensed()
            robots = np.asarray(self._controlled, dtype=np.int64)[rows]
            bodies = np.asarray(batch.bodies, dtype=np.int64)[robots]
            p, v, acc, rad = batch.positions, batch.velocities, batch.accelerations, batch.radii
            of_row = batch.body_of(np.arange(len(rad)))
            observed_rows = ObservedRows(
                bodies,
                self._goals if everyone else self._goals[rows],
                self._prev_cmd if everyone else self._prev_cmd[rows],
                self._kinds[of_row],
                np.asarray(batch.a_max),
                np.asarray(batch.v_max),
            )
            first, last = batch.nb_start[robots], batch.nb_start[robots + 1]
            nb_start = np.concatenate(([0], np.cumsum(last - first))).astype(np.int64)
            nb_index = np.concatenate(
                [batch.nb_index[a:b] for a, b in zip(first.tolist(), last.tolist(), strict=True)]
                or [np.zeros(0, dtype=np.int64)]
            ).astype(np.int64)
            sensed = WorldState(
                time=float(batch.time),
                positions=np.asarray(p),
                velocities=np.asarray(v),
                accelerations=np.asarray(acc),
                radii=np.asarray(rad),
                names=(),
                kinds=tuple(state.kinds[b] for b in of_row.tolist()),
            )
        observation_rows(
            p,
            v,
            acc,
            rad,
            observed_rows,
            max(self._time_limit - state.time, 0.0),
            nb_start,
            nb_index,
            out,
            idx,
            present,
        )
        if self._cand is not None:
            out[:, self._layout["nao"]] = self._nao_block(sensed, bodies, idx, present)
        if opts.keep_finished:
            out[:, self._finished_column] = ~self._alive[rows]
        return clipped_float32(out, self._obs_low, self._obs_high)

    def _nao_block(
        self,
        state: WorldState,
        bodies: NDArray[np.intp],
        idx: NDArray[np.intp],
        present: NDArray[np.bool_],
    ) -> NDArray[np.float64]:
        """Clipped clearance (m, M) of the candidate accelerations for each robot
        (:func:`~nao_arena.env_observations.nao_block`) at ``state`` (the truth, or the
        rows of what the robots sense)."""
        assert self._cand is not None
        return nao_block(
            state,
            self.arena.world,
            self.options,
            self._cand,
            self._walls,
            bodies,
            idx,
            present,
        )

    def state(self) -> NDArray[np.float32]:
        """Global state (float32): time (s); per body in world order x, y (m), vx, vy (m/s),
        ax, ay (m/s^2), radius (m), is_traffic; per robot goal x, y (m)."""
        st = self.arena.state
        if st is None:
            raise RuntimeError("call reset() before state()")
        bodies = np.column_stack(
            [st.positions, st.velocities, st.accelerations, st.radii, self._kinds]
        )
        return np.concatenate([[st.time], bodies.ravel(), self.arena.goals.ravel()]).astype(
            np.float32
        )

    # ------------------------------------------------------------------ rendering

    @property
    def controlled_robots(self) -> list[int]:
        """Robot indices (robot order) of the controlled robots, as ``possible_agents``."""
        return list(self._controlled)

    def _selected_robot(self) -> int:
        sel = self.options.selected
        names = [r.name for r in self.spec.robots]
        if sel is None:
            live = [self._controlled[self._row[a]] for a in self.agents]
            return live[0] if live else self._controlled[0]
        if isinstance(sel, str):
            if sel not in names:
                raise ValueError(
                    f"selected: unknown robot {sel!r} (robots: {', '.join(map(str, names))})"
                )
            return names.index(sel)
        return int(sel)

    def render(self) -> NDArray[np.uint8] | None:
        """rgb_array: a (H, W, 3) uint8 frame (``render_size``); human: draw in a window."""
        if self.render_mode is None:
            return None
        if self.arena.state is None:
            raise RuntimeError("call reset() before render()")
        from nao_arena.render import Viewer, ViewerOptions

        if self._viewer is None:
            self._viewer = Viewer(
                ViewerOptions(size=self.options.render_size), human=self.render_mode == "human"
            )
        frame = self._viewer.draw(
            self.arena,
            selected=self._selected_robot(),
            controlled=self._controlled,
            result=self.last_result,
        )
        return frame if self.render_mode == "rgb_array" else None

    def close(self) -> None:
        """Close the viewer's window, if any."""
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None

    def __str__(self) -> str:
        return f"nao_arena({self.spec.name})"


def parallel_env(
    map: str | Path = "roundabout",  # noqa: A002 - the issue's public keyword
    render_mode: str | None = None,
    **kwargs: Any,
) -> NaoArenaParallelEnv:
    """The map's PettingZoo parallel env; keywords: :class:`EnvOptions` fields, ``options=``,
    ``map_params=``, and map parameters (see the module docstring)."""
    return NaoArenaParallelEnv(map, render_mode=render_mode, **kwargs)


def env(
    map: str | Path = "roundabout",  # noqa: A002 - the issue's public keyword
    render_mode: str | None = None,
    **kwargs: Any,
) -> AECEnv:
    """The AEC version of :func:`parallel_env` (PettingZoo's ``parallel_to_aec``)."""
    return parallel_to_aec(parallel_env(map, render_mode=render_mode, **kwargs))
