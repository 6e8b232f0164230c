"""The physical world: disc bodies and static walls in pymunk.

This is the only module that imports pymunk. Bodies are the map's robots
and traffic vehicles in map order (:meth:`nao_arena.maps.MapSpec.bodies`);
walls are static segments (capsules) and convex polygons. Contacts between
bodies and with walls are resolved by pymunk with the map's elasticity and
friction, except a recorded person's: a replayed recording cannot react, so
its contacts are counted (by the statistics) but not resolved, and it passes
through what it meets. Bodies do not rotate (infinite moment of inertia).

Control and the speed limit
---------------------------
:meth:`World.step` advances one control period dt (s) in ``substeps``
physics steps of h = dt / substeps. Each body's commanded acceleration a
(m/s^2, world frame) is first scaled to |a| <= a_max. The body then
accelerates at a until its speed reaches v_max, at time tau (the positive
root of |v + a tau| = v_max, or never), and coasts for the rest of the
period: in substep j the force m a clamp((tau - j h) / h, 0, 1) is applied,
so that without contacts the velocity after the period is exactly
v + a min(tau, dt) (up to rounding; tests/reference/world_reference.py writes
this model out in numpy). The saturation time tau is
:func:`nao_arena.motion.saturation_time`, shared with the planner. A
body faster than v_max (after a contact) is first slowed to v_max by
scaling its velocity (never by moving it), and then gains no speed. Speeds
above v_max left by contacts at the end of a period are scaled back too, so
observed speeds never exceed v_max.

Bulk state I/O goes through ``pymunk.batch``'s C iterators: one pass per
substep writes all forces and one reads all positions
(:attr:`World.substep_positions`, the engine's exact path within the period:
between two substeps every body moves in a straight line), one more reads
the positions and velocities at the period's end. Their buffers are numpy
arrays owned by the world. Once pymunk has nothing of its own to do around a
step (it checks new bodies on the first), a period's substeps run in
compiled code that calls chipmunk directly, the same C calls ``Space.step``
makes (tested bit for bit). A fresh ``pymunk.Space`` is built on every
:meth:`World.reset`. Same map and same commands give bit-identical
trajectories.

Copies and pickles
------------------
A world is copied (``copy.deepcopy``) and pickled as its map and the
commands it was stepped with since its last reset (:attr:`World.commands`,
16 bytes per body per step); unpickling builds the world afresh from the
map and replays them, so that a copy continues bit for bit like the
original. Pickling the pymunk space itself is not enough: pymunk restores
bodies, shapes and the cached contacts (arbiters, with their accumulated
impulses), but rebuilds the broad phase's bounding-box tree by inserting
the shapes anew, so later steps find the same touching pairs in another
order, some with the two shapes swapped; the solver then rounds
differently wherever a body has two contacts at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple, cast

import numpy as np
import pymunk
import pymunk.batch as pb
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic
from numpy.typing import ArrayLike, NDArray

from nao_arena.jit import inner_kernel, kernel
from nao_arena.maps import MapSpec, PolygonWall, SegmentWall
from nao_arena.motion import (
    clip_accelerations,
    clip_norm,
    limit_norm,
    saturation_time,
    speed_limit_time,
)

__all__ = [
    "World",
    "WorldState",
    "applied_plans",
    "clip_accelerations",
    "speed_limit_time",
]

FloatArray = NDArray[np.float64]

_TOUCHES_NOTHING = pymunk.ShapeFilter(mask=0)
"""The collision filter of a recorded person's shape: a recording cannot react, so its
contacts are counted (the statistics' own check) but not resolved; a body it walks
into is not shoved aside at the recording's speed, as by an infinite mass."""


@dataclass(frozen=True)
class WorldState:
    """The bodies at one instant, world frame, one row per body in map order.

    time (s); positions (N, 2) m; velocities (N, 2) m/s; accelerations
    (N, 2) m/s^2: the mean acceleration over the last control period,
    (v_end - v_start) / dt, contacts included (zeros after a reset); radii
    (N,) m; names and kinds ("robot", "person" or "traffic") per body.
    """

    time: float
    positions: FloatArray
    velocities: FloatArray
    accelerations: FloatArray
    radii: FloatArray
    names: tuple[str, ...]
    kinds: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.radii)


