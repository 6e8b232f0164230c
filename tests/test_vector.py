"""nao_arena.vector and the SB3 vector backend against an independent model.

The model is K plain :class:`~nao_arena.environment.NaoArenaParallelEnv` s stepped through
the public dict API (``env.step({agent: action})``), copy k reset with seed ``s + k`` and
without a seed after each of its episodes ends, never through the code under test. The
vector env must give the same observations, rewards, flags and infos bit for bit,
auto-reset in the same step, reject bad input before stepping any copy, repeat itself in
fresh processes, and, through :func:`nao_arena.sb3.vec_env` with ``backend="vector"``,
give SB3 what the SuperSuit backend gives.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from bitwise import same  # tests/bitwise.py
from numpy.typing import NDArray

import nao_arena.vector_step as batch_module
from nao_arena.environment import OWN_FEATURES, NaoArenaParallelEnv
from nao_arena.envs import load
from nao_arena.vector import VectorEnv

IMPERFECT: dict[str, Any] = {"sensing_noise": {"position": 0.05}, "sensing_dropout": 0.2}
"""An imperfect world: noisy sensed positions, neighbours missed one time in five."""

INFO_KEYS = ("reached", "collisions", "faults", "finished")
"""The per-agent infos the vector env stacks into (K, R) arrays."""

Policy = Callable[[NDArray[np.float32], np.random.Generator], NDArray[np.float64]]
"""Actions (..., 2) from observations (..., D) and a generator."""


@pytest.fixture(autouse=True)
def _quiet() -> Iterator[None]:
    with warnings.catch_warnings():
        # PettingZoo's advice on agent names and infinite observation bounds
        warnings.simplefilter("ignore", UserWarning)
        yield


def random_actions(obs: NDArray[np.float32], rng: np.random.Generator) -> NDArray[np.float64]:
    """Uniform actions in [-1.2, 1.2] (beyond the box: the envs clip them)."""
    return rng.uniform(-1.2, 1.2, (*obs.shape[:-1], 2))


def seek_actions(obs: NDArray[np.float32], rng: np.random.Generator) -> NDArray[np.float64]:
    """Towards the goal read from each observation (goal offset, velocity), with noise, so
    that robots reach their goals at different times."""
    goal = obs[..., 0:2].astype(np.float64)
    vel = obs[..., 2:4].astype(np.float64)
    dist = np.hypot(goal[..., 0], goal[..., 1])[..., None]
    want = goal / np.maximum(dist, 1e-9) * np.minimum(1.4, dist)
    return np.clip((want - vel) / 0.5 + rng.normal(0.0, 0.3, goal.shape), -1.2, 1.2)


def first_seeks(obs: NDArray[np.float32], rng: np.random.Generator) -> NDArray[np.float64]:
    """The first agent of each copy seeks its goal (:func:`seek_actions`), the others
    wander (small uniform actions): some robots finish, others run out of time."""
    actions = rng.uniform(-0.3, 0.3, (*obs.shape[:-1], 2))
    actions[..., 0, :] = seek_actions(obs[..., :1, :], rng)[..., 0, :]
    return actions


@dataclass
class Step:
    """One step of K copies as (K, R, ...) arrays, the vector env's layout; ``ended`` (K,)
    marks the copies whose episode ended, ``final`` their last observations."""

    obs: NDArray[np.float32]
    rewards: NDArray[np.float64]
    terminated: NDArray[np.bool_]
    truncated: NDArray[np.bool_]
    infos: dict[str, NDArray[Any]]
    ended: NDArray[np.bool_]
    final: NDArray[np.float32]


class Reference:
    """K plain envs stepped through the dict API: what the vector env's copies must be."""

    def __init__(self, env_id: str, copies: int, seed: int, **env_kwargs: Any) -> None:
        make = load(env_id).parallel_env
        self.envs: list[NaoArenaParallelEnv] = [
            make(keep_finished=True, **env_kwargs) for _ in range(copies)
        ]
        self.agents = list(self.envs[0].possible_agents)
        self.obs = np.stack(
            [self._rows(env.reset(seed=seed + k)[0]) for k, env in enumerate(self.envs)]
        )

    def _rows(self, by_agent: dict[str, Any]) -> NDArray[Any]:
        return np.stack([by_agent[a] for a in self.agents])

    def step(self, actions: NDArray[np.float64]) -> Step:
        """Every copy's ``env.step`` with its rows of ``actions`` (K, R, 2); a copy whose
        episode ended (no agents left) is reset without a seed."""
        rows: list[tuple[Any, ...]] = []
        ended = np.zeros(len(self.envs), dtype=bool)
        final = np.zeros_like(self.obs)
        for k, env in enumerate(self.envs):
            obs, rew, term, trunc, infos = env.step(
                {a: actions[k, i] for i, a in enumerate(self.agents)}
            )
            assert list(obs) == self.agents  # keep_finished: every agent until the end
            row = self._rows(obs)
            if not env.agents:
                ended[k] = True
                final[k] = row
                row = self._rows(env.reset()[0])
            rows.append((row, rew, term, trunc, infos))
        self.obs = np.stack([r[0] for r in rows])
        info_arrays: dict[str, NDArray[Any]] = {
            key: np.array(
                [[r[4][a][key] for a in self.agents] for r in rows],
                dtype=np.int64 if key in ("collisions", "faults") else bool,
            )
            for key in INFO_KEYS
        }
        info_arrays["time"] = np.array([r[4][self.agents[0]]["time"] for r in rows])
        assert all(len({r[4][a]["time"] for a in self.agents}) == 1 for r in rows)
        return Step(
            obs=self.obs,
            rewards=np.array([[r[1][a] for a in self.agents] for r in rows], dtype=np.float64),
            terminated=np.array([[r[2][a] for a in self.agents] for r in rows], dtype=bool),
            truncated=np.array([[r[3][a] for a in self.agents] for r in rows], dtype=bool),
            infos=info_arrays,
            ended=ended,
            final=final,
        )


