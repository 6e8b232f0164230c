"""The ``nao`` agents' step for a whole batch, in a few compiled calls.

:func:`~nao_arena.agents.nao.NAOAgent.act_batch` runs these in turn; between them
only what needs Python runs (the detours' random angles, heading targets other than
the goals, the predictions):

1. :func:`prepare_rows`: each robot's own state gathered from the batch, which
   agents decide this step, the liveness bookkeeping
   (:func:`~nao_arena.agents._nao_columns.liveness_batch`), whether traffic is among
   the neighbours, and goal seeking toward the goals (:func:`desired_rows`);
2. :func:`settle_members`: per group of agents that share predictions, the keep test,
   the repairs and selections (:func:`~nao_arena.agents._nao_decide.decide_batch`) and
   their commits, braking where nothing is admissible;
3. :func:`yield_rows`: the stopping-plan rule over the robots that re-plan
   (:func:`~nao_arena.stopping.commit_plans_kernel`).

When the agents share one predictor and regular time grid, :func:`decide_rows` runs
the three in one call (and the turn-rate predictions before them), stopping where
Python must take over; :func:`settle_rows` is its part after :func:`prepare_rows`,
for the steps whose heading targets Python found.

Per-robot arrays are in the rows of the agents' table (:mod:`._nao_columns`); body
arrays are the batch's (:class:`~nao_arena.sensing.SensingBatch`).
"""

from __future__ import annotations

import math

import numpy as np

from nao_arena.geometry.kernels import (
    IndexLists,
    Predictions,
    Robots,
    WorldWalls,
    path_excursions,
    sampled_admissible_batch,
)
from nao_arena.jit import inner_kernel, kernel
from nao_arena.navigation import segment_clear
from nao_arena.predictors import turn_rate_arcs
from nao_arena.stopping import Group, Knowledge, commit_plans_kernel

from ._nao_bundles import (
    DecidingRobots,
    Decisions,
    GroupPaths,
    ObstacleLists,
    OneGroup,
    RobotRows,
)
from ._nao_columns import (
    AROUND,
    CUR_X,
    CUR_Y,
    DECIDE,
    DETOUR,
    KEEP_UNTESTED,
    KEPT,
    MARGIN,
    NAVIGATE,
    NO_SELECTION,
    RANGE,
    REPLAN,
    ROW,
    SEEN,
    STATUS,
    STOPPING,
    V_PREF,
    YIELDED,
    commit_row,
    liveness_batch,
    young_adjustments,
)
from ._nao_decide import (
    UNDECIDED,
    apply_braking,
    apply_decisions,
    decide_batch,
    keep_candidates,
    member_lists,
    wall_lists,
)
from ._nao_liveness import held_by_standing_kernel
from .goal import APPROACH_GAIN, Headings, goal_seeking_kernel

__all__ = [
    "BRAKING",
    "DECIDED",
    "PREPARED",
    "SETTLED",
    "TIME_CONSTANT",
    "decide_rows",
    "desired_rows",
    "own_rows",
    "prepare_rows",
    "settle_members",
    "settle_rows",
    "yield_rows",
]

#: the ``nao`` agents' goal seeking: time constant (s) and braking (fraction of a_max),
#: the defaults of :func:`~nao_arena.agents.goal.goal_seeking_accels`
TIME_CONSTANT = 0.5
BRAKING = 0.5


