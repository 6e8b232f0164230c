"""The compiled fast paths agree with the reference (numpy / earlier) implementations.

The all-NAO loop runs on compiled kernels and batched agents; each is checked
here against the path it replaces, on random and on crowded inputs:
neighbour lists, the turn-rate predictor, the containment filter and the
nearest-point search of the disk picture (against copies of the previous
kernels), the batched admissibility test (against ``admissible_kernel`` on
the same sampled paths), compiled bisection and sliding (against the Python
loops), and whole episodes with ``act_batch`` against the per-robot ``act``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba.core.errors import TypingError
from reference.kernels_reference import (
    bisect_ref,
    disk_samples_ref,
    drop_contained_ref,
    nearest_outside_disks_ref,
    repair_ref,
    slide_ref,
)
from reference.predictors_reference import turn_rate_numpy
from reference.selection_reference import CandidateTester, bundles, nearest_by_disks, search

from nao_arena.agents._nao_bundles import DecidingRobots, GroupPaths, ObstacleLists
from nao_arena.agents._nao_columns import StepMemo
from nao_arena.agents._nao_decide import (
    ADJUSTED,
    DESIRED,
    INFEASIBLE,
    REPAIRED,
    UNDECIDED,
    decide,
    ring_radii_rows,
    selection_settings,
)
from nao_arena.agents.nao import AOAgent, NAOAgent
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.geometry import selection
from nao_arena.geometry._kernel.batch import sampled_admissible_batch
from nao_arena.geometry._kernel.bundles import (
    IndexLists,
    Obstacles,
    OutsideSearch,
    Paths,
    Predictions,
    Robots,
    Scratch,
    SearchSettings,
    Walls,
    WorldWalls,
)
from nao_arena.geometry._kernel.candidates import _try_ball_disc
from nao_arena.geometry._kernel.disks import (
    capped_disks,
    drop_contained,
    largest_capped_reach,
    nao_disk_samples,
    nao_disks,
    nao_disks_within,
    radius_order,
)
from nao_arena.geometry._kernel.exact import admissible_kernel, clearance_kernel, piece_sweep
from nao_arena.geometry._kernel.outside import (
    nearest_outside_disks,
    outside_advance,
    outside_found,
    outside_setup,
)
from nao_arena.geometry._kernel.relevance import relevant_obstacles, relevant_sampled_paths
from nao_arena.geometry._kernel.sampled import RADIUS_CUT, path_excursions
from nao_arena.geometry._kernel.search import (
    bisect_disc,
    ok_disc,
    outward_normal,
    ring_search_disc,
    select_disc,
    slide_disc,
    try_candidates_disc,
)
from nao_arena.geometry.clearance import PiecewisePath, sampled_path
from nao_arena.geometry.outcome import Outcome
from nao_arena.geometry.selection import (
    _RINGS,
    AccelLimits,
    _ring_radii,
    repair_acceleration,
)
from nao_arena.geometry.walls import point_segment_distances
from nao_arena.maps import load_map
from nao_arena.predictors import turn_rate
from nao_arena.sensing import Neighbours, neighbour_lists, neighbours_in_range
from nao_arena.sorting import stable_order

# ---------------------------------------------------------------- scenes


def _neighbours(rng: np.random.Generator, n: int, spread: float = 6.0) -> Neighbours:
    speed = rng.choice([0.0, 1e-7, 0.5, 1.5], size=(n, 1))
    return Neighbours(
        ids=np.arange(n),
        kinds=("robot",) * n,
        positions=rng.normal(size=(n, 2)) * spread,
        velocities=rng.normal(size=(n, 2)) * speed,
        accelerations=rng.normal(size=(n, 2)),
        radii=rng.uniform(0.2, 0.6, size=n),
    )


def _disk_scene(rng: np.random.Generator, crowded: bool):
    """Sampled NAO disks of random straight-moving obstacles around the robot."""
    n = int(rng.integers(3, 12 if crowded else 5))
    times = np.linspace(0.0, 3.0, 31)
    pos = rng.normal(size=(n, 2)) * (2.0 if crowded else 5.0)
    vel = rng.normal(size=(n, 2))
    centres = pos[:, None, :] + vel[:, None, :] * times[None, :, None]
    path = sampled_path(times, centres, rng.uniform(0.6, 1.2, size=n))
    v = rng.normal(size=2)
    q = rng.normal(size=2)
    reach = float(rng.choice([0.25, 1.0, 4.0]))
    return nao_disks(v, *_disk_obstacles(path), 0.0, 4, q, reach, 2.0), q


def _disk_obstacles(path: PiecewisePath) -> tuple[Paths, Walls]:
    """The obstacles and walls of ``path`` as the disk picture and the search take them."""
    return Paths(*path.moving_arrays), Walls(path.walls, path.wall_radius)


# ---------------------------------------------------------------- sensing


@pytest.mark.parametrize("seed", range(6))
def test_neighbour_lists_match_neighbours_in_range(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    pos = np.round(rng.normal(size=(n, 2)) * 5.0, 1)  # rounded: equal distances occur
    bodies = rng.permutation(n)[: int(rng.integers(1, n + 1))]
    for rng_m, cap in [(4.0, None), (8.0, 3), (np.inf, None), (0.0, None)]:
        start, index = neighbour_lists(bodies, pos, rng_m, cap)
        for k, b in enumerate(bodies):
            expect = neighbours_in_range(int(b), pos, rng_m, cap)
            np.testing.assert_array_equal(index[start[k] : start[k + 1]], expect)


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 160),
    st.floats(0.5, 400.0),
    st.sampled_from([0.0, 0.7, 3.0, 15.0, 25.0, np.inf]),
    st.sampled_from([None, 0, 1, 6, 10]),
    st.sampled_from([0.0, 0.5, 0.9]),
    st.booleans(),
    st.integers(0, 2**32 - 1),
)
def test_neighbour_lists_through_the_grid_are_a_scan_over_all_bodies(
    n, spread, rng_m, cap, packed, hypot, seed
):
    """Many cells (bodies spread far beyond the range), a packed crowd among sparse
    bodies (the nearest-k search's rings), bodies on cell borders (positions on a
    lattice), equal distances, duplicates: the same lists as a scan of every body."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-spread, spread, size=(n, 2))
    crowd = rng.random(n) < packed
    pos[crowd] = rng.uniform(-0.6, 0.6, size=(int(crowd.sum()), 2)) * np.sqrt(crowd.sum())
    lattice = rng.random(n) < rng.choice([0.3, 1.0])  # all: ties in many cells
    step = rng.choice([rng_m, 0.5]) if 0 < rng_m < np.inf else rng.choice([0.5, 1.0])
    pos[lattice] = np.round(pos[lattice] / step) * step
    pos[rng.random(n) < 0.1] = pos[0]
    bodies = rng.permutation(n)[: int(rng.integers(1, n + 1))]
    start, index = neighbour_lists(bodies, pos, rng_m, cap, hypot=hypot)
    for k, b in enumerate(bodies):
        d = pos - pos[b]
        dist = np.hypot(d[:, 0], d[:, 1]) if hypot else np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2)
        dist[b] = np.inf
        expect = np.flatnonzero(dist <= rng_m)
        expect = expect[np.argsort(dist[expect], kind="stable")][:cap]
        np.testing.assert_array_equal(index[start[k] : start[k + 1]], expect)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 12), min_size=0, max_size=140), st.integers(0, 3))
