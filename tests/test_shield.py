"""The NAO safety shield (nao_arena.shield): random actions made NAO-admissible with the
``nao`` agent's own selection; admissible actions untouched; the PettingZoo API, seeding,
copies, keep_finished and SuperSuit's vector env through the wrapper."""

from __future__ import annotations

import copy
import json
import pickle
import re
import warnings
from pathlib import Path

import cloudpickle
import numpy as np
import pytest
import supersuit as ss
import yaml
from bitwise import same  # tests/bitwise.py
from hypothesis import given, settings
from hypothesis import strategies as st
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

from nao_arena.agents.nao import NAOAgent
from nao_arena.arena import Arena
from nao_arena.environment import env, parallel_env
from nao_arena.maps import load_map
from nao_arena.shield import SHIELD_STATUSES, NAOShield, nao_shield_v0
from nao_arena.world import clip_accelerations


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        # PettingZoo's advice on agent names and infinite observation bounds
        warnings.simplefilter("ignore", UserWarning)
        yield


def _random_actions(e, rng) -> dict[str, np.ndarray]:
    return {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in e.agents}


def _tiny_map(tmp_path, robots, time_limit=5.0):
    data = {
        "name": "tiny",
        "bounds": {"min": [-15, -15], "max": [15, 15]},
        "robots": robots,
        "episode": {"time_limit": time_limit},
    }
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _summary(e) -> str:
    return json.dumps(e.unwrapped.arena.summary().to_dict(), sort_keys=True)


SHIELD_KEYS = {"intervened", "correction", "status", "desired", "applied"}


# ---------------------------------------------------------------- the evidence

EVIDENCE_SEEDS = range(20)
EVIDENCE_TIME = 10.0  # s per episode


def _contacts_of_random_actions(name: str, seed: int, shielded: bool) -> tuple[int, int]:
    """Contacts (all bodies) of one episode of seeded random actions for every robot, and
    how many actions the shield replaced."""
    e = parallel_env(name, controlled="all", time_limit=EVIDENCE_TIME)
    if shielded:
        e = NAOShield(e)
    e.reset(seed=seed)
    rng = np.random.default_rng(seed)
    replaced = 0
    while e.agents:
        *_, infos = e.step(_random_actions(e, rng))
        replaced += sum(i["shield"]["intervened"] for i in infos.values()) if shielded else 0
    return len(e.unwrapped.arena.stats.contacts), replaced


def _contacts_of_nao(name: str, seed: int) -> int:
    """Contacts of the map's own ``nao`` robots on the same seed and time limit."""
    spec = load_map(name, **({"seed": seed} if "seed" in load_map(name).parameters else {}))
    episode = spec.episode.model_copy(update={"time_limit": EVIDENCE_TIME})
    return len(Arena(spec.model_copy(update={"episode": episode})).run(seed).contacts)


@pytest.mark.slow
@pytest.mark.parametrize("name, without_at_least", [("circle_swap", 5), ("crossing", 50)])
def test_the_shield_keeps_random_actions_as_free_of_contacts_as_the_nao_agent(
    name, without_at_least
):
    # circle_swap: 10 robots, crossing: 12; every robot controlled, 20 seeds
    bare = shielded = nao = replaced = 0
    for seed in EVIDENCE_SEEDS:
        bare += _contacts_of_random_actions(name, seed, False)[0]
        got, n = _contacts_of_random_actions(name, seed, True)
        shielded += got
        replaced += n
        nao += _contacts_of_nao(name, seed)
    assert bare >= without_at_least  # 10 and 114 when measured
    assert shielded <= nao  # 0 and 0 when measured (nao: 0 and 0)
    assert replaced > 0


# ---------------------------------------------------------------- what the shield does

FAR_APART = [
    {"name": "left", "start": [-10.0, 0.0], "goal": [-10.0, 5.0], "agent": "nao"},
    {"name": "right", "start": [10.0, 0.0], "goal": [10.0, 5.0], "agent": "nao"},
]