@kernel
def desired_rows(targets, has_target, pos, vel, a_max, v_max, real, opt):  # pragma: no cover
    """The goal-seeking accelerations (n, 2) m/s^2 of the table's rows toward targets
    (n, 2) m (rows without ``has_target`` track standing still): what
    :func:`~nao_arena.agents.goal.goal_seeking_accels` gives at the speed cap
    min(v_pref, v_max) m/s (v_max where v_pref is NaN), turned by each row's detour
    (rad); per row: position (m), velocity (m/s), a_max (m/s^2), v_max (m/s)."""
    n = targets.shape[0]
    cap = np.empty(n)
    offset = np.empty(n)
    cos_off = np.empty(n)
    sin_off = np.empty(n)
    for i in range(n):
        v_pref = opt[i, V_PREF]
        # min(v_pref, v_max) as numpy's minimum (a NaN v_max stays NaN); a NaN v_pref
        # (none) gives v_max
        cap[i] = v_pref if v_pref < v_max[i] else v_max[i]
        offset[i] = real[i, DETOUR]
        cos_off[i] = math.cos(offset[i])
        sin_off[i] = math.sin(offset[i])
    out = np.empty((n, 2))
    goal_seeking_kernel(
        targets,
        pos,
        vel,
        a_max,
        cap,
        Headings(offset, cos_off, sin_off),
        np.full(n, TIME_CONSTANT),
        BRAKING,
        APPROACH_GAIN,
        has_target,
        out,
    )
    return out


@kernel
def own_rows(inputs):  # pragma: no cover
    """Each robot's own state, one row per batch row of ``rows``, gathered from the body
    arrays of ``inputs`` (:class:`~nao_arena.agents._nao_bundles.OwnInputs`; ``bodies``:
    each batch row's body): position (m), velocity (m/s), radius (m), a_max (m/s^2),
    v_max (m/s), its goal (goals (R, 2) m, batch rows), whether traffic (``traffic``
    (B,): per body; empty: no body is) is among its neighbours (CSR nb_start, nb_index
    of the batch rows), and whether every goal is finite."""
    (
        rows,
        bodies,
        positions,
        velocities,
        radii,
        body_a_max,
        body_v_max,
        goals,
        nb_start,
        nb_index,
        traffic,
    ) = inputs
    n = rows.shape[0]
    pos = np.empty((n, 2))
    vel = np.empty((n, 2))
    rad = np.empty(n)
    a_max = np.empty(n)
    v_max = np.empty(n)
    own_goals = np.empty((n, 2))
    traffic_near = np.zeros(n, dtype=np.bool_)
    aimed = True
    for i in range(n):
        b = bodies[rows[i]]
        pos[i, 0] = positions[b, 0]
        pos[i, 1] = positions[b, 1]
        vel[i, 0] = velocities[b, 0]
        vel[i, 1] = velocities[b, 1]
        rad[i] = radii[b]
        a_max[i] = body_a_max[b]
        v_max[i] = body_v_max[b]
        own_goals[i, 0] = goals[rows[i], 0]
        own_goals[i, 1] = goals[rows[i], 1]
        aimed = aimed and math.isfinite(own_goals[i, 0]) and math.isfinite(own_goals[i, 1])
        if traffic.shape[0]:
            for e in range(nb_start[rows[i]], nb_start[rows[i] + 1]):
                if traffic[nb_index[e]]:
                    traffic_near[i] = True
                    break
    return pos, vel, rad, a_max, v_max, own_goals, traffic_near, aimed


