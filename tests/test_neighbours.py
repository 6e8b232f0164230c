"""The neighbour index (nao_arena.neighbours): its grid and queries against a scan of
every body, and the stopping plans' pair search through it."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.neighbours import (
    around,
    extent,
    grid,
    in_range_lists,
    nearest_lists,
    range_grid,
)
from nao_arena.stopping import _near_pairs


def _scene(n: int, spread: float, step: float, seed: int) -> np.ndarray:
    """Centres (n, 2) m: uniform over a square of half-width spread, some packed near the
    origin, some on a lattice of the given step (bodies on cell borders), some duplicates."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-spread, spread, size=(n, 2))
    packed = rng.random(n) < 0.3
    pos[packed] = rng.uniform(-1.0, 1.0, size=(int(packed.sum()), 2))
    lattice = rng.random(n) < 0.4
    pos[lattice] = np.round(pos[lattice] / step) * step
    pos[rng.random(n) < 0.1] = pos[0]
    return pos


def _distances(pos: np.ndarray, me: int, hypot: bool) -> np.ndarray:
    d = pos - pos[me]
    dist = np.hypot(d[:, 0], d[:, 1]) if hypot else np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2)
    dist[me] = np.inf
    return dist


@settings(max_examples=200, deadline=None)
@given(
    st.integers(1, 120),
    st.floats(0.5, 300.0),
    st.sampled_from([0.0, 0.5, 1.0, 4.0, 30.0]),
    st.integers(0, 2**32 - 1),
)
def test_around_holds_every_body_within_the_reach_in_index_order(n, spread, reach, seed):
    """The 3 x 3 cells around a body of a range_grid hold every body within the reach,
    each once, in index order, all from those cells."""
    pos = _scene(n, spread, max(reach, 0.5), seed)
    x0, y0, x1, y1 = extent(pos)
    assert (x0, y0, x1, y1) == (pos[:, 0].min(), pos[:, 1].min(), pos[:, 0].max(), pos[:, 1].max())
    h, gx, gy = range_grid(reach, n, x0, y0, x1, y1)
    assert h >= reach and gx * gy <= 4 * n + 16
    cell, cell_start, members = grid(pos, x0, y0, h, gx, gy)
    assert cell_start[-1] == n and sorted(members) == list(range(n))
    for c in range(gx * gy):  # each cell's bodies in index order
        run = members[cell_start[c] : cell_start[c + 1]]
        assert np.all(np.diff(run) > 0) and np.all(cell[run] == c)
    near = np.empty(n, dtype=np.int64)
    for me in range(n):
        count = around(cell[me], cell_start, members, gx, gy, near)
        got = near[:count]
        assert np.all(np.diff(got) > 0)
        within = np.flatnonzero(np.hypot(*(pos - pos[me]).T) <= reach)
        assert set(within) <= set(got)
        cx, cy = cell[got] % gx, cell[got] // gx
        assert np.all(np.abs(cx - cell[me] % gx) <= 1) and np.all(np.abs(cy - cell[me] // gx) <= 1)


@settings(max_examples=200, deadline=None)
@given(
    st.integers(1, 120),
    st.floats(0.5, 300.0),
    st.sampled_from([0.0, 0.7, 3.0, 25.0, np.inf]),
    st.sampled_from([-1, 0, 1, 6, 10]),
    st.booleans(),
    st.integers(0, 2**32 - 1),
)
def test_lists_are_a_scan_over_all_bodies(n, spread, rng_m, cap, hypot, seed):
    """in_range_lists (all within range, or the cap nearest: nearest_lists): per body the
    others within range by (distance, index), as a scan of every body."""
    pos = _scene(n, spread, rng_m if 0 < rng_m < np.inf else 0.5, seed)
    bodies = np.random.default_rng(seed).permutation(n).astype(np.int64)
    start, index = in_range_lists(bodies, pos, rng_m, cap, hypot)
    if cap >= 0:
        x0, y0, x1, y1 = extent(pos)
        s2, i2 = nearest_lists(bodies, pos, rng_m, cap, hypot, x0, y0, x1, y1)
        np.testing.assert_array_equal(s2, start)
        np.testing.assert_array_equal(i2, index)
    for k, b in enumerate(bodies):
        dist = _distances(pos, int(b), hypot)
        expect = np.flatnonzero(dist <= rng_m)
        expect = expect[np.argsort(dist[expect], kind="stable")]
        if cap >= 0:
            expect = expect[:cap]
        np.testing.assert_array_equal(index[start[k] : start[k + 1]], expect)


@settings(max_examples=200, deadline=None)
@given(
    st.integers(1, 80),
    st.floats(0.5, 200.0),
    st.sampled_from([0.0, 0.05, 0.3]),
    st.integers(0, 2**32 - 1),
)
def test_stopping_pairs_are_a_scan_over_all_pairs(n, spread, margin, seed):
    """The stopping plans' pair search: per robot, in index order, every other whose
    centre is within the radii + margin + both plans' extents (m)."""
    rng = np.random.default_rng(seed)
    pos = _scene(n, spread, 0.5, seed)
    radius = rng.uniform(0.1, 0.5, n)
    ext = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.0, 3.0, n))
    start, index = _near_pairs(pos, ext, radius, margin)
    for i in range(n):
        d = pos - pos[i]
        reach = radius[i] + radius + margin + ext[i] + ext
        expect = np.flatnonzero(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] <= reach * reach)
        expect = expect[expect != i]
        np.testing.assert_array_equal(index[start[i] : start[i + 1]], expect)
