"""The kernels' stable argsort and median against numpy's."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from nao_arena.sorting import median, sort_in_place, stable_argsort

# few distinct values, so that ties are common; NaN, infinities and signed zeros among them
KEYS = hnp.arrays(
    np.float64,
    st.integers(0, 80),
    elements=st.sampled_from([np.nan, -np.inf, np.inf, -0.0, 0.0, -1.5, 1.5, 2.0, 1e-300, 3.0]),
)


@settings(max_examples=300, deadline=None)
@given(KEYS)
def test_stable_argsort_is_numpys(keys):
    np.testing.assert_array_equal(stable_argsort(keys), np.argsort(keys, kind="stable"))


@settings(max_examples=100, deadline=None)
@given(hnp.arrays(np.float64, st.integers(0, 120), elements=st.floats(-1e6, 1e6)))
def test_stable_argsort_of_a_strided_column_is_numpys(values):
    table = np.stack([values, -values], axis=1)  # table[:, 0] is not contiguous
    np.testing.assert_array_equal(
        stable_argsort(table[:, 0]), np.argsort(table[:, 0], kind="stable")
    )


@settings(max_examples=300, deadline=None)
@given(
    # distances, as the kernels take medians of: no -0.0 (whose tie with 0.0 either may win)
    hnp.arrays(np.float64, st.integers(1, 40), elements=st.floats(0.0, 1e300).map(abs)),
    st.integers(0, 5),
)
def test_median_is_numpys_bit_for_bit(values, spare):
    n = len(values)
    padded = np.concatenate([values, np.full(spare, np.nan)])  # only the first n count
    before = padded.copy()
    got = median(padded, n)
    assert np.float64(got).tobytes() == np.float64(np.median(values)).tobytes()
    np.testing.assert_array_equal(padded, before)


@settings(max_examples=300, deadline=None)
@given(
    hnp.arrays(
        np.int64,
        st.integers(0, 150),
        elements=st.integers(-5, 5) | st.integers(-(2**63), 2**63 - 1),
    ),
    st.integers(0, 150),
)
def test_sort_in_place_is_numpys_sort(values, n):
    n = min(n, len(values))
    mine = values.copy()
    sort_in_place(mine, n)
    expected = values.copy()
    expected[:n].sort()
    np.testing.assert_array_equal(mine, expected)