def test_stable_order_is_numpys_stable_argsort(keys, spare):
    """The allocation-free sort of the neighbour lists: every length (runs of 16 merged
    up to several times), many equal keys (ties in index order), scratch larger than m."""
    key = np.array(keys + [99] * spare, dtype=np.float64) * 0.25
    m = len(keys)
    order = np.full(len(key), -1, dtype=np.int64)
    stable_order(key, m, order, np.empty(len(key), dtype=np.int64))
    np.testing.assert_array_equal(order[:m], np.argsort(key[:m], kind="stable"))


def test_arena_observations_match_per_robot_sensing():
    arena = Arena(load_map("roundabout", seed=1))
    arena.reset(1)
    for _ in range(20):
        arena.step()
    state = arena.state
    for k, obs in enumerate(arena.observations()):
        body = int(arena.robot_ids[k])
        idx = neighbours_in_range(body, state.positions, arena.sensing_range, arena.max_neighbours)
        nb = obs.neighbours
        np.testing.assert_array_equal(nb.ids, idx)
        assert nb.kinds == tuple(np.array(arena.world.kinds)[idx])
        np.testing.assert_array_equal(nb.positions, state.positions[idx])
        np.testing.assert_array_equal(nb.velocities, state.velocities[idx])
        np.testing.assert_array_equal(nb.accelerations, state.accelerations[idx])
        np.testing.assert_array_equal(nb.radii, state.radii[idx])
        assert nb.known_paths is not None and nb.known_paths.shape[0] == len(idx)
        np.testing.assert_array_equal(obs.position, state.positions[body])
        np.testing.assert_array_equal(obs.goal, arena.goals[k])
        assert obs.a_max == float(arena.world.a_max[body])


# ---------------------------------------------------------------- predictor


@pytest.mark.parametrize("seed", range(8))
def test_compiled_turn_rate_matches_numpy(seed):
    rng = np.random.default_rng(seed)
    nb = _neighbours(rng, int(rng.integers(1, 30)))
    times = (
        np.linspace(0.0, 3.0, 31)
        if seed % 2
        else np.sort(rng.uniform(0.0, 5.0, size=int(rng.integers(1, 20))))
    )
    fast = turn_rate(times, nb)
    ref = turn_rate_numpy(times, nb)
    assert fast.shape == ref.shape == (len(nb), len(times), 2)
    np.testing.assert_allclose(fast, ref, rtol=1e-13, atol=1e-12)


def test_turn_rate_rows_do_not_depend_on_the_others():
    """Agents predict every body at once and index: row i must not depend on the batch."""
    rng = np.random.default_rng(3)
    nb = _neighbours(rng, 25)
    times = np.linspace(0.0, 3.0, 31)
    everyone = turn_rate(times, nb)
    for keep in (np.array([4]), np.array([0, 7, 3, 24])):
        sub = Neighbours(
            ids=nb.ids[keep],
            kinds=tuple(nb.kinds[i] for i in keep),
            positions=nb.positions[keep],
            velocities=nb.velocities[keep],
            accelerations=nb.accelerations[keep],
            radii=nb.radii[keep],
        )
        np.testing.assert_array_equal(turn_rate(times, sub), everyone[keep])


# ---------------------------------------------------------------- disk picture


def _random_disks(rng: np.random.Generator) -> np.ndarray:
    m = int(rng.integers(0, 60))
    d = np.column_stack([rng.normal(size=(m, 2)) * 1.5, rng.lognormal(-1.0, 1.0, size=m)])
    if m > 4:  # exact duplicates and nested copies
        d[1] = d[0]
        d[3] = (d[2, 0] + 0.01, d[2, 1], d[2, 2] * 0.5)
    return d


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(40))
def test_drop_contained_matches_reference(seed):
    rng = np.random.default_rng(seed)
    disks = _random_disks(rng) if seed % 2 else _disk_scene(rng, True)[0]
    np.testing.assert_array_equal(drop_contained(disks), drop_contained_ref(disks))


def _outside_scene(rng, seed):
    """A nearest-outside-disks scene: random disks (none inside another) and a random
    point (seed % 3 == 0), else a crowded or sparse disk picture and its point."""
    if seed % 3 == 0:
        return drop_contained_ref(_random_disks(rng)), rng.normal(size=2)
    return _disk_scene(rng, crowded=seed % 3 == 1)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(60))
def test_nearest_outside_disks_matches_reference(seed):
    rng = np.random.default_rng(100 + seed)
    disks, q = _outside_scene(rng, seed)
    for max_out in (1, 8):
        ref = nearest_outside_disks_ref(q, disks, 2.0, max_out)
        np.testing.assert_array_equal(nearest_outside_disks(q, disks, 2.0, max_out), ref)
        # ``within``: the same rows, cut at that distance
        for within in (0.0, 0.3, 1.0):
            np.testing.assert_array_equal(
                nearest_outside_disks(q, disks, 2.0, max_out, within), ref[ref[:, 2] <= within]
            )
        # ``covered``: any ball with no free point (closer than the nearest candidate)
        # may be skipped without changing the answer
        if len(ref) and ref[0, 2] > 0.0:
            np.testing.assert_array_equal(
                nearest_outside_disks(q, disks, 2.0, max_out, math.inf, 0.999 * ref[0, 2]), ref
            )


def test_ring_radii_rows_are_the_selections_ring_radii():
    """decide's rings per robot, one array operation: the radii select_acceleration uses."""
    a_max = np.array([2.0, 0.5, 3.7, 1e-13, 0.0, 6.0, 2.0])
    np.testing.assert_array_equal(
        ring_radii_rows(a_max), np.stack([_ring_radii(float(a), _RINGS) for a in a_max])
    )


