"""nao_arena.sb3: the SB3 vector env seeds through SB3, its infos keep each robot's last
step, the episode recorder agrees with an independent tally on the bare env, the success
target stops training, and ``evaluate`` counts what the env reports.

These tests need the ``rl`` extra (stable-baselines3, with torch) and are skipped without
it, unless NAO_ARENA_REQUIRE_RL=1 (set by .ci/run, which installs the extra).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pytest

if os.environ.get("NAO_ARENA_REQUIRE_RL") != "1":
    pytest.importorskip("stable_baselines3", reason="needs the rl extra")

from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize

from nao_arena.envs import crowd_v0
from nao_arena.sb3 import (
    AgentEpisode,
    EpisodeRecorder,
    evaluate,
    learning_curve,
    parallel_env,
    vec_env,
)

SMALL: dict[str, Any] = {"n": 3, "lo": -3.0, "hi": 3.0, "time_limit": 6.0}
"""A small crowd: 3 robots in a walled 6 m square, 60 control steps per episode."""


def seek(base: Any) -> np.ndarray:
    """Normalized accelerations that drive every controlled robot of the bare env ``base``
    towards its goal (read from the arena's true state, not from observations)."""
    state = base.arena.state
    pos = state.positions[base._bodies]
    vel = state.velocities[base._bodies]
    to_goal = base._goals - pos
    dist = np.hypot(*to_goal.T)[:, None]
    want = to_goal / np.maximum(dist, 1e-9) * np.minimum(1.4, dist)
    return np.clip((want - vel) / 0.5, -1.0, 1.0)


def bare_of(vec: Any) -> Any:
    """The nao_arena env under a one-copy :func:`vec_env` stepped in this process."""
    concat = vec.venv.venv.venv  # VecMonitor -> seeded -> SuperSuit SB3 -> ConcatVecEnv
    return concat.vec_envs[0].par_env.unwrapped


def tally(episodes: int, seed: int, **kwargs: Any) -> list[tuple[bool, int, float]]:
    """Per agent-episode (reached, contacts, return) of the bare env driven by
    :func:`seek`, episode after episode as SuperSuit's vector env resets it."""
    par = crowd_v0.parallel_env(keep_finished=True, **kwargs)
    out: list[tuple[bool, int, float]] = []
    for k in range(episodes):
        par.reset(seed=seed if k == 0 else None)
        agents = list(par.possible_agents)
        reached = dict.fromkeys(agents, False)
        hits = dict.fromkeys(agents, 0)
        ret = dict.fromkeys(agents, 0.0)
        while par.agents:
            acts = seek(par)
            _, rew, _, _, infos = par.step(dict(zip(agents, acts, strict=True)))
            for a in agents:
                reached[a] |= bool(infos[a]["reached"])
                hits[a] += int(infos[a]["collisions"])
                ret[a] += float(rew[a])
        out += [(reached[a], hits[a], ret[a]) for a in agents]
    return out


@pytest.mark.filterwarnings("ignore:The `render_mode` attribute")  # SuperSuit has none
def test_recorder_matches_an_independent_tally_of_the_bare_env():
    short = {**SMALL, "n": 5, "time_limit": 4.0}  # some robots miss their goals
    monitored = vec_env("crowd_v0", seed=7, **short)
    # as train() runs it: the learner sees scaled rewards, the recorder the env's
    vec = VecNormalize(monitored, norm_obs=False, norm_reward=True)
    model = PPO("MlpPolicy", vec, n_steps=8, batch_size=8, seed=0, device="cpu")
    rec = EpisodeRecorder()
    rec.init_callback(model)
    vec.seed(7)
    vec.reset()
    rec.on_training_start({}, {})
    episodes = 4
    base = bare_of(monitored)
    while len(rec.episodes) < episodes * 5:
        acts = seek(base)
        _, rewards, dones, infos = vec.step(acts)
        model.num_timesteps += vec.num_envs
        rec.update_locals({"infos": infos, "rewards": rewards, "dones": dones})
        rec.on_step()
    vec.close()
    got = [(e.reached, e.contacts, e.ret) for e in rec.episodes]
    want = tally(episodes, seed=7, **short)
    assert [g[:2] for g in got] == [w[:2] for w in want]
    np.testing.assert_allclose([g[2] for g in got], [w[2] for w in want], rtol=1e-5, atol=1e-4)
    assert any(w[0] for w in want) and not all(w[0] for w in want)  # both outcomes occur
    assert rec.contacts == sum(w[1] for w in want) > 0
    assert all(1 <= e.steps <= 40 for e in rec.episodes)


def test_the_last_step_keeps_its_infos():
    """SuperSuit resets inside the step that ends an episode: the reached flags of that
    step must survive (the env's own reset infos say reached False)."""
    vec = vec_env("crowd_v0", seed=3, **SMALL)
    vec.reset()
    base = bare_of(vec)
    while True:
        _, _, dones, infos = vec.step(seek(base))
        if dones.any():
            break
    assert all("terminal_observation" in i for i in infos)
    assert all(i["reached"] for i in infos)  # seek reaches every goal of seed 3
    vec.close()


def params_after(seed: int) -> np.ndarray:
    vec = vec_env("crowd_v0", **SMALL)
    model = PPO("MlpPolicy", vec, n_steps=16, batch_size=16, n_epochs=1, seed=seed, device="cpu")
    model.learn(96)
    vec.close()
    return np.concatenate([p.detach().numpy().ravel() for p in model.policy.parameters()])


def test_ppo_seed_seeds_the_envs():
    """``PPO(seed=s)`` works (SuperSuit's own wrapper has no ``seed``) and gives the same
    training twice; another seed gives another."""
    a, b, c = params_after(1), params_after(1), params_after(2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_success_target_stops_training():
    vec = vec_env("crowd_v0", seed=0, **SMALL)
    model = PPO("MlpPolicy", vec, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu")
    rec = EpisodeRecorder(target_success=0.0, window=1)
    model.learn(10_000, callback=rec)
    vec.close()
    # the first episode ends at the time limit (60 steps x 3 agents): training stops there
    assert 180 <= model.num_timesteps < 10_000
    assert len(rec.episodes) == 3 and rec.target_reached()
    assert EpisodeRecorder(target_success=1.01, window=1).target_reached() is False


class Standing:
    """A policy that commands no acceleration."""

    def predict(self, obs: np.ndarray, deterministic: bool = True) -> tuple[np.ndarray, None]:
        return np.zeros((len(obs), 2), dtype=np.float32), None


class Greedy:
    """A policy of the normalized observations: accelerate along the goal direction."""

    def predict(self, obs: np.ndarray, deterministic: bool = True) -> tuple[np.ndarray, None]:
        goal = obs[:, 0:2] - 0.5  # goal_dx, goal_dy scaled to [0, 1] by symmetric bounds
        vel = obs[:, 2:4] - 0.5
        return np.clip(8.0 * goal - 4.0 * vel, -1.0, 1.0), None


def test_evaluate_counts_standing_robots():
    ev = evaluate(Standing(), "crowd_v0", 2, seed=5, **SMALL)
    assert (ev.episodes, ev.agent_episodes, ev.reached, ev.contacts) == (2, 6, 0, 0)
    assert ev.steps == 2 * 3 * 60 and ev.success == 0.0


def test_evaluate_agrees_with_a_loop_over_the_same_env():
    ev = evaluate(Greedy(), "crowd_v0", 3, seed=11, **SMALL)
    par = parallel_env("crowd_v0", **SMALL)
    reached = contacts = steps = 0
    for k in range(3):
        obs, _ = par.reset(seed=11 + k)
        done: dict[str, bool] = {}
        was_finished = dict.fromkeys(par.possible_agents, False)
        while par.agents:
            live = list(par.agents)
            acts, _ = Greedy().predict(np.stack([obs[a] for a in live]))
            obs, _, _, _, infos = par.step(dict(zip(live, acts, strict=True)))
            for a in live:
                steps += not was_finished[a]
                was_finished[a] = infos[a]["finished"]
                contacts += infos[a]["collisions"]
                done[a] = infos[a]["reached"]
        reached += sum(done.values())
    assert (ev.reached, ev.contacts, ev.steps) == (reached, contacts, steps)
    assert ev.reached > 0


def test_shielded_evaluation_counts_interventions_and_infeasible_contacts():
    ev = evaluate(Greedy(), "crowd_v0", 2, seed=0, shield=True, **SMALL)
    par = parallel_env("crowd_v0", shield=True, **SMALL)
    replaced = infeasible = 0
    for k in range(2):
        obs, _ = par.reset(seed=k)
        while par.agents:
            live = list(par.agents)
            acts, _ = Greedy().predict(np.stack([obs[a] for a in live]))
            obs, _, _, _, infos = par.step(dict(zip(live, acts, strict=True)))
            for a in live:
                replaced += infos[a]["shield"]["intervened"]
                if infos[a]["shield"]["status"] == "infeasible":
                    infeasible += infos[a]["collisions"]
    assert (ev.interventions, ev.infeasible_contacts) == (replaced, infeasible)
    assert 0 < ev.interventions <= ev.steps and ev.infeasible_contacts <= ev.contacts
    plain = evaluate(Greedy(), "crowd_v0", 2, seed=0, **SMALL)
    assert plain.interventions == plain.infeasible_contacts == 0


def test_learning_curve_takes_whole_windows():
    eps = [AgentEpisode(10 * (i + 1), float(i), i % 3 == 0, i % 2, 5) for i in range(7)]
    curve = learning_curve(eps, 3)
    assert curve.window == 3
    assert curve.timesteps.tolist() == [30, 60]  # the 7th episode is left out
    np.testing.assert_allclose(curve.ret, [1.0, 4.0])
    np.testing.assert_allclose(curve.success, [1 / 3, 1 / 3])
    np.testing.assert_allclose(curve.contacts, [1 / 3, 2 / 3])
    assert learning_curve(eps[:2], 3).timesteps.size == 0
    with pytest.raises(ValueError, match="window: expected at least 1"):
        learning_curve(eps, 0)


def test_stochastic_evaluation_repeats_with_its_seed():
    vec = vec_env("crowd_v0", **SMALL)
    model = PPO("MlpPolicy", vec, n_steps=16, batch_size=16, seed=0, device="cpu")
    vec.close()
    runs = [evaluate(model, "crowd_v0", 2, seed=4, deterministic=False, **SMALL) for _ in "ab"]
    assert runs[0] == runs[1]
    assert runs[0].per_episode[0]["seed"] == 4