@kernel
def applied_plans(
    commanded: FloatArray, rows: NDArray[np.int64], a_max: FloatArray, n: int
) -> FloatArray:  # pragma: no cover
    """(n, 2) m/s^2: the commanded accelerations of the bodies ``rows`` scaled to
    |a| <= a_max[j] (m/s^2) as :func:`clip_accelerations` scales them (the same
    arithmetic, :func:`~nao_arena.motion.clip_norm`), NaN for the other bodies: the
    accelerations the world applied to the robots (finite commands, as
    :meth:`World.step` takes them)."""
    out = np.full((n, 2), np.nan)
    for j in range(rows.shape[0]):
        r = rows[j]
        out[r, 0], out[r, 1] = clip_norm(commanded[r, 0], commanded[r, 1], a_max[j])
    return out


@kernel
def _plan_period(
    accels: FloatArray,
    v: FloatArray,
    a_max: FloatArray,
    v_max: FloatArray,
    masses: FloatArray,
    dt: float,
    rows: NDArray[np.intp],
    forces: FloatArray,
    v_out: FloatArray,
    a_out: FloatArray,
) -> tuple[bool, bool]:
    """The speed-limit model of one period for every body, in one pass.

    Writes the substep forces (substeps, rows, 2) N (row rows[i] for body i),
    the start velocities scaled to |v| <= v_max into v_out (N, 2) m/s and the
    commands scaled to |a| <= a_max, the accelerations applied, into a_out (N, 2)
    m/s^2 (nothing when a command is not finite; :attr:`World.applied_accelerations`);
    returns (all commands finite, some start velocity was scaled). Same arithmetic
    as :func:`clip_accelerations` (:func:`~nao_arena.motion.clip_norm`; the speed limit
    :func:`~nao_arena.motion.limit_norm`) and the numpy model in
    tests/reference/world_reference.py (bit-identical results; tested); the saturation
    time is :func:`nao_arena.motion.saturation_time`, the model the planner predicts
    with.
    """
    n = accels.shape[0]
    substeps = forces.shape[0]
    h = dt / substeps
    for i in range(n):
        if not (np.isfinite(accels[i, 0]) and np.isfinite(accels[i, 1])):
            return False, False
    any_over = False
    for i in range(n):
        ax, ay = clip_norm(accels[i, 0], accels[i, 1], a_max[i])
        a_out[i, 0], a_out[i, 1] = ax, ay
        vx, vy, speed = limit_norm(v[i, 0], v[i, 1], v_max[i])
        if speed > v_max[i]:
            any_over = True
        v_out[i, 0], v_out[i, 1] = vx, vy
        tau = saturation_time(vx, vy, ax, ay, v_max[i])
        fx, fy = masses[i] * ax, masses[i] * ay
        r = rows[i]
        for j in range(substeps):
            w = min(max((tau - j * h) / h, 0.0), 1.0)
            forces[j, r, 0] = w * fx
            forces[j, r, 1] = w * fy
    return True, any_over


@kernel
def _finish_period(
    data: FloatArray,
    rows: NDArray[np.intp],
    v_max: FloatArray,
    v_start: FloatArray,
    dt: float,
    pos: FloatArray,
    vel: FloatArray,
    acc: FloatArray,
) -> bool:
    """Read back one period: positions and velocities from the batch rows ``data`` (rows, 4)
    into pos / vel (N, 2), velocities above v_max scaled back, mean accelerations
    (vel - v_start) / dt into acc; returns whether some velocity was scaled."""
    any_over = False
    for i in range(pos.shape[0]):
        r = rows[i]
        pos[i, 0], pos[i, 1] = data[r, 0], data[r, 1]
        vx, vy, speed = limit_norm(data[r, 2], data[r, 3], v_max[i])
        if speed > v_max[i]:
            any_over = True
        vel[i, 0], vel[i, 1] = vx, vy
        acc[i, 0] = (vx - v_start[i, 0]) / dt
        acc[i, 1] = (vy - v_start[i, 1]) / dt
    return any_over


def _address(pointer: Any) -> int:
    """A cffi pointer (or function) of pymunk's C library as an integer address."""
    return int(pb.ffi.cast("uintptr_t", pointer))


_SPACE_STEP = _address(pb.ffi.addressof(pb.lib, "cpSpaceStep"))
_EACH_BODY = _address(pb.ffi.addressof(pb.lib, "cpSpaceEachBody"))


def _space_step_call(typingctx: Any, function: Any, space: Any, h: Any) -> Any:
    """``cpSpaceStep(space, h)`` in compiled code: the C function at address
    ``function``, the space at address ``space`` (integers), h (s)."""
    sig = types.void(types.int64, types.int64, types.float64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        fn, sp, step = args
        pointer = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [pointer, ir.DoubleType()])
        builder.call(builder.inttoptr(fn, fnty.as_pointer()), [builder.inttoptr(sp, pointer), step])
        return context.get_dummy_value()

    return sig, codegen


