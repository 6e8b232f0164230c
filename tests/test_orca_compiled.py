"""The compiled ``orca`` agent against its Python/numpy reference.

tests/reference/orca_reference.py is the agent as it was, robot by robot.
The compiled kernel performs the same floating-point operations, with each
2-vector dot product evaluated as numpy's dot evaluates it where that is
fma(a1, b1, fma(a0, b0, 0)) (OpenBLAS on x86-64 with FMA): there the
accelerations must agree to the bit (and whole episodes have the same
trajectory hash); where numpy's dot rounds differently, to 1e-9 m/s^2.
Checked on random scenes (random neighbour sets in any order, overlapping and
coincident discs, traffic and walls that do not reciprocate, infeasible
linear programs, per-robot options), on hand-made corner cases, and step by
step over whole episodes; and ``act_batch`` against ``act`` in the arena.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import orca_reference as ref  # tests/reference (tests/ is on sys.path)

from nao_arena.agents._kernel_inputs import BodyArrays, RobotTargets
from nao_arena.agents.orca import ORCAAgent, WallDiscs, _dot, orca_accelerations
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.geometry.kernels import IndexLists
from nao_arena.maps import load_map
from nao_arena.sensing import Neighbours, Observation, SensingBatch

REFERENCE_FILE = Path(__file__).parent / "reference" / "orca_reference.py"


def _fused_dot(a: np.ndarray, b: np.ndarray) -> float:
    """fma(a1, b1, fma(a0, b0, 0)), exactly (each step rounded once)."""
    first = float(Fraction(float(a[0])) * Fraction(float(b[0])))  # +0.0 for any zero
    return float(Fraction(float(a[1])) * Fraction(float(b[1])) + Fraction(first))


def _numpy_dot_is_fused() -> bool:
    """Whether numpy's 2-vector dot is :func:`_fused_dot` here (bits, sign of zero too)."""
    rng = np.random.default_rng(0)
    pairs = [
        (np.array([-1.0, 1.0 + 2.0**-30]), np.array([1.0, 1.0 - 2.0**-30])),
        (np.array([-1.0, -1.0]), np.zeros(2)),
    ]
    pairs += [
        (
            rng.normal(size=2) * 10.0 ** rng.uniform(-3, 3),
            rng.normal(size=2) * 10.0 ** rng.uniform(-3, 3),
        )
        for _ in range(500)
    ]
    return all(
        np.float64(a @ b).tobytes() == np.float64(_fused_dot(a, b)).tobytes() for a, b in pairs
    )


BIT_FOR_BIT = _numpy_dot_is_fused()


def assert_same(got: np.ndarray, want: np.ndarray) -> None:
    """The same bits where numpy's dot is the kernel's, else within 1e-9 m/s^2."""
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    assert got.shape == want.shape
    if BIT_FOR_BIT:
        same = got.tobytes() == want.tobytes()
        assert same or np.array_equal(got, want, equal_nan=True), (got, want)
        if not same:  # NaN payloads aside, zeros must carry the same sign
            assert np.array_equal(
                np.signbit(got[~np.isnan(got)]), np.signbit(want[~np.isnan(want)])
            ), (got, want)
    else:
        np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-9)


def test_the_kernels_dot_is_the_fused_form_on_every_machine():
    """fma(a1, b1, fma(a0, b0, 0)) to the bit, signed zeros included, whatever numpy does."""
    rng = np.random.default_rng(5)
    pairs = [
        (np.array([-1.0, 1.0 + 2.0**-30]), np.array([1.0, 1.0 - 2.0**-30])),
        (np.array([-1.0, -1.0]), np.zeros(2)),
        (np.array([-0.0, 2.0]), np.zeros(2)),
    ]
    pairs += [
        (
            rng.normal(size=2) * 10.0 ** rng.uniform(-5, 5),
            rng.normal(size=2) * 10.0 ** rng.uniform(-5, 5),
        )
        for _ in range(2000)
    ]
    for a, b in pairs:
        got = _dot(float(a[0]), float(a[1]), float(b[0]), float(b[1]))
        assert np.float64(got).tobytes() == np.float64(_fused_dot(a, b)).tobytes(), (a, b)
    # the first pair tells the fused form from the plain one (-2^-60 against 0)
    assert _dot(-1.0, 1.0 + 2.0**-30, 1.0, 1.0 - 2.0**-30) == -(2.0**-60)


