"""Borrowed views (no reference counting) in the compiled kernels: the same data, and
no leak. (A view used after its array was freed would give wrong results: the kernels'
tests against plain references and forward simulation would catch that.)"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from typing import NamedTuple

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from nao_arena.geometry.borrow import borrowed, borrowed_fields


@njit(cache=False)
def _write_through(arr, value):
    view = borrowed(arr)
    view[0, 1] = value
    return view.shape[0], view.shape[1], view.strides[0], view.strides[1], view[1, 0]


def test_borrowed_view_is_the_same_array() -> None:
    base = np.arange(24.0).reshape(4, 6)
    for arr in (base, base[::2, 1:5], base.T):
        before = sys.getrefcount(arr)
        got = _write_through(arr, -7.0)
        assert got == (arr.shape[0], arr.shape[1], arr.strides[0], arr.strides[1], arr[1, 0])
        assert arr[0, 1] == -7.0
        assert sys.getrefcount(arr) == before


class _Bundle(NamedTuple):
    grid: np.ndarray
    scale: float
    index: np.ndarray
    flag: bool


class _Nested(NamedTuple):
    inner: tuple[np.ndarray, np.ndarray]
    scale: float


@njit(cache=False)
def _write_through_fields(bundle, value):
    view = borrowed_fields(bundle)
    view.grid[0, 1] = value
    view.index[-1] = 7
    return view.grid[1, 0] * view.scale, view.grid.strides[0], view.index.shape[0], view.flag


def test_borrowed_fields_are_the_same_arrays_and_numbers() -> None:
    grid = np.arange(24.0).reshape(4, 6)[::2, 1:5]
    index = np.zeros(5, dtype=np.int64)
    bundle = _Bundle(grid, 0.5, index, True)
    counts = sys.getrefcount(grid), sys.getrefcount(index)
    got = _write_through_fields(bundle, -7.0)
    assert got == (grid[1, 0] * 0.5, grid.strides[0], 5, True)
    assert grid[0, 1] == -7.0 and index[-1] == 7
    assert (sys.getrefcount(grid), sys.getrefcount(index)) == counts


def test_borrowed_fields_refuses_a_field_it_cannot_borrow() -> None:
    """A nested tuple of arrays would come back without its reference: refused at
    compile time."""

    @njit(cache=False)
    def borrow_nested(bundle):
        return borrowed_fields(bundle).scale

    with pytest.raises(TypingError):
        borrow_nested(_Nested((np.zeros(2), np.zeros(3)), 1.0))


@pytest.mark.installed
def test_kernels_do_not_leak(tmp_path) -> None:
    """Sixty steps of a 12-robot NAO arena (keep tests, repairs, selections) in a fresh
    process with the runtime's allocation counters on: as many arrays are freed as
    were allocated during the loop."""
    script = textwrap.dedent("""
        import gc, sys
        import numpy as np
        from numba.core.runtime import rtsys
        from nao_arena.arena import Arena, ArenaOptions
        from nao_arena.maps import load_map

        arena = Arena(load_map("circle_swap", n=12), ArenaOptions(agent="nao"))
        arena.reset(3)
        for _ in range(5):
            arena.step()  # compile and warm every kernel the loop uses
        gc.collect()
        before = rtsys.get_allocation_stats()
        for _ in range(60):
            arena.step()
        gc.collect()
        after = rtsys.get_allocation_stats()
        new = after.alloc - before.alloc
        freed = after.free - before.free
        assert new > 1000, new  # the kernels did run
        assert new == freed, (new, freed)
        assert after.mi_alloc - before.mi_alloc == after.mi_free - before.mi_free
        print("ok", new)
    """)
    env = dict(os.environ, NUMBA_NRT_STATS="1")
    # run outside the checkout, so that the installed package is imported
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.startswith("ok")
