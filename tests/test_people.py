"""Robots among people: bodies of kind "person" (driven by their own agents, reported
apart), CrowdNav's scenes, and the social-navigation metrics checked against an
independent computation (dense sampling of the straight substep motion)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import nao_arena
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map, map_from_dict
from nao_arena.stats.people import PeopleMetrics, union_length

# --------------------------------------------------------------------------- metrics


def _sampled(path: np.ndarray, robot: int, people: list[int], radii, distance: float, dt: float):
    """(min gap m, discomfort time s) of ``robot`` by sampling each substep densely."""
    samples = 4001
    s = np.linspace(0.0, 1.0, samples)
    closest, near = math.inf, 0.0
    h = dt / (len(path) - 1)
    for k in range(len(path) - 1):
        own = path[k, robot] + s[:, None] * (path[k + 1, robot] - path[k, robot])
        gaps = []
        for p in people:
            other = path[k, p] + s[:, None] * (path[k + 1, p] - path[k, p])
            gaps.append(np.hypot(*(other - own).T) - radii[robot] - radii[p])
        gap = np.min(gaps, axis=0)
        closest = min(closest, float(gap.min()))
        # the share of samples below the threshold (a Riemann sum of the indicator)
        near += h * float(np.mean(gap < distance))
    return closest, near


coords = st.floats(-3.0, 3.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.lists(st.tuples(coords, coords), min_size=4, max_size=4), min_size=3, max_size=6),
    st.floats(0.05, 0.5),
)
def test_metrics_match_a_dense_sampling_of_the_substeps(rows, distance):
    path = np.array(rows, dtype=float)  # (S + 1, 4 bodies, 2)
    radii = np.array([0.3, 0.25, 0.35, 0.3])
    dt = 0.1
    metrics = PeopleMetrics(np.array([0, 1]), np.array([2, 3]), radii, distance, dt)
    metrics.update(path)
    for body in (0, 1):
        closest, near = _sampled(path, body, [2, 3], radii, distance, dt)
        got_closest, got_near = metrics.of_body(body)
        # sampling finds a gap at most one sample step's motion above the exact minimum
        assert got_closest <= closest + 1e-12
        assert got_closest >= closest - 3 * 6.0 * math.sqrt(2) / 4000
        # each of at most four interval ends per substep is off by at most one sample
        assert got_near == pytest.approx(near, abs=dt / (len(path) - 1) * 4 / 4000 * 2)


def test_union_length_counts_overlaps_once():
    lo = np.array([[0.1, 0.2, 0.8, 0.5], [0.0, 0.0, 1.0, 0.3]])
    hi = np.array([[0.4, 0.3, 0.9, 0.4], [1.0, 0.5, 1.0, 0.1]])
    # row 0: [0.1, 0.4] holds [0.2, 0.3]; [0.8, 0.9]; [0.5, 0.4] is empty
    np.testing.assert_allclose(union_length(lo, hi), [0.4, 1.0])


# --------------------------------------------------------------------------- people in maps


def _walker_map(robot_agent: str = "goal", robot_goal=(0.0, 0.0), sees: bool = False) -> dict:
    return {
        "name": "walker",
        "bounds": {"min": [-6, -6], "max": [6, 6]},
        "robots": [
            {
                "name": "walker",
                "kind": "person",
                "start": [-4.0, 0.0],
                "goal": [4.0, 0.0],
                "agent": "social_force",
                "agent_options": {"sees_robots": sees, "v_pref": 1.0},
            },
            {"name": "still", "start": [0.0, 0.0], "goal": list(robot_goal), "agent": robot_agent},
        ],
        "episode": {"time_limit": 8.0},
    }


def test_people_come_after_the_robots_and_keep_their_agents():
    spec = map_from_dict(_walker_map())
    assert [r.name for r in spec.robots] == ["still", "walker"]
    assert [b.kind for b in spec.bodies()] == ["robot", "person"]
    assert (spec.n_robots, spec.n_people) == (1, 1)
    arena = Arena(spec, ArenaOptions(agent="nao", agent_options={"horizon": 2.0}))
    arena.reset(0)
    assert [type(a).__name__ for a in arena.agents] == ["NAOAgent", "SocialForceAgent"]
    assert arena.labels_with("mine") == ["mine", "social_force"]
    summary = arena.run(0)
    assert [r.name for r in summary.robots] == ["still"]  # people are not reported as robots


def test_a_person_walking_into_a_standing_robot_is_not_the_robots_doing():
    arena = Arena(map_from_dict(_walker_map()))
    summary = arena.run(0)
    (robot,) = summary.robots
    (contact,) = [c for c in summary.contacts if {c.kind_a, c.kind_b} == {"robot", "person"}]
    assert contact.speed_a == 0.0 and contact.speed_b > 0.9  # a: the robot, standing
    assert (robot.person_contacts, robot.caused_person_contacts) == (1, 0)
    assert robot.min_person_distance < 0.0
    assert robot.discomfort_time > 0.0


def test_a_moving_robot_that_walks_into_a_person_caused_it():
    data = _walker_map(robot_agent="goal", robot_goal=(-4.0, 0.0))
    data["robots"][0].update(start=[-3.0, 0.0], goal=[-3.0, 0.0])  # the person stands
    summary = Arena(map_from_dict(data)).run(0)
    (robot,) = summary.robots
    assert robot.person_contacts >= 1 and robot.caused_person_contacts >= 1


def test_without_people_the_social_fields_keep_their_defaults():
    (robot, *_) = Arena(load_map("crossing", n=2)).run(0).robots
    assert not robot.among_people and robot.person_contacts == 0
    assert math.isnan(robot.min_person_distance)
    assert robot.discomfort_time == 0.0


def test_the_env_controls_only_the_robots():
    env = nao_arena.parallel_env("crowdnav_circle")
    assert env.possible_agents == ["robot"]
    obs, _ = env.reset(seed=0)
    layout = nao_arena.environment.observation_layout(env.options)
    rows = obs["robot"][layout["neighbours"]].reshape(-1, 9)
    present = rows[rows[:, 0] == 1.0]
    assert len(present) and np.all(present[:, 8] == 1.0)  # people: is_traffic 1


# --------------------------------------------------------------------------- CrowdNav scenes


@pytest.mark.parametrize("name", ["crowdnav_circle", "crowdnav_square"])
def test_crowdnav_scenes_place_people_clear_of_the_robot_and_each_other(name):
    for seed in range(5):
        spec = load_map(name, seed=seed, n=10)
        people = spec.robots[spec.n_robots :]
        assert len(people) == 10 and all(p.kind == "person" for p in people)
        starts = np.array([p.start for p in people])
        goals = np.array([p.goal for p in people])
        for pts in (starts, goals):
            d = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
            assert d[~np.eye(len(pts), dtype=bool)].min() >= 0.8 - 1e-9
            for q in ((0.0, -4.0), (0.0, 4.0)):
                assert np.hypot(*(pts - q).T).min() >= 0.8 - 1e-9
        if name == "crowdnav_circle":
            np.testing.assert_allclose(goals, -starts)  # through the centre
            assert np.all(np.abs(np.hypot(*starts.T) - 4.0) <= 0.5 * math.sqrt(2) + 1e-9)
        else:
            assert np.all(np.sign(starts[:, 0]) == -np.sign(goals[:, 0]))
            assert np.all(np.abs(starts) <= 5.0) and np.all(np.abs(goals) <= 5.0)
    assert load_map(name, seed=1).robots != load_map(name, seed=2).robots


def test_invisible_robot_people_ignore_it_visible_people_avoid_it():
    def people_paths(sees: bool) -> np.ndarray:
        arena = Arena(load_map("crowdnav_circle", seed=0, people_see_robot=sees))
        arena.reset(0)
        out = []
        for _ in range(60):
            out.append(arena.step().state.positions[1:].copy())
        return np.array(out)

    blind, seeing = people_paths(False), people_paths(True)
    assert not np.array_equal(blind, seeing)


# --------------------------------------------------------------------------- ORCA people


def _pair(kind_a: str, kind_b: str, sees: bool = True, agent: str = "orca") -> dict:
    """Two bodies walking head-on (slightly offset), both driven by ``agent``."""

    def body(name, kind, start, goal):
        return {
            "name": name,
            "kind": kind,
            "start": start,
            "goal": goal,
            "agent": agent,
            "agent_options": {"sees_robots": sees},
        }

    return {
        "name": "pair",
        "bounds": {"min": [-6, -6], "max": [6, 6]},
        "robots": [
            body("a", kind_a, [-4.0, 0.0], [4.0, 0.0]),
            body("b", kind_b, [4.0, 0.05], [-4.0, 0.05]),
        ],
        "episode": {"time_limit": 10.0},
    }


def _positions(data: dict, steps: int = 80) -> np.ndarray:
    arena = Arena(map_from_dict(data))
    arena.reset(0)
    return np.array([arena.step().state.positions.copy() for _ in range(steps)])


def test_orca_people_share_the_avoidance_as_robots_do():
    # the reciprocal rule among people is the robots' rule among robots, to the bit
    people = _positions(_pair("person", "person"))
    robots = _positions(_pair("robot", "robot"))
    np.testing.assert_array_equal(people, robots)
    # a robot counts a person as a body that does not cooperate: it takes all of it
    mixed = _positions(_pair("robot", "person"))
    assert not np.array_equal(mixed, robots)


def test_orca_people_that_do_not_see_robots_walk_as_if_alone():
    blind = _positions(_pair("robot", "person", sees=False))
    alone = _pair("robot", "person", sees=False)
    alone["robots"][0].update(start=[-4.0, 5.0], goal=[-4.0, 5.0])  # the robot out of the way
    walker = _positions(alone)[:, 1]
    # until the robot's own avoidance pushes it, the person walks as if it were alone
    far = np.hypot(*(blind[:, 0] - blind[:, 1]).T) > 2.0
    np.testing.assert_array_equal(blind[far, 1], walker[far])


def test_orca_act_and_act_batch_agree_for_people_and_robots():
    spec = load_map("crowdnav_circle", people_agent="orca", n=6, seed=2)
    for sees in (False, True):
        spec = load_map("crowdnav_circle", people_agent="orca", n=6, seed=2, people_see_robot=sees)
        arena = Arena(spec, ArenaOptions(agent="orca"))
        arena.reset(0)
        for _ in range(40):
            batch = arena.sensing()
            rows = list(range(len(arena.agents)))
            together = type(arena.agents[0]).act_batch(arena.agents, batch, rows)
            alone = np.array([ag.act(batch.observation(k)) for k, ag in enumerate(arena.agents)])
            np.testing.assert_array_equal(together, alone)
            arena.step()


# --------------------------------------------------------------------------- trials and report


def test_trial_tables_and_the_report_show_the_robots_among_people(tmp_path, capsys):
    from nao_arena.cli import main
    from nao_arena.report import PEOPLE_DISTANCE_FILE, PEOPLE_FILE

    out = tmp_path / "people"
    args = ["--map", "crowdnav_circle", "--agent", "goal", "--episodes", "3", "--out", str(out)]
    assert main(["trial", *args, "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "among people:" in printed and "robot-caused" in printed
    assert main(["report", str(out)]) == 0
    assert "among people:" in capsys.readouterr().out
    for name in (PEOPLE_FILE, PEOPLE_DISTANCE_FILE):
        png = out / name
        assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # without people, no such table and no such plot
    plain = tmp_path / "plain"
    assert (
        main(
            [
                "trial",
                "--map",
                "crossing",
                "--agent",
                "goal",
                "--episodes",
                "1",
                "--out",
                str(plain),
                "--quiet",
                "--set",
                "n=1",
            ]
        )
        == 0
    )
    assert "among people:" not in capsys.readouterr().out
    assert main(["report", str(plain)]) == 0
    assert not (plain / PEOPLE_FILE).exists() and not (plain / PEOPLE_DISTANCE_FILE).exists()