# ---------------------------------------------------------------- random scenes

_finite = {"allow_nan": False, "allow_infinity": False}


def _coords(draw, n: int, bound: float) -> np.ndarray:
    xs = draw(st.lists(st.floats(-bound, bound, **_finite), min_size=2 * n, max_size=2 * n))
    return np.array(xs, dtype=np.float64).reshape(n, 2)


@st.composite
def orca_options(draw) -> dict:
    """Valid agent options, defaults included."""
    opts: dict = {}
    if draw(st.booleans()):
        opts["horizon"] = draw(st.floats(0.2, 8.0))
    if draw(st.booleans()):
        opts["margin"] = draw(st.sampled_from([0.0, 0.05, 0.3]))
    if draw(st.booleans()):
        opts["v_pref"] = draw(st.one_of(st.none(), st.floats(0.0, 4.0)))
    if draw(st.booleans()):
        opts["time_constant"] = draw(st.floats(0.05, 1.5))
    if draw(st.booleans()):
        opts["sensing_range"] = draw(st.sampled_from([0.5, 3.0, 30.0, math.inf]))
    if draw(st.booleans()):
        opts["max_neighbours"] = draw(st.one_of(st.none(), st.integers(0, 12)))
    return opts


@st.composite
def scenes(draw) -> tuple[SensingBatch, list[int], list[dict]]:
    """A sensing batch of bodies in a box (small boxes: overlapping discs; some bodies
    coincide), robots and traffic, random neighbour lists in any order, walls, and the
    rows (robots, any order) to act with their options."""
    n = draw(st.integers(1, 9))
    r = draw(st.integers(1, n))
    box = draw(st.sampled_from([0.8, 3.0, 15.0]))
    pos = _coords(draw, n, box)
    for i, j in draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=2)):
        pos[j] = pos[i]  # coincident centres
    vel = _coords(draw, n, 3.0)
    if draw(st.booleans()):
        vel[: draw(st.integers(0, n))] = 0.0  # at rest: signed zeros matter
    radii = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=n, max_size=n)))
    a_max = np.array(draw(st.lists(st.floats(0.2, 5.0), min_size=n, max_size=n)))
    v_max = np.array(draw(st.lists(st.floats(0.2, 4.0), min_size=n, max_size=n)))
    kinds = np.array(
        ["robot"] * r + [draw(st.sampled_from(["robot", "traffic"])) for _ in range(n - r)]
    )
    goals = _coords(draw, r, 2.0 * box)
    for k in draw(st.lists(st.integers(0, r - 1), max_size=2)):
        goals[k] = pos[k]  # at its goal
    nb_start = [0]
    nb_index: list[int] = []
    for k in range(r):
        others = draw(st.permutations([j for j in range(n) if j != k]))
        nb_index += others[: draw(st.integers(0, len(others)))]
        nb_start.append(len(nb_index))
    n_walls = draw(st.integers(0, 3))
    walls = _coords(draw, 2 * n_walls, 1.5 * box).reshape(n_walls, 2, 2)
    wall_radius = np.array(
        draw(st.lists(st.sampled_from([0.0, 0.1, 0.25]), min_size=n_walls, max_size=n_walls))
    )
    batch = SensingBatch(
        time=0.0,
        dt=draw(st.sampled_from([0.05, 0.1, 0.2])),
        positions=pos,
        velocities=vel,
        accelerations=np.zeros((n, 2)),
        radii=radii,
        a_max=a_max,
        v_max=v_max,
        kinds=kinds,
        plans=None,
        known_paths=None,
        path_times=np.zeros(0),
        bodies=np.arange(r, dtype=np.int64),
        goals=goals,
        routes=[None] * r,
        walls=walls.reshape(-1, 2, 2),
        wall_radius=wall_radius,
        nb_start=np.array(nb_start, dtype=np.int64),
        nb_index=np.array(nb_index, dtype=np.int64),
    )
    rows = draw(st.permutations(list(range(r))))
    rows = rows[: draw(st.integers(1, r))]
    options = [draw(orca_options()) for _ in rows]
    return batch, rows, options


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(scenes())
def test_act_batch_and_act_match_the_reference_on_random_scenes(scene):
    batch, rows, options = scene
    agents = [ORCAAgent(**o) for o in options]
    want = np.array(
        [ref.ORCAAgent(**o).act(batch.observation(k)) for k, o in zip(rows, options, strict=True)]
    ).reshape(-1, 2)
    got = ORCAAgent.act_batch(agents, batch, rows)
    assert len(got) == len(rows)
    assert_same(np.array(got).reshape(-1, 2), want)
    one = [ag.act(batch.observation(k)) for ag, k in zip(agents, rows, strict=True)]
    assert_same(np.array(one).reshape(-1, 2), want)


