"""The Python between the ``nao`` agents' compiled calls: what a step hands to them.

A step of :meth:`~nao_arena.agents.nao.NAOAgent.act_batch` (and of
:meth:`~nao_arena.agents.nao.NAOAgent.nearest_admissible_batch`) gathers the
robots' own state from the batch (:func:`own_inputs`, :func:`own_rows_of`), the
obstacles each member of a group of shared predictions sees (:func:`group_view`,
:func:`obstacle_lists`), and, where the compiled goal seeking does not apply, the
heading targets (:func:`desired_accels`: a route's last waypoint for a missing goal,
the way around walls); :func:`keep_current` and :func:`decide_members` are the keep
test and the decisions of a group as separate compiled calls (the selection on its
own). Positions and targets are world-frame (m), velocities m/s, accelerations
m/s^2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.kernels import (
    IndexLists,
    Predictions,
    Robots,
    WorldWalls,
    path_excursions,
    sampled_admissible_batch,
)
from nao_arena.navigation import navigation_grid, route_targets
from nao_arena.sensing import SensingBatch, is_frozen

from ._nao_batch import desired_rows, own_rows
from ._nao_bundles import (
    DecidingRobots,
    Decisions,
    GroupPaths,
    ObstacleLists,
    OwnInputs,
    RobotRows,
)
from ._nao_columns import (
    AROUND,
    DECIDE,
    KEEP_UNTESTED,
    KEPT,
    MARGIN,
    NAVIGATE,
    RANGE,
    ROW,
    SEEN,
    AgentColumns,
    StepMemo,
)
from ._nao_decide import decide, keep_candidates, member_lists, wall_lists
from ._nao_per_robot import Excursions

if TYPE_CHECKING:
    from .nao import NAOAgent

_NO_TRAFFIC = np.zeros(0, dtype=np.bool_)


class GroupView(NamedTuple):
    """What the members m (rows of the agents' table) of a group that shares
    predictions decide from: the group's first agent (its predictor and time grid),
    the predictions ``pred`` (bodies, T, 2) m of every body, their excursions and the
    members' obstacle lists (:func:`obstacle_lists`; None: an irregular time grid)."""

    m: NDArray[np.int64]
    agent: NAOAgent
    pred: NDArray[np.float64]
    excursions: Excursions
    lists: ObstacleLists | None

    @property
    def paths(self) -> GroupPaths:
        """The group's time grid (contiguous) and predictions with their excursions, as
        the compiled calls take them (:class:`~nao_arena.agents._nao_bundles.GroupPaths`)."""
        times = np.ascontiguousarray(self.agent.times, dtype=np.float64)
        return GroupPaths(times, self.pred, self.excursions[0], self.excursions[1])


def traffic_mask(kinds: NDArray[np.str_], memo: StepMemo) -> NDArray[np.bool_] | None:
    """Per body: whether it is traffic (None: no body is); worked out once per frozen
    kinds array (the arena's, which every step's batch shares; see
    :func:`nao_arena.sensing.read_only`) and remembered in ``memo``."""
    if kinds is memo.kinds:
        return memo.traffic
    mask = kinds == "traffic"
    found = mask if mask.any() else None
    if is_frozen(kinds):
        memo.kinds, memo.traffic = kinds, found
    return found


def own_inputs(batch: SensingBatch, rows_a: NDArray[np.int64], memo: StepMemo) -> OwnInputs:
    """:class:`~nao_arena.agents._nao_bundles.OwnInputs` of the batch rows ``rows_a`` (the
    traffic mask remembered in ``memo``, :func:`traffic_mask`)."""
    f = np.ascontiguousarray
    traffic = traffic_mask(batch.kinds, memo)
    return OwnInputs(
        f(rows_a, dtype=np.int64),
        f(batch.bodies, dtype=np.int64),
        f(batch.positions, dtype=np.float64),
        f(batch.velocities, dtype=np.float64),
        f(batch.radii, dtype=np.float64),
        f(batch.a_max, dtype=np.float64),
        f(batch.v_max, dtype=np.float64),
        f(batch.goals, dtype=np.float64),
        f(batch.nb_start, dtype=np.int64),
        f(batch.nb_index, dtype=np.int64),
        _NO_TRAFFIC if traffic is None else traffic,
    )


def own_rows_of(batch: SensingBatch, rows_a: NDArray[np.int64], memo: StepMemo) -> tuple[Any, ...]:
    """:func:`~nao_arena.agents._nao_batch.own_rows` of the batch rows ``rows_a``: per
    robot its position (m), velocity (m/s), radius (m), a_max (m/s^2), v_max (m/s),
    goal (m), whether traffic is among its neighbours; and whether every goal is
    finite."""
    return own_rows(own_inputs(batch, rows_a, memo))


def group_view(
    m: NDArray[np.int64],
    ag0: NAOAgent,
    cols: AgentColumns,
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    own: RobotRows,
    pred: NDArray[np.float64],
    walls: WorldWalls,
) -> GroupView:
    """The :class:`GroupView` of the agents of rows m (ag0's predictor and time grid),
    given the predictions ``pred`` of every body and the batch's ``walls``
    (:func:`~nao_arena.agents._kernel_inputs.wall_segments`). Each member keeps what it
    saw (:meth:`~nao_arena.agents.nao.NAOAgent.last_obstacles`)."""
    excursions = path_excursions(pred)
    # m: distinct rows in order, so every row when there are as many
    rows_m = slice(None) if len(m) == len(cols.whole) else m
    cols.whole[rows_m, SEEN] = len(cols.seen)
    cols.whole[rows_m, ROW] = rows_a[rows_m]
    cols.seen.append((batch, pred, excursions))
    lists = obstacle_lists(m, cols, batch, rows_a, own, walls) if ag0._regular_grid() else None
    return GroupView(m, ag0, pred, excursions, lists)


def obstacle_lists(
    m: NDArray[np.int64],
    cols: AgentColumns,
    batch: SensingBatch,
    rows: NDArray[np.int64],
    own: RobotRows,
    world_walls: WorldWalls,
) -> ObstacleLists:
    """The obstacles each member (rows m of the agents' table) sees, as CSR lists
    (members' order): neighbours (nb_start, nb_index: body indices), then the walls in
    its range (wall_seg (W, 2, 2) m and wall_half (W,) m: every wall's ends and
    half-thickness, ``world_walls``; wall_start, wall_index)."""
    nb_start, nb_index = member_lists(
        np.ascontiguousarray(batch.nb_start, dtype=np.int64),
        np.ascontiguousarray(batch.nb_index, dtype=np.int64),
        np.ascontiguousarray(rows[m], dtype=np.int64),
    )
    wall_start = np.zeros(len(m) + 1, dtype=np.int64)
    walls, half = world_walls
    if not len(walls):
        return ObstacleLists(
            nb_start, nb_index, walls, half, wall_start, np.zeros(0, dtype=np.int64)
        )
    # the walls within each member's range: distance <= range + half-thickness + grow
    wall_start, wall_index = wall_lists(
        np.ascontiguousarray(own.pos[m], dtype=np.float64),
        own.rad[m] + cols.opt[m, MARGIN],
        cols.opt[m, RANGE],
        walls,
        half,
    )
    return ObstacleLists(nb_start, nb_index, walls, half, wall_start, wall_index)


def members(arrays: tuple[NDArray[Any], ...], m: NDArray[np.int64]) -> list[NDArray[Any]]:
    """The rows m of each array (contiguous; the arrays themselves, when contiguous and m
    takes every row in order)."""
    every = all(len(m) == len(a) for a in arrays)  # m: distinct rows in order, so all
    return [np.ascontiguousarray(a) if every else np.ascontiguousarray(a[m]) for a in arrays]


def keep_current(
    view: GroupView,
    cols: AgentColumns,
    nb_radius: NDArray[np.float64],
    own: RobotRows,
    current: NDArray[np.float64],
    desired: NDArray[np.float64],
    holds: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """Per member of ``view`` (rows of the agents' table): 1 keep the current
    acceleration current[i] (m/s^2; within keep_band of desired[i], or 0 while
    settling, and admissible), 0 select anew, 2 undecided here (decide from the full
    path; every candidate, when the time grid is irregular). holds: per member, whether
    it holds a young adjustment; nb_radius: the radius (m) of every body."""
    m = view.m
    status = np.zeros(len(m), dtype=np.int64)
    some = keep_candidates(
        m,
        np.ascontiguousarray(current, dtype=np.float64),
        np.ascontiguousarray(desired, dtype=np.float64),
        np.ascontiguousarray(own.a_max, dtype=np.float64),
        cols.whole,
        cols.opt,
        np.ascontiguousarray(holds, dtype=np.bool_),
        status,
    )
    if view.lists is None or some == 0:
        return status
    nb_start, nb_index, wall_seg, wall_half, wall_start, wall_index = view.lists
    todo = np.flatnonzero(status == KEEP_UNTESTED)
    res = np.full(len(m), -1, dtype=np.int64)
    f = np.ascontiguousarray
    pos_m, vel_m, cur_m, v_max_m, rad_m = members(
        (own.pos, own.vel, current, own.v_max, own.rad), m
    )
    sampled_admissible_batch(
        Predictions(
            f(view.agent.times, dtype=np.float64),
            view.pred,
            f(nb_radius),
            view.excursions[0],
            view.excursions[1],
        ),
        IndexLists(nb_start, nb_index),
        WorldWalls(wall_seg, wall_half),
        IndexLists(wall_start, wall_index),
        todo,
        Robots(pos_m, vel_m, v_max_m, rad_m, cols.opt[m, MARGIN]),
        cur_m,
        res,
    )
    # 1: keep; 0: not admissible (select); -1: non-finite paths (the slow path reports it)
    status[todo] = np.where(res[todo] == 1, KEPT, np.where(res[todo] == 0, DECIDE, KEEP_UNTESTED))
    return status


def decide_members(
    view: GroupView,
    status: NDArray[np.int64],
    cols: AgentColumns,
    nb_radius: NDArray[np.float64],
    own: RobotRows,
    current: NDArray[np.float64],
    desired: NDArray[np.float64],
    holds: NDArray[np.bool_],
) -> Decisions | None:
    """The repairs (of the young adjustments, ``holds``) of current (m/s^2) and the
    selections toward desired (m/s^2) of the members of ``view`` with status 0, in one
    compiled call (:func:`~nao_arena.agents._nao_decide.decide`; its obstacle lists must
    be there): (kind, accel m/s^2, tested) per member, or None when there are none."""
    assert view.lists is not None
    m = view.m
    todo = np.flatnonzero(status == DECIDE)
    if len(todo) == 0:
        return None
    p, v, r, a, s, c, d = members(
        (own.pos, own.vel, own.rad, own.a_max, own.v_max, current, desired), m
    )
    robots = DecidingRobots(p, v, r + cols.opt[m, MARGIN], a, s)
    return decide(view.paths, view.lists, nb_radius, todo, robots, holds, c, d, cols.memo)


def desired_accels(
    cols: AgentColumns,
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    goals: NDArray[np.float64],
    pos: NDArray[np.float64],
    vel: NDArray[np.float64],
    a_max: NDArray[np.float64],
    v_max: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The goal-seeking accelerations (n, 2) m/s^2 (:func:`desired_rows`: goal seeking
    at min(v_pref, v_max), turned by each agent's detour; agents: the rows of ``cols``)
    toward the robots' :func:`heading_targets`."""
    targets, has_target = heading_targets(cols, batch, rows_a, goals, pos)
    return desired_rows(
        np.ascontiguousarray(targets, dtype=np.float64),
        has_target,
        pos,
        vel,
        a_max,
        v_max,
        cols.real,
        cols.opt,
    )


def heading_targets(
    cols: AgentColumns,
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    goals: NDArray[np.float64],
    pos: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Where each robot heads (n, 2) m, and whether it has a target: its goal; a robot
    without a finite goal heads for its route's last waypoint, or has none (stands
    still); where a wall stands in the way, the way around it (:func:`around_walls`)."""
    targets = goals
    has_target = np.ones(len(goals), dtype=np.bool_)
    if not np.isfinite(goals).all():
        lost = ~np.all(np.isfinite(goals), axis=1)
        targets = goals.copy()
        has_target = ~lost
        for i in np.flatnonzero(lost).tolist():
            route = batch.routes[int(rows_a[i])]
            if route is not None and len(route):
                targets[i] = route[-1]
                has_target[i] = True
    if len(batch.walls):
        targets = around_walls(cols, batch, rows_a, targets, pos)
    return targets, has_target


def around_walls(
    cols: AgentColumns,
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    targets: NDArray[np.float64],
    pos: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The heading targets (n, 2) m of the robots whose agents (rows of ``cols``)
    ``navigate``: their targets, or where a wall stands between, the way around it
    (:func:`~nao_arena.navigation.route_targets`; one grid per radius + margin)."""
    radii = batch.radii[batch.bodies[rows_a]]
    steer = np.flatnonzero(cols.whole[:, NAVIGATE]).tolist()
    if not steer:
        return targets
    out = np.array(targets, dtype=np.float64, copy=True)
    walls = batch.walls.reshape(-1, 2, 2)
    # the grid covers the walls (padded): the same for every robot and batch
    box = np.array([walls.reshape(-1, 2).min(axis=0), walls.reshape(-1, 2).max(axis=0)])
    groups: dict[float, list[int]] = {}
    clearances = (radii + cols.opt[:, MARGIN]).tolist()
    for i in steer:
        groups.setdefault(clearances[i], []).append(i)
    for clearance, group in groups.items():
        grid = navigation_grid(walls, batch.wall_radius, clearance, box)
        g = np.asarray(group, dtype=np.int64)
        out[g], around = route_targets(grid, pos[g], targets[g], radii[g])
        cols.whole[g, AROUND] = around
    return out


def predictions(ag0: NAOAgent, batch: SensingBatch) -> NDArray[np.float64]:
    """The predicted centres (bodies, T, 2) m of every body of ``batch`` at ag0's times
    (s), by ag0's predictor; ValueError when it returns another shape (the compiled
    calls index them by body and time)."""
    pred = np.ascontiguousarray(ag0.predict(ag0.times, batch.everyone()), dtype=np.float64)
    expected = (len(batch.positions), len(ag0.times), 2)
    if pred.shape != expected:
        raise ValueError(
            f"predictor {ag0.predictor_name!r} returned centres of shape {pred.shape}, "
            f"expected {expected} (bodies, times, 2)"
        )
    return pred
