"""The NAO agent's rules, one robot at a time (``act``): holding and repairing an
avoidance adjustment, what it does when nothing is admissible, neighbours already
inside the margin, escalating detours; ``act`` is ``act_batch`` for the one-robot batch
of an observation (whole episodes: test_fast_path.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference.goal_reference import goal_seeking_accels_reference
from reference.nao_reference import detour_step

from nao_arena.agents import _nao_columns as columns
from nao_arena.agents._nao_decide import keep_candidates, member_lists
from nao_arena.agents._nao_liveness import held_by_standing_kernel
from nao_arena.agents.goal import GoalAgent, goal_seeking_accel, goal_seeking_accels
from nao_arena.agents.nao import NAOAgent
from nao_arena.geometry import AccelLimits, repair_acceleration
from nao_arena.obstacles import RADIUS_CUT, obstacle_paths
from nao_arena.sensing import Neighbours, Observation, SensingBatch, neighbour_lists


def observation(
    pos=(0.0, 0.0),
    vel=(1.0, 0.0),
    goal=(10.0, 0.0),
    nb_pos=(3.0, 0.0),
    nb_vel=(0.0, 0.0),
    kind="robot",
    radius=0.3,
) -> Observation:
    nb = Neighbours(
        ids=np.array([1]),
        kinds=(kind,),
        positions=np.array([nb_pos], dtype=float),
        velocities=np.array([nb_vel], dtype=float),
        accelerations=np.zeros((1, 2)),
        radii=np.array([radius]),
    )
    return Observation(
        time=0.0,
        dt=0.1,
        robot_id=0,
        position=np.array(pos, dtype=float),
        velocity=np.array(vel, dtype=float),
        acceleration=np.zeros(2),
        radius=radius,
        a_max=2.0,
        v_max=1.5,
        goal=np.array(goal, dtype=float),
        neighbours=nb,
    )


def agent(**options) -> NAOAgent:
    ag = NAOAgent(predictor="constant_velocity", **options)
    ag.reset(None, np.random.default_rng(0))
    return ag


@pytest.mark.slow
def test_a_young_adjustment_is_kept_while_admissible_then_reselected():
    obs = observation()
    held = agent()
    first = held.act(obs)
    sel = held.last_selection
    assert sel.status == "adjusted"
    desired = agent().act(observation(nb_pos=(50.0, 50.0)))  # the same robot, no obstacle
    assert np.hypot(*(first - desired)) > held.keep_band  # outside the band
    for _ in range(9):  # 0.9 s < reselect_after = 1 s: kept, no new selection
        np.testing.assert_array_equal(held.act(obs), first)
        assert held.last_selection is sel
    held.act(obs)  # 1 s old: selected afresh
    assert held.last_selection is not sel
    eager = agent(reselect_after=0.0)
    eager.act(obs)
    before = eager.last_selection
    eager.act(obs)
    assert eager.last_selection is not before


def test_a_young_adjustment_that_becomes_inadmissible_is_repaired_locally():
    obs = observation()
    ag = agent()
    first = ag.act(obs)
    sel = ag.last_selection
    assert sel.status == "adjusted"
    path = ag.last_obstacles()
    # just past the boundary, towards the neighbour straight ahead: inadmissible
    bad = next(
        b
        for b in (first + s * (np.array([2.0, 0.0]) - first) for s in np.linspace(0.01, 1.0, 100))
        if not ag.admissible(obs, b)
    )
    ag.current = bad
    desired = agent().act(observation(nb_pos=(50.0, 50.0)))
    expected = repair_acceleration(
        ag.current, desired, obs.velocity, path, AccelLimits(2.0), v_max=1.5
    )
    assert expected is not None
    got = ag.act(obs)
    np.testing.assert_array_equal(got, expected)
    assert ag.last_selection is sel and ag.age == pytest.approx(0.1)  # not a new selection
    assert ag.admissible(obs, got)


def head_on(kind: str) -> Observation:
    """A neighbour 0.1 m away (surfaces) closing at 3 m/s: no acceleration avoids it."""
    return observation(vel=(1.5, 0.0), nb_pos=(0.7, 0.0), nb_vel=(-1.5, 0.0), kind=kind)


def test_nothing_admissible_brakes_among_robots():
    ag = agent()
    a = ag.act(head_on("robot"))
    assert ag.last_selection.status == "infeasible"
    np.testing.assert_allclose(a, [-2.0, 0.0])  # -v/|v| min(a_max, |v| / dt)
    slow = agent()
    a = slow.act(observation(vel=(0.1, 0.0), nb_pos=(0.7, 0.0), nb_vel=(-1.5, 0.0)))
    assert slow.last_selection.status == "infeasible"
    np.testing.assert_allclose(a, [-1.0, 0.0])  # stops within the period: -v / dt


def test_nothing_admissible_postpones_contact_among_traffic():
    ag = agent()
    a = ag.act(head_on("traffic"))
    assert ag.last_selection.status == "infeasible"
    assert not np.allclose(a, [-2.0, 0.0])
    forced = agent(infeasible="brake")
    np.testing.assert_allclose(forced.act(head_on("traffic")), [-2.0, 0.0])
    dodging = agent(infeasible="latest_contact")
    np.testing.assert_array_equal(dodging.act(head_on("robot")), a)


def test_a_neighbour_inside_the_margin_may_be_left_not_approached():
    # at rest, surfaces 0.05 m apart (margin 0.15): leaving is admissible, closing is not
    leave = agent()
    leave.act(observation(vel=(0.0, 0.0), goal=(-10.0, 0.0), nb_pos=(0.65, 0.0)))
    assert leave.last_selection.status == "desired"
    approach = agent()
    a = approach.act(observation(vel=(0.0, 0.0), goal=(10.0, 0.0), nb_pos=(0.65, 0.0)))
    assert approach.last_selection.status != "desired"
    assert a[0] <= 1e-9  # no component towards the neighbour


def test_detours_turn_further_the_longer_a_robot_crawls():
    ag = agent()
    for _ in range(11):  # 1.1 s
        detour_step(ag, far=True, crawling=True, dt=0.1, to_goal=10.0)
    assert ag.detour_turns == 1 and -math.pi / 3 <= ag.detour <= -math.pi / 6
    for _ in range(20):  # 3.1 s
        detour_step(ag, far=True, crawling=True, dt=0.1, to_goal=10.0)
    assert ag.detour_turns == 3 and -math.pi <= ag.detour <= -math.pi / 2
    for _ in range(100):
        detour_step(ag, far=True, crawling=True, dt=0.1, to_goal=10.0)
    assert -5 * math.pi / 6 - math.pi / 3 <= ag.detour <= -5 * math.pi / 6  # backing off
    for _ in range(9):  # 0.9 s moving freely
        detour_step(ag, far=True, crawling=False, dt=0.1, to_goal=10.0)
    assert ag.detour != 0.0
    for _ in range(2):  # 1.1 s: moved freely for detour_after
        detour_step(ag, far=True, crawling=False, dt=0.1, to_goal=10.0)
    assert ag.detour == 0.0 and ag.detour_turns == 0


def test_detours_switch_sides_after_a_spell_without_progress():
    """20 s (switch_side_after) held by standing neighbours without coming 0.5 m closer:
    detours turn left from then on; a robot that keeps getting closer, or is held by a
    moving crowd, keeps turning right."""
    stuck, going, crowd = agent(), agent(), agent()
    for k in range(201):
        detour_step(stuck, far=True, crawling=True, dt=0.1, to_goal=10.0)
        detour_step(going, far=True, crawling=True, dt=0.1, to_goal=100.0 - 0.1 * k)
        detour_step(crowd, far=True, crawling=True, dt=0.1, to_goal=10.0, held=False)
    assert stuck.side == 1.0 and going.side == -1.0 and going.detour < 0.0
    assert crowd.side == -1.0 and crowd.detour < 0.0
    for _ in range(11):
        detour_step(stuck, far=True, crawling=True, dt=0.1, to_goal=10.0)
    assert stuck.detour_turns == 1 and math.pi / 6 <= stuck.detour <= math.pi / 3
    for _ in range(200):  # another spell: back to the right
        detour_step(stuck, far=True, crawling=True, dt=0.1, to_goal=10.0)
    assert stuck.side == -1.0
    with pytest.raises(ValueError, match="switch_side_after"):
        NAOAgent(switch_side_after=0.0)


def _held_scene(extra: list[tuple[float, float]], speed: float = 0.0) -> SensingBatch:
    """Robot 0 at the origin (radius 0.5 m) heading for (0, 10); a robot 1.2 m ahead (gap
    0.2 m) moving at ``speed`` m/s, and standing ``extra`` bodies (x, y) of radius 0.5 m."""
    pos = np.array([(0.0, 0.0), (0.0, 1.2), *extra])
    vel = np.zeros_like(pos)
    vel[1, 0] = speed
    n = len(pos)
    bodies = np.zeros(1, dtype=np.int64)
    start, index = neighbour_lists(bodies, pos, 15.0, 10)
    return SensingBatch(
        time=0.0,
        dt=0.1,
        positions=pos,
        velocities=vel,
        accelerations=np.zeros((n, 2)),
        radii=np.full(n, 0.5),
        a_max=np.full(n, 2.0),
        v_max=np.full(n, 1.5),
        kinds=np.array(["robot"] * n),
        plans=None,
        known_paths=None,
        path_times=np.zeros(0),
        bodies=bodies,
        goals=np.array([[0.0, 10.0]]),
        routes=(None,),
        walls=np.zeros((0, 2, 2)),
        wall_radius=np.zeros(0),
        nb_start=start,
        nb_index=index,
    )


@pytest.mark.parametrize(
    ("extra", "held"),
    [
        ([], True),  # held by a standing robot, room behind: counts
        ([(3.0, -1.5)], True),  # a body behind but more than 1 m off the surface
        ([(0.8, -1.0)], False),  # boxed in: a body within 1 m behind (a jam)
        ([(1.3, 0.3)], True),  # a body close beside, towards the goal: still counts
    ],
)
def test_only_a_robot_held_by_standing_robots_with_room_behind_counts_toward_switching(extra, held):
    """The time toward switch_side_after counts while the nearest neighbour stands within
    1 m and nothing is within 1 m behind the robot (away from its goal): held behind a
    parked row, not packed in a jam, where switching sides would go against the crowd."""
    batch = _held_scene(extra)
    rows = np.zeros(1, dtype=np.int64)
    got = _held_by_standing(batch, rows, np.array([0.5]), batch.goals)
    assert got.tolist() == [held]
    moving = _held_scene(extra, speed=0.5)  # the nearest moves: a crowd, not a parked row
    assert _held_by_standing(moving, rows, np.array([0.5]), moving.goals).tolist() == [False]


def _held_by_standing(
    batch: SensingBatch, rows: np.ndarray, rad: np.ndarray, goals: np.ndarray
) -> np.ndarray:
    """The compiled held test (:func:`held_by_standing_kernel`) of the batch rows ``rows``."""
    out = np.zeros(len(rows), dtype=np.bool_)
    f = np.ascontiguousarray
    held_by_standing_kernel(
        f(batch.nb_start),
        f(batch.nb_index),
        f(rows),
        f(batch.bodies),
        f(batch.positions),
        f(batch.velocities),
        f(batch.radii),
        f(rad),
        f(goals),
        out,
    )
    return out


def _held_reference(
    batch: SensingBatch, rows: np.ndarray, rad: np.ndarray, goals: np.ndarray
) -> np.ndarray:
    """The held test in plain numpy, robot by robot (the compiled one's reference)."""
    out = np.zeros(len(rows), dtype=bool)
    for i, row in enumerate(rows.tolist()):
        nbs = batch.nb_index[batch.nb_start[row] : batch.nb_start[row + 1]]
        if not len(nbs):
            continue
        own = batch.positions[batch.bodies[row]]
        rel = batch.positions[nbs] - own
        surface = np.hypot(rel[:, 0], rel[:, 1]) - batch.radii[nbs] - rad[i]
        still = np.hypot(*batch.velocities[nbs[0]]) < 0.1
        behind = rel @ (goals[i] - own) < 0.0
        out[i] = still and surface[0] < 1.0 and not np.any((surface < 1.0) & behind)
    return out


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 40), st.integers(0, 2**32 - 1), st.floats(0.5, 6.0), st.integers(0, 10))
def test_held_by_standing_matches_a_robot_by_robot_reference(n, seed, spread, cap):
    """The compiled held test gives the reference's answer for every robot of random
    crowds (half of the bodies standing, goals anywhere, some robots without neighbours)."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-spread, spread, (n, 2)) * math.sqrt(n)
    vel = rng.uniform(-0.3, 0.3, (n, 2)) * (rng.random((n, 1)) < 0.5)
    radii = rng.uniform(0.2, 0.6, n)
    bodies = rng.permutation(n)[: max(1, n // 2)].astype(np.int64)
    start, index = neighbour_lists(bodies, pos, 4.0, cap)
    k = len(bodies)
    goals = rng.uniform(-10.0, 10.0, (k, 2))
    batch = SensingBatch(
        time=0.0,
        dt=0.1,
        positions=pos,
        velocities=vel,
        accelerations=np.zeros((n, 2)),
        radii=radii,
        a_max=np.full(n, 2.0),
        v_max=np.full(n, 1.5),
        kinds=np.array(["robot"] * n),
        plans=None,
        known_paths=None,
        path_times=np.zeros(0),
        bodies=bodies,
        goals=goals,
        routes=(None,) * k,
        walls=np.zeros((0, 2, 2)),
        wall_radius=np.zeros(0),
        nb_start=start,
        nb_index=index,
    )
    rows = rng.permutation(k).astype(np.int64)
    rad = radii[bodies[rows]]
    want = _held_reference(batch, rows, rad, goals[rows])
    assert _held_by_standing(batch, rows, rad, goals[rows]).tolist() == want.tolist()


# ---------------------------------------------------------------- one robot is a batch of one


def random_batch(rng: np.random.Generator, n_robots: int, odd: str) -> SensingBatch:
    """A step of n_robots robots and two traffic cars in a walled 8 m box; ``odd``:
    "" (nothing), "nan" (a car's velocity unknown) or "inf" (robot 1 infinitely fast)."""
    n = n_robots + 2
    pos = rng.uniform(-3.0, 3.0, (n, 2))
    vel = rng.uniform(-1.2, 1.2, (n, 2))
    if odd == "nan":
        vel[n_robots, 0] = np.nan
    if odd == "inf" and n_robots > 1:
        vel[1] = (np.inf, 0.0)
    bodies = np.arange(n_robots, dtype=np.int64)
    start, index = neighbour_lists(bodies, pos, 4.0)
    walls = np.array([[[-4.0, -4.0], [4.0, -4.0]], [[4.0, -4.0], [4.0, 4.0]]])
    return SensingBatch(
        time=0.0,
        dt=0.1,
        positions=pos,
        velocities=vel,
        accelerations=rng.uniform(-1.0, 1.0, (n, 2)),
        radii=rng.uniform(0.2, 0.4, n),
        a_max=np.full(n, 2.0),
        v_max=np.full(n, 1.5),
        kinds=np.array(["robot"] * n_robots + ["traffic"] * 2),
        plans=None,
        known_paths=None,
        path_times=np.zeros(0),
        bodies=bodies,
        goals=rng.uniform(-6.0, 6.0, (n_robots, 2)),
        routes=(None,) * n_robots,
        walls=walls,
        wall_radius=np.full(2, 0.05),
        nb_start=start,
        nb_index=index,
    )


def outcome(res: object) -> object:
    return (type(res).__name__, str(res)) if isinstance(res, Exception) else res.tobytes()


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # the non-finite input
@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_robots=st.integers(1, 6),
    odd=st.sampled_from(["", "nan", "inf"]),
    infeasible=st.sampled_from(["auto", "latest_contact"]),
    samples=st.sampled_from([None, 4]),
)
def test_act_on_an_observation_is_act_batch_on_the_arenas_batch(
    seed, n_robots, odd, infeasible, samples
):
    """act (the one-robot batch of an observation) and act_batch (every robot of the
    arena's batch) decide alike, step after step: accelerations, failures, selections,
    detours and the obstacles tested, also for non-finite input and with no braking."""
    rng = np.random.default_rng(seed)
    # stopping plans act across the batch (a batch of one has no one to yield to)
    options = {"infeasible": infeasible, "samples": samples, "margin": 0.3, "stopping_plans": False}
    together = [NAOAgent(**options) for _ in range(n_robots)]
    alone = [NAOAgent(**options) for _ in range(n_robots)]
    for k in range(n_robots):
        together[k].reset(None, np.random.default_rng(k))
        alone[k].reset(None, np.random.default_rng(k))
    for _ in range(4):
        batch = random_batch(rng, n_robots, odd)
        got = NAOAgent.act_batch(together, batch, range(n_robots))
        for k in range(n_robots):
            try:
                one = alone[k].act(batch.observation(k))
            except Exception as exc:  # noqa: BLE001 - compared with act_batch's
                one = exc
            assert outcome(got[k]) == outcome(one)
            a, b = together[k], alone[k]
            assert (a.last_selection is None) == (b.last_selection is None)
            if a.last_selection is not None:
                assert a.last_selection.status == b.last_selection.status
            np.testing.assert_array_equal(a.last_decision()[1], b.last_decision()[1])
            assert a.detour == b.detour
            if not isinstance(one, Exception):
                pa, pb = a.last_obstacles(), b.last_obstacles()
                np.testing.assert_array_equal(pa.c, pb.c)
                np.testing.assert_array_equal(pa.radius, pb.radius)