_space_step: Any = intrinsic(_space_step_call)


def _each_body_call(typingctx: Any, function: Any, space: Any, func: Any, data: Any) -> Any:
    """``cpSpaceEachBody(space, func, data)`` in compiled code: the C function at address
    ``function``, every other argument an address (integers)."""
    sig = types.void(types.int64, types.int64, types.int64, types.int64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        fn, sp, it, dat = args
        pointer = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [pointer, pointer, pointer])
        builder.call(
            builder.inttoptr(fn, fnty.as_pointer()),
            [
                builder.inttoptr(sp, pointer),
                builder.inttoptr(it, pointer),
                builder.inttoptr(dat, pointer),
            ],
        )
        return context.get_dummy_value()

    return sig, codegen


_each_body: Any = intrinsic(_each_body_call)


_GET_BODY = _address(pb.ffi.addressof(pb.lib, "pmSpaceBodyGetIteratorFuncBatched"))
_SET_BODY = _address(pb.ffi.addressof(pb.lib, "pmSpaceBodySetIteratorFuncBatched"))


def _body_order(space: pymunk.Space) -> NDArray[np.uintp]:
    """The body ids of ``space`` in its iteration order (``pymunk.batch``'s BODY_ID read,
    into a C array freed here)."""
    ints = pb.ffi.gc(pb.lib.pmIntArrayNew(0), pb.lib.pmIntArrayFree)
    data = pb.ffi.new("pmBatchedData *")
    data.intArray = ints
    data.floatArray = pb.ffi.gc(pb.lib.pmFloatArrayNew(0), pb.lib.pmFloatArrayFree)
    data.fields = pb.BodyFields.BODY_ID.value
    pb.lib.cpSpaceEachBody(space._space, pb.ffi.cast("void *", _GET_BODY), data)
    raw = pb.ffi.buffer(ints.arr, pb.ffi.sizeof("uintptr_t") * ints.num)
    return np.frombuffer(raw, dtype=np.uintp).copy()


#: the data slots of :class:`_BatchIO` after the substeps' force slots
_READ_POSITIONS, _READ_STATE, _WRITE_VELOCITIES = 0, 1, 2


class _BatchIO:
    """``pymunk.batch``'s C structures for one world, over float64 arrays owned here.

    pymunk's batched body iterators read from and write to a ``pmFloatArray`` (a count,
    a capacity and a C array of doubles). Here every such array is a numpy array:
    the substeps' forces (substeps, rows, 2) N, the velocities (rows, 2) m/s to write,
    and one read array of capacity 4 rows + 4 (pymunk grows an array, by moving it,
    only when it is within 3 values of full, which a read of 4 values per row never
    is). The counts (:attr:`counts`, column :attr:`num`) are a view of the C structures,
    so compiled code can rewind them. Rows are bodies in the space's iteration order.
    """

    def __init__(self, substeps: int, rows: int) -> None:
        ffi = pb.ffi
        self.substeps, self.rows = substeps, rows
        self.forces = np.zeros((substeps, rows, 2))
        self.velocities = np.zeros((rows, 2))
        self.floats = np.zeros(4 * rows + 4)
        targets = [*self.forces, self.velocities, self.floats]
        self._arrays = ffi.new("pmFloatArray[]", len(targets))
        self._views = [ffi.from_buffer("double[]", t) for t in targets]  # kept alive
        for arr, view, target in zip(self._arrays, self._views, targets, strict=True):
            arr.arr = view
            arr.num = 0
            arr.max = target.size
        self.counts = np.frombuffer(ffi.buffer(self._arrays), dtype=np.int32).reshape(
            len(targets), -1
        )
        self.num = ffi.offsetof("pmFloatArray", "num") // 4
        fields = pb.BodyFields
        # (array, fields) per data slot: each substep's forces, then the reads and writes
        slots = [(j, fields.FORCE) for j in range(substeps)] + [
            (substeps + 1, fields.POSITION),
            (substeps + 1, fields.POSITION | fields.VELOCITY),
            (substeps, fields.VELOCITY),
        ]
        self._data = ffi.new("pmBatchedData[]", len(slots))
        for data, (a, f) in zip(self._data, slots, strict=True):
            data.floatArray = self._arrays + a
            data.fields = f.value
        self.data = np.array([_address(self._data + j) for j in range(len(slots))], dtype=np.int64)
        self._array_of = [a for a, _ in slots]  # the counts row of each data slot

    def _each(self, space: pymunk.Space, slot: int, func: int) -> None:
        """One pass of pymunk's body iterator ``func`` over data slot ``slot``."""
        self.counts[self._array_of[slot], self.num] = 0
        pb.lib.cpSpaceEachBody(space._space, pb.ffi.cast("void *", func), self._data + slot)

    def write_forces(self, space: pymunk.Space, substep: int) -> None:
        """Set every body's force from :attr:`forces` [substep]."""
        self._each(space, substep, _SET_BODY)

    def read_positions(self, space: pymunk.Space) -> FloatArray:
        """Positions of every body, (rows, 2) (a view of :attr:`floats`)."""
        self._each(space, self.substeps + _READ_POSITIONS, _GET_BODY)
        return self.floats[: 2 * self.rows].reshape(-1, 2)

    def read_state(self, space: pymunk.Space) -> FloatArray:
        """Positions and velocities of every body, (rows, 4) (:meth:`state`)."""
        self._each(space, self.substeps + _READ_STATE, _GET_BODY)
        return self.state()

    def state(self) -> FloatArray:
        """The last positions and velocities read, (rows, 4) (a view of :attr:`floats`)."""
        return self.floats[: 4 * self.rows].reshape(-1, 4)

    def write_velocities(self, space: pymunk.Space) -> None:
        """Set every body's velocity from :attr:`velocities`."""
        self._each(space, self.substeps + _WRITE_VELOCITIES, _SET_BODY)


