"""Batched admissibility: one acceleration per robot against sampled obstacle paths
(neighbours' predicted centres and walls), all robots in one compiled call. The inputs
travel in the world-frame bundles of :mod:`.bundles` (:class:`~.bundles.Predictions`,
:class:`~.bundles.IndexLists`, :class:`~.bundles.WorldWalls`, :class:`~.bundles.Robots`).
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry._kernel.bundles import Motion, Obstacles
from nao_arena.geometry._kernel.exact import candidate_setup, fill_sweep, robot_state, scan_obstacle
from nao_arena.geometry._kernel.sampled import RADIUS_CUT, moving_pieces
from nao_arena.geometry._kernel.segment import point_segment_dist2, segment_within
from nao_arena.geometry.borrow import borrowed
from nao_arena.jit import inner_kernel, kernel


@kernel(error_model="numpy")
def sampled_admissible_batch(predictions, neighbours, walls, wall_lists, rows, robots, acc, out):
    """Admissibility of one acceleration per robot against sampled obstacle paths.

    For each robot k of ``rows`` (the rows of the :class:`~.bundles.Robots` ``robots``:
    position pos[k] m, velocity vel[k] m/s, speed limit v_max[k] m/s, radius[k] m,
    margin[k] m; world frame): its obstacles are the bodies
    ``neighbours.indices[neighbours.start[k]:neighbours.start[k + 1]]`` (an
    :class:`~.bundles.IndexLists`) of the :class:`~.bundles.Predictions`, with
    world-frame centres pred[body] (T, 2) m at ``times`` (s, times[0] = 0, T >= 2),
    radii radius[body] + radius[k] + margin[k] (m), then the walls
    ``wall_lists.indices[wall_lists.start[k]:wall_lists.start[k + 1]]`` of the
    :class:`~.bundles.WorldWalls` (ends (M, 2, 2) m, world frame) with radii half (m,
    half-thicknesses) + radius[k] + margin[k], cut alike (see
    :func:`~nao_arena.geometry._kernel.segment.nearby_walls`). The paths are built exactly as
    :func:`~nao_arena.geometry.clearance.sampled_path` builds them from the
    robot-relative centres (a radius larger than the distance at t = 0 is cut to
    that distance times 1 - 1e-9), and acc[k] (m/s^2) is tested as
    :func:`admissible_kernel` tests it (margin 0). The predictions' excursion and
    finite: :func:`path_excursions` of ``pred``. out[k] = 1 admissible, 0 not, -1
    non-finite centres (left to the caller).
    """
    keep, kept, buf, res = admissible_scratch(predictions.times, neighbours.start, rows)
    _admissible_rows(
        predictions, neighbours, walls, wall_lists, rows, robots, acc, out, keep, kept, buf, res
    )


@inner_kernel(error_model="numpy")
def admissible_scratch(times, nb_start, rows):
    """The scratch arrays of :func:`admissible_row` for the robots ``rows`` of the
    neighbour lists ``nb_start`` (CSR starts) at the sample ``times`` (s): (keep, kept,
    buf, res), rows enough for the most obstacles any of them has (see
    :func:`_admissible_rows`)."""
    most = 0
    for k in rows:
        most = max(most, nb_start[k + 1] - nb_start[k])
    steps = times.shape[0] - 1
    kept = Obstacles(
        times,
        np.empty((most, steps, 2)),
        np.empty((most, steps, 2)),
        np.zeros((most, steps, 2)),
        np.empty(most),
        np.empty((most, steps)),
    )
    return np.empty(most, dtype=np.int64), kept, np.empty(3), np.empty(3)


@inner_kernel(error_model="numpy")
def _admissible_rows(
    predictions, neighbours, walls, wall_lists, rows, robots, acc, out, keep, kept, buf, res
):
    """:func:`sampled_admissible_batch` with its scratch arrays given: keep (rows enough
    for every robot's obstacles) int64, the indices of a robot's obstacles kept, and
    ``kept`` the :class:`~.bundles.Obstacles` they become (their pieces, cut radii and
    sweeps; as many rows; seg_b zero), buf and res (3,)."""
    acc, out, rows = borrowed(acc), borrowed(out), borrowed(rows)
    for k in rows:
        out[k] = admissible_row(
            predictions,
            neighbours,
            walls,
            wall_lists,
            k,
            robots,
            acc[k, 0],
            acc[k, 1],
            keep,
            kept,
            buf,
            res,
        )


@inner_kernel(error_model="numpy")
def admissible_row(
    predictions, neighbours, walls, wall_lists, k, robots, ax, ay, keep, kept, buf, res
):
    """What :func:`sampled_admissible_batch` says of robot k's acceleration (ax, ay)
    m/s^2: 1 admissible, 0 not, -1 non-finite centres (scratch arrays as
    :func:`_admissible_rows` takes them). Arrays borrowed here."""
    times, pred, nb_radius, excursion, finite_path = predictions
    nb_start, nb_index = neighbours
    wall_seg, wall_half = walls
    wall_start, wall_index = wall_lists
    pos, vel, v_max, radius, margin = robots
    _, c, w, b, keep_r, sweep = kept
    times, pred = borrowed(times), borrowed(pred)
    nb_start, nb_index = borrowed(nb_start), borrowed(nb_index)
    nb_radius, wall_seg, wall_half = borrowed(nb_radius), borrowed(wall_seg), borrowed(wall_half)
    wall_start, wall_index = borrowed(wall_start), borrowed(wall_index)
    pos, vel, v_max = borrowed(pos), borrowed(vel), borrowed(v_max)
    radius, margin, excursion = borrowed(radius), borrowed(margin), borrowed(excursion)
    finite_path = borrowed(finite_path)
    keep, keep_r = borrowed(keep), borrowed(keep_r)
    c, w, b, sweep = borrowed(c), borrowed(w), borrowed(b), borrowed(sweep)
    buf, res = borrowed(buf), borrowed(res)
    horizon = times[-1]
    n_nb = nb_start[k + 1] - nb_start[k]
    n_w = wall_start[k + 1] - wall_start[k]
    vx, vy, tau, bound = candidate_setup(vel[k, 0], vel[k, 1], ax, ay, v_max[k], horizon)
    motion = Motion(vx, vy, ax, ay, tau, bound)
    px = pos[k, 0]
    py = pos[k, 1]
    # skip the obstacles that stay far: |x(t)| <= bound t for the robot (and it stays
    # within bound * horizon / 2 of where it is halfway), and a sampled path stays
    # within its largest sample excursion from its start
    travel = bound * horizon
    _, _, _, _, mx, my = robot_state(vx, vy, ax, ay, tau, 0.5 * horizon)
    half = 0.5 * travel
    n = np.int64(0)
    for i in range(n_nb):
        body = nb_index[nb_start[k] + i]
        x0 = pred[body, 0, 0] - px
        y0 = pred[body, 0, 1] - py
        r = min(nb_radius[body] + radius[k] + margin[k], math.sqrt(x0 * x0 + y0 * y0) * RADIUS_CUT)
        if not finite_path[body]:
            return -1
        ex = excursion[body]
        gap = (
            max(
                math.sqrt(x0 * x0 + y0 * y0) - travel,
                math.sqrt((x0 - mx) ** 2 + (y0 - my) ** 2) - half,
            )
            - ex
        )
        if gap > (r + 1e-9) * (1.0 + 1e-9):
            continue
        keep[n] = i
        keep_r[n] = r
        n += 1
    for i in range(n_w):
        d = wall_index[wall_start[k] + i]
        ax0 = wall_seg[d, 0, 0] - px
        ay0 = wall_seg[d, 0, 1] - py
        bx0 = wall_seg[d, 1, 0] - px
        by0 = wall_seg[d, 1, 1] - py
        r = min(
            wall_half[d] + (radius[k] + margin[k]),
            math.sqrt(point_segment_dist2(ax0, ay0, bx0, by0)) * RADIUS_CUT,
        )
        if segment_within(motion, travel, horizon, ax0, ay0, bx0, by0, r, buf, res):
            return 0
    if n == 0:
        return 1
    for q in range(n):
        moving_pieces(pred, nb_index[nb_start[k] + keep[q]], px, py, times, c, w, q)
    fill_sweep(times, w, b, n, sweep)
    for q in range(n):
        scan_obstacle(
            motion,
            times,
            c,
            w,
            b,
            sweep,
            q,
            keep_r[q],
            0.0,
            False,
            buf,
            res,
        )
        if res[0] < (keep_r[q] + 0.0) ** 2:
            return 0
    return 1
