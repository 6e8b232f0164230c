"""The ``social_force`` agent (agents/social_force.py): people walking by the social force
model of Helbing and Molnár.

Checked against the model's definition, written out again here, and against forward
simulations in the arena:

- the repulsion of a body and of a wall is A exp((r - d) / B) along the normal, with the
  anisotropy lambda + (1 - lambda) (1 + cos phi) / 2, to the last bits of a float
  (random configurations);
- a lone person walks a straight line to its goal at its desired speed and stops there;
  two people meeting head-on in a corridor step aside and pass without touching;
- ``sees_robots=False`` leaves out robots only; the desired speed is drawn from the
  episode's generator (same seed, same person); act and act_batch give the same bits.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from strategies import floats, unit, vec

from nao_arena.agents.social_force import (
    V_PREF_MAX,
    V_PREF_MEAN,
    V_PREF_MIN,
    V_PREF_SD,
    SocialForceAgent,
    SocialForceParams,
    draw_v_pref,
)
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map
from nao_arena.sensing import Neighbours, Observation, SensingBatch

REF = "nao_arena.agents.social_force:SocialForceAgent"
FAR = 1000.0  # m: a goal this far away leaves the desired speed uncapped


# ---------------------------------------------------------------- helpers


def _obs(
    position,
    velocity=(0.0, 0.0),
    goal=None,
    radius=0.3,
    nb_positions=(),
    nb_radii=(),
    kinds=None,
    walls=(),
    wall_radius=(),
    v_max=3.0,
    route=None,
) -> Observation:
    """One person's observation: its own state (m, m/s), goal (m), neighbours (m) and
    walls (segments (W, 2, 2) m, half-thicknesses (W,) m)."""
    n = len(nb_positions)
    return Observation(
        time=0.0,
        dt=0.1,
        robot_id=0,
        position=np.asarray(position, dtype=float),
        velocity=np.asarray(velocity, dtype=float),
        acceleration=np.zeros(2),
        radius=float(radius),
        a_max=2.0,
        v_max=float(v_max),
        goal=None if goal is None else np.asarray(goal, dtype=float),
        route=None if route is None else np.asarray(route, dtype=float),
        neighbours=Neighbours(
            ids=np.arange(1, n + 1, dtype=np.int64),
            kinds=tuple(kinds) if kinds is not None else ("robot",) * n,
            positions=np.asarray(nb_positions, dtype=float).reshape(n, 2),
            velocities=np.zeros((n, 2)),
            accelerations=np.zeros((n, 2)),
            radii=np.asarray(nb_radii, dtype=float).reshape(n),
        ),
        walls=np.asarray(walls, dtype=float).reshape(-1, 2, 2),
        wall_radius=np.asarray(wall_radius, dtype=float).reshape(-1),
    )


def _walker(v_pref: float, **params) -> tuple[SocialForceAgent, dict]:
    """A person with desired speed v_pref (m/s) walking at exactly that speed along +x
    from the origin toward a far goal on the x axis: its driving term is exactly zero, so
    what it returns is the repulsion alone (its heading is +x)."""
    agent = SocialForceAgent(v_pref=v_pref, **params)
    where = dict(position=(0.0, 0.0), velocity=(v_pref, 0.0), goal=(FAR, 0.0))
    return agent, where


def _map(tmp_path: Path, robots: list[tuple], walls: str = "", time_limit: float = 30.0) -> Path:
    """A map file of hand-placed robots (start, goal; radius 0.3 m, a_max 2 m/s^2,
    v_max 2.5 m/s) and the given wall entries (YAML lines), without bounding walls."""
    lines = [
        "name: social_force_test",
        "bounds: {min: [-10.0, -6.0], max: [10.0, 6.0], walls: false}",
        "walls:" + ("\n" + walls if walls else " []"),
        "robots:",
    ]
    for start, goal in robots:
        lines.append(
            f"  - {{start: {[float(x) for x in start]}, goal: {[float(x) for x in goal]}, "
            "radius: 0.3, a_max: 2.0, "
            "v_max: 2.5, agent: goal}"
        )
    lines.append(f"episode: {{time_limit: {time_limit}}}")
    path = tmp_path / "people.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _walk(arena: Arena, seed: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities (steps + 1, robots, 2) of ``steps`` control steps."""
    arena.reset(seed)
    assert arena.state is not None
    p = [arena.state.positions[arena.robot_ids].copy()]
    v = [arena.state.velocities[arena.robot_ids].copy()]
    for _ in range(steps):
        result = arena.step()
        assert not result.faults
        p.append(result.state.positions[arena.robot_ids].copy())
        v.append(result.state.velocities[arena.robot_ids].copy())
    return np.array(p), np.array(v)


