"""The ``nao`` agents' walls in range (compiled, ``wall_lists``) against the numpy
arithmetic they replaced: the distance of every member to every wall by
``point_segment_distances``, kept where it is at most range + half-thickness + radius
and margin; the same lists, wall by wall, for any layout (degenerate walls included)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.agents._nao_decide import wall_lists
from nao_arena.geometry.walls import point_segment_distances

coord = st.floats(-40.0, 40.0, allow_nan=False)


def numpy_lists(pos, grow, reach, walls, half):
    dist = point_segment_distances(pos, walls)
    near = dist <= reach[:, None] + half[None, :] + grow[:, None]
    member, which = np.nonzero(near)
    start = np.zeros(len(pos) + 1, dtype=np.int64)
    np.cumsum(np.bincount(member, minlength=len(pos)), out=start[1:])
    return start, which.astype(np.int64)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.tuples(coord, coord, st.floats(0.1, 1.0), st.floats(0.0, 20.0)), min_size=1),
    st.lists(st.tuples(coord, coord, coord, coord, st.floats(0.0, 0.5), st.booleans()), min_size=1),
)
def test_the_walls_in_range_are_the_numpy_ones(members, segments) -> None:
    pos = np.array([[x, y] for x, y, _, _ in members])
    grow = np.array([g for *_, g, _ in members])
    reach = np.array([r for *_, r in members])
    walls = np.array(
        [[[ax, ay], [ax, ay] if zero else [bx, by]] for ax, ay, bx, by, _, zero in segments]
    )
    half = np.array([h for *_, h, _ in segments])
    # a member on a wall's threshold exactly: the comparison's bits matter
    d0 = point_segment_distances(pos[:1], walls[:1])[0, 0]
    reach[0] = max(d0 - half[0] - grow[0], 0.0)
    start, index = wall_lists(pos, grow, reach, walls, half)
    ref_start, ref_index = numpy_lists(pos, grow, reach, walls, half)
    assert np.array_equal(start, ref_start) and np.array_equal(index, ref_index)