def test_admissible_actions_pass_unchanged_and_the_episode_is_the_bare_one(tmp_path):
    # 20 m apart: no acceleration reaches the other robot within the horizon
    path = _tiny_map(tmp_path, FAR_APART, time_limit=3.0)
    bare, shielded = parallel_env(path), NAOShield(parallel_env(path))
    passed = []
    inner_step = shielded.env.step
    shielded.env.step = lambda actions: (passed.append(actions), inner_step(actions))[1]
    assert same(bare.reset(seed=4)[0], shielded.reset(seed=4)[0])
    rng = np.random.default_rng(0)
    while bare.agents:
        actions = _random_actions(bare, rng)
        out_bare = bare.step(actions)
        out = shielded.step(actions)
        assert all(passed[-1][a] is actions[a] for a in actions)  # the same objects
        for info in out[4].values():
            shield = info.pop("shield")
            assert shield["status"] == "kept" and shield["intervened"] is False
            assert shield["correction"] == 0.0
            assert np.array_equal(shield["applied"], shield["desired"])
        assert same(out, out_bare)
    assert _summary(bare) == _summary(shielded)  # the trajectory hash too


HEAD_ON = [
    {"name": "left", "start": [-2.0, 0.0], "goal": [2.0, 0.0], "agent": "nao"},
    {"name": "right", "start": [2.0, 0.0], "goal": [-2.0, 0.0], "agent": "nao"},
]


def test_an_inadmissible_action_becomes_the_nao_agents_selection(tmp_path):
    e = NAOShield(parallel_env(_tiny_map(tmp_path, HEAD_ON)))
    e.reset(seed=0)
    base = e.unwrapped
    batch = base.arena.sensing()
    ref = NAOAgent(predictor="turn_rate")  # the map's (and the nao agent's) default
    obs = batch.observation(0)
    desired = np.array([2.0, 0.0])  # full acceleration at a robot 4 m ahead
    assert not ref.admissible(obs, desired)
    expected, status = ref.nearest_admissible(obs, desired)
    assert status == "adjusted"
    assert ref.admissible(obs, expected)
    *_, infos = e.step({"left": np.array([1.0, 0.0]), "right": np.zeros(2)})
    shield = infos["left"]["shield"]
    assert shield["status"] == "adjusted" and shield["intervened"] is True
    assert np.array_equal(shield["desired"], desired)
    assert np.array_equal(shield["applied"], expected)
    assert shield["correction"] == float(np.hypot(*(expected - desired))) > 0.0
    # what the world applied: the selection, to rounding (action = selection / a_max)
    np.testing.assert_allclose(base.arena.commanded[0], expected, rtol=0, atol=1e-12)
    assert infos["right"]["shield"]["status"] == "kept"


def test_nothing_admissible_falls_back_to_braking(tmp_path):
    # closing at 2 x 1.5 m/s with 0.6 m between the surfaces: every acceleration touches
    # (each robot needs 0.56 m to stop); the nao agent's fallback brakes towards standing
    # still, at a_max
    robots = [
        dict(HEAD_ON[0], start=[-0.6, 0.0], velocity=[1.5, 0.0]),
        dict(HEAD_ON[1], start=[0.6, 0.0], velocity=[-1.5, 0.0]),
    ]
    e = NAOShield(parallel_env(_tiny_map(tmp_path, robots)))
    e.reset(seed=0)
    *_, infos = e.step({"left": np.array([1.0, 0.0]), "right": np.array([0.0, 0.5])})
    for a, brake in (("left", [-2.0, 0.0]), ("right", [2.0, 0.0])):
        shield = infos[a]["shield"]
        assert shield["status"] == "infeasible" and shield["intervened"] is True
        np.testing.assert_array_equal(shield["applied"], brake)
    assert infos["left"]["shield"]["correction"] == 4.0


def _reference_step(e, ref_agents, actions):
    """What per-robot ``nearest_admissible`` gives for the step about to be taken."""
    base = e.unwrapped
    batch = base.arena.sensing()
    out = {}
    for a in base.agents:
        i = base.possible_agents.index(a)
        k = base.controlled_robots[i]
        a_max = float(base.arena.world.a_max[base.arena.robot_ids[k]])
        want = clip_accelerations(
            np.clip(np.asarray(actions[a], float), -1, 1)[None] * a_max, [a_max]
        )[0]
        out[a] = ref_agents[i].nearest_admissible(batch.observation(k), want)
    return out