def _weight(cos_phi: float, lam: float) -> float:
    return lam + (1.0 - lam) * (1.0 + cos_phi) / 2.0


# ---------------------------------------------------------------- 1. a lone person


@pytest.mark.parametrize("v_pref", [1.3, None])
def test_a_lone_person_walks_straight_to_its_goal_at_its_desired_speed(tmp_path, v_pref):
    start, goal = np.array([-7.0, -2.0]), np.array([6.0, 3.0])
    arena = Arena(
        load_map(_map(tmp_path, [(start, goal)])),
        ArenaOptions(agent=REF, agent_options={"v_pref": v_pref}),
    )
    p, v = _walk(arena, seed=5, steps=200)
    person = arena.agents[0]
    want = person.v_pref if v_pref is None else v_pref
    assert V_PREF_MIN <= want <= V_PREF_MAX
    line = (goal - start) / np.linalg.norm(goal - start)
    along = (p[:, 0] - start) @ line
    across = (p[:, 0] - start) @ np.array([-line[1], line[0]])
    speed = np.hypot(*v[:, 0].T)
    assert np.abs(across).max() < 1e-9  # a straight line
    assert np.all(np.diff(along) >= -1e-12)  # never back
    assert speed.max() == pytest.approx(want, rel=1e-3)  # cruises at v_pref ...
    assert speed.max() <= want * (1 + 1e-9)  # ... and never faster
    # it stops within the goal radius (0.2 m) and stays
    arrived = np.flatnonzero(np.hypot(*(p[:, 0] - goal).T) <= 0.2)[0]
    assert np.all(np.hypot(*(p[arrived:, 0] - goal).T) <= 0.2)
    assert speed[-1] < 1e-3
    assert arena.summary().robots[0].reached_goal


# ---------------------------------------------------------------- 2. head-on in a corridor


@pytest.mark.parametrize("offset", [0.05, 0.1, 0.2])
def test_two_people_meeting_head_on_in_a_corridor_step_aside_and_pass(tmp_path, offset):
    """A 3 m wide corridor; the two start 12 m apart, their lines ``offset`` m to either
    side of its axis (exactly on one line the model's forces have no sideways part at
    all), both at 1 m/s (see the module docstring: faster, they brush as they pass)."""
    walls = "\n".join(
        f"  - {{type: segment, a: [-10.0, {y}], b: [10.0, {y}], thickness: 0.2}}"
        for y in (1.5, -1.5)
    )
    robots = [((-6.0, offset), (6.0, offset)), ((6.0, -offset), (-6.0, -offset))]
    arena = Arena(
        load_map(_map(tmp_path, robots, walls)),
        ArenaOptions(agent=REF, agent_options={"v_pref": 1.0}),
    )
    p, _ = _walk(arena, seed=0, steps=250)
    summary = arena.summary()
    assert summary.contacts == []
    gap = np.hypot(*(p[:, 0] - p[:, 1]).T) - 0.6
    assert gap.min() > 0.0
    # each steps aside to its own side by more than 0.2 m and comes back to its line
    assert p[:, 0, 1].max() > offset + 0.2
    assert p[:, 1, 1].min() < -offset - 0.2
    assert all(r.reached_goal for r in summary.robots)


# ---------------------------------------------------------------- 3. the repulsion's formula