@kernel
def prepare_rows(inputs, wall_segments, dt, table):  # pragma: no cover
    """The start of a batch's step for the rows of the agents' table ``table``
    (:class:`~nao_arena.agents._nao_bundles.AgentTable`; agent i drives batch row
    rows[i] of ``inputs``, :class:`~nao_arena.agents._nao_bundles.OwnInputs`).

    The robots' own state (:func:`own_rows`); ``live``: the rows that decide this step
    (REPLAN, or no selection yet), n_live of them; ``out``: the current accelerations
    (m/s^2), what the others keep. When some row is live: their liveness bookkeeping of
    dt s (:func:`~nao_arena.agents._nao_columns.liveness_batch`, with whether parked
    robots hold them, :func:`~nao_arena.agents._nao_liveness.held_by_standing_kernel`;
    turn[i]: the detour turns once more, its angle for the caller to draw) and the goal
    seeking toward the goals (:func:`desired_rows`), valid where ``direct``: every goal
    is finite and, for the robots that ``navigate``, in sight past the walls
    (``wall_segments``, :class:`~nao_arena.geometry.kernels.WorldWalls`: (W, 2, 2)
    m of half-thickness (W,) m) (:func:`~nao_arena.navigation.segment_clear` at the
    robot's radius; their AROUND is then cleared, as
    :func:`~nao_arena.navigation.route_targets` clears it); else the caller finds the
    heading targets.

    Returns (pos, vel, rad, a_max, v_max, goals, live, n_live, out, turn, turns,
    traffic_near, desired, direct); turns counts turn; desired is unset (the caller's to
    find) when no row is live, some detour turned or not ``direct``.
    """
    rows, bodies, nb_start, nb_index = inputs.rows, inputs.bodies, inputs.nb_start, inputs.nb_index
    positions, velocities, radii = inputs.positions, inputs.velocities, inputs.radii
    walls, wall_half = wall_segments
    real, whole, opt = table
    pos, vel, rad, a_max, v_max, own_goals, traffic_near, direct = own_rows(inputs)
    n = rows.shape[0]
    live = np.empty(n, dtype=np.bool_)
    out = np.empty((n, 2))
    n_live = 0
    for i in range(n):
        live[i] = whole[i, REPLAN] != 0 or whole[i, STATUS] == NO_SELECTION
        n_live += live[i]
        out[i, 0] = real[i, CUR_X]
        out[i, 1] = real[i, CUR_Y]
    turn = np.zeros(n, dtype=np.bool_)
    if n_live == 0:
        return (
            pos,
            vel,
            rad,
            a_max,
            v_max,
            own_goals,
            live,
            n_live,
            out,
            turn,
            0,
            traffic_near,
            out,
            direct,
        )
    held = np.empty(n, dtype=np.bool_)
    held_by_standing_kernel(
        nb_start, nb_index, rows, bodies, positions, velocities, radii, rad, own_goals, held
    )
    liveness_batch(live, pos, vel, own_goals, rad, v_max, held, dt, real, whole, opt, turn)
    turns = 0
    for i in range(n):
        turns += turn[i]
    if direct and walls.shape[0]:
        for i in range(n):
            if (
                whole[i, NAVIGATE] != 0
                and math.isfinite(pos[i, 0])
                and math.isfinite(pos[i, 1])
                and not segment_clear(
                    pos[i, 0], pos[i, 1], own_goals[i, 0], own_goals[i, 1], walls, wall_half, rad[i]
                )
            ):
                direct = False
                break
        if direct:
            for i in range(n):
                if whole[i, NAVIGATE] != 0:
                    whole[i, AROUND] = 0
    desired = out  # unset: the caller finds the targets and the goal seeking itself
    if direct and turns == 0:
        desired = desired_rows(
            own_goals, np.ones(n, dtype=np.bool_), pos, vel, a_max, v_max, real, opt
        )
    return (
        pos,
        vel,
        rad,
        a_max,
        v_max,
        own_goals,
        live,
        n_live,
        out,
        turn,
        turns,
        traffic_near,
        desired,
        direct,
    )


@inner_kernel
def rows_with(status, code):  # pragma: no cover
    """The indices (int64, ascending) of the entries of ``status`` equal to ``code`` (of
    the same dtype: codes, or flags and True): ``np.flatnonzero(status == code)`` as a
    loop (numba's own is compiled anew, uncached, in every process)."""
    count = 0
    for j in range(status.shape[0]):
        count += status[j] == code
    out = np.empty(count, dtype=np.int64)
    q = 0
    for j in range(status.shape[0]):
        if status[j] == code:
            out[q] = j
            q += 1
    return out