def test_the_one_robot_batch_gives_back_the_observation():
    obs = observation(goal=(4.0, 1.0))
    batch = SensingBatch.of_observation(obs)
    again = batch.observation(0)
    for name in ("position", "velocity", "acceleration", "goal", "walls", "wall_radius"):
        np.testing.assert_array_equal(getattr(again, name), getattr(obs, name))
    assert (again.radius, again.a_max, again.v_max) == (obs.radius, obs.a_max, obs.v_max)
    for name in ("positions", "velocities", "accelerations", "radii"):
        np.testing.assert_array_equal(
            getattr(again.neighbours, name), getattr(obs.neighbours, name)
        )
    assert again.neighbours.kinds == obs.neighbours.kinds
    no_goal = SensingBatch.of_observation(
        observation(goal=(0.0, 0.0)).__class__(**{**obs.__dict__, "goal": None})
    )
    assert np.all(np.isnan(no_goal.goals))


class Cautious(NAOAgent):
    """Overrides act (the hook act_batch honours) and calls the inherited one."""

    def act(self, obs: Observation) -> np.ndarray:
        return 0.5 * super().act(obs)


def test_a_subclass_act_is_what_act_batch_runs_and_may_call_the_inherited_act():
    rng = np.random.default_rng(3)
    batch = random_batch(rng, 3, "")
    plain = [NAOAgent() for _ in range(3)]
    cautious = [Cautious() for _ in range(3)]
    for k in range(3):
        plain[k].reset(None, np.random.default_rng(k))
        cautious[k].reset(None, np.random.default_rng(k))
    got = Cautious.act_batch(cautious, batch, [0, 1, 2])
    want = NAOAgent.act_batch(plain, batch, [0, 1, 2])
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, 0.5 * w)