def vector_step(vec: VectorEnv, actions: NDArray[np.float64]) -> tuple[Step, dict[str, Any]]:
    """The vector env's step as a :class:`Step`, and its raw infos."""
    obs, rewards, terminated, truncated, infos = vec.step(actions)
    ended = infos.get("_final_obs", np.zeros(vec.num_envs, dtype=bool))
    final = infos.get("final_obs", np.zeros_like(obs))
    step = Step(obs, rewards, terminated, truncated, infos, ended, final)
    return step, infos


def assert_same_step(got: Step, want: Step) -> None:
    """Observations, rewards, flags, infos and the final observations of the copies that
    ended: equal to the bit, with the documented dtypes and shapes."""
    assert same(got.obs, want.obs)
    assert same(got.rewards, want.rewards)
    assert same(got.terminated, want.terminated)
    assert same(got.truncated, want.truncated)
    for key in (*INFO_KEYS, "time"):
        assert same(got.infos[key], want.infos[key]), key
    assert np.array_equal(got.ended, want.ended)
    assert same(got.final[want.ended], want.final[want.ended])


def lockstep(
    env_id: str,
    env_kwargs: dict[str, Any],
    policy: Policy,
    seed: int,
    steps: int,
    copies: int = 3,
    check: Callable[[VectorEnv, Reference], None] | None = None,
) -> Iterator[tuple[Step, dict[str, Any], Step]]:
    """The vector env and the :class:`Reference`, stepped together with the policy's
    actions on the reference's observations: (vector step, its raw infos, reference step);
    ``check(vec, ref)`` after every step."""
    vec = VectorEnv(env_id, copies, seed=seed, **env_kwargs)
    ref = Reference(env_id, copies, seed, **env_kwargs)
    obs, infos = vec.reset()
    assert same(obs, ref.obs)
    assert obs.shape == (copies, len(ref.agents), ref.obs.shape[-1])
    assert vec.agents == ref.agents
    assert not infos["reached"].any() and not infos["collisions"].any()
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        actions = policy(ref.obs, rng)
        got, raw = vector_step(vec, actions)
        want = ref.step(actions)
        if check is not None:
            check(vec, ref)
        yield got, raw, want
    vec.close()


@dataclass(frozen=True)
class Case:
    """A scene for the lockstep tests; ``finishers``: some robots finish well before the
    end of their episode, so that ``after_done`` drives them for a while."""

    env_id: str
    env_kwargs: dict[str, Any]
    policy: Policy
    finishers: bool
    contacts: bool