@kernel
def settle_members(
    m, paths, lists, nb_radius, own, current, desired, dt, settings, table, out
):  # pragma: no cover
    """The decisions of the members m (rows of the agents' table ``table``,
    :class:`~nao_arena.agents._nao_bundles.AgentTable`; they share the predictions
    ``paths``, :class:`~nao_arena.agents._nao_bundles.GroupPaths`, and see the obstacles
    of the member CSR lists ``lists``,
    :class:`~nao_arena.agents._nao_bundles.ObstacleLists`, with every body's radius
    nb_radius (B,) m, as :func:`~nao_arena.agents._nao_decide.decide_batch` reads them).

    1. The keep test: a member keeps its current acceleration current[i] (m/s^2) where
       :func:`~nao_arena.agents._nao_decide.keep_candidates` allows it (within keep_band
       of desired[i], or a young adjustment) and it stays admissible
       (:func:`~nao_arena.geometry._kernel.batch.sampled_admissible_batch`);
    2. the others are repaired (young adjustments) or select in full
       (:func:`~nao_arena.agents._nao_decide.decide_batch`; ``settings``: its
       :class:`~nao_arena.agents._nao_bundles.SelectionSettings`, ring radii per
       member), committed into the table and ``out`` (n, 2) m/s^2
       (:func:`~nao_arena.agents._nao_decide.apply_decisions`), and where nothing is
       admissible and the fallback is braking, braking is
       (:func:`~nao_arena.agents._nao_decide.apply_braking`; traffic_near[i]: traffic
       among the neighbours, dt s).

    ``own`` (:class:`~nao_arena.agents._nao_bundles.RobotRows`, n rows): pos (m), vel
    (m/s), rad (m), a_max (m/s^2), v_max (m/s), traffic_near; per row current, desired
    (m/s^2). Returns, per member, status (KEPT, DECIDE: decided here, KEEP_UNTESTED: a
    keep candidate whose paths are not finite, tested by the caller), the decide
    outcomes (kind, accel m/s^2, tested; kind UNDECIDED where not decided), settled
    (kept or committed here; the others are left to the caller) and how many are not
    settled.
    """
    times, pred, excursion, finite_path = paths
    nb_start, nb_index, wall_seg, wall_half, wall_start, wall_index = lists
    pos, vel, rad, a_max, v_max, traffic = own
    real, whole, opt = table
    k = m.shape[0]
    every = k == pos.shape[0]  # m: distinct rows in order, so all of them
    p = pos if every else pos[m]
    v = vel if every else vel[m]
    c = current if every else current[m]
    d = desired if every else desired[m]
    r = rad if every else rad[m]
    a = a_max if every else a_max[m]
    s = v_max if every else v_max[m]
    margin = np.empty(k)
    for j in range(k):
        margin[j] = opt[m[j], MARGIN]
    holds = np.empty(k, dtype=np.bool_)
    young_adjustments(m, real, whole, opt, holds)
    status = np.zeros(k, dtype=np.int64)
    settled = np.zeros(k, dtype=np.bool_)
    some = keep_candidates(m, current, desired, a_max, whole, opt, holds, status)
    if some:
        todo = rows_with(status, np.int64(KEEP_UNTESTED))
        res = np.full(k, -1, dtype=np.int64)
        sampled_admissible_batch(
            Predictions(times, pred, nb_radius, excursion, finite_path),
            IndexLists(nb_start, nb_index),
            WorldWalls(wall_seg, wall_half),
            IndexLists(wall_start, wall_index),
            todo,
            Robots(p, v, s, r, margin),
            c,
            res,
        )
        # 1: keep; 0: not admissible (select); -1: non-finite paths (the caller reports it)
        for j in todo:
            status[j] = KEPT if res[j] == 1 else (DECIDE if res[j] == 0 else KEEP_UNTESTED)
            settled[j] = status[j] == KEPT
    kind = np.full(k, UNDECIDED, dtype=np.int64)
    accel = np.zeros((k, 2))
    tested = np.zeros(k, dtype=np.int64)
    todo = rows_with(status, np.int64(DECIDE))
    if todo.shape[0]:
        grow = r + margin
        decide_batch(
            paths,
            lists,
            nb_radius,
            todo,
            DecidingRobots(p, v, grow, a, s),
            holds,
            c,
            d,
            settings,
            Decisions(kind, accel, tested),
        )
        apply_decisions(m, status, kind, accel, tested, real, whole, out, settled)
        apply_braking(m, status, kind, tested, traffic, vel, a_max, dt, real, whole, out, settled)
    left = 0
    for j in range(k):
        left += not settled[j]
    return status, kind, accel, tested, settled, left