class _Bodies(NamedTuple):
    """What the compiled period reads of the bodies, map order: a_max (N,) m/s^2, v_max
    (N,) m/s, masses (N,) kg, the batch row of each (N,), the control period dt (s)."""

    a_max: FloatArray
    v_max: FloatArray
    masses: FloatArray
    rows: NDArray[np.intp]
    dt: float


class _Chipmunk(NamedTuple):
    """One world's chipmunk space and :class:`_BatchIO` buffers as compiled code takes
    them: the addresses of ``cpSpaceStep``, ``cpSpaceEachBody``, the space and the
    batched set and get iterators; the count column, the data slots' addresses, the
    counts, the forces (substeps, rows, 2) N, the velocities (rows, 2) m/s to write, the
    read array."""

    space_step: int
    each_body: int
    space: int
    set_body: int
    get_body: int
    num: int
    data: NDArray[np.int64]
    counts: NDArray[np.int32]
    forces: FloatArray
    velocities: FloatArray
    floats: FloatArray


class PeriodArrays(NamedTuple):
    """What one control period of a world produces (:func:`period_into` writes it):
    the substep centres path (S + 1, N, 2) m, rows 0 and S the start and the end; the
    end positions (N, 2) m, velocities (N, 2) m/s and mean accelerations (N, 2) m/s^2;
    the applied accelerations (N, 2) m/s^2 (:attr:`World.applied_accelerations`)."""

    path: FloatArray
    positions: FloatArray
    velocities: FloatArray
    accelerations: FloatArray
    applied: FloatArray


class DirectPeriod(NamedTuple):
    """Where a compiled control period of a world starts (:meth:`World.direct_period`):
    the bodies' positions ``start`` (N, 2) m and velocities ``v_start`` (N, 2) m/s."""

    start: FloatArray
    v_start: FloatArray


@inner_kernel
def _substeps(chip: _Chipmunk, rows: NDArray[np.intp], h: float, path: FloatArray) -> None:
    """One period's physics substeps of ``h`` s, in chipmunk directly: before substep j,
    the forces of data slot j; after each but the last, every body's position into
    path[j + 1] (N, 2) m (body i from read row rows[i]); after the last, positions and
    velocities into ``chip.floats`` (see :class:`_BatchIO`)."""
    substeps = path.shape[0] - 1
    read = substeps + 1
    counts, num, floats, data = chip.counts, chip.num, chip.floats, chip.data
    for j in range(substeps):
        counts[j, num] = 0
        _each_body(chip.each_body, chip.space, chip.set_body, data[j])
        _space_step(chip.space_step, chip.space, h)
        counts[read, num] = 0
        if j + 1 < substeps:
            _each_body(chip.each_body, chip.space, chip.get_body, data[substeps + _READ_POSITIONS])
            for i in range(rows.shape[0]):
                r = rows[i]
                path[j + 1, i, 0] = floats[2 * r]
                path[j + 1, i, 1] = floats[2 * r + 1]
        else:
            _each_body(chip.each_body, chip.space, chip.get_body, data[substeps + _READ_STATE])


