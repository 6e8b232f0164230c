"""Contact episodes (swept, exact), near misses, per-robot metrics and their files."""

from __future__ import annotations

import csv
import json
from itertools import combinations
from pathlib import Path

import numpy as np
import pytest

from nao_arena.maps import map_from_dict
from nao_arena.stats import (
    EpisodeStats,
    StatsConfig,
    segment_distances,
    sweep_pairs,
    swept_disc_distances,
)
from nao_arena.world import World


def two(radius: float = 0.5, **kw) -> EpisodeStats:
    return EpisodeStats([radius, radius], ["robot", "robot"], ["a", "b"], dt=0.1, **kw)


def feed(stats: EpisodeStats, path: np.ndarray, accels: np.ndarray | None = None,
         goal: np.ndarray | None = None) -> list:
    """Feed positions path (T, N, 2) sampled every dt; velocities from differences."""
    dt = stats.dt
    events = []
    n = path.shape[1]
    for k in range(len(path) - 1):
        vel = (path[k + 1] - path[k]) / dt
        acc = np.zeros((n, 2)) if accels is None else accels[k]
        reached = np.zeros(n, bool) if goal is None else goal[k]
        events += stats.update(k * dt, path[k], path[k + 1], vel, acc, reached)
    return events


# ---------------------------------------------------------------- geometry


def test_swept_disc_distance_against_sampling() -> None:
    rng = np.random.default_rng(0)
    d0, d1 = rng.normal(size=(300, 2)) * 3, rng.normal(size=(300, 2)) * 3
    dmin, t = swept_disc_distances(d0, d1)
    ts = np.linspace(0, 1, 20001)
    dense = np.min(np.hypot(*(d0[:, None] + (d1 - d0)[:, None] * ts[None, :, None]).T), axis=0)
    assert np.all(dmin <= dense + 1e-12)
    np.testing.assert_allclose(dmin, dense, atol=1e-6)
    assert np.all((t >= 0) & (t <= 1))


def test_segment_distance_against_sampling() -> None:
    rng = np.random.default_rng(1)
    p0, p1, a, b = (rng.normal(size=(300, 2)) * 2 for _ in range(4))
    d = segment_distances(p0, p1, a, b)
    u = np.linspace(0, 1, 20001)
    path = p0[:, None] + (p1 - p0)[:, None] * u[None, :, None]  # (K, U, 2)
    ab = (b - a)[:, None]
    t = np.clip(np.sum((path - a[:, None]) * ab, -1) / np.sum(ab * ab, -1), 0, 1)
    off = path - a[:, None] - t[..., None] * ab
    dense = np.min(np.hypot(off[..., 0], off[..., 1]), axis=1)
    assert np.all(d <= dense + 1e-12)
    np.testing.assert_allclose(d, dense, atol=1e-3)
    # a crossing has distance 0
    assert segment_distances(np.array([[0.0, -1.0]]), np.array([[0.0, 1.0]]),
                             np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]]))[0] == 0.0


def test_sweep_pairs_equals_brute_force() -> None:
    rng = np.random.default_rng(2)
    for n in (0, 1, 2, 50, 400):
        lo = rng.uniform(0, 50, size=(n, 2))
        hi = lo + rng.uniform(0, 4, size=(n, 2))
        i, j = sweep_pairs(lo, hi)
        got = sorted(zip(i.tolist(), j.tolist(), strict=True))
        want = sorted(
            (a, b) for a, b in combinations(range(n), 2)
            if np.all(lo[a] <= hi[b]) and np.all(lo[b] <= hi[a])
        )
        assert got == want
        assert np.all(i < j) if n else True


# ---------------------------------------------------------------- contact episodes


def test_tunneling_head_on_at_100_m_s_is_recorded() -> None:
    stats = two()
    path = np.array([[[-5.0 + 10.0 * k, 0.2], [5.0 - 10.0 * k, 0.0]] for k in range(4)])
    centres = np.hypot(*(path[:, 0] - path[:, 1]).T)
    assert np.all(centres > 1.0)  # never overlapping at a step boundary
    events = feed(stats, path)
    assert len(events) == 1 and len(stats.contacts) == 1
    ev = events[0]
    assert (ev.a, ev.b, ev.kind_a, ev.kind_b) == (0, 1, "robot", "robot")
    assert 0.0 < ev.time < 0.1
    assert ev.impact_speed > 150.0  # ~200 m/s closing along a near head-on normal
    assert ev.max_penetration == pytest.approx(0.8)
    assert ev.end_time == pytest.approx(0.1)
    s = stats.summary()
    assert [r.collisions for r in s.robots] == [1, 1]
    assert not any(r.success for r in s.robots)


def test_contact_time_and_impact_speed() -> None:
    stats = two()
    # b at rest, a approaches at 2 m/s: touches when the centres are 1 m apart
    path = np.array([[[-2.0 + 0.2 * k, 0.0], [0.0, 0.0]] for k in range(8)])
    events = feed(stats, path)
    assert len(events) == 1
    assert events[0].time == pytest.approx(0.5)
    assert events[0].impact_speed == pytest.approx(2.0)


