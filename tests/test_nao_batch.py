"""The ``nao`` agents' batch step in its compiled calls (:mod:`nao_arena.agents._nao_batch`)
is the step it replaced, bit for bit: the same accelerations, the same agents' state
and errors, step after step, on random crowds with traffic, walls, goals missing,
non-finite states and every option that changes the path through the step; and each
compiled call is its plain definition."""

from __future__ import annotations

import collections
import math

import numpy as np
import pytest
from bitwise import same_up_to_nan_sign
from hypothesis import given, settings
from hypothesis import strategies as st
from reference.nao_batch_reference import act_rows_reference

import nao_arena.agents.nao as nao_module
from nao_arena.agents import _nao_columns as columns
from nao_arena.agents._nao_batch import (
    DECIDED,
    PREPARED,
    SETTLED,
    desired_rows,
    own_rows,
    rows_with,
)
from nao_arena.agents._nao_bundles import OwnInputs
from nao_arena.agents.goal import goal_seeking_accels
from nao_arena.agents.nao import NAOAgent
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map
from nao_arena.sensing import SensingBatch, neighbour_lists


def crowd(
    rng: np.random.Generator, n_robots: int, traffic: int, walls: bool, odd: str, spread: float
) -> SensingBatch:
    """n_robots robots (bodies 0 ..) and ``traffic`` cars (after them) within ``spread`` m
    of the origin, some standing, some slow; walls: a corner of an 8 m box; odd: "nan"
    (a car's velocity unknown), "inf" (robot 0 infinitely fast), "goal" (some goals
    missing, one with a route) or ""."""
    n = n_robots + traffic
    pos = rng.uniform(-spread, spread, (n, 2))
    vel = rng.uniform(-1.5, 1.5, (n, 2)) * rng.choice([0.0, 0.05, 1.0], (n, 1))
    if odd == "nan" and traffic:
        vel[n_robots, 0] = np.nan
    if odd == "inf":
        vel[0] = (np.inf, 0.0)
    goals = pos[:n_robots] + rng.normal(0.0, 3.0, (n_robots, 2)) * rng.choice(
        [0.01, 1.0], (n_robots, 1)
    )
    routes: list = [None] * n_robots
    if odd == "goal":
        goals[rng.random(n_robots) < 0.5] = np.nan
        goals[0] = np.nan
        routes[0] = rng.uniform(-5.0, 5.0, (3, 2))
    bodies = (
        rng.permutation(n)[:n_robots].astype(np.int64)
        if traffic == 0
        else np.arange(n_robots, dtype=np.int64)
    )
    start, index = neighbour_lists(bodies, pos, 4.0, int(rng.integers(1, 12)))
    segs = (
        np.array([[[-4.0, -4.0], [4.0, -4.0]], [[4.0, -4.0], [4.0, 4.0]]])
        if walls
        else np.zeros((0, 2, 2))
    )
    return SensingBatch(
        time=0.0,
        dt=0.1,
        positions=pos,
        velocities=vel,
        accelerations=rng.uniform(-1.0, 1.0, (n, 2)),
        radii=rng.uniform(0.2, 0.5, n),
        a_max=rng.choice([2.0, 1.0], n),
        v_max=rng.choice([1.5, 1.0], n),
        kinds=np.array(["robot"] * n_robots + ["traffic"] * traffic),
        plans=None,
        known_paths=None,
        path_times=np.zeros(0),
        bodies=bodies,
        goals=goals,
        routes=routes,
        walls=segs,
        wall_radius=np.full(len(segs), 0.05),
        nb_start=start,
        nb_index=index,
        substeps=int(rng.choice([1, 10])),
    )


def _broken_predictor(times: np.ndarray, nb: object) -> np.ndarray:
    raise RuntimeError("no prediction")