@inner_kernel
def _write_velocities_kernel(chip: _Chipmunk, rows: NDArray[np.intp], v: FloatArray) -> None:
    """Set every body's velocity to v (N, 2) m/s (body i at batch row rows[i])."""
    substeps = chip.forces.shape[0]
    for i in range(rows.shape[0]):
        chip.velocities[rows[i], 0] = v[i, 0]
        chip.velocities[rows[i], 1] = v[i, 1]
    chip.counts[substeps, chip.num] = 0
    _each_body(chip.each_body, chip.space, chip.set_body, chip.data[substeps + _WRITE_VELOCITIES])


@inner_kernel
def _put_rows(path: FloatArray, j: int, points: FloatArray) -> None:
    """path[j] = points (N, 2) m, element by element (a slice assignment would compile
    numba's shape-mismatch message, with its string formatting, into the caller)."""
    for i in range(points.shape[0]):
        path[j, i, 0] = points[i, 0]
        path[j, i, 1] = points[i, 1]


@inner_kernel
def period_into(
    chip: _Chipmunk,
    bodies: _Bodies,
    accels: FloatArray,
    start: FloatArray,
    v_start: FloatArray,
    out: PeriodArrays,
) -> bool:
    """One control period straight in chipmunk (:meth:`World.step` once pymunk is idle):
    :func:`_plan_period`, the start velocities written when some was scaled,
    :func:`_substeps`, :func:`_finish_period` and the end velocities written when
    some was scaled. ``accels`` (N, 2) m/s^2 the commands; ``start`` (N, 2) m and
    ``v_start`` (N, 2) m/s the bodies at the period's start; the results go into
    ``out`` (:class:`PeriodArrays`). Returns whether every command is finite (nothing
    is stepped otherwise)."""
    n = accels.shape[0]
    substeps = chip.forces.shape[0]
    v = np.empty((n, 2))
    finite, over = _plan_period(
        accels,
        v_start,
        bodies.a_max,
        bodies.v_max,
        bodies.masses,
        bodies.dt,
        bodies.rows,
        chip.forces,
        v,
        out.applied,
    )
    if not finite:
        return False
    if over:
        _write_velocities_kernel(chip, bodies.rows, v)
    _put_rows(out.path, np.int64(0), start)  # not the literal 0 (nao_arena.geometry._kernel)
    _substeps(chip, bodies.rows, bodies.dt / substeps, out.path)
    rows_in_space = (chip.floats.shape[0] - 4) // 4
    state = chip.floats[: 4 * rows_in_space].reshape((rows_in_space, 4))
    pos, vel = out.positions, out.velocities
    if _finish_period(
        state, bodies.rows, bodies.v_max, v_start, bodies.dt, pos, vel, out.accelerations
    ):
        _write_velocities_kernel(chip, bodies.rows, vel)
    _put_rows(out.path, substeps, pos)
    return True