def test_ring_radii_rows_remembered_only_for_the_same_limits():
    """The radii remembered in a table's memo are those of the limits asked for: other
    limits (another value, another count of robots), then the first ones again; the
    same limits are served from the memo."""
    memo = StepMemo()
    first = np.array([2.0, 2.0, 2.0])
    for a_max in (first, np.array([2.0, 2.0, 0.5]), np.array([2.0, 2.0]), first.copy(), first):
        got = ring_radii_rows(a_max, memo)
        np.testing.assert_array_equal(got, np.stack([_ring_radii(float(a), _RINGS) for a in a_max]))
        assert memo.ring_radii is got and ring_radii_rows(a_max.copy(), memo) is got


def _outside_rows(q, disks, a_max, within, covered, row):
    """outside_setup then outside_advance until ``row`` is final: (res, resume position)."""
    res = np.full((8, 3), math.inf)
    lower = np.empty(len(disks) + 1)
    order, scale = outside_setup(q, disks, a_max, within, res, lower)
    m = len(disks)
    search = OutsideSearch(
        res,
        lower,
        order,
        scale,
        np.empty((2 * m + 8, 2)),
        np.empty(2 * m + 4),
        np.empty(2 * m + 4),
        np.empty(4, dtype=np.uint64),
    )
    oi = outside_advance(q, disks, a_max, covered, search, 0, row)
    return res, oi


@pytest.mark.parametrize("seed", range(40))
def test_outside_rows_are_final_before_every_circle_is_visited(seed):
    """Advanced only until row r is final, the rows 0..r of the search are those of the
    whole search (nearest_outside_disks): its leading candidates, in its order."""
    rng = np.random.default_rng(4100 + seed)
    disks, q = _outside_scene(rng, seed)
    for within, covered in ((math.inf, 0.0), (1.0, 0.0), (math.inf, 0.05)):
        ref = nearest_outside_disks(q, disks, 2.0, 8, within, covered)
        for row in range(8):
            res, _ = _outside_rows(q, disks, 2.0, within, covered, row)
            found = outside_found(res[: row + 1], within)
            assert found == min(row + 1, len(ref))
            np.testing.assert_array_equal(res[:found], ref[:found])


def test_outside_search_stops_early_in_a_crowded_picture():
    """The first candidate is often final before the farther circles are visited."""
    early = 0
    for seed in range(20):
        disks, q = _disk_scene(np.random.default_rng(seed), crowded=True)
        full = _outside_rows(q, disks, 2.0, math.inf, 0.0, 8)[1]
        early += _outside_rows(q, disks, 2.0, math.inf, 0.0, 0)[1] < full
    assert early >= 2


@pytest.mark.parametrize("seed", range(30))
def test_ball_search_tries_the_candidates_of_nearest_outside_disks(seed):
    """_try_ball_disc (candidates tried as soon as each is final) answers as
    nearest_outside_disks followed by try_candidates_disc: same point, same count of
    tests, and 'empty' exactly when there is no candidate."""
    t, rng = _tester(5000 + seed)
    p = t.path
    for _ in range(4):
        a_d = t.limits.project(rng.uniform(-2.5, 2.5, size=2))
        samples = nao_disk_samples(t.v, *_disk_obstacles(p), 0.0, 2, a_d, 8.0, 2.0, 16.0, 0.02)
        for reach in (0.5, 2.0, 8.0):
            disks = nao_disks_within(samples, reach)
            for covered in (0.0, 0.25 * reach):
                cands = nearest_outside_disks(a_d, disks, 2.0, 8, reach, covered)
                ref = try_candidates_disc(cands, 0, reach, a_d, 1e-3, *bundles(t, 2.0), 0.0, disks)
                got = _try_ball_disc(a_d, disks, reach, 1e-3, *bundles(t, 2.0), 0.0, covered)
                assert got[:4] == ref[:4]
                assert got[4] == (len(cands) == 0)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(20))
def test_capped_disks_are_the_chosen_balls_disks(seed):
    """capped_disks hands back the disks of the ball it chose, whether it worked out their
    containment while choosing (a ball over the cap in raw samples) or afterwards."""
    rng = np.random.default_rng(800 + seed)
    n = int(rng.integers(1, 12))
    times = np.linspace(0.0, 2.5, 26)
    path = _straight_paths(rng, n, times, spread=2.0)
    samples = nao_disk_samples(
        rng.normal(size=2),
        *_disk_obstacles(path),
        0.1,
        2,
        rng.normal(size=2),
        16.0,
        2.0,
        16.0,
        0.02,
    )
    for cap in (2, 8, 24, 64, 1000):
        chosen, disks = capped_disks(samples, radius_order(samples), 0.0625, 8.0, cap)
        assert chosen == largest_capped_reach(samples, 0.0625, 8.0, cap)
        if chosen < 0.0:
            assert disks.shape == (0, 3)
        else:
            np.testing.assert_array_equal(disks, nao_disks_within(samples, chosen))
            assert len(disks) <= cap


@pytest.mark.parametrize("seed", range(20))
def test_largest_capped_reach_matches_the_doubling(seed):
    """The last doubled reach whose disks (after containment) stay within the cap, as
    the ball-by-ball doubling finds it."""
    rng = np.random.default_rng(700 + seed)
    n = int(rng.integers(1, 12))
    times = np.linspace(0.0, 3.0, 31)
    path = _straight_paths(rng, n, times, spread=2.0)
    q = rng.normal(size=2)
    samples = nao_disk_samples(
        rng.normal(size=2), *_disk_obstacles(path), 0.1, 2, q, 16.0, 2.0, 16.0, 0.02
    )
    for cap in (4, 16, 48):
        reach, ref = 0.125, -1.0
        while reach < 8.0:
            reach *= 2.0
            if len(nao_disks_within(samples, reach)) > cap:
                break
            ref = reach
        assert largest_capped_reach(samples, 0.125, 8.0, cap) == ref


@pytest.mark.parametrize("seed", range(10))
def test_nao_disks_within_a_smaller_reach_match_nao_disks(seed):
    rng = np.random.default_rng(300 + seed)
    n = int(rng.integers(1, 8))
    times = np.linspace(0.0, 3.0, 31)
    path = _straight_paths(rng, n, times, spread=3.0)
    v = rng.normal(size=2)
    q = rng.normal(size=2)
    args = (v, *_disk_obstacles(path), 0.1, 4, q)
    samples = nao_disk_samples(*args, 8.0, 2.0)
    for reach in (0.125, 0.5, 2.0, 8.0):
        np.testing.assert_array_equal(
            nao_disks_within(samples, reach), nao_disks(*args, reach, 2.0)
        )


