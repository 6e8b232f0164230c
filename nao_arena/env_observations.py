"""The observation's bounds, its own and neighbour blocks (:func:`observation_rows`,
compiled) and its NAO block (see "Observation bounds" and "Observations" in
:mod:`nao_arena.environment`)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.env_options import NEIGHBOUR_FEATURES, OWN_FEATURES, EnvOptions
from nao_arena.geometry.clearance import path_clearance
from nao_arena.jit import kernel
from nao_arena.maps import Bounds
from nao_arena.obstacles import obstacle_paths
from nao_arena.predictors import get_predictor
from nao_arena.sensing import Neighbours
from nao_arena.world import World, WorldState

__all__ = ["ObservedRows", "nao_block", "observation_bounds", "observation_rows"]

_BOUND_SLACK = 1e-6
"""Relative widening of the observation bounds that rounding could otherwise cross."""


def observation_bounds(
    world: World,
    ctl: NDArray[np.intp],
    bounds: Bounds,
    options: EnvOptions,
    sensing_range: float,
    time_limit: float,
    lay: dict[str, slice],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lower and upper bounds (D,) of the observation entries (layout ``lay``) for the
    controlled robots' bodies ``ctl`` of ``world`` in a map of ``bounds`` (see "Observation
    bounds" in :mod:`nao_arena.environment`; sensing range m, time limit s); dynamic bounds
    widened by a relative _BOUND_SLACK."""
    wide = 1.0 + _BOUND_SLACK
    v_all, v_own = float(np.max(world.v_max)), float(np.max(world.v_max[ctl]))
    a_own = float(np.max(world.a_max[ctl]))
    r_all, r_own = float(np.max(world.radii)), float(np.max(world.radii[ctl]))
    lo, hi = np.array(bounds.min, dtype=float), np.array(bounds.max, dtype=float)
    if options.position_margin is not None:
        p_lo, p_hi = lo - options.position_margin, hi + options.position_margin
    elif bounds.walls:
        p_lo, p_hi = lo, hi
    else:
        p_lo, p_hi = np.full(2, -np.inf), np.full(2, np.inf)
    v, acc, dv = v_own * wide, 2.0 * v_own / world.dt * wide, (v_all + v_own) * wide
    own = {
        "goal_dx": ((lo[0] - p_hi[0]) * wide, (hi[0] - p_lo[0]) * wide),
        "goal_dy": ((lo[1] - p_hi[1]) * wide, (hi[1] - p_lo[1]) * wide),
        "vx": (-v, v),
        "vy": (-v, v),
        "ax": (-acc, acc),
        "ay": (-acc, acc),
        "cmd_ax": (-a_own * wide, a_own * wide),
        "cmd_ay": (-a_own * wide, a_own * wide),
        "a_max": (0.0, a_own),
        "v_max": (0.0, v_own),
        "radius": (0.0, r_own),
        "x": (p_lo[0], p_hi[0]),
        "y": (p_lo[1], p_hi[1]),
        "goal_x": (lo[0], hi[0]),
        "goal_y": (lo[1], hi[1]),
        "time_left": (0.0, time_limit),
    }
    reach = sensing_range * wide
    reach_xy = [reach if math.isfinite(reach) else p_hi[i] - p_lo[i] for i in (0, 1)]
    acc_all = 2.0 * v_all / world.dt * wide
    row = {
        "mask": (0.0, 1.0),
        "dx": (-reach_xy[0], reach_xy[0]),
        "dy": (-reach_xy[1], reach_xy[1]),
        "dvx": (-dv, dv),
        "dvy": (-dv, dv),
        "ax": (-acc_all, acc_all),
        "ay": (-acc_all, acc_all),
        "radius": (0.0, r_all),
        "is_traffic": (0.0, 1.0),
    }
    k = options.max_neighbours
    pairs = (
        [own[f] for f in OWN_FEATURES]
        + [row[f] for f in NEIGHBOUR_FEATURES] * k
        + [(-options.nao_clip, options.nao_clip)] * (lay["nao"].stop - lay["nao"].start)
        + [(0.0, 1.0)] * (lay["finished"].stop - lay["finished"].start)
    )
    out = np.array(pairs, dtype=np.float64).reshape(-1, 2)
    return out[:, 0].copy(), out[:, 1].copy()