@st.composite
def observations(draw) -> Observation:
    """A robot's observation built by hand: goal, route's end or nothing to head for."""
    m = draw(st.integers(0, 8))
    box = draw(st.sampled_from([1.0, 5.0]))
    position = _coords(draw, 1, box)[0]
    target = draw(st.sampled_from(["goal", "route", "none"]))
    goal = _coords(draw, 1, 3.0 * box)[0] if target == "goal" else None
    route = _coords(draw, draw(st.integers(1, 3)), 3.0 * box) if target == "route" else None
    nb = Neighbours(
        ids=np.arange(1, m + 1),
        kinds=tuple(draw(st.sampled_from(["robot", "traffic"])) for _ in range(m)),
        positions=_coords(draw, m, box),
        velocities=_coords(draw, m, 2.0),
        accelerations=np.zeros((m, 2)),
        radii=np.array(draw(st.lists(st.floats(0.1, 0.8), min_size=m, max_size=m))),
    )
    return Observation(
        time=0.0,
        dt=0.1,
        robot_id=0,
        position=position,
        velocity=_coords(draw, 1, 2.0)[0],
        acceleration=np.zeros(2),
        radius=draw(st.floats(0.1, 0.8)),
        a_max=draw(st.floats(0.5, 4.0)),
        v_max=draw(st.floats(0.5, 3.0)),
        goal=goal,
        route=route,
        neighbours=nb,
    )


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(observations(), orca_options())
def test_act_matches_the_reference_on_hand_made_observations(obs, options):
    assert_same(ORCAAgent(**options).act(obs), ref.ORCAAgent(**options).act(obs))


# ---------------------------------------------------------------- corner cases


def _ring(k: int, radius: float, speed: float) -> Observation:
    """A robot at the origin among k neighbours on a circle, closing in at ``speed``."""
    ang = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    pos = radius * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    nb = Neighbours(
        ids=np.arange(1, k + 1),
        kinds=("robot",) * (k - 1) + ("traffic",),
        positions=pos,
        velocities=-speed * pos / radius,
        accelerations=np.zeros((k, 2)),
        radii=np.full(k, 0.5),
    )
    return Observation(
        time=0.0,
        dt=0.1,
        robot_id=0,
        position=np.zeros(2),
        velocity=np.array([0.3, -0.1]),
        acceleration=np.zeros(2),
        radius=0.5,
        a_max=2.0,
        v_max=1.5,
        goal=np.array([5.0, 1.0]),
        neighbours=nb,
    )


def _reference_lines(obs: Observation, agent: ref.ORCAAgent) -> list[ref.HalfPlane]:
    discs = ref.observed_discs(obs, agent.margin, agent.sensing_range)
    order = np.argsort(np.hypot(*discs.positions.T), kind="stable")[: agent.max_neighbours]
    return [
        ref.orca_half_plane(
            discs.positions[k],
            obs.velocity - discs.velocities[k],
            float(discs.radii[k]),
            obs.velocity,
            agent.horizon,
            obs.dt,
            0.5 if discs.reactive[k] else 1.0,
        )
        for k in order
    ]


@pytest.mark.parametrize(("k", "radius", "speed"), [(6, 0.9, 1.0), (8, 1.05, 1.4), (12, 1.2, 0.5)])
def test_infeasible_programs_take_the_fallback_like_the_reference(k, radius, speed):
    obs = _ring(k, radius, speed)
    lines = _reference_lines(obs, ref.ORCAAgent())
    fail, _ = ref._lp2(lines, obs.v_max, ref.preferred_velocity(obs, None), False)
    assert fail < len(lines)  # the scene is infeasible: the fallback (_lp3) decides
    assert_same(ORCAAgent().act(obs), ref.ORCAAgent().act(obs))


