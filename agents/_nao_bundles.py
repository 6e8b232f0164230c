"""The named bundles the ``nao`` agents' compiled calls take their arrays in.

numba passes a named tuple as its fields: a bundle costs nothing inside the compiled
code, and two arrays given in the wrong order no longer compile (they no longer sit
side by side in a long argument list). Python builds each bundle once per step (the
constant ones once per table: :class:`AgentTable`, :class:`SelectionSettings`).

Positions and walls are world-frame (m), velocities m/s, accelerations m/s^2, times s.
n is the number of rows of the agents' table (robots of the batch), k the number of
members of a group that shares predictions, B the bodies of the batch, T the samples
of the time grid.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.predictors import TurnRateInputs
from nao_arena.stopping import Knowledge

__all__ = [
    "AgentTable",
    "Decisions",
    "DecidingRobots",
    "ObstacleLists",
    "OneGroup",
    "OwnInputs",
    "GroupPaths",
    "RobotRows",
    "SelectionSettings",
]


class AgentTable(NamedTuple):
    """The agents' table (:class:`~nao_arena.agents._nao_columns.AgentColumns`), one row
    per agent: ``real`` (n, N_REAL) float64 state, ``whole`` (n, N_WHOLE) int64 state
    and flags, ``opt`` (n, N_OPT) float64 options; their columns and units are those of
    :mod:`~nao_arena.agents._nao_columns` (CUR_X: m/s^2, AGE: s, MARGIN: m, ...)."""

    real: NDArray[np.float64]
    whole: NDArray[np.int64]
    opt: NDArray[np.float64]


class OwnInputs(NamedTuple):
    """What :func:`~nao_arena.agents._nao_batch.own_rows` (and ``prepare_rows``) gathers
    each robot's own state from, contiguous as the kernels take them: rows (n,) int64,
    the batch rows of the robots; bodies (R,) int64, the body of each batch row; per
    body (B rows) positions (B, 2) m, velocities (B, 2) m/s, radii (B,) m, a_max (B,)
    m/s^2, v_max (B,) m/s; per batch row the goals (R, 2) m and the CSR neighbour lists
    nb_start (R + 1,), nb_index (body indices); traffic (B,) bool: per body whether it
    is traffic (empty: no body is)."""

    rows: NDArray[np.int64]
    bodies: NDArray[np.int64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    radii: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]
    goals: NDArray[np.float64]
    nb_start: NDArray[np.int64]
    nb_index: NDArray[np.int64]
    traffic: NDArray[np.bool_]


class RobotRows(NamedTuple):
    """Each robot's own state, by row of the agents' table: pos (n, 2) m, vel (n, 2)
    m/s, rad (n,) m, a_max (n,) m/s^2, v_max (n,) m/s, and traffic_near (n,) bool:
    whether traffic is among its neighbours."""

    pos: NDArray[np.float64]
    vel: NDArray[np.float64]
    rad: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]
    traffic_near: NDArray[np.bool_]


class GroupPaths(NamedTuple):
    """The time grid and what a group's predictor made of it, shared by the group's
    members: times (T,) s (from 0, increasing), pred (B, T, 2) m: each body's predicted
    centre at each time; excursion (B,) m and finite (B,) bool: per body the largest
    distance of a predicted centre from the first one and whether all its centres are
    finite (:func:`~nao_arena.geometry.kernels.path_excursions` of ``pred``)."""

    times: NDArray[np.float64]
    pred: NDArray[np.float64]
    excursion: NDArray[np.float64]
    finite: NDArray[np.bool_]


class ObstacleLists(NamedTuple):
    """The obstacles each member k of a group sees, as CSR lists in the members' order:
    the bodies nb_index[nb_start[k]:nb_start[k + 1]] (body indices; nb_start (k + 1,)),
    and the walls wall_index[wall_start[k]:wall_start[k + 1]] (wall_start (k + 1,)) of
    every wall's ends wall_seg (W, 2, 2) m and half-thickness wall_half (W,) m."""

    nb_start: NDArray[np.int64]
    nb_index: NDArray[np.int64]
    wall_seg: NDArray[np.float64]
    wall_half: NDArray[np.float64]
    wall_start: NDArray[np.int64]
    wall_index: NDArray[np.int64]


class DecidingRobots(NamedTuple):
    """The robots of :func:`~nao_arena.agents._nao_decide.decide_batch`, one row each
    (the members of a group): pos (k, 2) m, vel (k, 2) m/s, grow (k,) m: what every
    obstacle grows by (the robot's radius plus its margin), a_max (k,) m/s^2 and v_max
    (k,) m/s."""

    pos: NDArray[np.float64]
    vel: NDArray[np.float64]
    grow: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]


class SelectionSettings(NamedTuple):
    """The settings of the repairs and selections, as
    :func:`~nao_arena.geometry.select_acceleration` and
    :func:`~nao_arena.geometry.repair_acceleration` pass them: ring_radii (k, rings)
    m/s^2, per robot the radii of the fallback rings; unit_rings (rings, points, 2) their
    unit vectors; repair_steps (S,) the radii of the repair's rings (fractions of
    a_max); repair_unit (P, 2) their unit vectors; max_disks, the most disks of the
    disk picture; n_sub disks per piece of the obstacle paths and per_second (per s) at
    least; sliver_depth (fraction of a_max), the deepest sliver a thinned-out disk
    picture leaves."""

    ring_radii: NDArray[np.float64]
    unit_rings: NDArray[np.float64]
    repair_steps: NDArray[np.float64]
    repair_unit: NDArray[np.float64]
    max_disks: int
    n_sub: int
    per_second: float
    sliver_depth: float


class Decisions(NamedTuple):
    """Per robot of :func:`~nao_arena.agents._nao_decide.decide_batch` (k rows, written
    by it): kind (k,) int64, an :class:`~nao_arena.geometry.outcome.Outcome`; accel
    (k, 2) m/s^2 for REPAIRED, DESIRED and ADJUSTED; tested (k,) int64, the candidates
    the selection tested."""

    kind: NDArray[np.int64]
    accel: NDArray[np.float64]
    tested: NDArray[np.int64]


class OneGroup(NamedTuple):
    """What :func:`~nao_arena.agents._nao_batch.decide_rows` and
    :func:`~nao_arena.agents._nao_batch.settle_rows` take of a batch whose agents share
    one predictor and regular time grid, besides the robots' rows: the grid times (T,) s
    (from 0, increasing); every body's predicted centres pred (B, T, 2) m, or, where
    ``arcs`` holds the bodies (the built-in ``turn_rate`` predictor), none yet (0 rows:
    decide_rows makes them from ``arcs``,
    :func:`~nao_arena.predictors.turn_rate_arcs`); the :class:`SelectionSettings` of
    the rows; what the stopping-plan rule takes (``know``,
    :class:`~nao_arena.stopping.Knowledge`; the world's ``substeps``; the plans'
    ``margin`` m); and ``finish``: whether no robot's decision is to be made robust
    in Python (the rule may then run in the same call)."""

    times: NDArray[np.float64]
    pred: NDArray[np.float64]
    arcs: TurnRateInputs
    settings: SelectionSettings
    know: Knowledge
    substeps: int
    margin: float
    finish: bool
