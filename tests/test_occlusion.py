"""Occlusion (nao_arena.occlusion) against rays cast by an independent numpy model.

The model casts rays from the observer's centre and finds where each first meets a disc
(the quadratic's smaller root) or a wall's capsule (its two end discs and the four edges
of its rectangle, as a polygon): the target is visible along a ray that meets it before
every occluder. The kernel's answer is checked both ways: a visible target's witness
direction is such a ray, and no ray of a fine fan over a hidden target's directions is.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from nao_arena.occlusion import visible, visible_witness

FAN = 2001  # rays over the target's directions for the hidden check


def _ray_discs(o, u, centres, radii):
    """(rays, discs): distance along each unit ray u (rays, 2) from o to its first point
    in each disc; inf where it misses."""
    p = centres[None, :, :] - o[None, None, :]
    b = np.einsum("rk,rdk->rd", u, np.broadcast_to(p, (len(u), *p.shape[1:])))
    c = np.sum(p * p, axis=2) - radii[None, :] ** 2
    disc = b * b - c
    t = b - np.sqrt(np.maximum(disc, 0.0))
    return np.where((disc >= 0.0) & (t >= 0.0), t, np.inf)


def _ray_edges(o, u, a, b):
    """(rays, edges): distance along each ray to the segment a[e]-b[e]; inf if missed."""
    e = b - a
    w = a[None, :, :] - o[None, None, :]
    den = u[:, None, 0] * e[None, :, 1] - u[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / den
        s = (w[..., 0] * u[:, None, 1] - w[..., 1] * u[:, None, 0]) / den
    ok = (den != 0.0) & (t >= 0.0) & (s >= 0.0) & (s <= 1.0)
    return np.where(ok, t, np.inf)


def _ray_capsules(o, u, walls, half):
    """(rays, walls): distance along each ray to each capsule (end discs and rectangle)."""
    if len(walls) == 0:
        return np.zeros((len(u), 0))
    ends = _ray_discs(o, u, walls.reshape(-1, 2), np.repeat(half, 2)).reshape(len(u), -1, 2)
    best = ends.min(axis=2)
    d = walls[:, 1] - walls[:, 0]
    n = np.stack([-d[:, 1], d[:, 0]], axis=1)
    length = np.hypot(d[:, 0], d[:, 1])
    n = n / np.where(length > 0, length, 1.0)[:, None] * half[:, None]
    corners = [walls[:, 0] + n, walls[:, 1] + n, walls[:, 1] - n, walls[:, 0] - n]
    for i in range(4):
        best = np.minimum(best, _ray_edges(o, u, corners[i], corners[(i + 1) % 4]))
    return best


def _first_to_target(o, angles, target, occluders, walls, half):
    """Per ray direction (rad): whether it meets the target (centre, radius) first."""
    u = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    tj = _ray_discs(o, u, target[0][None], np.array([target[1]]))[:, 0]
    others = np.concatenate(
        [
            _ray_discs(o, u, occluders[0], occluders[1]).reshape(len(u), -1),
            _ray_capsules(o, u, walls, half),
        ],
        axis=1,
    )
    return np.isfinite(tj) & np.all(tj[:, None] < others, axis=1)


def _point_segment(p, seg):
    d = seg[1] - seg[0]
    t = np.clip(np.dot(p - seg[0], d) / max(np.dot(d, d), 1e-300), 0.0, 1.0)
    return float(np.hypot(*(p - seg[0] - t * d)))


BOUNDARY = 1e-9
"""m: how close to a convention's threshold a distance is taken as on it."""


def _on_a_boundary(positions, radii, walls, half) -> bool:
    """Whether a distance the module's conventions compare with a threshold (an
    occluder that overlaps the observer or the target is not counted) equals it within
    rounding: there the kernel and the model of these tests may round to opposite
    sides, as for an observer on a wall of no width (a distance of 0 against 3e-18)."""
    o, c, r = positions[0], positions[1], radii[1]
    discs = [
        (math.hypot(*(positions[k] - o)), radii[k] + radii[0]) for k in range(2, len(positions))
    ] + [(math.hypot(*(positions[k] - c)), radii[k] + r) for k in range(2, len(positions))]
    segments = [(_point_segment(o, walls[w]), half[w]) for w in range(len(walls))] + [
        (_point_segment(c, walls[w]), half[w] + r) for w in range(len(walls))
    ]
    return any(abs(dist - limit) <= BOUNDARY for dist, limit in discs + segments)


