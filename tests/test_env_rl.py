"""The PettingZoo env with the tools RL users use: copies and pickles that continue bit for
bit, agents kept live until the episode ends, finite observation bounds, SuperSuit's vector
envs and wrappers, the versioned envs of :mod:`nao_arena.envs`."""

from __future__ import annotations

import copy
import json
import os
import pickle
import re
import warnings
from pathlib import Path

import cloudpickle
import gymnasium
import numpy as np
import pytest
import supersuit as ss
import yaml
from bitwise import same  # tests/bitwise.py
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

from nao_arena.environment import (
    NEIGHBOUR_FEATURES,
    OWN_FEATURES,
    EnvOptions,
    RewardWeights,
    env,
    observation_layout,
    parallel_env,
)
from nao_arena.maps import load_map
from nao_arena.world import World

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        # PettingZoo's advice on agent names and infinite observation bounds
        warnings.simplefilter("ignore", UserWarning)
        yield


def _pickle(x):
    return pickle.loads(pickle.dumps(x))


def _cloudpickle(x):
    return cloudpickle.loads(cloudpickle.dumps(x))


COPIES = {"pickle": _pickle, "cloudpickle": _cloudpickle, "deepcopy": copy.deepcopy}


def _summary(e) -> str:
    return json.dumps(e.unwrapped.arena.summary().to_dict(), sort_keys=True)


# ---------------------------------------------------------------- copies and pickles


@pytest.mark.parametrize("how", COPIES)
def test_world_copies_continue_bit_for_bit_through_crowded_contacts(how):
    # 40 robots in a 12 m box pushed at random: many bodies with several contacts at once,
    # where a copy of the pymunk space alone (its own pickling) rounds differently
    world = World(load_map("crowd", n=40, lo=-6.0, hi=6.0, seed=0))
    rng = np.random.default_rng(0)
    push = world.a_max[:, None] * 2.0
    for _ in range(60):
        world.step(rng.uniform(-1, 1, (world.n, 2)) * push)
    twin = COPIES[how](world)
    assert twin.time == world.time and np.array_equal(twin.commands, world.commands)
    for _ in range(50):
        a = rng.uniform(-1, 1, (world.n, 2)) * push
        s1, s2 = world.step(a), twin.step(a)
        assert same(s1.positions, s2.positions) and same(s1.velocities, s2.velocities)
        assert same(s1.accelerations, s2.accelerations)
        assert same(world.substep_positions, twin.substep_positions)


def test_world_command_log_restarts_with_reset():
    world = World(load_map("circle_swap", n=3))
    for _ in range(40):
        world.step(np.ones((3, 2)))
    assert world.commands.shape == (40, 3, 2) and not world.commands.flags.writeable
    world.reset()
    assert world.commands.shape == (0, 3, 2)
    world.step(np.full((3, 2), 0.5))
    assert np.array_equal(world.commands, np.full((1, 3, 2), 0.5))
    assert np.array_equal(_pickle(world).state().positions, world.state().positions)


@pytest.mark.parametrize("kind", ["parallel", "aec"])
@pytest.mark.parametrize("how", COPIES)
def test_envs_pickle_and_copy_before_and_after_reset(kind, how):
    make = parallel_env if kind == "parallel" else env
    e = make("circle_swap", n=4, time_limit=3.0)
    fresh = COPIES[how](e)
    e.reset(seed=5)
    fresh.reset(seed=5)
    assert _summary(fresh) == _summary(e)
    again = COPIES[how](e)
    assert _summary(again) == _summary(e)
    if kind == "parallel":
        assert same(again.observations(), e.observations())
        assert again.agents == e.agents
    else:
        assert same(again.last(), e.last()) and again.agent_selection == e.agent_selection


def _random_actions(e, rng):
    return {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in e.agents}


@pytest.mark.parametrize("how", COPIES)
@pytest.mark.parametrize(
    "name, controlled",
    [
        ("circle_swap", ["swap0", "swap3", "swap7"]),  # the other seven: NAO agents
        ("roundabout", ["west_east"]),  # one robot controlled, one NAO robot and traffic
    ],
)
def test_parallel_copy_mid_episode_continues_bit_for_bit(name, controlled, how):
    e = parallel_env(name, controlled=controlled)
    e.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(30):
        e.step(_random_actions(e, rng))
    twin = COPIES[how](e)
    assert _summary(twin) == _summary(e)  # statistics and trajectory hash so far
    for _ in range(50):
        actions = _random_actions(e, rng)
        assert same(twin.step(actions), e.step(actions))
    assert _summary(twin) == _summary(e)


