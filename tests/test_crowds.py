"""Evidence for dense crowds: NAO robots arrive, all at once, stay, and never touch.

The scenes are the RVO2 / AVO2 benchmarks' (maps ``dense_swap``,
``dense_swap_perturbed``, ``crossing_streams``, ``crossing_streams_perturbed``:
disc radius 0.5 m, a_max 2 m/s^2, v_max 1.5 m/s, dt 0.1 s, arrival within
0.1 m). An episode ends only when every robot is within 0.1 m of its goal at
the same time, so a robot pushed off its goal must come back for the episode
to end before its time limit. The ``goal`` agent (no avoidance) must collide
on the same seeds, so the scenes are able to fail.
Measured when last changed: dense_swap_perturbed n = 30 (seeds 0-19) all at
their goals at once by 34.0-41.1 s; crossing_streams_perturbed seeds 0-3 by 45-62 s,
seed 4 (a robot behind the parked row, see below) by 87.6 s.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from nao_arena.arena import Arena
from nao_arena.maps import load_map
from nao_arena.trials import make_map

ALL_AT_GOAL_WITHIN = {
    "dense_swap": 60.0,
    "dense_swap_perturbed": 60.0,
    "crossing_streams": 120.0,
    "crossing_streams_perturbed": 120.0,
}
"""Stated limits (s): every robot within 0.1 m of its goal at the same time by then."""

CASES = [("dense_swap", 10, 0), ("dense_swap", 30, 0)]
CASES += [("dense_swap_perturbed", n, seed) for n in (10, 30) for seed in range(5)]
CASES += [("crossing_streams", 20, 0)]
# seed 4: one northbound robot is carried east by the eastbound stream and ends up behind
# the row of parked eastbound robots (1 m gaps); turning right leads along the row, so it
# arrives only after switching its detours to the left (switch_side_after)
CASES += [("crossing_streams_perturbed", 20, seed) for seed in range(5)]


def _episode(name: str, n: int, seed: int, agent: str = "nao"):
    arena = Arena(
        make_map(name, seed, {"n": n, "agent": agent, "time_limit": ALL_AT_GOAL_WITHIN[name]})
    )
    summary = arena.run(seed=seed)
    return arena, summary


@pytest.mark.slow
@pytest.mark.parametrize(("name", "n", "seed"), CASES)
def test_nao_robots_all_reach_their_goals_at_once_without_contact(name, n, seed):
    arena, summary = _episode(name, n, seed)
    assert list(summary.contacts) == []
    assert arena.time < ALL_AT_GOAL_WITHIN[name]  # ended because all were at their goals
    assert all(r.at_goal_at_end and r.success for r in summary.robots)
    assert all(r.final_goal_distance <= 0.1 for r in summary.robots)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "n", "seed"),
    [
        ("dense_swap", 10, 0),
        ("dense_swap_perturbed", 10, 0),
        ("crossing_streams", 20, 0),
        ("crossing_streams_perturbed", 20, 0),
    ],
)
def test_goal_seeking_without_avoidance_collides_on_the_same_scenes(name, n, seed):
    _, summary = _episode(name, n, seed, agent="goal")
    assert len(summary.contacts) > 0


PARKED = """
name: parked
bounds: {{min: [-10.0, -10.0], max: [10.0, 10.0]}}
robots:
  - {{start: [0.0, 0.0], goal: [0.0, 0.0], radius: 0.5, a_max: 2.0, v_max: 1.5, agent: nao}}
  - {{start: [-6.0, {offset}], goal: [6.0, {offset}], radius: 0.5, a_max: 2.0, v_max: 1.5,
     agent: goal}}