def make_agents(seed: int, n: int, options: list[dict]) -> list[NAOAgent]:
    """Agents with these options; "grid": "irregular" (a time grid that does not start at
    0: the per-robot path) or "broken" (a predictor that raises: the group's errors)."""
    out = []
    for k in range(n):
        opts = dict(options[k])
        grid = opts.pop("grid")
        ag = NAOAgent(**opts)
        if grid == "irregular":
            ag.times = np.linspace(0.05, 1.0, 6)
        elif grid == "broken":
            ag.predictor_name = "broken"
            ag.predict = _broken_predictor
        ag.reset(None, np.random.default_rng(seed + k))
        out.append(ag)
    return out


def tables(agents: list[NAOAgent]) -> tuple[np.ndarray, ...]:
    """The agents' table: state and options."""
    cols = columns.columns_of(agents)
    return cols.real, cols.whole, cols.opt


def generators(agents: list[NAOAgent]) -> list[int]:
    """Where each agent's generator stands (its draws so far)."""
    return [ag.rng.bit_generator.state["state"]["state"] for ag in agents]


@st.composite
def agent_options(draw: st.DrawFn) -> dict:
    return {
        "infeasible": draw(st.sampled_from(["auto", "brake", "latest_contact"])),
        "replan": draw(st.sampled_from([True, True, True, False])),
        "stopping_plans": draw(st.booleans()),
        "v_pref": draw(st.sampled_from([None, 0.5, 3.0])),
        "margin": draw(st.sampled_from([0.15, 0.05])),
        "detour_after": draw(st.sampled_from([1.0, 0.1])),  # 0.1 s: detours turn at once
        "horizon": draw(st.sampled_from([3.0, 1.0])),  # two groups of predictions
        "predictor": draw(st.sampled_from([None, None, "constant_velocity"])),
        "navigate": draw(st.booleans()),
        "uncertainty_growth": draw(st.sampled_from([0.0, 0.0, 0.0, 0.3])),
        "grid": draw(st.sampled_from(["", "", "", "", "irregular", "broken"])),
    }


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 9),
    traffic=st.sampled_from([0, 2]),
    walls=st.booleans(),
    odd=st.sampled_from(["", "", "nan", "inf", "goal"]),
    spread=st.sampled_from([1.5, 3.0, 6.0]),
    options=st.data(),
    one_grid=st.booleans(),
)
def test_the_fused_batch_step_is_the_former_step_bit_for_bit(
    seed, n, traffic, walls, odd, spread, options, one_grid
):
    """NAOAgent.act_batch against the former numpy glue between the same kernels
    (tests/reference/nao_batch_reference.py), over five steps of random crowds: the
    accelerations, the errors and every agent's table row and generator alike. With
    ``one_grid`` the agents share one predictor and time grid: the step that
    decide_rows takes in one call."""
    opts = [options.draw(agent_options()) for _ in range(n)]
    if one_grid:
        for o in opts[1:]:
            o.update({k: opts[0][k] for k in ("horizon", "predictor", "grid")})
    fused, former = make_agents(seed % 1000, n, opts), make_agents(seed % 1000, n, opts)
    rng = np.random.default_rng(seed)
    for _ in range(5):
        batch = crowd(rng, n, traffic, walls, odd, spread)
        rows = rng.permutation(n).astype(np.int64)
        with np.errstate(all="ignore"):
            got = NAOAgent.act_batch(fused, batch, rows)
            want, errors = act_rows_reference(former, batch, rows)
        if isinstance(got, list):
            for i, res in enumerate(got):
                if i in errors:
                    assert type(res) is type(errors[i]) and str(res) == str(errors[i])
                else:
                    assert same_up_to_nan_sign(res, want[i])
        else:
            assert not errors
            assert same_up_to_nan_sign(got, want)
        for a, b in zip(tables(fused), tables(former), strict=True):
            assert same_up_to_nan_sign(a, b)
        assert generators(fused) == generators(former)


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 20),
    odd=st.sampled_from(["", "nan", "inf"]),
    turned=st.booleans(),
)
def test_desired_rows_is_goal_seeking_at_the_agents_cap_bit_for_bit(seed, n, odd, turned):
    """desired_rows: goal_seeking_accels (checked against its numpy reference in
    test_nao_agent.py) at min(v_pref, v_max) (v_max where v_pref is NaN; a NaN v_max
    stays NaN, as numpy's minimum keeps it), turned by the detours; bit for bit (NaN
    results at the same places)."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-20.0, 20.0, (n, 2))
    targets = pos + rng.normal(0.0, 1.0, (n, 2)) * rng.choice([0.0, 0.01, 1.0, 30.0], (n, 1))
    vel = rng.uniform(-2.0, 2.0, (n, 2))
    a_max = rng.uniform(0.5, 3.0, n)
    v_max = rng.uniform(0.5, 2.0, n)
    real = np.zeros((n, columns.N_REAL))
    opt = np.zeros((n, columns.N_OPT))
    opt[:, columns.V_PREF] = rng.choice([np.nan, 0.3, 1.0, 5.0], n)
    if turned:
        real[:, columns.DETOUR] = rng.uniform(-np.pi, np.pi, n) * (rng.random(n) < 0.7)
    if odd:
        vel[rng.integers(n)] = float(odd)
        targets[rng.integers(n), rng.integers(2)] = float(odd)
        v_max[rng.integers(n)] = np.nan
    has = rng.random(n) < 0.8
    with np.errstate(all="ignore"):
        got = desired_rows(targets, has, pos, vel, a_max, v_max, real, opt)
        v_pref = opt[:, columns.V_PREF]
        cap = np.where(np.isnan(v_pref), v_max, np.minimum(v_pref, v_max))
        want = goal_seeking_accels(
            targets, pos, vel, a_max, cap, real[:, columns.DETOUR], has_target=has
        )
    assert same_up_to_nan_sign(got, want)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 25), cars=st.integers(0, 5))
def test_own_rows_gathers_each_robots_state_and_traffic_flag(seed, n, cars):
    """own_rows: each robot's own state and goal by plain indexing, traffic among its
    neighbours by their kinds, and whether every goal is finite."""
    rng = np.random.default_rng(seed)
    total = n + cars + 3
    pos, vel = rng.normal(size=(total, 2)), rng.normal(size=(total, 2))
    radii, a_max, v_max = rng.random(total), rng.random(total), rng.random(total)
    bodies = rng.permutation(total)[:n].astype(np.int64)
    goals = rng.normal(size=(n, 2))
    if rng.random() < 0.3:
        goals[rng.integers(n), rng.integers(2)] = np.nan
    traffic = np.zeros(total, dtype=bool)
    traffic[rng.permutation(total)[:cars]] = True
    start, index = neighbour_lists(bodies, pos, 1.5)
    rows = rng.permutation(n)[: int(rng.integers(1, n + 1))].astype(np.int64)
    got = own_rows(
        OwnInputs(
            rows,
            bodies,
            pos,
            vel,
            radii,
            a_max,
            v_max,
            goals,
            start,
            index,
            traffic if cars else np.zeros(0, dtype=bool),
        )
    )
    b = bodies[rows]
    want = (pos[b], vel[b], radii[b], a_max[b], v_max[b], goals[rows])
    for g, w in zip(got[:6], want, strict=True):
        assert g.tobytes() == w.tobytes()
    near = [bool(traffic[index[start[r] : start[r + 1]]].any()) for r in rows.tolist()]
    assert got[6].tolist() == near
    assert got[7] == bool(np.isfinite(goals[rows]).all())
    assert not math.isnan(float(got[2].sum()))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 4), max_size=30), st.integers(0, 4))
def test_rows_with_is_flatnonzero(status, code):
    a = np.array(status, dtype=np.int64)
    np.testing.assert_array_equal(
        rows_with(a, np.int64(code)), np.flatnonzero(a == code).astype(np.int64)
    )


@settings(max_examples=100, deadline=None)
@given(st.lists(st.booleans(), max_size=30))
def test_rows_with_of_a_mask_is_flatnonzero(flags):
    mask = np.array(flags, dtype=np.bool_)
    np.testing.assert_array_equal(
        rows_with(mask, np.bool_(True)), np.flatnonzero(mask).astype(np.int64)
    )


@pytest.mark.parametrize("bad", ["fewer bodies", "no time axis", "a shorter grid"])
def test_a_predictor_of_the_wrong_shape_is_its_robots_failure(bad: str) -> None:
    """Predictions the compiled calls would index out of bounds are refused before them:
    every robot of the group gets a fault naming the expected shape; nothing crashes."""

    def wrong(times: np.ndarray, nb: object) -> np.ndarray:
        centres = np.zeros((len(nb), len(times), 2))  # type: ignore[arg-type]
        return {
            "fewer bodies": centres[:-1],
            "no time axis": centres[:, 0],
            "a shorter grid": centres[:, :-1],
        }[bad]

    arena = Arena(load_map("crowd", n=4, lo=-3.0, hi=3.0, seed=1), ArenaOptions(agent="nao"))
    arena.reset(seed=0)
    for agent in arena.agents:
        agent.predictor_name = "wrong"
        agent.predict = wrong
    for _ in range(3):
        faults = arena.step().faults
        assert len(faults) == 4
        assert all("expected (4, 31, 2) (bodies, times, 2)" in f.message for f in faults)


def _episode_stages(
    monkeypatch: pytest.MonkeyPatch, name: str, params: dict, options: dict, one_call: bool
) -> tuple[str, collections.Counter]:
    """The trajectory hash of 120 steps of ``name`` with ``nao`` agents of ``options``, and
    how far decide_rows and settle_rows took the steps ((call, stage) pairs; none when
    ``one_call`` is off: every step then takes the calls one by one)."""
    stages: collections.Counter = collections.Counter()

    def counted(call: str) -> None:
        compiled = getattr(nao_module, call)

        def count(*args: object) -> tuple:
            result = compiled(*args)
            stages[call, int(result[0])] += 1
            return result

        monkeypatch.setattr(nao_module, call, count)

    counted("decide_rows")
    counted("settle_rows")
    if not one_call:
        monkeypatch.setattr(nao_module, "_shared_predictor", lambda agents, cols: None)
    arena = Arena(load_map(name, **params), ArenaOptions(agent="nao", agent_options=options))
    arena.reset(seed=2)
    for _ in range(120):
        arena.step()
        if arena.done:
            break
    monkeypatch.undo()
    return arena.summary().trajectory_hash, stages


# (call, stage): the whole step in one call; handed back after prepare_rows (heading
# targets to find in Python); the rest of the step once Python found them
ONE_CALL, HANDED_BACK, AFTER_TARGETS = (
    ("decide_rows", DECIDED),
    ("decide_rows", PREPARED),
    ("settle_rows", DECIDED),
)


@pytest.mark.parametrize(
    ("name", "params", "options", "stages"),
    [
        # detours turn: some steps stop after prepare_rows, the targets turned in Python
        (
            "dense_swap_perturbed",
            {"n": 10, "lo": -20, "hi": 20},
            {},
            {ONE_CALL, HANDED_BACK, AFTER_TARGETS},
        ),
        # walls in the way of the goals: the way around them in Python, every step
        ("doorway", {}, {}, {HANDED_BACK, AFTER_TARGETS}),
        ("intersection", {}, {}, {ONE_CALL, HANDED_BACK, AFTER_TARGETS}),
        # decisions made robust in Python: every step stops after settle_members
        (
            "crowd",
            {"n": 8, "lo": -3.0, "hi": 3.0, "seed": 1},
            {"uncertainty_growth": 0.2},
            {("decide_rows", SETTLED), HANDED_BACK, ("settle_rows", SETTLED)},
        ),
    ],
)
def test_decide_rows_takes_each_step_as_far_as_it_can_with_the_same_bits(
    monkeypatch: pytest.MonkeyPatch, name: str, params: dict, options: dict, stages: set
) -> None:
    """The batch step in one or two compiled calls (decide_rows, settle_rows), stopped
    where Python must take over, gives the trajectory of the calls one by one."""
    one, seen = _episode_stages(monkeypatch, name, params, options, True)
    by_one, none = _episode_stages(monkeypatch, name, params, options, False)
    assert one == by_one
    assert set(seen) == stages and not none
