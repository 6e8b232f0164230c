"""The physical world: disc bodies and static walls in pymunk.

This is the only module that imports pymunk. Bodies are the map's robots
and traffic vehicles in map order (:meth:`nao_arena.maps.MapSpec.bodies`);
walls are static segments (capsules) and convex polygons. Contacts between
bodies and with walls are resolved by pymunk with the map's elasticity and
friction. Bodies do not rotate (infinite moment of inertia).

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
:func:`nao_arena.speed_limit.saturation_time`, shared with the planner. A
body faster than v_max (after a contact) is first slowed to v_max by
scaling its velocity (never by moving it), and then gains no speed. Speeds
above v_max left by contacts at the end of a period are scaled back too, so
observed speeds never exceed v_max.

Bulk state I/O goes through ``pymunk.batch``: one call per substep writes
all forces and one reads all positions (:attr:`World.substep_positions`, the
engine's exact path within the period: between two substeps every body
moves in a straight line), one more reads the velocities at the period's
end. The batch buffers' C arrays are owned here and freed with the world
(``pymunk.batch.Buffer`` never frees its own). A fresh ``pymunk.Space`` is
built on every :meth:`World.reset`. Same map and same commands give
bit-identical trajectories.

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

import numpy as np
import pymunk
import pymunk.batch as pb
from numba import njit
from numpy.typing import ArrayLike, NDArray

from nao_arena.maps import MapSpec, PolygonWall, SegmentWall
from nao_arena.speed_limit import saturation_time, speed_limit_time

__all__ = [
    "World",
    "WorldState",
    "clip_accelerations",
    "speed_limit_time",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class WorldState:
    """The bodies at one instant, world frame, one row per body in map order.

    time (s); positions (N, 2) m; velocities (N, 2) m/s; accelerations
    (N, 2) m/s^2: the mean acceleration over the last control period,
    (v_end - v_start) / dt, contacts included (zeros after a reset); radii
    (N,) m; names and kinds ("robot" or "traffic") per body.
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


def clip_accelerations(accels: ArrayLike, a_max: ArrayLike) -> FloatArray:
    """Rows of accels (N, 2) m/s^2 scaled to |a| <= a_max (N,) (direction kept)."""
    a = np.asarray(accels, dtype=float)
    norm = np.hypot(a[:, 0], a[:, 1])
    scale = np.minimum(1.0, np.asarray(a_max, float) / np.maximum(norm, 1e-300))
    return a * scale[:, None]


@njit(cache=True)
def _plan_period(
    accels: FloatArray, v: FloatArray, a_max: FloatArray, v_max: FloatArray,
    masses: FloatArray, dt: float, rows: NDArray[np.intp], forces: FloatArray,
    v_out: FloatArray,
) -> tuple[bool, bool]:
    """The speed-limit model of one period for every body, in one pass.

    Writes the substep forces (substeps, rows, 2) N (row rows[i] for body i)
    and the start velocities scaled to |v| <= v_max into v_out (N, 2) m/s;
    returns (all commands finite, some start velocity was scaled). Same
    arithmetic as :func:`clip_accelerations` and the numpy model in
    tests/reference/world_reference.py (bit-identical results; tested); the saturation
    time is :func:`nao_arena.speed_limit.saturation_time`, the model the planner
    predicts with.
    """
    n = accels.shape[0]
    substeps = forces.shape[0]
    h = dt / substeps
    for i in range(n):
        if not (np.isfinite(accels[i, 0]) and np.isfinite(accels[i, 1])):
            return False, False
    any_over = False
    for i in range(n):
        ax, ay = accels[i, 0], accels[i, 1]
        norm = np.hypot(ax, ay)
        scale = min(1.0, a_max[i] / max(norm, 1e-300))
        ax, ay = ax * scale, ay * scale
        vx, vy = v[i, 0], v[i, 1]
        speed = np.hypot(vx, vy)
        if speed > v_max[i]:
            f = v_max[i] / speed
            vx, vy = vx * f, vy * f
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


@njit(cache=True)
def _finish_period(
    data: FloatArray, rows: NDArray[np.intp], v_max: FloatArray, v_start: FloatArray,
    dt: float, pos: FloatArray, vel: FloatArray, acc: FloatArray,
) -> bool:
    """Read back one period: positions and velocities from the batch rows ``data`` (rows, 4)
    into pos / vel (N, 2), velocities above v_max scaled back, mean accelerations
    (vel - v_start) / dt into acc; returns whether some velocity was scaled."""
    any_over = False
    for i in range(pos.shape[0]):
        r = rows[i]
        pos[i, 0], pos[i, 1] = data[r, 0], data[r, 1]
        vx, vy = data[r, 2], data[r, 3]
        speed = np.hypot(vx, vy)
        if speed > v_max[i]:
            f = v_max[i] / speed
            vx, vy = vx * f, vy * f
            any_over = True
        vel[i, 0], vel[i, 1] = vx, vy
        acc[i, 0] = (vx - v_start[i, 0]) / dt
        acc[i, 1] = (vy - v_start[i, 1]) / dt
    return any_over


