"""The communication channel (range, latency, loss) and the stopping-plan rule's tubes for
robots that are not linked, checked against the world (pymunk) and independent tallies."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_stopping import A_MAX, DT, RADIUS, SUBSTEPS, V_MAX, min_gaps, robots_map

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.communication import OFF, Channel, Communication, exchanges, lost
from nao_arena.maps import MapError, load_map, map_from_dict
from nao_arena.stopping import (
    Knowledge,
    Noise,
    commit_plans,
    plan_clearance,
    stopping_plan,
    tube_clearance,
    tube_reference,
)
from nao_arena.world import World

# ---------------------------------------------------------------------- the channel


def test_loss_draws_are_symmetric_deterministic_and_at_the_rate() -> None:
    """Each unordered pair loses its exchange of a period with the given probability: the
    same draw for (i, j) and (j, i) and for the same key, another for another key or
    period; over 40,000 pair-periods the share lost is within 5 standard deviations."""
    rng = np.random.default_rng(3)
    i = rng.integers(0, 200, 40_000)
    j = rng.integers(0, 200, 40_000)
    for loss in (0.1, 0.5, 0.9):
        a = lost(7, i, j, 12, loss)
        assert np.array_equal(a, lost(7, j, i, 12, loss))
        assert np.array_equal(a, lost(7, i, j, 12, loss))
        sd = math.sqrt(loss * (1 - loss) / len(i))
        assert abs(a.mean() - loss) < 5 * sd
    assert not np.array_equal(lost(7, i, j, 12, 0.5), lost(8, i, j, 12, 0.5))
    assert not np.array_equal(lost(7, i, j, 12, 0.5), lost(7, i, j, 13, 0.5))
    assert not lost(7, i, j, 12, 0.0).any() and lost(7, i, j, 12, 1.0).all()


def test_exchanges_follow_the_range() -> None:
    """Robots 0 and 1 are 3 m apart, robot 2 10 m from both: range 5 links only the first
    pair, range 0 (off) none, an infinite range every pair."""
    pos = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 10.0]])
    near = exchanges(pos, Communication(range=5.0), 1, 0)
    assert near.tolist() == [[False, True, False], [True, False, False], [False, False, False]]
    assert not exchanges(pos, OFF, 1, 0).any()
    every = exchanges(pos, Communication(), 1, 0)
    assert every.sum() == 6 and not every.diagonal().any()


def test_messages_arrive_after_the_latency_with_the_state_sent() -> None:
    """With 0.2 s of latency (two periods of 0.1 s) the message sent at t arrives at
    t + 0.2 and carries the state of t; no pair is ever linked."""
    channel = Channel(Communication(latency=0.2), 2, 0.1, key=5)
    for k in range(5):
        t = round(0.1 * k, 10)
        pos = np.array([[float(k), 0.0], [0.0, float(k)]])
        vel = np.array([[1.0, 2.0], [3.0, 4.0]]) * k
        heard = channel.exchange(t, pos, vel)
        assert not heard.linked.any()
        if k < 2:
            assert np.all(np.isinf(heard.time))
        else:
            assert heard.time[0, 1] == pytest.approx(0.1 * (k - 2))
            assert heard.position[0, 1].tolist() == [0.0, float(k - 2)]
            assert heard.velocity[1, 0].tolist() == [float(k - 2), float(2 * (k - 2))]
            assert np.isinf(heard.time[0, 0])


def test_a_lost_exchange_keeps_the_older_message() -> None:
    """With every exchange lost nothing is heard; with half of them lost, a pair that lost
    this period's exchange keeps the message of the last period it did not lose."""
    pos = np.array([[0.0, 0.0], [1.0, 0.0]])
    dead = Channel(Communication(loss=1.0), 2, 0.1, key=1)
    for k in range(5):
        assert np.all(np.isinf(dead.exchange(0.1 * k, pos, pos).time))
    channel = Channel(Communication(loss=0.5), 2, 0.1, key=2)
    last = -math.inf
    for k in range(40):
        heard = channel.exchange(round(0.1 * k, 10), pos + k, pos)
        if not lost(2, np.array([0]), np.array([1]), k, 0.5)[0]:
            last = round(0.1 * k, 10)
            assert heard.linked[0, 1] and heard.linked[1, 0]
        else:
            assert not heard.linked[0, 1]
        assert heard.time[0, 1] == last


