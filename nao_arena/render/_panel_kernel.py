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

Speed: a neighbour's exact clearance is computed only where the label depends on its
value. Decision scans (:func:`_below`, the admissibility scan of
:func:`~nao_arena.geometry._kernel.exact.scan_obstacle`, which prunes pieces and stops at
the first close one) settle whether a clearance lies below a level (0, a wall's
clearance, the least so far) by more than :data:`BAND` either way; only where two
obstacles' clearances come within BAND of each other or of 0, or where two neighbours
may both be the least, are exact clearances computed. Neighbours far from the robot's
path over every window of :data:`WINDOW` pieces are skipped first. A wall is measured
only where the path's bounding box meets the wall's box grown by its half-thickness.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from nao_arena.geometry.borrow import borrowed
from nao_arena.geometry.kernels import (
    Motion,
    candidate_setup,
    robot_state,
    scan_obstacle,
    segment_min_distance,
)
from nao_arena.jit import inner_kernel, kernel

__all__ = ["BAND", "panel_labels", "wall_clearances"]

BAND = 1e-6
"""Half-width (m) of the band around a level where the decision scans leave the comparison
to the exact clearance: far wider than the rounding of either."""

WINDOW = 8
"""Pieces per time window of the coarse prune: a neighbour is skipped at once where, in every
window, robot and neighbour stay farther apart than its radius + BAND."""

FREE = -1
WALLS = -2
NO, YES, UNSURE = 0, 1, 2
"""Answers of :func:`_below`."""


class Neighbours(NamedTuple):
    """The neighbours' paths (robot-relative), piece by piece: seg_t (S + 1,) s the pieces'
    ends, seg_c, seg_w, seg_b (N, S, 2) m, m/s, m/s^2 each piece's start, velocity and
    acceleration, sweep (N, S) m its :func:`~nao_arena.geometry._kernel.exact.piece_sweep`,
    and windows (N, ceil(S / WINDOW)) m (:func:`_windows`)."""

    seg_t: np.ndarray
    seg_c: np.ndarray
    seg_w: np.ndarray
    seg_b: np.ndarray
    sweep: np.ndarray
    windows: np.ndarray


class Scratch(NamedTuple):
    """The scratch arrays of :func:`_fill_labels` (N neighbours): cand (N,) int64 the
    candidate neighbours' indices, state (N,) int64 their :func:`_below` answers, upper
    (N,) m an upper bound on each one's clearance, and buf, out (3,) float64 the
    :func:`~nao_arena.geometry._kernel.exact.scan_obstacle` buffers (out[0]: a squared
    distance, m^2)."""

    cand: np.ndarray
    state: np.ndarray
    upper: np.ndarray
    buf: np.ndarray
    out: np.ndarray


@inner_kernel(error_model="numpy")
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


@inner_kernel(error_model="numpy")
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
        d = (
            segment_min_distance(
                vx,
                vy,
                ax,
                ay,
                v_max,
                walls[w, 0, 0],
                walls[w, 0, 1],
                walls[w, 1, 0],
                walls[w, 1, 1],
                horizon,
            )
            - grown[w]
        )
        if d < best:
            best = d
            if best < stop_below:
                break
    return best