def test_last_obstacles_and_admissible_report_what_act_tested():
    ag = agent()
    assert ag.last_obstacles() is None
    obs = observation()
    a = ag.act(obs)
    path = ag.last_obstacles()
    assert path is not None and path.n_obstacles == 1  # the neighbour ahead
    np.testing.assert_allclose(path.c[0, 0], [3.0, 0.0])
    assert ag.admissible(obs, a) and not ag.admissible(obs, np.array([2.0, 0.0]))
    assert not ag.admissible(obs, np.array([0.0, 2.5]))  # beyond a_max


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # the non-finite input
@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_robots=st.integers(1, 6),
    odd=st.sampled_from(["", "nan", "inf"]),
    v_pref=st.sampled_from([None, 0.8, 3.0]),
)
def test_goal_seeking_in_bulk_is_goal_seeking_robot_by_robot(seed, n_robots, odd, v_pref):
    """GoalAgent.act_batch and NAO's goal seeking (goal_seeking_accels) compute what
    goal_seeking_accel computes for each robot, bit for bit (also for non-finite input)."""
    batch = random_batch(np.random.default_rng(seed), n_robots, odd)
    agents = [GoalAgent(v_pref=v_pref, time_constant=0.3 + 0.1 * k) for k in range(n_robots)]
    got = GoalAgent.act_batch(agents, batch, range(n_robots))
    for k in range(n_robots):
        want = goal_seeking_accel(batch.observation(k), v_pref, 0.3 + 0.1 * k)
        np.testing.assert_array_equal(got[k], want)


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # the non-finite input
@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 30),
    odd=st.sampled_from(["", "nan", "inf", "at_goal"]),
    turned=st.booleans(),
    per_row_tau=st.booleans(),
    targets_missing=st.booleans(),
)
def test_compiled_goal_seeking_is_the_numpy_reference_bit_for_bit(
    seed, n, odd, turned, per_row_tau, targets_missing
):
    """goal_seeking_accels (compiled) gives the vectorised numpy reference's accelerations
    bit for bit: heading offsets, per-row time constants, robots without a target,
    robots on their goal, far and near goals, non-finite input."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-20.0, 20.0, (n, 2))
    targets = pos + rng.normal(0.0, 1.0, (n, 2)) * rng.choice([0.01, 1.0, 30.0], (n, 1))
    vel = rng.uniform(-2.0, 2.0, (n, 2))
    a_max = rng.uniform(0.5, 3.0, n)
    cap = rng.uniform(0.2, 2.0, n)
    if odd == "at_goal":
        targets[::2] = pos[::2]
    elif odd:
        vel[rng.integers(n)] = float(odd)
        targets[rng.integers(n), rng.integers(2)] = float(odd)
    offsets = (rng.uniform(-np.pi, np.pi, n) * (rng.random(n) < 0.7)).tolist() if turned else None
    tau = rng.uniform(0.2, 1.0, n) if per_row_tau else 0.5
    has = rng.random(n) < 0.8 if targets_missing else None
    got = goal_seeking_accels(targets, pos, vel, a_max, cap, offsets, tau, has_target=has)
    want = goal_seeking_accels_reference(
        targets, pos, vel, a_max, cap, offsets, tau, has_target=has
    )
    np.testing.assert_array_equal(got, want)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 25))
def test_keep_candidates_and_member_lists_are_their_plain_definitions(seed, n):
    """The compiled keep candidates are: within the band of the desired acceleration or
    holding a young adjustment, and within a_max (NaN: not near, not outside); the
    members' lists are their rows' slices of the batch lists, concatenated."""
    rng = np.random.default_rng(seed)
    current = rng.uniform(-2.5, 2.5, (n, 2))
    desired = current + rng.normal(0.0, 0.3, (n, 2)) * rng.choice([0.0, 1.0, 5.0], (n, 1))
    current[rng.random(n) < 0.1] = np.nan
    a_max = rng.uniform(1.0, 3.0, n)
    members = rng.permutation(n)[: int(rng.integers(1, n + 1))].astype(np.int64)
    whole = np.zeros((n, columns.N_WHOLE), dtype=np.int64)
    opt = np.zeros((n, columns.N_OPT))
    opt[:, columns.KEEP_BAND] = rng.choice([0.1, 0.3], n)
    whole[:, columns.SETTLING] = rng.random(n) < 0.3
    band = np.where(whole[:, columns.SETTLING] == 1, 0.0, opt[:, columns.KEEP_BAND])
    holds = rng.random(len(members)) < 0.3
    status = np.full(len(members), -7, dtype=np.int64)
    count = keep_candidates(members, current, desired, a_max, whole, opt, holds, status)
    for j, i in enumerate(members.tolist()):
        near = np.hypot(*(current[i] - desired[i])) <= band[i]
        inside = not np.hypot(*current[i]) > a_max[i] * (1 + 1e-9)
        assert status[j] == (2 if (near or holds[j]) and inside else 0)
    assert count == int(np.sum(status == 2))
    counts = rng.integers(0, 6, n)
    nb_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    nb_index = rng.integers(0, 100, nb_start[-1]).astype(np.int64)
    start, index = member_lists(nb_start, nb_index, members)
    want = [nb_index[nb_start[r] : nb_start[r + 1]] for r in members.tolist()]
    assert np.diff(start).tolist() == [len(w) for w in want]
    assert index.tolist() == (np.concatenate(want).tolist() if want else [])


def test_obstacle_paths_cut_radii_inside_the_margin_and_keep_walls_within_reach():
    times = np.linspace(0.0, 1.0, 3)
    centres = np.array([[[1.5, 1.0]] * 3, [[5.0, 1.0]] * 3])  # world frame, at rest
    position = np.array([1.0, 1.0])
    # segments 0.3 m, 2 m and 8 m away (world frame), grown radii 0.5 m
    walls = np.array([[[0.0, 1.3], [2.0, 1.3]], [[0.0, 3.0], [2.0, 3.0]], [[0.0, 9.0], [2.0, 9.0]]])
    walls_r = np.array([0.5, 0.5, 0.5])
    cut = obstacle_paths(
        times, centres, np.array([0.75, 0.75]), position, walls, walls_r, wall_reach=4.0
    )
    np.testing.assert_array_equal(cut.radius, [0.5 * RADIUS_CUT, 0.75])
    np.testing.assert_array_equal(cut.c[:, 0], [[0.5, 0.0], [4.0, 0.0]])
    # the nearest wall cut to just under its distance, the far one beyond reach left out
    np.testing.assert_allclose(cut.wall_radius, [0.3 * RADIUS_CUT, 0.5], rtol=1e-12)
    np.testing.assert_array_equal(cut.walls, walls[:2] - position)
    whole = obstacle_paths(
        times, centres, np.array([0.75, 0.75]), position, walls, walls_r, cut=False
    )
    np.testing.assert_array_equal(whole.radius, [0.75, 0.75])
    np.testing.assert_array_equal(whole.wall_radius, [0.5, 0.5, 0.5])
    assert obstacle_paths(times, np.zeros((0, 3, 2)), np.zeros(0), position).n_obstacles == 0


def test_traffic_near_follows_each_kinds_array_even_when_remembered():
    """The robots' traffic flags read each batch's kinds: the mask remembered for the
    arena's read-only kinds array is never served for another array, a writable one, or
    one that was changed (a copy with other kinds)."""
    from types import SimpleNamespace

    from nao_arena.agents._nao_columns import StepMemo
    from nao_arena.agents._nao_step import own_rows_of

    memo = StepMemo()  # the table's: what one batch remembers between steps

    def batch(kinds: np.ndarray) -> SimpleNamespace:
        # robot 0 (body 0) sees body 1, robot 1 (body 2) sees body 2
        return SimpleNamespace(
            kinds=kinds,
            nb_start=np.array([0, 1, 2]),
            nb_index=np.array([1, 2]),
            bodies=np.array([0, 2]),
            positions=np.zeros((3, 2)),
            velocities=np.zeros((3, 2)),
            radii=np.full(3, 0.5),
            a_max=np.full(3, 2.0),
            v_max=np.full(3, 1.5),
            goals=np.zeros((2, 2)),
        )

    def traffic_near(b: SimpleNamespace) -> list[bool]:
        return own_rows_of(b, np.array([0, 1]), memo)[6].tolist()

    owned = np.array(["robot", "traffic", "robot"])
    owned.setflags(write=False)
    other = np.array(["robot", "robot", "traffic"])
    other.setflags(write=False)
    writable = np.array(["robot", "robot", "robot"], dtype="<U7")
    for _ in range(2):  # twice: the second round is served from what was remembered
        assert traffic_near(batch(owned)) == [True, False]
        assert traffic_near(batch(other)) == [False, True]
        assert traffic_near(batch(writable)) == [False, False]
        writable[1] = "traffic"
        assert traffic_near(batch(writable)) == [True, False]
        writable[1] = "robot"