def _straight_paths(
    rng: np.random.Generator,
    n: int,
    times: np.ndarray,
    spread: float,
    speed: float = 1.0,
    radii: tuple[float, float] = (0.5, 1.0),
):
    """n obstacles on straight lines sampled at ``times``: start positions N(0, spread^2)
    (m), velocities N(0, speed^2) (m/s), radii uniform in ``radii`` (m), drawn in that
    order."""
    pos = rng.normal(size=(n, 2)) * spread
    vel = rng.normal(size=(n, 2)) * speed
    return sampled_path(
        times, pos[:, None, :] + vel[:, None, :] * times[None, :, None], rng.uniform(*radii, size=n)
    )


@pytest.mark.parametrize("seed", range(60))
def test_disk_samples_are_every_sample_that_meets_ball_and_limit(seed):
    """Far obstacles and pieces out of reach included (whole pieces are skipped when no
    acceleration within a_max reaches them): the same disks as sampling every time."""
    rng = np.random.default_rng(900 + seed)
    n = int(rng.integers(1, 8))
    times = np.linspace(0.0, 2.5, 26)
    pos = rng.normal(size=(n, 2)) * rng.choice([1.0, 4.0, 8.0])
    vel = rng.normal(size=(n, 2)) * 1.5
    path = sampled_path(
        times,
        pos[:, None, :] + vel[:, None, :] * times[None, :, None],
        rng.uniform(0.3, 1.0, size=n),
    )
    v = rng.normal(size=2)
    q = rng.normal(size=2)
    for reach in (0.5, 4.0):
        got = nao_disk_samples(v, *_disk_obstacles(path), 0.1, 2, q, reach, 2.0, 16.0, 0.0)
        ref = disk_samples_ref(v, path, 0.1, 2, q, reach, 2.0, 16.0)
        assert got.shape == ref.shape
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("seed", range(20))
def test_thinned_disk_samples_keep_every_left_out_disk_close(seed):
    """nao_disk_samples(thin > 0) keeps a subsequence of the full samples of one obstacle;
    each left-out disk lies within sqrt(8 thin rho) of the last kept one, which is at
    least as large; the last disk is kept; thinning leaves out disks."""
    rng = np.random.default_rng(500 + seed)
    times = np.linspace(0.0, 3.0, 31)
    path = _straight_paths(rng, 1, times, spread=3.0)
    args = (rng.normal(size=2), *_disk_obstacles(path), 0.1, 2, np.zeros(2), 8.0, 2.0, 16.0)
    full = nao_disk_samples(*args)
    thin = 0.02
    kept = nao_disk_samples(*args, thin)
    if len(full) == 0:
        assert len(kept) == 0
        return
    assert len(kept) < len(full) or len(full) < 10
    j = -1
    for row in full:
        if j + 1 < len(kept) and np.array_equal(row, kept[j + 1]):
            j += 1
            continue
        assert j >= 0, "the first disk is kept"
        assert kept[j, 2] >= row[2]
        assert np.sum((row[:2] - kept[j, :2]) ** 2) <= 8.0 * thin * row[2]
    assert j == len(kept) - 1, "the kept disks are a subsequence"
    assert np.array_equal(full[-1], kept[-1])


# ---------------------------------------------------------------- admissibility


def _batch_scene(seed: int):
    rng = np.random.default_rng(seed)
    n_bodies = int(rng.integers(2, 25))
    nb_all = _neighbours(rng, n_bodies, spread=3.0)
    times = np.linspace(0.0, 3.0, 31)
    pred = turn_rate(times, nb_all)
    rows = np.arange(n_bodies)
    start, index = neighbour_lists(rows, nb_all.positions, float(rng.uniform(2.0, 10.0)))
    wall_a = rng.normal(size=(int(rng.integers(0, 8)), 2)) * 4.0
    wall_c = np.stack([wall_a, wall_a + rng.normal(size=wall_a.shape) * 3.0], axis=1)
    wall_r = rng.uniform(0.0, 0.3, size=len(wall_c))
    near = [np.flatnonzero(rng.random(len(wall_c)) < 0.6) for _ in rows]
    wall_start = np.concatenate([[0], np.cumsum([len(x) for x in near])]).astype(np.int64)
    wall_index = (np.concatenate(near) if near else np.zeros(0)).astype(np.int64)
    acc = rng.normal(size=(n_bodies, 2)) * 1.5
    v_max = rng.choice([1.0, 2.0, np.inf], size=n_bodies)
    margin = rng.uniform(0.0, 0.3, size=n_bodies)
    return (
        times,
        pred,
        nb_all,
        start,
        index,
        wall_c,
        wall_r,
        wall_start,
        wall_index,
        acc,
        v_max,
        margin,
    )


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(25))
def test_batched_admissibility_matches_admissible_kernel(seed):
    (
        times,
        pred,
        nb_all,
        start,
        index,
        wall_c,
        wall_r,
        wall_start,
        wall_index,
        acc,
        v_max,
        margin,
    ) = _batch_scene(seed)
    n = len(nb_all)
    pos, vel, rad = nb_all.positions, nb_all.velocities, nb_all.radii
    out = np.full(n, 7, dtype=np.int64)
    sampled_admissible_batch(
        Predictions(times, pred, rad, *path_excursions(pred)),
        IndexLists(start, index),
        WorldWalls(wall_c, wall_r),
        IndexLists(wall_start, wall_index),
        np.arange(n),
        Robots(pos, vel, v_max, rad, margin),
        acc,
        out,
    )
    for k in range(n):
        idx = index[start[k] : start[k + 1]]
        widx = wall_index[wall_start[k] : wall_start[k + 1]]
        centres = pred[idx] - pos[k]
        radii = rad[idx] + rad[k] + margin[k]
        if len(radii) == 0 and len(widx) == 0:
            assert out[k] == 1
            continue
        # documented: a radius beyond the current distance is cut to just under it
        x0, y0 = centres[:, 0, 0], centres[:, 0, 1]
        radii = np.minimum(radii, np.sqrt(x0 * x0 + y0 * y0) * (1.0 - 1e-9))
        segs = wall_c[widx] - pos[k]
        dist = point_segment_distances(np.zeros((1, 2)), segs)[0]
        w_rad = np.minimum(wall_r[widx] + (rad[k] + margin[k]), dist * (1.0 - 1e-9))
        moving = sampled_path(times, centres.reshape(-1, len(times), 2), radii)
        path = PiecewisePath(
            moving.t,
            moving.c,
            moving.velocity,
            moving.acceleration,
            moving.radius,
            np.ascontiguousarray(segs.reshape(-1, 2, 2)),
            w_rad,
        )
        ok = np.empty(1, dtype=bool)
        admissible_kernel(
            vel[k][None].copy(),
            acc[k][None].copy(),
            v_max[k],
            Obstacles(*path.moving_arrays, piece_sweep(path.t, path.velocity, path.acceleration)),
            Walls(path.walls, path.wall_radius),
            0.0,
            ok,
        )
        assert out[k] == int(ok[0]), k