episode: {{time_limit: 40.0, goal_tolerance: 0.1}}
"""


@pytest.mark.parametrize("offset", [0.0, 0.3])
def test_a_parked_robot_yields_to_a_robot_that_does_not_avoid_and_returns(
    tmp_path: Path, offset: float
):
    """Robot 0 sits on its goal, on the straight path of robot 1, which does not avoid:
    robot 0 must leave its goal, let robot 1 pass without contact, and come back."""
    path = tmp_path / "parked.yaml"
    path.write_text(PARKED.format(offset=offset))
    arena = Arena(load_map(path))
    summary = arena.run(seed=0)
    parked, passer = summary.robots
    assert list(summary.contacts) == []
    assert parked.time_away_after_arrival > 0.0  # it yielded
    assert parked.at_goal_at_end and passer.at_goal_at_end  # and came back
    assert arena.time < 40.0


def test_a_parked_robot_with_nothing_around_stays_still(tmp_path: Path):
    """Nothing threatens it: it holds its goal exactly (no chattering around it)."""
    path = tmp_path / "alone.yaml"
    path.write_text("""
name: alone
bounds: {min: [-10.0, -10.0], max: [10.0, 10.0]}
robots:
  - {start: [-3.0, 0.0], goal: [2.0, 1.0], radius: 0.5, a_max: 2.0, v_max: 1.5, agent: nao}
  - {start: [5.0, 5.0], goal: [5.0, 5.0], radius: 0.5, a_max: 2.0, v_max: 1.5, agent: nao}
episode: {time_limit: 30.0, goal_tolerance: 0.1}
""")
    arena = Arena(load_map(path))
    arena.reset(0)
    speeds, offsets = [], []
    while arena.time < 30.0 - 1e-9:
        arena.step()
        if arena.time > 20.0:
            speeds.append(float(abs(arena.state.velocities[0]).max()))
            offsets.append(float(abs(arena.state.positions[0] - arena.goals[0]).max()))
    # settling decays with a time constant of about 1 s (it chattered at 0.1 m/s, 2.5 cm)
    assert max(speeds) < 1e-4 and max(offsets) < 1e-4


def _behind_the_row_map(tmp_path: Path) -> Path:
    """The stuck case of crossing_streams_perturbed seed 4, reduced: a row of 20 parked
    robots along y = 0 (x = 2 .. 40 m, 2 m apart), a column of parked robots along x = 0
    with a free slot at y = 20 m, and one robot south of the row whose goal is that slot."""
    parked = [(float(x), 0.0) for x in range(2, 42, 2)]
    parked += [(0.0, float(y)) for y in range(2, 42, 2) if y != 20]
    robot = "  - {{start: [{0}, {1}], goal: [{2}, {3}], radius: 0.5, a_max: 2.0, v_max: 1.5}}"
    lines = [robot.format(9.4, -1.3, 0.0, 20.0)]
    lines += [robot.format(x, y, x, y) for x, y in parked]
    path = tmp_path / "behind_the_row.yaml"
    path.write_text(
        "name: behind_the_row\nbounds: {min: [-20.0, -20.0], max: [50.0, 50.0]}\n"
        "robots:\n" + "\n".join(lines) + "\nepisode: {time_limit: 150.0, goal_tolerance: 0.1}\n"
    )
    return path


@pytest.mark.slow
def test_a_robot_behind_a_row_of_parked_robots_gets_round_it_by_switching_sides(tmp_path: Path):
    """Detours to the right lead along the row, away from its near end: without switching
    sides the robot is still behind the row after 150 s; with switch_side_after (20 s by
    default, counted while its nearest neighbour stands still) it gets round and parks in
    its slot, without contact."""
    from nao_arena.arena import ArenaOptions

    spec = load_map(_behind_the_row_map(tmp_path))
    stuck = Arena(spec, ArenaOptions(agent_options={"switch_side_after": float("inf")}))
    summary = stuck.run(seed=0)
    assert not summary.robots[0].reached_goal and stuck.time >= 150.0
    arena = Arena(spec)
    summary = arena.run(seed=0)
    assert summary.robots[0].at_goal_at_end and arena.time < 150.0
    assert list(summary.contacts) == []