class _ReadBuffer:
    """A ``pymunk.batch`` buffer that pymunk fills (and grows); its C arrays are freed
    when it is collected. :meth:`fill` is ``pymunk.batch.get_space_bodies`` without its
    per-call set-up, and :meth:`floats` reuses its array view while the C array stays
    where it is (pymunk only moves it to grow it)."""

    _GET = pb.ffi.addressof(pb.lib, "pmSpaceBodyGetIteratorFuncBatched")

    def __init__(self) -> None:
        self._float_arr = pb.ffi.gc(pb.lib.pmFloatArrayNew(0), pb.lib.pmFloatArrayFree)
        self._int_arr = pb.ffi.gc(pb.lib.pmIntArrayNew(0), pb.lib.pmIntArrayFree)
        self._data = pb.ffi.new("pmBatchedData *")
        self._data.floatArray = self._float_arr
        self._data.intArray = self._int_arr
        self._view_key: tuple[int, int, int] | None = None
        self._view = np.zeros((0, 0))

    def fill(self, space: pymunk.Space, fields: pb.BodyFields) -> None:
        """Clear, then read ``fields`` of every body of ``space`` (its iteration order)."""
        self._float_arr.num = 0
        self._int_arr.num = 0
        self._data.fields = fields.value
        pb.lib.cpSpaceEachBody(space._space, self._GET, self._data)

    def floats(self, rows: int, cols: int) -> FloatArray:
        """The float data as a (rows, cols) array (a view, valid until the next fill)."""
        arr = self._float_arr
        key = (int(pb.ffi.cast("uintptr_t", arr.arr)), arr.num, cols)
        if key != self._view_key:
            data = pb.ffi.buffer(arr.arr, 8 * arr.num)
            self._view = np.frombuffer(data, dtype=np.float64).reshape(rows, cols)
            self._view_key = key
        return self._view

    def ints(self) -> NDArray[np.uintp]:
        """The integer data (a copy)."""
        data = pb.ffi.buffer(self._int_arr.arr, pb.ffi.sizeof("uintptr_t") * self._int_arr.num)
        return np.frombuffer(data, dtype=np.uintp).copy()


class _WriteBuffer:
    """A ``pymunk.batch`` buffer over a float64 numpy array that pymunk reads (the array
    is kept alive here; nothing is allocated in C). :meth:`write` is
    ``pymunk.batch.set_space_bodies`` without its per-call set-up."""

    _SET = pb.ffi.addressof(pb.lib, "pmSpaceBodySetIteratorFuncBatched")

    def __init__(self, array: FloatArray) -> None:
        self._array = array
        self._view = pb.ffi.from_buffer("double[]", array)
        self._float_arr = pb.ffi.new("pmFloatArray *")
        self._float_arr.arr = self._view
        self._float_arr.num = self._float_arr.max = array.size
        self._int_arr = pb.ffi.new("pmIntArray *")
        self._data = pb.ffi.new("pmBatchedData *")
        self._data.floatArray = self._float_arr
        self._data.intArray = self._int_arr

    def write(self, space: pymunk.Space, fields: pb.BodyFields) -> None:
        """Write ``fields`` of every body of ``space`` (its iteration order) from the
        array, as ``pymunk.batch.set_space_bodies(space, fields, self)`` does."""
        self._data.fields = fields.value
        size = self._float_arr.num
        self._float_arr.num = 0  # pymunk reads from the start, counting up
        pb.lib.cpSpaceEachBody(space._space, self._SET, self._data)
        self._float_arr.num = size


#: pymunk's own bookkeeping around a step, as this pymunk version names it (checked
#: once: with another version :func:`_step_space` always calls ``Space.step``)
_STEP_STATE = ("_bodies_to_check", "_add_later", "_remove_later", "_post_step_callbacks",
               "_removed_shapes", "threaded", "_locked")
_DIRECT_STEP = all(hasattr(pymunk.Space(), name) for name in _STEP_STATE)