@inner_kernel(error_model="numpy")
def _windows(seg_t, seg_c, sweep):
    """Per neighbour and window of :data:`WINDOW` pieces (N, ceil(S / WINDOW)): how far (m)
    the neighbour moves from its centre at the window's start within the window (the sum of
    its pieces' sweeps), inf for a window of infinite length."""
    N, S = sweep.shape
    out = np.zeros((N, (S + WINDOW - 1) // WINDOW))
    for n in range(N):
        for j in range(S):
            if math.isfinite(seg_t[j + 1] - seg_t[j]):
                out[n, j // WINDOW] += sweep[n, j]
            else:
                out[n, j // WINDOW] = math.inf
    return out


@inner_kernel(error_model="numpy")
def _out_of_reach(vx, vy, ax, ay, tau, bound, seg_t, seg_c, windows, n, reach):
    """Whether robot (speed at most bound m/s) and neighbour n stay farther apart than reach
    (m) in every window: their distance at the window's start less what both move within
    it (a cheap sound prune before the scan, which checks piece by piece)."""
    S = seg_c.shape[1]
    for i in range(windows.shape[1]):
        j0 = i * WINDOW
        j1 = min(j0 + WINDOW, S)
        h = seg_t[j1] - seg_t[j0]
        if not math.isfinite(h) or not math.isfinite(windows[n, i]):
            return False
        rax, ray, rvx, rvy, rpx, rpy = robot_state(vx, vy, ax, ay, tau, seg_t[j0])
        dx = rpx - seg_c[n, j0, 0]
        dy = rpy - seg_c[n, j0, 1]
        limit = (reach + windows[n, i] + bound * h) * (1.0 + 1e-9)
        if not dx * dx + dy * dy > limit * limit:
            return False
    return True


@inner_kernel(error_model="numpy")
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


@inner_kernel(error_model="numpy")
def wall_clearances(
    grid: np.ndarray,
    v: np.ndarray,
    v_max: float,
    horizon: float,
    walls: np.ndarray,
    grown: np.ndarray,
) -> np.ndarray:
    """Per acceleration of grid (G, 2) m/s^2 (velocity v (2,) m/s, speed limit v_max m/s):
    the least clearance (G,) m of the path over [0, horizon] s to the walls (W, 2, 2) m
    (robot-relative ends), distance minus grown (W,) m. Exact where negative; elsewhere a
    value >= 0 (inf where no wall comes within reach)."""
    boxes = _wall_boxes(walls, grown)
    out = np.empty(grid.shape[0])
    for k in range(grid.shape[0]):
        out[k] = _walls_least(
            v[0], v[1], grid[k, 0], grid[k, 1], v_max, horizon, walls, grown, boxes, -math.inf
        )
    return out


@inner_kernel(error_model="numpy")
def _below(cand, paths, n, r, level, buf, out):
    """Whether neighbour n's exact clearance (radius r m; paths :class:`Neighbours`) is
    below ``level`` (m) for the candidate ``cand``
    (:class:`~nao_arena.geometry.kernels.Motion`): :data:`YES`, :data:`NO`, or
    :data:`UNSURE` where it may lie within :data:`BAND` of level. out[0] then holds a
    squared distance (m^2) the path reaches (NO: unset)."""
    vx, vy, ax, ay, tau, bound = cand.vx, cand.vy, cand.ax, cand.ay, cand.tau, cand.bound
    seg_t, seg_c, seg_w, seg_b = paths.seg_t, paths.seg_c, paths.seg_w, paths.seg_b
    sweep, windows = paths.sweep, paths.windows
    outer = r + level + BAND
    if not outer > 0.0:
        return NO  # the clearance is at least -r
    if _out_of_reach(vx, vy, ax, ay, tau, bound, seg_t, seg_c, windows, n, outer):
        return NO
    if (
        scan_obstacle(
            Motion(vx, vy, ax, ay, tau, bound),
            seg_t,
            seg_c,
            seg_w,
            seg_b,
            sweep,
            n,
            r,
            level + BAND,
            False,
            buf,
            out,
        )
        < 0
    ):
        return NO  # never within r + level + BAND
    inner = r + level - BAND
    if inner > 0.0:
        if out[0] < inner * inner:
            return YES
        if (
            scan_obstacle(
                Motion(vx, vy, ax, ay, tau, bound),
                seg_t,
                seg_c,
                seg_w,
                seg_b,
                sweep,
                n,
                r,
                level - BAND,
                False,
                buf,
                out,
            )
            >= 0
        ):
            return YES  # within r + level - BAND
    return UNSURE


@inner_kernel(error_model="numpy")
def _exact(cand, paths, n, r, buf, out):
    """Neighbour n's exact clearance (m; radius r m, paths :class:`Neighbours`) for the
    candidate ``cand`` (:class:`~nao_arena.geometry.kernels.Motion`), as
    :func:`clearance_kernel` computes it."""
    vx, vy, ax, ay, tau, bound = cand.vx, cand.vy, cand.ax, cand.ay, cand.tau, cand.bound
    seg_t, seg_c, seg_w, seg_b = paths.seg_t, paths.seg_c, paths.seg_w, paths.seg_b
    sweep = paths.sweep
    scan_obstacle(
        Motion(vx, vy, ax, ay, tau, bound),
        seg_t,
        seg_c,
        seg_w,
        seg_b,
        sweep,
        n,
        r,
        math.inf,
        True,
        buf,
        out,
    )
    return math.sqrt(out[0]) - r


@kernel(error_model="numpy")
def panel_labels(
    grid: np.ndarray,
    v: np.ndarray,
    v_max: float,
    seg_t: np.ndarray,
    seg_c: np.ndarray,
    seg_w: np.ndarray,
    seg_b: np.ndarray,
    radius: np.ndarray,
    sweep: np.ndarray,
    walls: np.ndarray,
    grown: np.ndarray,
) -> np.ndarray:
    """Label (G,) of each acceleration of grid (G, 2) m/s^2 (see the module): -1 free, -2
    walls, n the neighbour n of the path (seg_t (S + 1,) s, seg_c, seg_w, seg_b (N, S, 2)
    m, m/s, m/s^2, robot-relative, radius (N,) m grown, sweep its
    :func:`~nao_arena.geometry._kernel.exact.piece_sweep`). Robot: velocity v (2,) m/s,
    speed limit v_max m/s. Walls (W, 2, 2) m robot-relative with grown half-thicknesses
    (W,) m, over the horizon seg_t[-1] s (W = 0: none)."""
    labels = np.empty(grid.shape[0], dtype=np.int64)
    N = seg_c.shape[0]
    _fill_labels(
        grid,
        v,
        v_max,
        Neighbours(seg_t, seg_c, seg_w, seg_b, sweep, _windows(seg_t, seg_c, sweep)),
        radius,
        walls,
        grown,
        _wall_boxes(walls, grown),
        Scratch(
            np.empty(N, dtype=np.int64),
            np.empty(N, dtype=np.int64),
            np.empty(N),
            np.empty(3),
            np.empty(3),
        ),
        labels,
    )
    return labels


@inner_kernel(error_model="numpy")
def _fill_labels(grid, v, v_max, paths, radius, walls, grown, boxes, scratch, labels):
    """:func:`panel_labels` into labels, with the neighbours' paths and :func:`_windows`
    (:class:`Neighbours`), the walls' boxes and scratch arrays (:class:`Scratch`). Arrays
    borrowed here.

    Per acceleration: the candidates are the neighbours whose clearance may be negative
    (:func:`_below` level 0), with an upper bound on it; where a wall's clearance W is
    negative, only those that may lie below W (else the walls win). One sure candidate
    left is the label; otherwise the exact clearance of the likeliest least, then of each
    other candidate that may lie below the least so far."""
    grid, v, radius = borrowed(grid), borrowed(v), borrowed(radius)
    paths = Neighbours(
        borrowed(paths.seg_t),
        borrowed(paths.seg_c),
        borrowed(paths.seg_w),
        borrowed(paths.seg_b),
        borrowed(paths.sweep),
        borrowed(paths.windows),
    )
    seg_t, seg_c = paths.seg_t, paths.seg_c
    walls, grown, boxes = borrowed(walls), borrowed(grown), borrowed(boxes)
    cand, state, upper = borrowed(scratch.cand), borrowed(scratch.state), borrowed(scratch.upper)
    buf, out, labels = borrowed(scratch.buf), borrowed(scratch.out), borrowed(labels)
    N = seg_c.shape[0]
    horizon = seg_t[-1]
    degenerate = not (horizon > seg_t[0])  # an empty horizon: the exact clearance decides
    for k in range(grid.shape[0]):
        ax = grid[k, 0]
        ay = grid[k, 1]
        vx, vy, tau, bound = candidate_setup(v[0], v[1], ax, ay, v_max, horizon)
        c_k = Motion(vx, vy, ax, ay, tau, bound)
        m = 0
        for n in range(N):
            s = UNSURE
            if not degenerate:
                s = _below(c_k, paths, n, radius[n], 0.0, buf, out)
            if s != NO:
                cand[m] = n
                state[m] = s
                upper[m] = math.sqrt(out[0]) - radius[n] if s != UNSURE else 0.0
                m += 1
        wall = math.inf
        if walls.shape[0]:
            wall = _walls_least(
                v[0], v[1], ax, ay, v_max, horizon, walls, grown, boxes, -math.inf if m else 0.0
            )
        if m and wall < 0.0:
            # only a neighbour at or below the walls' clearance can show
            kept = 0
            for i in range(m):
                n = cand[i]
                s = UNSURE
                if not degenerate:
                    s = _below(c_k, paths, n, radius[n], wall, buf, out)
                if s != NO:
                    cand[kept] = n
                    state[kept] = s
                    upper[kept] = upper[i]
                    kept += 1
            m = kept
        if m == 0:
            labels[k] = WALLS if wall < 0.0 else FREE
            continue
        if m == 1 and state[0] == YES:
            labels[k] = cand[0]  # below 0 and below the walls, the only one
            continue
        # exact clearances (first least, as numpy's argmin over all neighbours): the
        # likeliest least first, then the others that may lie below the least so far
        first = 0
        for i in range(1, m):
            if upper[i] < upper[first]:
                first = i
        owner = cand[first]
        best = _exact(c_k, paths, owner, radius[owner], buf, out)
        for i in range(m):
            n = cand[i]
            if i == first:
                continue
            if not degenerate and _below(c_k, paths, n, radius[n], best, buf, out) == NO:
                continue
            c = _exact(c_k, paths, n, radius[n], buf, out)
            if c < best or (c == best and n < owner):
                best = c
                owner = n
        label = owner if best < 0.0 else FREE
        if wall < 0.0 and wall < best:
            label = WALLS
        labels[k] = label