@pytest.mark.parametrize("seed", range(8))
def test_pruned_admissibility_matches_the_exact_clearance(seed):
    """admissible_kernel (piece prune with the speed bound, the end-point exit, early
    stop) against clearance_kernel's exact minimum distance (no prune): for margins
    just below and just above each candidate's exact clearance the verdicts are
    admissible and not admissible. Robots start at up to twice v_max (clamped), brake
    through zero or saturate; obstacles accelerate; three static walls."""
    rng = np.random.default_rng(seed)
    n, s, k = 6, 12, 60
    seg_t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 0.4, size=s))])
    seg_c = rng.normal(size=(n, s, 2)) * 6.0
    seg_w = rng.normal(size=(n, s, 2))
    seg_b = rng.normal(size=(n, s, 2)) * 0.5
    radius = rng.uniform(0.2, 1.0, size=n)
    ends = rng.normal(size=(3, 2)) * 8.0
    walls = np.ascontiguousarray(np.stack([ends, ends + rng.normal(size=(3, 2)) * 2.0], axis=1))
    wall_r = rng.uniform(0.1, 0.5, size=3)
    v_max = 1.5
    cand_v = rng.normal(size=(k, 2)) * v_max
    cand_a = rng.normal(size=(k, 2)) * 1.5
    clear = np.empty((k, n + 3))
    clearance_kernel(
        cand_v,
        cand_a,
        v_max,
        Paths(seg_t, seg_c, seg_w, seg_b, radius),
        Walls(walls, wall_r),
        clear,
        np.empty((k, n + 3)),
        np.empty((k, n + 3)),
    )
    sweep = piece_sweep(seg_t, seg_w, seg_b)
    ok = np.empty(1, dtype=bool)
    checked = 0
    for i in range(k):
        least = float(np.min(clear[i]))
        if least <= 1e-3:
            continue
        for margin, expect in ((least * (1.0 - 1e-6), True), (least * (1.0 + 1e-6), False)):
            admissible_kernel(
                cand_v[i][None].copy(),
                cand_a[i][None].copy(),
                v_max,
                Obstacles(seg_t, seg_c, seg_w, seg_b, radius, sweep),
                Walls(walls, wall_r),
                margin,
                ok,
            )
            assert bool(ok[0]) is expect, (i, margin, least)
        checked += 1
    assert checked >= 5


def test_bundles_given_in_each_others_place_do_not_compile():
    """The point of the named bundles: the walls given where the neighbour lists go (and
    the other way round) is a typing error, where the flat argument list it replaced
    (two int64 arrays beside two float64 ones) left some swaps to run."""
    (
        times,
        pred,
        nb_all,
        start,
        index,
        wall_c,
        wall_r,
        wall_start,
        wall_index,
        acc,
        v_max,
        margin,
    ) = _batch_scene(0)
    n = len(nb_all)
    pos, vel, rad = nb_all.positions, nb_all.velocities, nb_all.radii
    paths = Predictions(times, pred, rad, *path_excursions(pred))
    robots = Robots(pos, vel, v_max, rad, margin)
    neighbours, walls = IndexLists(start, index), WorldWalls(wall_c, wall_r)
    out = np.full(n, 7, dtype=np.int64)
    sampled_admissible_batch(
        paths, neighbours, walls, IndexLists(wall_start, wall_index), np.arange(n), robots, acc, out
    )
    assert set(out.tolist()) <= {0, 1}
    with pytest.raises(TypingError):
        sampled_admissible_batch(
            paths,
            walls,
            neighbours,
            IndexLists(wall_start, wall_index),
            np.arange(n),
            robots,
            acc,
            out,
        )


def test_batched_admissibility_flags_non_finite_paths():
    (
        times,
        pred,
        nb_all,
        start,
        index,
        wall_c,
        wall_r,
        wall_start,
        wall_index,
        acc,
        v_max,
        margin,
    ) = _batch_scene(1)
    pred = pred.copy()
    pred[:, 5, 0] = np.nan
    n = len(nb_all)
    out = np.zeros(n, dtype=np.int64)
    sampled_admissible_batch(
        Predictions(times, pred, nb_all.radii, *path_excursions(pred)),
        IndexLists(start, index),
        WorldWalls(wall_c, wall_r),
        IndexLists(wall_start, wall_index),
        np.arange(n),
        Robots(nb_all.positions, nb_all.velocities, v_max, nb_all.radii, margin),
        acc,
        out,
    )
    has_nb = np.diff(start) > 0
    assert np.all(out[has_nb] == -1)


# ---------------------------------------------------------------- bisection, sliding


def _tester(seed: int):
    rng = np.random.default_rng(seed)
    times = np.linspace(0.0, 3.0, 31)
    n = int(rng.integers(1, 6))
    path = _straight_paths(rng, n, times, spread=2.5, radii=(0.6, 1.2))
    limits = AccelLimits(2.0)
    return CandidateTester(
        rng.normal(size=2), path, limits, 0.0, float(rng.choice([1.5, np.inf]))
    ), rng


@pytest.mark.parametrize("seed", range(30))
def test_compiled_bisect_and_slide_match_python_loops(seed):
    for attempt in range(20):  # a scene with both admissible and colliding accelerations
        t, rng = _tester(1000 * seed + attempt)
        limits = t.limits
        grid = rng.uniform(-2.0, 2.0, size=(200, 2))
        grid = grid[np.hypot(*grid.T) <= 2.0]
        ok = t.ok(grid)
        if ok.any() and not ok.all():
            break
    else:
        pytest.fail("no scene with a boundary")
    good = grid[ok][0]
    bad = grid[~ok][0]
    args = (*bundles(t, limits.a_max), t.margin)
    before = t.count
    ref = bisect_ref(t, bad, good, 1e-3)
    ref_count = t.count - before
    x, y, count = bisect_disc(bad, good, 1e-3, *args)
    np.testing.assert_array_equal([x, y], ref)
    assert count == ref_count
    before = t.count
    ref = slide_ref(t, bad, ref, limits, 1e-3)
    ref_count = t.count - before
    x, y, count = slide_disc(bad, np.array([x, y]), 1e-3, *args)
    np.testing.assert_array_equal([x, y], ref)
    assert count == ref_count


# ---------------------------------------------------------------- whole episodes


class _PerRobotNAO(NAOAgent):
    act_batch = None  # the Arena then calls act() robot by robot


class _PerRobotAO(AOAgent):
    act_batch = None