def _step_space(space: pymunk.Space, h: float) -> None:
    """``space.step(h)``; straight to chipmunk's step when pymunk has nothing of its own
    to do around it (no body to check, nothing to add or remove, no post-step
    callback: the world adds and removes bodies only between episodes and sets no
    collision handler), which is what ``Space.step`` then does."""
    if (not _DIRECT_STEP or space._bodies_to_check or space._add_later
            or space._remove_later or space._post_step_callbacks or space._removed_shapes
            or space.threaded):
        space.step(h)
        return
    space._locked = True
    try:
        pb.lib.cpSpaceStep(space._space, h)
    finally:
        space._locked = False


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
        self.robot_indices = np.array(
            [b.index for b in self.bodies if b.kind == "robot"], dtype=np.intp
        )
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
            body = pymunk.Body(b.mass, float("inf"))
            body.position = b.start
            body.velocity = b.velocity
            shape = pymunk.Circle(body, b.radius)
            shape.elasticity = phys.elasticity
            shape.friction = phys.friction
            space.add(body, shape)
            pm_bodies.append(body)
        static = space.static_body
        for w in self.spec.walls:
            if isinstance(w, SegmentWall):
                shape = pymunk.Segment(static, w.a, w.b, w.thickness / 2)
            else:
                assert isinstance(w, PolygonWall)
                shape = pymunk.Poly(static, [tuple(p) for p in w.points])
            shape.elasticity = phys.elasticity
            shape.friction = phys.friction
            space.add(shape)
        for a, b in self.spec.bound_wall_segments():
            shape = pymunk.Segment(static, a, b, self.spec.bounds.wall_thickness / 2)
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
        self._prev_positions = self._pos.copy()
        return self.state()

    def _setup_batch(self) -> None:
        """Map the space's body iteration order to map order; allocate the I/O buffers
        (once per world: a reset keeps them when the row count is the same)."""
        ids = _ReadBuffer()
        pb.get_space_bodies(self._space, pb.BodyFields.BODY_ID, ids)
        order = ids.ints()
        row_of = {int(pid): r for r, pid in enumerate(order)}
        self._rows = np.array([row_of[b.id] for b in self._pm_bodies], dtype=np.intp)
        self._identity = bool(np.array_equal(self._rows, np.arange(self.n)))
        if getattr(self, "_n_rows", None) == len(order):
            return
        self._n_rows = len(order)
        # one persistent force array and buffer per substep (rows in iteration order)
        self._forces = np.zeros((self.substeps, self._n_rows, 2))
        self._force_bufs = [_WriteBuffer(self._forces[j].reshape(-1))
                            for j in range(self.substeps)]
        self._vel_rows = np.zeros((self._n_rows, 2))
        self._vel_buf = _WriteBuffer(self._vel_rows.reshape(-1))
        self._get_buf = _ReadBuffer()

    # ------------------------------------------------------------------ I/O

    def _read(self) -> None:
        buf = self._get_buf
        buf.fill(self._space, pb.BodyFields.POSITION | pb.BodyFields.VELOCITY)
        data = buf.floats(self._n_rows, 4)
        data = data[: self.n] if self._identity else data[self._rows]
        self._pos = data[:, 0:2].copy()
        self._vel = data[:, 2:4].copy()
        self._path = self._pos[None].copy()
        self._path.setflags(write=False)

    def _write_velocities(self, v: FloatArray) -> None:
        if self._identity:
            self._vel_rows[: self.n] = v
        else:
            self._vel_rows[self._rows] = v
        self._vel_buf.write(self._space, pb.BodyFields.VELOCITY)
        self._vel = v

    def _record(self, accels: FloatArray) -> None:
        """Append one step's commands to the log (capacity doubled when full)."""
        if self._steps == len(self._log):
            grown = np.empty((max(16, 2 * len(self._log)), self.n, 2))
            grown[: self._steps] = self._log[: self._steps]
            self._log = grown
        self._log[self._steps] = accels

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
        v_start = self._vel
        v = np.empty_like(v_start)
        finite, over = _plan_period(a, v_start, self.a_max, self.v_max, self.masses, self.dt,
                                    self._rows, self._forces, v)
        if not finite:
            raise ValueError("expected finite accelerations")
        self._record(a)
        if over:
            self._write_velocities(v)
        h = self.dt / self.substeps
        space = self._space
        buf = self._get_buf
        path = np.empty((self.substeps + 1, self.n, 2))
        path[0] = self._pos
        for j, force_buf in enumerate(self._force_bufs):
            force_buf.write(space, pb.BodyFields.FORCE)
            _step_space(space, h)
            if j + 1 < self.substeps:
                buf.fill(space, pb.BodyFields.POSITION)
                data = buf.floats(self._n_rows, 2)
                path[j + 1] = data[: self.n] if self._identity else data[self._rows]
        self._prev_positions = self._pos
        buf.fill(space, pb.BodyFields.POSITION | pb.BodyFields.VELOCITY)
        data = buf.floats(self._n_rows, 4)
        self._pos = np.empty((self.n, 2))
        vel = np.empty((self.n, 2))
        self._acc = np.empty((self.n, 2))
        if _finish_period(data, self._rows, self.v_max, v_start, self.dt, self._pos, vel,
                          self._acc):
            self._write_velocities(vel)
        path[self.substeps] = self._pos
        path.setflags(write=False)
        self._path = path
        self._vel = vel
        self._steps += 1
        self.time = self._steps * self.dt
        return self.state()