def nao_block(
    state: WorldState,
    world: World,
    opts: EnvOptions,
    candidates: NDArray[np.float64],
    nearby_walls: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
    bodies: NDArray[np.intp],
    idx: NDArray[np.intp],
    present: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """Clipped clearance (m, M) of the candidate accelerations (M, 2, fractions of
    a_max) for each robot of ``bodies``, against its present neighbours ``idx[present]``
    (K per robot) and ``nearby_walls`` (segments (W, 2, 2) m, half-thicknesses (W,) m,
    or None) at ``state`` (see "Observations", ``nao``, in
    :mod:`nao_arena.environment`). ``state`` may hold rows of what the robots sense
    (:meth:`~nao_arena.arena.Arena.sensed`), with ``bodies`` and ``idx`` rows of it; the
    robots' own rows are their bodies' (their limits are read from ``world``)."""
    times = np.linspace(0.0, opts.nao_horizon, opts.nao_samples)
    flat = idx[present]
    predicted = np.zeros((0, len(times), 2))
    if len(flat):
        nb = Neighbours(
            ids=flat.astype(np.int64),
            kinds=tuple(state.kinds[i] for i in flat.tolist()),
            positions=state.positions[flat],
            velocities=state.velocities[flat],
            accelerations=state.accelerations[flat],
            radii=state.radii[flat],
        )
        predicted = get_predictor(opts.nao_predictor)(times, nb)
    counts = present.sum(axis=1)
    starts = np.concatenate([[0], np.cumsum(counts)])
    out = np.full((len(bodies), len(candidates)), opts.nao_clip)
    h = opts.nao_horizon
    for i, b in enumerate(bodies.tolist()):
        r_own = float(state.radii[b])
        a_max, v_max = float(world.a_max[b]), float(world.v_max[b])
        grow = r_own + opts.nao_margin
        walls, half = nearby_walls if nearby_walls is not None else (None, None)
        # the agent's obstacles, without its radius cut: the walls within reach
        path = obstacle_paths(
            times,
            predicted[starts[i] : starts[i + 1]],
            state.radii[flat[starts[i] : starts[i + 1]]] + grow,
            state.positions[b],
            walls,
            None if half is None else half + grow,
            v_max * h + 0.5 * a_max * h * h,
            cut=False,
        )
        if path.n_obstacles == 0:
            continue
        clear = path_clearance(candidates * a_max, state.velocities[b], path, v_max=v_max)
        out[i] = np.min(clear.clearance, axis=1)
    return np.clip(out, -opts.nao_clip, opts.nao_clip)


class ObservedRows(NamedTuple):
    """What :func:`observation_rows` reads besides the bodies' sensed state (world
    frame; m rows, N bodies): per row, bodies (m,) int64 the row's body index, goals
    (m, 2) m its goal and prev_cmd (m, 2) m/s^2 its last command; per body, is_traffic
    (N,) 1.0 for a body that is not a robot (traffic, people), else 0.0, and the limits
    a_max (N,) m/s^2 and v_max (N,) m/s."""

    bodies: NDArray[np.int64]
    goals: NDArray[np.float64]
    prev_cmd: NDArray[np.float64]
    is_traffic: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]


@kernel
def observation_rows(
    p: NDArray[np.float64],
    v: NDArray[np.float64],
    acc: NDArray[np.float64],
    rad: NDArray[np.float64],
    rows: ObservedRows,
    time_left: float,
    nb_start: NDArray[np.int64],
    nb_index: NDArray[np.int64],
    out: NDArray[np.float64],
    idx: NDArray[np.int64],
    present: NDArray[np.bool_],
) -> None:
    """Fill the own and neighbour blocks of ``out`` (m, D, zeroed) for the rows' robots
    (:class:`ObservedRows`; the bodies' positions p (N, 2) m, velocities v (N, 2) m/s,
    accelerations acc (N, 2) m/s^2 and radii rad (N,) m; time_left s) with the first K =
    idx.shape[1] neighbours of each in the lists ``nb_index[nb_start[i]:nb_start[i + 1]]``
    (:func:`~nao_arena.sensing.neighbour_lists`: nearest first; the robot itself, listed
    last with an infinite range, is skipped; absent rows stay zero); ``idx`` /
    ``present`` (m, K) get the neighbours' body indices and the row mask."""
    bodies, goals, prev_cmd = rows.bodies, rows.goals, rows.prev_cmd
    is_traffic, a_max, v_max = rows.is_traffic, rows.a_max, rows.v_max
    k = idx.shape[1]
    n_own = 16
    for i in range(bodies.shape[0]):
        b = bodies[i]
        o = out[i]
        o[0] = goals[i, 0] - p[b, 0]
        o[1] = goals[i, 1] - p[b, 1]
        o[2] = v[b, 0]
        o[3] = v[b, 1]
        o[4] = acc[b, 0]
        o[5] = acc[b, 1]
        o[6] = prev_cmd[i, 0]
        o[7] = prev_cmd[i, 1]
        o[8] = a_max[b]
        o[9] = v_max[b]
        o[10] = rad[b]
        o[11] = p[b, 0]
        o[12] = p[b, 1]
        o[13] = goals[i, 0]
        o[14] = goals[i, 1]
        o[15] = time_left
        r = 0
        for e in range(nb_start[i], nb_start[i + 1]):
            j = nb_index[e]
            if j == b or r == k:
                continue
            idx[i, r] = j
            present[i, r] = True
            c = n_own + 9 * r
            o[c] = 1.0
            o[c + 1] = p[j, 0] - p[b, 0]
            o[c + 2] = p[j, 1] - p[b, 1]
            o[c + 3] = v[j, 0] - v[b, 0]
            o[c + 4] = v[j, 1] - v[b, 1]
            o[c + 5] = acc[j, 0]
            o[c + 6] = acc[j, 1]
            o[c + 7] = rad[j]
            o[c + 8] = is_traffic[j]
            r += 1
