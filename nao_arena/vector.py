"""K copies of a versioned env stepped in one process, with arrays in and out.

``VectorEnv("circle_swap_v0", num_envs=64, seed=0)`` holds 64 copies of the env (each
with ``keep_finished=True``: every robot stays an agent until its episode ends) and
steps them all with one call:

- ``reset(seed)`` returns observations (K, R, D) float32 and infos; copy k starts with
  seed ``seed + k``, and each later episode of a copy with a seed drawn from that copy's
  generator (:meth:`nao_arena.environment.NaoArenaParallelEnv.reset`).
- ``step(actions)`` takes normalized accelerations (K, R, 2) (R agents per copy, in
  ``agents`` order) and returns observations (K, R, D), rewards (K, R), terminated and
  truncated (K, R) and infos, a dict of arrays: ``reached``, ``collisions``, ``faults``,
  ``finished`` (K, R) as each copy's infos hold them, and ``time`` (K,) s.
- Auto-reset in the same step (Gymnasium's ``AutoresetMode.SAME_STEP``): a copy whose
  episode ends is reset at once; its row of the returned observations is the new
  episode's first, and ``infos["final_obs"]`` (K, R, D) holds the last observations of
  the episode that ended, for the copies that ``infos["_final_obs"]`` (K,) marks. The
  infos of the ending step (``reached``, ...) are those of the episode that ended.

The copies whose period no agent acts in (see :mod:`nao_arena.vector_step`) run it
together in one compiled call; the others take the env's own step
(:meth:`~nao_arena.environment.NaoArenaParallelEnv.step_arrays`). Both run the same
kernels in the same order, so the results are those of K separate envs stepped with the
same actions, bit for bit. A copy's objects (``envs[k]``) take the batched periods when
they are read. Stable-Baselines3 takes the vector env through
:class:`nao_arena.sb3.NaoVecEnv` (one SB3 entry per robot).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode
from numpy.typing import ArrayLike, NDArray

from nao_arena.environment import NaoArenaParallelEnv
from nao_arena.envs import load
from nao_arena.kernels import ensure_env_compiled
from nao_arena.vector_step import CopyBatch, CopyOutputs
from nao_arena.world import PeriodArrays

__all__ = ["VectorEnv"]

_INFOS = ("reached", "collisions", "faults", "finished", "time")
"""The step's infos (K, R) (``time``: (K,))."""
_ROWS = ("observations", "rewards", "terminated", "truncated", *_INFOS)
"""What a copy's own step (:class:`~nao_arena.env_step.StepArrays`) gives row by row."""


