"""Evidence that the NAO agents keep robots apart, in the full arena (pymunk physics).

Each scenario runs 20 seeds: the seed drives the map's randomness (start
perturbations, traffic phases) and the agents' generators. The baselines run
on the same seeds and must collide, so the scenarios are able to fail.
Measured when last changed (one core): every seed of circle_swap_perturbed ends
with all 10 NAO robots at their goals at once within 22.1 s, crossing (12) within
33.4 s; roundabout adjustments per episode 64 (known path), 69 (turn rate), AO 94.
"""

from __future__ import annotations

import numpy as np
import pytest

from nao_arena.agents.nao import NAOAgent
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.trials import make_map

SEEDS = range(20)


def run(map_name: str, seed: int, options: ArenaOptions | None = None, **params):
    arena = Arena(make_map(map_name, seed, params), options)  # seeds the map if it has a seed
    summary = arena.run(seed=seed).to_dict()
    robots = summary["robots"]
    return {
        "collisions": sum(r["collisions"] for r in robots),
        "arrived": sum(bool(r["reached_goal"]) for r in robots),
        "robots": len(robots),
        "adjustments": sum(r["adjustments"] for r in robots),
        "time": arena.time,
        "time_limit": arena.spec.episode.time_limit,
    }


@pytest.mark.slow
@pytest.mark.parametrize("map_name", ["circle_swap_perturbed", "crossing"])
def test_nao_robots_never_collide_and_all_arrive(map_name):
    results = [run(map_name, seed) for seed in SEEDS]
    assert [r["collisions"] for r in results] == [0] * len(SEEDS)
    for r in results:
        assert r["arrived"] == r["robots"], r
        assert r["time"] < r["time_limit"], r


@pytest.mark.slow
@pytest.mark.parametrize("map_name", ["circle_swap_perturbed", "crossing"])
def test_goal_seeking_without_avoidance_collides_on_the_same_seeds(map_name):
    collided = [run(map_name, seed, agent="goal")["collisions"] > 0 for seed in SEEDS]
    assert all(collided)


@pytest.mark.slow
@pytest.mark.parametrize("predictor", ["known_path", "turn_rate"])
def test_nao_crosses_the_roundabout_without_collision(predictor):
    results = [run("roundabout", seed, predictor=predictor) for seed in SEEDS]
    collisions = [r["collisions"] for r in results]
    # with turn-rate predictions the two robots touched once (seed 16: 3.2 mm deep at
    # 1.03 m/s, inside one control step) before they shared stopping plans; now neither
    # predictor lets them touch (tests/test_explain.py replays that touch without plans)
    assert collisions == [0] * len(SEEDS)
    assert all(r["arrived"] == r["robots"] for r in results)
    # the same scenes are dangerous: driving straight at the goal collides
    goal = [run("roundabout", seed, agent="goal")["collisions"] > 0 for seed in SEEDS]
    assert sum(goal) >= 15


OPEN_LOOP = ArenaOptions(
    sensing_range=120.0,
    known_path_horizon=20.0,
    known_path_samples=201,
    agent_options={"replan": False, "horizon": 20.0, "samples": 201, "sensing_range": 120.0},
)


@pytest.mark.slow
def test_one_constant_acceleration_crosses_the_roundabout_with_nao_not_with_ao():
    """The paper's claim: one acceleration chosen outside the NAOs (known circular
    paths) crosses 30 circling vehicles; chosen outside the AOs it collides."""
    nao = [run("roundabout_crossing", seed, OPEN_LOOP)["collisions"] for seed in SEEDS]
    ao = [run("roundabout_crossing", seed, OPEN_LOOP, agent="ao")["collisions"] for seed in SEEDS]
    assert nao == [0] * len(SEEDS)
    assert sum(c > 0 for c in ao) >= 10


@pytest.mark.slow
def test_nao_adjusts_its_acceleration_less_often_than_ao_in_the_roundabout():
    """The paper's second claim, with re-planning every control step: both stay
    collision-free here, NAO with fewer acceleration adjustments."""
    nao = [run("roundabout", seed)["adjustments"] for seed in SEEDS]
    ao = [run("roundabout", seed, agent="ao")["adjustments"] for seed in SEEDS]
    assert np.mean(nao) < np.mean(ao)


@pytest.mark.slow
@pytest.mark.parametrize("n", [4, 6, 10, 30])
def test_symmetric_swaps_neither_collide_nor_deadlock(n):
    """Exactly symmetric circle swaps (no perturbation): every robot aims through the
    centre at once, the stand-off that deadlocks reciprocal velocity methods."""
    radius = max(8.0, 0.35 * n)
    for seed in range(3):
        r = run("circle_swap", seed, n=n, radius=radius, lo=-radius - 4, hi=radius + 4)
        assert r["collisions"] == 0, r
        assert r["arrived"] == r["robots"] and r["time"] < r["time_limit"], r


def test_infeasible_option_is_checked():
    with pytest.raises(ValueError, match="auto"):
        NAOAgent(infeasible="pray")