KEPT_REPAIRED_ADJUSTED = {"kept", "repaired", "adjusted"}


@pytest.mark.parametrize(
    "name, kw, statuses",
    [
        ("crossing", {}, KEPT_REPAIRED_ADJUSTED),
        ("circle_swap", {}, KEPT_REPAIRED_ADJUSTED),
        # traffic near: nothing admissible -> the acceleration that postpones contact longest
        ("two_lane_road", {"controlled": ["overtaker"]}, {"repaired", "adjusted", "infeasible"}),
    ],
)
def test_the_shield_selects_robot_by_robot_what_it_selects_at_once(name, kw, statuses):
    # nearest_admissible_batch (the shield) against nearest_admissible robot by robot,
    # bit for bit
    e = NAOShield(parallel_env(name, time_limit=8.0, **kw))
    e.reset(seed=1)
    refs = e._make_agents(None)
    rng = np.random.default_rng(1)
    seen = set()
    while e.agents:
        actions = _random_actions(e, rng)
        expected = _reference_step(e, refs, actions)
        *_, infos = e.step(actions)
        for a, (accel, status) in expected.items():
            assert infos[a]["shield"]["status"] == status
            assert np.array_equal(infos[a]["shield"]["applied"], accel)
            seen.add(status)
    assert statuses <= seen


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(2, 8), steps=st.integers(1, 12))
def test_selected_accelerations_are_admissible_or_the_fallback(seed, n, steps):
    # n robots in a walled 7 m box (the map's seed 0), random actions drawn from seed
    e = NAOShield(
        parallel_env("crowd", n=n, lo=-3.5, hi=3.5, seed=0, reseed_map=False, time_limit=5.0)
    )
    e.reset(seed=seed)
    rng = np.random.default_rng(seed)
    refs = e._make_agents(None)
    base = e.unwrapped
    for _ in range(steps):
        batch = base.arena.sensing()
        *_, infos = e.step(_random_actions(e, rng))
        for a, info in infos.items():
            shield = info["shield"]
            assert shield.keys() == SHIELD_KEYS and shield["status"] in SHIELD_STATUSES
            assert shield["intervened"] == (shield["status"] != "kept")
            if shield["status"] in ("kept", "repaired", "adjusted"):
                i = base.possible_agents.index(a)
                obs = batch.observation(base.controlled_robots[i])
                ag = refs[i]
                assert ag.admissible(obs, shield["applied"])
            assert np.hypot(*shield["applied"]) <= 2.0 * (1 + 1e-9)
        if not e.agents:
            break


def test_the_ao_shield_predicts_constant_accelerations_and_options_reach_the_agents():
    e = NAOShield(parallel_env("circle_swap", n=3), agent="ao", horizon=2.0, margin=0.05)
    assert all(ag.predictor_name == "constant_acceleration" for ag in e.shield_agents)
    assert all(ag.horizon == 2.0 and ag.margin == 0.05 for ag in e.shield_agents)
    nao = NAOShield(parallel_env("circle_swap", n=3))
    assert all(ag.predictor_name == "turn_rate" and ag.horizon == 3.0 for ag in nao.shield_agents)


# ---------------------------------------------------------------- infos and statuses


def test_infos_carry_the_shield_entry_after_reset_and_every_step():
    e = NAOShield(parallel_env("crossing", time_limit=3.0))
    _, infos = e.reset(seed=2)
    assert all(
        i["shield"]
        == {
            "intervened": False,
            "correction": 0.0,
            "status": "reset",
            "desired": None,
            "applied": None,
        }
        for i in infos.values()
    )
    rng = np.random.default_rng(2)
    while e.agents:
        live = list(e.agents)
        *_, infos = e.step(_random_actions(e, rng))
        assert set(infos) == set(live)
        for info in infos.values():
            assert info["shield"].keys() == SHIELD_KEYS
            assert isinstance(info["shield"]["intervened"], bool)
            assert info["shield"]["correction"] >= 0.0
            assert info["shield"]["status"] in SHIELD_STATUSES
            assert {"collisions", "reached", "time", "faults"} <= info.keys()  # the env's
    assert sum(e.statuses.values()) == 30 * 12 and e.statuses["kept"] > 0


