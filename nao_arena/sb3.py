"""Stable-Baselines3 with the versioned envs: one policy shared by every robot.

Needs the ``rl`` extra (stable-baselines3, supersuit, torch).

- :func:`vec_env`: copies of a versioned env as one SB3 vector env with an entry per
  controlled robot (SuperSuit), so every agent-step is one PPO timestep and all robots
  share the policy; optionally behind the NAO safety shield
  (:class:`nao_arena.shield.NAOShield`). Observations are scaled to [0, 1] by their
  bounds (``normalize_obs_v0``); on a map without walls the positions are bounded by
  ``position_margin`` (m) around the map's bounds.
- :class:`EpisodeRecorder`: an SB3 callback that records every finished agent-episode
  (return, goal reached, contacts, steps) and can stop training once the success over
  the last ``window`` agent-episodes reaches a target.
- :func:`train`: PPO with :data:`PPO_SETTINGS` and :data:`TRAINING_REWARDS` until a
  success target or a budget of agent-steps (:class:`Training`).
- :func:`learning_curve`: return, success and contacts over the training, per window of
  agent-episodes.
- :func:`evaluate`: a trained policy's success and contacts on fresh seeded episodes,
  with or without the shield.

An agent-episode is one robot's part of an env episode. It succeeds when the robot
reaches its goal before the time limit. Its contacts are the contact events the robot
started (``infos[agent]["collisions"]``, bodies and walls; a contact between two robots
counts for each of them).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import supersuit as ss
from gymnasium import spaces
from numpy.typing import NDArray
from pettingzoo.utils import BaseParallelWrapper
from stable_baselines3 import PPO
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecMonitor, VecNormalize

from nao_arena.env_options import RewardWeights
from nao_arena.envs import load
from nao_arena.vector import VectorEnv

__all__ = [
    "PPO_SETTINGS",
    "TRAINING_REWARDS",
    "AgentEpisode",
    "Curve",
    "EpisodeRecorder",
    "NaoVecEnv",
    "Evaluation",
    "Training",
    "decaying_learning_rate",
    "bounded_kwargs",
    "evaluate",
    "learning_curve",
    "parallel_env",
    "train",
    "vec_env",
]

TRAINING_REWARDS = RewardWeights(progress=3.0, accel_change=0.01)
"""The reward weights :func:`train` trains with: progress 3 per m (the env's default 1)
and the command's smoothness 0.01 (default 0.1); a contact and the goal keep their 10.
With the defaults, a whole crossing's progress (about 10 m) earns what one contact costs,
and the smoothness term of a policy that still explores (about 0.1 per step over 400 to
600 steps) outweighs both. Success and contacts are counted the same way whatever the
weights."""


def decaying_learning_rate(progress_remaining: float) -> float:
    """PPO's learning rate: 3e-4 at the start, falling linearly to 0 at the end of the
    budget of agent-steps (SB3 passes the share of the budget left, 1 -> 0)."""
    return 3e-4 * progress_remaining


PPO_SETTINGS: dict[str, Any] = {
    "n_steps": 256,
    "batch_size": 1024,
    "n_epochs": 10,
    "learning_rate": decaying_learning_rate,
    "gamma": 0.995,
    "gae_lambda": 0.95,
    "policy_kwargs": {"log_std_init": -0.5},
}
"""The keyword arguments of SB3's ``PPO`` that :func:`train` uses (with ``MlpPolicy`` on
the CPU). ``n_steps`` is per vector entry: a rollout holds ``n_steps`` x agents x copies
agent-steps. A crossing of ``crossing_v0`` takes about 110 control steps: ``gamma``
0.995 looks about 200 ahead. With a constant learning rate and ``gamma`` 0.99, the
policy for ``crossing_v0`` without the shield stalled below 90 % success in 3 million
agent-steps; with these settings it reached 95 % in 2.7 million."""

POSITION_MARGIN = 2.0
"""m: how far outside an open map's bounds an observed position may be (it is clipped
there), so that every observation has finite bounds to scale by."""


def parallel_env(env_id: str, shield: bool = False, **env_kwargs: Any) -> Any:
    """The parallel env ``env_id`` (a versioned env, e.g. ``"crowd_v0"``) with
    ``keep_finished=True`` (SuperSuit's vector env needs a fixed set of agents), finite
    observation bounds, optionally behind the NAO shield, with observations scaled to
    [0, 1]. ``env_kwargs``: :class:`nao_arena.env_options.EnvOptions` fields and map
    parameters."""
    par, _ = _bounded_env(env_id, env_kwargs)
    if shield:
        from nao_arena.shield import NAOShield

        par = NAOShield(par)
    return ss.normalize_obs_v0(_FinalInfos(par))


def bounded_kwargs(env_id: str, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` with ``keep_finished=True`` and, when the env's observations would
    have an infinite bound (an open map), ``position_margin`` :data:`POSITION_MARGIN`."""
    par, kwargs = _bounded_env(env_id, env_kwargs)
    par.close()
    return kwargs


def _bounded_env(env_id: str, env_kwargs: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """The parallel env of :func:`bounded_kwargs`' keywords, and those keywords (a second
    env is built only for an open map)."""
    kwargs = {"keep_finished": True, **env_kwargs}
    par = load(env_id).parallel_env(**kwargs)
    space = par.observation_space(par.possible_agents[0])
    if np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high)):
        return par, kwargs
    par.close()
    kwargs = {"position_margin": POSITION_MARGIN, **kwargs}
    return load(env_id).parallel_env(**kwargs), kwargs


