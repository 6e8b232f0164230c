"""The statistics of one episode as it runs: :class:`EpisodeStats` keeps the state between
steps, calls the compiled kernel once per step and turns its rare contact events into
:class:`~nao_arena.stats.ContactEvent` objects."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.stats.events import first_disc_touch, first_touching_substep, first_wall_touch
from nao_arena.stats.kernel import (
    EV_DEEPER,
    EV_START,
    EpisodeArrays,
    StatsArrays,
    liveness_kernel,
    step_kernel,
    swept_distances,
    swept_wall_distances,
)
from nao_arena.stats.people import PeopleMetrics, robot_caused
from nao_arena.stats.records import (
    ContactEvent,
    EpisodeSummary,
    FaultEvent,
    RobotSummary,
    StatsConfig,
)

__all__ = ["EpisodeStats", "StepCounts", "StepOutcome"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

NO_GOALS = np.zeros((0, 2))
"""The liveness goals (0, 2) m of statistics without goals: only the arrival bookkeeping."""


class StepCounts(NamedTuple):
    """The counters of :class:`EpisodeStats` after some steps (:meth:`EpisodeStats.adopt_steps`):
    steps, time (s) at the end of the last, open proximity episodes, deadlock duration
    (s) and start (s, NaN: none)."""

    steps: int
    time: float
    n_prox: int
    deadlock_duration: float
    deadlock_time: float


class StepOutcome(NamedTuple):
    """What the compiled statistics of one control step give back
    (:func:`nao_arena.period.control_period`): the event rows (code, a, b) and their
    values of the contacts and proximity episodes (:func:`~nao_arena.stats.kernel.step_kernel`),
    the open proximity episodes after it, and whether every robot away from its goal
    is stuck (:func:`~nao_arena.stats.kernel.liveness_kernel`)."""

    codes: NDArray[np.int64]
    values: FloatArray
    n_prox: int
    deadlocked: bool


def _c_array(x: ArrayLike, dtype: type, shape: tuple[int, ...]) -> np.ndarray:
    """x as a C-contiguous array of dtype and shape, broadcast if need be (x itself when
    it already is one)."""
    a: np.ndarray = np.ascontiguousarray(x, dtype=dtype)
    return a if a.shape == shape else np.ascontiguousarray(np.broadcast_to(a, shape))


class EpisodeStats:
    """Contact episodes and per-robot metrics, updated once per control step.

    radii (N,) m; kinds (N,) "robot" or "traffic"; names (N,) (default
    "body<i>"); walls: (segments (W, 2, 2) m, half-thicknesses (W,) m) or
    None; dt: control period (s); velocities: (N, 2) m/s at t = 0 (used for
    the impact speed of contacts in the first step; else the step's mean
    velocity is used); goals: (N, 2) m, the robots' goals (rows of other
    bodies ignored), for the liveness metrics (None: not tracked).

    Episode flags are kept per pair in dense boolean (N, N) and (N, W) arrays
    (N^2 bytes each: 9 MB for 3000 bodies), the depth of open contacts in a small
    map; candidate pairs come from one sort-and-sweep per step over boxes that
    cover each body's swept step, its constant-velocity path over the TTC horizon
    and the separation range. The first update in a process loads (or, the first
    time, compiles and caches) the numba kernel.
    """

    def __init__(
        self,
        radii: ArrayLike,
        kinds: Sequence[str],
        names: Sequence[str] | None = None,
        walls: tuple[ArrayLike, ArrayLike] | None = None,
        dt: float = 0.1,
        config: StatsConfig | None = None,
        velocities: ArrayLike | None = None,
        goals: ArrayLike | None = None,
        replayed: ArrayLike | None = None,
    ) -> None:
        self.config = config or StatsConfig()
        self.radii = np.ascontiguousarray(radii, dtype=float).reshape(-1)
        self.n = n = len(self.radii)
        self.kinds = tuple(kinds)
        self.names = tuple(names) if names is not None else tuple(f"body{i}" for i in range(n))
        self.dt = float(dt)
        if walls is None:
            segs, wr = np.zeros((0, 2, 2)), np.zeros(0)
        else:
            segs = np.ascontiguousarray(walls[0], dtype=float).reshape(-1, 2, 2)
            wr = np.ascontiguousarray(walls[1], dtype=float).reshape(-1)
        self.wall_segments, self.wall_radii = segs, wr
        self.n_walls = len(wr)
        pad = 0.5 * self.config.separation_range
        self._wall_lo = np.minimum(segs[:, 0], segs[:, 1]) - (wr + pad)[:, None]
        self._wall_hi = np.maximum(segs[:, 0], segs[:, 1]) + (wr + pad)[:, None]
        along = segs[:, 1] - segs[:, 0]
        length = np.hypot(along[:, 0], along[:, 1])
        unit = along / np.where(length > 0, length, 1.0)[:, None]
        self._wall_normals = np.stack([-unit[:, 1], unit[:, 0]], axis=1)
        self.is_robot = np.array([k == "robot" for k in self.kinds], dtype=bool)
        # recorded people: their contacts with one another and with walls are the
        # recording's, not the simulation's, and are not counted
        self.replayed = (
            np.zeros(n, dtype=bool) if replayed is None else np.asarray(replayed, dtype=bool)
        )
        self._uncounted: set[tuple[int, int, bool]] = set()
        people = np.array([k == "person" for k in self.kinds], dtype=bool)
        self._people = (
            PeopleMetrics(
                np.flatnonzero(self.is_robot),
                np.flatnonzero(people),
                self.radii,
                self.config.discomfort_distance,
                self.dt,
                self.config.separation_range,
            )
            if people.any()
            else None
        )
        self._v_prev = None if velocities is None else np.asarray(velocities, float).copy()
        self.contacts: list[ContactEvent] = []
        self.faults: list[FaultEvent] = []
        # pair state: body-body (upper triangle used) and body-wall
        self._touch_bb = np.zeros((n, n), dtype=bool)
        self._touch_bw = np.zeros((n, self.n_walls), dtype=bool)
        self._depth_bb = np.zeros((n, n))
        self._depth_bw = np.zeros((n, self.n_walls))
        self._open_events: dict[tuple[int, int, bool], ContactEvent] = {}
        self._prox = np.zeros((n, n), dtype=bool)
        self._prox_contact = np.zeros((n, n), dtype=bool)
        self._n_prox = 0
        self.collisions = np.zeros(n, dtype=np.int64)
        self.wall_collisions = np.zeros(n, dtype=np.int64)
        self.near_misses = np.zeros(n, dtype=np.int64)
        self.min_separation = np.full(n, np.inf)
        self.min_ttc = np.full(n, np.inf)
        self.reached = np.zeros(n, dtype=bool)
        self.time_to_goal = np.full(n, np.nan)
        self.path_length = np.zeros(n)
        self.adjustments = np.zeros(n, dtype=np.int64)
        self._a_prev = np.empty((n, 2))  # the last step's commands (after the first)
        self._has_prev = False
        cfg = self.config
        self._cfg = np.array(
            [
                cfg.separation_range,
                cfg.ttc_horizon,
                cfg.near_miss_distance,
                cfg.hysteresis,
                cfg.adjustment_threshold,
            ],
            dtype=float,
        )
        self._order = np.arange(n + self.n_walls)  # broad phase order, kept between steps
        self.time = 0.0
        self.steps = 0
        # liveness: distances to the goals over the last stuck window (a ring of steps)
        self._goals = None if goals is None else _c_array(goals, np.float64, (n, 2))
        self._window = max(1, int(round(self.config.stuck_window / self.dt)))
        self._goal_dist = np.full((self._window, n), np.nan)
        self.stuck_time = np.zeros(n)
        self.time_away = np.zeros(n)
        self.at_goal = np.zeros(n, dtype=bool)
        self.deadlock_time = math.nan
        self.deadlock_duration = 0.0
        self._bundle()

    def _bundle(self) -> None:
        """step_kernel's named bundle, built once: it holds the very arrays of the
        attributes (the kernel updates the episode's state in place)."""
        self._arrays = EpisodeArrays(
            self.radii,
            self.is_robot,
            self._cfg,
            self._wall_lo,
            self._wall_hi,
            self.wall_segments,
            self.wall_radii,
            self._wall_normals,
            self._order,
            self._touch_bb,
            self._touch_bw,
            self._depth_bb,
            self._depth_bw,
            self._prox,
            self._prox_contact,
            self.path_length,
            self.adjustments,
            self.reached,
            self.time_to_goal,
            self.min_separation,
            self.min_ttc,
            self.near_misses,
        )
        self.period_arrays = StatsArrays(
            self._a_prev,
            self._arrays,
            NO_GOALS if self._goals is None else self._goals,
            self.is_robot,
            self._goal_dist,
            self._window,
            float(self.config.stuck_progress),
            self.at_goal,
            self.time_away,
            self.stuck_time,
        )
        """The statistics' arrays as a compiled control period takes them
        (:func:`nao_arena.period.control_period`; the very arrays, updated in place)."""

    # ------------------------------------------------------------------ update

    def update(
        self,
        t: float,
        positions_before: ArrayLike,
        positions_after: ArrayLike,
        velocities_after: ArrayLike,
        commanded_accels: ArrayLike,
        goal_reached: ArrayLike,
        substeps: ArrayLike | None = None,
    ) -> list[ContactEvent]:
        """Account for one control step [t, t + dt]; returns the contacts that started in it.

        positions_before/after (N, 2) m; velocities_after (N, 2) m/s;
        commanded_accels (N, 2) m/s^2; goal_reached (N,) bool at the step's end;
        substeps: the centres (S + 1, N, 2) m after each physics substep, rows 0 and S
        being positions_before and positions_after (see
        :attr:`nao_arena.world.World.substep_positions`); contacts and separations are
        then exact for straight motion between rows. None: one straight line per step.
        """
        n = self.n
        if substeps is None:
            path = np.stack(
                [
                    _c_array(positions_before, np.float64, (n, 2)),
                    _c_array(positions_after, np.float64, (n, 2)),
                ]
            )
        else:
            path = np.ascontiguousarray(substeps, dtype=np.float64)
            if path.ndim != 3 or path.shape[0] < 2 or path.shape[1:] != (n, 2):
                raise ValueError(
                    f"substeps: expected shape (S + 1, {n}, 2) with S >= 1, got {path.shape}"
                )
        v1 = _c_array(velocities_after, np.float64, (n, 2))
        acc = _c_array(commanded_accels, np.float64, (n, 2))
        goal = _c_array(goal_reached, np.bool_, (n,))
        t = float(t)
        codes, vals, n_prox = step_kernel(
            t,
            self.dt,
            path,
            v1,
            acc,
            self._a_prev,
            self._has_prev,
            goal,
            self._n_prox,
            self._arrays,
        )
        if self._people is not None:
            self._people.update(path)
        outcome = StepOutcome(codes, vals, n_prox, self._stuck(path[-1], goal))
        return self.adopt_step(t, outcome, path, v1)

    @property
    def compiled_steps(self) -> bool:
        """Whether a step can run in compiled code whole (:meth:`adopt_step`): a scene
        without recorded people, whose metrics are Python's."""
        return self._people is None

    @property
    def has_last_command(self) -> bool:
        """Whether a step has been accounted for (the commands of the last are kept)."""
        return self._has_prev

    @property
    def open_proximity_episodes(self) -> int:
        """The proximity episodes open now."""
        return self._n_prox

    def adopt_step(
        self, t: float, outcome: StepOutcome, path: FloatArray, velocities_after: FloatArray
    ) -> list[ContactEvent]:
        """Take the control step [t, t + dt] (s) whose kernels have run (in one compiled
        call, :func:`nao_arena.period.control_period`, in a scene without people; or
        :meth:`update`'s, which updates the people's metrics first): its ``outcome``,
        the centres ``path`` (S + 1, N, 2) m after each substep and the velocities
        (N, 2) m/s at its end. Returns the contacts that started in it."""
        self._n_prox = outcome.n_prox
        started = self._events(t, outcome.codes, outcome.values, path)
        self._v_prev = velocities_after.copy()
        self._deadlock(t, outcome.deadlocked)
        self.steps += 1
        self.time = t + self.dt
        return started

    def adopt_steps(self, counts: StepCounts, velocities_after: FloatArray) -> None:
        """Take control steps whose kernels ran in a batch (:mod:`nao_arena.vector_step`;
        their contact events were applied one step at a time, :meth:`_events`): their
        counters and the bodies' velocities (N, 2) m/s at the end of the last; a scene
        without people."""
        self.steps = counts.steps
        self.time = counts.time
        self._n_prox = counts.n_prox
        self._has_prev = True
        self._v_prev = velocities_after
        self.deadlock_duration = counts.deadlock_duration
        self.deadlock_time = counts.deadlock_time

    def _events(
        self, t: float, codes: NDArray[np.int64], vals: FloatArray, path: FloatArray
    ) -> list[ContactEvent]:
        """The kernel's event rows of the step [t, t + dt] applied (the last command is
        now kept); the contacts that started, in time order."""
        self._has_prev = True
        started: list[ContactEvent] = []
        if len(codes):
            self._apply_events(t, codes.tolist(), vals.tolist(), path, started)
            started.sort(key=lambda e: (e.time, e.a, e.b, e.kind_b))
        return started

    def _stuck(self, p1: FloatArray, goal: NDArray[np.bool_]) -> bool:
        """Stuck and away-after-arrival time of the step that ends with the bodies at p1
        (N, 2) m (after the kernel marked new arrivals); whether every robot away from
        its goal is stuck (:meth:`_deadlock` counts it)."""
        # the distances one window ago are NaN at first (too early: not stuck)
        live = self.period_arrays
        deadlocked = liveness_kernel(
            self.dt,
            np.ascontiguousarray(p1, dtype=np.float64),
            live.goals,
            goal,
            live.is_robot,
            live.episode.reached,
            live.goal_dist,
            self.steps % live.window,
            live.stuck_progress,
            live.at_goal,
            live.time_away,
            live.stuck_time,
        )
        return bool(deadlocked)

    def _deadlock(self, t: float, deadlocked: bool) -> None:
        """The deadlock time of the step that ends at t + dt, when every robot away from
        its goal is stuck in it (``deadlocked``)."""
        if deadlocked:
            self.deadlock_duration += self.dt
            if math.isnan(self.deadlock_time):
                self.deadlock_time = t + self.dt

    def record_fault(self, t: float, body: int, message: str) -> FaultEvent:
        """Record an agent's fault at time t (s) for the robot of body index ``body``."""
        ev = FaultEvent(float(t), int(body), self.names[body], str(message))
        self.faults.append(ev)
        return ev

    def _apply_events(
        self,
        t: float,
        codes: list[list[int]],
        vals: list[float],
        path: FloatArray,
        started: list[ContactEvent],
    ) -> None:
        """Contact episodes that deepened, started or ended in this step (the kernel's rows);
        path: the step's substep centres (S + 1, N, 2) m."""
        for (code, a, b), val in zip(codes, vals, strict=True):
            wall = code >= 3
            kind = code - 3 if wall else code
            key = (a, b, wall)
            if key in self._uncounted or (
                kind == EV_START and self.replayed[a] and (wall or self.replayed[b])
            ):
                # a recorded person's contact with another or with a wall
                if kind == EV_START:
                    self._uncounted.add(key)
                elif kind != EV_DEEPER:
                    self._uncounted.discard(key)
                continue
            if kind == EV_DEEPER:
                ev = self._open_events[(a, b, wall)]
                ev.max_penetration = max(ev.max_penetration, val)
            elif kind == EV_START:
                if wall:
                    ev = self._wall_event(t, a, b, path, val)
                    self.wall_collisions[a] += 1
                else:
                    ev = self._disc_event(t, a, b, path, val)
                    self.collisions[b] += 1
                self.collisions[a] += 1
                self._open_events[(a, b, wall)] = ev
                self.contacts.append(ev)
                started.append(ev)
            else:
                self._open_events.pop((a, b, wall)).end_time = t + self.dt

    def _approach_velocity(self, path: FloatArray, s: int, body: int) -> FloatArray:
        """Velocity (2,) m/s of ``body`` while it first touched, in substep s of path: the
        substep's displacement over its duration (S > 1), else the velocity at the step's
        start (the step's mean velocity for the first step without start velocities)."""
        substeps = len(path) - 1
        if substeps > 1:
            return (path[s + 1, body] - path[s, body]) / (self.dt / substeps)
        if self._v_prev is not None:
            return self._v_prev[body]
        return (path[1, body] - path[0, body]) / self.dt

    def _disc_event(self, t: float, a: int, b: int, path: FloatArray, sep: float) -> ContactEvent:
        reach = float(self.radii[a] + self.radii[b])
        rel = path[:, b] - path[:, a]
        s = first_touching_substep(swept_distances(rel), reach)
        tc, nrm = first_disc_touch(rel[s], rel[s + 1], reach)
        va, vb = self._approach_velocity(path, s, a), self._approach_velocity(path, s, b)
        vrel = vb - va
        return ContactEvent(
            time=t + (s + tc) / (len(path) - 1) * self.dt,
            a=a,
            b=b,
            kind_a=self.kinds[a],
            kind_b=self.kinds[b],
            name_a=self.names[a],
            name_b=self.names[b],
            impact_speed=max(0.0, -float(vrel @ nrm)),
            max_penetration=-sep,
            speed_a=float(np.hypot(*va)),
            speed_b=float(np.hypot(*vb)),
            began_overlapping=bool(np.hypot(*rel[0]) < reach),
        )

    def _wall_event(
        self, t: float, body: int, wall: int, path: FloatArray, sep: float
    ) -> ContactEvent:
        reach = float(self.radii[body] + self.wall_radii[wall])
        seg = self.wall_segments[wall]
        own = path[:, body]
        s = first_touching_substep(swept_wall_distances(own, seg[0], seg[1]), reach)
        tc, nrm = first_wall_touch(own[s], own[s + 1], seg[0], seg[1], reach)
        v = self._approach_velocity(path, s, body)
        return ContactEvent(
            time=t + (s + tc) / (len(path) - 1) * self.dt,
            a=body,
            b=wall,
            kind_a=self.kinds[body],
            kind_b="wall",
            name_a=self.names[body],
            name_b=f"wall{wall}",
            impact_speed=max(0.0, -float(v @ nrm)),
            max_penetration=-sep,
            speed_a=float(np.hypot(*v)),
            speed_b=0.0,
        )

    # ------------------------------------------------------------------ results

    def _among_people(self, k: int) -> dict[str, Any]:
        """The social-navigation fields of robot body k's summary (none without people)."""
        if self._people is None:
            return {}
        with_people = [
            c
            for c in self.contacts
            if k in (c.a, c.b) and "person" in (c.kind_a, c.kind_b) and c.kind_b != "wall"
        ]
        moving = self.config.moving_speed
        closest, discomfort = self._people.of_body(k)
        return {
            "among_people": True,
            "person_contacts": len(with_people),
            "caused_person_contacts": sum(robot_caused(c, k, moving) for c in with_people),
            "min_person_distance": closest,
            "discomfort_time": discomfort,
        }

    def summary(self) -> EpisodeSummary:
        """The episode so far: per-robot rows (robots only, in body order) and all events.

        Open contact episodes have end_time NaN; open proximity episodes without
        contact count as near misses.
        """
        pending = np.zeros(self.n, dtype=np.int64)
        ii, jj = np.nonzero(self._prox & ~self._prox_contact)
        np.add.at(pending, ii, 1)
        np.add.at(pending, jj, 1)
        if self._goals is None or self.steps == 0:
            final = [math.nan] * self.n
        else:
            last = self._goal_dist[(self.steps - 1) % self._window]
            final = [float(d) for d in last]
        rows = []
        for k in np.flatnonzero(self.is_robot).tolist():
            active_time = self.time_to_goal[k] if self.reached[k] else self.time
            rows.append(
                RobotSummary(
                    index=k,
                    name=self.names[k],
                    reached_goal=bool(self.reached[k]),
                    success=bool(self.reached[k] and self.collisions[k] == 0 and self.at_goal[k]),
                    time_to_goal=float(self.time_to_goal[k]),
                    path_length=float(self.path_length[k]),
                    collisions=int(self.collisions[k]),
                    wall_collisions=int(self.wall_collisions[k]),
                    near_misses=int(self.near_misses[k] + pending[k]),
                    min_separation=float(self.min_separation[k]),
                    min_ttc=float(self.min_ttc[k]),
                    adjustments=int(self.adjustments[k]),
                    adjustment_rate=(
                        float(self.adjustments[k] / active_time) if active_time > 0 else 0.0
                    ),
                    stuck_time=float(self.stuck_time[k]),
                    time_away_after_arrival=float(self.time_away[k]),
                    final_goal_distance=final[k],
                    at_goal_at_end=bool(self.at_goal[k]),
                    timed_out=not bool(self.reached[k]),
                    **self._among_people(k),
                )
            )
        return EpisodeSummary(
            duration=self.time,
            steps=self.steps,
            robots=rows,
            contacts=list(self.contacts),
            faults=list(self.faults),
            deadlock_time=self.deadlock_time,
            deadlock_duration=self.deadlock_duration,
        )