# ---------------------------------------------------------------- agents that finish


NEAR_AND_FAR = [
    {"name": "near_0", "start": [0.0, 0.0], "goal": [0.1, 0.0], "agent": "goal"},
    {"name": "far_0", "start": [5.0, 5.0], "goal": [-5.0, 5.0], "agent": "goal"},
]


def test_keep_finished_finished_agents_are_not_shielded(tmp_path):
    e = NAOShield(
        parallel_env(_tiny_map(tmp_path, NEAR_AND_FAR), keep_finished=True, after_done="hold")
    )
    e.reset(seed=0)
    zero = np.zeros(2, dtype=np.float32)
    _, _, _, _, infos = e.step({"near_0": zero, "far_0": zero})
    assert infos["near_0"]["finished"] is True
    assert infos["near_0"]["shield"]["status"] == "kept"  # it acted in this step
    steps = 1
    while e.agents:
        _, _, _, _, infos = e.step({"near_0": np.ones(2), "far_0": np.array([-1.0, 0.0])})
        steps += 1
        assert infos["near_0"]["shield"] == {
            "intervened": False,
            "correction": 0.0,
            "status": "finished",
            "desired": None,
            "applied": None,
        }
        assert infos["far_0"]["shield"]["status"] == "kept"
    assert steps == 50 and e.statuses == {"kept": 51}


def test_keep_finished_through_the_supersuit_vector_env():
    par = NAOShield(parallel_env("circle_swap", n=4, time_limit=1.0, keep_finished=True))
    vec = ss.pettingzoo_env_to_vec_env_v1(par)
    obs, infos = vec.reset(seed=0)
    assert obs.shape == (4, vec.observation_space.shape[0])
    rng = np.random.default_rng(0)
    resets = 0
    for _ in range(25):  # two and a half episodes of 10 steps
        obs, rew, term, trunc, infos = vec.step(rng.uniform(-1, 1, (4, 2)).astype(np.float32))
        assert all(i["shield"].keys() == SHIELD_KEYS for i in infos)
        resets += bool(np.all(term | trunc))
    assert resets == 2


# ---------------------------------------------------------------- the PettingZoo API


@pytest.mark.parametrize(
    "name, kw",
    [
        ("circle_swap", {"n": 3}),
        ("roundabout", {}),
        ("circle_swap", {"n": 3, "keep_finished": True}),
    ],
)
def test_the_shield_passes_the_api_tests(name, kw):
    kw = {"time_limit": 1.5, **kw}
    parallel_api_test(NAOShield(parallel_env(name, **kw)), num_cycles=30)
    api_test(nao_shield_v0(env(name, **kw)), num_cycles=30)
    parallel_seed_test(lambda: nao_shield_v0(parallel_env(name, **kw)), num_cycles=15)


def test_spaces_agents_and_state_are_the_envs():
    inner = parallel_env("crossing")
    e = nao_shield_v0(inner)
    assert isinstance(e, NAOShield) and e.unwrapped is inner
    assert e.possible_agents == inner.possible_agents
    for a in e.possible_agents:
        assert e.observation_space(a) is inner.observation_space(a)
        assert e.action_space(a) is inner.action_space(a)
    e.reset(seed=0)
    assert e.agents == inner.agents and np.array_equal(e.state(), inner.state())
    aec = nao_shield_v0(env("crossing"))
    aec.reset(seed=0)
    assert aec.agents == inner.possible_agents


COPIES = {
    "pickle": lambda x: pickle.loads(pickle.dumps(x)),
    "cloudpickle": lambda x: cloudpickle.loads(cloudpickle.dumps(x)),
    "deepcopy": copy.deepcopy,
}