@pytest.mark.parametrize("how", COPIES)
def test_aec_copy_mid_episode_continues_bit_for_bit(how):
    e = env("circle_swap", controlled=[0, 3, 7])
    e.reset(seed=3)
    rng = np.random.default_rng(1)
    for _ in range(3 * 30):
        e.step(rng.uniform(-1, 1, 2).astype(np.float32))
    twin = COPIES[how](e)
    for _ in range(3 * 50):
        assert twin.agent_selection == e.agent_selection
        assert same(twin.last(), e.last())
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        e.step(action)
        twin.step(action)
    assert _summary(twin) == _summary(e)


def test_copy_with_open_contacts_keeps_the_statistics():
    # pushed together: contact episodes are open (with their depths) when the copy is taken
    e = parallel_env("crowd", n=12, lo=-3.0, hi=3.0, controlled="all")
    e.reset(seed=0)
    rng = np.random.default_rng(2)
    stats = e.arena.stats
    for _ in range(200):
        e.step(_random_actions(e, rng))
        if stats._touch_bb.any():
            break
    assert stats._touch_bb.any()
    twin = copy.deepcopy(e)
    twin_stats = twin.arena.stats
    np.testing.assert_array_equal(twin_stats._touch_bb, stats._touch_bb)
    np.testing.assert_array_equal(twin_stats._depth_bb, stats._depth_bb)
    assert twin_stats._arrays.depth_bb is twin_stats._depth_bb  # the bundle shares them
    for _ in range(50):
        actions = _random_actions(e, rng)
        assert same(twin.step(actions), e.step(actions))
    assert _summary(twin) == _summary(e)


def test_copies_keep_what_agents_sense_read_only():
    e = parallel_env("two_lane_road")
    e.reset(seed=0)
    arena = copy.deepcopy(e).arena
    for name in ("goals", "walls", "wall_radius", "path_times"):
        assert not getattr(arena, name).flags.writeable, name
    assert all(r is None or not r.flags.writeable for r in arena.routes)


def test_copies_drop_the_viewer_and_render_alike():
    e = parallel_env("circle_swap", n=3, render_mode="rgb_array", render_size=(640, 400))
    e.reset(seed=0)
    frame = e.render()
    assert e._viewer is not None
    twin = copy.deepcopy(e)
    assert twin._viewer is None
    assert np.array_equal(twin.render(), frame)
    e.close()
    twin.close()


# ---------------------------------------------------------------- agents that finish


def _tiny_map(tmp_path, robots, time_limit=5.0, **extra):
    data = {
        "name": "tiny",
        "bounds": {"min": [-10, -10], "max": [10, 10]},
        "robots": robots,
        "episode": {"time_limit": time_limit},
        **extra,
    }
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


NEAR_AND_FAR = [
    {"name": "near_0", "start": [0.0, 0.0], "goal": [0.1, 0.0], "agent": "goal"},
    {"name": "far_0", "start": [5.0, 5.0], "goal": [-5.0, 5.0], "agent": "goal"},
]


def test_keep_finished_keeps_agents_live_until_the_time_limit(tmp_path):
    e = parallel_env(_tiny_map(tmp_path, NEAR_AND_FAR), keep_finished=True, after_done="hold")
    lay = observation_layout(e.options)
    assert lay["finished"].stop - lay["finished"].start == 1
    obs, infos = e.reset(seed=0)
    assert all(o[lay["finished"]] == 0.0 for o in obs.values())
    assert infos["near_0"]["finished"] is False
    zero = np.zeros(2, dtype=np.float32)
    obs, rew, term, trunc, info = e.step({"near_0": zero, "far_0": zero})
    assert rew["near_0"] == pytest.approx(RewardWeights().goal, abs=0.05)  # the arrival
    assert term == {"near_0": False, "far_0": False} and not any(trunc.values())
    assert info["near_0"]["finished"] is True and info["far_0"]["finished"] is False
    assert obs["near_0"][lay["finished"]] == 1.0 and obs["far_0"][lay["finished"]] == 0.0
    assert e.agents == ["near_0", "far_0"] and e.finished_agents == ["near_0"]
    held = e.arena.state.positions[0].copy()
    push = np.ones(2, dtype=np.float32)
    n = 1
    while e.agents:
        obs, rew, term, trunc, info = e.step({"near_0": push, "far_0": zero})  # ignored
        n += 1
        if e.agents:
            assert rew["near_0"] == 0.0 and not term["near_0"] and not trunc["near_0"]
            assert obs["near_0"][lay["finished"]] == 1.0
    assert n == 50 and e.agents == []
    assert term == {"near_0": True, "far_0": False}  # finished: terminated at the end
    assert trunc == {"near_0": False, "far_0": True}  # the time limit
    assert np.hypot(*(e.arena.state.positions[0] - held)) < 0.05  # braked, not pushed