CASES = {
    "circle_swap": Case(
        "circle_swap_v0", {"n": 10, "radius": 2.0, "time_limit": 3.0}, random_actions, False, True
    ),
    "crossing_hold": Case(
        "crossing_v0",
        {"n": 2, "after_done": "hold", "time_limit": 14.0},
        seek_actions,
        True,
        True,
    ),
    "crowd_agent": Case(
        "crowd_v0", {"n": 3, "lo": -4.0, "hi": 4.0, "time_limit": 5.0}, seek_actions, True, False
    ),
    "imperfect_world": Case(
        "circle_swap_v0",
        {"n": 10, "radius": 2.0, "time_limit": 3.0, "arena": IMPERFECT},
        random_actions,
        False,
        True,
    ),
}


def max_steps(case: Case) -> int:
    par = load(case.env_id).parallel_env(keep_finished=True, **case.env_kwargs)
    return int(par.max_steps)


@pytest.mark.parametrize("check_every", [1, 7])
@pytest.mark.parametrize("name", list(CASES))
def test_vector_env_equals_separate_envs_bit_for_bit(
    name: str, check_every: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """K=3 copies equal 3 plain envs stepped through the dict API (seeds s + k, then
    unseeded resets), to the bit: observations, the final observations of every episode
    that ends, rewards, terminated, truncated and the infos, over more than two episodes'
    worth of steps, and every copy's own state after every step (:func:`assert_same_copies`);
    with finished robots held (``after_done="hold"``) or driven by their own agents, and
    in an imperfect world (sensing noise and dropout). The plain scenes' copies step in
    the compiled batch while every robot is unfinished (and on their own after), the
    imperfect world's never. The copies' objects are read (and so take what the batch
    ran) after every step, or every 7th with room for 5 batched periods between (the
    objects take up to 5 periods at once, and more often than they are read)."""
    case = CASES[name]
    if check_every > 1:
        monkeypatch.setattr(batch_module, "HISTORY", 5)
    checks = iter(range(1, 10**9))
    endings = np.zeros(3, dtype=np.int64)
    contacts = finished_before_end = 0
    seen: list[tuple[Step, Step]] = []
    batched = count_batched(monkeypatch)
    for got, _, want in lockstep(
        case.env_id,
        case.env_kwargs,
        case.policy,
        seed=11,
        steps=2 * max_steps(case) + 3,
        check=lambda vec, ref: next(checks) % check_every or assert_same_copies(vec, ref),
    ):
        assert_same_step(got, want)
        seen.append((got, want))
        endings += want.ended
        contacts += int(want.infos["collisions"].sum())
        finished_before_end += int(want.infos["finished"][~want.ended].sum())
    assert (endings >= 1).all(), endings  # every copy auto-reset at least once
    for got, want in seen:  # no returned array was a view that later steps overwrote
        assert_same_step(got, want)
    if case.contacts:
        assert contacts > 0
    if case.finishers:
        assert finished_before_end > 0
    if name == "imperfect_world":
        assert batched == {"calls": 0, "copies": 0, "events": 0}
    else:
        assert batched["copies"] > 100, batched
    if name == "circle_swap":
        assert batched["events"] > 0  # contacts began, ended or deepened in the batch


def count_batched(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Counts, from now on, the compiled batch's calls, the copies they stepped and the
    contact event rows they returned (:func:`nao_arena.vector_step.step_copies`)."""
    counts = {"calls": 0, "copies": 0, "events": 0}
    step_copies = batch_module.step_copies

    def counted(copies: Any, which: NDArray[np.int64], *args: Any) -> Any:
        codes, values = step_copies(copies, which, *args)
        counts["calls"] += 1
        counts["copies"] += len(which)
        counts["events"] += len(codes)
        return codes, values

    monkeypatch.setattr(batch_module, "step_copies", counted)
    return counts


def assert_same_copies(vec: VectorEnv, ref: Reference) -> None:
    """Every copy's own objects equal the reference env's: the episode summary (the
    statistics, contact events and trajectory hash), the world's state, last period,
    commands and time, the env's agents, events and last result."""
    for env, want in zip(vec.envs, ref.envs, strict=True):
        assert same(env.arena.summary().to_dict(), want.arena.summary().to_dict())
        world, other = env.arena.world, want.arena.world
        for name in ("positions", "velocities", "previous_positions", "substep_positions"):
            assert same(getattr(world, name), getattr(other, name)), name
        assert same(world.applied_accelerations, other.applied_accelerations)
        for array in (world.substep_positions, world.applied_accelerations):
            assert not array.flags.writeable  # handed out read-only, as a stepped world's
        assert same(world.commands, other.commands)
        assert world.time == other.time
        assert env.agents == want.agents
        assert same(env.events, want.events)
        assert (env.last_result is None) == (want.last_result is None)
        if env.last_result is not None and want.last_result is not None:
            assert same(env.last_result.commanded, want.last_result.commanded)
            assert same(env.last_result.state.accelerations, want.last_result.state.accelerations)
            assert same(  # by the bit: a contact's NaN entries are equal
                [e.to_dict() for e in env.last_result.contacts],
                [e.to_dict() for e in want.last_result.contacts],
            )


def test_auto_reset_replaces_exactly_the_copies_that_ended() -> None:
    """At a step that ends some copies' episodes: ``_final_obs`` marks exactly those;
    their ``final_obs`` rows are the ended episodes' last observations and the returned
    rows the new episodes' first (full time left, nobody finished); every agent of an
    ended copy is terminated or truncated, no agent of another copy is; the step's infos
    are the ended episode's. Copies end at different steps here (robots reaching their
    goals end an episode early)."""
    case = CASES["crowd_agent"]
    time_limit = float(case.env_kwargs["time_limit"])
    time_left, finished = OWN_FEATURES.index("time_left"), -1  # the layout's first, last
    partial = whole = 0
    for got, raw, want in lockstep(
        case.env_id, case.env_kwargs, case.policy, seed=5, steps=3 * max_steps(case)
    ):
        done = got.terminated | got.truncated
        if not want.ended.any():
            assert "final_obs" not in raw and "_final_obs" not in raw
            assert not done.any()
            continue
        mask = raw["_final_obs"]
        assert mask.dtype == np.bool_ and mask.shape == (3,)
        assert np.array_equal(mask, want.ended)
        assert raw["final_obs"].shape == got.obs.shape
        assert same(raw["final_obs"][mask], want.final[mask])
        assert same(got.obs, want.obs)  # the reference reset the ended copies
        assert (got.obs[mask][..., time_left] == np.float32(time_limit)).all()
        assert (got.obs[mask][..., finished] == 0.0).all()
        assert (raw["final_obs"][mask][..., time_left] < np.float32(time_limit)).all()
        assert done[mask].all() and not done[~mask].any()
        assert (got.infos["time"][mask] > 0.0).all()  # the ended episode's, not 0.0
        assert np.array_equal(got.infos["reached"], want.infos["reached"])
        partial += not mask.all()
        whole += int(mask.sum())
    assert partial > 0  # some step ended some copies but not all
    assert whole >= 3


def test_explicit_resets_seed_the_copies() -> None:
    """``reset(seed=s)`` starts copy k with seed s + k; ``reset()`` after the first makes
    every copy draw its episode seed from its own generator, as the plain env's unseeded
    reset does; the constructor's seed applies only to the first reset."""
    kw: dict[str, Any] = {"n": 3, "lo": -4.0, "hi": 4.0, "time_limit": 2.0}
    vec = VectorEnv("crowd_v0", 2, seed=4, **kw)
    envs = [load("crowd_v0").parallel_env(keep_finished=True, **kw) for _ in range(2)]

    def rows(seed: int | None) -> NDArray[np.float32]:
        firsts = [
            env.reset(seed=None if seed is None else seed + k)[0] for k, env in enumerate(envs)
        ]
        return np.stack([np.stack([f[a] for a in vec.agents]) for f in firsts])

    assert same(vec.reset()[0], rows(4))
    assert same(vec.reset()[0], rows(None))
    assert same(vec.reset(seed=20)[0], rows(20))
    again = vec.reset()[0]
    assert same(again, rows(None))
    assert not np.array_equal(again, rows(4))  # the seeds matter in this scene


def test_spaces_describe_the_arrays() -> None:
    """The spaces are those of the copies' agents stacked (K, R, ...): every returned
    observation and final observation lies in ``observation_space``, whose rows are the
    plain env's agent space; actions are (K, R, 2) in [-1, 1]."""
    kw: dict[str, Any] = {"n": 3, "lo": -4.0, "hi": 4.0, "time_limit": 1.0}
    vec = VectorEnv("crowd_v0", 2, seed=0, **kw)
    par = load("crowd_v0").parallel_env(keep_finished=True, **kw)
    single = par.observation_space(par.possible_agents[0])
    assert vec.agents == par.possible_agents and vec.num_agents == 3
    assert vec.observation_space.shape == (2, 3, *single.shape)
    assert same(vec.observation_space.low[1, 2], single.low)
    assert same(vec.observation_space.high[0, 1], single.high)
    assert vec.single_observation_space == single
    assert vec.action_space.shape == (2, 3, 2)
    assert (vec.action_space.low == -1.0).all() and (vec.action_space.high == 1.0).all()
    obs, _ = vec.reset()
    assert vec.observation_space.contains(obs)
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(2 * par.max_steps):
        obs, _, _, _, infos = vec.step(random_actions(obs, rng))
        assert vec.observation_space.contains(obs)
        if "final_obs" in infos:
            assert vec.observation_space.contains(infos["final_obs"])
            ends += 1
    assert ends == 2


@pytest.mark.parametrize("name", ["circle_swap", "crossing_hold", "crowd_agent"])
def test_step_arrays_equals_the_dict_step(name: str) -> None:
    """The env's own ``step_arrays`` returns what ``step`` returns in its dicts, in
    ``possible_agents`` order, and leaves the same ``events`` (contact and fault dicts),
    over two episodes (the second after an unseeded reset), with contacts and (in the
    scenes with finishers) robots finished before the end."""
    case = CASES[name]
    a = load(case.env_id).parallel_env(keep_finished=True, **case.env_kwargs)
    b = load(case.env_id).parallel_env(keep_finished=True, **case.env_kwargs)
    agents = list(a.possible_agents)
    rng = np.random.default_rng(2)
    contacts = finished = 0
    for episode in range(2):
        seed = 8 if episode == 0 else None
        obs_a, _ = a.reset(seed=seed)
        obs_b, _ = b.reset(seed=seed)
        obs = np.stack([obs_a[x] for x in agents])
        assert same(obs, np.stack([obs_b[x] for x in agents]))
        while a.agents:
            actions = case.policy(obs, rng)
            o, rew, term, trunc, infos = a.step(dict(zip(agents, actions, strict=True)))
            out = b.step_arrays(actions)
            obs = np.stack([o[x] for x in agents])
            assert same(out.observations, obs)
            assert same(out.rewards, np.array([rew[x] for x in agents]))
            assert same(out.terminated, np.array([term[x] for x in agents]))
            assert same(out.truncated, np.array([trunc[x] for x in agents]))
            for key in INFO_KEYS:
                want = np.array([infos[x][key] for x in agents])
                assert np.array_equal(getattr(out, key), want), key
            assert all(out.time == infos[x]["time"] for x in agents)
            assert same(b.events, a.events)
            assert b.agents == a.agents
            contacts += sum(len(a.events[x]["collisions"]) for x in agents)
            finished += int(out.finished.sum()) if a.agents else 0
        with pytest.raises(RuntimeError, match="episode has ended"):
            b.step_arrays(np.zeros((len(agents), 2)))
    assert contacts > 0
    if case.finishers:
        assert finished > 0


# ---------------------------------------------------------------------------- bad input

SMALL: dict[str, Any] = {"n": 3, "radius": 2.0, "time_limit": 3.0}


@pytest.mark.parametrize("num_envs", [0, -1, True, False, 2.0, "2", None])
def test_num_envs_must_be_a_positive_integer(num_envs: Any) -> None:
    """0, negatives, booleans, floats, strings and None are refused, naming num_envs."""
    with pytest.raises(ValueError, match="num_envs: expected a positive integer"):
        VectorEnv("circle_swap_v0", num_envs, **SMALL)


def test_numpy_integer_num_envs_is_accepted() -> None:
    vec = VectorEnv("circle_swap_v0", np.int64(2), seed=0, **SMALL)
    assert vec.num_envs == 2 and isinstance(vec.num_envs, int)
    assert vec.reset()[0].shape == (2, 3, vec.single_observation_space.shape[0])


def test_a_vector_env_of_envs_made_alike() -> None:
    """``VectorEnv.of_envs``: envs of a map (not a versioned env) step as separate envs
    do; envs not made alike are refused with one line."""
    envs = [NaoArenaParallelEnv("crossing", keep_finished=True, time_limit=3.0) for _ in range(3)]
    vec = VectorEnv.of_envs(envs, seed=2)
    ref = [NaoArenaParallelEnv("crossing", keep_finished=True, time_limit=3.0) for _ in range(3)]
    obs, _ = vec.reset()
    want = np.stack([np.stack(list(r.reset(seed=2 + k)[0].values())) for k, r in enumerate(ref)])
    assert same(obs, want) and vec.env_id == "crossing"
    rng = np.random.default_rng(0)
    for _ in range(40):
        actions = rng.uniform(-1.0, 1.0, vec.action_space.shape)
        got, rewards, *_ = vec.step(actions)
        for k, r in enumerate(ref):
            out = r.step({a: actions[k, i] for i, a in enumerate(r.agents)})
            if not r.agents:
                r.reset()
            else:
                assert same(got[k], np.stack(list(out[0].values())))
                assert same(rewards[k], np.array(list(out[1].values())))
    other = NaoArenaParallelEnv("crossing", keep_finished=True, time_limit=4.0)
    with pytest.raises(ValueError, match="same map, map parameters and options"):
        VectorEnv.of_envs([envs[0], other])
    with pytest.raises(ValueError, match="keep_finished=True"):
        VectorEnv.of_envs([NaoArenaParallelEnv("crossing")])


def test_keep_finished_false_is_refused() -> None:
    with pytest.raises(ValueError, match="keep_finished"):
        VectorEnv("circle_swap_v0", 2, keep_finished=False, **SMALL)
    vec = VectorEnv("circle_swap_v0", 1, keep_finished=True, **SMALL)
    assert vec.envs[0].options.keep_finished


def test_step_before_reset_is_refused() -> None:
    vec = VectorEnv("circle_swap_v0", 2, seed=0, **SMALL)
    with pytest.raises(RuntimeError, match=r"reset\(\) before step\(\)"):
        vec.step(np.zeros((2, 3, 2)))
    par = load("circle_swap_v0").parallel_env(keep_finished=True, **SMALL)
    with pytest.raises(RuntimeError, match=r"reset\(\) before step\(\)"):
        par.step_arrays(np.zeros((3, 2)))


@pytest.mark.parametrize(
    "shape", [(2, 3), (2, 3, 3), (1, 3, 2), (3, 3, 2), (2, 2, 2), (6, 2), (2, 3, 2, 1)]
)
def test_wrong_action_shapes_are_refused(shape: tuple[int, ...]) -> None:
    vec = VectorEnv("circle_swap_v0", 2, seed=0, **SMALL)
    vec.reset()
    with pytest.raises(ValueError, match=r"actions: expected shape \(2, 3, 2\), got"):
        vec.step(np.zeros(shape))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_actions_are_refused_before_any_copy_steps(bad: float) -> None:
    """A NaN or inf anywhere (here in the last copy) is refused with ValueError, and no
    copy has stepped: the next valid steps equal the reference that never saw the bad
    one."""
    vec = VectorEnv("circle_swap_v0", 2, seed=1, **SMALL)
    ref = Reference("circle_swap_v0", 2, 1, **SMALL)
    vec.reset()
    rng = np.random.default_rng(0)
    actions = random_actions(ref.obs, rng)
    poisoned = actions.copy()
    poisoned[1, 2, 1] = bad
    with pytest.raises(ValueError, match="actions: expected finite numbers"):
        vec.step(poisoned)
    for _ in range(3):
        got, _ = vector_step(vec, actions)
        assert_same_step(got, ref.step(actions))
        actions = random_actions(ref.obs, rng)


def test_step_arrays_refuses_bad_input() -> None:
    """The env's own array step: wrong shape, NaN, and an env without keep_finished."""
    par = load("circle_swap_v0").parallel_env(keep_finished=True, **SMALL)
    par.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(3, 2\), got shape \(2, 2\)"):
        par.step_arrays(np.zeros((2, 2)))
    nan = np.zeros((3, 2))
    nan[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN or inf"):
        par.step_arrays(nan)
    leaving = load("circle_swap_v0").parallel_env(**SMALL)
    leaving.reset(seed=0)
    with pytest.raises(ValueError, match="keep_finished=True"):
        leaving.step_arrays(np.zeros((3, 2)))


# ---------------------------------------------------------------------------- processes

ROLLOUT = textwrap.dedent(
    """
    import hashlib
    import numpy as np
    from nao_arena.vector import VectorEnv

    def rollout(seed):
        arena = {"sensing_noise": {"position": 0.05}, "sensing_dropout": 0.2}
        kw = dict(n=3, lo=-4.0, hi=4.0, time_limit=1.5, arena=arena)
        vec = VectorEnv("crowd_v0", 2, seed=seed, **kw)
        rng = np.random.default_rng(0)
        h = hashlib.sha256()
        obs, _ = vec.reset()
        h.update(obs.tobytes())
        for _ in range(40):
            out = vec.step(rng.uniform(-1.2, 1.2, (2, vec.num_agents, 2)))
            for x in out[:4]:
                h.update(x.dtype.str.encode() + x.tobytes())
            for key in sorted(out[4]):
                h.update(key.encode() + out[4][key].dtype.str.encode() + out[4][key].tobytes())
        return h.hexdigest()
    """
)


def child_hash(hashseed: str) -> str:
    """The rollout's hash computed in a fresh Python process."""
    env = {**os.environ, "PYTHONHASHSEED": hashseed}
    # from the tests folder: from the repository root, ``-c`` would import the source tree
    res = subprocess.run(
        [sys.executable, "-c", ROLLOUT + "\nprint(rollout(7))"],
        capture_output=True,
        text=True,
        env=env,
        check=True,
        cwd=os.path.dirname(os.path.abspath(__file__)),
        timeout=120,
    )
    return res.stdout.strip()


@pytest.mark.slow
@pytest.mark.installed
def test_rollouts_repeat_in_fresh_processes() -> None:
    """The same seeded rollout (a seeded map, sensing noise, auto-resets) hashes alike in
    two fresh processes with different string hash seeds and in this one; another seed
    hashes otherwise."""
    scope: dict[str, Any] = {}
    exec(ROLLOUT, scope)  # the children's own code, in this process
    here, other = scope["rollout"](7), scope["rollout"](8)
    first, second = child_hash("1"), child_hash("2")
    assert len(first) == 64
    assert first == second == here
    assert other != here


# ---------------------------------------------------------------------------- SB3


def rl_extra() -> None:
    pytest.importorskip("stable_baselines3", reason="needs the rl extra")
    pytest.importorskip("supersuit", reason="needs the rl extra")


SWAP: dict[str, Any] = {"n": 4, "radius": 1.5, "time_limit": 3.0}
"""A small swap: 4 robots 3 m from their goals, 30 control steps per episode (with
:func:`first_seeks` the first robot mostly reaches its goal, the others do not; some
robots collide)."""


@pytest.mark.filterwarnings("ignore:The `render_mode` attribute")  # SuperSuit has none
def test_sb3_vector_backend_equals_supersuit() -> None:
    """``backend="vector"`` gives SB3 what the SuperSuit backend gives over two episodes:
    observations (scaled), rewards, dones, terminal observations and the reached,
    collisions, faults and finished infos; at the episode ends ``TimeLimit.truncated`` is
    "truncated and not terminated" as the plain envs report it (both values occur)."""
    rl_extra()
    from nao_arena.sb3 import vec_env

    fast = vec_env("circle_swap_v0", copies=2, seed=3, backend="vector", **SWAP)
    slow = vec_env("circle_swap_v0", copies=2, seed=3, **SWAP)
    ref = Reference("circle_swap_v0", 2, 3, position_margin=2.0, **SWAP)
    assert same(fast.reset(), slow.reset())
    rng = np.random.default_rng(1)
    cut_values: set[bool] = set()
    ends = contacts = 0
    for _ in range(2 * 30 + 2):
        actions = first_seeks(ref.obs, rng).astype(np.float32)
        want = ref.step(actions.astype(np.float64))
        flat = np.clip(actions.reshape(-1, 2), -1.0, 1.0)
        obs_f, rew_f, done_f, info_f = fast.step(flat)
        obs_s, rew_s, done_s, info_s = slow.step(flat)
        assert same(obs_f, obs_s)
        assert same(rew_f, rew_s)
        assert np.array_equal(done_f, done_s)
        assert np.array_equal(done_f, (want.terminated | want.truncated).reshape(-1))
        term, trunc = want.terminated.reshape(-1), want.truncated.reshape(-1)
        contacts += sum(f["collisions"] for f in info_f)
        for i, (f, s) in enumerate(zip(info_f, info_s, strict=True)):
            for key in ("reached", "collisions", "faults", "finished"):
                assert f[key] == s[key], (i, key)
            assert ("terminal_observation" in f) == bool(done_f[i])
            assert ("TimeLimit.truncated" in f) == bool(done_f[i])
            if done_f[i]:
                assert same(f["terminal_observation"], s["terminal_observation"])
                assert f["TimeLimit.truncated"] == bool(trunc[i] and not term[i])
                cut_values.add(f["TimeLimit.truncated"])
                ends += 1
    assert ends == 2 * 2 * 4  # two episodes of both copies
    assert cut_values == {True, False}
    assert contacts > 0
    fast.close()
    slow.close()


def test_sb3_backend_options_are_checked() -> None:
    rl_extra()
    from nao_arena.sb3 import vec_env

    with pytest.raises(ValueError, match="shield needs backend 'supersuit'"):
        vec_env("circle_swap_v0", copies=2, seed=3, backend="vector", shield=True, **SWAP)
    with pytest.raises(ValueError, match="backend: expected 'supersuit' or 'vector', got 'nope'"):
        vec_env("circle_swap_v0", copies=2, seed=3, backend="nope", **SWAP)


CROWD: dict[str, Any] = {"n": 4, "lo": -4.0, "hi": 4.0, "time_limit": 0.5}
"""A small seeded crowd whose episodes end every 5 control steps: two copies make 8 SB3
entries, so a rollout of ``n_steps=8`` holds 64 agent-steps and several episode ends."""


def ppo_run(env_seed: int, ppo_seed: int) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """PPO (``n_steps=8, batch_size=16``) for 64 timesteps on the vector backend built with
    ``env_seed``: its policy's parameters and the observations of its rollout."""
    from stable_baselines3 import PPO

    from nao_arena.sb3 import vec_env

    vec = vec_env("crowd_v0", copies=2, seed=env_seed, backend="vector", **CROWD)
    assert vec.num_envs == 8
    model = PPO("MlpPolicy", vec, n_steps=8, batch_size=16, n_epochs=1, seed=ppo_seed, device="cpu")
    model.learn(64)
    assert model.num_timesteps == 64
    # the buffer after training: flattened entry by entry, n_steps rows each
    buffer = model.rollout_buffer
    assert buffer.episode_starts.reshape(8, 8)[:, 1:].any()  # episodes ended in the rollout
    observed = buffer.observations.reshape(8, 8, -1).copy()
    vec.close()
    params = np.concatenate([p.detach().numpy().ravel() for p in model.policy.parameters()])
    return params, observed


def test_ppo_learns_on_the_vector_backend_and_its_seed_seeds_it() -> None:
    """PPO learns on ``backend="vector"`` without error (episodes end within the rollout);
    ``PPO(seed=s)`` seeds it: runs with the same PPO seed give the same parameters and
    observations even over vec_envs built with different seeds (PPO's seed decides the
    episodes: copy k starts with s + k), and another PPO seed gives other parameters."""
    rl_extra()

    a, obs_a = ppo_run(3, 0)
    b, obs_b = ppo_run(9, 0)
    c, _ = ppo_run(3, 1)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(obs_a, obs_b)
    assert not np.array_equal(a, c)
    first = VectorEnv("crowd_v0", 2, seed=0, **CROWD)  # walled: finite bounds
    low, high = first.single_observation_space.low, first.single_observation_space.high
    want = (first.reset()[0].reshape(8, -1) - low) / (high - low)
    np.testing.assert_array_equal(obs_a[:, 0], want)  # copy k started with PPO's seed + k
    assert not np.array_equal(  # the env's seed matters in this scene
        VectorEnv("crowd_v0", 2, seed=3, **CROWD).reset()[0],
        VectorEnv("crowd_v0", 2, seed=9, **CROWD).reset()[0],
    )
