"""The cheap coverage proof of the nearest-outside-disks search (outside._surely_covered).

It may only skip circles the exact computation finds covered: whenever it says
"covered", the exact free arcs (tests/reference: atan2, acos and a sort, no proof)
are none. Pictures like the selection's: chains of growing disks (an obstacle's
acceleration obstacle sampled at successive times), loose disks, the limit disc.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from reference.kernels_reference import free_arc_points_ref

from nao_arena.geometry._kernel.outside import _surely_covered

A_MAX = 2.0


def _picture(
    rng: np.random.Generator, chains: int, links: int, loose: int, spread: float
) -> np.ndarray:
    """Disks (M, 3) m/s^2: ``chains`` chains of ``links`` overlapping disks along smooth
    curves (rows in chain order, as the selection's samples are), then ``loose`` disks."""
    rows = []
    for _ in range(chains):
        start = rng.normal(size=2) * spread
        step = rng.normal(size=2) * 0.15
        bend = rng.normal(size=2) * 0.02
        r0 = rng.uniform(0.1, 0.8)
        grow = rng.uniform(0.0, 0.08)
        for t in range(links):
            c = start + step * t + bend * t * t
            rows.append((c[0], c[1], r0 + grow * t))
    for _ in range(loose):
        c = rng.normal(size=2) * spread
        rows.append((c[0], c[1], rng.lognormal(-1.0, 0.7)))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def _exact_free(
    cx: float, cy: float, rho: float, in_limit: bool, disks: np.ndarray, skip: int
) -> bool:
    """Whether the exact computation finds a free arc on the circle."""
    out = np.empty((2 * len(disks) + 8, 2))
    return free_arc_points_ref(cx, cy, rho, in_limit, np.zeros(2), disks, skip, A_MAX, out, 0) > 0


def _proofs(disks: np.ndarray) -> tuple[int, int]:
    """Every circle of the picture (each disk's, the limit circle's): asserts that no
    circle proven covered has an exact free arc; returns (proven, covered exactly)."""
    cover = np.empty(4, dtype=np.uint64)
    proven = covered = 0
    circles = [(x, y, r, True, j) for j, (x, y, r) in enumerate(disks)]
    circles.append((0.0, 0.0, A_MAX, False, -1))
    for cx, cy, rho, in_limit, skip in circles:
        free = _exact_free(cx, cy, rho, in_limit, disks, skip)
        sure = _surely_covered(
            cx, cy, rho, in_limit, disks, skip, A_MAX, cover, np.empty(5), np.empty(5)
        )
        assert not (sure and free), (cx, cy, rho, skip)
        proven += sure
        covered += not free
    return proven, covered


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    chains=st.integers(0, 8),
    links=st.integers(1, 24),
    loose=st.integers(0, 30),
    spread=st.sampled_from([0.2, 0.6, 1.5, 4.0]),
)
def test_a_circle_proven_covered_has_no_exact_free_arc(seed, chains, links, loose, spread):
    _proofs(_picture(np.random.default_rng(seed), chains, links, loose, spread))


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 40))
def test_touching_and_nested_disks_are_never_proven_by_mistake(seed, n):
    """Near-tangent pairs, disks through the same points, copies and nested disks: the
    cases where rounding decides."""
    rng = np.random.default_rng(seed)
    base = _picture(rng, 2, 6, 4, 0.5)
    rows = [base]
    for _ in range(n):
        i = rng.integers(len(base))
        x, y, r = base[i]
        kind = rng.integers(4)
        if kind == 0:  # externally tangent (to rounding)
            ang = rng.uniform(0, 2 * np.pi)
            r2 = rng.uniform(0.05, 1.0)
            d = r + r2
            rows.append([[x + d * np.cos(ang), y + d * np.sin(ang), r2]])
        elif kind == 1:  # internally tangent
            ang = rng.uniform(0, 2 * np.pi)
            r2 = r * rng.uniform(0.2, 0.99)
            d = r - r2
            rows.append([[x + d * np.cos(ang), y + d * np.sin(ang), r2]])
        elif kind == 2:  # an exact copy
            rows.append([[x, y, r]])
        else:  # the same circle nudged by a few ulps
            rows.append([[np.nextafter(x, np.inf), y, np.nextafter(r, 0.0)]])
    _proofs(np.concatenate(rows))


def test_the_proof_covers_most_circles_of_a_crowded_picture():
    """Not vacuous: deep in a crowd, nearly every circle the exact computation finds
    covered is proven so, cheaply; and it proves none when the disks are apart."""
    rng = np.random.default_rng(7)
    proven = covered = 0
    for _ in range(20):
        p, c = _proofs(_picture(rng, 8, 16, 20, 0.6))
        proven += p
        covered += c
    assert covered > 500
    assert proven >= 0.8 * covered
    apart = np.array([[0.6 * k - 1.5, 0.0, 0.2] for k in range(6)])  # inside the limit disc
    assert _proofs(apart) == (0, 0)
