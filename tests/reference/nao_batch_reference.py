"""Reference for the ``nao`` agents' batch step: the step as it ran before its
bookkeeping was fused into the compiled calls of :mod:`nao_arena.agents._nao_batch`
(numpy glue between the same kernels; the heading targets and the robot-by-robot
path, which were not fused, are the agent's own), for the tests that check the
fused step bit for bit."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from nao_arena.agents._kernel_inputs import wall_segments
from nao_arena.agents._nao_columns import (
    CUR_X,
    CUR_Y,
    DETOUR,
    NO_SELECTION,
    REPLAN,
    STATUS,
    STOPPING,
    V_PREF,
    YIELDED,
    AgentColumns,
    columns_of,
    liveness_batch,
)
from nao_arena.agents._nao_decide import apply_braking, apply_decisions
from nao_arena.agents._nao_liveness import held_by_standing_kernel
from nao_arena.agents._nao_per_robot import robust, undecided
from nao_arena.agents._nao_step import (
    RobotRows,
    decide_members,
    group_view,
    heading_targets,
    keep_current,
    members,
    traffic_mask,
)
from nao_arena.agents.goal import goal_seeking_accels
from nao_arena.agents.nao import PLAN_MARGIN
from nao_arena.sensing import SensingBatch
from nao_arena.stopping import commit_plans


def act_rows_reference(
    agents: Sequence, batch: SensingBatch, rows_a: NDArray[np.int64]
) -> tuple[NDArray[np.float64], dict]:
    """The former ``_act_rows``: accelerations (n, 2) m/s^2 and errors by agent."""
    n = len(rows_a)
    cols = columns_of(agents)
    real, whole = cols.real, cols.whole
    errors: dict[int, Exception] = {}
    bodies = batch.bodies[rows_a]
    pos, vel, rad = batch.positions[bodies], batch.velocities[bodies], batch.radii[bodies]
    a_max, v_max = batch.a_max[bodies], batch.v_max[bodies]
    goals = batch.goals[rows_a]
    live = (whole[:, REPLAN] != 0) | (whole[:, STATUS] == NO_SELECTION)
    out = real[:, CUR_X : CUR_Y + 1].copy()
    if not live.any():
        return out, errors
    held = np.zeros(n, dtype=np.bool_)
    f = np.ascontiguousarray
    held_by_standing_kernel(
        f(batch.nb_start),
        f(batch.nb_index),
        f(rows_a),
        f(batch.bodies),
        f(batch.positions),
        f(batch.velocities),
        f(batch.radii),
        f(rad),
        f(goals),
        held,
    )
    turn = np.empty(n, dtype=np.bool_)
    liveness_batch(
        live,
        f(pos),
        f(vel),
        f(goals),
        f(rad),
        f(v_max),
        held,
        float(batch.dt),
        real,
        whole,
        cols.opt,
        turn,
    )
    for i in np.flatnonzero(turn).tolist():
        agents[i]._turn_detour()
    desired = _desired_reference(cols, batch, rows_a, goals, pos, vel, a_max, v_max)
    traffic_near = _traffic_near_reference(batch, rows_a, cols)
    own = RobotRows(pos, vel, rad, a_max, v_max, traffic_near)
    current = real[:, CUR_X : CUR_Y + 1].copy()
    cols.seen = []
    for group in cols.grid_groups(agents):
        m = group[live[group]]
        if not len(m):
            continue
        ag0 = agents[int(m[0])]
        try:
            pred = f(ag0.predict(ag0.times, batch.everyone()), dtype=np.float64)
        except Exception as exc:  # noqa: BLE001
            for i in m.tolist():
                errors[i] = exc
            continue
        view = group_view(m, ag0, cols, batch, rows_a, own, pred, wall_segments(batch))
        holds = cols.holds(m)
        status = keep_current(view, cols, batch.radii, own, current, desired, holds)
        decided = (
            decide_members(view, status, cols, batch.radii, own, current, desired, holds)
            if view.lists is not None
            else None
        )
        settled = status == 1
        if decided is not None:
            apply_decisions(m, status, *decided, real, whole, out, settled)
            apply_braking(
                m,
                status,
                decided[0],
                decided[2],
                traffic_near,
                vel,
                a_max,
                float(batch.dt),
                real,
                whole,
                out,
                settled,
            )
        if not settled.all():
            undecided(
                agents, view, status, settled, errors, out, batch, rows_a, own, current, desired
            )
    robust(agents, live, errors, out, own, desired)
    take = (cols.whole[:, STOPPING] != 0) & (cols.whole[:, REPLAN] != 0)
    if errors:
        take[list(errors)] = False
    g = np.flatnonzero(take)
    if len(g):
        brake, braking = commit_plans(
            *members((pos, vel, out, rad, a_max, v_max), g),
            batch.dt,
            batch.substeps,
            PLAN_MARGIN,
            batch.walls.reshape(-1, 2, 2),
            batch.wall_radius,
        )
        if brake.any():
            yielding = g[brake]
            cols.commit(yielding, braking[brake], YIELDED, 0)
            out[yielding] = braking[brake]
    return out, errors


def _traffic_near_reference(
    batch: SensingBatch, rows: NDArray[np.int64], cols: AgentColumns
) -> NDArray[np.bool_]:
    is_traffic = traffic_mask(batch.kinds, cols.memo)
    if is_traffic is None:
        return np.zeros(len(rows), dtype=bool)
    seen = np.concatenate([[0], np.cumsum(is_traffic[batch.nb_index])])
    return (seen[batch.nb_start[rows + 1]] - seen[batch.nb_start[rows]]) > 0


def _desired_reference(cols, batch, rows_a, goals, pos, vel, a_max, v_max):
    targets, has_target = heading_targets(cols, batch, rows_a, goals, pos)
    v_pref = cols.opt[:, V_PREF]
    cap = np.where(np.isnan(v_pref), v_max, np.minimum(v_pref, v_max))
    return goal_seeking_accels(
        targets, pos, vel, a_max, cap, cols.real[:, DETOUR], has_target=has_target
    )
