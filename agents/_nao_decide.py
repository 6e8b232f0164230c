"""The ``nao`` agent's policy for many robots' re-selections, in one compiled call.

:func:`decide_batch` is what the ``nao`` agent does, robot by robot, for the
robots whose current acceleration it cannot keep: build the obstacle paths it
needs (:func:`~nao_arena.geometry._kernel.relevance.relevant_sampled_paths`), repair a
young adjustment locally (:func:`~nao_arena.geometry.selection.repair_acceleration`)
and otherwise select in full
(:func:`~nao_arena.geometry.selection.select_acceleration`, limit disc,
no clearance), with the same floating-point operations, so the results are the
same; what it cannot decide (non-finite input, nothing admissible) it leaves
to the caller, which has the fallbacks.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.kernels import (
    IndexLists,
    Obstacles,
    Predictions,
    Robots,
    SearchSettings,
    Walls,
    WorldWalls,
    admissible_row,
    admissible_scratch,
    nearby_walls,
    piece_sweep,
    relevant_sampled_paths,
    relevant_walls,
    repair_relevant,
    select_relevant,
)
from nao_arena.geometry.outcome import Outcome
from nao_arena.geometry.selection import (
    _DISKS_PER_PIECE,
    _DISKS_PER_SECOND,
    _MAX_DISKS,
    _REPAIR_STEPS,
    _REPAIR_UNIT,
    _RING_POINTS,
    _RINGS,
    _SLIVER_DEPTH,
    _unit_rings,
)
from nao_arena.jit import kernel
from nao_arena.motion import braking, onto_disc, project_onto_disc

from ._nao_bundles import (
    DecidingRobots,
    Decisions,
    GroupPaths,
    ObstacleLists,
    SelectionSettings,
)
from ._nao_columns import (
    AUTO,
    BRAKE,
    CUR_X,
    CUR_Y,
    DECIDE,
    FALLBACK,
    KEEP_BAND,
    KEEP_UNTESTED,
    SETTLING,
    StepMemo,
    commit_row,
)

__all__ = [
    "ADJUSTED",
    "DESIRED",
    "INFEASIBLE",
    "REPAIRED",
    "UNDECIDED",
    "apply_braking",
    "apply_decisions",
    "decide",
    "decide_batch",
    "keep_candidates",
    "member_lists",
    "ring_radii_rows",
    "selection_settings",
]

# the outcomes decide_batch writes (:class:`~nao_arena.geometry.outcome.Outcome`)
UNDECIDED = Outcome.UNDECIDED  # non-finite input or paths: the caller decides (and reports)
REPAIRED = Outcome.REPAIRED  # a nearby admissible acceleration (the adjustment keeps its age)
DESIRED = Outcome.DESIRED  # the desired acceleration is admissible
ADJUSTED = Outcome.ADJUSTED  # the admissible acceleration nearest the desired one
INFEASIBLE = Outcome.INFEASIBLE  # nothing admissible found: the caller's fallback


@kernel
def decide_batch(paths, lists, nb_radius, rows, robots, repair, current, desired, settings, out):
    """Re-select for the robots ``rows`` (indices into the per-robot arrays).

    Robot k sees the bodies nb_index[nb_start[k]:nb_start[k + 1]] (world-frame
    centres pred[body] (T, 2) m at ``times`` s, radii nb_radius[body] + grow[k] m)
    and the walls wall_index[wall_start[k]:wall_start[k + 1]] of wall_seg ((M, 2, 2) m,
    world frame; radii wall_half (m) + grow[k], cut as
    :func:`~nao_arena.geometry._kernel.segment.nearby_walls` cuts them) (``paths``:
    :class:`~nao_arena.agents._nao_bundles.GroupPaths`, with the excursions of
    ``pred``; ``lists``: :class:`~nao_arena.agents._nao_bundles.ObstacleLists`;
    nb_radius (B,) m: every body's radius); ``robots``
    (:class:`~nao_arena.agents._nao_bundles.DecidingRobots`): position pos[k] (m),
    velocity vel[k] (m/s), limits a_max[k] (m/s^2) and v_max[k] (m/s).
    When repair[k], the current acceleration current[k] is first repaired towards
    desired[k] (m/s^2). ``settings``
    (:class:`~nao_arena.agents._nao_bundles.SelectionSettings`): ring_radii[k] (m/s^2),
    unit_rings, max_disks, n_sub, per_second, sliver_depth (fraction of a_max), as
    :func:`~nao_arena.geometry.selection.select_acceleration` passes them.

    Writes ``out`` (:class:`~nao_arena.agents._nao_bundles.Decisions`): kind[k] (an
    :class:`~nao_arena.geometry.outcome.Outcome`), accel[k] (m/s^2, for REPAIRED,
    DESIRED, ADJUSTED) and tested[k] (candidates tested by the selection).
    """
    times, pred, excursion, finite_path = paths
    nb_start, nb_index, wall_seg, wall_half, wall_start, wall_index = lists
    pos, vel, grow, a_max, v_max = robots
    (
        ring_radii,
        unit_rings,
        repair_steps,
        repair_unit,
        max_disks,
        n_sub,
        per_second,
        sliver_depth,
    ) = settings
    kind, accel, tested = out
    # the desired acceleration first, against the obstacles within its own reach only
    # (the keep test's admissibility, sampled_admissible_batch)
    sampled = Predictions(times, pred, nb_radius, excursion, finite_path)
    neighbours = IndexLists(nb_start, nb_index)
    world_walls = WorldWalls(wall_seg, wall_half)
    walls_seen = IndexLists(wall_start, wall_index)
    grown = Robots(pos, vel, v_max, grow, np.zeros(grow.shape[0]))
    keep, kept, buf, res = admissible_scratch(times, nb_start, rows)
    for k in rows:
        vx = vel[k, 0]
        vy = vel[k, 1]
        if not (math.isfinite(vx) and math.isfinite(vy)):
            kind[k] = Outcome.UNDECIDED
            continue
        if not repair[k] and wall_start[k + 1] == wall_start[k]:
            # no repair to try and no wall in range: when the desired acceleration
            # (projected onto the limit disc) is admissible, the full selection takes it
            # (it tests it first, with the same test on the obstacles both keep)
            dx, dy = onto_disc(
                desired[k, 0] if math.isfinite(desired[k, 0]) else 0.0,
                desired[k, 1] if math.isfinite(desired[k, 1]) else 0.0,
                a_max[k],
            )
            if dx * dx + dy * dy <= a_max[k] * a_max[k] * (1 + 1e-12) + 1e-300 and (
                admissible_row(
                    sampled,
                    neighbours,
                    world_walls,
                    walls_seen,
                    k,
                    grown,
                    dx,
                    dy,
                    keep,
                    kept,
                    buf,
                    res,
                )
                == 1
            ):
                kind[k] = Outcome.DESIRED
                accel[k, 0] = dx
                accel[k, 1] = dy
                tested[k] = 1
                continue
        c, w, b, rad, finite = relevant_sampled_paths(
            times,
            pred,
            nb_index[nb_start[k] : nb_start[k + 1]],
            pos[k],
            nb_radius,
            grow[k],
            vel[k],
            a_max[k],
            v_max[k],
            excursion,
            finite_path,
        )
        walls, wall_r = nearby_walls(
            wall_seg,
            wall_half,
            wall_index[wall_start[k] : wall_start[k + 1]],
            pos[k],
            grow[k],
            math.inf,
            np.bool_(True),
        )
        walls, wall_r = relevant_walls(vel[k], a_max[k], v_max[k], times[-1], walls, wall_r, 0.0)
        if not finite:
            kind[k] = Outcome.UNDECIDED
            continue
        # the obstacles kept are those the selection and the repair keep (relevant for
        # a_max, margin 0): they are used as they are
        sweep = piece_sweep(times, w, b)
        if repair[k]:
            prev = current[k]
            want = desired[k]
            if (
                math.isfinite(prev[0])
                and math.isfinite(prev[1])
                and math.isfinite(want[0])
                and math.isfinite(want[1])
            ):
                found, x, y, _ = repair_relevant(
                    prev,
                    want,
                    a_max[k],
                    repair_steps,
                    repair_unit,
                    vel[k],
                    v_max[k],
                    Obstacles(times, c, w, b, rad, sweep),
                    Walls(walls, wall_r),
                )
                if found:
                    kind[k] = Outcome.REPAIRED
                    accel[k, 0] = x
                    accel[k, 1] = y
                    continue
        # select_acceleration: the desired acceleration projected onto the limit disc
        dx, dy = onto_disc(
            desired[k, 0] if math.isfinite(desired[k, 0]) else 0.0,
            desired[k, 1] if math.isfinite(desired[k, 1]) else 0.0,
            a_max[k],
        )
        a_d = np.empty(2)
        a_d[0] = dx
        a_d[1] = dy
        tol = max(1e-3, 1e-9 * max(a_max[k], 1.0))
        status, x, y, count = select_relevant(
            a_d,
            vel[k],
            a_max[k],
            v_max[k],
            Obstacles(times, c, w, b, rad, sweep),
            Walls(walls, wall_r),
            0.0,
            SearchSettings(
                tol,
                ring_radii[k],
                unit_rings,
                max_disks,
                n_sub,
                per_second,
                sliver_depth * a_max[k],
            ),
        )
        tested[k] = count
        if status == Outcome.DESIRED:
            kind[k] = Outcome.DESIRED
            accel[k, 0] = dx
            accel[k, 1] = dy
        elif status == Outcome.ADJUSTED:
            kind[k] = Outcome.ADJUSTED
            accel[k, 0] = x
            accel[k, 1] = y
        else:
            kind[k] = Outcome.INFEASIBLE


def ring_radii_rows(
    a_max: NDArray[np.float64], memo: StepMemo | None = None
) -> NDArray[np.float64]:
    """Per robot, the radii (m/s^2) of the fallback rings of limit a_max (m/s^2), as
    :func:`~nao_arena.geometry.selection._ring_radii` gives them (same values): (n, rings).
    With a ``memo`` (the agents' table's), the radii of the last limits are remembered
    there (a batch's limits rarely change; not to be modified)."""
    a = np.ascontiguousarray(a_max, dtype=np.float64)
    key = a.tobytes()
    if memo is not None and memo.ring_radii is not None and memo.limits == key:
        return memo.ring_radii
    span = 2.0 * np.maximum(a, 1e-12)
    radii = np.ascontiguousarray(span[:, None] * 0.5 ** np.arange(_RINGS - 1, -1, -1))
    if memo is not None:
        memo.limits, memo.ring_radii = key, radii
    return radii


def decide(
    paths: GroupPaths,
    lists: ObstacleLists,
    nb_radius: NDArray[np.float64],
    rows: NDArray[np.int64],
    robots: DecidingRobots,
    repair: NDArray[np.bool_],
    current: NDArray[np.float64],
    desired: NDArray[np.float64],
    memo: StepMemo | None = None,
) -> Decisions:
    """:func:`decide_batch` with the settings :func:`~nao_arena.geometry.select_acceleration`
    and :func:`~nao_arena.geometry.repair_acceleration` use by default
    (:func:`selection_settings`). paths: the time grid and the predictions with their
    excursions; lists: the members' CSR obstacle lists; nb_radius (B,) m: every body's
    radius; per-robot arrays as in :func:`decide_batch`; memo: where the settings are
    remembered (:func:`ring_radii_rows`). Returns the :class:`Decisions` (kind, accel
    m/s^2, tested) per robot (kind UNDECIDED for the robots not in ``rows``)."""
    f = np.ascontiguousarray
    n = len(robots.a_max)
    out = Decisions(
        np.full(n, Outcome.UNDECIDED, dtype=np.int64),
        np.zeros((n, 2)),
        np.zeros(n, dtype=np.int64),
    )
    decide_batch(
        GroupPaths(f(paths.times, dtype=np.float64), paths.pred, paths.excursion, paths.finite),
        lists,
        f(nb_radius),
        rows,
        DecidingRobots(
            f(robots.pos), f(robots.vel), f(robots.grow), f(robots.a_max), f(robots.v_max)
        ),
        repair,
        f(current),
        f(desired),
        selection_settings(robots.a_max, memo),
        out,
    )
    return out


def selection_settings(
    a_max: NDArray[np.float64], memo: StepMemo | None = None
) -> SelectionSettings:
    """The :class:`SelectionSettings` of :func:`decide_batch` for robots of limits a_max
    (m/s^2): the settings :func:`~nao_arena.geometry.select_acceleration` and
    :func:`~nao_arena.geometry.repair_acceleration` use by default. With a ``memo``
    (the agents' table's), the settings of the last limits are remembered there, with
    their ring radii (:func:`ring_radii_rows`; not to be modified)."""
    radii = ring_radii_rows(a_max, memo)
    if memo is not None and memo.settings is not None and memo.settings.ring_radii is radii:
        return memo.settings
    settings = SelectionSettings(
        radii,
        _unit_rings(_RINGS, _RING_POINTS),
        _REPAIR_STEPS,
        _REPAIR_UNIT,
        _MAX_DISKS,
        _DISKS_PER_PIECE,
        _DISKS_PER_SECOND,
        _SLIVER_DEPTH,
    )
    if memo is not None:
        memo.settings = settings
    return settings


@kernel
def keep_candidates(members, current, desired, a_max, whole, opt, holds, status):
    """Per member j (row members[j] of the agents' table, columns
    :mod:`~nao_arena.agents._nao_columns`): status[j] = KEEP_UNTESTED if its current acceleration
    current[i] (m/s^2) may be kept, subject to the admissibility test: within keep_band
    (m/s^2; 0 while settling) of desired[i] or holds[j] (a young adjustment), and within
    a_max[i] (m/s^2, up to 1e-9 relative); else DECIDE. Returns how many are KEEP_UNTESTED."""
    count = 0
    for j in range(members.shape[0]):
        i = members[j]
        band = 0.0 if whole[i, SETTLING] != 0 else opt[i, KEEP_BAND]
        near = math.hypot(current[i, 0] - desired[i, 0], current[i, 1] - desired[i, 1]) <= band
        inside = not (math.hypot(current[i, 0], current[i, 1]) > a_max[i] * (1 + 1e-9))
        status[j] = KEEP_UNTESTED if (near or holds[j]) and inside else DECIDE
        count += status[j] == KEEP_UNTESTED
    return count


@kernel
def apply_decisions(members, status, kind, accel, tested, real, whole, out, settled):
    """The repairs and the selections of an admissible acceleration among the outcomes
    (kind, accel m/s^2, tested) of :func:`decide` for the members j with status[j] DECIDE,
    into their rows members[j] of the agents' table (a repair becomes the current
    acceleration; a selection also the last full selection, whose age restarts) and of
    ``out`` (n, 2) m/s^2; settled[j] = True for each of them."""
    for j in range(members.shape[0]):
        if status[j] != DECIDE:
            continue
        i = members[j]
        kd = kind[j]
        if kd == REPAIRED:
            real[i, CUR_X] = accel[j, 0]
            real[i, CUR_Y] = accel[j, 1]
        elif kd == DESIRED or kd == ADJUSTED:
            commit_row(real, whole, i, accel[j, 0], accel[j, 1], kd, tested[j])
        else:
            continue
        out[i, 0] = accel[j, 0]
        out[i, 1] = accel[j, 1]
        settled[j] = True


@kernel
def apply_braking(
    members, status, kind, tested, traffic, vel, a_max, dt, real, whole, out, settled
):
    """For the members j with status[j] 0 whose :func:`decide` outcome is INFEASIBLE and
    whose fallback is braking (option ``infeasible`` "brake", or "auto" without traffic
    among the neighbours, traffic[i]): what
    :func:`~nao_arena.agents._nao_per_robot.fallback` and ``AccelLimits(a_max).project``
    give, braking towards standing still within dt (s)
    from velocity vel[i] (m/s), committed as a selection of status INFEASIBLE into row
    members[j] = i of the agents' table and of ``out`` (n, 2) m/s^2; settled[j] = True
    for each of them (the same functions: :func:`~nao_arena.motion.braking`,
    :func:`~nao_arena.motion.project_onto_disc`)."""
    for j in range(members.shape[0]):
        if status[j] != 0 or kind[j] != INFEASIBLE:
            continue
        i = members[j]
        mode = whole[i, FALLBACK]
        if not (mode == BRAKE or (mode == AUTO and not traffic[i])):
            continue
        x, y = braking(vel[i, 0], vel[i, 1], a_max[i], dt)
        # onto the limit disc as AccelLimits.project does it (the braking's norm is at most
        # a_max up to rounding: the scale is never subnormal)
        x, y = project_onto_disc(x, y, a_max[i])
        commit_row(real, whole, i, x, y, np.int64(INFEASIBLE), tested[j])
        out[i, 0] = x
        out[i, 1] = y
        settled[j] = True


@kernel
def member_lists(nb_start, nb_index, rows):
    """The neighbour lists of the batch rows ``rows`` (CSR nb_start, nb_index of the
    whole batch), concatenated in that order: (start (len(rows) + 1,), index)."""
    start = np.zeros(rows.shape[0] + 1, dtype=np.int64)
    for j in range(rows.shape[0]):
        start[j + 1] = start[j] + nb_start[rows[j] + 1] - nb_start[rows[j]]
    index = np.empty(start[-1], dtype=np.int64)
    for j in range(rows.shape[0]):
        lo = nb_start[rows[j]]
        for e in range(start[j + 1] - start[j]):
            index[start[j] + e] = nb_index[lo + e]
    return start, index


@kernel
def wall_lists(pos, grow, reach, walls, half):  # pragma: no cover
    """The walls within each member's range, as CSR lists (start (k + 1,), index, walls
    ascending): wall w is member j's when the distance from its centre pos[j] (m) to the
    wall's segment walls[w] ((2, 2) m) is at most reach[j] + half[w] + grow[j] (m: its
    sensing range, the wall's half-thickness, its radius and margin). The distance is
    :func:`nao_arena.geometry.walls.point_segment_distances`' arithmetic, operation by
    operation (the same bits)."""
    k = pos.shape[0]
    n_walls = walls.shape[0]
    near = np.zeros((k, n_walls), dtype=np.bool_)
    start = np.zeros(k + 1, dtype=np.int64)
    for j in range(k):
        count = 0
        for w in range(n_walls):
            ax, ay = walls[w, 0, 0], walls[w, 0, 1]
            abx, aby = walls[w, 1, 0] - ax, walls[w, 1, 1] - ay
            ll = max(abx * abx + aby * aby, 1e-300)
            relx, rely = pos[j, 0] - ax, pos[j, 1] - ay
            t = relx * abx
            t += rely * aby
            t /= ll
            t = min(max(t, 0.0), 1.0)
            dist = math.hypot(relx - t * abx, rely - t * aby)
            if dist <= reach[j] + half[w] + grow[j]:
                near[j, w] = True
                count += 1
        start[j + 1] = start[j] + count
    index = np.empty(start[k], dtype=np.int64)
    q = 0
    for j in range(k):
        for w in range(n_walls):
            if near[j, w]:
                index[q] = w
                q += 1
    return start, index