def _trajectory(
    map_name: str,
    episode: int,
    steps: int,
    per_robot: bool,
    agent: str | None = None,
    agent_options: dict | None = None,
    **params,
):
    arena = Arena(
        load_map(map_name, **params),
        ArenaOptions(agent=agent, agent_options=agent_options or {}) if agent else None,
    )
    arena.reset(episode)
    if per_robot:
        for ag in arena.agents:
            ag.__class__ = _PerRobotAO if isinstance(ag, AOAgent) else _PerRobotNAO
    rows = []
    for _ in range(steps):
        if arena.done:
            break
        res = arena.step()
        rows.append(np.concatenate([res.state.positions.ravel(), res.commanded.ravel()]))
        assert not res.faults
    return np.array(rows)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("map_name", "agent", "params"),
    [
        ("circle_swap", None, {"n": 12, "radius": 6.0, "lo": -10.0, "hi": 10.0}),
        ("roundabout", None, {"seed": 2}),
        ("roundabout", None, {"seed": 4, "predictor": "known_path"}),
        ("crossing", "ao", {"seed": 1}),
        # nothing admissible and no braking: the per-robot path decides
        (
            "circle_swap",
            "nao",
            {
                "n": 12,
                "radius": 6.0,
                "lo": -10.0,
                "hi": 10.0,
                "agent_options": {"infeasible": "latest_contact"},
            },
        ),
    ],
)
def test_act_batch_reproduces_per_robot_act(map_name, agent, params):
    batched = _trajectory(map_name, 3, 80, False, agent, **params)
    single = _trajectory(map_name, 3, 80, True, agent, **params)
    np.testing.assert_array_equal(batched, single)


class _Batchy:
    """act_batch returning a bad value, an exception and a good one."""

    def reset(self, spec, rng):
        pass

    def act(self, obs):
        return np.zeros(2)

    @classmethod
    def act_batch(cls, agents, batch, rows):
        out = []
        for k in rows:
            if k == 0:
                out.append(np.array([np.nan, 0.0]))
            elif k == 1:
                out.append(ValueError("boom"))
            else:
                out.append(np.full(2, 0.1))
        return out


class _Broken(_Batchy):
    @classmethod
    def act_batch(cls, agents, batch, rows):
        raise RuntimeError("all down")


def test_arena_rejects_actions_for_robots_it_does_not_have():
    arena = Arena(load_map("crossing"))
    arena.reset(0)
    for k in (len(arena.robots), -1):
        with pytest.raises(ValueError, match=f"robot index {k} is not one of"):
            arena.step({k: np.zeros(2)})
    arena.step({0: np.zeros(2)})  # a valid one replaces that robot's agent


def test_arena_contains_act_batch_failures():
    arena = Arena(load_map("circle_swap", n=4, radius=5.0, lo=-8.0, hi=8.0))
    arena.reset(0)
    arena.agents = [_Batchy() for _ in arena.agents]
    res = arena.step()
    assert [f.robot for f in res.faults] == [0, 1]
    assert "non-finite" in res.faults[0].message and "ValueError: boom" in res.faults[1].message
    np.testing.assert_array_equal(res.commanded[arena.robot_ids[:2]], 0.0)
    np.testing.assert_array_equal(res.commanded[arena.robot_ids[2:]], 0.1)
    arena.agents = [_Broken() for _ in arena.agents]
    res = arena.step()
    assert [f.robot for f in res.faults] == [0, 1, 2, 3]
    assert all("RuntimeError: all down" in f.message for f in res.faults)
    # external actions still replace agents
    res = arena.step({2: np.array([0.2, 0.0])})
    assert [f.robot for f in res.faults] == [0, 1, 3]


class _CustomNAO(NAOAgent):
    """Overrides act: the inherited act_batch must defer to it."""

    def act(self, obs):
        return np.array([0.05, -0.05])


def test_act_batch_defers_to_an_overridden_act():
    arena = Arena(load_map("circle_swap", n=4, radius=5.0, lo=-8.0, hi=8.0))
    arena.reset(0)
    for ag in arena.agents:
        ag.__class__ = _CustomNAO
    res = arena.step()
    assert not res.faults
    np.testing.assert_array_equal(res.commanded[arena.robot_ids], [[0.05, -0.05]] * 4)


# ---------------------------------------------------------------- disk candidates


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(40))
def test_compiled_candidate_loop_matches_the_python_loop(seed):
    """The disk picture's candidates confirmed in a compiled loop (try_candidates_disc)
    and in the Python loop it replaces: the same answers and counts."""
    t, rng = _tester(seed)
    twin = CandidateTester(t.v, t.path, t.limits, 0.0, t.v_max)
    for _ in range(10):
        a_d = rng.uniform(-2.5, 2.5, size=2)
        a_d = t.limits.project(a_d)
        for cap in (selection._MAX_DISKS, None):
            before, before_py = t.count, twin.count
            got = nearest_by_disks(t, a_d, 1e-3, max_disks=cap)
            ref = nearest_by_disks(twin, a_d, 1e-3, max_disks=cap, compiled=False)
            if ref is None:
                assert got is None
            else:
                np.testing.assert_array_equal(got, ref)
            assert t.count - before == twin.count - before_py


def _boundary_scene(seed: int):
    """A _tester scene with both admissible and colliding accelerations: (tester, rng,
    grid points in the limit disc, their admissibility)."""
    for attempt in range(20):
        t, rng = _tester(1000 * seed + attempt)
        grid = rng.uniform(-2.0, 2.0, size=(200, 2))
        grid = grid[np.hypot(*grid.T) <= 2.0]
        ok = t.ok(grid)
        if ok.any() and not ok.all():
            return t, rng, grid, ok
    pytest.fail("no scene with a boundary")


@pytest.mark.parametrize("seed", range(40))
def test_compiled_rings_match_the_python_rings(seed):
    """The ring fallback of select_acceleration, compiled for the limit disc, against the
    Python loop it replaces (all rings tested, the innermost with an admissible candidate
    wins, its nearest admissible candidate is bisected and slid): the same answers."""
    t, rng, _, _ = _boundary_scene(seed)
    radii = 4.0 * 0.5 ** np.arange(7, -1, -1)
    found_any = 0
    for _ in range(10):
        a_d = t.limits.project(rng.uniform(-2.5, 2.5, size=2))
        found, x, y, _ = ring_search_disc(
            a_d, radii, selection._unit_rings(8, 16), 1e-3, *bundles(t, 2.0), 0.0
        )
        cands = selection._ring_candidates(a_d, radii, 16, t.limits)
        ok = t.ok(cands).reshape(8, 16)
        ref = None
        for i in range(8):
            if ok[i].any():
                good = cands[i * 16 : (i + 1) * 16][ok[i]]
                start = bisect_ref(t, a_d, good[int(np.argmin(np.hypot(*(good - a_d).T)))], 1e-3)
                ref = slide_ref(t, a_d, start, t.limits, 1e-3)
                break
        assert found == (ref is not None)
        if ref is not None:
            found_any += 1
            np.testing.assert_array_equal([x, y], ref)
    assert found_any