def test_one_event_per_contact_episode_with_hysteresis() -> None:
    stats = two(config=StatsConfig(hysteresis=0.01))
    gaps = [0.5, 0.2, -0.05, -0.1, 0.004, -0.002, 0.008, -0.03, 0.3, 0.6, -0.01, 0.5]
    path = np.array([[[0.0, 0.0], [1.0 + g, 0.0]] for g in gaps])
    events = feed(stats, path)
    # first episode: from -0.05 through the jitter below the hysteresis up to 0.3
    # second episode: the touch at -0.01
    assert len(events) == 2
    assert stats.contacts[0].max_penetration == pytest.approx(0.1)
    assert stats.contacts[0].end_time == pytest.approx(0.8)
    assert stats.contacts[1].max_penetration == pytest.approx(0.01)


def test_resting_contact_in_the_world_is_one_episode() -> None:
    spec = map_from_dict({
        "bounds": {"min": [-10, -10], "max": [10, 10]},
        "robots": [
            {"start": [-1.0, 0.0], "goal": [5, 0], "radius": 0.5},
            {"start": [1.0, 0.0], "goal": [-5, 0], "radius": 0.5},
        ],
        "physics": {"elasticity": 0.0},
    })
    world = World(spec)
    stats = EpisodeStats(world.radii, world.kinds, world.names, dt=world.dt)
    push = np.array([[2.0, 0.0], [-2.0, 0.0]])
    state = world.state()
    for k in range(80):
        cmd = push if k < 50 else -push  # pushing for 5 s, then backing away
        new = world.step(cmd)
        stats.update(state.time, state.positions, new.positions, new.velocities, cmd,
                     np.zeros(2, bool))
        state = new
    assert len(stats.contacts) == 1
    assert np.isfinite(stats.contacts[0].end_time)
    assert stats.contacts[0].max_penetration < 0.05


def test_swept_wall_contact() -> None:
    walls = (np.array([[[0.0, -5.0], [0.0, 5.0]]]), np.array([0.05]))
    stats = EpisodeStats([0.3], ["robot"], ["r"], walls=walls, dt=0.1)
    # through the thin wall in one step, never touching at step boundaries
    path = np.array([[[-1.0, 0.0]], [[1.0, 0.5]], [[3.0, 1.0]]])
    events = feed(stats, path)
    assert len(events) == 1
    ev = events[0]
    assert (ev.kind_a, ev.kind_b, ev.b, ev.name_b) == ("robot", "wall", 0, "wall0")
    assert ev.impact_speed == pytest.approx(20.0, rel=1e-6)
    assert ev.time == pytest.approx(0.1 * (1.0 - 0.35) / 2.0, rel=1e-6)
    s = stats.summary().robots[0]
    assert s.collisions == 1 and s.wall_collisions == 1
    # moving along the wall at 0.4 m from its surface: nothing
    quiet = EpisodeStats([0.3], ["robot"], walls=walls, dt=0.1)
    feed(quiet, np.array([[[-0.75, -4.0 + k]] for k in range(8)]))
    assert quiet.contacts == []


def test_traffic_and_kinds_are_reported() -> None:
    stats = EpisodeStats([0.5, 1.0], ["robot", "traffic"], ["r", "car"], dt=0.1)
    path = np.array([[[0.0, 0.0], [3.0 - 0.5 * k, 0.0]] for k in range(5)])
    events = feed(stats, path)
    assert [(e.kind_a, e.kind_b, e.name_b) for e in events] == [("robot", "traffic", "car")]
    assert len(stats.summary().robots) == 1  # rows for robots only


# ---------------------------------------------------------------- near misses, TTC


@pytest.mark.parametrize(("offset", "near"), [(1.1, 1), (1.3, 0), (0.9, 0)])
def test_near_misses_count_close_passes_without_contact(offset: float, near: int) -> None:
    stats = two()
    path = np.array([[[-3.0 + 0.25 * k, 0.0], [3.0 - 0.25 * k, offset]] for k in range(25)])
    feed(stats, path)
    rows = stats.summary().robots
    assert [r.near_misses for r in rows] == [near, near]
    assert rows[0].min_separation == pytest.approx(offset - 1.0)
    assert rows[0].collisions == (1 if offset < 1.0 else 0)


def test_near_miss_open_at_the_end_is_counted() -> None:
    stats = two()
    feed(stats, np.array([[[0.0, 0.0], [1.5 - 0.2 * k, 0.0]] for k in range(3)]))
    assert [r.near_misses for r in stats.summary().robots] == [1, 1]


def test_min_separation_far_is_inf() -> None:
    stats = two()
    feed(stats, np.array([[[0.0, 0.0], [50.0, 0.0]]] * 3))
    assert stats.summary().robots[0].min_separation == np.inf


