"""What the compiled baselines (``orca``, ``cbf``) share around their kernels: arrays as
the kernels take them (contiguous, typed) and bundled by what they describe
(:class:`BodyArrays`, :class:`RobotTargets`; the neighbour lists and walls in the
geometry's bundles :class:`~nao_arena.geometry.kernels.IndexLists` and
:class:`~nao_arena.geometry.kernels.WorldWalls`), the robots' mask
memoised for the arena's kinds array, the agents' option tables memoised per group of
agents, and the dispatch of a batch between the kernel and subclasses with an ``act`` of
their own."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Generic, NamedTuple, TypeVar

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.kernels import IndexLists, WorldWalls
from nao_arena.sensing import LastArrayMemo, SensingBatch

__all__ = [
    "BodyArrays",
    "OptionTables",
    "RobotTargets",
    "act_rows",
    "body_arrays",
    "f64",
    "i64",
    "neighbour_lists",
    "robot_mask",
    "wall_segments",
]

T = TypeVar("T")


def f64(a: Any) -> NDArray[np.float64]:
    """A contiguous float64 array (a copy only where needed: a batch's read-only arrays
    go to the kernel as they are)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def i64(a: Any) -> NDArray[np.int64]:
    """A contiguous int64 array (a copy only where needed, as :func:`f64`)."""
    return np.ascontiguousarray(a, dtype=np.int64)


class BodyArrays(NamedTuple):
    """Every body sensed (N rows, world frame) as the kernels take them: reactive (N,)
    the bodies that reciprocate (take half of the avoidance), positions (N, 2) m,
    velocities (N, 2) m/s, radii (N,) m, a_max (N,) m/s^2, v_max (N,) m/s."""

    reactive: NDArray[np.bool_]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    radii: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]


class RobotTargets(NamedTuple):
    """The robots (R, robot order): their bodies (R,) (body indices) and the points they
    head for, targets (R, 2) m where has_target (R,)."""

    bodies: NDArray[np.int64]
    targets: NDArray[np.float64]
    has_target: NDArray[np.bool_]


def body_arrays(batch: SensingBatch, reactive: NDArray[np.bool_] | None = None) -> BodyArrays:
    """The bodies of ``batch`` as :class:`BodyArrays`; ``reactive`` None: the robots."""
    return BodyArrays(
        robot_mask(batch.kinds) if reactive is None else reactive,
        f64(batch.positions),
        f64(batch.velocities),
        f64(batch.radii),
        f64(batch.a_max),
        f64(batch.v_max),
    )


def wall_segments(batch: SensingBatch) -> WorldWalls:
    """The walls of ``batch`` as :class:`~nao_arena.geometry.kernels.WorldWalls`."""
    return WorldWalls(f64(batch.walls).reshape(-1, 2, 2), f64(batch.wall_radius))


def neighbour_lists(batch: SensingBatch) -> IndexLists:
    """The neighbour lists of ``batch`` (robot k's neighbours are the bodies
    ``indices[start[k]:start[k + 1]]``) as :class:`~nao_arena.geometry.kernels.IndexLists`."""
    return IndexLists(i64(batch.nb_start), i64(batch.nb_index))


_ROBOT_MASKS: LastArrayMemo[NDArray[np.bool_]] = LastArrayMemo(
    lambda kinds: np.asarray(kinds) == "robot"
)


def robot_mask(kinds: NDArray[np.str_]) -> NDArray[np.bool_]:
    """Which bodies are robots (they reciprocate), remembered for the arena's kinds array
    (every step's batch shares it)."""
    return _ROBOT_MASKS(kinds)


class OptionTables(Generic[T]):
    """The kernel's option table of a group of agents (``compute(agents)``), memoised per
    sequence of agents (the arena asks for the same robots every step) until
    :meth:`clear` (an option of some agent was set). The agents are kept with their
    table, so that their ids stay theirs while it is here; at most 16 groups are kept."""

    def __init__(self, compute: Callable[[Sequence[Any]], T]) -> None:
        self._compute = compute
        self._tables: dict[tuple[int, ...], tuple[list[Any], T]] = {}

    def __call__(self, agents: Sequence[Any]) -> T:
        key = tuple(map(id, agents))
        hit = self._tables.get(key)
        if hit is None:
            if len(self._tables) > 16:
                self._tables.clear()
            hit = self._tables[key] = (list(agents), self._compute(agents))
        return hit[1]

    def clear(self) -> None:
        """Forget every table (an option of some agent may have changed)."""
        self._tables.clear()


def act_rows(
    agents: Sequence[Any],
    batch: SensingBatch,
    rows: Sequence[int],
    base_act: Callable[..., Any],
    compiled: Callable[[Sequence[Any], SensingBatch, NDArray[np.int64]], NDArray[np.float64]],
) -> NDArray[np.float64] | list[NDArray[np.float64] | Exception]:
    """An ``act_batch``: ``compiled(agents, batch, rows)`` (an array (len(rows), 2) m/s^2)
    when every agent's ``act`` is ``base_act``; else the agents of a subclass with an
    ``act`` of its own act robot by robot, the others in one compiled call, and the
    result is a list with one acceleration or exception per row."""
    rows_a = np.asarray(rows, dtype=np.int64)
    if all(type(ag).act is base_act for ag in agents):
        return compiled(agents, batch, rows_a)
    out: list[NDArray[np.float64] | Exception] = [np.zeros(2)] * len(rows_a)
    todo = []
    for i, ag in enumerate(agents):
        if type(ag).act is base_act:
            todo.append(i)
            continue
        try:
            out[i] = ag.act(batch.observation(int(rows_a[i])))
        except Exception as exc:  # noqa: BLE001 - the agent's failure
            out[i] = exc
    if todo:
        acc = compiled([agents[i] for i in todo], batch, rows_a[todo])
        for j, i in enumerate(todo):
            out[i] = acc[j]
    return out