class VectorEnv:
    """``num_envs`` copies of the versioned env ``env_id`` (see the module docstring);
    ``env_kwargs``: :class:`~nao_arena.env_options.EnvOptions` fields and map parameters,
    the same for every copy (``keep_finished`` is always True)."""

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self, env_id: str, num_envs: int, seed: int | None = None, **env_kwargs: Any
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer):
            raise ValueError(f"num_envs: expected a positive integer, got {num_envs!r}")
        if num_envs < 1:
            raise ValueError(f"num_envs: expected a positive integer, got {num_envs}")
        if env_kwargs.get("keep_finished") is False:
            raise ValueError("keep_finished: a vector env keeps every agent until the end")
        module = load(env_id)
        ensure_env_compiled(module.MAP, vector=True)
        make = module.parallel_env
        envs = [make(**{**env_kwargs, "keep_finished": True}) for _ in range(int(num_envs))]
        self._setup(env_id, envs, seed)

    @classmethod
    def of_envs(cls, envs: list[NaoArenaParallelEnv], seed: int | None = None) -> VectorEnv:
        """A vector env of the given envs, made alike (the same map, map parameters and
        options, with ``keep_finished=True``), named after their map: an env of a map
        file, or with options no versioned env has; ValueError otherwise."""
        if not envs:
            raise ValueError("envs: expected at least one env")
        first = envs[0]
        if not first.options.keep_finished:
            raise ValueError("envs: expected envs with keep_finished=True")
        for env in envs[1:]:
            if (env.map_source, env.map_params, env.options) != (
                first.map_source,
                first.map_params,
                first.options,
            ):
                raise ValueError("envs: expected envs of the same map, map parameters and options")
        ensure_env_compiled(first.map_source, vector=True)  # the batch's kernels, ahead
        vec = cls.__new__(cls)
        vec._setup(str(first.map_source), envs, seed)
        return vec

    def _setup(self, env_id: str, envs: list[NaoArenaParallelEnv], seed: int | None) -> None:
        self._envs = envs
        first = envs[0]
        self.env_id = env_id
        self.num_envs = len(envs)
        self.agents: list[str] = list(first.possible_agents)
        """The agents of each copy (R), in the order of every (K, R, ...) array."""
        self.num_agents = len(self.agents)
        self.single_observation_space: spaces.Box = first.observation_space(self.agents[0])
        self.single_action_space: spaces.Box = first.action_space(self.agents[0])
        shape = (self.num_envs, self.num_agents)
        low, high = self.single_observation_space.low, self.single_observation_space.high
        self.observation_space = spaces.Box(
            np.broadcast_to(low, (*shape, *low.shape)),
            np.broadcast_to(high, (*shape, *high.shape)),
            dtype=np.float32,
        )
        self.action_space = spaces.Box(-1.0, 1.0, shape=(*shape, 2), dtype=np.float32)
        self._seed = seed
        self._batch: CopyBatch | None = None

    @property
    def envs(self) -> list[NaoArenaParallelEnv]:
        """The copies (each an env of its own, its objects up to date when read)."""
        if self._batch is not None:
            self._batch.sync_all()
        return self._envs

    def reset(
        self, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Start an episode in every copy: copy k with seed ``seed + k`` (``seed`` None:
        the constructor's seed, if any; else each copy draws its own). ``options`` is
        accepted for API compatibility and ignored."""
        if seed is None and self._batch is None:
            seed = self._seed
        obs = np.empty(self.observation_space.shape, dtype=np.float32)
        for k, env in enumerate(self._envs):
            first, _ = env.reset(seed=None if seed is None else int(seed) + k)
            obs[k] = [first[a] for a in self.agents]
        self._batch = CopyBatch(self._envs)
        zeros = np.zeros((self.num_envs, self.num_agents), dtype=np.int64)
        infos = {
            "reached": zeros.astype(bool),
            "collisions": zeros,
            "faults": zeros.copy(),
            "finished": zeros.astype(bool),
            "time": np.zeros(self.num_envs),
        }
        return obs, infos

    def step(
        self, actions: ArrayLike
    ) -> tuple[
        NDArray[np.float32],
        NDArray[np.float64],
        NDArray[np.bool_],
        NDArray[np.bool_],
        dict[str, Any],
    ]:
        """One control period of every copy with ``actions`` (K, R, 2): finite normalized
        accelerations, clipped to [-1, 1]. Returns observations, rewards, terminated,
        truncated and infos (see the module docstring)."""
        batch = self._batch
        if batch is None:
            raise RuntimeError("call reset() before step()")
        shape = (self.num_envs, self.num_agents, 2)
        cmd = np.asarray(actions, dtype=np.float64)
        if cmd.shape != shape:
            raise ValueError(f"actions: expected shape {shape}, got {cmd.shape}")
        if not np.isfinite(cmd).all():
            raise ValueError("actions: expected finite numbers, got NaN or inf")
        cmd = np.clip(cmd, -1.0, 1.0)
        out = self._outputs()
        batched = batch.runnable()
        own = np.ones(self.num_envs, dtype=bool)
        own[batched] = False
        own_steps = np.flatnonzero(own).tolist()
        for k in own_steps:  # before the batch replaces its last outputs
            batch.sync(k)
        ended = np.zeros(self.num_envs, dtype=bool)
        if len(batched):
            batch.step(batched, cmd, out)
            ended[batched] = out.ended[batched]
        for k in own_steps:
            env = self._envs[k]
            arrays = env._step_clipped(cmd[k])
            for name in _ROWS:
                getattr(out, name)[k] = getattr(arrays, name)
            ended[k] = not env.agents
            if batch.batchable[k]:
                batch.load(k)
        obs = out.observations
        infos: dict[str, Any] = {name: getattr(out, name) for name in _INFOS}
        if ended.any():
            final = np.zeros_like(obs)
            final[ended] = obs[ended]
            for k in np.flatnonzero(ended).tolist():
                first, _ = self._envs[k].reset()
                obs[k] = [first[a] for a in self.agents]
                batch.restart(k)
            infos["final_obs"] = final
            infos["_final_obs"] = ended
        return obs, out.rewards, out.terminated, out.truncated, infos

    def _outputs(self) -> CopyOutputs:
        """New arrays for a step's results (:class:`~nao_arena.vector_step.CopyOutputs`)."""
        k_envs, r = self.num_envs, self.num_agents
        world = self._envs[0].arena.world
        n, substeps = world.n, world.substeps
        path = np.empty((k_envs, substeps + 1, n, 2))
        path_read_only = path.view()
        path_read_only.setflags(write=False)
        events = np.zeros((2, k_envs), dtype=np.int64)
        return CopyOutputs(
            period=PeriodArrays(
                path,
                np.empty((k_envs, n, 2)),
                np.empty((k_envs, n, 2)),
                np.empty((k_envs, n, 2)),
                np.empty((k_envs, n, 2)),
            ),
            path_read_only=path_read_only,
            observations=np.empty(self.observation_space.shape, dtype=np.float32),
            rewards=np.empty((k_envs, r)),
            terminated=np.empty((k_envs, r), dtype=bool),
            truncated=np.empty((k_envs, r), dtype=bool),
            reached=np.empty((k_envs, r), dtype=bool),
            collisions=np.empty((k_envs, r), dtype=np.int64),
            faults=np.empty((k_envs, r), dtype=np.int64),
            finished=np.empty((k_envs, r), dtype=bool),
            time=np.empty(k_envs),
            ended=np.zeros(k_envs, dtype=bool),
            event_start=events[0],
            event_count=events[1],
        )

    def close(self) -> None:
        """Close every copy."""
        for env in self._envs:
            env.close()

    def __repr__(self) -> str:
        return f"VectorEnv({self.env_id!r}, num_envs={self.num_envs})"
