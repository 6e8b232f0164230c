"""What an agent sees: its own state and its neighbours within sensing range.

All positions, velocities and accelerations are in the world frame (m,
m/s, m/s^2); times in s. Known paths (the true future centres of scripted
traffic) and shared plans (the acceleration a cooperative agent committed
to) are included where the map provides them. :class:`SensingBatch` holds
every robot's view of one step as bulk arrays (batched agents read it
directly; :meth:`SensingBatch.observation` gives one robot's
:class:`Observation`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from nao_arena.communication import Heard
from nao_arena.neighbours import in_range_lists

T = TypeVar("T")

__all__ = [
    "LastArrayMemo",
    "Neighbours",
    "Observation",
    "ReadOnlyRoutes",
    "SensingBatch",
    "neighbour_lists",
    "neighbours_in_range",
    "is_frozen",
    "kinds_tuple",
    "read_only",
]


def _vec(n: int = 0) -> NDArray[np.float64]:
    return np.zeros((n, 2))


@dataclass(frozen=True)
class Neighbours:
    """The other bodies an agent senses, one row each.

    ids: body indices in the world; kinds: "robot" or "traffic";
    positions, velocities, accelerations: (n, 2); radii: (n,) m.
    known_paths: (n, T, 2) true future centres at ``path_times`` (NaN rows
    where unknown); plans: (n, 2) committed accelerations (NaN where the
    neighbour shares none).
    """

    ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    kinds: tuple[str, ...] = ()
    positions: NDArray[np.float64] = field(default_factory=_vec)
    velocities: NDArray[np.float64] = field(default_factory=_vec)
    accelerations: NDArray[np.float64] = field(default_factory=_vec)
    radii: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    path_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    known_paths: NDArray[np.float64] | None = None
    plans: NDArray[np.float64] | None = None

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(frozen=True)
class Observation:
    """One agent's view at one control step.

    time: simulated time (s); dt: control period (s); robot_id: the robot's index
    (robot order, 0 .. R - 1; its neighbours' ``ids`` are body indices in the
    world); own state in the world frame; goal (2,) m or None; route (M, 2)
    waypoints or None; limits a_max (m/s^2) and v_max (m/s); walls: (W, 2, 2)
    segment end points (m) within range, with their half-thickness
    ``wall_radius`` (W,) m.
    """

    time: float
    dt: float
    robot_id: int
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    radius: float
    a_max: float
    v_max: float
    goal: NDArray[np.float64] | None = None
    route: NDArray[np.float64] | None = None
    neighbours: Neighbours = field(default_factory=Neighbours)
    walls: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2, 2)))
    wall_radius: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    own_path: NDArray[np.float64] | None = None


def neighbours_in_range(
    me: int,
    positions: NDArray[np.float64],
    sensing_range: float,
    max_neighbours: int | None = None,
) -> NDArray[np.int64]:
    """Indices of bodies within ``sensing_range`` (m) of body ``me``, nearest first.

    Ties are broken by index so the order is deterministic.
    """
    rel = positions - positions[me]
    d = np.sqrt(rel[:, 0] * rel[:, 0] + rel[:, 1] * rel[:, 1])
    d[me] = np.inf
    idx = np.flatnonzero(d <= sensing_range)
    idx = idx[np.lexsort((idx, d[idx]))]
    if max_neighbours is not None:
        idx = idx[:max_neighbours]
    return idx.astype(np.int64)


def neighbour_lists(
    bodies: NDArray[np.int64],
    positions: NDArray[np.float64],
    sensing_range: float,
    max_neighbours: int | None = None,
    hypot: bool = False,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """:func:`neighbours_in_range` for every body of ``bodies`` at once (same lists, same order).

    Returns CSR arrays (start (B + 1,), index (E,)): the neighbours of
    bodies[k] are index[start[k]:start[k + 1]], nearest first, ties by index.
    hypot: distances (m) by ``math.hypot`` (the env's observations) instead of
    sqrt(dx^2 + dy^2) (what the agents sense); the two can differ in the last bit.
    Found through the neighbour index (:func:`nao_arena.neighbours.in_range_lists`).
    """
    bodies = np.ascontiguousarray(bodies, dtype=np.int64)
    b = len(bodies)
    if b == 0 or len(positions) == 0:
        return np.zeros(b + 1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return in_range_lists(
        bodies,
        np.ascontiguousarray(positions, dtype=np.float64),
        float(sensing_range),
        -1 if max_neighbours is None else int(max_neighbours),
        bool(hypot),
    )


def read_only(array: NDArray) -> NDArray:
    """``array`` itself if no one can write into its memory, else a copy of it that no one
    can: read-only, in memory an immutable ``bytes`` object owns (``setflags(write=True)``
    raises ValueError on it and on every view of it, and no ``.base`` leads to writable
    memory). What agents sense is made of these: they share no writable memory with the
    arena."""
    if is_frozen(array):
        return array
    data = np.ascontiguousarray(array)
    return np.ndarray(data.shape, data.dtype, buffer=data.tobytes())


def is_frozen(array: NDArray) -> bool:
    """Whether ``array`` is read-only and its memory belongs to a ``bytes`` object."""
    base = array.base
    if type(base) is bytes:
        return True  # a bytes object's buffer is read-only: so is every array on it
    if array.flags.writeable:
        return False
    while isinstance(base, np.ndarray):
        base = base.base
    return isinstance(base, bytes)


class LastArrayMemo(Generic[T]):
    """``derive(array)``, remembered for the last frozen array it was given (by identity;
    see :func:`read_only`: its memory cannot change). Made for what agents derive from
    the arena's kinds array, which every step's batch shares: worked out once per arena.
    Threads may share it: the remembered pair is replaced whole."""

    __slots__ = ("_derive", "_last")

    def __init__(self, derive: Callable[[NDArray[Any]], T]) -> None:
        self._derive = derive
        self._last: tuple[NDArray[Any], T] | None = None

    def __call__(self, array: NDArray[Any]) -> T:
        last = self._last
        if last is not None and last[0] is array:
            return last[1]
        value = self._derive(array)
        if is_frozen(array):
            self._last = (array, value)
        return value


kinds_tuple: LastArrayMemo[tuple[str, ...]] = LastArrayMemo(tuple)
"""``tuple(kinds)`` of a batch's kinds array, remembered for the arena's."""


class ReadOnlyRoutes(tuple):
    """Routes (M, 2) m (or None) of the robots, each read-only (made by :meth:`of`)."""

    __slots__ = ()

    @classmethod
    def of(cls, routes: Sequence[NDArray[np.float64] | None]) -> ReadOnlyRoutes:
        """``routes`` as read-only views (no copy)."""
        if type(routes) is cls:
            return routes
        return cls(None if r is None else read_only(np.asarray(r)) for r in routes)


_BATCH_ARRAYS = (
    "positions",
    "velocities",
    "accelerations",
    "radii",
    "a_max",
    "v_max",
    "kinds",
    "plans",
    "known_paths",
    "path_times",
    "bodies",
    "goals",
    "walls",
    "wall_radius",
    "nb_start",
    "nb_index",
    "row_bodies",
)
"""The array fields of :class:`SensingBatch` (made read-only)."""


@dataclass(frozen=True)
class SensingBatch:
    """Every robot's view at one control step, as bulk arrays (world frame, m, m/s, m/s^2).

    Body arrays (N bodies): positions, velocities, accelerations (N, 2),
    radii, a_max, v_max (N,), kinds; plans (N, 2) and known_paths (N, T, 2)
    at ``path_times`` (s) as in :class:`Neighbours`. Robot arrays (R robots,
    robot order): bodies (R,) body indices, goals (R, 2), routes. The
    neighbours of robot k are ``nb_index[nb_start[k]:nb_start[k + 1]]``
    (nearest first). ``substeps``: the world's physics substeps per period dt (the
    stopping plans of :mod:`nao_arena.stopping` follow them). :meth:`observation`
    builds the :class:`Observation` a per-robot agent sees; batched agents read the
    arrays directly.

    Rows and bodies: row i of the body arrays is body i, unless ``row_bodies`` is set
    (then row i is what the batch holds of body ``row_bodies[i]``): with sensing noise
    (:func:`nao_arena.imperfection.with_neighbour_noise`) each (robot, neighbour) pair
    has a row of its own, appended after the bodies' rows, and the neighbour lists
    point at those rows. ``bodies``, ``nb_index`` and :meth:`neighbour_ids` are rows;
    :meth:`body_of` gives the bodies, and so do the ``ids`` of :meth:`observation`'s
    neighbours and of :meth:`everyone`.

    Latency: ``time`` (s) is when the batch was sensed; ``latency`` (s) is the sensing
    latency of the arena that delivers it (0: none), and ``age`` (s) how long ago the
    batch was sensed when the agents receive it (the latency, in whole control periods;
    less at the start of an episode, when the first state is all there is). An agent
    that knows what it commanded since can bring what it sensed up to now (the ``nao``
    agents do). ``actuation_lag`` (s): the time constant of the first-order response of
    the robots' applied accelerations to their commands (0: none; see
    :mod:`nao_arena.imperfection`), which a robot knows of its own actuators and may
    invert (the ``nao`` agents do). ``sensing_noise``: the standard deviations (position
    m, velocity m/s, acceleration m/s^2) of the noise on what the robots sense of their
    neighbours, which a robot knows of its own sensors.

    Communication (:mod:`nao_arena.communication`): ``heard`` is None when it is perfect
    (every robot shares its state and plan with every other at once); otherwise it holds
    which robots are linked this period and the last message each robot heard from each
    other (:class:`~nao_arena.communication.Heard`, robot order, current time). Then the
    neighbour lists point at rows of their own (as with noise) and a neighbour's ``plans``
    row is NaN unless the pair is linked.

    The batch is frozen (assigning an attribute raises), and every array it holds
    is read-only in memory no one can write (see :func:`read_only`: an array given
    to the constructor is copied unless it already is), and so is every view of it
    handed out (an observation's position, goal, walls ...): an agent that writes
    into what it senses gets an exception (a fault), whether it writes, calls
    ``setflags(write=True)`` on an array or on its ``.base``, or assigns an
    attribute; it cannot change the arena's state, another agent's senses or the
    episode's record. ``routes`` is a :class:`ReadOnlyRoutes` tuple.
    """

    time: float
    dt: float
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    radii: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]
    kinds: NDArray[np.str_]
    plans: NDArray[np.float64] | None
    known_paths: NDArray[np.float64] | None
    path_times: NDArray[np.float64]
    bodies: NDArray[np.int64]
    goals: NDArray[np.float64]
    routes: Sequence[NDArray[np.float64] | None]
    walls: NDArray[np.float64]
    wall_radius: NDArray[np.float64]
    nb_start: NDArray[np.int64]
    nb_index: NDArray[np.int64]
    substeps: int = 10
    row_bodies: NDArray[np.int64] | None = None
    latency: float = 0.0
    age: float = 0.0
    actuation_lag: float = 0.0
    sensing_noise: tuple[float, float, float] = (0.0, 0.0, 0.0)
    heard: Heard | None = None
    _everyone: Neighbours | None = None

    def __post_init__(self) -> None:
        fields = self.__dict__
        for name in _BATCH_ARRAYS:
            value = fields[name]
            # an array on a bytes object's memory is frozen already (see is_frozen)
            if value is not None and type(value.base) is not bytes:
                fields[name] = read_only(value)
        fields["routes"] = ReadOnlyRoutes.of(self.routes)

    @classmethod
    def of_observation(cls, obs: Observation) -> SensingBatch:
        """The one-robot batch of ``obs``: body 0 is the robot (robot 0), bodies 1 .. n its
        neighbours in their order (what it does not know of them, a_max and v_max, NaN);
        a goal of None is NaN; the robot senses every neighbour and the walls of ``obs``."""
        nb = obs.neighbours
        n = len(nb)

        def own_first(own: object, rows: object, width: tuple[int, ...]) -> NDArray[np.float64]:
            return np.concatenate(
                [
                    np.asarray(own, dtype=np.float64).reshape((1, *width)),
                    np.asarray(rows, dtype=np.float64).reshape((n, *width)),
                ]
            )

        unknown = np.full(n, np.nan)
        t = nb.known_paths.shape[1:] if nb.known_paths is not None else ()
        return cls(
            time=obs.time,
            dt=obs.dt,
            positions=own_first(obs.position, nb.positions, (2,)),
            velocities=own_first(obs.velocity, nb.velocities, (2,)),
            accelerations=own_first(obs.acceleration, nb.accelerations, (2,)),
            radii=own_first(obs.radius, nb.radii, ()),
            a_max=own_first(obs.a_max, unknown, ()),
            v_max=own_first(obs.v_max, unknown, ()),
            kinds=np.array(("robot", *nb.kinds)),
            plans=None if nb.plans is None else own_first(np.full(2, np.nan), nb.plans, (2,)),
            known_paths=(
                None if nb.known_paths is None else own_first(np.full(t, np.nan), nb.known_paths, t)
            ),
            path_times=np.asarray(nb.path_times, dtype=np.float64),
            bodies=np.zeros(1, dtype=np.int64),
            goals=(
                np.full((1, 2), np.nan)
                if obs.goal is None
                else np.asarray(obs.goal, dtype=np.float64).reshape(1, 2)
            ),
            routes=(obs.route,),
            walls=np.asarray(obs.walls, dtype=np.float64),
            wall_radius=np.asarray(obs.wall_radius, dtype=np.float64),
            nb_start=np.array([0, n], dtype=np.int64),
            nb_index=np.arange(1, n + 1, dtype=np.int64),
        )

    def neighbour_ids(self, k: int) -> NDArray[np.int64]:
        """The rows (body indices, unless ``row_bodies`` is set) of what robot k senses,
        nearest first."""
        return self.nb_index[self.nb_start[k] : self.nb_start[k + 1]]

    def body_of(self, rows: NDArray[np.int64]) -> NDArray[np.int64]:
        """The body index (in the world) of each of ``rows`` (rows of the body arrays)."""
        if self.row_bodies is None:
            return np.asarray(rows, dtype=np.int64)
        return self.row_bodies[rows]

    def everyone(self) -> Neighbours:
        """All rows as one :class:`Neighbours` (row i of the batch; its ``ids``: the
        bodies): predict once, index per robot."""
        everyone = self._everyone
        if everyone is None:
            everyone = Neighbours(
                ids=self.body_of(np.arange(len(self.positions), dtype=np.int64)),
                kinds=kinds_tuple(self.kinds),
                positions=self.positions,
                velocities=self.velocities,
                accelerations=self.accelerations,
                radii=self.radii,
                path_times=self.path_times,
                known_paths=self.known_paths,
                plans=self.plans,
            )
            self.__dict__["_everyone"] = everyone
        return everyone

    def observation(self, k: int) -> Observation:
        """Robot k's :class:`Observation` (robot order)."""
        idx = self.neighbour_ids(k)
        body = int(self.bodies[k])
        nb = Neighbours(
            ids=self.body_of(idx),
            kinds=tuple(self.kinds[idx]),
            positions=self.positions[idx],
            velocities=self.velocities[idx],
            accelerations=self.accelerations[idx],
            radii=self.radii[idx],
            path_times=self.path_times,
            known_paths=None if self.known_paths is None else self.known_paths[idx],
            plans=None if self.plans is None else self.plans[idx],
        )
        return Observation(
            time=self.time,
            dt=self.dt,
            robot_id=int(k),
            position=self.positions[body],
            velocity=self.velocities[body],
            acceleration=self.accelerations[body],
            radius=float(self.radii[body]),
            a_max=float(self.a_max[body]),
            v_max=float(self.v_max[body]),
            goal=self.goals[k],
            route=self.routes[k],
            neighbours=nb,
            walls=self.walls,
            wall_radius=self.wall_radius,
        )