def test_coincident_and_overlapping_neighbours_and_walls_match_the_reference():
    nb = Neighbours(
        ids=np.arange(1, 5),
        kinds=("robot", "robot", "traffic", "robot"),
        positions=np.array([[0.0, 0.0], [0.0, 0.0], [0.4, 0.1], [3.0, 0.0]]),
        velocities=np.array([[0.0, 0.0], [0.5, 0.0], [-1.0, 0.0], [-1.0, 0.0]]),
        accelerations=np.zeros((4, 2)),
        radii=np.full(4, 0.5),
    )
    walls = np.array([[[-2.0, 0.6], [2.0, 0.6]], [[1.0, -3.0], [1.0, 3.0]]])
    for velocity in (np.zeros(2), np.array([1.0, 0.2])):
        obs = Observation(
            time=0.0,
            dt=0.1,
            robot_id=0,
            position=np.zeros(2),
            velocity=velocity,
            acceleration=np.zeros(2),
            radius=0.5,
            a_max=2.0,
            v_max=1.5,
            goal=np.array([4.0, 0.0]),
            neighbours=nb,
            walls=walls,
            wall_radius=np.array([0.1, 0.0]),
        )
        for opts in (
            {},
            {"max_neighbours": None},
            {"max_neighbours": 0},
            {"max_neighbours": 2, "margin": 0.0},
            {"sensing_range": 0.5},
        ):
            assert_same(ORCAAgent(**opts).act(obs), ref.ORCAAgent(**opts).act(obs))


# ---------------------------------------------------------------- whole episodes


def _episode_rows(map_name: str, seed: int) -> tuple[Arena, int]:
    """Run ``map_name`` with the compiled agent; at every step the reference acts on the
    same observations and the commands must agree. Returns the arena and the steps."""
    arena = Arena(load_map(map_name), ArenaOptions(agent="orca"))
    arena.reset(seed)
    reference = ref.ORCAAgent()
    steps = 0
    while not arena.done:
        batch = arena.sensing()
        want = np.array([reference.act(batch.observation(k)) for k in range(len(arena.robots))])
        res = arena.step()
        assert not res.faults
        assert_same(res.commanded[arena.robot_ids], want)
        steps += 1
    return arena, steps


@pytest.mark.slow
@pytest.mark.parametrize(("map_name", "seed"), [("crossing", 3), ("circle_swap_perturbed", 1)])
def test_whole_episodes_command_what_the_reference_commands_at_every_step(map_name, seed):
    arena, steps = _episode_rows(map_name, seed)
    assert steps > 50 and all(r.reached_goal for r in arena.summary().robots)


@pytest.mark.slow
@pytest.mark.skipif(not BIT_FOR_BIT, reason="numpy's dot rounds otherwise on this machine")
@pytest.mark.parametrize(("map_name", "seed"), [("crossing", 0), ("circle_swap_perturbed", 4)])
def test_whole_episodes_follow_the_reference_trajectory_to_the_bit(map_name, seed):
    spec = load_map(map_name)
    runs = [
        Arena(spec, ArenaOptions(agent=agent)).run(seed)
        for agent in ("orca", f"{REFERENCE_FILE}:ORCAAgent")
    ]
    assert runs[0].trajectory_hash == runs[1].trajectory_hash


class _PerRobotORCA(ORCAAgent):
    act_batch = None  # the arena then calls act() robot by robot


@pytest.mark.parametrize(
    ("map_name", "params"),
    [
        ("corridor", {}),  # walls
        ("roundabout", {"seed": 1}),  # traffic
        ("circle_swap", {"n": 14, "radius": 5.0, "lo": -8.0, "hi": 8.0}),  # a crowd
    ],
)
def test_act_batch_in_the_arena_is_act_robot_by_robot(map_name, params):
    hashes = []
    for per_robot in (False, True):
        arena = Arena(
            load_map(map_name, **params),
            ArenaOptions(agent="orca", agent_options={"max_neighbours": 6}),
        )
        arena.reset(0)
        if per_robot:
            for ag in arena.agents:
                ag.__class__ = _PerRobotORCA
        for _ in range(120):
            if arena.done:
                break
            assert not arena.step().faults
        hashes.append(arena.summary().trajectory_hash)
    assert hashes[0] == hashes[1]