@settings(max_examples=150, deadline=None)
@given(
    p=vec(5.0),
    v=vec(1.5),
    goal_angle=floats(-math.pi, math.pi),
    v_pref=floats(0.5, 2.0),
    v_max=floats(0.5, 2.5),
    offset=vec(3.0),
    ri=floats(0.1, 0.5),
    rj=floats(0.1, 0.5),
    strength=floats(0.5, 30.0),
    b=floats(0.05, 1.0),
    lam=floats(0.0, 1.0),
    tau=floats(0.2, 1.0),
)
def test_the_acceleration_is_the_formula(
    p, v, goal_angle, v_pref, v_max, offset, ri, rj, strength, b, lam, tau
):
    """(v0 e_goal - v) / tau + A exp((r_ij - d_ij) / B) n_ij w(phi), computed here from
    the definition (a far goal: v0 = min(v_pref, v_max))."""
    d = float(np.hypot(*offset))
    assume(d > 0.05 and np.hypot(*v) > 1e-3)
    goal = p + FAR * unit(goal_angle)
    agent = SocialForceAgent(v_pref=v_pref, strength=strength, range=b, anisotropy=lam, tau=tau)
    got = agent.act(_obs(p, v, goal, ri, [p + offset], [rj], v_max=v_max))

    e_goal = (goal - p) / np.linalg.norm(goal - p)
    drive = (min(v_pref, v_max) * e_goal - v) / tau
    n = -offset / d  # from the neighbour to the person
    cos_phi = float(np.dot(-n, v / np.linalg.norm(v)))
    push = strength * math.exp((ri + rj - d) / b) * _weight(cos_phi, lam) * n
    want = drive + push
    scale = np.abs(drive).max() + np.abs(push).max()
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale)