@kernel
def yield_rows(
    own, out, failed, dt, substeps, margin, wall_segments, know, table
):  # pragma: no cover
    """The stopping-plan rule (:func:`~nao_arena.stopping.commit_plans_kernel`) over the
    rows of the agents' table ``table`` (:class:`~nao_arena.agents._nao_bundles.AgentTable`)
    that re-plan with stopping plans (STOPPING and REPLAN) and decided this step (not
    ``failed``): a robot whose plan would meet another's, or a wall (``wall_segments``,
    :class:`~nao_arena.geometry.kernels.WorldWalls`: (W, 2, 2) m of
    half-thickness (W,) m), at the sum of the radii plus margin (m), brakes instead; it
    commits that braking acceleration as a selection of status YIELDED, into the table
    and ``out`` (n, 2) m/s^2. ``own`` (:class:`~nao_arena.agents._nao_bundles.RobotRows`,
    per row): pos (m), vel (m/s), rad (m), a_max (m/s^2), v_max (m/s); out (m/s^2); the
    world's dt (s) and substeps; ``know``: what the rows know of each other
    (:class:`~nao_arena.stopping.Knowledge`, rows by rows)."""
    pos, vel, rad, a_max, v_max = own.pos, own.vel, own.rad, own.a_max, own.v_max
    walls, wall_half = wall_segments
    real, whole = table.real, table.whole
    n = pos.shape[0]
    take = np.empty(n, dtype=np.bool_)
    count = 0
    for i in range(n):
        take[i] = whole[i, STOPPING] != 0 and whole[i, REPLAN] != 0 and not failed[i]
        count += take[i]
    if count == 0:
        return
    g = rows_with(take, np.bool_(True))
    every = count == n
    brake = np.zeros(count, dtype=np.bool_)
    braking = np.zeros((count, 2))
    if not every and know.linked.shape[0] != 0:
        know = Knowledge(
            know.linked[g][:, g],
            know.position[g][:, g],
            know.velocity[g][:, g],
            know.free[g][:, g],
            know.spread[g][:, g],
            know.sigmas,
        )
    commit_plans_kernel(
        Group(
            pos if every else pos[g],
            vel if every else vel[g],
            rad if every else rad[g],
            a_max if every else a_max[g],
            v_max if every else v_max[g],
        ),
        out if every else out[g],
        dt,
        substeps,
        margin,
        walls,
        wall_half,
        know,
        brake,
        braking,
    )
    for j in range(count):
        if brake[j]:
            i = g[j]
            commit_row(real, whole, i, braking[j, 0], braking[j, 1], np.int64(YIELDED), np.int64(0))
            out[i, 0] = braking[j, 0]
            out[i, 1] = braking[j, 1]


#: how far :func:`decide_rows` (or :func:`settle_rows`) took a batch's step: the start
#: only (:func:`prepare_rows`), the decisions of the compiled calls too
#: (:func:`settle_members`), or all of it
PREPARED, SETTLED, DECIDED = 0, 1, 2


@kernel
def decide_rows(inputs, wall_segments, dt, table, group):  # pragma: no cover
    """A batch's step for agents that share one predictor and regular time grid, as far
    as compiled calls take it, in one call: :func:`prepare_rows`, then, when every row
    decides this step and no detour turned, every goal is known and in sight
    (``direct``; else the caller finds the heading targets), :func:`settle_rows` of the
    robots' rows toward the goals (``group``:
    :class:`~nao_arena.agents._nao_bundles.OneGroup`).

    The predictions are made first where the group's ``arcs`` hold the bodies
    (:func:`~nao_arena.predictors.turn_rate_arcs`).

    Returns (stage, prepared, rest, out, pred, excursion, finite): stage PREPARED,
    SETTLED or DECIDED; prepared, what :func:`prepare_rows` returns (None at DECIDED:
    nothing of it is left to do); rest, what :func:`settle_rows` returns last (None but
    at SETTLED); out, the accelerations (n, 2) m/s^2 decided so far; pred, the
    predictions (B, T, 2) m; excursion and finite, theirs (empty at PREPARED).
    """
    times, pred, arcs, settings, know, substeps, margin, finish = group
    if arcs.positions.shape[0]:
        pred = turn_rate_arcs(arcs, times.shape[0])
        group = OneGroup(times, pred, arcs, settings, know, substeps, margin, finish)
    prepared = prepare_rows(inputs, wall_segments, dt, table)
    pos, vel, rad, a_max, v_max, _, _, n_live, out, _, turns, traffic_near, desired, direct = (
        prepared
    )
    n = pos.shape[0]
    if n_live < n or turns or not direct:
        return PREPARED, prepared, None, out, pred, np.zeros(0), np.zeros(0, dtype=np.bool_)
    stage, excursion, finite, rest = settle_rows(
        inputs,
        wall_segments,
        dt,
        table,
        group,
        RobotRows(pos, vel, rad, a_max, v_max, traffic_near),
        desired,
        out,
    )
    if stage == DECIDED:
        return stage, None, None, out, pred, excursion, finite
    return stage, prepared, rest, out, pred, excursion, finite