@pytest.mark.slow
@pytest.mark.parametrize("how", COPIES)
def test_copies_mid_episode_continue_bit_for_bit(how):
    e = NAOShield(parallel_env("crossing", time_limit=8.0))
    twin_before_reset = COPIES[how](e)
    e.reset(seed=3)
    twin_before_reset.reset(seed=3)
    rng = np.random.default_rng(3)
    for _ in range(25):
        actions = _random_actions(e, rng)
        assert same(twin_before_reset.step(actions), e.step(actions))
    twin = COPIES[how](e)  # holding adjustments: the agents' state goes with the copy
    assert any(ag._holds_adjustment() for ag in e.shield_agents)
    for _ in range(40):
        actions = _random_actions(e, rng)
        assert same(twin.step(actions), e.step(actions))
    assert twin.statuses == e.statuses
    assert _summary(twin) == _summary(e)


@pytest.mark.parametrize("how", COPIES)
def test_the_shielded_aec_env_copies(how):
    e = nao_shield_v0(env("circle_swap", n=3, time_limit=3.0))
    e.reset(seed=1)
    rng = np.random.default_rng(1)
    for _ in range(3 * 10):
        e.step(rng.uniform(-1, 1, 2).astype(np.float32))
    twin = COPIES[how](e)
    for _ in range(3 * 10):
        assert twin.agent_selection == e.agent_selection and same(twin.last(), e.last())
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        e.step(action)
        twin.step(action)


def test_the_readme_example_runs():
    section = (Path(__file__).parents[1] / "docs" / "how-to" / "shield.md").read_text(
        encoding="utf-8"
    )
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    scope: dict = {}
    exec(code, scope)
    assert scope["env"].agents == [] and scope["shields"]
    assert all(info.keys() == SHIELD_KEYS for info in scope["shields"].values())
    assert scope["env"].statuses["kept"] > 0


# ---------------------------------------------------------------- bad input


def test_bad_wrapping_and_options_are_refused():
    with pytest.raises(TypeError, match="expected a nao_arena parallel env"):
        NAOShield(object())
    with pytest.raises(TypeError, match="AEC env converted from one"):
        nao_shield_v0(ss.clip_actions_v0(env("circle_swap", n=3)))
    with pytest.raises(ValueError, match="agent: expected 'nao', 'ao' or a subclass"):
        NAOShield(parallel_env("circle_swap", n=3), agent="orca")
    with pytest.raises(ValueError, match="replan"):
        NAOShield(parallel_env("circle_swap", n=3), replan=False)
    with pytest.raises(ValueError, match="horizon: expected a positive number"):
        NAOShield(parallel_env("circle_swap", n=3), horizon=-1.0)
    with pytest.raises(TypeError):
        NAOShield(parallel_env("circle_swap", n=3), no_such_option=1)


def test_bad_desired_accelerations_are_refused_by_the_agent():
    e = parallel_env("circle_swap", n=3)
    e.reset(seed=0)
    batch = e.arena.sensing()
    ag = NAOAgent()
    with pytest.raises(ValueError, match=r"desired: expected \(2,\) or \(1, 2\)"):
        ag.nearest_admissible(batch.observation(0), np.zeros(3))
    with pytest.raises(ValueError, match="desired: expected finite accelerations"):
        ag.nearest_admissible(batch.observation(0), [np.inf, 0.0])
    with pytest.raises(ValueError, match=r"desired: expected \(2, 2\) accelerations"):
        NAOAgent.nearest_admissible_batch([ag, NAOAgent()], batch, [0, 1], np.zeros(2))


def test_bad_actions_raise_what_the_env_raises():
    e = NAOShield(parallel_env("circle_swap", n=3))
    with pytest.raises(RuntimeError, match="reset"):
        e.step({})
    e.reset(seed=0)
    good = {a: np.zeros(2) for a in e.agents}
    with pytest.raises(ValueError, match="action of 'swap1': expected finite values"):
        e.step({**good, "swap1": np.array([np.nan, 0.0])})
    with pytest.raises(ValueError, match="missing actions for live agents: swap2"):
        e.step({a: good[a] for a in ("swap0", "swap1")})
    with pytest.raises(ValueError, match="expected real numbers"):
        e.step({**good, "swap0": [True, False]})
    assert e.unwrapped.arena.time == 0.0  # nothing stepped
