"""The single-robot Gymnasium env (:class:`nao_arena.envs.SingleRobotEnv`): registered for every
versioned env, passes Gymnasium's checker, and is exactly the parallel env with that one
robot controlled."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from nao_arena.environment import parallel_env
from nao_arena.envs import SingleRobotEnv, available
from nao_arena.envs._single import gymnasium_id


def test_every_versioned_env_is_registered_with_gymnasium():
    for name in available():
        assert gymnasium_id(name) in gymnasium.registry, name
    assert gymnasium_id("dense_swap_v1") == "nao_arena/dense_swap-v1"


def test_gymnasiums_checker_passes_among_an_orca_crowd():
    env = gymnasium.make("nao_arena/crossing-v0", agent="orca", position_margin=5.0)
    inner = env.unwrapped
    assert isinstance(inner, SingleRobotEnv)
    check_env(inner, skip_render_check=True)
    others = [n for k, n in enumerate(inner.par.arena.agent_names) if k != 0]
    assert others and set(others) == {"orca"}


def test_it_is_the_parallel_env_with_one_robot_controlled():
    """Same seed, same actions: the same observations, rewards and ends as the parallel env
    with ``controlled=[robot]`` (an independent run of the same loop)."""
    single = SingleRobotEnv("circle_swap", robot="swap2", n=6)
    par = parallel_env("circle_swap", controlled=["swap2"], n=6)
    rng = np.random.default_rng(7)
    obs, _ = single.reset(seed=11)
    pobs, _ = par.reset(seed=11)
    np.testing.assert_array_equal(obs, pobs["swap2"])
    for _ in range(1000):
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        obs, reward, term, trunc, info = single.step(action)
        pobs, prew, pterm, ptrunc, pinfo = par.step({"swap2": action})
        np.testing.assert_array_equal(obs, pobs["swap2"])
        assert (reward, term, trunc, info) == (
            prew["swap2"],
            pterm["swap2"],
            ptrunc["swap2"],
            pinfo["swap2"],
        )
        if term or trunc:
            break
    assert term or trunc
    with pytest.raises(RuntimeError, match="call reset"):
        single.step(np.zeros(2, dtype=np.float32))
    # and again from the same seed: the same episode
    again, _ = single.reset(seed=11)
    first, _ = SingleRobotEnv("circle_swap", robot="swap2", n=6).reset(seed=11)
    np.testing.assert_array_equal(again, first)


def test_one_robot_only():
    with pytest.raises(TypeError, match="give robot=NAME"):
        SingleRobotEnv("crossing", controlled="all")
