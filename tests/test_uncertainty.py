"""Predictions that grow less certain with time: obstacle radii grown with prediction time
(:func:`nao_arena.geometry.grown_with_time`) checked by forward simulation, and the NAO
agent's ``uncertainty_growth`` option that selects against them first."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from forward_sim import Polyline, Robot, turning_walker
from hypothesis import given, settings
from strategies import floats, vec

from nao_arena.agents._nao_per_robot import admissible
from nao_arena.agents.nao import NAOAgent
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.geometry import grown_with_time, sampled_path
from nao_arena.geometry.clearance import UNCERTAINTY_WINDOWS
from nao_arena.maps import load_map, map_from_dict

HORIZON = 3.0
TIMES = np.linspace(0.0, HORIZON, 31)
A_MAX = 2.0


def _window_end(t: float) -> float:
    """The end (s) of the window of :data:`UNCERTAINTY_WINDOWS` that holds time t, on a
    horizon of :data:`HORIZON` s cut every 0.1 s (a piece starting at 0.9 s ends at 1 s)."""
    for w in UNCERTAINTY_WINDOWS:
        if t < w - 1e-9:
            return w
    return HORIZON


@settings(max_examples=150, deadline=None)
@given(
    start=vec(4.0),
    velocity=vec(1.8),
    turn=floats(-0.8, 0.8),
    v=vec(1.0),
    accel=vec(A_MAX / math.sqrt(2.0)),
    growth=floats(0.05, 0.5),
)
def test_an_admissible_acceleration_keeps_each_window_grown_distance(
    start, velocity, turn, v, accel, growth
):
    """Against the grown paths, an admissible acceleration keeps the obstacle at least its
    radius plus growth x the end of the window away at every time, by forward
    simulation of the robot and of the walker."""
    radius = 0.75
    centers = turning_walker(TIMES, start, velocity, turn)
    grown = grown_with_time(sampled_path(TIMES, centers, radius), growth)
    if not admissible(np.asarray(accel), np.asarray(v), A_MAX, math.inf, grown):
        return
    t = np.linspace(0.0, HORIZON, 6001)
    gap = Robot.make(v, accel).position(t) - Polyline.make(TIMES, centers).position(t)
    distance = np.hypot(gap[:, 0], gap[:, 1])
    needed = radius + growth * np.array([_window_end(float(s)) for s in t])
    # between grid points the distance changes by at most the two speeds x half a spacing
    slack = (1.0 + A_MAX * HORIZON + 1.8) * (t[1] - t[0]) / 2
    assert np.all(distance >= needed - slack), float(np.min(distance - needed))


def test_a_pass_clear_as_predicted_is_too_close_once_uncertain():
    """A walker predicted to pass 0.9 m from the standing robot's centre at 1.5 s: clear
    of a combined radius of 0.75 m, but not of 0.75 + 0.3 m/s x 2 s (the window ending
    at 2 s); every copy of the walker outside its window is far away."""
    centers = np.array([[-1.5 + 1.0 * t, 0.9] for t in TIMES])
    path = sampled_path(TIMES, centers, 0.75)
    stand = np.zeros(2)
    assert admissible(stand, stand, A_MAX, math.inf, path)
    grown = grown_with_time(path, 0.3)
    assert not admissible(stand, stand, A_MAX, math.inf, grown)
    assert grown.radius.tolist() == pytest.approx([0.75 + 0.3, 0.75 + 0.6, 0.75 + 0.9])
    starts = grown.t[:-1]
    for copy, (lo, hi) in enumerate([(0.0, 1.0), (1.0, 2.0), (2.0, math.inf)]):
        inside = (starts >= lo) & (starts < hi)
        np.testing.assert_array_equal(grown.c[copy, inside], path.c[0, inside])
        assert np.all(np.abs(grown.c[copy, ~inside]) >= 1.0e4)
    # a robot that steps back out of the way is clear of the grown walker too
    assert admissible(np.array([0.0, -A_MAX]), stand, A_MAX, 1.0, grown)


def test_no_growth_is_the_path_itself_and_a_bad_growth_raises():
    path = sampled_path(TIMES, np.zeros((TIMES.size, 2)), 0.5)
    assert grown_with_time(path, 0.0) is path
    for bad in (-0.1, math.nan, math.inf):
        with pytest.raises(ValueError, match="growth: expected a number >= 0"):
            grown_with_time(path, bad)


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_uncertainty_growth_is_a_number_at_least_0(bad):
    with pytest.raises(ValueError, match="uncertainty_growth: expected a number >= 0"):
        NAOAgent(uncertainty_growth=bad)


def _crossing(growth: float) -> dict:
    """A NAO robot crossing (0, -3) -> (0, 3) m while a person who does not see it walks
    (-3, 0.4) -> (3, 0.4) m at 1 m/s, predicted at constant velocity."""
    return {
        "name": "crossing",
        "bounds": {"min": [-6, -6], "max": [6, 6]},
        "robots": [
            {
                "name": "walker",
                "kind": "person",
                "start": [-3.0, 0.4],
                "goal": [3.0, 0.4],
                "agent": "social_force",
                "agent_options": {"sees_robots": False, "v_pref": 1.0},
            },
            {
                "name": "robot",
                "start": [0.0, -3.0],
                "goal": [0.0, 3.0],
                "agent": "nao",
                "predictor": "constant_velocity",
                "agent_options": {"uncertainty_growth": growth},
            },
        ],
        "episode": {"time_limit": 12.0},
    }


def test_a_nao_robot_unsure_of_its_predictions_keeps_more_room():
    """The same crossing with uncertainty_growth 0 and 0.3 m/s: both arrive. The plain
    robot passes the person at about its margin (0.15 m between the discs); the unsure
    one at least its margin plus 0.3 m/s x 1 s, the growth of the first window."""
    summaries = {g: Arena(map_from_dict(_crossing(g))).run(0) for g in (0.0, 0.3)}
    for summary in summaries.values():
        (robot,) = summary.robots
        assert robot.reached_goal and robot.person_contacts == 0
    plain, unsure = (summaries[g].robots[0].min_person_distance for g in (0.0, 0.3))
    assert 0.15 - 1e-3 <= plain < 0.3 and unsure >= 0.15 + 0.3, (plain, unsure)


def test_nao_robots_unsure_of_each_other_still_never_touch():
    """The selection against grown radii comes before the stopping-plan rule among the
    robots of a batch, which still decides: ten NAO robots swapping places on a circle
    with uncertainty_growth 0.3 m/s all arrive without a contact."""
    options = ArenaOptions(agent="nao", agent_options={"uncertainty_growth": 0.3})
    summary = Arena(load_map("circle_swap"), options).run(0)
    assert len(summary.robots) == 10 and all(r.reached_goal for r in summary.robots)
    assert summary.contacts == []


PEOPLE_MAPS = [
    str(Path(__file__).resolve().parents[1] / "benchmarks" / "people" / f"{name}.yaml")
    for name in ("eth_univ", "eth_hotel", "ucy_zara01")
]


@pytest.mark.parametrize("source", PEOPLE_MAPS)
def test_the_crossing_maps_pass_the_nao_options_on(source):
    spec = load_map(source, uncertainty_growth=0.3, infeasible="stop_in_time")
    (robot,) = spec.robots
    assert robot.agent_options == {
        "margin": 0.15,
        "infeasible": "stop_in_time",
        "uncertainty_growth": 0.3,
    }
    assert robot.agent_options_for == "nao"  # another agent keeps its own options