# ---------------------------------------------------------------------- maps and options


def _map(extra: dict) -> dict:
    return {
        "bounds": {"min": [-10, -10], "max": [10, 10]},
        "robots": [{"start": [0, 0], "goal": [5, 0]}, {"start": [0, 3], "goal": [5, 3]}],
        **extra,
    }


@pytest.mark.parametrize(
    ("section", "expected"),
    [
        (False, Communication(range=0.0)),
        ("off", Communication(range=0.0)),
        (True, Communication()),
        ({"range": 5, "latency": 0.1, "loss": 0.25}, Communication(5.0, 0.1, 0.25)),
        ({"range": float("inf")}, Communication()),
        ({"range": None}, Communication()),
        ({"range": ".inf"}, Communication()),
    ],
)
def test_map_communication_section(section: object, expected: Communication) -> None:
    spec = map_from_dict(_map({"communication": section}))
    arena = Arena(spec)
    assert arena.imperfections.communication == expected


@pytest.mark.parametrize(
    ("section", "field"),
    [
        ({"loss": 1.5}, "communication.loss"),
        ({"range": -1}, "communication.range"),
        ({"latency": -0.1}, "communication.latency"),
        ({"range": "far"}, "communication.range"),
        ({"bandwidth": 3}, "communication.bandwidth"),
        ("sometimes", "communication"),
    ],
)
def test_bad_communication_names_the_field(section: object, field: str) -> None:
    with pytest.raises(MapError) as err:
        map_from_dict(_map({"communication": section}))
    assert field in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("communication_loss", 1.5),
        ("communication_range", -2.0),
        ("communication_range", math.nan),
        ("communication_latency", -1.0),
        ("communication_range", True),
    ],
)
def test_bad_communication_option_names_it(option: str, value: object) -> None:
    with pytest.raises(ValueError, match=option):
        Arena(map_from_dict(_map({})), ArenaOptions(**{option: value}))


def test_perfect_communication_changes_nothing() -> None:
    """Explicitly perfect communication (infinite range, no latency, no loss) runs the
    episode of no option bit for bit."""
    spec = load_map("dense_swap_perturbed", n=12, time_limit=8.0)
    a = Arena(spec, ArenaOptions(agent="nao")).run(seed=1)
    b = Arena(
        spec,
        ArenaOptions(
            agent="nao",
            communication_range=math.inf,
            communication_latency=0.0,
            communication_loss=0.0,
        ),
    ).run(seed=1)
    assert a.trajectory_hash == b.trajectory_hash and a.trajectory_hash


def test_plans_are_shared_over_links_only() -> None:
    """A robot's sensed neighbour carries its committed acceleration when the two are
    linked, NaN otherwise (communication off, or out of range)."""
    spec = load_map("dense_swap_perturbed", n=6, time_limit=3.0)
    seen = {}
    for name, reach in (("on", math.inf), ("near", 1e-3), ("off", 0.0)):
        arena = Arena(spec, ArenaOptions(agent="goal", communication_range=reach))
        arena.reset(seed=0)
        arena.step()
        batch = arena._communicated(arena.sensing())
        nb = batch.observation(0).neighbours
        robots = [k for k, kind in enumerate(nb.kinds) if kind == "robot"]
        assert robots
        seen[name] = nb.plans[robots]
    assert np.all(np.isfinite(seen["on"]))
    assert np.all(np.isnan(seen["near"])) and np.all(np.isnan(seen["off"]))


# ---------------------------------------------------------------------- tubes