class _FinalInfos(BaseParallelWrapper):
    """A parallel env whose ``reset`` returns empty infos. SuperSuit's vector env resets
    a finished episode inside the step that ends it and merges the reset's infos over
    that step's: the env's reset infos (``reached`` False, ``collisions`` 0) would hide
    whether each robot reached its goal and the contacts of the last step."""

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        obs, infos = self.env.reset(seed=seed, options=options)
        return obs, {agent: {} for agent in infos}


def vec_env(
    env_id: str,
    copies: int = 1,
    seed: int = 0,
    shield: bool = False,
    num_cpus: int = 0,
    backend: str = "supersuit",
    **env_kwargs: Any,
) -> VecEnv:
    """``copies`` copies of :func:`parallel_env` as one SB3 vector env with an entry per
    agent (entries ordered copy by copy, agents in ``possible_agents`` order), wrapped in
    ``VecMonitor``. Seeded with ``seed``: copy k starts with seed ``seed + k``, the later
    episodes' seeds come from generators seeded by it.

    ``backend``: ``"supersuit"`` (SuperSuit's vector env; ``num_cpus`` worker processes
    step the copies, 0: this process) or ``"vector"`` (:class:`NaoVecEnv` over
    :class:`nao_arena.vector.VectorEnv`: every copy in this process, several times
    faster; the same observations, rewards and dones, and SB3's ``TimeLimit.truncated``
    in the infos; no shield)."""
    if backend == "vector":
        if shield:
            raise ValueError("backend 'vector': the shield needs backend 'supersuit'")
        vector = VectorEnv(env_id, copies, seed=seed, **bounded_kwargs(env_id, env_kwargs))
        return VecMonitor(NaoVecEnv(vector, scale_observations=True))
    if backend != "supersuit":
        raise ValueError(f"backend: expected 'supersuit' or 'vector', got {backend!r}")
    vec = ss.pettingzoo_env_to_vec_env_v1(parallel_env(env_id, shield, **env_kwargs))
    vec = ss.concat_vec_envs_v1(vec, copies, num_cpus=num_cpus, base_class="stable_baselines3")
    with warnings.catch_warnings():  # SuperSuit's vector env has no render_mode
        warnings.filterwarnings("ignore", message="The `render_mode` attribute")
        seeded = _SeededVecEnv(vec)
        seeded.seed(seed)
        return VecMonitor(seeded)