@settings(max_examples=100, deadline=None)
@given(
    angle=floats(-math.pi, math.pi),
    d1=floats(0.3, 4.0),
    step=floats(0.01, 2.0),
    b=floats(0.05, 1.0),
    lam=floats(0.0, 1.0),
)
def test_the_repulsion_decays_with_distance_as_exp_of_minus_distance_over_b(
    angle, d1, step, b, lam
):
    """The same neighbour in the same direction, ``step`` m further off: the push keeps
    its direction and shrinks by exactly exp(-step / B)."""
    agent, where = _walker(1.2, range=b, anisotropy=lam)
    d2 = d1 + step
    near = agent.act(_obs(**where, nb_positions=[d1 * unit(angle)], nb_radii=[0.3]))
    far = agent.act(_obs(**where, nb_positions=[d2 * unit(angle)], nb_radii=[0.3]))
    ratio = math.exp(-step / b)
    np.testing.assert_allclose(far, near * ratio, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(
        near,
        -7.0 * math.exp((0.6 - d1) / b) * _weight(math.cos(angle), lam) * unit(angle),
        rtol=1e-12,
        atol=1e-300,
    )


def test_a_body_with_no_gap_pushes_with_the_full_strength():
    agent, where = _walker(1.0, anisotropy=1.0)
    got = agent.act(_obs(**where, nb_positions=[(0.0, 0.6)], nb_radii=[0.3]))
    np.testing.assert_allclose(got, [0.0, -7.0], rtol=1e-15, atol=1e-15)


# ---------------------------------------------------------------- 4. anisotropy


@settings(max_examples=100, deadline=None)
@given(d=floats(0.4, 3.0), lam=floats(0.0, 1.0))
def test_a_body_behind_pushes_lambda_times_as_hard_as_the_same_body_ahead(d, lam):
    agent, where = _walker(1.3, anisotropy=lam)
    ahead = agent.act(_obs(**where, nb_positions=[(d, 0.0)], nb_radii=[0.3]))
    behind = agent.act(_obs(**where, nb_positions=[(-d, 0.0)], nb_radii=[0.3]))
    beside = agent.act(_obs(**where, nb_positions=[(0.0, d)], nb_radii=[0.3]))
    assert ahead[0] < 0.0 and ahead[1] == 0.0  # pushed back, away from it
    assert behind[0] >= 0.0 and behind[1] == 0.0  # pushed forward
    assert behind[0] == pytest.approx(-lam * ahead[0], rel=1e-12, abs=1e-300)
    assert -beside[1] == pytest.approx((lam + 1.0) / 2.0 * -ahead[0], rel=1e-12, abs=1e-300)


def test_with_the_default_anisotropy_a_body_behind_pushes_half_as_hard():
    agent, where = _walker(1.3)
    ahead = agent.act(_obs(**where, nb_positions=[(1.0, 0.0)], nb_radii=[0.3]))
    behind = agent.act(_obs(**where, nb_positions=[(-1.0, 0.0)], nb_radii=[0.3]))
    assert behind[0] == pytest.approx(-0.5 * ahead[0], rel=1e-12)
    assert abs(behind[0]) < abs(ahead[0])


def test_at_rest_the_desired_direction_is_the_heading_and_at_the_goal_none():
    agent = SocialForceAgent(v_pref=1.0, anisotropy=0.2)
    nb = dict(nb_positions=[(-1.0, 0.0)], nb_radii=[0.3])
    # at rest, goal ahead (+x): the body at -x is behind
    walking_off = agent.act(_obs((0.0, 0.0), goal=(FAR, 0.0), **nb))
    alone = agent.act(_obs((0.0, 0.0), goal=(FAR, 0.0)))
    push = 7.0 * math.exp(-0.4 / 0.3)
    np.testing.assert_allclose(walking_off - alone, [0.2 * push, 0.0], rtol=1e-12)
    # at rest at the goal: no heading, every direction weighs 1
    standing = agent.act(_obs((0.0, 0.0), goal=(0.05, 0.0), **nb))
    np.testing.assert_allclose(standing, [push, 0.0], rtol=1e-12)


# ---------------------------------------------------------------- 5. sees_robots


@settings(max_examples=60, deadline=None)
@given(
    robot_at=vec(2.0),
    other_at=vec(2.0),
    other_kind=st.sampled_from(["traffic", "person"]),
)
def test_without_sees_robots_robots_are_left_out_and_nothing_else(robot_at, other_at, other_kind):
    """``sees_robots=False`` ignores neighbours of kind "robot"; every other kind (traffic,
    people) still pushes."""
    assume(np.hypot(*robot_at) > 0.2 and np.hypot(*other_at) > 0.2)
    where = dict(position=(0.0, 0.0), velocity=(0.8, 0.2), goal=(FAR, 0.0))
    both = dict(nb_positions=[robot_at, other_at], nb_radii=[0.3, 0.3])
    blind = SocialForceAgent(v_pref=1.2, sees_robots=False)
    seeing = SocialForceAgent(v_pref=1.2)
    got = blind.act(_obs(**where, **both, kinds=["robot", other_kind]))
    without_robot = blind.act(
        _obs(**where, nb_positions=[other_at], nb_radii=[0.3], kinds=[other_kind])
    )
    nobody = blind.act(_obs(**where))
    assert got.tobytes() == without_robot.tobytes()
    assert not np.array_equal(got, nobody)  # the other body pushes
    seen = seeing.act(_obs(**where, **both, kinds=["robot", other_kind]))
    assert not np.array_equal(seen, got)  # seen, the robot pushes


def test_in_the_arena_people_without_sees_robots_walk_through_a_robot(tmp_path):
    """A robot standing in a person's way: a person that sees robots steps around it, one
    that does not walks on as if it were not there (into it)."""
    robots = [((-4.0, 0.0), (4.0, 0.0)), ((0.0, 0.05), (0.0, 0.05))]
    out = {}
    for sees in (True, False):
        arena = Arena(
            load_map(_map(tmp_path, robots)),
            ArenaOptions(agent=REF, agent_options={"v_pref": 1.0, "sees_robots": sees}),
        )
        _walk(arena, seed=0, steps=60)
        out[sees] = [c for c in arena.summary().contacts if {c.a, c.b} == {0, 1}]
    assert out[True] == []
    assert out[False]


# ---------------------------------------------------------------- 6. the desired speed


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**63 - 1))
def test_the_same_seed_draws_the_same_person_within_the_clip_range(seed):
    agent = SocialForceAgent()
    agent.reset(None, np.random.default_rng(seed))
    first = agent.v_pref
    agent.reset(None, np.random.default_rng(seed))
    assert agent.v_pref == first
    assert V_PREF_MIN <= first <= V_PREF_MAX
    assert first == draw_v_pref(np.random.default_rng(seed))