@pytest.mark.parametrize("seed", range(40))
def test_compiled_repair_matches_the_python_loop(seed):
    """repair_acceleration for the limit disc (compiled) against the loop it replaces."""
    t, rng, grid, ok = _boundary_scene(seed)
    answers = 0
    for k in range(20):
        # previous accelerations just inside the NAO, next to admissible ones
        prev = t.limits.project(grid[~ok][k % (~ok).sum()] + rng.normal(size=2) * 0.05)
        want = t.limits.project(rng.uniform(-2.5, 2.5, size=2))
        got = repair_acceleration(prev, want, t.v, t.path, t.limits, v_max=t.v_max)
        ref = repair_ref(t, prev, want)
        if ref is None:
            assert got is None
        else:
            answers += 1
            np.testing.assert_array_equal(got, ref)
    assert answers


@pytest.mark.parametrize("seed", range(30))
def test_relevant_paths_match_sampled_path_then_relevance(seed):
    """The agents' compiled path building keeps exactly the obstacles relevant_obstacles
    keeps from the sampled_path of all of them, with the same pieces."""
    rng = np.random.default_rng(seed)
    times = np.linspace(0.0, 3.0, 31)
    n = int(rng.integers(0, 12))
    pred = rng.normal(size=(n, 1, 2)) * 6.0 + rng.normal(size=(n, 1, 2)) * times[None, :, None]
    radii = rng.uniform(0.2, 0.6, size=n)
    idx = rng.permutation(n)[: int(rng.integers(0, n + 1))].astype(np.int64)
    position, velocity = rng.normal(size=2), rng.normal(size=2)
    grow = 0.45
    a_max, v_max = 2.0, float(rng.choice([1.5, np.inf]))
    c, w, b, rad, finite = relevant_sampled_paths(
        times, pred, idx, position, radii, grow, velocity, a_max, v_max, *path_excursions(pred)
    )
    assert finite
    centres = pred[idx] - position
    all_r = np.minimum(
        radii[idx] + grow,
        np.sqrt(centres[:, 0, 0] * centres[:, 0, 0] + centres[:, 0, 1] * centres[:, 0, 1])
        * RADIUS_CUT,
    )
    full = sampled_path(times, centres.reshape(-1, len(times), 2), all_r)
    keep = relevant_obstacles(velocity, a_max, v_max, *full.moving_arrays, 0.0)
    np.testing.assert_array_equal(c, full.c[keep])
    np.testing.assert_array_equal(w, full.velocity[keep])
    np.testing.assert_array_equal(b, full.acceleration[keep])
    np.testing.assert_array_equal(rad, full.radius[keep])
    if n:
        bad = pred.copy()
        bad[0, 3, 1] = np.nan
        assert not relevant_sampled_paths(
            times,
            bad,
            np.arange(n),
            position,
            radii,
            grow,
            velocity,
            a_max,
            v_max,
            *path_excursions(bad),
        )[4]


@pytest.mark.parametrize("delta", [1e-6, 1e-3, 0.1])
def test_relevant_paths_keep_an_obstacle_at_the_full_speed_reach(delta):
    """The cheap proof before the exact relevance test drops nothing the exact test
    keeps: a robot already at v_max towards a static obstacle whose grown disc it
    reaches delta (m) before the horizon keeps it; delta beyond the reach drops it."""
    times = np.linspace(0.0, 3.0, 31)
    v_max, radius, grow = 1.5, 0.3, 0.2
    reach = radius + grow + v_max * times[-1]
    for d, kept in ((reach - delta, 1), (reach + delta, 0)):
        pred = np.repeat(np.array([[[d, 0.0]]]), len(times), axis=1)
        c, w, b, rad, finite = relevant_sampled_paths(
            times,
            pred,
            np.array([0]),
            np.zeros(2),
            np.array([radius]),
            grow,
            np.array([v_max, 0.0]),
            2.0,
            v_max,
            *path_excursions(pred),
        )
        assert finite and len(rad) == kept, (d, kept)


@pytest.mark.parametrize("seed", range(40))
def test_compiled_selection_matches_the_python_steps(seed):
    """select_disc (steps 1-3 of select_acceleration compiled for the limit disc) against
    the same steps run from Python (reference.selection_reference.search): the same
    answers."""
    t, rng, grid, ok = _boundary_scene(seed)
    p = t.path
    radii = 4.0 * 0.5 ** np.arange(7, -1, -1)
    statuses = set()
    for k in range(10):
        # half of them inside the NAO
        a_d = (
            grid[~ok][k % (~ok).sum()]
            if k % 2
            else t.limits.project(rng.uniform(-2.5, 2.5, size=2))
        )
        status, x, y, _ = selection.select_disc(
            a_d,
            t.v,
            2.0,
            t.v_max,
            *_disk_obstacles(p),
            0.0,
            SearchSettings(
                1e-3,
                radii,
                selection._unit_rings(8, 16),
                selection._MAX_DISKS,
                selection._DISKS_PER_PIECE,
                selection._DISKS_PER_SECOND,
                selection._SLIVER_DEPTH * 2.0,
            ),
        )
        ref = search(t, a_d, radii, 16, 1e-3)
        statuses.add(status)
        if ref is None:
            assert status == Outcome.INFEASIBLE
        else:
            assert status.label == ref[1]
            np.testing.assert_array_equal([x, y], ref[0])
    assert statuses - {Outcome.DESIRED}


def test_outward_normal_points_away_from_the_circles_through_the_point():
    # two unit circles centred at (-0.6, 0) and (0.6, 0) meet at (0, 0.8): away from both
    # is straight up; a point on one circle only gets that circle's normal; off all: none
    disks = np.array([[-0.6, 0.0, 1.0], [0.6, 0.0, 1.0], [5.0, 5.0, 0.5]])
    np.testing.assert_allclose(outward_normal(0.0, 0.8, disks), (0.0, 1.0), atol=1e-12)
    np.testing.assert_allclose(outward_normal(-1.6, 0.0, disks), (-1.0, 0.0), atol=1e-12)
    assert outward_normal(3.0, 3.0, disks) == (0.0, 0.0)