@kernel
def _direct_period(
    chip: _Chipmunk,
    bodies: _Bodies,
    accels: FloatArray,
    start: FloatArray,
    v_start: FloatArray,
) -> tuple[bool, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`period_into` into new arrays: returns (all commands finite), the substep
    centres (S + 1, N, 2) m, the end positions (N, 2) m, velocities (N, 2) m/s, mean
    accelerations (N, 2) m/s^2 and the applied accelerations (N, 2) m/s^2."""
    n = accels.shape[0]
    out = PeriodArrays(
        np.empty((chip.forces.shape[0] + 1, n, 2)),
        np.empty((n, 2)),
        np.empty((n, 2)),
        np.empty((n, 2)),
        np.empty((n, 2)),
    )
    finite = period_into(chip, bodies, accels, start, v_start, out)
    return finite, out.path, out.positions, out.velocities, out.accelerations, out.applied


#: pymunk's own bookkeeping around a step, as this pymunk version names it (checked
#: once: with another version, or while it has something to do, :meth:`World.step`
#: calls ``Space.step``)
_STEP_STATE = (
    "_bodies_to_check",
    "_add_later",
    "_remove_later",
    "_post_step_callbacks",
    "_removed_shapes",
    "threaded",
    "_locked",
)
_DIRECT_STEP = all(hasattr(pymunk.Space(), name) for name in _STEP_STATE)


def _pymunk_is_idle(space: pymunk.Space) -> bool:
    """Whether ``Space.step`` would do nothing but chipmunk's step: no body to check,
    nothing to add or remove, no post-step callback, not threaded (the world adds and
    removes bodies only between episodes and sets no collision handler)."""
    return _DIRECT_STEP and not (
        space._bodies_to_check
        or space._add_later
        or space._remove_later
        or space._post_step_callbacks
        or space._removed_shapes
        or space.threaded
    )


class World:
    """The pymunk world of one map.

    ``World(spec)`` builds the space (see :meth:`reset`); :meth:`step`
    advances one control period; :meth:`state` reads the bodies. Static
    per-body data: :attr:`radii`, :attr:`masses`, :attr:`a_max`,
    :attr:`v_max` (N,), :attr:`names`, :attr:`kinds`. Copies and pickles replay
    :attr:`commands` (see the module docstring).
    """

    def __init__(self, spec: MapSpec) -> None:
        self.spec = spec
        self.bodies = spec.bodies()
        self.n = len(self.bodies)
        self.dt = float(spec.physics.dt)
        self.substeps = int(spec.physics.substeps)
        self.radii = np.array([b.radius for b in self.bodies], dtype=float)
        self.masses = np.array([b.mass for b in self.bodies], dtype=float)
        self.a_max = np.array([b.a_max for b in self.bodies], dtype=float)
        self.v_max = np.array([b.v_max for b in self.bodies], dtype=float)
        self.names = tuple(b.name for b in self.bodies)
        self.kinds = tuple(b.kind for b in self.bodies)
        # the bodies driven by agents: the robots, then the people (MapSpec.robots order)
        self.robot_indices = np.array([b.index for b in self.bodies if b.robot >= 0], dtype=np.intp)
        self.replayed = np.array([b.replayed for b in self.bodies], dtype=bool)
        """Per body: whether it is a recorded person, moved by its recording."""
        self._replayed_rows = np.flatnonzero(self.replayed)
        self.traffic_indices = np.array(
            [b.index for b in self.bodies if b.kind == "traffic"], dtype=np.intp
        )
        self._walls = spec.wall_segments()
        self._log = np.empty((0, self.n, 2))
        self.reset()

    def __getstate__(self) -> dict[str, object]:
        """The map and the commands since the last reset (the space and the batch
        buffers, C objects, are rebuilt by :meth:`__setstate__`)."""
        return {"spec": self.spec, "commands": self.commands.copy()}

    def __setstate__(self, state: dict[str, object]) -> None:
        """A fresh world for the map, stepped with the pickled commands."""
        self.__init__(state["spec"])  # type: ignore[misc]
        for accels in state["commands"]:  # type: ignore[attr-defined]
            self.step(accels)

    # ------------------------------------------------------------------ setup

    def reset(self) -> WorldState:
        """Build a fresh pymunk space with every body at its start; time 0."""
        phys = self.spec.physics
        space = pymunk.Space(threaded=False)
        space.iterations = phys.iterations
        space.collision_slop = phys.collision_slop
        space.gravity = (0.0, 0.0)
        space.damping = 1.0
        pm_bodies = []
        for b in self.bodies:
            if b.replayed:
                body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            else:
                body = pymunk.Body(b.mass, float("inf"))
            body.position = b.start
            body.velocity = b.velocity
            shape: pymunk.Shape = pymunk.Circle(body, b.radius)
            shape.elasticity = phys.elasticity
            shape.friction = phys.friction
            if b.replayed:
                shape.filter = _TOUCHES_NOTHING
            space.add(body, shape)
            pm_bodies.append(body)
        static = space.static_body
        for w in self.spec.walls:
            if isinstance(w, SegmentWall):
                shape = pymunk.Segment(static, w.a, w.b, w.thickness / 2)
            else:
                assert isinstance(w, PolygonWall)
                # typeshed's tuple() drops the length; points are validated (x, y) pairs
                vertices = cast("list[tuple[float, float]]", [tuple(p) for p in w.points])
                shape = pymunk.Poly(static, vertices)
            shape.elasticity = phys.elasticity
            shape.friction = phys.friction
            space.add(shape)
        for end_a, end_b in self.spec.bound_wall_segments():
            shape = pymunk.Segment(static, end_a, end_b, self.spec.bounds.wall_thickness / 2)
            shape.elasticity = phys.elasticity
            shape.friction = phys.friction
            space.add(shape)
        self._space = space
        self._pm_bodies = pm_bodies
        self._setup_batch()
        self._steps = 0
        self.time = 0.0
        self._read()
        self._acc = np.zeros((self.n, 2))
        self._applied = np.zeros((self.n, 2))
        self._applied.setflags(write=False)
        self._prev_positions = self._pos.copy()
        # which recorded people are in the scene in the first control period
        self._present = (
            self.spec.replay_states(0)[2] if len(self._replayed_rows) else np.zeros(0, bool)
        )
        return self.state()

    def _setup_batch(self) -> None:
        """Map the space's body iteration order to map order; allocate the I/O buffers
        (once per world: a reset keeps them when the row count is the same)."""
        order = _body_order(self._space)
        row_of = {int(pid): r for r, pid in enumerate(order)}
        self._rows = np.array([row_of[b.id] for b in self._pm_bodies], dtype=np.intp)
        if getattr(self, "_n_rows", None) != len(order):
            self._n_rows = len(order)
            self._io = _BatchIO(self.substeps, self._n_rows)
        io = self._io
        self._chip = _Chipmunk(
            _SPACE_STEP,
            _EACH_BODY,
            _address(self._space._space),
            _SET_BODY,
            _GET_BODY,
            io.num,
            io.data,
            io.counts,
            io.forces,
            io.velocities,
            io.floats,
        )
        self._body_data = _Bodies(self.a_max, self.v_max, self.masses, self._rows, self.dt)

    # ------------------------------------------------------------------ I/O

    def _read(self) -> None:
        data = self._io.read_state(self._space)[self._rows]
        self._pos = data[:, 0:2].copy()
        self._vel = data[:, 2:4].copy()
        self._path = self._pos[None].copy()
        self._path.setflags(write=False)

    def _write_velocities(self, v: FloatArray) -> None:
        self._io.velocities[self._rows] = v
        self._io.write_velocities(self._space)
        self._vel = v

    def _record(self, accels: FloatArray, steps: int = 1) -> None:
        """Write the commands of the next ``steps`` steps, ``accels`` (N, 2) or (steps, N,
        2), into the log (capacity doubled, at least, when full)."""
        end = self._steps + steps
        if end > len(self._log):
            grown = np.empty((max(16, 2 * len(self._log), end), self.n, 2))
            grown[: self._steps] = self._log[: self._steps]
            self._log = grown
        self._log[self._steps : end] = accels

    # ------------------------------------------------------------------ public

    @property
    def positions(self) -> FloatArray:
        """Current centres (N, 2) m (a copy)."""
        return self._pos.copy()

    @property
    def velocities(self) -> FloatArray:
        """Current velocities (N, 2) m/s (a copy)."""
        return self._vel.copy()

    @property
    def previous_positions(self) -> FloatArray:
        """Centres (N, 2) m at the start of the last control period (a copy)."""
        return self._prev_positions.copy()

    @property
    def substep_positions(self) -> FloatArray:
        """Centres (S + 1, N, 2) m after each physics substep of the last control period,
        its start (row 0) and end (row S) included: the engine moves every body in a
        straight line between two rows. Read-only; (1, N, 2) after a reset."""
        return self._path

    @property
    def applied_accelerations(self) -> FloatArray:
        """The accelerations (N, 2) m/s^2 the last :meth:`step` applied: its commands scaled
        to |a| <= a_max (:func:`clip_accelerations`' arithmetic, the same bits), before
        the speed limit cut them at the saturation time. Read-only; zeros after a reset."""
        return self._applied

    @property
    def commands(self) -> FloatArray:
        """The commanded accelerations (steps, N, 2) m/s^2 given to :meth:`step` since
        the last reset, as given (before any limit), one row per step (read-only view)."""
        log = self._log[: self._steps]
        log.setflags(write=False)
        return log

    def wall_segments(self) -> tuple[FloatArray, FloatArray]:
        """All walls as segments (W, 2, 2) m and half-thicknesses (W,) m (polygon edges: 0)."""
        return self._walls

    def state(self) -> WorldState:
        """The bodies now (arrays are copies)."""
        return WorldState(
            time=self.time,
            positions=self._pos.copy(),
            velocities=self._vel.copy(),
            accelerations=self._acc.copy(),
            radii=self.radii,
            names=self.names,
            kinds=self.kinds,
        )

    def step(self, accels: ArrayLike) -> WorldState:
        """Advance one control period with commanded accelerations (N, 2) m/s^2, world frame.

        Applies the speed-limit model of the module docstring; returns the new state.
        """
        a = np.asarray(accels, dtype=np.float64)
        if a.shape != (self.n, 2):
            raise ValueError(f"expected accelerations of shape ({self.n}, 2), got {a.shape}")
        space, v_start = self._space, self._vel
        if _pymunk_is_idle(space):
            space._locked = True
            try:
                finite, *arrays = _direct_period(self._chip, self._body_data, a, self._pos, v_start)
            finally:
                space._locked = False
            if not finite:
                raise ValueError("expected finite accelerations")
            self._record(a)
            period = PeriodArrays(*arrays)
        else:
            period = self._period_through_pymunk(a)
        self._take(period)
        if len(self._replayed_rows):
            self._replay()
        return self.state()

    def direct_period(self) -> DirectPeriod | None:
        """The bodies' positions (N, 2) m and velocities (N, 2) m/s now, from which a
        compiled control period (:func:`period_into`, on :meth:`compiled_space`) starts;
        None when the next period must be :meth:`step`'s (pymunk has something of its
        own to do around a step, or recorded people are replayed)."""
        if len(self._replayed_rows) or not _pymunk_is_idle(self._space):
            return None
        return DirectPeriod(self._pos, self._vel)

    def compiled_space(self) -> tuple[_Chipmunk, _Bodies]:
        """This episode's chipmunk space and buffers and the bodies' limits and rows, as
        compiled code steps them (:func:`period_into`); made anew by :meth:`reset`."""
        return self._chip, self._body_data

    def adopt_period(self, accels: FloatArray, period: PeriodArrays) -> WorldState:
        """Take one control period that :func:`period_into` ran on this world's space
        (from :meth:`direct_period`) for the commanded accelerations ``accels``
        (N, 2) m/s^2: what :meth:`step` keeps of it (the arrays of ``period`` are kept,
        made read-only where :meth:`step` hands them out); returns the new state, as
        :meth:`step` does."""
        self._record(accels)
        self._take(period)
        return self.state()

    def _take(self, period: PeriodArrays) -> None:
        """The world after a control period whose commands are recorded: its results
        (:class:`PeriodArrays`) become the bodies' state, the substep path and the applied
        accelerations (these two read-only); one more step."""
        self._prev_positions = self._pos
        self._pos, self._vel, self._acc = period.positions, period.velocities, period.accelerations
        period.path.setflags(write=False)
        self._path = period.path
        period.applied.setflags(write=False)
        self._applied = period.applied
        self._steps += 1
        self.time = self._steps * self.dt

    def adopt_periods(self, commands: FloatArray, last: PeriodArrays) -> None:
        """Take control periods that :func:`period_into` ran on this world's space in a
        batch (:mod:`nao_arena.vector_step`): their commands (P, N, 2) m/s^2 and the last
        one's results: what :meth:`step` keeps of its own (the arrays are kept, not
        copied; nothing writes into them)."""
        self._record(commands, len(commands))
        self._steps += len(commands)
        self._prev_positions = last.path[0]
        self._pos, self._vel, self._acc = last.positions, last.velocities, last.accelerations
        self._path = last.path
        self._applied = last.applied
        self.time = self._steps * self.dt

    def _period_through_pymunk(self, a: FloatArray) -> PeriodArrays:
        """:func:`_direct_period`'s steps with the substeps through ``Space.step`` (while
        pymunk has something of its own to do around a step): the same kernels and
        results."""
        v_start = self._vel
        v = np.empty_like(v_start)
        applied = np.empty((self.n, 2))
        finite, over = _plan_period(
            a,
            v_start,
            self.a_max,
            self.v_max,
            self.masses,
            self.dt,
            self._rows,
            self._io.forces,
            v,
            applied,
        )
        if not finite:
            raise ValueError("expected finite accelerations")
        self._record(a)
        if over:
            self._write_velocities(v)
        path = np.empty((self.substeps + 1, self.n, 2))
        path[0] = self._pos
        space, io, h = self._space, self._io, self.dt / self.substeps
        for j in range(self.substeps):
            io.write_forces(space, j)
            space.step(h)
            if j + 1 < self.substeps:
                path[j + 1] = io.read_positions(space)[self._rows]
        data = io.read_state(space)
        pos = np.empty((self.n, 2))
        vel = np.empty((self.n, 2))
        acc = np.empty((self.n, 2))
        if _finish_period(data, self._rows, self.v_max, v_start, self.dt, pos, vel, acc):
            self._write_velocities(vel)
        path[self.substeps] = pos
        return PeriodArrays(path, pos, vel, acc, applied)

    def _replay(self) -> None:
        """Recorded people for the control period that starts now: each present one at its
        recorded centre, moving along the chord to its next one; the absent ones waiting
        at their parking places (:meth:`nao_arena.maps.MapSpec.replay_states`). Their
        acceleration is the change of the chord velocity over dt (0 when one appears or
        leaves)."""
        rows = self._replayed_rows
        pos, vel, present = self.spec.replay_states(self._steps)
        both = present & self._present
        acc = np.where(both[:, None], (vel - self._vel[rows]) / self.dt, 0.0)
        self._present = present
        for k, r in enumerate(rows.tolist()):
            body = self._pm_bodies[r]
            body.position = (float(pos[k, 0]), float(pos[k, 1]))
            body.velocity = (float(vel[k, 0]), float(vel[k, 1]))
        self._pos[rows] = pos
        self._vel[rows] = vel
        self._acc[rows] = acc