def test_the_draws_follow_the_normal_distribution_clipped():
    draws = np.array([draw_v_pref(np.random.default_rng(s)) for s in range(4000)])
    assert draws.min() >= V_PREF_MIN and draws.max() <= V_PREF_MAX
    assert len(np.unique(draws)) > 3900  # different seeds, different draws
    assert draws.mean() == pytest.approx(V_PREF_MEAN, abs=0.015)
    assert draws.std() == pytest.approx(V_PREF_SD, abs=0.015)
    # the clip: a normal draw outside [0.5, 2.0] m/s lands on that end
    raw = {s: np.random.default_rng(s).normal(1.34, 0.26) for s in range(20000)}
    fast = next(s for s, x in raw.items() if x > 2.0)
    slow = next(s for s, x in raw.items() if x < 0.5)
    assert draw_v_pref(np.random.default_rng(fast)) == V_PREF_MAX
    assert draw_v_pref(np.random.default_rng(slow)) == V_PREF_MIN


def test_in_the_arena_each_person_draws_from_its_own_generator():
    spec = load_map("crossing")
    arena = Arena(spec, ArenaOptions(agent=REF))
    arena.reset(7)
    first = [a.v_pref for a in arena.agents]
    arena.reset(7)
    assert [a.v_pref for a in arena.agents] == first
    arena.reset(8)
    other = [a.v_pref for a in arena.agents]
    assert all(a != b for a, b in zip(first, other, strict=True))
    assert len(set(first)) == len(first)  # people of one episode differ
    assert all(V_PREF_MIN <= x <= V_PREF_MAX for x in first + other)


def test_a_given_desired_speed_is_kept_and_draws_nothing():
    agent = SocialForceAgent(v_pref=0.9)
    rng = np.random.default_rng(1)
    before = rng.bit_generator.state
    agent.reset(None, rng)
    assert agent.v_pref == 0.9
    assert rng.bit_generator.state == before
    assert SocialForceAgent().v_pref == V_PREF_MEAN  # not reset yet: the mean


def test_the_desired_speed_is_capped_by_v_max():
    agent = SocialForceAgent(v_pref=1.8, tau=0.5)
    got = agent.act(_obs((0.0, 0.0), goal=(FAR, 0.0), v_max=1.2))
    np.testing.assert_allclose(got, [1.2 / 0.5, 0.0], rtol=1e-15)


# ---------------------------------------------------------------- 7. act and act_batch


@pytest.mark.parametrize(
    ("name", "options"),
    [
        ("crossing", {}),
        ("corridor", {"sees_robots": False}),
        ("two_lane_road", {"v_pref": 1.5, "anisotropy": 0.2}),
        ("doorway", {"range": 0.08, "strength": 25.0}),
    ],
)
def test_act_and_act_batch_agree_to_the_bit_over_episodes(name, options):
    """Every step of episodes with people, traffic and walls: act on each person's own
    observation gives the bits act_batch gave the arena."""
    arena = Arena(load_map(name), ArenaOptions(agent=REF, agent_options=options))
    arena.reset(3)
    alone = copy.deepcopy(arena.agents)  # the same desired speeds
    steps = 0
    while not arena.done and steps < 150:
        batch = arena.sensing()
        one = np.array([ag.act(batch.observation(k)) for k, ag in enumerate(alone)])
        got = arena.step().commanded[arena.robot_ids]
        assert got.tobytes() == one.tobytes(), (name, arena.time)
        steps += 1