def test_sliver_candidates_pushed_along_the_outward_normal_are_admissible():
    """A candidate in a sliver of a thinned disk picture whose ray push from the desired
    acceleration stays inside the NAO is pushed away from the circles through it: more
    candidates are confirmed than by the ray alone, and every one is admissible."""
    only_normal = 0
    for seed in range(20):
        t, rng = _tester(seed)
        p = t.path
        for _ in range(3):
            a_d = t.limits.project(rng.uniform(-2.5, 2.5, size=2))
            samples = nao_disk_samples(t.v, *_disk_obstacles(p), 0.0, 2, a_d, 8.0, 2.0, 16.0, 0.02)
            disks = nao_disks_within(samples, 8.0)
            cands = nearest_outside_disks(a_d, disks, 2.0, 8, 8.0)
            for k in range(len(cands)):
                args = (cands[k : k + 1], 0, 8.0, a_d, 1e-3, *bundles(t, 2.0), 0.0)
                found, x, y, _, _ = try_candidates_disc(*args, disks)
                ray_only = try_candidates_disc(*args, np.zeros((0, 3)))[0]
                assert found or not ray_only
                if found:
                    assert t.ok1(np.array([x, y]))
                    only_normal += not ray_only
    assert only_normal >= 10


@pytest.mark.parametrize("seed", range(20))
def test_exact_test_answer_does_not_depend_on_its_hint(seed):
    """ok_disc tests the (obstacle, piece) that last rejected first: whatever the hint
    (none, random, the one a nearby candidate left), the answer is admissible_kernel's."""
    for attempt in range(20):  # a scene with both admissible and colliding accelerations
        t, rng = _tester(1000 * seed + attempt)
        cands = rng.uniform(-2.0, 2.0, size=(150, 2))
        cands = cands[np.hypot(*cands.T) <= 2.0]
        ref = t.ok(cands)
        if ref.any() and not ref.all():
            break
    else:
        pytest.fail("no scene with a boundary")
    p = t.path
    n_obs, n_pieces = p.c.shape[0], p.c.shape[1]
    buf, res = np.empty(3), np.empty(3)
    carried = np.full(2, -1, dtype=np.int64)
    for a, want in zip(cands, ref, strict=True):
        for hint in (
            np.full(2, -1, dtype=np.int64),
            carried,
            np.array([rng.integers(n_obs), rng.integers(n_pieces)], dtype=np.int64),
        ):
            ok, tested = ok_disc(a[0], a[1], *bundles(t, 2.0), 0.0, Scratch(buf, res, hint))
            assert ok == want and tested == 1


def test_decide_takes_the_desired_acceleration_exactly_where_the_selection_does():
    """decide tries the desired acceleration first against the obstacles within its own
    reach (the keep test's admissibility) and takes it when admissible, before building
    the obstacle paths of the full selection: for robots with no wall in range and no
    repair to try, it is DESIRED exactly where select_disc, on the relevant paths the
    full selection builds, says DESIRED, with the same acceleration (and tested 1)."""
    outcomes = {True: 0, False: 0}
    for seed in range(12):
        times, pred, nb_all, start, index, *_, v_max, margin = _batch_scene(seed)
        rng = np.random.default_rng(seed)
        n = len(nb_all)
        pos, vel, rad = nb_all.positions, nb_all.velocities, nb_all.radii
        a_max = np.full(n, 2.0)
        grow = rad + margin
        # inside the limit disc (projected onto it unchanged), some toward the others
        desired = rng.normal(size=(n, 2))
        desired *= (rng.uniform(0.05, 0.99, n) * a_max / np.hypot(*desired.T))[:, None]
        no_walls = np.zeros(n + 1, dtype=np.int64)
        excursion, finite = path_excursions(pred)
        kind, accel, tested = decide(
            GroupPaths(times, pred, excursion, finite),
            ObstacleLists(start, index, np.zeros((0, 2, 2)), np.zeros(0), no_walls, no_walls[:0]),
            rad,
            np.arange(n),
            DecidingRobots(pos, vel, grow, a_max, v_max),
            np.zeros(n, dtype=bool),
            np.zeros((n, 2)),
            desired,
        )
        chosen = selection_settings(a_max)
        for k in range(n):
            c, w, b, r, ok = relevant_sampled_paths(
                times,
                pred,
                index[start[k] : start[k + 1]],
                pos[k],
                rad,
                grow[k],
                vel[k],
                a_max[k],
                v_max[k],
                excursion,
                finite,
            )
            assert ok
            status, x, y, _ = select_disc(
                desired[k],
                vel[k],
                a_max[k],
                v_max[k],
                Paths(times, c, w, b, r),
                Walls(np.zeros((0, 2, 2)), np.zeros(0)),
                0.0,
                SearchSettings(
                    max(1e-3, 1e-9 * max(a_max[k], 1.0)),
                    chosen.ring_radii[k],
                    chosen.unit_rings,
                    chosen.max_disks,
                    chosen.n_sub,
                    chosen.per_second,
                    chosen.sliver_depth * a_max[k],
                ),
            )
            taken = status == DESIRED
            outcomes[taken] += 1
            assert (kind[k] == DESIRED) == taken, k
            if taken:
                assert accel[k, 0] == x == desired[k, 0] and accel[k, 1] == y == desired[k, 1]
                assert tested[k] == 1
    assert min(outcomes.values()) >= 10, outcomes


@pytest.mark.slow
def test_decide_leaves_non_finite_robots_to_the_caller():
    (
        times,
        pred,
        nb_all,
        start,
        index,
        wall_c,
        wall_r,
        wall_start,
        wall_index,
        acc,
        v_max,
        margin,
    ) = _batch_scene(2)
    n = len(nb_all)
    vel = nb_all.velocities.copy()
    vel[0, 1] = np.nan
    pred = pred.copy()
    bad_body = index[start[1]] if start[2] > start[1] else None
    if bad_body is not None:
        pred[bad_body, 3, 0] = np.inf
    kind, _, _ = decide(
        GroupPaths(times, pred, *path_excursions(pred)),
        ObstacleLists(start, index, wall_c, wall_r, wall_start, wall_index),
        nb_all.radii,
        np.arange(n),
        DecidingRobots(nb_all.positions, vel, nb_all.radii + margin, np.full(n, 2.0), v_max),
        np.ones(n, dtype=bool),
        acc,
        np.zeros((n, 2)),
    )
    assert kind[0] == UNDECIDED
    if bad_body is not None:
        assert kind[1] == UNDECIDED
    others = [
        k for k in range(n) if not np.any(np.isin(index[start[k] : start[k + 1]], [bad_body]))
    ]
    assert all(kind[k] in (REPAIRED, DESIRED, ADJUSTED, INFEASIBLE) for k in others if k)