@kernel
def settle_rows(inputs, wall_segments, dt, table, group, own, desired, out):  # pragma: no cover
    """The rest of a batch's step after :func:`prepare_rows` (``inputs``, ``wall_segments``,
    ``dt``, ``table`` as there) when every row decides and the agents share one predictor
    and regular time grid: the obstacle lists of every row
    (:func:`~nao_arena.agents._nao_decide.member_lists`,
    :func:`~nao_arena.agents._nao_decide.wall_lists` within each robot's sensing range),
    then :func:`settle_members` against the predictions of ``group``
    (:class:`~nao_arena.agents._nao_bundles.OneGroup`, its ``pred`` made) toward the
    desired accelerations (n, 2) m/s^2 of the robots ``own``
    (:class:`~nao_arena.agents._nao_bundles.RobotRows`), into ``out`` (n, 2) m/s^2;
    then, when every row is settled and the group may ``finish``, :func:`yield_rows`.
    Each row's SEEN and ROW columns point at the predictions (view 0, its batch row).

    Returns (stage, excursion, finite, rest): stage SETTLED or DECIDED; the excursions
    and finiteness of pred (:func:`~nao_arena.geometry.kernels.path_excursions`); at
    SETTLED, rest: what the caller still needs (None at DECIDED): the rows' obstacle
    lists (:class:`~nao_arena.agents._nao_bundles.ObstacleLists`), what
    :func:`settle_members` returns of the rows (status, settled, how many are left) and
    their current accelerations (m/s^2) before it.
    """
    walls, wall_half = wall_segments
    real, whole, opt = table
    times, pred, _, settings, know, substeps, margin, finish = group
    pos, rad = own.pos, own.rad
    n = pos.shape[0]
    excursion, finite = path_excursions(pred)
    rows = inputs.rows
    for i in range(n):
        whole[i, SEEN] = 0
        whole[i, ROW] = rows[i]
    nb_start, nb_index = member_lists(inputs.nb_start, inputs.nb_index, rows)
    wall_start = np.zeros(n + 1, dtype=np.int64)
    wall_index = np.zeros(0, dtype=np.int64)
    if walls.shape[0]:
        grow = np.empty(n)
        reach = np.empty(n)
        for i in range(n):
            grow[i] = rad[i] + opt[i, MARGIN]
            reach[i] = opt[i, RANGE]
        wall_start, wall_index = wall_lists(pos, grow, reach, walls, wall_half)
    lists = ObstacleLists(nb_start, nb_index, walls, wall_half, wall_start, wall_index)
    current = out.copy()
    status, _, _, _, settled, left = settle_members(
        np.arange(n),
        GroupPaths(times, pred, excursion, finite),
        lists,
        inputs.radii,
        own,
        current,
        desired,
        dt,
        settings,
        table,
        out,
    )
    if left or not finish:
        return SETTLED, excursion, finite, (lists, status, settled, left, current)
    yield_rows(
        own, out, np.zeros(n, dtype=np.bool_), dt, substeps, margin, wall_segments, know, table
    )
    return DECIDED, excursion, finite, None
