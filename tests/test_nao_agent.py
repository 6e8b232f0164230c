"""The NAO agent's rules, one robot at a time (``act``): holding and repairing an
avoidance adjustment, what it does when nothing is admissible, neighbours already
inside the margin, escalating detours. (``act_batch`` is checked against ``act`` in
test_fast_path.py.)"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nao_arena.agents.nao import NAOAgent
from nao_arena.geometry import AccelLimits, repair_acceleration
from nao_arena.sensing import Neighbours, Observation


def observation(pos=(0.0, 0.0), vel=(1.0, 0.0), goal=(10.0, 0.0), nb_pos=(3.0, 0.0),
                nb_vel=(0.0, 0.0), kind="robot", radius=0.3) -> Observation:
    nb = Neighbours(
        ids=np.array([1]), kinds=(kind,), positions=np.array([nb_pos], dtype=float),
        velocities=np.array([nb_vel], dtype=float), accelerations=np.zeros((1, 2)),
        radii=np.array([radius]),
    )
    return Observation(
        time=0.0, dt=0.1, robot_id=0, position=np.array(pos, dtype=float),
        velocity=np.array(vel, dtype=float), acceleration=np.zeros(2), radius=radius,
        a_max=2.0, v_max=1.5, goal=np.array(goal, dtype=float), neighbours=nb,
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
    path = ag.obstacle_paths(obs)
    # just past the boundary, towards the neighbour straight ahead: inadmissible
    bad = next(b for b in (first + s * (np.array([2.0, 0.0]) - first)
                           for s in np.linspace(0.01, 1.0, 100))
               if not ag._admissible(b, obs, path))
    ag.current = bad
    desired = agent().act(observation(nb_pos=(50.0, 50.0)))
    expected = repair_acceleration(ag.current, desired, obs.velocity, path, AccelLimits(2.0),
                                   v_max=1.5)
    assert expected is not None
    got = ag.act(obs)
    np.testing.assert_array_equal(got, expected)
    assert ag.last_selection is sel and ag.age == pytest.approx(0.1)  # not a new selection
    assert ag._admissible(got, obs, path)


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
        ag._detour_step(far=True, crawling=True, dt=0.1)
    assert ag.detour_turns == 1 and -math.pi / 3 <= ag.detour <= -math.pi / 6
    for _ in range(20):  # 3.1 s
        ag._detour_step(far=True, crawling=True, dt=0.1)
    assert ag.detour_turns == 3 and -math.pi <= ag.detour <= -math.pi / 2
    for _ in range(100):
        ag._detour_step(far=True, crawling=True, dt=0.1)
    assert -5 * math.pi / 6 - math.pi / 3 <= ag.detour <= -5 * math.pi / 6  # backing off
    for _ in range(9):  # 0.9 s moving freely
        ag._detour_step(far=True, crawling=False, dt=0.1)
    assert ag.detour != 0.0
    for _ in range(2):  # 1.1 s: moved freely for detour_after
        ag._detour_step(far=True, crawling=False, dt=0.1)
    assert ag.detour == 0.0 and ag.detour_turns == 0
