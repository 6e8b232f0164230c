"""Point-to-segment distances: the contact check's (compiled, :mod:`nao_arena.stats.kernel`)
and the map loader's (numpy: map checks, navigation grids, the agents' wall ranges) are one
arithmetic, hypot(ap - t ab), and give the same bits but for segments shorter than
1e-150 m, which they guard differently. (The geometry kernels' ``point_segment_dist2``,
relative to the origin and squared, is another arithmetic.)"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.geometry.kernels import point_segment_distance
from nao_arena.geometry.walls import segment_distances_xy


def same(a: float, b: float) -> bool:
    """The same float64 bits (any NaN equal to any NaN)."""
    a, b = float(a), float(b)
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return np.array([a]).view(np.int64)[0] == np.array([b]).view(np.int64)[0]


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.floats(-50.0, 50.0), min_size=6, max_size=6),
    st.sampled_from([None, "degenerate", "axis"]),
)
def test_the_two_point_segment_distances_agree_on_real_segments(c, kind) -> None:
    """The contact check's point-to-segment distance (stats, compiled) and the map loader's
    (numpy, also the agents' wall ranges): the same bits for segments of no length or of
    squared length at least 1e-300 (they guard shorter ones differently)."""
    px, py, ax, ay, bx, by = c
    if kind == "degenerate":
        bx, by = ax, ay
    elif kind == "axis":
        by = ay
    ux, uy = bx - ax, by - ay
    if (ux != 0.0 or uy != 0.0) and ux * ux + uy * uy < 1e-300:
        return
    got = point_segment_distance(px, py, ax, ay, bx, by)
    want = segment_distances_xy(np.array([px]), np.array([py]), np.array([[ax, ay], [bx, by]]))
    assert same(got, want[0])
