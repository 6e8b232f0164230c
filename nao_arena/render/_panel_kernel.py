"""Compiled labels of the viewer's acceleration panel: which obstacle each grid
acceleration runs into within the horizon.

Frame and model as in :mod:`nao_arena.geometry._kernel.exact`: the robot starts at
the origin at t = 0 with velocity v (m/s, clamped to v_max), keeps the constant
acceleration a (m/s^2) until its speed reaches v_max and then its velocity.

Label of a grid acceleration: -1 free; n >= 0 the neighbour n with the least exact
clearance (:func:`~nao_arena.geometry._kernel.exact.clearance_kernel`, the values of
:func:`nao_arena.geometry.path_clearance` bit for bit) when that clearance is
negative; -2 the walls when the least wall clearance (exact distance of the path to
the segment, :func:`~nao_arena.geometry._kernel.segment.segment_min_distance`, minus
the grown half-thickness) is negative and below the neighbours' least clearance.

Speed: the exact clearance of a neighbour is needed only where the label depends on
its value. A decision scan first settles, per neighbour, whether the path comes
within its radius + :data:`BAND` (no: clearance >= 0 for sure) and, if so, within
its radius - :data:`BAND` (yes: clearance < 0 for sure); only accelerations that
collide with two or more neighbours, or with a neighbour and a wall, or that fall in
that band of a neighbour, get the exact clearances. A wall is measured only where the
path's bounding box meets the wall's box grown by its half-thickness.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nao_arena.geometry._kernel.exact import candidate_setup, scan_obstacle
from nao_arena.geometry._kernel.segment import segment_min_distance
from nao_arena.geometry.borrow import borrowed

__all__ = ["BAND", "panel_labels", "wall_clearances"]

BAND = 1e-6
"""Half-width (m) of the band around a neighbour's radius where the decision scan leaves
the answer to the exact clearance: far wider than the rounding of either."""

FREE = -1
WALLS = -2


@njit(cache=True, error_model="numpy", inline="always")
def _extent(v, a, tau, horizon):
    """Least and greatest value of one coordinate of the path (m) over t in [0, horizon]
    (finite): v t + a t^2 / 2 up to tau, then straight on."""
    t1 = min(tau, horizon)
    x1 = v * t1 + 0.5 * a * t1 * t1
    lo = min(0.0, x1)
    hi = max(0.0, x1)
    if a != 0.0:
        ts = -v / a
        if 0.0 < ts < t1:
            xs = v * ts + 0.5 * a * ts * ts
            lo = min(lo, xs)
            hi = max(hi, xs)
    if tau < horizon:
        x2 = x1 + (v + a * tau) * (horizon - tau)
        lo = min(lo, x2)
        hi = max(hi, x2)
    return lo, hi


@njit(cache=True, error_model="numpy", inline="always")
def _walls_least(vx, vy, ax, ay, v_max, horizon, walls, grown, boxes, stop_below):
    """Least over the walls (W, 2, 2) m of (exact distance from the path to the wall minus
    grown (W,) m), measuring only the walls whose grown boxes (W, 4) (x lo, x hi, y lo,
    y hi) m meet the path's bounding box (others: farther than grown); inf when none
    does. Stops at the first value below ``stop_below`` (m)."""
    cx, cy, tau, bound = candidate_setup(vx, vy, ax, ay, v_max, horizon)
    best = math.inf
    if not math.isfinite(horizon):
        xlo, xhi, ylo, yhi = -math.inf, math.inf, -math.inf, math.inf
    else:
        xlo, xhi = _extent(cx, ax, tau, horizon)
        ylo, yhi = _extent(cy, ay, tau, horizon)
        # slack: the rounding of the box against that of the exact distances
        pad = 1e-9 * (1.0 + bound * horizon + (abs(ax) + abs(ay)) * horizon * horizon)
        xlo -= pad
        xhi += pad
        ylo -= pad
        yhi += pad
    for w in range(walls.shape[0]):
        if xhi < boxes[w, 0] or xlo > boxes[w, 1] or yhi < boxes[w, 2] or ylo > boxes[w, 3]:
            continue
        d = segment_min_distance(vx, vy, ax, ay, v_max, walls[w, 0, 0], walls[w, 0, 1],
                                 walls[w, 1, 0], walls[w, 1, 1], horizon) - grown[w]
        if d < best:
            best = d
            if best < stop_below:
                break
    return best


@njit(cache=True, error_model="numpy")
def _wall_boxes(walls, grown):
    """Per wall (W, 2, 2) m: its box grown by grown (W,) m and a little slack (W, 4)."""
    boxes = np.empty((walls.shape[0], 4))
    for w in range(walls.shape[0]):
        r = grown[w] + 1e-9 * (1.0 + abs(grown[w]))
        for c in range(2):
            lo = min(walls[w, 0, c], walls[w, 1, c])
            hi = max(walls[w, 0, c], walls[w, 1, c])
            pad = r + 1e-9 * (abs(lo) + abs(hi))
            boxes[w, 2 * c] = lo - pad
            boxes[w, 2 * c + 1] = hi + pad
    return boxes


@njit(cache=True, error_model="numpy")
def wall_clearances(grid: np.ndarray, v: np.ndarray, v_max: float, horizon: float,
                    walls: np.ndarray, grown: np.ndarray) -> np.ndarray:
    """Per acceleration of grid (G, 2) m/s^2 (velocity v (2,) m/s, speed limit v_max m/s):
    the least clearance (G,) m of the path over [0, horizon] s to the walls (W, 2, 2) m
    (robot-relative ends), distance minus grown (W,) m. Exact where negative; elsewhere a
    value >= 0 (inf where no wall comes within reach)."""
    boxes = _wall_boxes(walls, grown)
    out = np.empty(grid.shape[0])
    for k in range(grid.shape[0]):
        out[k] = _walls_least(v[0], v[1], grid[k, 0], grid[k, 1], v_max, horizon, walls,
                              grown, boxes, -math.inf)
    return out


@njit(cache=True, error_model="numpy")
def panel_labels(grid: np.ndarray, v: np.ndarray, v_max: float, seg_t: np.ndarray,
                 seg_c: np.ndarray, seg_w: np.ndarray, seg_b: np.ndarray, radius: np.ndarray,
                 sweep: np.ndarray, walls: np.ndarray, grown: np.ndarray) -> np.ndarray:
    """Label (G,) of each acceleration of grid (G, 2) m/s^2 (see the module): -1 free, -2
    walls, n the neighbour n of the path (seg_t (S + 1,) s, seg_c, seg_w, seg_b (N, S, 2)
    m, m/s, m/s^2, robot-relative, radius (N,) m grown, sweep its
    :func:`~nao_arena.geometry._kernel.exact.piece_sweep`). Robot: velocity v (2,) m/s,
    speed limit v_max m/s. Walls (W, 2, 2) m robot-relative with grown half-thicknesses
    (W,) m, over the horizon seg_t[-1] s (W = 0: none)."""
    labels = np.empty(grid.shape[0], dtype=np.int64)
    _fill_labels(grid, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep, walls, grown,
                 _wall_boxes(walls, grown), np.empty(seg_c.shape[0], dtype=np.int64),
                 np.empty(3), np.empty(3), labels)
    return labels


@njit(cache=True, error_model="numpy")
def _fill_labels(grid, v, v_max, seg_t, seg_c, seg_w, seg_b, radius, sweep, walls, grown, boxes,
                 hit, buf, out, labels):
    """:func:`panel_labels` into labels, with its scratch arrays (hit (N,) ints, buf and
    out (3,)). Arrays borrowed here."""
    grid, v, seg_t, seg_c = borrowed(grid), borrowed(v), borrowed(seg_t), borrowed(seg_c)
    seg_w, seg_b, radius, sweep = borrowed(seg_w), borrowed(seg_b), borrowed(radius), \
        borrowed(sweep)
    walls, grown, boxes = borrowed(walls), borrowed(grown), borrowed(boxes)
    hit, buf, out, labels = borrowed(hit), borrowed(buf), borrowed(out), borrowed(labels)
    N = seg_c.shape[0]
    horizon = seg_t[-1]
    degenerate = not (horizon > seg_t[0])  # an empty horizon: the exact clearance decides
    for k in range(grid.shape[0]):
        ax = grid[k, 0]
        ay = grid[k, 1]
        vx, vy, tau, bound = candidate_setup(v[0], v[1], ax, ay, v_max, horizon)
        n_hit = 0
        n_sure = 0
        for n in range(N):
            r = radius[n]
            if not degenerate and scan_obstacle(vx, vy, ax, ay, tau, bound, seg_t, seg_c,
                                                seg_w, seg_b, sweep, n, r, BAND, False, buf,
                                                out) < 0:
                continue  # never within r + BAND: clearance >= 0
            hit[n_hit] = n
            n_hit += 1
            inner = r - BAND
            if degenerate or inner <= 0.0:
                continue
            if out[0] < inner * inner or scan_obstacle(
                    vx, vy, ax, ay, tau, bound, seg_t, seg_c, seg_w, seg_b, sweep, n, r, -BAND,
                    False, buf, out) >= 0:
                n_sure += 1  # within r - BAND: clearance < 0
        wall = math.inf
        if walls.shape[0]:
            wall = _walls_least(v[0], v[1], ax, ay, v_max, horizon, walls, grown, boxes,
                                -math.inf if n_hit else 0.0)
        if n_hit == 0:
            labels[k] = WALLS if wall < 0.0 else FREE
            continue
        if n_hit == 1 and n_sure == 1 and not wall < 0.0:
            labels[k] = hit[0]
            continue
        # the exact clearances, as clearance_kernel computes them, and their first least
        best = math.inf
        owner = FREE
        for i in range(n_hit):
            n = hit[i]
            scan_obstacle(vx, vy, ax, ay, tau, bound, seg_t, seg_c, seg_w, seg_b, sweep, n,
                          radius[n], math.inf, True, buf, out)
            c = math.sqrt(out[0]) - radius[n]
            if c < best or owner == FREE:
                best = c
                owner = n
        label = owner if best < 0.0 else FREE
        if wall < 0.0 and wall < best:
            label = WALLS
        labels[k] = label