class NaoVecEnv(VecEnv):
    """A :class:`nao_arena.vector.VectorEnv` as an SB3 vector env: one entry per robot
    (K x R entries, copy by copy, agents in order), all sharing one policy.

    Observations (K R, D) float32, scaled to [0, 1] by the observation bounds with
    ``scale_observations`` (SuperSuit's ``normalize_obs_v0`` arithmetic; the bounds must
    be finite); rewards float32. An entry is done when its copy's episode ends (every
    robot of a copy at once); its infos then hold ``terminal_observation`` and SB3's
    ``TimeLimit.truncated``; every step's infos hold ``reached``, ``collisions``,
    ``faults`` and ``finished``. ``seed(s)`` (what ``PPO(seed=s)`` calls) seeds the next
    reset: copy k with ``s + k``."""

    def __init__(self, vector: VectorEnv, scale_observations: bool = False) -> None:
        space = vector.single_observation_space
        self._low = space.low
        self._size = space.high - space.low
        self._scale = scale_observations
        if scale_observations:
            if not (np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))):
                raise ValueError(
                    "scale_observations: the observation bounds must be finite "
                    "(give position_margin on an open map)"
                )
            space = spaces.Box(np.float32(0.0), np.float32(1.0), space.shape, np.float32)
        super().__init__(vector.num_envs * vector.num_agents, space, vector.single_action_space)
        self.vector = vector
        self._shape = (vector.num_envs, vector.num_agents)
        self._actions: NDArray[np.float32] | None = None
        self._next_seed: int | None = None

    def _observations(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        flat = obs.reshape(self.num_envs, -1)
        if not self._scale:
            return flat
        scaled = (flat - self._low) / self._size * 1.0 + 0.0  # float32 throughout
        return cast(NDArray[np.float32], scaled)

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._next_seed = seed
        return [seed] * self.num_envs

    def reset(self) -> NDArray[np.float32]:
        obs, _ = self.vector.reset(seed=self._next_seed)
        self._next_seed = None
        self.reset_infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        return self._observations(obs)

    def step_async(self, actions: NDArray[np.float32]) -> None:
        self._actions = actions

    def step_wait(self) -> Any:
        assert self._actions is not None, "step_async() first"
        actions = np.asarray(self._actions).reshape(*self._shape, 2)
        obs, rewards, terminated, truncated, infos = self.vector.step(actions)
        dones = (terminated | truncated).reshape(-1)
        reached = infos["reached"].reshape(-1).tolist()
        collisions = infos["collisions"].reshape(-1).tolist()
        faults = infos["faults"].reshape(-1).tolist()
        finished = infos["finished"].reshape(-1).tolist()
        entries = [
            {"reached": r, "collisions": c, "faults": f, "finished": fin}
            for r, c, f, fin in zip(reached, collisions, faults, finished, strict=True)
        ]
        if "final_obs" in infos:
            final = self._observations(infos["final_obs"])
            cut = (truncated & ~terminated).reshape(-1).tolist()
            for i in np.flatnonzero(dones).tolist():
                entries[i]["terminal_observation"] = final[i]
                entries[i]["TimeLimit.truncated"] = cut[i]
        return self._observations(obs), rewards.reshape(-1).astype(np.float32), dones, entries

    def close(self) -> None:
        self.vector.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        value = None if attr_name == "render_mode" else getattr(self.vector, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        setattr(self.vector, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        result = getattr(self.vector, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


class _SeededVecEnv(VecEnvWrapper):
    """SuperSuit's SB3 vector env with SB3's seeding: ``seed(s)`` (what ``PPO(seed=s)``
    calls) seeds the next reset of the copies (SuperSuit's own wrapper has no ``seed``)."""

    def __init__(self, venv: VecEnv) -> None:
        super().__init__(venv)
        self._next_seed: int | None = None

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._next_seed = seed
        return [seed] * self.num_envs

    def reset(self) -> Any:
        if self._next_seed is None:
            return self.venv.reset()
        inner: Any = self.venv  # SuperSuit's SB3VecEnvWrapper over its ConcatVecEnv
        obs, inner.reset_infos = inner.venv.reset(seed=self._next_seed)
        self._next_seed = None
        return obs

    def step_wait(self) -> Any:
        return self.venv.step_wait()


@dataclass(frozen=True)
class AgentEpisode:
    """One finished agent-episode: ``timesteps``, the training's agent-steps when it
    ended; ``ret``, its return (the env's rewards, as ``VecMonitor`` sums them, not the
    scaled rewards the learner sees); ``reached``, whether the robot reached its goal;
    ``contacts``, the contact events it started; ``steps``, its control steps."""

    timesteps: int
    ret: float
    reached: bool
    contacts: int
    steps: int


class EpisodeRecorder(BaseCallback):
    """Records every finished agent-episode of the training (:class:`AgentEpisode`), in
    order, and counts the contact events of every agent-step. With ``target_success``,
    training stops once at least ``window`` agent-episodes have finished and the share
    of the last ``window`` that reached their goals is at least ``target_success``."""

    def __init__(self, target_success: float | None = None, window: int = 500) -> None:
        super().__init__()
        self.target_success = target_success
        self.window = window
        self.episodes: list[AgentEpisode] = []
        self.contacts = 0
        """Contact events over all agent-steps of the training so far."""
        self._ret: NDArray[np.float64] = np.zeros(0)
        self._contacts: NDArray[np.int64] = np.zeros(0, dtype=np.int64)
        self._steps: NDArray[np.int64] = np.zeros(0, dtype=np.int64)

    def _on_training_start(self) -> None:
        n = self.training_env.num_envs
        self._ret = np.zeros(n)
        self._contacts = np.zeros(n, dtype=np.int64)
        self._steps = np.zeros(n, dtype=np.int64)

    def _on_step(self) -> bool:
        infos: Sequence[dict[str, Any]] = self.locals["infos"]
        rewards = np.asarray(self.locals["rewards"], dtype=np.float64)
        dones = np.asarray(self.locals["dones"], dtype=bool)
        hits = np.fromiter((int(i.get("collisions", 0)) for i in infos), np.int64, len(infos))
        self.contacts += int(hits.sum())
        self._ret += rewards
        self._contacts += hits
        self._steps += 1
        for i in np.flatnonzero(dones).tolist():
            # VecMonitor's return is the env's; the callback's rewards are what the
            # learner sees (scaled, under VecNormalize)
            monitored = infos[i].get("episode")
            self.episodes.append(
                AgentEpisode(
                    timesteps=int(self.num_timesteps),
                    ret=float(monitored["r"]) if monitored else float(self._ret[i]),
                    reached=bool(infos[i].get("reached", False)),
                    contacts=int(self._contacts[i]),
                    steps=int(self._steps[i]),
                )
            )
            self._ret[i] = 0.0
            self._contacts[i] = 0
            self._steps[i] = 0
        return not self.target_reached()

    def success(self, last: int | None = None) -> float:
        """The share of the last ``last`` (default ``window``) agent-episodes that reached
        their goals (nan before any finished)."""
        recent = self.episodes[-(last or self.window) :]
        return sum(e.reached for e in recent) / len(recent) if recent else float("nan")

    def target_reached(self) -> bool:
        """Whether the success target is set and met (see the class)."""
        return (
            self.target_success is not None
            and len(self.episodes) >= self.window
            and self.success() >= self.target_success
        )


@dataclass(frozen=True)
class Evaluation:
    """A policy's figures over ``episodes`` env episodes (``agent_episodes`` robots'
    episodes in all): ``reached`` agent-episodes reached their goals, ``contacts``
    contact events in all, ``with_contact`` agent-episodes had at least one; ``steps``
    agent-steps; ``interventions`` agent-steps whose action the shield replaced and
    ``infeasible_contacts`` the contact events that began in a step in which the shield
    found no admissible acceleration for the robot (status ``infeasible``; both 0
    without the shield)."""

    episodes: int
    agent_episodes: int
    reached: int
    contacts: int
    with_contact: int
    steps: int
    interventions: int = 0
    infeasible_contacts: int = 0
    per_episode: list[dict[str, Any]] = field(default_factory=list)

    @property
    def success(self) -> float:
        """The share of agent-episodes that reached their goals."""
        return self.reached / self.agent_episodes if self.agent_episodes else float("nan")


def evaluate(
    model: BaseAlgorithm,
    env_id: str,
    episodes: int,
    seed: int,
    shield: bool = False,
    deterministic: bool = True,
    **env_kwargs: Any,
) -> Evaluation:
    """Run ``model`` (its actions for every robot at once) on ``episodes`` episodes of
    :func:`parallel_env` seeded ``seed``, ``seed + 1``, ...; figures per
    :class:`Evaluation`. With ``deterministic=False`` the actions are drawn from the
    policy's distribution, by torch's global generator, seeded here with ``seed``."""
    if not deterministic:
        import torch

        torch.manual_seed(seed)
    par = parallel_env(env_id, shield, **env_kwargs)
    agents = list(par.possible_agents)
    reached = contacts = with_contact = steps = interventions = infeasible_contacts = 0
    rows: list[dict[str, Any]] = []
    for k in range(episodes):
        obs, _ = par.reset(seed=seed + k)
        hits = dict.fromkeys(agents, 0)
        done_reached = dict.fromkeys(agents, False)
        finished = dict.fromkeys(agents, False)
        while par.agents:
            live = list(par.agents)
            actions, _ = model.predict(
                np.stack([obs[a] for a in live]), deterministic=deterministic
            )
            obs, _, _, _, infos = par.step(dict(zip(live, actions, strict=True)))
            for a in live:
                info = infos[a]
                steps += not finished[a]
                finished[a] = bool(info["finished"])
                hits[a] += int(info["collisions"])
                done_reached[a] = bool(info["reached"])
                shielded = info.get("shield", {})
                interventions += bool(shielded.get("intervened", False))
                if shielded.get("status") == "infeasible":
                    infeasible_contacts += int(info["collisions"])
        reached += sum(done_reached.values())
        contacts += sum(hits.values())
        with_contact += sum(h > 0 for h in hits.values())
        rows.append(
            {
                "seed": seed + k,
                "reached": sum(done_reached.values()),
                "contacts": sum(hits.values()),
            }
        )
    par.close()
    return Evaluation(
        episodes=episodes,
        agent_episodes=episodes * len(agents),
        reached=reached,
        contacts=contacts,
        with_contact=with_contact,
        steps=steps,
        interventions=interventions,
        infeasible_contacts=infeasible_contacts,
        per_episode=rows,
    )


@dataclass(frozen=True)
class Training:
    """What :func:`train` did: the trained ``model``; the finished agent-episodes
    (:class:`AgentEpisode`, in order); ``contacts``, the contact events of all its
    agent-steps; ``timesteps``, agent-steps; ``seconds``, wall-clock time (s);
    ``target_met``: the success target stopped it (else the budget did)."""

    model: PPO
    episodes: list[AgentEpisode]
    contacts: int
    timesteps: int
    seconds: float
    target_met: bool


def train(
    env_id: str,
    timesteps: int,
    shield: bool = False,
    seed: int = 0,
    copies: int = 2,
    num_cpus: int = 0,
    target_success: float | None = 0.9,
    window: int = 500,
    rewards: RewardWeights = TRAINING_REWARDS,
    on_progress: Callable[[EpisodeRecorder, int], None] | None = None,
    **env_kwargs: Any,
) -> Training:
    """Train one PPO policy shared by every robot of ``env_id`` (:func:`vec_env` with
    ``copies`` copies, optionally behind the shield), for at most ``timesteps``
    agent-steps, or until the success over the last ``window`` agent-episodes reaches
    ``target_success`` (checked every agent-step). Rewards are scaled by their running
    standard deviation (SB3's ``VecNormalize``, rewards only: the policy reads the raw
    scaled observations, so it needs nothing more to run). ``on_progress(recorder,
    timesteps)`` after every rollout."""
    vec = vec_env(env_id, copies, seed, shield, num_cpus, rewards=rewards, **env_kwargs)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="The `render_mode` attribute")
        scaled = VecNormalize(vec, norm_obs=False, norm_reward=True, gamma=PPO_SETTINGS["gamma"])
    model = PPO("MlpPolicy", scaled, device="cpu", verbose=0, seed=seed, **PPO_SETTINGS)
    recorder = EpisodeRecorder(target_success, window)
    callbacks: list[BaseCallback] = [recorder]
    if on_progress is not None:
        callbacks.append(_Progress(recorder, on_progress))
    started = time.perf_counter()
    model.learn(total_timesteps=timesteps, callback=callbacks)
    seconds = time.perf_counter() - started
    scaled.close()
    return Training(
        model=model,
        episodes=list(recorder.episodes),
        contacts=recorder.contacts,
        timesteps=int(model.num_timesteps),
        seconds=seconds,
        target_met=recorder.target_reached(),
    )


class _Progress(BaseCallback):
    """Calls ``report(recorder, timesteps)`` after every rollout."""

    def __init__(self, recorder: EpisodeRecorder, report: Callable[[EpisodeRecorder, int], None]):
        super().__init__()
        self.recorder = recorder
        self.report = report

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self.report(self.recorder, int(self.num_timesteps))


@dataclass(frozen=True)
class Curve:
    """A learning curve: per window of ``window`` consecutive agent-episodes (whole
    windows only), the agent-steps of training when its last episode ended, and its mean
    return, success share and mean contact events per agent-episode."""

    window: int
    timesteps: NDArray[np.int64]
    ret: NDArray[np.float64]
    success: NDArray[np.float64]
    contacts: NDArray[np.float64]


def learning_curve(episodes: Sequence[AgentEpisode], window: int) -> Curve:
    """:class:`Curve` of ``episodes`` (in the order they finished) in whole windows of
    ``window`` agent-episodes (the episodes after the last whole window are left out)."""
    if window < 1:
        raise ValueError(f"window: expected at least 1 agent-episode, got {window}")
    chunks = [episodes[i : i + window] for i in range(0, len(episodes) - window + 1, window)]
    return Curve(
        window=window,
        timesteps=np.array([c[-1].timesteps for c in chunks], dtype=np.int64),
        ret=np.array([np.mean([e.ret for e in c]) for c in chunks]),
        success=np.array([np.mean([e.reached for e in c]) for c in chunks]),
        contacts=np.array([np.mean([e.contacts for e in c]) for c in chunks]),
    )