def _check(positions, radii, walls, half):
    """Body 0 observes body 1 past bodies 2.. and the walls: the kernel against rays."""
    n = len(positions)
    direction = visible_witness(0, 1, np.arange(n), positions, radii, walls, half)
    o, c, r = positions[0], positions[1], radii[1]
    d = math.hypot(*(c - o))
    if d <= r:
        assert not math.isnan(direction)
        return
    # the occluders the model counts (the module's conventions)
    mine = [
        k
        for k in range(2, n)
        if math.hypot(*(positions[k] - o)) > radii[k] + radii[0]
        and math.hypot(*(positions[k] - c)) >= radii[k] + r
    ]
    kept = [
        w
        for w in range(len(walls))
        if _point_segment(o, walls[w]) > half[w] and _point_segment(c, walls[w]) >= half[w] + r
    ]
    occ = (positions[mine].reshape(-1, 2), radii[mine])
    phi, width = math.atan2(c[1] - o[1], c[0] - o[0]), math.asin(r / d)
    if math.isnan(direction):
        fan = phi + np.linspace(-width, width, FAN)[1:-1]
        seen = _first_to_target(o, fan, (c, r), occ, walls[kept], half[kept])
        assert not seen.any(), f"hidden, yet seen along {fan[seen][:3]}"
    else:
        assert abs(math.remainder(direction - phi, math.tau)) <= width + 1e-12
        assert _first_to_target(o, np.array([direction]), (c, r), occ, walls[kept], half[kept])[
            0
        ], "the witness ray does not meet the target first"
    # the CSR wrapper gives the same answer
    keep = visible(
        np.array([0, 1]),
        np.array([1]),
        np.array([0]),
        np.array([0, n]),
        np.arange(n),
        positions,
        radii,
        walls,
        half,
    )
    assert keep.tolist() == [not math.isnan(direction)]


coordinate = st.floats(-6.0, 6.0, allow_nan=False)
point = st.tuples(coordinate, coordinate)


@given(
    st.lists(st.tuples(point, st.floats(0.05, 1.5)), min_size=2, max_size=9),
    st.lists(st.tuples(point, point, st.floats(0.0, 0.4)), max_size=3),
)
@settings(max_examples=300, deadline=None)
def test_the_kernel_agrees_with_cast_rays(bodies, wall_list):
    positions = np.array([b[0] for b in bodies], dtype=float)
    radii = np.array([b[1] for b in bodies], dtype=float)
    walls = np.array([[a, b] for a, b, _ in wall_list], dtype=float).reshape(-1, 2, 2)
    half = np.array([h for _, _, h in wall_list], dtype=float)
    assume(all(math.hypot(*(w[1] - w[0])) > 1e-3 for w in walls))
    assume(not _on_a_boundary(positions, radii, walls, half))
    _check(positions, radii, walls, half)


@pytest.mark.parametrize(
    ("positions", "radii", "walls", "seen"),
    [
        # a larger body right in front hides a smaller one behind it
        ([(0, 0), (4, 0), (2, 0)], [0.3, 0.3, 0.5], [], False),
        # beside it, not behind it: seen
        ([(0, 0), (4, 1.5), (2, 0)], [0.3, 0.3, 0.5], [], True),
        # the same body behind the target hides nothing
        ([(0, 0), (2, 0), (4, 0)], [0.3, 0.3, 0.5], [], True),
        # two bodies side by side cover it where one alone does not
        ([(0, 0), (6, 0), (2, 0.3)], [0.3, 0.5, 0.3], [], True),
        ([(0, 0), (6, 0), (2, 0.3), (2, -0.3)], [0.3, 0.5, 0.3, 0.3], [], False),
        # a wall between them hides it; a wall beside them does not
        ([(0, 0), (4, 0)], [0.3, 0.3], [((2, -3), (2, 3))], False),
        ([(0, 0), (4, 0)], [0.3, 0.3], [((2, 1), (2, 3))], True),
        # a body overlapping the target hides nothing from it; touching it, it does
        ([(0, 0), (4, 0), (3.35, 0)], [0.3, 0.3, 0.4], [], True),
        ([(0, 0), (4, 0), (3.25, 0)], [0.3, 0.3, 0.45], [], False),
        # an observer within a wall's width does not count that wall
        ([(0, 0.03125), (0, 2)], [1.0, 1.0], [((0, 0), (0, 0.05))], True),
    ],
)
def test_scenes_with_a_known_answer(positions, radii, walls, seen):
    positions = np.array(positions, dtype=float)
    radii = np.array(radii, dtype=float)
    walls = np.array(walls, dtype=float).reshape(-1, 2, 2)
    half = np.full(len(walls), 0.1)
    direction = visible_witness(0, 1, np.arange(len(positions)), positions, radii, walls, half)
    assert (not math.isnan(direction)) == seen
    _check(positions, radii, walls, half)
