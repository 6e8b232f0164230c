"""Piecewise paths of sampled obstacle centres, built inside the compiled loops.

A body's predicted centres (T, 2) m at the sample times become linear pieces
(start centre m, velocity m/s; no acceleration); a disc at rest becomes pieces
with zero velocity.
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.jit import inner_kernel, kernel


@inner_kernel(error_model="numpy")
def moving_pieces(pred, body, px, py, times, c, w, row):
    """Write into c, w [row] the pieces of body's sampled centres pred[body] (T, 2) m,
    relative to (px, py): start centres (m) and velocities (m/s), as
    :func:`~nao_arena.geometry.clearance.sampled_path` builds them."""
    for j in range(times.shape[0] - 1):
        moving_piece(pred, body, px, py, times, c, w, row, j)


@inner_kernel(error_model="numpy")
def moving_piece(pred, body, px, py, times, c, w, row, j):
    """Piece j of :func:`moving_pieces` into c, w [row, j]; returns it: (start centre m,
    velocity m/s)."""
    x0 = pred[body, j, 0] - px
    y0 = pred[body, j, 1] - py
    h = times[j + 1] - times[j]
    wx = (pred[body, j + 1, 0] - px - x0) / h
    wy = (pred[body, j + 1, 1] - py - y0) / h
    c[row, j, 0] = x0
    c[row, j, 1] = y0
    w[row, j, 0] = wx
    w[row, j, 1] = wy
    return x0, y0, wx, wy


@inner_kernel(error_model="numpy")
def static_pieces(x0, y0, times, c, w, row):
    """Write into c, w [row] the pieces of a disc at rest at (x0, y0) m (robot-relative),
    as :func:`~nao_arena.geometry.clearance.sampled_path` builds them."""
    for j in range(times.shape[0] - 1):
        dt = times[j + 1] - times[j]
        c[row, j, 0] = x0
        c[row, j, 1] = y0
        w[row, j, 0] = (x0 - x0) / dt
        w[row, j, 1] = (y0 - y0) / dt


# An obstacle already closer than its grown radius counts with (just under) its current
# distance: the robot may not close in further but may move away (see agents/nao.py).
RADIUS_CUT = 1.0 - 1e-9


@kernel(error_model="numpy")
def path_excursions(pred):
    """Per body of ``pred`` (n, T, 2) m: the largest distance (m) of a sampled centre from
    the first one, and whether all its centres are finite."""
    n = pred.shape[0]
    T = pred.shape[1]
    excursion = np.zeros(n)
    finite = np.ones(n, dtype=np.bool_)
    for body in range(n):
        ex = 0.0
        for j in range(1, T):
            dx = pred[body, j, 0] - pred[body, 0, 0]
            dy = pred[body, j, 1] - pred[body, 0, 1]
            e2 = dx * dx + dy * dy
            if not math.isfinite(e2):
                finite[body] = False
            elif e2 > ex:
                ex = e2
        if not (math.isfinite(pred[body, 0, 0]) and math.isfinite(pred[body, 0, 1])):
            finite[body] = False
        excursion[body] = math.sqrt(ex)
    return excursion, finite
