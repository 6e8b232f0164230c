"""The RL libraries run nao_arena's envs unchanged: TorchRL, RLlib and BenchMARL (the
rl extra; Stable-Baselines3 and SuperSuit are in tests/test_env_rl.py and
tests/test_train_example.py, a plain loop in tests/test_env.py).

Each library's tests skip without it, unless ``NAO_ARENA_REQUIRE_RL=1`` (set by .ci/run,
which installs the extra): then a missing library fails them.
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

import numpy as np
import pytest

import nao_arena
from nao_arena.envs import available


def need(module: str) -> ModuleType:
    """``module``, imported; skip without it (fail if NAO_ARENA_REQUIRE_RL=1)."""
    if os.environ.get("NAO_ARENA_REQUIRE_RL") == "1":
        return importlib.import_module(module)
    return pytest.importorskip(module, reason=f"{module} is in the rl extra")


# --------------------------------------------------------------------------- TorchRL


def test_torchrl_groups_the_robots_of_each_stream_and_checks_its_specs():
    need("torchrl")
    from torchrl.envs import PettingZooWrapper
    from torchrl.envs.utils import check_env_specs

    par = nao_arena.parallel_env("crossing", agent_names="grouped")
    env = PettingZooWrapper(par, use_mask=True)
    assert env.group_map == {
        "east": [f"east_{k}" for k in range(6)],
        "north": [f"north_{k}" for k in range(6)],
    }
    check_env_specs(env)


def test_torchrl_rollout_stacks_observations_rewards_and_infos():
    torch = need("torch")
    need("torchrl")
    from torchrl.envs import PettingZooWrapper

    env = PettingZooWrapper(
        nao_arena.parallel_env("crossing", agent_names="grouped"), use_mask=True
    )
    torch.manual_seed(0)
    td = env.rollout(20)
    assert td.batch_size == (20,)
    for group in ("east", "north"):
        assert td[group, "observation"].shape == (20, 6, 70)
        assert td["next", group, "reward"].shape == (20, 6, 1)
        info = td["next", group, "info"]
        assert set(info.keys()) == {"collisions", "faults", "reached", "time"}
        # the infos' time is the arena's, one control period (0.1 s) per step
        np.testing.assert_allclose(info["time"][:, 0].numpy(), 0.1 * np.arange(1, 21), atol=1e-5)


def test_torchrl_keep_finished_needs_no_mask_and_repeats_with_the_seed():
    torch = need("torch")
    need("torchrl")
    from torchrl.envs import PettingZooWrapper
    from torchrl.envs.utils import check_env_specs

    def rollout():
        par = nao_arena.parallel_env("crossing", n=2, agent_names="grouped", keep_finished=True)
        env = PettingZooWrapper(par, seed=3)
        check_env_specs(env)
        torch.manual_seed(0)
        return env.rollout(15)

    first, second = rollout(), rollout()
    assert "finished" in first["next", "east", "info"].keys()
    assert torch.equal(first["next", "east", "observation"], second["next", "east", "observation"])
    assert torch.equal(first["next", "north", "reward"], second["next", "north", "reward"])


# --------------------------------------------------------------------------- RLlib


def _rllib_env(config=None):
    need("ray.rllib")
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    return ParallelPettingZooEnv(nao_arena.parallel_env("crossing", n=2, time_limit=3.0))


def test_rllib_wrapper_steps_as_the_env_does():
    env = _rllib_env()
    par = nao_arena.parallel_env("crossing", n=2, time_limit=3.0)
    obs, _ = env.reset(seed=1)
    ref, _ = par.reset(seed=1)
    assert set(obs) == set(ref) == {"east0", "east1", "north0", "north1"}
    for step in range(40):
        actions = {a: np.array([np.cos(step), np.sin(step)], dtype=np.float32) for a in par.agents}
        obs, rew, term, trunc, _ = env.step(actions)
        ref, ref_rew, *_ = par.step(actions)
        for a in ref:
            np.testing.assert_array_equal(obs[a], ref[a])
            assert rew[a] == ref_rew[a]
        if trunc["__all__"] or term["__all__"]:
            break
    assert trunc["__all__"] or term["__all__"]  # the 3 s limit is 30 steps


@pytest.mark.slow
def test_rllib_ppo_trains_a_shared_policy_for_one_iteration():
    ray = need("ray")
    _rllib_env()
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.tune.registry import register_env

    register_env("nao_arena_crossing", _rllib_env)
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False, ignore_reinit_error=True)
    try:
        config = (
            PPOConfig()
            .environment("nao_arena_crossing")
            .multi_agent(policies={"shared"}, policy_mapping_fn=lambda *a, **k: "shared")
            .env_runners(num_env_runners=0)
            .training(train_batch_size=200, minibatch_size=50, num_epochs=1)
            .debugging(seed=0)
        )
        algo = config.build_algo()
        try:
            result = algo.train()
        finally:
            algo.stop()
    finally:
        ray.shutdown()
    sampled = result["env_runners"]["num_agent_steps_sampled"]
    assert set(sampled) == {"east0", "east1", "north0", "north1"}
    assert all(int(n) > 0 for n in sampled.values())


# --------------------------------------------------------------------------- BenchMARL


def _benchmarl():
    need("benchmarl")
    from nao_arena import benchmarl as tasks

    return tasks


def test_benchmarl_has_a_task_per_versioned_env():
    tasks = _benchmarl()
    assert sorted(t.name.lower() for t in tasks.NaoArenaTask) == available()


def test_benchmarl_task_builds_grouped_envs_with_state():
    tasks = _benchmarl()
    task = tasks.NaoArenaTask.CROSSING_V0.get_task(config={"n": 2})
    env = task.get_env_fun(num_envs=1, continuous_actions=True, seed=0, device="cpu")()
    assert task.group_map(env) == {"east": ["east_0", "east_1"], "north": ["north_0", "north_1"]}
    assert task.max_steps(env) == nao_arena.parallel_env("crossing").max_steps
    assert "state" in task.state_spec(env).keys()
    assert set(task.observation_spec(env)["east"].keys()) == {"observation"}
    with pytest.raises(ValueError, match="continuous"):
        task.get_env_fun(num_envs=1, continuous_actions=False, seed=0, device="cpu")


@pytest.mark.slow
def test_benchmarl_mappo_runs_an_iteration(tmp_path):
    tasks = _benchmarl()
    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig

    config = ExperimentConfig.get_from_yaml()
    config.max_n_iters = 1
    config.on_policy_collected_frames_per_batch = 60
    config.on_policy_n_envs_per_worker = 1
    config.on_policy_n_minibatch_iters = 1
    config.on_policy_minibatch_size = 30
    config.evaluation = False
    config.loggers = []
    config.create_json = False
    config.save_folder = str(tmp_path)
    config.checkpoint_at_end = False
    config.sampling_device = config.train_device = config.buffer_device = "cpu"
    experiment = Experiment(
        task=tasks.NaoArenaTask.CROSSING_V0.get_task(config={"n": 2, "time_limit": 3.0}),
        algorithm_config=MappoConfig.get_from_yaml(),
        model_config=MlpConfig.get_from_yaml(),
        seed=0,
        config=config,
    )
    experiment.run()
    assert experiment.n_iters_performed == 1
    assert experiment.total_frames == 60
