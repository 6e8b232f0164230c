"""The ``nao`` agents' state as columns: one row per agent of a batch.

Each :class:`~nao_arena.agents.nao.NAOAgent` keeps its numeric state (current
acceleration, the age of its adjustment, its liveness bookkeeping, the status of
its last selection) and its numeric options in one row of an
:class:`AgentColumns`; its attributes (``agent.detour``, ``agent.current``,
``agent.margin`` ...) read and write that row (:class:`Column`). The agents of
one batch share one table (:func:`columns_of`), so that a step updates them all
in a few compiled calls instead of a Python call per robot. A new agent has a
table of its own; a batch with other members than the last gathers the rows of
its agents into a new table (values unchanged).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.selection import Selection
from nao_arena.jit import inner_kernel, kernel

from ._nao_bundles import AgentTable, SelectionSettings

# real (float64) columns: state
CUR_X, CUR_Y = 0, 1  # the current acceleration (m/s^2)
SEL_X, SEL_Y = 2, 3  # the acceleration of the last full selection (m/s^2)
AGE = 4  # s since the last full selection
CRAWL = 5  # s crawling away from the goal
FREE = 6  # s moving freely
DETOUR = 7  # rad: the goal direction's turn (<= 0: right)
SIDE = 8  # -1: detours turn right; +1: left
BEST = 9  # m: the closest the robot has come to its goal
SINCE = 10  # s since it last came 0.5 m closer
N_REAL = 11

# whole (int64) columns: state and flags
TURNS = 0  # how many detour turns
STATUS = 1  # the last full selection's status (index into SELECTION_LABELS; -1: none)
TESTED = 2  # how many candidates the last full selection tested
SETTLING = 3  # 1: within goal_zone of the goal (tracks the desired acceleration)
AROUND = 4  # 1: the last heading target was a way around a wall
SEEN = 5  # which of the table's ``seen`` views the last step saw (-1: none)
ROW = 6  # the robot's row in that view's batch
REPLAN, NAVIGATE, STOPPING = 7, 8, 9  # options (0/1)
CACHED = 10  # 1: the table's ``selections`` entry is the row's last full selection
FALLBACK = 11  # option ``infeasible``: its index in FALLBACKS
N_WHOLE = 12

# option (float64) columns
MARGIN = 0  # m
KEEP_BAND = 1  # m/s^2
GOAL_ZONE = 2  # m
RESELECT = 3  # s (reselect_after)
DETOUR_AFTER = 4  # s
SWITCH_AFTER = 5  # s (switch_side_after)
RANGE = 6  # m (sensing_range)
V_PREF = 7  # m/s (NaN: none, the robot's v_max)
N_OPT = 8

#: the statuses of a full selection, by their codes in the STATUS column (the first
#: three are :class:`~nao_arena.geometry.outcome.Outcome` DESIRED, ADJUSTED, INFEASIBLE)
SELECTION_LABELS: tuple[str, ...] = ("desired", "adjusted", "infeasible", "yielded")
#: the ``infeasible`` options, by their codes in the FALLBACK column
FALLBACKS: tuple[str, ...] = ("auto", "brake", "latest_contact", "stop_in_time")
AUTO, BRAKE = 0, 1
NO_SELECTION = -1
ADJUSTED_SELECTION = 1
YIELDED = 3

#: what the keep test says of a member's current acceleration (the status arrays of
#: keep_candidates, settle_members and the per-robot path)
DECIDE = 0  # not kept: decide (repair or select) this step
KEPT = 1  # still admissible: kept
KEEP_UNTESTED = 2  # may be kept, but the admissibility test is still to be done

PROGRESS = 0.5  # m closer to the goal that counts as progress (switch_side_after)


@dataclass
class StepMemo:
    """What a table works out once and reuses while the batches it steps repeat it:
    the traffic mask (per body, None: no body is traffic) of the last read-only kinds
    array (``kinds``, ``traffic``; see :func:`~nao_arena.agents._nao_step.traffic_mask`)
    and the fallback ring radii (n, rings) m/s^2 of the last limits (``limits``: the
    bytes of a_max, ``ring_radii``; see
    :func:`~nao_arena.agents._nao_decide.ring_radii_rows`). Replaced a pair at a time.
    ``settings``: the last selection settings
    (:func:`~nao_arena.agents._nao_decide.selection_settings`), valid while their
    ring radii are ``ring_radii``."""

    kinds: Any = None
    traffic: NDArray[np.bool_] | None = None
    limits: bytes | None = None
    ring_radii: NDArray[np.float64] | None = None
    settings: SelectionSettings | None = None


class AgentColumns:
    """The state and numeric options of n agents, one row each: ``real`` (n, N_REAL)
    float64, ``whole`` (n, N_WHOLE) int64 and ``opt`` (n, N_OPT) float64 (column
    indices above); ``selections``: each row's last full selection once built
    (:class:`Selection`; where CACHED is 0, built from the columns when asked for);
    ``seen``:
    (batch, predictions, excursions) of the last step, indexed by the SEEN column;
    ``members``: the agents of the rows (None once an agent has left the table);
    ``memo``: what its steps work out once (:class:`StepMemo`); ``table``: the three
    arrays as the compiled calls take them
    (:class:`~nao_arena.agents._nao_bundles.AgentTable`)."""

    def __init__(self, n: int) -> None:
        self.real = np.zeros((n, N_REAL))
        self.whole = np.zeros((n, N_WHOLE), dtype=np.int64)
        self.opt = np.zeros((n, N_OPT))
        self.table = AgentTable(self.real, self.whole, self.opt)
        self.selections: list[Selection | None] = [None] * n
        self.seen: list[tuple[Any, NDArray[np.float64], Any]] = []
        self.members: tuple[Any, ...] | None = None
        self.version = 0  # counts changes of the members' time grids and predictors
        self._grid_groups: tuple[int, list[NDArray[np.int64]]] | None = None
        self.memo = StepMemo()

    def copy_row(self, src: AgentColumns, r: int, i: int) -> None:
        """Row i of this table becomes row r of ``src`` (with its last view)."""
        self.real[i] = src.real[r]
        self.whole[i] = src.whole[r]
        self.opt[i] = src.opt[r]
        self.selections[i] = src.selections[r]
        view = int(src.whole[r, SEEN])
        if view >= 0:
            self.whole[i, SEEN] = len(self.seen)
            self.seen.append(src.seen[view])

    def commit(
        self, r: int | NDArray[np.int64], accel: NDArray[np.float64], status: int, tested: int
    ) -> None:
        """A full selection (status code, candidates tested) of ``accel`` (2,) m/s^2 for
        row r (or of accel (k, 2) for the rows r (k,)): it becomes the current
        acceleration and its age restarts."""
        self.real[r, SEL_X : SEL_Y + 1] = accel
        self.real[r, CUR_X : CUR_Y + 1] = accel
        self.real[r, AGE] = 0.0
        self.whole[r, STATUS] = status
        self.whole[r, TESTED] = tested
        self.whole[r, CACHED] = 0

    def selection(self, r: int) -> Selection | None:
        """Row r's last full selection (built once from the columns)."""
        if self.whole[r, CACHED]:
            return self.selections[r]
        code = int(self.whole[r, STATUS])
        sel = None
        if code != NO_SELECTION:
            sel = Selection(
                self.real[r, SEL_X : SEL_Y + 1].copy(),
                SELECTION_LABELS[code],
                None,
                math.inf,
                int(self.whole[r, TESTED]),
            )
        self.selections[r] = sel
        self.whole[r, CACHED] = 1
        return sel

    def set_selection(self, r: int, sel: Selection | None) -> None:
        """Row r's last full selection becomes ``sel`` (the object is kept as it is)."""
        if sel is None:
            self.whole[r, STATUS] = NO_SELECTION
        else:
            self.real[r, SEL_X : SEL_Y + 1] = sel.accel
            self.whole[r, STATUS] = SELECTION_LABELS.index(sel.status)
            self.whole[r, TESTED] = sel.evaluations
        self.selections[r] = sel
        self.whole[r, CACHED] = 1

    def holds(self, m: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Per row of m: whether its current acceleration is an avoidance adjustment young
        enough to keep (while admissible) even though it lies outside keep_band of the
        desired one (:func:`young_adjustments`)."""
        holds = np.empty(len(m), dtype=np.bool_)
        young_adjustments(m, self.real, self.whole, self.opt, holds)
        return holds

    def grid_groups(self, members: Sequence[Any]) -> list[NDArray[np.int64]]:
        """The rows grouped by (predictor name, time grid) in order of first appearance:
        the agents of a group share predictions; worked out again when a member's grid
        or predictor changes."""
        if self._grid_groups is None or self._grid_groups[0] != self.version:
            keys: dict[tuple[str, bytes], list[int]] = {}
            for i, ag in enumerate(members):
                keys.setdefault((ag.predictor_name, ag.times.tobytes()), []).append(i)
            self._grid_groups = (
                self.version,
                [np.asarray(m, dtype=np.int64) for m in keys.values()],
            )
        return self._grid_groups[1]


@inner_kernel
def commit_row(real, whole, i, x, y, status, tested):  # pragma: no cover
    """:meth:`AgentColumns.commit` of the acceleration (x, y) m/s^2 for row i, in the
    compiled passes."""
    real[i, CUR_X] = real[i, SEL_X] = x
    real[i, CUR_Y] = real[i, SEL_Y] = y
    real[i, AGE] = 0.0
    whole[i, STATUS] = status
    whole[i, TESTED] = tested
    whole[i, CACHED] = 0


class TableMember(Protocol):
    """An agent whose state is row ``_row`` of the table ``_cols``."""

    _cols: AgentColumns
    _row: int


def columns_of(agents: Sequence[TableMember]) -> AgentColumns:
    """The one table whose rows are ``agents`` in this order: theirs if they already
    share it, else a new one with their rows (the tables they leave are no longer
    any batch's)."""
    cols = agents[0]._cols
    members = cols.members
    if members is not None and len(members) == len(agents) and members == tuple(agents):
        return cols
    new = AgentColumns(len(agents))
    for i, ag in enumerate(agents):
        new.copy_row(ag._cols, ag._row, i)
    for ag in agents:
        ag._cols.members = None
    for i, ag in enumerate(agents):
        ag._cols, ag._row = new, i
    new.members = tuple(agents)
    return new


class Column:
    """An agent attribute kept in its row of its table: ``table`` "real", "whole" or
    "opt", column ``index``, read as ``kind`` (float, int or bool)."""

    def __init__(self, table: str, index: int, kind: type = float) -> None:
        self.table, self.index, self.kind = table, index, kind

    def __get__(self, ag: Any, owner: type | None = None) -> Any:
        if ag is None:
            return self
        return self.kind(getattr(ag._cols, self.table)[ag._row, self.index])

    def __set__(self, ag: Any, value: Any) -> None:
        getattr(ag._cols, self.table)[ag._row, self.index] = value


class OptionalSpeed(Column):
    """A speed option (m/s) that may be None (stored as NaN)."""

    def __get__(self, ag: Any, owner: type | None = None) -> Any:
        if ag is None:
            return self
        value = float(ag._cols.opt[ag._row, self.index])
        return None if math.isnan(value) else value

    def __set__(self, ag: Any, value: Any) -> None:
        if value is not None and math.isnan(float(value)):
            raise ValueError("v_pref: expected a speed (m/s) or None, got NaN")
        ag._cols.opt[ag._row, self.index] = math.nan if value is None else float(value)


class Choice(Column):
    """An option that is one of ``labels`` (stored as its index in the whole table)."""

    def __init__(self, index: int, labels: tuple[str, ...], name: str) -> None:
        super().__init__("whole", index, int)
        self.labels, self.name = labels, name

    def __get__(self, ag: Any, owner: type | None = None) -> Any:
        if ag is None:
            return self
        return self.labels[int(ag._cols.whole[ag._row, self.index])]

    def __set__(self, ag: Any, value: Any) -> None:
        if value not in self.labels:
            raise ValueError(
                f"{self.name}: expected one of "
                f"{', '.join(repr(v) for v in self.labels)}, got {value!r}"
            )
        ag._cols.whole[ag._row, self.index] = self.labels.index(value)


class Acceleration:
    """The agent's current acceleration (2,) m/s^2: a view of its row (writes go
    through)."""

    def __get__(self, ag: Any, owner: type | None = None) -> Any:
        if ag is None:
            return self
        return ag._cols.real[ag._row, CUR_X : CUR_Y + 1]

    def __set__(self, ag: Any, value: Any) -> None:
        ag._cols.real[ag._row, CUR_X : CUR_Y + 1] = value


class GridAttribute:
    """An attribute that decides which agents share predictions (time grid,
    predictor): setting it tells the agent's table to group its rows again."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.slot = "_" + name

    def __get__(self, ag: Any, owner: type | None = None) -> Any:
        if ag is None:
            return self
        return ag.__dict__[self.slot]

    def __set__(self, ag: Any, value: Any) -> None:
        ag.__dict__[self.slot] = value
        ag._cols.version += 1


@kernel
def young_adjustments(m, real, whole, opt, holds):  # pragma: no cover
    """holds[j]: whether row m[j]'s current acceleration is an avoidance adjustment young
    enough to keep (while admissible) even though it lies outside keep_band of the
    desired one (last selection "adjusted", not settling, AGE < reselect_after)."""
    for j in range(m.shape[0]):
        i = m[j]
        holds[j] = (
            whole[i, STATUS] == ADJUSTED_SELECTION
            and whole[i, SETTLING] == 0
            and real[i, AGE] < opt[i, RESELECT] - 1e-9
        )


@inner_kernel
def detour_row(r, far, crawling, dt, to_goal, held, real, whole, opt):  # pragma: no cover
    """One step (dt s) of row r's liveness bookkeeping (see the ``nao`` module's
    Liveness) from: far from the goal, crawling (below v_max / 4), the distance to the
    goal (m) and held (its nearest neighbour stands still close by). Returns whether
    the detour turns once more: the caller draws the angle from the agent's generator
    (TURNS is already counted)."""
    if to_goal < real[r, BEST] - PROGRESS:
        real[r, BEST] = to_goal
        real[r, SINCE] = 0.0
    elif held:
        real[r, SINCE] += dt
    if far and real[r, SINCE] >= opt[r, SWITCH_AFTER]:
        # no progress on this side: detour to the other side from now on
        real[r, SIDE] = -real[r, SIDE]
        real[r, SINCE] = 0.0
        real[r, BEST] = to_goal
        real[r, DETOUR] = 0.0
        whole[r, TURNS] = 0
        real[r, CRAWL] = 0.0
    if far and crawling:
        real[r, CRAWL] += dt
        real[r, FREE] = 0.0
    else:
        real[r, FREE] += dt
        real[r, CRAWL] = 0.0
    if real[r, CRAWL] >= opt[r, DETOUR_AFTER] * (whole[r, TURNS] + 1):
        if abs(real[r, DETOUR]) < 5.0 * np.pi / 6.0:
            # each further detour_after of crawling turns another 30-60 degrees
            whole[r, TURNS] += 1
            return True
        if whole[r, AROUND] != 0:
            # turned all the way round on a way around a wall and still held (backing
            # off further leads into the walls): head along the way again
            real[r, DETOUR] = 0.0
            whole[r, TURNS] = 0
            real[r, CRAWL] = 0.0
    elif real[r, DETOUR] != 0.0 and real[r, FREE] >= opt[r, DETOUR_AFTER]:
        real[r, DETOUR] = 0.0
        whole[r, TURNS] = 0
    return False


@inner_kernel
def liveness_batch(
    live, positions, velocities, goals, radii, v_max, held, dt, real, whole, opt, turn
):  # pragma: no cover
    """One step (dt s) of the bookkeeping of the rows with ``live``: the detours
    (:func:`detour_row`; turn[r] = 1 where the detour turns once more), SETTLING (within
    goal_zone of the goal) and AGE. Per row: position (m), velocity (m/s), goal (m),
    radius (m), v_max (m/s), held (see :func:`detour_row`)."""
    for r in range(live.shape[0]):
        turn[r] = False
        if not live[r]:
            continue
        speed = math.hypot(velocities[r, 0], velocities[r, 1])
        to_goal = math.hypot(goals[r, 0] - positions[r, 0], goals[r, 1] - positions[r, 1])
        turn[r] = detour_row(
            r,
            to_goal > 4 * radii[r],
            speed < 0.25 * v_max[r],
            dt,
            to_goal,
            held[r],
            real,
            whole,
            opt,
        )
        whole[r, SETTLING] = to_goal <= opt[r, GOAL_ZONE]
        real[r, AGE] += dt