def _drive(p: np.ndarray, v: np.ndarray, accels: list[np.ndarray], periods: int) -> np.ndarray:
    """Substep positions (one robot) of the world driving ``accels`` for the first periods
    and then the braking rule, for ``periods`` periods in all: a pymunk run."""
    spec = robots_map(p[None], p[None] + 50.0, v[None])
    world = World(spec)
    world.reset()
    out = [world.positions[0].copy()]
    for k in range(periods):
        vel = world.velocities[0]
        if k < len(accels):
            a = accels[k]
        else:
            speed = float(np.hypot(*vel))
            a = -vel * (min(A_MAX, speed / DT) / speed) if speed > 0 else np.zeros(2)
        world.step(a[None])
        out.extend(world.substep_positions[1:, 0])
    return np.array(out)


unit = st.floats(-1.0, 1.0)


@settings(max_examples=80, deadline=None)
@given(
    st.integers(1, 4),
    st.lists(unit, min_size=4, max_size=4),
    st.lists(unit, min_size=8, max_size=8),
    st.lists(unit, min_size=4, max_size=4),
    st.lists(unit, min_size=4, max_size=4),
    st.sampled_from([0.0, 3.0]),
)
def test_a_plan_clear_of_a_tube_is_clear_of_every_path_in_it(
    free: int,
    state: list[float],
    accels: list[float],
    mine: list[float],
    error: list[float],
    sigmas: float,
) -> None:
    """Robot j's state is known (free - 1) periods ago, with an error of at most
    ``sigmas`` standard deviations (0.05 m, 0.1 m/s; none for 0); it then drives any
    accelerations (|a| <= a_max) for ``free`` periods and brakes, in the world. Robot
    i's plan (from now) comes no closer to j's path than tube_clearance says (a lower
    bound)."""
    sigma_p, sigma_v = 0.05, 0.1
    p_j = np.array(state[:2]) * 2.0
    v_j = np.array(state[2:]) * V_MAX / math.sqrt(2)
    acc = [np.array(accels[2 * k : 2 * k + 2]) * A_MAX / math.sqrt(2) for k in range(free)]
    path_j = _drive(p_j, v_j, acc, free + 12)[(free - 1) * SUBSTEPS :]
    # what i knows: the true state off by at most sigmas standard deviations (norms)
    known_p = p_j + np.array(error[:2]) / math.sqrt(2) * sigmas * sigma_p
    known_v = v_j + np.array(error[2:]) / math.sqrt(2) * sigmas * sigma_v
    p_i = p_j + np.array([mine[0], mine[1]]) * 3.0
    v_i = np.array([mine[2], mine[3]]) * V_MAX / math.sqrt(2)
    plan_i = stopping_plan(p_i, v_i, -v_i * 2.0, A_MAX, V_MAX, DT, SUBSTEPS)
    ref = np.empty(((free + 1) * SUBSTEPS + 200, 2))
    n_ref = tube_reference(*known_p, *known_v, free, A_MAX, V_MAX, DT, SUBSTEPS, ref)
    bound = tube_clearance(
        plan_i, len(plan_i), ref, n_ref, float(np.hypot(*known_v)), free, A_MAX, V_MAX, DT,
        SUBSTEPS, Noise(sigma_p, sigma_v, sigmas),
    )  # fmt: skip
    actual = plan_clearance(plan_i, path_j, SUBSTEPS)
    assert actual >= bound - 1e-9


@pytest.mark.parametrize("angle", [0.0, 1.0, 2.5])
def test_the_noise_widens_the_tube_by_its_sigmas(angle: float) -> None:
    """A robot at rest, sensed 3 standard deviations of position (and velocity) noise
    away from where it is, and standing still: the tube grown by 3 sigmas still holds it
    (the clearance it gives a point 1 m from the true position is at most 1 m), and
    without the growth it would not."""
    sigma_p, sigma_v = 0.05, 0.1
    away = np.array([math.cos(angle), math.sin(angle)])
    truth = np.zeros(2)
    known_p = truth - 3 * sigma_p * away  # off, away from the observer
    known_v = -3 * sigma_v * away
    point = (truth + 1.0 * away)[None]  # the observer, standing 1 m away
    ref = np.empty((400, 2))
    n_ref = tube_reference(*known_p, *known_v, 1, A_MAX, V_MAX, DT, SUBSTEPS, ref)
    speed = float(np.hypot(*known_v))

    def clearance(sigmas: float) -> float:
        noise = Noise(sigma_p, sigma_v, sigmas)
        return tube_clearance(point, 1, ref, n_ref, speed, 1, A_MAX, V_MAX, DT, SUBSTEPS, noise)

    assert clearance(3.0) <= 1.0
    assert clearance(0.0) > 1.0