# ---------------------------------------------------------------- the agent


class _Custom(ORCAAgent):
    """Overrides act: act_batch must defer to it (and act for the others as before)."""

    def act(self, obs):
        if obs.robot_id == 1:
            raise RuntimeError("custom failure")
        return np.array([0.05, -0.05])


def test_act_batch_defers_to_an_overridden_act_robot_by_robot():
    arena = Arena(
        load_map("circle_swap", n=4, radius=5.0, lo=-8.0, hi=8.0), ArenaOptions(agent="orca")
    )
    arena.reset(0)
    batch = arena.sensing()
    plain = ORCAAgent.act_batch(arena.agents, batch, [0, 1, 2, 3])
    arena.agents[1].__class__ = _Custom
    arena.agents[3].__class__ = _Custom
    out = ORCAAgent.act_batch(arena.agents, batch, [0, 1, 2, 3])
    assert isinstance(out[1], RuntimeError)
    np.testing.assert_array_equal(out[3], [0.05, -0.05])
    for k in (0, 2):
        np.testing.assert_array_equal(out[k], plain[k])


def test_an_option_set_after_construction_counts_at_the_next_step():
    arena = Arena(
        load_map("circle_swap", n=6, radius=3.0, lo=-6.0, hi=6.0), ArenaOptions(agent="orca")
    )
    arena.reset(0)
    for _ in range(5):
        arena.step()
    batch = arena.sensing()
    rows = list(range(6))
    before = np.array(ORCAAgent.act_batch(arena.agents, batch, rows))
    for ag in arena.agents:
        ag.horizon = 0.5
        ag.max_neighbours = 1
    after = np.array(ORCAAgent.act_batch(arena.agents, batch, rows))
    want = np.array(
        [ref.ORCAAgent(horizon=0.5, max_neighbours=1).act(batch.observation(k)) for k in rows]
    )
    assert not np.array_equal(before, after)
    assert_same(after, want)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"horizon": 0.0}, "horizon: expected a number > 0 (s), got 0.0"),
        ({"horizon": "3"}, "horizon: expected a number > 0 (s), got '3'"),
        ({"time_constant": -1.0}, "time_constant: expected a number > 0 (s)"),
        ({"margin": math.nan}, "margin: expected a number >= -inf (m)"),
        ({"margin": math.inf}, "margin: expected a finite number (m)"),
        ({"v_pref": -0.5}, "v_pref: expected a number >= 0 (m/s)"),
        ({"sensing_range": math.nan}, "sensing_range: expected a number >= 0 (m)"),
        ({"max_neighbours": -1}, "max_neighbours: expected an integer >= 0 or None (all), got -1"),
        ({"max_neighbours": 2.5}, "max_neighbours: expected an integer >= 0 or None"),
        ({"max_neighbours": True}, "max_neighbours: expected an integer >= 0 or None"),
    ],
)
def test_bad_options_are_rejected_by_name(options, message):
    with pytest.raises(ValueError, match="orca option " + re.escape(message)):
        ORCAAgent(**options)


def test_the_kernel_handles_no_rows_and_no_obstacles():
    empty = orca_accelerations(
        BodyArrays(
            np.ones(1, dtype=np.bool_),
            np.zeros((1, 2)),
            np.zeros((1, 2)),
            np.ones(1),
            np.ones(1),
            np.ones(1),
        ),
        RobotTargets(np.zeros(1, dtype=np.int64), np.zeros((1, 2)), np.ones(1, dtype=np.bool_)),
        IndexLists(np.zeros(2, dtype=np.int64), np.zeros(0, dtype=np.int64)),
        np.zeros(0, dtype=np.int64),
        WallDiscs(
            np.zeros((0, 2)), np.zeros(0), np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
        ),
        np.zeros((0, 5)),
        np.zeros(0, dtype=np.bool_),
        np.zeros(0, dtype=np.int64),
        0.1,
    )
    assert empty.shape == (0, 2)