def test_time_to_collision_head_on() -> None:
    stats = two()
    p0 = np.array([[-5.5, 0.0], [5.5, 0.0]])
    p1 = np.array([[-5.0, 0.0], [5.0, 0.0]])
    v = np.array([[1.0, 0.0], [-1.0, 0.0]])
    stats.update(0.0, p0, p1, v, np.zeros((2, 2)), np.zeros(2, bool))
    # centres 10 m apart closing at 2 m/s, contact at 9 m: 4.5 s
    assert stats.summary().robots[0].min_ttc == pytest.approx(4.5)
    stats2 = two(config=StatsConfig(ttc_horizon=3.0))
    stats2.update(0.0, p0, p1, v, np.zeros((2, 2)), np.zeros(2, bool))
    assert stats2.summary().robots[0].min_ttc == np.inf


# ---------------------------------------------------------------- per-robot metrics


def test_goal_path_length_and_adjustments() -> None:
    stats = EpisodeStats([0.3], ["robot"], ["r"], dt=0.1,
                         config=StatsConfig(adjustment_threshold=0.1))
    path = np.array([[[0.1 * k, 0.0]] for k in range(21)])
    acc = np.zeros((20, 1, 2))
    acc[3:6, 0, 0] = 1.0  # change up at step 3, down at step 6
    acc[8, 0, 1] = 0.05  # below the threshold: not an adjustment
    goal = np.zeros((20, 1), bool)
    goal[9:] = True  # reached at the end of step 9 (t = 1.0 s)
    feed(stats, path, acc, goal)
    row = stats.summary().robots[0]
    assert row.reached_goal and row.success
    assert row.time_to_goal == pytest.approx(1.0)
    assert row.path_length == pytest.approx(1.0)
    assert row.adjustments == 2
    assert row.adjustment_rate == pytest.approx(2.0)


def test_faults_are_recorded() -> None:
    stats = two()
    stats.record_fault(0.3, 1, "returned NaN")
    assert stats.summary().faults[0].to_dict() == {
        "time": 0.3, "robot": 1, "name": "b", "message": "returned NaN",
    }


# ---------------------------------------------------------------- serialization


def test_summary_serialization_and_atomic_files(tmp_path: Path) -> None:
    stats = two()
    feed(stats, np.array([[[-5.0 + 10.0 * k, 0.2], [5.0 - 10.0 * k, 0.0]] for k in range(3)]))
    summary = stats.summary()
    data = json.loads(summary.to_json())
    assert data["steps"] == 2 and len(data["contacts"]) == 1
    assert data["robots"][0]["time_to_goal"] is None  # NaN -> null
    out = tmp_path / "sub" / "summary.json"
    summary.write_json(out)
    assert json.loads(out.read_text()) == data
    summary.write_csv(tmp_path / "robots.csv", tmp_path / "contacts.csv")
    rows = list(csv.DictReader((tmp_path / "robots.csv").open()))
    assert [r["name"] for r in rows] == ["a", "b"] and rows[0]["collisions"] == "1"
    contacts = list(csv.DictReader((tmp_path / "contacts.csv").open()))
    assert contacts[0]["kind_b"] == "robot"
    leftovers = [p.name for p in tmp_path.rglob("*.tmp")]
    assert leftovers == []


def test_config_is_checked() -> None:
    with pytest.raises(ValueError, match="separation_range"):
        StatsConfig(near_miss_distance=2.0, separation_range=1.0)


def test_broad_phase_scales() -> None:
    """3000 spread bodies: candidate pairs stay few (no all-pairs loop)."""
    rng = np.random.default_rng(3)
    n = 3000
    p = rng.uniform(0, 1000, size=(n, 2))
    stats = EpisodeStats(np.full(n, 0.3), ["robot"] * n, dt=0.1)
    stats.update(0.0, p, p + 0.1, np.ones((n, 2)), np.zeros((n, 2)), np.zeros(n, bool))
    lo = np.minimum(p, p + 0.1) - 0.8
    i, _ = sweep_pairs(lo, lo + 1.7)
    assert len(i) < 50 * n // 100


def test_first_wall_touch_time_against_sampling() -> None:
    from nao_arena.stats import _first_wall_touch  # the closed form, checked directly

    rng = np.random.default_rng(4)
    ts = np.linspace(0.0, 1.0, 20001)
    checked = 0
    for _ in range(300):
        p0, p1, a, b = (rng.normal(size=2) * 2 for _ in range(4))
        reach = 0.3
        path = p0 + (p1 - p0) * ts[:, None]
        ab = b - a
        u = np.clip((path - a) @ ab / (ab @ ab), 0, 1)
        dist = np.hypot(*(path - a - u[:, None] * ab).T)
        inside = np.flatnonzero(dist <= reach)
        if len(inside) == 0:
            continue
        t, nrm = _first_wall_touch(p0, p1, a, b, reach)
        assert abs(t - ts[inside[0]]) < 1e-4
        assert np.hypot(*nrm) == pytest.approx(1.0)
        checked += 1
    assert checked > 30
