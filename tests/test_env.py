"""The PettingZoo environments: API conformance on every shipped map, seeding,
observation layout, actions, rewards, terminations and infos."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

from nao_arena.environment import (
    NEIGHBOUR_FEATURES,
    OWN_FEATURES,
    EnvOptions,
    RewardWeights,
    env,
    nao_candidates,
    observation_layout,
    parallel_env,
)
from nao_arena.geometry import nao_clearance
from nao_arena.maps import MapError, available_maps, load_map
from nao_arena.sensing import neighbour_lists

SMALL = {
    "circle_swap": {"n": 4},
    "circle_swap_perturbed": {"n": 4},
    "crowd": {"n": 4},
    "corridor": {"n": 2},
    "crossing": {"n": 2},
    "dense_swap": {"n": 4},
    "dense_swap_perturbed": {"n": 4},
    "crossing_streams": {"n": 2},
    "crossing_streams_perturbed": {"n": 2},
    "doorway": {"n": 2},
    "doorway_perturbed": {"n": 2},
    "intersection": {"n": 1},
    "intersection_perturbed": {"n": 1},
    "warehouse_aisles": {"n": 1},
    "warehouse_aisles_perturbed": {"n": 1},
    "pillar_corridor": {"n": 2},
    "pillar_corridor_perturbed": {"n": 2},
}
"""Map parameters that keep the API tests quick."""


def small(name: str) -> dict:
    params = dict(SMALL.get(name, {}))
    return {"map_params": params, "time_limit": 1.5}


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        # PettingZoo's advice on agent names and infinite observation bounds
        warnings.simplefilter("ignore", UserWarning)
        yield


@pytest.mark.parametrize("name", available_maps())
def test_parallel_api(name):
    parallel_api_test(parallel_env(name, **small(name)), num_cycles=30)


@pytest.mark.parametrize("name", available_maps())
def test_parallel_seed(name):
    parallel_seed_test(lambda: parallel_env(name, **small(name)), num_cycles=15)


@pytest.mark.parametrize("name", available_maps())
def test_aec_api(name):
    api_test(env(name, **small(name)), num_cycles=30)


def test_nao_features_pass_the_api_test():
    parallel_api_test(
        parallel_env("two_lane_road", nao_features=True, time_limit=1.0), num_cycles=15
    )


def test_same_seed_same_actions_same_observations():
    def run(seed: int) -> list:
        e = parallel_env("crowd", n=5, time_limit=2.0, nao_features=True)
        obs, _ = e.reset(seed=seed)
        rng = np.random.default_rng(7)
        out = [obs]
        while e.agents:
            acts = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in e.agents}
            obs, rew, term, trunc, info = e.step(acts)
            out.append((obs, rew, term, trunc, info))
        return out

    a, b = run(3), run(3)
    assert len(a) == len(b) == 21
    for x, y in zip(a, b, strict=True):
        _assert_same(x, y)
    c = run(4)
    assert not np.array_equal(a[0]["crowd0"], c[0]["crowd0"])  # the seed moved the layout


def _assert_same(x, y):
    if isinstance(x, dict):
        assert x.keys() == y.keys()
        for k in x:
            _assert_same(x[k], y[k])
    elif isinstance(x, list | tuple):
        assert len(x) == len(y)
        for u, v in zip(x, y, strict=True):
            _assert_same(u, v)
    elif isinstance(x, np.ndarray):
        assert np.array_equal(x, y)
    else:
        assert x == y or (x != x and y != y)


def test_seed_goes_to_map_and_arena():
    e = parallel_env("crowd", n=3)
    e.reset(seed=11)
    assert e.spec.parameters["seed"] == 11
    assert e.spec.robots[0].start == load_map("crowd", n=3, seed=11).robots[0].start
    e2 = parallel_env("crowd", n=3, reseed_map=False, seed=5)
    e2.reset(seed=11)
    assert e2.spec.parameters["seed"] == 5


def test_unseeded_resets_follow_the_last_seed():
    e1, e2 = parallel_env("crowd", n=3), parallel_env("crowd", n=3)
    e1.reset(seed=1)
    e2.reset(seed=1)
    o1, _ = e1.reset()
    o2, _ = e2.reset()
    _assert_same(o1, o2)


def test_options_and_map_parameters_are_split():
    e = parallel_env(
        "circle_swap",
        n=3,
        max_neighbours=2,
        rewards={"progress": 2.0},
        arena={"sensing_range": 5.0},
    )
    assert e.options.max_neighbours == 2
    assert e.options.rewards == RewardWeights(progress=2.0)
    assert e.arena.sensing_range == 5.0
    assert len(e.possible_agents) == 3
    with pytest.raises(MapError, match="unknown parameter"):
        parallel_env("circle_swap", no_such_parameter=1)
    e = parallel_env("circle_swap", options=EnvOptions(max_neighbours=1), map_params={"n": 2})
    assert e.observation_space("swap0").shape == (observation_layout(e.options)["nao"].stop,)


def test_controlled_subset_others_driven_by_their_agents():
    e = parallel_env("roundabout", controlled=["west_east"], time_limit=2.0)
    assert e.possible_agents == ["west_east"]
    e.reset(seed=0)
    start = e.arena.state.positions[e.arena.robot_ids[1]].copy()
    for _ in range(10):
        e.step({"west_east": np.zeros(2, dtype=np.float32)})
    moved = e.arena.state.positions[e.arena.robot_ids[1]] - start
    assert np.hypot(*moved) > 1.0  # south_north drove itself (NAO agent)
    assert parallel_env("roundabout", controlled=[1]).possible_agents == ["south_north"]
    with pytest.raises(ValueError, match="unknown robot"):
        parallel_env("roundabout", controlled=["nobody"])
    with pytest.raises(ValueError, match="out of range"):
        parallel_env("roundabout", controlled=[5])


def test_bad_actions_raise():
    e = parallel_env("circle_swap", n=2)
    e.reset(seed=0)
    ok = np.zeros(2, dtype=np.float32)
    with pytest.raises(ValueError, match="finite"):
        e.step({"swap0": np.array([np.nan, 0.0]), "swap1": ok})
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        e.step({"swap0": np.zeros(3), "swap1": ok})
    with pytest.raises(ValueError, match="missing"):
        e.step({"swap0": ok})
    with pytest.raises(ValueError, match="unknown agent"):
        e.step({"swap0": ok, "swap1": ok, "ghost": ok})


@pytest.mark.parametrize(
    "actions, fragment",
    [
        (None, "expected a dict of agent name -> action of shape \\(2,\\), got NoneType"),
        ([np.zeros(2), np.zeros(2)], "expected a dict .* got list"),
        (np.zeros((2, 2)), "expected a dict .* got ndarray"),
        (
            {"swap0": np.array([0.5 + 1j, 0.0]), "swap1": np.zeros(2)},
            "action of 'swap0': expected real numbers .* got complex numbers",
        ),
        (
            {"swap0": np.zeros(2), "swap1": np.array([True, False])},
            "action of 'swap1': expected real numbers .* got booleans",
        ),
        ({"swap0": [True, 0.5], "swap1": np.zeros(2)}, "action of 'swap0': .* got booleans"),
        ({"swap0": np.zeros(2), "swap1": ["1", "0"]}, "action of 'swap1': .* got strings"),
        ({"swap0": None, "swap1": np.zeros(2)}, "action of 'swap0': .* got objects: None"),
    ],
)
def test_actions_that_are_not_real_numbers_raise(actions, fragment):
    """Booleans and complex numbers used to be cast to floats, and a non-dict raised
    AttributeError; every one now raises ValueError naming what was wrong."""
    e = parallel_env("circle_swap", n=2)
    e.reset(seed=0)
    with pytest.raises(ValueError, match=fragment):
        e.step(actions)
    # nothing was stepped: a valid step still works from time 0
    _, _, _, _, infos = e.step({"swap0": np.zeros(2), "swap1": [0, 1]})
    assert infos["swap0"]["time"] == pytest.approx(e.arena.world.dt)


def test_action_scaling_and_clipping():
    e = parallel_env("circle_swap", n=2, arena={"agent": "goal"})
    e.reset(seed=0)
    e.step({"swap0": np.array([5.0, 0.0]), "swap1": np.array([1.0, 1.0])})
    cmd = e.arena.commanded[e.arena.robot_ids]
    a_max = e.arena.world.a_max[e.arena.robot_ids]
    assert np.allclose(cmd[0], [a_max[0], 0.0])  # clipped to [-1, 1], times a_max
    assert np.allclose(cmd[1], [a_max[1], a_max[1]])  # the world scales it to |a| <= a_max
    v = e.arena.state.velocities[e.arena.robot_ids[1]]
    assert np.hypot(*v) == pytest.approx(a_max[1] * e.arena.world.dt, rel=1e-6)


def test_observation_layout():
    opts = EnvOptions(max_neighbours=3, nao_features=True)
    lay = observation_layout(opts)
    assert lay["own"] == slice(0, len(OWN_FEATURES))
    assert lay["neighbours"].stop - lay["neighbours"].start == 3 * len(NEIGHBOUR_FEATURES)
    assert lay["nao"].stop - lay["nao"].start == len(nao_candidates(opts)) == 17
    e = parallel_env("circle_swap", n=3, options=opts, radius=4.0)
    obs, _ = e.reset(seed=0)
    st = e.arena.state
    o = obs["swap0"].astype(float)
    own = dict(zip(OWN_FEATURES, o[lay["own"]], strict=True))
    p0, g0 = st.positions[0], e.arena.goals[0]
    assert [own["goal_dx"], own["goal_dy"]] == pytest.approx(g0 - p0, abs=1e-5)
    assert [own["x"], own["y"]] == pytest.approx(p0, abs=1e-5)
    assert own["a_max"] == 2.0 and own["v_max"] == 1.5 and own["radius"] == pytest.approx(0.3)
    assert own["time_left"] == pytest.approx(40.0)
    nb = o[lay["neighbours"]].reshape(3, len(NEIGHBOUR_FEATURES))
    assert list(nb[:, 0]) == [1.0, 1.0, 0.0]  # two neighbours, one zero-padded row
    assert np.all(nb[2] == 0.0)
    d = np.hypot(nb[:2, 1], nb[:2, 2])
    assert d[0] <= d[1]
    assert nb[0, 1:3] == pytest.approx(
        st.positions[int(np.argmin(np.hypot(*(st.positions[1:] - p0).T))) + 1] - p0, abs=1e-5
    )
    # NAO block: the zero acceleration's clearance against the two neighbours
    times = np.linspace(0.0, opts.nao_horizon, opts.nao_samples)
    centres = np.stack([st.positions[j] - p0 + 0 * times[:, None] for j in (1, 2)])
    expect = np.min(
        nao_clearance(
            np.zeros((1, 2)),
            st.velocities[0],
            times,
            centres,
            st.radii[1:] + st.radii[0],
            v_max=1.5,
        )
    )
    assert o[lay["nao"]][0] == pytest.approx(expect, abs=1e-5)
    assert e.observation_space("swap0").contains(obs["swap0"])


def _tiny_map(tmp_path: Path, robots: list[dict], **extra) -> Path:
    data = {
        "name": "tiny",
        "bounds": {"min": [-10, -10], "max": [10, 10]},
        "robots": robots,
        "episode": {"time_limit": 5.0},
        **extra,
    }
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_goal_terminates_and_removes_the_agent(tmp_path):
    path = _tiny_map(
        tmp_path,
        [
            {"name": "near_0", "start": [0.0, 0.0], "goal": [0.1, 0.0], "agent": "goal"},
            {"name": "far_0", "start": [5.0, 5.0], "goal": [-5.0, 5.0], "agent": "goal"},
        ],
    )
    e = parallel_env(path, after_done="hold")
    e.reset(seed=0)
    zero = np.zeros(2, dtype=np.float32)
    obs, rew, term, trunc, info = e.step({"near_0": zero, "far_0": zero})
    assert term == {"near_0": True, "far_0": False}
    assert info["near_0"]["reached"] is True
    assert rew["near_0"] == pytest.approx(RewardWeights().goal, abs=0.05)
    assert e.agents == ["far_0"]
    e.step({"far_0": zero, "near_0": None})  # actions for agents no longer live are ignored
    assert np.allclose(e.arena.state.velocities[0], 0.0)  # held
    n = 2
    while e.agents:
        _, _, _, trunc, _ = e.step({"far_0": zero})
        n += 1
    assert trunc == {"far_0": True} and n == 50


def test_collisions_in_infos_rewards_and_termination(tmp_path):
    path = _tiny_map(
        tmp_path,
        [
            {"name": "left_0", "start": [-1.0, 0.0], "goal": [5.0, 0.0]},
            {"name": "right_0", "start": [1.0, 0.0], "goal": [-5.0, 0.0]},
        ],
    )
    push = {"left_0": np.array([1.0, 0.0]), "right_0": np.array([-1.0, 0.0])}
    e = parallel_env(path, terminate_on_collision=True)
    e.reset(seed=0)
    for _ in range(20):
        obs, rew, term, trunc, info = e.step(push)
        if info["left_0"]["collisions"]:
            break
    assert info["left_0"]["collisions"] == info["right_0"]["collisions"] == 1
    (ev,) = e.events["left_0"]["collisions"]
    assert {ev["name_a"], ev["name_b"]} == {"left_0", "right_0"}
    assert e.events["right_0"]["collisions"] == e.events["left_0"]["collisions"]
    # the infos are numbers only (every RL library stacks them); the events are beside them
    assert all(isinstance(v, bool | int | float) for i in info.values() for v in i.values())
    assert rew["left_0"] < -RewardWeights().collision + 1.0
    assert term == {"left_0": True, "right_0": True}
    assert e.agents == []


def test_state_and_spaces():
    e = parallel_env("roundabout", time_limit=1.0)
    e.reset(seed=0)
    s = e.state()
    assert s.dtype == np.float32 and s.shape == e.state_space.shape
    n = e.arena.world.n
    bodies = s[1 : 1 + 8 * n].reshape(n, 8)
    assert np.allclose(bodies[:, :2], e.arena.state.positions, atol=1e-4)
    assert list(bodies[:, 7]) == [0.0] * 2 + [1.0] * (n - 2)
    a = e.action_space("west_east")
    assert a.shape == (2,) and a.dtype == np.float32 and a.low[0] == -1 and a.high[0] == 1
    assert e.observation_space("west_east") is e.observation_space("west_east")
    assert e.metadata["render_fps"] == pytest.approx(10.0)


def test_package_level_constructors():
    from pettingzoo import AECEnv, ParallelEnv

    import nao_arena

    par = nao_arena.parallel_env("circle_swap", n=3)
    aec = nao_arena.env("circle_swap", n=3)
    assert isinstance(par, ParallelEnv) and isinstance(aec, AECEnv)
    assert par.possible_agents == aec.possible_agents


def _neighbour_rows_reference(p, v, acc, rad, kinds, bodies, rng_m, k):
    """The neighbour block by sorting all distances (numpy, stable: ties by index)."""
    m = len(bodies)
    d = np.hypot(p[None, :, 0] - p[bodies][:, None, 0], p[None, :, 1] - p[bodies][:, None, 1])
    d[np.arange(m), bodies] = np.inf
    d[d > rng_m] = np.inf
    idx = np.argsort(d, axis=1, kind="stable")[:, :k]
    present = np.isfinite(np.take_along_axis(d, idx, axis=1))
    nb = np.zeros((m, k, 9))
    nb[..., 0] = present
    nb[..., 1:3] = p[idx] - p[bodies][:, None]
    nb[..., 3:5] = v[idx] - v[bodies][:, None]
    nb[..., 5:7] = acc[idx]
    nb[..., 7] = rad[idx]
    nb[..., 8] = kinds[idx]
    return nb * present[..., None], np.where(present, idx, 0), present


@pytest.mark.parametrize("seed", range(30))
def test_neighbour_kernel_matches_sorting(seed):
    """The env's neighbour rows come from the sensing's search (neighbour_lists with
    math.hypot distances): the K nearest within range, ties by index, never the robot
    itself (also with an infinite range, where the search lists it last)."""
    from nao_arena.env_observations import ObservedRows, observation_rows
    from nao_arena.environment import OWN_FEATURES

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    # integer grid positions: many equal distances, to check the tie order; else
    # random ones, where math.hypot and sqrt(dx^2 + dy^2) differ in the last bit
    p = rng.integers(-4, 5, (n, 2)).astype(float) if seed % 2 else rng.uniform(-4.0, 4.0, (n, 2))
    v, acc = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    rad, kinds = rng.uniform(0.1, 1.0, n), (rng.random(n) < 0.5).astype(float)
    a_max, v_max = rng.uniform(1, 3, n), rng.uniform(1, 3, n)
    bodies = rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False).astype(np.int64)
    m = len(bodies)
    goals, cmd = rng.normal(size=(m, 2)), rng.normal(size=(m, 2))
    k, rng_m = min(int(rng.integers(1, 8)), n - 1), float(rng.uniform(1.0, 8.0))
    if seed % 5 == 0:
        rng_m = math.inf
    n_own = len(OWN_FEATURES)
    out = np.zeros((m, n_own + 9 * k + 3))
    idx = np.zeros((m, k), dtype=np.int64)
    present = np.zeros((m, k), dtype=bool)
    start, index = neighbour_lists(bodies, p, rng_m, k, hypot=True)
    observation_rows(
        p,
        v,
        acc,
        rad,
        ObservedRows(bodies, goals, cmd, kinds, a_max, v_max),
        7.5,
        start,
        index,
        out,
        idx,
        present,
    )
    ref_out, ref_idx, ref_present = _neighbour_rows_reference(
        p, v, acc, rad, kinds, bodies, rng_m, k
    )
    np.testing.assert_array_equal(present, ref_present)
    np.testing.assert_array_equal(idx, ref_idx)
    np.testing.assert_array_equal(out[:, n_own : n_own + 9 * k], ref_out.reshape(m, -1))
    assert not out[:, n_own + 9 * k :].any()  # the NAO block is not touched
    own = np.column_stack(
        [
            goals - p[bodies],
            v[bodies],
            acc[bodies],
            cmd,
            a_max[bodies],
            v_max[bodies],
            rad[bodies],
            p[bodies],
            goals,
            np.full(m, 7.5),
        ]
    )
    np.testing.assert_array_equal(out[:, :n_own], own)


def test_grouped_agent_names_share_a_group_per_prefix():
    """agent_names="grouped": <group>_<k> names (what TorchRL and BenchMARL group by), the
    same episode as with the map's names."""
    from nao_arena.environment import grouped_names

    assert grouped_names(["east0", "east1", "west0", "car", "a_7", "9"]) == [
        "east_0",
        "east_1",
        "west_0",
        "car_0",
        "a_0",
        "robot_0",
    ]
    plain = parallel_env("crossing")
    grouped = parallel_env("crossing", agent_names="grouped")
    assert len(grouped.possible_agents) == len(plain.possible_agents) == 12
    groups = {a.rsplit("_", 1)[0] for a in grouped.possible_agents}
    assert len(groups) < len(grouped.possible_agents)
    obs_p, _ = plain.reset(seed=1)
    obs_g, _ = grouped.reset(seed=1)
    rename = dict(zip(plain.possible_agents, grouped.possible_agents, strict=True))
    for a, o in obs_p.items():
        np.testing.assert_array_equal(o, obs_g[rename[a]])
    with pytest.raises(ValueError, match="agent_names: expected 'map' or 'grouped'"):
        parallel_env("crossing", agent_names="torchrl")