def test_keep_finished_ends_when_every_agent_has_finished(tmp_path):
    robots = [
        dict(NEAR_AND_FAR[0]),
        {"name": "next_0", "start": [3.0, 0.0], "goal": [3.0, 1.5], "agent": "goal"},
    ]
    e = parallel_env(_tiny_map(tmp_path, robots), keep_finished=True)
    e.reset(seed=0)
    up = {"near_0": np.zeros(2), "next_0": np.array([0.0, 1.0])}
    _, _, term, _, _ = e.step(up)
    assert e.finished_agents == ["near_0"] and term == {"near_0": False, "next_0": False}
    while e.agents:
        _, rew, term, trunc, _ = e.step(up)
    assert term == {"near_0": True, "next_0": True}
    assert trunc == {"near_0": False, "next_0": False}
    assert e.arena.time < 5.0


@pytest.mark.parametrize("name", ["circle_swap", "corridor", "roundabout"])
def test_keep_finished_passes_the_api_tests(name):
    kw = {
        "keep_finished": True,
        "time_limit": 1.5,
        "map_params": {"n": 3} if name == "circle_swap" else {"n": 1} if name == "corridor" else {},
    }
    parallel_api_test(parallel_env(name, **kw), num_cycles=30)
    api_test(env(name, **kw), num_cycles=30)
    parallel_seed_test(lambda: parallel_env(name, **kw), num_cycles=15)


def test_default_mode_has_no_finished_entry():
    lay = observation_layout(EnvOptions())
    assert lay["finished"].start == lay["finished"].stop == lay["nao"].stop
    e = parallel_env("circle_swap", n=3)
    assert e.observation_space("swap0").shape == (lay["nao"].stop,)
    e.reset(seed=0)
    assert e.finished_agents == []


def test_supersuit_vector_env_needs_keep_finished_or_black_death(tmp_path):
    path = _tiny_map(tmp_path, NEAR_AND_FAR, time_limit=1.0)
    vec = ss.pettingzoo_env_to_vec_env_v1(parallel_env(path))
    vec.reset(seed=0)
    with pytest.raises(AssertionError, match="black_death"):
        vec.step(np.zeros((2, 2), dtype=np.float32))  # near_0 arrives and leaves
    for vec in (
        ss.pettingzoo_env_to_vec_env_v1(parallel_env(path, keep_finished=True)),
        ss.pettingzoo_env_to_vec_env_v1(ss.black_death_v3(parallel_env(path))),
    ):
        obs, _ = vec.reset(seed=0)
        assert obs.shape == (2, vec.observation_space.shape[0])
        resets = 0
        for _ in range(25):  # two and a half episodes of 10 steps
            obs, rew, term, trunc, infos = vec.step(np.zeros((2, 2), dtype=np.float32))
            assert obs.shape[0] == rew.shape[0] == term.shape[0] == trunc.shape[0] == 2
            resets += bool(np.all(term | trunc))
        assert resets == 2


# ---------------------------------------------------------------- observation bounds


def _finite(e) -> bool:
    box = e.observation_space(e.possible_agents[0])
    return bool(np.all(np.isfinite(box.low)) and np.all(np.isfinite(box.high)))


def test_observation_bounds_are_finite_where_the_quantities_are_bounded():
    for name in ("crowd", "corridor"):  # closed by walls at their bounds
        assert _finite(parallel_env(name))
    e = parallel_env("circle_swap", n=3, nao_features=True, keep_finished=True)
    box = e.observation_space("swap0")
    own = {f: (box.low[i], box.high[i]) for i, f in enumerate(OWN_FEATURES)}
    # open map: positions (and the goal offset) unbounded, everything else finite
    assert own["x"] == (-np.inf, np.inf) and own["goal_dx"] == (-np.inf, np.inf)
    assert own["goal_x"] == (-12.0, 12.0)
    assert own["vx"][1] == pytest.approx(1.5, rel=1e-5)
    assert own["ax"][1] == pytest.approx(2 * 1.5 / 0.1, rel=1e-5)
    assert own["cmd_ax"][1] == pytest.approx(2.0, rel=1e-5)
    assert own["time_left"] == (0.0, 40.0)
    nb = slice(len(OWN_FEATURES), len(OWN_FEATURES) + len(NEIGHBOUR_FEATURES))
    assert np.all(np.isfinite(box.low[nb])) and np.all(np.isfinite(box.high[nb]))
    assert box.high[nb][NEIGHBOUR_FEATURES.index("dx")] == pytest.approx(30.0, rel=1e-5)
    assert np.all(np.isfinite(box.low[len(OWN_FEATURES) + 4 :]))
    e = parallel_env("circle_swap", n=3, position_margin=2.0)
    assert _finite(e)
    box = e.observation_space("swap0")
    assert box.high[OWN_FEATURES.index("x")] == 14.0
    assert box.high[OWN_FEATURES.index("goal_dx")] == pytest.approx(26.0, rel=1e-5)