def _knowledge_of(history: list[tuple[np.ndarray, np.ndarray]], age: int, n: int) -> Knowledge:
    """What every robot knows of every other with no link: their exact states ``age``
    periods ago (the oldest kept, at the start)."""
    pos, vel = history[max(len(history) - 1 - age, 0)]
    free = np.full((n, n), min(age, len(history) - 1) + 1, dtype=np.int64)
    np.fill_diagonal(free, 0)
    return Knowledge(
        np.zeros((n, n), dtype=np.bool_),
        np.broadcast_to(pos, (n, n, 2)).copy(),
        np.broadcast_to(vel, (n, n, 2)).copy(),
        free,
        np.zeros((n, n, 2)),
        3.0,
    )


def _unlinked_goal_seekers(spec, age: int, periods: int, forget: bool) -> float:
    """Smallest centre distance (m) in the world over an episode of goal seekers that run
    the rule knowing each other's exact states ``age`` periods old, with no link (or, with
    ``forget``, knowing nothing of each other)."""
    world = World(spec)
    world.reset()
    goals = np.array([r.goal for r in spec.robots], float)
    n = len(goals)
    ones = np.ones(n)
    history = [(world.positions.copy(), world.velocities.copy())]
    closest = math.inf
    for _ in range(periods):
        pos, vel = history[-1]
        to_goal = goals - pos
        dist = np.hypot(*to_goal.T)
        speed = np.minimum(V_MAX, np.sqrt(A_MAX * dist))
        desired = (to_goal / np.maximum(dist, 1e-9)[:, None] * speed[:, None] - vel) / 0.3
        know = _knowledge_of(history, age, n)
        if forget:
            know = know._replace(free=np.zeros_like(know.free))
        brake, braking = commit_plans(
            pos, vel, desired, RADIUS * ones, A_MAX * ones, V_MAX * ones, DT, SUBSTEPS, 0.005,
            know=know,
        )  # fmt: skip
        world.step(np.where(brake[:, None], braking, desired))
        closest = min(closest, float(np.min(min_gaps(world.substep_positions))))
        history.append((world.positions.copy(), world.velocities.copy()))
    return closest


@pytest.mark.parametrize("age", [0, 1, 3])
def test_unlinked_robots_never_touch_in_the_world(age: int) -> None:
    """Eight goal seekers swap across a circle with no communication, each knowing the
    others' states ``age`` periods old: knowing nothing they collide; with the tubes no
    two centres come within 2 r in the world, and they still get going."""
    ang = 2 * np.pi * np.arange(8) / 8
    starts = 4.0 * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    spec = robots_map(starts, -starts)
    assert _unlinked_goal_seekers(spec, age, 80, forget=True) < 2 * RADIUS - 0.01
    assert _unlinked_goal_seekers(spec, age, 150, forget=False) >= 2 * RADIUS


def test_short_sighted_nao_robots_without_communication_never_touch() -> None:
    """The short-sighted swap of test_stopping (avoidance that cannot keep 30 robots apart
    on its own), with communication off and 0.1 s of sensing latency: the stopping plans
    keep every pair apart through the tubes alone."""
    options = ArenaOptions(
        agent_options={"horizon": 0.3, "margin": 0.0},
        communication_range=0.0,
        sensing_latency=0.1,
    )
    arena = Arena(load_map("dense_swap_perturbed", n=30, time_limit=60.0), options)
    summary = arena.run(seed=0)
    assert summary.contacts == []
