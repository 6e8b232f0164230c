"""The PettingZoo env with the tools RL users use: copies and pickles that continue bit for
bit, agents kept live until the episode ends, finite observation bounds, SuperSuit's vector
envs and wrappers, the versioned envs of :mod:`nao_arena.envs`."""

from __future__ import annotations

import copy
import json
import os
import pickle
import warnings

import cloudpickle
import numpy as np
import pytest

from nao_arena.environment import env, parallel_env
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


def same(x, y) -> bool:
    """Equal to the bit (floats and arrays by their bytes), recursively."""
    if isinstance(x, dict):
        return type(y) is dict and x.keys() == y.keys() and all(same(x[k], y[k]) for k in x)
    if isinstance(x, list | tuple):
        return len(x) == len(y) and all(same(a, b) for a, b in zip(x, y, strict=True))
    if isinstance(x, np.ndarray):
        return (isinstance(y, np.ndarray) and x.dtype == y.dtype and x.shape == y.shape
                and x.tobytes() == y.tobytes())
    if isinstance(x, float):
        return isinstance(y, float) and np.float64(x).tobytes() == np.float64(y).tobytes()
    return type(x) is type(y) and x == y


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
@pytest.mark.parametrize("name, controlled", [
    ("circle_swap", ["swap0", "swap3", "swap7"]),  # the other seven: NAO agents
    ("roundabout", ["west_east"]),  # one robot controlled, one NAO robot and traffic
])
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
    # pushed together: contact episodes are open (the statistics' depth map is filled)
    # when the copy is taken
    e = parallel_env("crowd", n=12, lo=-3.0, hi=3.0, controlled="all")
    e.reset(seed=0)
    rng = np.random.default_rng(2)
    stats = e.arena.stats
    for _ in range(200):
        e.step(_random_actions(e, rng))
        if len(stats._depth):
            break
    assert len(stats._depth)
    twin = copy.deepcopy(e)
    assert dict(twin.arena.stats._depth) == dict(stats._depth)
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