@pytest.mark.parametrize(
    "name, kw",
    [
        ("crowd", {"n": 10, "lo": -4.0, "hi": 4.0}),
        ("roundabout", {}),
        ("circle_swap", {"position_margin": 0.5, "nao_features": True}),
        ("two_lane_road", {"keep_finished": True}),
    ],
)
def test_observations_stay_within_their_space(name, kw):
    e = parallel_env(name, controlled="all", time_limit=20.0, **kw)
    obs, _ = e.reset(seed=1)
    rng = np.random.default_rng(0)
    while e.agents:
        for a, o in obs.items():
            assert e.observation_space(a).contains(o), a
        obs = e.step({a: rng.uniform(-1, 1, 2) for a in e.agents})[0]


def test_position_margin_clips_positions_into_the_bounds():
    e = parallel_env("circle_swap", n=2, position_margin=0.0)
    e.reset(seed=0)
    east = {a: np.array([1.0, 0.0]) for a in e.agents}
    for _ in range(150):
        obs = e.step(east)[0]
    x = OWN_FEATURES.index("x")
    assert e.arena.state.positions[0, 0] > 12.0  # left the open map
    assert obs["swap0"][x] == 12.0
    assert e.observation_space("swap0").contains(obs["swap0"])


def test_normalize_obs_needs_finite_bounds():
    ss.normalize_obs_v0(parallel_env("crowd", n=4))
    ss.normalize_obs_v0(parallel_env("circle_swap", n=4, position_margin=1.0))
    with pytest.raises(AssertionError, match="infinite bounds"):
        ss.normalize_obs_v0(parallel_env("circle_swap", n=4))


# ---------------------------------------------------------------- SuperSuit and Gymnasium


def need_sb3():
    """The stable_baselines3 module; skip the test without it (fail if
    NAO_ARENA_REQUIRE_RL=1, as .ci/run sets after installing the rl extra)."""
    if os.environ.get("NAO_ARENA_REQUIRE_RL") == "1":
        import stable_baselines3

        return stable_baselines3
    return pytest.importorskip(
        "stable_baselines3",
        reason="SuperSuit's stable_baselines3 base class needs stable_baselines3 (the rl extra)",
    )


def _vec_run(num_cpus: int, steps: int = 25) -> list:
    """A SuperSuit vector env of 2 envs x 4 agents (``keep_finished``), driven by seeded
    random actions; returns what it returned, step by step."""
    par = parallel_env("circle_swap", n=4, time_limit=1.0, keep_finished=True)
    vec = ss.concat_vec_envs_v1(
        ss.pettingzoo_env_to_vec_env_v1(par), 2, num_cpus=num_cpus, base_class="gymnasium"
    )
    try:
        assert isinstance(vec, gymnasium.vector.VectorEnv)
        assert vec.num_envs == 8
        # SuperSuit's spaces are one agent's, not batched (Gymnasium's single_* spaces)
        box = vec.observation_space
        assert box == par.observation_space("swap0")
        assert vec.action_space == par.action_space("swap0")
        obs, _ = vec.reset(seed=7)  # (the infos' layout depends on num_cpus in SuperSuit)
        assert obs.shape == (8, box.shape[0]) and obs.dtype == np.float32
        out = [obs]
        rng = np.random.default_rng(0)
        for _ in range(steps):
            actions = rng.uniform(-1, 1, (8, 2)).astype(np.float32)
            obs, rew, term, trunc, infos = vec.step(actions)
            assert obs.shape == (8, box.shape[0]) and rew.shape == (8,)
            assert term.shape == trunc.shape == (8,) and len(infos) == 8
            assert all(box.contains(o) for o in obs)
            # (flags come as uint8 in process, bool from worker processes)
            out += [obs, rew, term.astype(bool), trunc.astype(bool)]
        return out
    finally:
        vec.close()