@settings(max_examples=60, deadline=None)
@given(data=st.data(), people=st.integers(1, 6), others=st.integers(0, 4), walls=st.integers(0, 3))
def test_act_and_act_batch_agree_on_random_batches(data, people, others, walls):
    n = people + others
    pos = np.array([data.draw(vec(4.0)) for _ in range(n)])
    vel = np.array([data.draw(vec(1.5)) for _ in range(n)])
    radii = np.array([data.draw(floats(0.1, 0.5)) for _ in range(n)])
    kinds = ["robot"] * people + [
        data.draw(st.sampled_from(["robot", "traffic"])) for _ in range(others)
    ]
    seg = np.array([[data.draw(vec(5.0)), data.draw(vec(5.0))] for _ in range(walls)])
    start, index = [0], []
    for k in range(people):
        index += [j for j in range(n) if j != k and data.draw(st.booleans())]
        start.append(len(index))
    batch = SensingBatch(
        time=0.0,
        dt=0.1,
        positions=pos,
        velocities=vel,
        accelerations=np.zeros((n, 2)),
        radii=radii,
        a_max=np.full(n, 2.0),
        v_max=np.full(n, 2.0),
        kinds=np.array(kinds),
        plans=None,
        known_paths=None,
        path_times=np.zeros(0),
        bodies=np.arange(people, dtype=np.int64),
        goals=np.array([data.draw(vec(6.0)) for _ in range(people)]),
        routes=[None] * people,
        walls=seg.reshape(-1, 2, 2),
        wall_radius=np.array([data.draw(floats(0.0, 0.2)) for _ in range(walls)]),
        nb_start=np.array(start, dtype=np.int64),
        nb_index=np.array(index, dtype=np.int64),
    )
    agents = [
        SocialForceAgent(
            v_pref=data.draw(floats(0.5, 2.0)),
            anisotropy=data.draw(floats(0.0, 1.0)),
            sees_robots=data.draw(st.booleans()),
        )
        for _ in range(people)
    ]
    together = SocialForceAgent.act_batch(agents, batch, list(range(people)))
    assert isinstance(together, np.ndarray) and together.shape == (people, 2)
    assert np.all(np.isfinite(together))
    for k, agent in enumerate(agents):
        assert agent.act(batch.observation(k)).tobytes() == together[k].tobytes()


# ---------------------------------------------------------------- 8. walls


@settings(max_examples=100, deadline=None)
@given(
    x=floats(-4.5, 4.5),
    y=floats(-1.5, 1.5),
    r=floats(0.1, 0.5),
    wr=floats(0.0, 0.3),
    a_w=floats(1.0, 60.0),
    b_w=floats(0.05, 0.5),
)
def test_a_wall_repels_along_its_normal_as_the_formula_says(x, y, r, wr, a_w, b_w):
    """A person at rest at its goal (no driving term) beside the wall segment from (-5, 0)
    to (5, 0) of half-thickness wr: pushed straight away from it, A_w exp((r - (|y| - wr))
    / B_w)."""
    assume(abs(y) > 1e-3)
    agent = SocialForceAgent(v_pref=1.0, wall_strength=a_w, wall_range=b_w)
    got = agent.act(
        _obs((x, y), goal=(x, y), radius=r, walls=[[(-5.0, 0.0), (5.0, 0.0)]], wall_radius=[wr])
    )
    want = math.copysign(a_w * math.exp((r - (abs(y) - wr)) / b_w), y)
    assert abs(got[0]) <= 1e-12 * abs(want)
    assert got[1] == pytest.approx(want, rel=1e-12)


def test_beyond_its_end_a_wall_repels_from_its_end_point():
    agent = SocialForceAgent(v_pref=1.0)
    p = np.array([5.3, 0.4])  # 0.5 m from the end (5, 0), along (0.6, 0.8)
    got = agent.act(_obs(p, goal=p, walls=[[(-5.0, 0.0), (5.0, 0.0)]], wall_radius=[0.0]))
    np.testing.assert_allclose(got, 50.0 * math.exp((0.3 - 0.5) / 0.2) * np.array([0.6, 0.8]))


def test_a_person_walking_beside_a_wall_is_pushed_off_it(tmp_path):
    walls = "  - {type: segment, a: [-10.0, 0.0], b: [10.0, 0.0], thickness: 0.2}"
    arena = Arena(
        load_map(_map(tmp_path, [((-6.0, 0.55), (6.0, 0.55))], walls)),
        ArenaOptions(agent=REF, agent_options={"v_pref": 1.2}),
    )
    p, _ = _walk(arena, seed=0, steps=40)
    y = p[:, 0, 1]
    # its goal lies on its line, 0.15 m from the wall's surface: pushed off at once, it
    # never comes nearer the wall than where it started
    assert y[1] > y[0] and y.min() == y[0] and y.max() > 1.0
    assert arena.summary().contacts == []


# ---------------------------------------------------------------- robustness and options


