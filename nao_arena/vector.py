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

Every copy runs the env's own step (:meth:`~nao_arena.environment.NaoArenaParallelEnv.step_arrays`:
the compiled physics period, contact statistics, rewards and observations), so the
results are those of K separate envs stepped with the same actions, bit for bit; the
vector env only saves the dicts and the per-agent bookkeeping. Stable-Baselines3 takes it
through :class:`nao_arena.sb3.NaoVecEnv` (one SB3 entry per robot).
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

__all__ = ["VectorEnv"]


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
        make = load(env_id).parallel_env
        self.envs: list[NaoArenaParallelEnv] = [
            make(**{**env_kwargs, "keep_finished": True}) for _ in range(int(num_envs))
        ]
        first = self.envs[0]
        self.env_id = env_id
        self.num_envs = len(self.envs)
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
        self._started = False

    def reset(
        self, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Start an episode in every copy: copy k with seed ``seed + k`` (``seed`` None:
        the constructor's seed, if any; else each copy draws its own). ``options`` is
        accepted for API compatibility and ignored."""
        if seed is None and not self._started:
            seed = self._seed
        self._started = True
        obs = np.empty(self.observation_space.shape, dtype=np.float32)
        for k, env in enumerate(self.envs):
            first, _ = env.reset(seed=None if seed is None else int(seed) + k)
            obs[k] = [first[a] for a in self.agents]
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
        if not self._started:
            raise RuntimeError("call reset() before step()")
        shape = (self.num_envs, self.num_agents, 2)
        cmd = np.asarray(actions, dtype=np.float64)
        if cmd.shape != shape:
            raise ValueError(f"actions: expected shape {shape}, got {cmd.shape}")
        if not np.isfinite(cmd).all():
            raise ValueError("actions: expected finite numbers, got NaN or inf")
        cmd = np.clip(cmd, -1.0, 1.0)
        k_envs, r = self.num_envs, self.num_agents
        obs = np.empty(self.observation_space.shape, dtype=np.float32)
        rewards = np.empty((k_envs, r))
        terminated = np.empty((k_envs, r), dtype=bool)
        truncated = np.empty((k_envs, r), dtype=bool)
        reached = np.empty((k_envs, r), dtype=bool)
        collisions = np.empty((k_envs, r), dtype=np.int64)
        faults = np.empty((k_envs, r), dtype=np.int64)
        finished = np.empty((k_envs, r), dtype=bool)
        times = np.empty(k_envs)
        ended: list[int] = []
        for k, env in enumerate(self.envs):
            out = env._step_clipped(cmd[k])
            obs[k] = out.observations
            rewards[k] = out.rewards
            terminated[k] = out.terminated
            truncated[k] = out.truncated
            reached[k] = out.reached
            collisions[k] = out.collisions
            faults[k] = out.faults
            finished[k] = out.finished
            times[k] = out.time
            if not env.agents:
                ended.append(k)
        infos: dict[str, Any] = {
            "reached": reached,
            "collisions": collisions,
            "faults": faults,
            "finished": finished,
            "time": times,
        }
        if ended:
            final = np.zeros_like(obs)
            mask = np.zeros(k_envs, dtype=bool)
            for k in ended:
                final[k] = obs[k]
                mask[k] = True
                first, _ = self.envs[k].reset()
                obs[k] = [first[a] for a in self.agents]
            infos["final_obs"] = final
            infos["_final_obs"] = mask
        return obs, rewards, terminated, truncated, infos

    def close(self) -> None:
        """Close every copy."""
        for env in self.envs:
            env.close()

    def __repr__(self) -> str:
        return f"VectorEnv({self.env_id!r}, num_envs={self.num_envs})"