def test_concat_vec_envs_in_process():
    out = _vec_run(0)
    # out: the reset's observations, then (obs, rew, term, trunc) per step; both envs
    # reach the time limit (10 steps) together, twice in 25 steps
    assert sum(bool(np.all(trunc)) for trunc in out[4::4]) == 2


@pytest.mark.slow
def test_concat_vec_envs_in_two_processes_give_the_same_results():
    assert same(_vec_run(2), _vec_run(0))


def _sb3_run(num_cpus: int) -> list:
    """SuperSuit's stable_baselines3 vector env of 2 envs x 4 agents over 12 steps (an
    episode is 10), seeded as examples/train_ppo.py does: through the Gymnasium vector env
    below the wrapper (the wrapper's seed() reaches a SuperSuit env without one)."""
    from stable_baselines3.common.vec_env import VecEnv

    par = parallel_env("circle_swap_perturbed", n=4, time_limit=1.0, keep_finished=True)
    vec = ss.concat_vec_envs_v1(
        ss.pettingzoo_env_to_vec_env_v1(par), 2, num_cpus=num_cpus, base_class="stable_baselines3"
    )
    try:
        assert isinstance(vec, VecEnv) and vec.num_envs == 8
        dim = par.observation_space(par.possible_agents[0]).shape[0]
        assert vec.observation_space.shape == (dim,) and vec.action_space.shape == (2,)
        vec.venv.reset(seed=3)
        obs = vec.reset()  # unseeded: each env's seed drawn from its seeded generator
        assert obs.shape == (8, dim)
        assert not np.array_equal(obs[:4], obs[4:])  # two episodes, two seeded maps
        out = [obs]
        for i in range(12):
            obs, rew, dones, infos = vec.step(np.full((8, 2), 0.5, dtype=np.float32))
            assert obs.shape == (8, dim) and rew.shape == dones.shape == (8,)
            assert len(infos) == 8
            assert np.all(dones) == (i == 9)  # the time limit: every agent of both envs
            out += [obs, rew, dones.astype(bool)]  # (uint8 in process, bool from workers)
        return out
    finally:
        vec.close()


def test_concat_vec_envs_for_stable_baselines3():
    need_sb3()
    first = _sb3_run(0)
    assert same(_sb3_run(0), first)  # the seeding above makes runs repeat


@pytest.mark.slow
def test_concat_vec_envs_for_stable_baselines3_in_two_processes():
    need_sb3()
    assert same(_sb3_run(2), _sb3_run(0))


def test_frame_stack_and_normalize_through_the_vector_env():
    par = parallel_env("crowd", n=4, time_limit=1.0, keep_finished=True)
    box = par.observation_space("crowd0")
    dim = box.shape[0]
    wrapped = ss.frame_stack_v1(ss.normalize_obs_v0(par), 3)
    assert wrapped.observation_space("crowd0").shape == (3 * dim,)
    obs, _ = wrapped.reset(seed=0)
    raw = par.observations()["crowd0"]
    assert np.all(obs["crowd0"][: 2 * dim] == 0.0)  # the stack starts empty
    np.testing.assert_allclose(
        obs["crowd0"][2 * dim :], (raw - box.low) / (box.high - box.low), rtol=1e-5, atol=1e-6
    )
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(wrapped), 2, base_class="gymnasium")
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (8, 3 * dim)
    for _ in range(12):
        obs = vec.step(np.zeros((8, 2), dtype=np.float32))[0]
        assert obs.shape == (8, 3 * dim)
        assert np.all((obs >= 0.0) & (obs <= 1.0))  # normalized by the finite bounds
    vec.close()


def _readme_recipe() -> str:
    page = Path(__file__).resolve().parents[1] / "docs" / "how-to" / "rl.md"
    section = page.read_text(encoding="utf-8").split("\n## Training with RL\n", 1)[1]
    return next(
        b for b in re.findall(r"```python\n(.*?)```", section, re.S) if "concat_vec_envs_v1" in b
    )


@pytest.mark.parametrize("way", ["keep_finished", "black_death"])
def test_readme_vector_env_recipe_runs_both_ways(way):
    code = _readme_recipe()
    if way == "black_death":
        code = re.sub(r"^par = .*\n# par = ", "par = ", code, flags=re.M)
    scope: dict = {}
    exec(compile(code, "docs/how-to/rl.md", "exec"), scope)
    vec, par = scope["vec"], scope["par"]
    try:
        assert vec.num_envs == 4 * 12
        assert scope["obs"].shape == (48, par.observation_space("east0").shape[0])
        assert scope["rewards"].shape == scope["terminations"].shape == (48,)
        assert ("black_death" in type(par).__name__) == (way == "black_death")
    finally:
        vec.close()