@settings(max_examples=100, deadline=None)
@given(
    p=vec(2.0),
    v=vec(2.0),
    nb=st.lists(vec(2.0), min_size=0, max_size=5),
    on_wall=st.booleans(),
)
def test_the_acceleration_is_finite_however_deep_the_overlap(p, v, nb, on_wall):
    """Bodies on top of the person (centres together included), a person on a wall's
    centre line: a finite acceleration (the world scales it to a_max)."""
    nb_positions = [p + 0.01 * q for q in nb] + [p]
    walls = [[p - (1.0, 0.0), p + (1.0, 0.0)]] if on_wall else [[(-9.0, -9.0), (9.0, -9.0)]]
    agent = SocialForceAgent(v_pref=1.3, range=0.001, wall_range=0.001)  # exp(4000) without the cap
    got = agent.act(
        _obs(
            p,
            v,
            (5.0, 5.0),
            2.0,
            nb_positions,
            [2.0] * len(nb_positions),
            walls=walls,
            wall_radius=[1.0],
        )
    )
    assert got.shape == (2,) and np.all(np.isfinite(got))


def test_without_a_goal_the_person_heads_for_its_route_end_or_stands():
    agent = SocialForceAgent(v_pref=1.0)
    to_route = agent.act(_obs((0.0, 0.0), route=[(1.0, 1.0), (0.0, FAR)]))
    np.testing.assert_allclose(to_route, [0.0, 1.0 / 0.5], atol=1e-12)
    standing = agent.act(_obs((0.0, 0.0), velocity=(0.4, -0.2)))
    np.testing.assert_allclose(standing, [-0.8, 0.4], rtol=1e-15)


def test_near_its_goal_the_person_slows_to_d_over_two_tau():
    agent = SocialForceAgent(v_pref=1.3)
    got = agent.act(_obs((0.0, 0.0), goal=(0.5, 0.0)))
    np.testing.assert_allclose(got, [0.5 / (2 * 0.5) / 0.5, 0.0], rtol=1e-15)
    inside = agent.act(_obs((0.0, 0.0), velocity=(0.3, 0.0), goal=(0.15, 0.0)))
    np.testing.assert_allclose(inside, [-0.3 / 0.5, 0.0], rtol=1e-15)


def test_the_options_and_their_defaults():
    agent = SocialForceAgent()
    assert agent.params == SocialForceParams()
    assert agent.params.strength == pytest.approx(2.1 / 0.3)
    assert agent.params.wall_strength == pytest.approx(10.0 / 0.2)
    assert (agent.params.tau, agent.params.range, agent.params.wall_range) == (0.5, 0.3, 0.2)
    assert agent.params.anisotropy == 0.5 and agent.params.sees_robots is True
    assert agent.panel().v_pref == agent.v_pref
    taken = SocialForceAgent(tau=1, strength=0, sees_robots=np.bool_(False), v_pref=2)
    assert (taken.params.tau, taken.params.strength, taken.v_pref) == (1.0, 0.0, 2.0)
    assert taken.params.sees_robots is False
    with pytest.raises(AttributeError):
        taken.params.tau = 2.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"tau": 0.0}, "social_force option tau: expected a finite number > 0 (s)"),
        ({"tau": math.inf}, "social_force option tau"),
        ({"strength": -1.0}, "social_force option strength: expected a finite number >= 0"),
        ({"range": 0.0}, "social_force option range: expected a finite number > 0 (m)"),
        ({"anisotropy": 1.5}, "social_force option anisotropy: expected a number in [0, 1]"),
        ({"anisotropy": -0.1}, "social_force option anisotropy"),
        ({"wall_strength": math.nan}, "social_force option wall_strength"),
        ({"wall_range": "0.2"}, "social_force option wall_range"),
        ({"goal_radius": -0.1}, "social_force option goal_radius"),
        ({"sees_robots": 0}, "social_force option sees_robots: expected True or False"),
        ({"v_pref": -1.0}, "social_force option v_pref: expected a finite number >= 0 (m/s)"),
        ({"v_pref": True}, "social_force option v_pref"),
    ],
)
def test_bad_options_are_refused_in_one_line(options, message):
    with pytest.raises(ValueError) as info:
        SocialForceAgent(**options)
    text = str(info.value)
    assert text.startswith(message) and "\n" not in text
