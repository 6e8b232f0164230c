"""Contact episodes (swept, exact), near misses, per-robot metrics and their files."""

from __future__ import annotations

import csv
import json
from itertools import combinations
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference.stats_reference import point_segment, segment_distances, swept_disc_distances

from nao_arena.maps import map_from_dict
from nao_arena.stats import EpisodeStats, StatsConfig, sweep_pairs
from nao_arena.stats.events import first_disc_touch, first_wall_touch
from nao_arena.stats.kernel import swept_distances, swept_wall_distances
from nao_arena.world import World


def two(radius: float = 0.5, **kw) -> EpisodeStats:
    return EpisodeStats([radius, radius], ["robot", "robot"], ["a", "b"], dt=0.1, **kw)


def feed(
    stats: EpisodeStats,
    path: np.ndarray,
    accels: np.ndarray | None = None,
    goal: np.ndarray | None = None,
) -> list:
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
    assert (
        segment_distances(
            np.array([[0.0, -1.0]]),
            np.array([[0.0, 1.0]]),
            np.array([[-1.0, 0.0]]),
            np.array([[1.0, 0.0]]),
        )[0]
        == 0.0
    )


@pytest.mark.slow
def test_sweep_pairs_equals_brute_force() -> None:
    rng = np.random.default_rng(2)
    for n in (0, 1, 2, 50, 400):
        lo = rng.uniform(0, 50, size=(n, 2))
        hi = lo + rng.uniform(0, 4, size=(n, 2))
        i, j = sweep_pairs(lo, hi)
        got = sorted(zip(i.tolist(), j.tolist(), strict=True))
        want = sorted(
            (a, b)
            for a, b in combinations(range(n), 2)
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
    spec = map_from_dict(
        {
            "bounds": {"min": [-10, -10], "max": [10, 10]},
            "robots": [
                {"start": [-1.0, 0.0], "goal": [5, 0], "radius": 0.5},
                {"start": [1.0, 0.0], "goal": [-5, 0], "radius": 0.5},
            ],
            "physics": {"elasticity": 0.0},
        }
    )
    world = World(spec)
    stats = EpisodeStats(world.radii, world.kinds, world.names, dt=world.dt)
    push = np.array([[2.0, 0.0], [-2.0, 0.0]])
    state = world.state()
    for k in range(80):
        cmd = push if k < 50 else -push  # pushing for 5 s, then backing away
        new = world.step(cmd)
        stats.update(
            state.time, state.positions, new.positions, new.velocities, cmd, np.zeros(2, bool)
        )
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
    stats = EpisodeStats(
        [0.3], ["robot"], ["r"], dt=0.1, config=StatsConfig(adjustment_threshold=0.1)
    )
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
        "time": 0.3,
        "robot": 1,
        "name": "b",
        "message": "returned NaN",
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
        t, nrm = first_wall_touch(p0, p1, a, b, reach)
        assert abs(t - ts[inside[0]]) < 1e-4
        assert np.hypot(*nrm) == pytest.approx(1.0)
        checked += 1
    assert checked > 30


# ---------------------------------------------------------------- compiled kernel vs numpy


def sweep_pairs_numpy(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sort-and-sweep in numpy (the specification of sweep_pairs, order included)."""
    n = len(lo)
    empty = np.zeros(0, dtype=np.intp)
    if n < 2:
        return empty, empty
    order = np.argsort(lo[:, 0], kind="stable")
    slo, shi = lo[order], hi[order]
    idx = np.arange(n)
    counts = np.searchsorted(slo[:, 0], shi[:, 0], side="right") - idx - 1
    np.maximum(counts, 0, out=counts)
    total = int(counts.sum())
    if total == 0:
        return empty, empty
    first = np.repeat(idx, counts)
    second = np.arange(total) - np.repeat(np.cumsum(counts) - counts - idx - 1, counts)
    keep = (slo[second, 1] <= shi[first, 1]) & (slo[first, 1] <= shi[second, 1])
    a, b = order[first[keep]], order[second[keep]]
    return np.minimum(a, b), np.maximum(a, b)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    substeps=st.integers(1, 12),
    scale=st.sampled_from([1e-3, 1.0, 30.0]),
)
def test_swept_distances_equal_the_numpy_reference(seed: int, substeps: int, scale: float) -> None:
    """The compiled per-substep distances of a new contact's event are the numpy
    reference's bit for bit (paths with repeated points included)."""
    rng = np.random.default_rng(seed)
    path = rng.normal(size=(substeps + 1, 2)) * scale
    path[rng.random(substeps + 1) < 0.2] = path[0]  # standing still in some substeps
    a, b = rng.normal(size=(2, 2)) * scale
    if rng.random() < 0.2:
        b = a.copy()  # a point-like wall
    want = swept_disc_distances(path[:-1], path[1:])[0]
    assert np.array_equal(swept_distances(path), want)
    ends = np.broadcast_to(np.stack([a, b]), (substeps, 2, 2))
    want = segment_distances(path[:-1], path[1:], ends[:, 0], ends[:, 1])
    assert np.array_equal(swept_wall_distances(path, a, b), want)
    column = np.stack([path, -path], axis=1)[:, 0]  # a strided view, as the recorder passes
    assert np.array_equal(swept_wall_distances(column, a, b), want)


def test_sweep_pairs_same_pairs_and_order_as_numpy() -> None:
    rng = np.random.default_rng(5)
    for n in (0, 1, 2, 30, 300):
        lo = rng.uniform(0, 40, size=(n, 2))
        lo[: n // 3, 0] = np.round(lo[: n // 3, 0])  # ties in the sort key
        hi = lo + rng.uniform(0, 5, size=(n, 2))
        got, want = sweep_pairs(lo, hi), sweep_pairs_numpy(lo, hi)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


class ReferenceStats:
    """EpisodeStats.update written plainly in numpy: every pair, no broad phase.

    Pairs are visited in the broad phase's order (by rank of the boxes' lo x in a
    stable sort: first the lower rank, then the higher), so contact events come out
    in the same order. Uses the numpy geometry of tests/reference/stats_reference.py
    and the event helpers of nao_arena.stats.events.
    """

    def __init__(self, radii, kinds, names, walls, dt, config, velocities):
        self.s = EpisodeStats(radii, kinds, names, walls, dt, config, velocities)

    def update(self, t, p0, p1, v1, acc, goal, substeps=None):  # noqa: C901, PLR0915
        from nao_arena.stats import ContactEvent

        s, cfg = self.s, self.s.config
        n, nw, dt = s.n, s.n_walls, s.dt
        path = np.stack([p0, p1]) if substeps is None else np.asarray(substeps, float)
        m = len(path) - 1  # substeps; straight lines between rows
        v0 = s._v_prev if s._v_prev is not None else (p1 - p0) / dt

        def first_touch(dist, reach):  # the first substep within reach, else the closest
            below = np.flatnonzero(dist < reach)
            return int(below[0]) if len(below) else int(np.argmin(dist))

        def approach(k, body):  # velocity while touching first, in substep k
            if m > 1:
                return (path[k + 1, body] - path[k, body]) / (dt / m)
            return v0[body]

        # robot metrics
        active = s.is_robot & ~s.reached
        step = p1 - p0
        s.path_length += np.where(active, np.hypot(step[:, 0], step[:, 1]), 0.0)
        if s._has_prev:
            da = acc - s._a_prev
            s.adjustments += active & (np.hypot(da[:, 0], da[:, 1]) > cfg.adjustment_threshold)
        s._a_prev, s._has_prev = acc.copy(), True
        new_goal = goal & active
        s.time_to_goal[new_goal] = t + dt
        s.reached |= new_goal
        # the broad phase's visiting order
        pad = 0.5 * cfg.separation_range
        ahead = p1 + v1 * cfg.ttc_horizon
        lo_x = np.concatenate(
            [np.minimum(path[:, :, 0].min(axis=0), ahead[:, 0]) - (s.radii + pad), s._wall_lo[:, 0]]
        )
        rank = np.empty(n + nw, dtype=np.int64)
        rank[np.argsort(lo_x, kind="stable")] = np.arange(n + nw)

        def visiting(a, b):
            ra, rb = rank[a], rank[b]
            k = np.lexsort((np.maximum(ra, rb), np.minimum(ra, rb)))
            return a[k], b[k]

        started = []

        def contacts(i, j, sep, sep_end, wall, make):
            state = s._touch_bw if wall else s._touch_bb
            was = state[i, j]
            touching = sep < 0.0
            new = touching & ~was
            live = was | new
            ended = live & (sep_end > cfg.hysteresis)
            for k in np.flatnonzero(was):
                ev = s._open_events[(int(i[k]), int(j[k]), wall)]
                ev.max_penetration = max(ev.max_penetration, float(-sep[k]))
            for k in np.flatnonzero(new):
                a, b = int(i[k]), int(j[k])
                ev = make(k)
                s._open_events[(a, b, wall)] = ev
                s.contacts.append(ev)
                started.append(ev)
                s.collisions[a] += 1
                if wall:
                    s.wall_collisions[a] += 1
                else:
                    s.collisions[b] += 1
            for k in np.flatnonzero(ended):
                s._open_events.pop((int(i[k]), int(j[k]), wall)).end_time = t + dt
            state[i[live], j[live]] = (live & ~ended)[live]

        # body pairs
        i, j = visiting(*np.triu_indices(n, 1))
        reach = s.radii[i] + s.radii[j]
        d1, w = p1[j] - p1[i], v1[j] - v1[i]
        aa = w[:, 0] * w[:, 0] + w[:, 1] * w[:, 1]
        bb = d1[:, 0] * w[:, 0] + d1[:, 1] * w[:, 1]
        cc = d1[:, 0] * d1[:, 0] + d1[:, 1] * d1[:, 1] - reach * reach
        disc = bb * bb - aa * cc
        hit = (((bb < 0.0) & (disc >= 0.0)) | (cc <= 0.0)) & (s.is_robot[i] | s.is_robot[j])
        with np.errstate(divide="ignore", invalid="ignore"):
            ttc = cc / np.maximum(np.sqrt(np.maximum(disc, 0.0)) - bb, 1e-300)
        ttc = np.where(cc <= 0.0, 0.0, ttc)
        soon = hit & (ttc <= cfg.ttc_horizon)
        np.minimum.at(s.min_ttc, i[soon], ttc[soon])
        np.minimum.at(s.min_ttc, j[soon], ttc[soon])
        rel = path[:, j] - path[:, i]  # (m + 1, pairs, 2)
        per_substep = np.array([swept_disc_distances(rel[k], rel[k + 1])[0] for k in range(m)])
        if m == 1:
            sep = per_substep[0] - reach
        else:  # the closest points of swept_disc_distances, the root of the least square
            closest = [
                rel[k]
                + (rel[k + 1] - rel[k]) * swept_disc_distances(rel[k], rel[k + 1])[1][:, None]
                for k in range(m)
            ]
            sep = (
                np.sqrt(np.min([c[:, 0] * c[:, 0] + c[:, 1] * c[:, 1] for c in closest], axis=0))
                - reach
            )
        near = np.flatnonzero(sep < cfg.separation_range)
        if len(near):
            i, j, sep, reach, d1 = i[near], j[near], sep[near], reach[near], d1[near]
            rel, per_substep = rel[:, near], per_substep[:, near]
            np.minimum.at(s.min_separation, i, sep)
            np.minimum.at(s.min_separation, j, sep)
            sep_end = np.hypot(d1[:, 0], d1[:, 1]) - reach

            def make_disc(k):
                a, b = int(i[k]), int(j[k])
                q = first_touch(per_substep[:, k], float(reach[k]))
                tc, nrm = first_disc_touch(rel[q, k], rel[q + 1, k], float(reach[k]))
                return ContactEvent(
                    time=t + (q + tc) / m * dt,
                    a=a,
                    b=b,
                    kind_a=s.kinds[a],
                    kind_b=s.kinds[b],
                    name_a=s.names[a],
                    name_b=s.names[b],
                    impact_speed=max(0.0, -float((approach(q, b) - approach(q, a)) @ nrm)),
                    max_penetration=float(-sep[k]),
                    speed_a=float(np.hypot(*approach(q, a))),
                    speed_b=float(np.hypot(*approach(q, b))),
                    began_overlapping=bool(np.hypot(*rel[0, k]) < reach[k]),
                )

            contacts(i, j, sep, sep_end, False, make_disc)
            new = sep < cfg.near_miss_distance
            if s._n_prox or np.any(new):
                had = s._prox_contact[i, j] | (sep < 0.0)
                live = s._prox[i, j] | new
                ended = live & (sep_end > cfg.near_miss_distance + cfg.hysteresis)
                missed = ended & ~had
                np.add.at(s.near_misses, i[missed], 1)
                np.add.at(s.near_misses, j[missed], 1)
                keep = live & ~ended
                s._prox[i, j] = keep
                s._prox_contact[i, j] = had & keep
                s._n_prox = int(np.count_nonzero(keep))
        # body-wall pairs: every pair, exact distance over every substep
        if nw:
            bi, bw = np.meshgrid(np.arange(n), np.arange(nw), indexing="ij")
            first, second = visiting(bi.ravel(), bw.ravel() + n)
            i, w = first, second - n
            segs = s.wall_segments
            reach = s.radii[i] + s.wall_radii[w]
            a, b = segs[w, 0], segs[w, 1]
            per_substep = np.array(
                [segment_distances(path[k, i], path[k + 1, i], a, b) for k in range(m)]
            )
            sep = per_substep.min(axis=0) - reach
            sep_end = point_segment(p1[i], a, b) - reach

            def make_wall(k):
                body, wall = int(i[k]), int(w[k])
                q = first_touch(per_substep[:, k], float(reach[k]))
                tc, nrm_k = first_wall_touch(
                    path[q, body], path[q + 1, body], a[k], b[k], float(reach[k])
                )
                return ContactEvent(
                    time=t + (q + tc) / m * dt,
                    a=body,
                    b=wall,
                    kind_a=s.kinds[body],
                    kind_b="wall",
                    name_a=s.names[body],
                    name_b=f"wall{wall}",
                    impact_speed=max(0.0, -float(approach(q, body) @ nrm_k)),
                    max_penetration=float(-sep[k]),
                    speed_a=float(np.hypot(*approach(q, body))),
                    speed_b=0.0,
                )

            contacts(i, w, sep, sep_end, True, make_wall)
        s._v_prev = v1.copy()
        s._deadlock(t, s._stuck(p1, goal))  # not the kernel's: tested on its own
        s.steps += 1
        s.time = t + dt
        started.sort(key=lambda e: (e.time, e.a, e.b, e.kind_b))
        return started


def random_scene(seed: int, n: int, steps: int):
    """Bodies wandering in a walled 10 m x 10 m box (no physics: they pass through each
    other and the walls), some fast, with goals and jumpy commands."""
    rng = np.random.default_rng(seed)
    radii = rng.uniform(0.15, 0.5, n)
    kinds = ["traffic" if k % 5 == 4 else "robot" for k in range(n)]
    corners = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    segs = np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)
    segs = np.concatenate([segs, [[[3.0, 5.0], [7.0, 5.5]]], [[[5.0, 5.0], [5.0, 5.0]]]])
    walls = (segs, np.array([0.05, 0.05, 0.05, 0.05, 0.1, 0.2]))
    pos = rng.uniform(0.5, 9.5, (n, 2))
    vel = rng.normal(size=(n, 2))
    frames, accels, goals = [pos.copy()], [], []
    for k in range(steps):
        acc = np.round(rng.normal(size=(n, 2)) * 2, 1) * (rng.uniform(size=(n, 1)) < 0.3)
        vel = 0.9 * vel + acc * 0.1 + (5.0 - pos) * 0.02
        vel[k % n] *= 8.0 if k % 7 == 0 else 1.0  # now and then a fast one
        pos = pos + vel * 0.1
        frames.append(pos.copy())
        accels.append(acc)
        goals.append(rng.uniform(size=n) < 0.01 * k / steps)
    return radii, kinds, walls, np.array(frames), np.array(accels), np.array(goals)


def substep_paths(frames: np.ndarray, substeps: int, seed: int) -> np.ndarray:
    """(steps, substeps + 1, n, 2) paths between the frames: the straight line plus a bend
    (as constant acceleration would make) and now and then a sharp kink (a bounce), ends
    pinned to the frames."""
    rng = np.random.default_rng(seed + 100)
    steps, n = len(frames) - 1, frames.shape[1]
    f = np.linspace(0.0, 1.0, substeps + 1)[None, :, None, None]
    p0, p1 = frames[:-1, None], frames[1:, None]
    bend = rng.normal(size=(steps, 1, n, 2)) * 0.05 * (f * (1 - f))
    kink = (rng.uniform(size=(steps, 1, n, 1)) < 0.1) * rng.normal(size=(steps, 1, n, 2)) * 0.3
    peak = rng.uniform(0.2, 0.8, size=(steps, 1, n, 1))
    tent = np.minimum(f / peak, (1 - f) / (1 - peak))
    return p0 + (p1 - p0) * f + bend + kink * tent


@pytest.mark.slow
@pytest.mark.parametrize("substeps", [None, 10])
@pytest.mark.parametrize("seed", range(6))
def test_compiled_update_equals_numpy_reference(seed: int, substeps: int | None) -> None:
    n = (8, 25, 60)[seed % 3]
    radii, kinds, walls, frames, accels, goals = random_scene(seed, n, 80)
    paths = None if substeps is None else substep_paths(frames, substeps, seed)
    config = StatsConfig(near_miss_distance=0.3, separation_range=1.0)
    v_start = (frames[1] - frames[0]) / 0.1
    names = [f"b{k}" for k in range(n)]
    runs = [EpisodeStats(radii, kinds, names, walls, 0.1, config, v_start) for _ in range(2)]
    ref = ReferenceStats(radii, kinds, names, walls, 0.1, config, v_start)
    for k in range(len(accels)):
        vel = (frames[k + 1] - frames[k]) / 0.1
        args = (k * 0.1, frames[k], frames[k + 1], vel, accels[k], goals[k])
        path = None if paths is None else paths[k]
        want = [e.to_dict() for e in ref.update(*args, substeps=path)]
        for stats in runs:
            assert [e.to_dict() for e in stats.update(*args, substeps=path)] == want, k
    want = ref.s.summary().to_dict()
    assert len(want["contacts"]) > 5 and any(c["kind_b"] == "wall" for c in want["contacts"])
    assert sum(r["near_misses"] for r in want["robots"]) > 0
    for stats in runs:  # bit-identical, events in the same order, run after run
        assert stats.summary().to_dict() == want
        for name in (
            "min_separation",
            "min_ttc",
            "path_length",
            "near_misses",
            "adjustments",
            "_prox",
            "_prox_contact",
            "_touch_bb",
            "_touch_bw",
        ):
            assert np.array_equal(getattr(stats, name), getattr(ref.s, name)), name


def test_substeps_find_contacts_the_step_ends_hide() -> None:
    """A pair that bounces off each other inside one step (apart at both ends, overlapping
    at a middle substep) is a contact; without the substeps it is not seen."""
    p0 = np.array([[-0.33, 0.0], [0.33, 0.0]])
    mid = np.array([[-0.29, 0.0], [0.29, 0.0]])  # 2 cm overlap of two 0.3 m discs
    path = np.stack([p0, mid, p0])
    v = np.zeros((2, 2))
    blind = two(0.3)
    blind.update(0.0, p0, p0, v, v, np.zeros(2, bool))
    assert blind.contacts == []
    seen = two(0.3)
    started = seen.update(0.0, p0, p0, v, v, np.zeros(2, bool), substeps=path)
    assert len(started) == 1 and started[0].max_penetration == pytest.approx(0.02)
    assert 0.0 < started[0].time < 0.05  # during the first of the two substeps
    assert started[0].impact_speed == pytest.approx(0.04 / 0.05 * 2)
    with pytest.raises(ValueError, match="substeps"):
        seen.update(0.1, p0, p0, v, v, np.zeros(2, bool), substeps=path[:, :1])


def test_wall_contact_ends_when_the_robot_backs_away() -> None:
    """A contact still open at a step's end (separation below the hysteresis) ends once
    the robot is clear, even if its whole next step stays beyond the wall's reach."""
    walls = (np.array([[[0.0, -5.0], [0.0, 5.0]]]), np.array([0.05]))
    stats = EpisodeStats([0.3], ["robot"], ["r"], walls=walls, dt=0.1)
    # reach 0.35 m: touching at -0.345, 5 mm clear at -0.355, then away and back
    xs = [-1.0, -0.36, -0.345, -0.355, -0.5, -0.8, -0.345, -0.34]
    feed(stats, np.array([[[x, 0.0]] for x in xs]))
    assert len(stats.contacts) == 2
    assert stats.contacts[0].end_time == pytest.approx(0.4)
    assert 0.5 < stats.contacts[1].time <= 0.6


# ---------------------------------------------------------------- liveness


def _liveness_run(tracks: np.ndarray, goals: np.ndarray, tol: float = 0.3, **cfg):
    """Feed tracks (T, N, 2) every 0.1 s with goal flags from a tolerance; the summary."""
    n = tracks.shape[1]
    stats = EpisodeStats(
        np.full(n, 0.2), ["robot"] * n, dt=0.1, goals=goals, config=StatsConfig(**cfg)
    )
    at_goal = np.hypot(*(tracks - goals[None]).transpose(2, 0, 1)) <= tol
    feed(stats, tracks, goal=at_goal[1:])
    return stats.summary()


def test_stuck_time_counts_steps_without_progress_after_the_first_window() -> None:
    steps = 100  # 10 s
    still = np.zeros((steps + 1, 1, 2))  # stands 5 m from its goal
    s = _liveness_run(still, np.array([[5.0, 0.0]]), stuck_window=2.0)
    row = s.robots[0]
    assert row.stuck_time == pytest.approx(10.0 - 2.0)
    assert row.timed_out and not row.reached_goal
    assert row.final_goal_distance == pytest.approx(5.0)
    # alone and stuck: every robot away from its goal is stuck -> deadlock
    assert s.deadlock_time == pytest.approx(2.1)
    assert s.deadlock_duration == pytest.approx(8.0)
    # creeping 0.04 m/s (0.08 m per 2 s window) is below the 0.1 m progress: still stuck
    t = np.arange(steps + 1) * 0.1
    creep = np.stack([0.04 * t, 0 * t], axis=1)[:, None]
    assert _liveness_run(creep, np.array([[5.0, 0.0]]), stuck_window=2.0).robots[
        0
    ].stuck_time == pytest.approx(8.0)
    walk = np.stack([0.3 * t, 0 * t], axis=1)[:, None]
    s = _liveness_run(walk, np.array([[5.0, 0.0]]), stuck_window=2.0)
    assert s.robots[0].stuck_time == 0.0 and np.isnan(s.deadlock_time)


def test_time_away_after_arrival_and_final_distance() -> None:
    # arrives at 1 s, is pushed 1 m off at 2 s and stays there until 5 s
    t = np.arange(51) * 0.1
    x = np.clip(5.0 * t, 0.0, 5.0) - np.where(t >= 2.0, 1.0, 0.0)
    track = np.stack([x, 0 * t], axis=1)[:, None]
    s = _liveness_run(track, np.array([[5.0, 0.0]]), stuck_window=1.0)
    row = s.robots[0]
    assert row.reached_goal and not row.timed_out
    assert row.time_to_goal == pytest.approx(1.0)
    assert row.time_away_after_arrival == pytest.approx(3.0 + 0.1)  # steps ending 2.0 .. 5.0
    assert row.final_goal_distance == pytest.approx(1.0)
    assert row.stuck_time == pytest.approx(3.0 + 0.1)  # pushed away, then still: no progress


def test_liveness_in_the_arena_summary() -> None:
    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.maps import load_map

    arena = Arena(load_map("crossing"), ArenaOptions(agent="goal"))
    summary = arena.run(0).to_dict()
    assert "deadlock_time" in summary and "deadlock_duration" in summary
    for r in summary["robots"]:
        assert r["final_goal_distance"] is not None and r["final_goal_distance"] >= 0
        assert r["stuck_time"] >= 0 and r["time_away_after_arrival"] >= 0
        assert r["timed_out"] == (not r["reached_goal"])


def _liveness_reference(
    dt, p1, goals, goal, robots, reached, goal_dist, slot, progress, time_away, stuck_time
):
    """The liveness bookkeeping as numpy operations (the recorder's former code)."""
    at_goal = goal & robots
    time_away = time_away + dt * (reached & ~goal & robots)
    dist = np.hypot(p1[:, 0] - goals[:, 0], p1[:, 1] - goals[:, 1])
    before = goal_dist[slot].copy()
    away = robots & ~goal
    stuck = away & (before - dist < progress)
    goal_dist = goal_dist.copy()
    goal_dist[slot] = dist
    stuck_time = stuck_time + dt * stuck
    deadlocked = bool(away.any() and (stuck == away).all())
    return at_goal, time_away, goal_dist, stuck_time, deadlocked


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 7))
def test_liveness_kernel_is_the_numpy_bookkeeping_bit_for_bit(seed, n) -> None:
    from nao_arena.stats.kernel import liveness_kernel

    rng = np.random.default_rng(seed)
    window = int(rng.integers(1, 4))
    p1 = rng.normal(size=(n, 2)) * 3
    goals = p1 + rng.normal(size=(n, 2)) * rng.choice([0.0, 0.05, 1.0], size=(n, 1))
    goals[rng.random(n) < 0.2] = np.nan  # traffic: no goal
    goal, robots, reached = (rng.random(n) < q for q in (0.4, 0.8, 0.5))
    goal_dist = rng.normal(size=(window, n)) + 1.0
    goal_dist[rng.random((window, n)) < 0.3] = np.nan  # too early
    slot = int(rng.integers(0, window))
    time_away, stuck_time = rng.random(n), rng.random(n)
    expected = _liveness_reference(
        0.1, p1, goals, goal, robots, reached, goal_dist, slot, 0.1, time_away, stuck_time
    )
    at_goal = np.zeros(n, dtype=bool)
    deadlocked = liveness_kernel(
        0.1, p1, goals, goal, robots, reached, goal_dist, slot, 0.1, at_goal, time_away, stuck_time
    )
    got = (at_goal, time_away, goal_dist, stuck_time, deadlocked)
    for g, e in zip(got[:4], expected[:4], strict=True):
        assert g.tobytes() == e.tobytes()
    assert got[4] == expected[4]
