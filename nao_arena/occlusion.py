"""Occlusion: which bodies a robot can see past the bodies and walls in front of them.

Model (``sensing.occlusion``; world frame, m, rad). A robot senses from its centre o. A
body j (a disc of centre c_j, radius r_j) is *visible* when some ray from o reaches a
point of j before it reaches any other body or wall, that is, when the directions under
which j is seen (an interval of half-width asin(r_j / |c_j - o|) around the direction of
c_j) are not all covered by the directions of what stands in front of j. The occluders
are the other bodies within the sensing range (whether in the field of view or not) and
the walls, capsules of half-width ``wall_radius`` around their segments.

Two disjoint convex shapes seen from a point outside both are in the same order along
every ray that meets both, so "in front of j" is decided on one such ray, and each
occluder hides either all of its interval's overlap with j's or none of it. Tangent rays
do not count: j is hidden when the union of the closed intervals in front of it covers
j's closed interval, up to gaps narrower than :data:`SLIVER` (what rounding leaves where
two shadows, or a shadow and j's edge, meet on one tangent ray). Conventions for shapes
that are not disjoint: a body the observer overlaps, or that overlaps j, hides nothing
from it; a wall that holds the observer's centre or overlaps j hides nothing from it; a
body whose disc holds the observer's centre is visible.

:func:`visible` is compiled (numba, ``cache=True``); it is called only when a map or
the options turn occlusion on.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.kernels import point_segment_distance
from nao_arena.jit import inner_kernel, kernel

__all__ = ["SLIVER", "visible", "visible_witness"]

SLIVER = 1e-12
"""Widest gap (rad) between shadows that still counts as covered: a sliver that rounding
leaves where two shadows, or a shadow and the edge of the body, meet on one tangent ray."""


@inner_kernel
def _wrap(angle: float) -> float:
    """``angle`` (rad) wrapped into [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@inner_kernel
def _ray_disc(ox: float, oy: float, ux: float, uy: float, cx: float, cy: float, r: float) -> float:
    """Distance (m) along the unit ray o + t u, t >= 0, at which it first meets the disc
    (c, r); inf if it misses it. o is outside the disc."""
    px, py = cx - ox, cy - oy
    along = px * ux + py * uy
    across2 = (px * px + py * py) - along * along
    if along < 0.0 or across2 > r * r:
        return math.inf
    return along - math.sqrt(max(r * r - across2, 0.0))


@inner_kernel
def _ray_segment(
    ox: float, oy: float, ux: float, uy: float, ax: float, ay: float, bx: float, by: float
) -> float:
    """Distance (m) along the unit ray o + t u, t >= 0, at which it crosses the segment
    a-b; inf if it does not."""
    ex, ey = bx - ax, by - ay
    den = ux * ey - uy * ex
    if den == 0.0:
        return math.inf
    wx, wy = ax - ox, ay - oy
    t = (wx * ey - wy * ex) / den
    s = (wx * uy - wy * ux) / den
    if t < 0.0 or s < 0.0 or s > 1.0:
        return math.inf
    return t


@inner_kernel
def _ray_capsule(
    ox: float, oy: float, ux: float, uy: float, seg: NDArray[np.float64], h: float
) -> float:
    """Distance (m) along the unit ray o + t u at which it first meets the capsule of
    half-width h around the segment ``seg`` (2, 2); inf if it misses it. o is outside."""
    ax, ay, bx, by = seg[0, 0], seg[0, 1], seg[1, 0], seg[1, 1]
    best = min(_ray_disc(ox, oy, ux, uy, ax, ay, h), _ray_disc(ox, oy, ux, uy, bx, by, h))
    ex, ey = bx - ax, by - ay
    length = math.hypot(ex, ey)
    if length > 0.0:  # its two sides (with h = 0: the segment itself)
        nx, ny = -ey / length * h, ex / length * h
        for sign in (-1.0, 1.0):
            t = _ray_segment(
                ox, oy, ux, uy, ax + sign * nx, ay + sign * ny, bx + sign * nx, by + sign * ny
            )
            best = min(best, t)
    return best


@inner_kernel
def _disc_interval(ox: float, oy: float, cx: float, cy: float, r: float) -> tuple[float, float]:
    """(direction, half-width) in rad of the disc (c, r) seen from o outside it."""
    d = math.hypot(cx - ox, cy - oy)
    return math.atan2(cy - oy, cx - ox), math.asin(min(r / d, 1.0))


@inner_kernel
def _capsule_interval(
    ox: float, oy: float, seg: NDArray[np.float64], h: float, reference: float
) -> tuple[float, float]:
    """The directions (rad, relative to ``reference``, the interval's middle within pi of
    it) under which the capsule of half-width h around ``seg`` is seen from o outside it:
    the angular hull of its two end discs' intervals (the tangents from outside a capsule
    touch it at its end caps), less than pi wide."""
    centre0, half0 = _disc_interval(ox, oy, seg[0, 0], seg[0, 1], h)
    centre1, half1 = _disc_interval(ox, oy, seg[1, 0], seg[1, 1], h)
    d0 = _wrap(centre0 - reference)
    d1 = d0 + _wrap(centre1 - centre0)  # the second end next to the first (less than pi apart)
    lo = min(d0 - half0, d1 - half1)
    hi = max(d0 + half0, d1 + half1)
    shift = _wrap(0.5 * (lo + hi)) - 0.5 * (lo + hi)
    return lo + shift, hi + shift


@inner_kernel
def _covered(lows: NDArray[np.float64], highs: NDArray[np.float64], m: int, lo: float, hi: float):
    """(whether the first m closed intervals [lows, highs] (rad) cover [lo, hi] up to gaps
    of at most :data:`SLIVER` rad, the middle of the first wider gap if not, else NaN)."""
    order = np.argsort(lows[:m])
    reach = lo
    for q in order:
        if lows[q] > reach + SLIVER:
            return False, 0.5 * (reach + min(lows[q], hi))
        reach = max(reach, highs[q])
        if reach >= hi - SLIVER:
            return True, math.nan
    if reach >= hi - SLIVER:
        return True, math.nan
    return False, 0.5 * (reach + hi)


@kernel
def _witness(
    observer: int,
    target: int,
    candidates: NDArray[np.int64],
    positions: NDArray[np.float64],
    radii: NDArray[np.float64],
    walls: NDArray[np.float64],
    wall_radius: NDArray[np.float64],
    lows: NDArray[np.float64],
    highs: NDArray[np.float64],
) -> float:
    """A direction (rad, world frame) from the observer's centre under which ``target``
    is seen first, or NaN if it is hidden (see the module); ``candidates``: the bodies
    that may occlude it (the observer and the target among them are skipped). lows and
    highs: scratch of at least len(candidates) + len(walls)."""
    ox, oy = positions[observer, 0], positions[observer, 1]
    cx, cy = positions[target, 0], positions[target, 1]
    rj = radii[target]
    dj = math.hypot(cx - ox, cy - oy)
    phi = math.atan2(cy - oy, cx - ox)
    if dj <= rj:
        return phi
    half = math.asin(rj / dj)
    m = 0
    for k in candidates:
        if k == observer or k == target:
            continue
        kx, ky, rk = positions[k, 0], positions[k, 1], radii[k]
        dk = math.hypot(kx - ox, ky - oy)
        if dk <= rk + radii[observer] or math.hypot(kx - cx, ky - cy) < rk + rj:
            continue  # it overlaps the observer or the target: it hides nothing
        centre, width = _disc_interval(ox, oy, kx, ky, rk)
        mid = _wrap(centre - phi)
        lo, hi = mid - width, mid + width
        lo, hi = max(lo, -half), min(hi, half)
        if lo > hi:
            continue
        mid = phi + 0.5 * (lo + hi)
        ux, uy = math.cos(mid), math.sin(mid)
        if _ray_disc(ox, oy, ux, uy, kx, ky, rk) < _ray_disc(ox, oy, ux, uy, cx, cy, rj):
            lows[m], highs[m] = lo, hi
            m += 1
    for w in range(walls.shape[0]):
        h = wall_radius[w]
        ax, ay, bx, by = walls[w, 0, 0], walls[w, 0, 1], walls[w, 1, 0], walls[w, 1, 1]
        if (
            point_segment_distance(ox, oy, ax, ay, bx, by) <= h
            or point_segment_distance(cx, cy, ax, ay, bx, by) < h + rj
        ):
            continue  # it holds the observer's centre or overlaps the target: it hides nothing
        lo, hi = _capsule_interval(ox, oy, walls[w], h, phi)
        lo, hi = max(lo, -half), min(hi, half)
        if lo > hi:
            continue
        mid = phi + 0.5 * (lo + hi)
        ux, uy = math.cos(mid), math.sin(mid)
        if _ray_capsule(ox, oy, ux, uy, walls[w], h) < _ray_disc(ox, oy, ux, uy, cx, cy, rj):
            lows[m], highs[m] = lo, hi
            m += 1
    hidden, gap = _covered(lows, highs, m, -half, half)
    return math.nan if hidden else phi + gap


@kernel
def _visible_kernel(
    start, index, observers, occluders_start, occluders, positions, radii, walls, wall_radius
):  # noqa: E501
    keep = np.empty(index.shape[0], dtype=np.bool_)
    widest = 0
    for k in range(observers.shape[0]):
        widest = max(widest, occluders_start[k + 1] - occluders_start[k])
    lows = np.empty(widest + walls.shape[0])
    highs = np.empty(widest + walls.shape[0])
    for k in range(observers.shape[0]):
        near = occluders[occluders_start[k] : occluders_start[k + 1]]
        for e in range(start[k], start[k + 1]):
            direction = _witness(
                observers[k], index[e], near, positions, radii, walls, wall_radius, lows, highs
            )
            keep[e] = not math.isnan(direction)
    return keep


class Scene(NamedTuple):
    """What hides what, as the kernels take it: body centres (N, 2) m and radii (N,) m,
    wall segments (W, 2, 2) m and their half-widths (W,) m (contiguous float64)."""

    positions: NDArray[np.float64]
    radii: NDArray[np.float64]
    walls: NDArray[np.float64]
    wall_radius: NDArray[np.float64]

    @classmethod
    def of(
        cls,
        positions: NDArray[np.float64],
        radii: NDArray[np.float64],
        walls: NDArray[np.float64],
        wall_radius: NDArray[np.float64],
    ) -> Scene:
        """The arrays as contiguous float64 (walls as (W, 2, 2))."""
        f = np.ascontiguousarray
        return cls(
            f(positions, dtype=np.float64),
            f(radii, dtype=np.float64),
            f(walls, dtype=np.float64).reshape(-1, 2, 2),
            f(wall_radius, dtype=np.float64),
        )


def visible(
    start: NDArray[np.int64],
    index: NDArray[np.int64],
    observers: NDArray[np.int64],
    occluders_start: NDArray[np.int64],
    occluders: NDArray[np.int64],
    positions: NDArray[np.float64],
    radii: NDArray[np.float64],
    walls: NDArray[np.float64],
    wall_radius: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """Which entries of the CSR neighbour lists (``start`` (R + 1,), ``index`` (E,): the
    bodies observer k = body ``observers[k]`` senses are index[start[k]:start[k + 1]])
    are visible (see the module) past the bodies of observer k's CSR list of
    ``occluders`` (``occluders_start`` (R + 1,)) and the ``walls`` (W, 2, 2) m of
    half-width ``wall_radius`` (W,) m; body centres ``positions`` (N, 2) m, ``radii``
    (N,) m. Returns (E,) booleans."""
    f = np.ascontiguousarray
    scene = Scene.of(positions, radii, walls, wall_radius)
    keep = _visible_kernel(
        f(start, dtype=np.int64),
        f(index, dtype=np.int64),
        f(observers, dtype=np.int64),
        f(occluders_start, dtype=np.int64),
        f(occluders, dtype=np.int64),
        scene.positions,
        scene.radii,
        scene.walls,
        scene.wall_radius,
    )
    return np.asarray(keep, dtype=bool)


def visible_witness(
    observer: int,
    target: int,
    occluders: NDArray[np.int64],
    positions: NDArray[np.float64],
    radii: NDArray[np.float64],
    walls: NDArray[np.float64],
    wall_radius: NDArray[np.float64],
) -> float:
    """A direction (rad, world frame) from body ``observer``'s centre along which the ray
    meets body ``target`` before any of the bodies ``occluders`` and the walls (see
    :func:`visible`); NaN if ``target`` is hidden."""
    scene = Scene.of(positions, radii, walls, wall_radius)
    scratch = len(occluders) + len(scene.walls)
    near = np.ascontiguousarray(occluders, dtype=np.int64)
    lows, highs = np.empty(scratch), np.empty(scratch)
    return float(
        _witness(
            int(observer),
            int(target),
            near,
            scene.positions,
            scene.radii,
            scene.walls,
            scene.wall_radius,
            lows,
            highs,
        )
    )
