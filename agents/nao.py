"""``nao`` and ``ao``: choose a constant acceleration outside every neighbour's NAO.

Each step the agent predicts its neighbours' centres over the horizon
(predictor option), builds their NAOs (grown by both radii and a safety
margin; walls as exact static segments), and

1. keeps its current acceleration while that stays admissible and either
   lies within ``keep_band`` (m/s^2) of the desired one or is an avoidance
   adjustment younger than ``reselect_after`` (s) (the paper's premise: few
   adjustments; an adjustment is revisited toward the goal that often);
2. otherwise takes the admissible acceleration nearest the desired one
   (goal seeking, see :func:`nao_arena.agents.goal.goal_seeking_accel`);
   an adjustment younger than ``reselect_after`` that has just become
   inadmissible is first repaired locally (the admissible point nearest the
   desired one among rings around it,
   :func:`nao_arena.geometry.repair_acceleration`), which costs a tenth of a
   full selection;
3. if none is admissible: with ``infeasible="auto"`` (the default) it brakes
   as hard as it can toward standing still when its neighbours are robots
   (they avoid a robot that stands still; in a crowd whose predictions keep
   changing, stopping is what keeps contacts rare) and takes the acceleration
   that postpones contact longest when traffic is among them (traffic does
   not stop for it); ``"brake"`` and ``"latest_contact"`` force either.

4. last, the robots of one batch that re-plan commit to *stopping plans*
   together (``stopping_plans``, :mod:`nao_arena.stopping`): each one's
   choice, followed by braking to a standstill, must keep the others'
   plans and the walls at the sum of the radii plus 5 mm, or the robot brakes
   instead (status "yielded"); under this rule NAO robots among NAO robots
   never touch, whatever their predictions missed.

With ``replan=False`` the agent selects once, at its first step, and
holds that acceleration for the whole episode (the paper's open-loop
crossing; choose a horizon that covers the manoeuvre).

Liveness: a robot that has crawled (speed below a quarter of v_max) for
``detour_after`` s while away from its goal turns its goal direction to the
right by a random angle in [30, 60] degrees (drawn from its own generator),
and by another such angle after each further ``detour_after`` s of crawling
(up to about 180 degrees: backing off), until it has moved freely again for
``detour_after`` s; symmetric stand-offs then resolve like traffic keeping
right, and a robot boxed in by its neighbours eventually backs out. A robot
that has not come 0.5 m closer to its goal for ``switch_side_after`` s
while its nearest neighbour stood still within 1 m and nothing was within 1 m
behind it (held by parked robots with room behind, not by a moving crowd or
a jam all around) switches the side of its detours (right to left, and
back after another such spell): a robot held behind a row of parked robots
whose near end lies to its left gets round it.

Walls: where a wall stands between a robot and its goal, the robot heads for
the farthest point it sees on the shortest way around the walls instead of
the goal (``navigate``, :mod:`nao_arena.navigation`); a robot on such a way
that has turned all the way round (150-180 degrees) and is still held heads
along the way again rather than backing further into the walls.

A neighbour or wall already closer than its grown radius (inside the
margin, or touching) counts with just under its current distance: the
robot may not close in further but may move away.

Its own predicted path includes its speed limit, so "admissible" means
collision-free for the world's real dynamics over the horizon (up to the
physics integration error, covered by the margin).
``ao`` is the same agent with constant-acceleration predictions (the AO).

The agents of one class act together (:meth:`NAOAgent.act_batch`):
predictions once per step for all bodies, and the rest of the step in three
compiled calls (:mod:`nao_arena.agents._nao_batch`: the robots' own state,
liveness and goal seeking; per group of shared predictions, the keep test (1.),
the repairs and the selections; the stopping plans (4.)); their state (current
acceleration, adjustment age, detours, last selection) and numeric options are
the rows of one table (:mod:`nao_arena.agents._nao_columns`), so no Python runs
per robot unless a robot needs the slow path; :meth:`NAOAgent.act`
is ``act_batch`` for the one-robot batch of its observation. A subclass
customises the agent through its options (as :class:`AOAgent` does) or by
overriding ``act``, which ``act_batch`` then calls robot by robot.
:meth:`NAOAgent.last_obstacles` and :meth:`NAOAgent.last_decision` report
what the last step tested and decided.

:meth:`NAOAgent.nearest_admissible` (and its batch form) is the selection on
its own, for an acceleration chosen by something else: the safety shield of
:mod:`nao_arena.shield`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.agent import PanelAgent
from nao_arena.geometry import (
    AccelLimits,
    PiecewisePath,
    repair_acceleration,
    select_acceleration,
)
from nao_arena.geometry.kernels import (
    admissible_kernel,
    path_excursions,
    piece_sweep,
    relevant_sampled_paths,
    relevant_walls,
    sampled_admissible_batch,
)
from nao_arena.geometry.selection import Selection
from nao_arena.geometry.walls import point_segment_distances
from nao_arena.motion import braking
from nao_arena.navigation import navigation_grid, route_targets
from nao_arena.obstacles import obstacle_paths, relative_walls
from nao_arena.predictors import get_predictor
from nao_arena.sensing import Observation, SensingBatch, is_frozen

from . import _nao_columns as col
from ._nao_batch import (
    desired_rows,
    own_rows,
    prepare_rows,
    settle_members,
    yield_rows,
)
from ._nao_columns import (
    AGE,
    AROUND,
    CUR_X,
    CUR_Y,
    DETOUR,
    GOAL_ZONE,
    KEEP_BAND,
    MARGIN,
    NAVIGATE,
    NO_SELECTION,
    RANGE,
    REPLAN,
    RESELECT,
    ROW,
    SEEN,
    SELECTION_LABELS,
    SETTLING,
    STATUS,
    STOPPING,
    V_PREF,
    Acceleration,
    AgentColumns,
    Column,
    GridAttribute,
    OptionalSpeed,
    columns_of,
    detour_row,
    young_adjustments,
)
from ._nao_decide import (
    ADJUSTED,
    DESIRED,
    INFEASIBLE,
    REPAIRED,
    ObstacleLists,
    decide,
    keep_candidates,
    member_lists,
    selection_settings,
)

if TYPE_CHECKING:
    from nao_arena.maps import RobotSpec

_SAMPLE_STEP = 0.1  # s between the samples of a predicted path by default
PLAN_MARGIN = 0.005  # m kept between stopping plans beyond the sum of the radii


class NAOAgent:
    """NAO avoidance. Options: horizon (s), samples (per horizon; None: one every 0.1 s),
    predictor name, margin (m), keep_band (m/s^2), v_pref (m/s), sensing_range (m),
    detour_after (s), replan, reselect_after (s), infeasible ("auto", "brake" or
    "latest_contact"), goal_zone (m), navigate (heads around walls that stand between
    the robot and its goal, see :mod:`nao_arena.navigation`), stopping_plans (commits
    to stopping plans with the other robots of its batch and brakes where its choice
    would meet theirs, see :mod:`nao_arena.stopping`).

    The default horizon is 3 s (four stopping times of the shipped robots, v_max / a_max
    = 0.75 s; a car of the roundabout stops from 6 m/s in 2 s); the two-lane road sets
    6 s (an overtake). A shorter one runs faster in crowds, see docs/results/benchmarks.md."""

    # the agent's state and numeric options live in its row of a table shared with the
    # other agents of its batch (:mod:`nao_arena.agents._nao_columns`)
    current = Acceleration()
    age = Column("real", AGE)
    crawl_time = Column("real", col.CRAWL)
    free_time = Column("real", col.FREE)
    detour = Column("real", DETOUR)
    side = Column("real", col.SIDE)
    best_distance = Column("real", col.BEST)
    since_progress = Column("real", col.SINCE)
    detour_turns = Column("whole", col.TURNS, int)
    settling = Column("whole", SETTLING, bool)
    around_wall = Column("whole", AROUND, bool)
    replan = Column("whole", REPLAN, bool)
    navigate = Column("whole", NAVIGATE, bool)
    stopping_plans = Column("whole", STOPPING, bool)
    margin = Column("opt", MARGIN)
    keep_band = Column("opt", KEEP_BAND)
    goal_zone = Column("opt", GOAL_ZONE)
    reselect_after = Column("opt", RESELECT)
    detour_after = Column("opt", col.DETOUR_AFTER)
    switch_side_after = Column("opt", col.SWITCH_AFTER)
    sensing_range = Column("opt", RANGE)
    v_pref = OptionalSpeed("opt", V_PREF)
    infeasible = col.Choice(col.FALLBACK, col.FALLBACKS, "infeasible")
    times = GridAttribute()
    predictor_name = GridAttribute()
    predict = GridAttribute()

    def __init__(
        self,
        horizon: float = 3.0,
        samples: int | None = None,
        predictor: str | None = None,
        margin: float = 0.15,
        keep_band: float = 0.3,
        v_pref: float | None = None,
        sensing_range: float = 30.0,
        detour_after: float = 1.0,
        replan: bool = True,
        reselect_after: float = 1.0,
        infeasible: str = "auto",
        goal_zone: float = 1.0,
        navigate: bool = True,
        stopping_plans: bool = True,
        switch_side_after: float = 20.0,
    ) -> None:
        if infeasible not in ("auto", "latest_contact", "brake"):
            raise ValueError(
                f"infeasible: expected 'auto', 'latest_contact' or 'brake', got {infeasible!r}"
            )
        self._cols = AgentColumns(1)
        self._row = 0
        self._cols.members = (self,)
        self.infeasible = infeasible
        self.replan = bool(replan)
        self.reselect_after = float(reselect_after)
        self.horizon = float(horizon)
        if not (math.isfinite(self.horizon) and self.horizon > 0.0):
            raise ValueError(f"horizon: expected a positive number of seconds, got {horizon!r}")
        self.detour_after = float(detour_after)
        self.goal_zone = float(goal_zone)
        self.navigate = bool(navigate)
        self.stopping_plans = bool(stopping_plans)
        self.switch_side_after = float(switch_side_after)
        if not self.switch_side_after > 0.0:
            raise ValueError(
                "switch_side_after: expected a positive number of seconds "
                f"(inf: never), got {switch_side_after!r}"
            )
        if not (math.isfinite(self.goal_zone) and self.goal_zone >= 0.0):
            raise ValueError(f"goal_zone: expected a distance >= 0 (m), got {goal_zone!r}")
        if samples is None:
            samples = max(2, round(self.horizon / _SAMPLE_STEP) + 1)
        self.times = np.linspace(0.0, self.horizon, int(samples))
        self.predictor_name = predictor or "turn_rate"
        self.predict = get_predictor(self.predictor_name)
        self.margin = float(margin)
        self.keep_band = float(keep_band)
        self.v_pref = v_pref
        self.sensing_range = float(sensing_range)
        self._grid_checked: NDArray[np.float64] | None = None
        self._grid_regular = False
        self.reset(None, np.random.default_rng(0))

    def reset(self, spec: RobotSpec | None, rng: np.random.Generator) -> None:
        """Start an episode: no decision yet, no detour; ``rng`` draws the detours."""
        self.current = np.zeros(2)
        self.last_selection = None
        self.age = 0.0
        self.rng = rng
        self.crawl_time = 0.0
        self.free_time = 0.0
        self.detour = 0.0
        self.detour_turns = 0
        self.side = -1.0  # detours turn right (-1) or, after switching sides, left (+1)
        self.best_distance = math.inf  # the closest (m) the robot has come to its goal
        self.since_progress = 0.0  # s since it last came 0.5 m closer
        self.settling = False
        self.around_wall = False  # the last heading target was a way around a wall
        self._cols.whole[self._row, SEEN] = -1  # nothing seen yet (see _seen)

    @property
    def last_selection(self) -> Selection | None:
        """The agent's last full selection (None before the first)."""
        return self._cols.selection(self._row)

    @last_selection.setter
    def last_selection(self, sel: Selection | None) -> None:
        self._cols.set_selection(self._row, sel)

    @property
    def _seen(
        self,
    ) -> (
        tuple[SensingBatch, int, NDArray[np.float64], tuple[NDArray[np.float64], NDArray[np.bool_]]]
        | None
    ):
        """What the last step saw: (batch, robot row, predictions, their excursions)."""
        cols, r = self._cols, self._row
        view = int(cols.whole[r, SEEN])
        if view < 0:
            return None
        batch, pred, excursions = cols.seen[view]
        return batch, int(cols.whole[r, ROW]), pred, excursions

    def __getstate__(self) -> dict[str, Any]:
        """Pickled (or copied) alone: with a table of its own row only."""
        state = self.__dict__.copy()
        own = AgentColumns(1)
        own.copy_row(self._cols, self._row, 0)
        state["_cols"], state["_row"] = own, 0
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._cols.members = (self,)

    def last_decision(self) -> tuple[Selection | None, NDArray[np.float64], float]:
        """What the agent keeps of its decisions, read-only: its last full selection (None
        before the first; ``status`` "desired", "adjusted" or "infeasible"), a copy of its
        current acceleration (2,) m/s^2 (kept, repaired or selected) and its detour (rad,
        <= 0: the goal direction is turned right by -detour, see the module docstring)."""
        return self.last_selection, np.array(self.current, dtype=np.float64), float(self.detour)

    def _regular_grid(self) -> bool:
        """Whether the time grid starts at 0 and increases (what the compiled paths
        assume); checked once per grid."""
        times = self.times
        if self._grid_checked is not times:
            self._grid_regular = bool(
                len(times) >= 2
                and times[0] == 0.0
                and np.all(np.diff(times) > 0)
                and np.all(np.isfinite(times))
            )
            self._grid_checked = times
        return self._grid_regular

    def _relevant_paths(
        self,
        predicted: NDArray[np.float64],
        excursions: tuple[NDArray[np.float64], NDArray[np.bool_]],
        idx: NDArray[np.int64],
        nb_radii: NDArray[np.float64],
        position: NDArray[np.float64],
        radius: float,
        walls: NDArray[np.float64],
        wall_radius: NDArray[np.float64],
        velocity: NDArray[np.float64],
        a_max: float,
        v_max: float,
    ) -> PiecewisePath:
        """:func:`~nao_arena.obstacles.obstacle_paths` of the neighbours predicted[idx]
        (radii nb_radii[idx]) and the walls in sensing range, without the obstacles
        that no acceleration within a_max (m/s^2) can reach (velocity m/s, speed limit
        v_max m/s): what every selection drops first (:func:`relevant_obstacles`), built
        in one compiled pass (where the time grid is regular and the velocity finite).
        excursions: :func:`path_excursions` of ``predicted`` (shared by the robots of a
        step)."""
        times = self.times
        grow = radius + self.margin
        if not (self._regular_grid() and math.isfinite(velocity[0]) and math.isfinite(velocity[1])):
            return obstacle_paths(
                times,
                predicted[idx],
                nb_radii[idx] + grow,
                position,
                walls,
                wall_radius + grow,
                self.sensing_range,
            )
        c, w, b, rad, finite = relevant_sampled_paths(
            times,
            predicted,
            idx,
            position,
            nb_radii,
            grow,
            velocity,
            float(a_max) * (1.0 + 1e-9),
            float(v_max),
            excursions[0],
            excursions[1],
        )
        if not finite:
            raise ValueError("centers: expected finite values")
        wall_rel, wall_r = relative_walls(walls, wall_radius + grow, position, self.sensing_range)
        wall_rel, wall_r = relevant_walls(
            velocity,
            float(a_max) * (1.0 + 1e-9),
            float(v_max),
            float(times[-1]),
            wall_rel,
            wall_r,
            0.0,
        )
        return PiecewisePath(times, c, w, b, rad, wall_rel, wall_r)

    def _select(
        self,
        desired: NDArray[np.float64],
        velocity: NDArray[np.float64],
        path: PiecewisePath,
        a_max: float,
        v_max: float,
        dt: float,
        traffic: bool = False,
    ) -> NDArray[np.float64]:
        """The full selection (m/s^2); becomes the current acceleration. traffic: whether
        non-reactive traffic is among the neighbours (``infeasible="auto"`` then dodges)."""
        sel = select_acceleration(
            desired,
            velocity,
            path,
            _limits(a_max),
            v_max=v_max,
            with_clearance=False,
            fallback=self._fallback(velocity, a_max, dt, traffic),
        )
        return self._commit(sel)

    def _fallback(
        self, velocity: NDArray[np.float64], a_max: float, dt: float, traffic: bool
    ) -> NDArray[np.float64] | None:
        """The acceleration (m/s^2) taken when nothing is admissible: braking towards
        standing still within one step dt (s) (:func:`nao_arena.motion.braking`), or None:
        the one that postpones contact longest (see ``infeasible``).
        (:func:`~nao_arena.agents._nao_decide.apply_braking` does the same for many
        robots.)"""
        if _brakes_when_infeasible(self, traffic):
            vx, vy = float(velocity[0]), float(velocity[1])
            return np.array(braking(vx, vy, float(a_max), float(dt)))
        return None

    def _commit(self, sel: Selection) -> NDArray[np.float64]:
        """A full selection becomes the current acceleration (m/s^2, a copy returned); its
        age restarts."""
        self.last_selection = sel
        self.age = 0.0
        self.current = sel.accel
        return self.current.copy()

    def _repair(
        self,
        desired: NDArray[np.float64],
        velocity: NDArray[np.float64],
        path: PiecewisePath,
        a_max: float,
        v_max: float,
    ) -> NDArray[np.float64] | None:
        """For a young adjustment that has become inadmissible: a nearby admissible
        acceleration (m/s^2, :func:`repair_acceleration`), which becomes the current one
        without restarting the adjustment's age; None: select in full."""
        if not self._holds_adjustment():
            return None
        fixed = repair_acceleration(
            self.current, desired, velocity, path, _limits(a_max), v_max=v_max
        )
        if fixed is not None:
            self.current = fixed
        return fixed

    def _holds_adjustment(self) -> bool:
        """Whether the current acceleration is an avoidance adjustment young enough to keep
        (while admissible) even though it lies outside keep_band of the desired one."""
        return bool(_holds(self._cols, np.array([self._row]))[0])

    def act(self, obs: Observation) -> NDArray[np.float64]:
        """The robot's acceleration (m/s^2): :meth:`act_batch` for the one-robot batch of
        ``obs`` (:meth:`SensingBatch.of_observation`); raises what that reports."""
        out, errors = _act_rows(
            [self], SensingBatch.of_observation(obs), np.zeros(1, dtype=np.int64)
        )
        if errors:
            raise errors[0]
        return out[0]

    @classmethod
    def act_batch(
        cls, agents: Sequence[NAOAgent], batch: SensingBatch, rows: Sequence[int]
    ) -> NDArray[np.float64] | list[NDArray[np.float64] | Exception]:
        """The accelerations (m/s^2) of the robots ``rows`` of ``batch`` (agent i drives
        robot rows[i]): an array (len(rows), 2), or where some robot's step raised, a list
        with one acceleration or exception per row.

        Predictions are made once per step for all bodies (per predictor and
        time grid) and indexed per robot; the liveness bookkeeping and goal
        seeking are one compiled call; whether the current accelerations stay
        admissible, and the repairs and selections of the others, are another
        per group; the stopping plans a third; only what they leave undecided
        (non-finite input, an irregular time grid, no admissible acceleration
        with ``infeasible="latest_contact"``) and the heading targets other than
        the goals (a detour turned this step, a goal missing, a wall in the
        way) run in Python. A subclass that overrides :meth:`act` gets its own
        ``act`` called robot by robot (the one hook besides the options).
        """
        rows_a = np.asarray(rows, dtype=np.int64)
        if all(t.act is NAOAgent.act for t in {type(ag) for ag in agents}):
            accels, errors = _act_rows(agents, batch, rows_a)
            if not errors:
                return accels
            return [errors.get(i, accels[i]) for i in range(len(rows_a))]
        out: list[NDArray[np.float64] | Exception | None] = [None] * len(rows_a)
        own = [i for i, ag in enumerate(agents) if type(ag).act is not NAOAgent.act]
        for i in own:
            try:
                out[i] = agents[i].act(batch.observation(int(rows_a[i])))
            except Exception as exc:  # noqa: BLE001 - the agent's failure
                out[i] = exc
        rest = [i for i in range(len(rows_a)) if out[i] is None]
        if rest:
            accels, errors = _act_rows([agents[i] for i in rest], batch, rows_a[rest])
            for j, i in enumerate(rest):
                out[i] = errors.get(j, accels[j])
        return out  # type: ignore[return-value]

    def panel(self) -> PanelAgent:
        """What the viewer's acceleration panel shows of this agent (its time grid,
        predictor, margin, v_pref, detour and the status of its last selection)."""
        code = int(self._cols.whole[self._row, STATUS])
        return PanelAgent(
            times=self.times,
            predict=self.predict,
            margin=self.margin,
            v_pref=self.v_pref,
            detour=float(self.detour),
            status=None if code == NO_SELECTION else SELECTION_LABELS[code],
        )

    def last_obstacles(self) -> PiecewisePath | None:
        """The obstacles of the agent's last step (None before its first): its
        neighbours' predicted paths and the wall discs in range, robot-relative (m),
        grown by its radius and margin, without those no acceleration within a_max could
        reach: what its keep test, repair and selection tested."""
        return None if self._seen is None else self._paths_of(*self._seen)

    def admissible(self, obs: Observation, accel: NDArray[np.float64]) -> bool:
        """Whether ``accel`` (2,) m/s^2 is within a_max and keeps the robot of ``obs`` clear
        of every obstacle the agent would see there (its keep test; changes nothing)."""
        batch = SensingBatch.of_observation(obs)
        pred = np.ascontiguousarray(self.predict(self.times, batch.everyone()), dtype=np.float64)
        path = self._paths_of(batch, 0, pred, path_excursions(pred))
        return self._admissible(
            np.asarray(accel, dtype=np.float64), batch.velocities[0], obs.a_max, obs.v_max, path
        )

    def _paths_of(
        self,
        batch: SensingBatch,
        k: int,
        pred: NDArray[np.float64],
        excursions: tuple[NDArray[np.float64], NDArray[np.bool_]],
    ) -> PiecewisePath:
        """:meth:`_relevant_paths` of robot k of ``batch`` (predictions ``pred`` of every
        body, with their :func:`path_excursions`)."""
        body = int(batch.bodies[k])
        return self._relevant_paths(
            pred,
            excursions,
            batch.neighbour_ids(k),
            batch.radii,
            batch.positions[body],
            float(batch.radii[body]),
            batch.walls,
            batch.wall_radius,
            batch.velocities[body],
            float(batch.a_max[body]),
            float(batch.v_max[body]),
        )

    def _detour_step(
        self, far: bool, crawling: bool, dt: float, to_goal: float, held: bool = True
    ) -> None:
        """One step (dt s) of the liveness bookkeeping (module docstring, Liveness) from
        precomputed tests: far from the goal, crawling (below v_max / 4), the distance
        to the goal (m), and held (its nearest neighbour stands still close by: only such
        time counts toward switching sides); :func:`detour_row` on the agent's row."""
        cols = self._cols
        if detour_row(
            self._row,
            bool(far),
            bool(crawling),
            float(dt),
            float(to_goal),
            bool(held),
            cols.real,
            cols.whole,
            cols.opt,
        ):
            self._turn_detour()

    def _turn_detour(self) -> None:
        """Turn the detour once more, by an angle in [30, 60] degrees (drawn from the
        agent's generator) to its side."""
        self.detour += self.side * float(self.rng.uniform(np.pi / 6, np.pi / 3))

    def _admissible(
        self,
        a: NDArray[np.float64],
        v: NDArray[np.float64],
        a_max: float,
        v_max: float,
        path: PiecewisePath,
    ) -> bool:
        """Whether acceleration a (m/s^2) is within a_max and keeps the robot (velocity v m/s,
        speed limit v_max m/s) clear of every obstacle of ``path`` over the horizon."""
        if float(np.hypot(*a)) > a_max * (1 + 1e-9):
            return False
        if path.n_obstacles == 0:
            return True
        ok = np.empty(1, dtype=bool)
        admissible_kernel(
            v[None].copy(),
            a[None].copy(),
            v_max,
            *path.arrays,
            piece_sweep(path.t, path.velocity, path.acceleration),
            0.0,
            ok,
        )
        return bool(ok[0])

    # ------------------------------------------------------------ the selection on its own
    # For an acceleration chosen by something else (the safety shield of nao_arena.shield):
    # the same predictions, admissibility test, repair, selection and fallbacks as act and
    # act_batch, with that acceleration in place of goal seeking (no detours, no replan).

    def nearest_admissible(
        self, obs: Observation, desired: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], str]:
        """The admissible acceleration (m/s^2) nearest ``desired`` (2,) m/s^2 for the robot
        of ``obs``, and how it was found (:data:`SHIELD_STATUSES`): "kept" (``desired`` is
        admissible and comes back as it is), "repaired" (it is not, and a young adjustment
        is repaired locally, as in :meth:`act`), "adjusted" (the full selection's nearest
        admissible one) or "infeasible" (nothing admissible: the fallback of
        ``infeasible``). Call once per control step: it ages the current adjustment
        (``reselect_after``) and the result becomes the current acceleration."""
        want = _desired_rows(desired, 1)
        out, status = NAOAgent.nearest_admissible_batch(
            [self], SensingBatch.of_observation(obs), [0], want
        )
        return out[0], status[0]

    def _nearest_on(
        self,
        desired: NDArray[np.float64],
        velocity: NDArray[np.float64],
        path: PiecewisePath,
        a_max: float,
        v_max: float,
        dt: float,
        traffic: bool,
    ) -> tuple[NDArray[np.float64], str]:
        """:meth:`nearest_admissible` on the robot's obstacle paths ``path`` (velocity m/s,
        limits a_max m/s^2 and v_max m/s, control period dt s; traffic: whether traffic is
        among the neighbours)."""
        if self._admissible(desired, velocity, a_max, v_max, path):
            self.current = desired.copy()
            return self.current, "kept"
        fixed = self._repair(desired, velocity, path, a_max, v_max)
        if fixed is not None:
            return fixed, "repaired"
        accel = self._select(desired, velocity, path, a_max, v_max, dt, traffic)
        assert self.last_selection is not None
        return accel, _SELECTION_STATUS[self.last_selection.status]

    @classmethod
    def nearest_admissible_batch(
        cls,
        agents: Sequence[NAOAgent],
        batch: SensingBatch,
        rows: Sequence[int],
        desired: NDArray[np.float64],
    ) -> tuple[NDArray[np.float64], list[str]]:
        """:meth:`nearest_admissible` for many robots at once (same results): agent i
        drives robot rows[i] of ``batch`` and gets desired[i] (m/s^2). Predictions once
        per step for all bodies, the admissibility of the desired accelerations in one
        compiled call, the repairs and selections of the others in another (as
        :meth:`act_batch`). Returns the accelerations (n, 2) m/s^2 and the statuses."""
        n = len(rows)
        rows_a = np.asarray(rows, dtype=np.int64)
        want = _desired_rows(desired, n)
        out = np.zeros((n, 2))
        status = [""] * n
        cols = columns_of(agents)
        pos, vel, rad, a_max, v_max, _, traffic_near, _ = _own_rows(batch, rows_a)
        cols.real[:, AGE] += batch.dt
        previous = cols.real[:, CUR_X : CUR_Y + 1].copy()
        cols.seen = []
        for m in cols.grid_groups(agents):
            ag0 = agents[int(m[0])]
            pred = np.ascontiguousarray(ag0.predict(ag0.times, batch.everyone()), dtype=np.float64)
            excursions, lists = _group_view(m, ag0, cols, batch, rows_a, pos, rad, pred)
            # the keep test with the desired accelerations as the ones to keep
            every = np.ones(len(m), dtype=bool)
            keep = _keep_current(
                m,
                ag0,
                cols,
                pred,
                excursions,
                lists,
                batch.radii,
                pos,
                vel,
                rad,
                v_max,
                want,
                want,
                a_max,
                every,
            )
            holds = _holds(cols, m)
            decided = (
                _decide(
                    m,
                    keep,
                    ag0,
                    cols,
                    pred,
                    excursions,
                    lists,
                    batch.radii,
                    pos,
                    vel,
                    rad,
                    a_max,
                    v_max,
                    previous,
                    want,
                    holds,
                )
                if lists is not None
                else None
            )
            for j, (i, st) in enumerate(zip(m.tolist(), keep.tolist(), strict=True)):
                ag = agents[i]
                if st == 1:
                    cols.real[i, CUR_X : CUR_Y + 1] = want[i]
                    out[i], status[i] = want[i], "kept"
                    continue
                if decided is not None and st == 0:
                    done = _take_decision(
                        ag, decided, j, vel[i], float(a_max[i]), batch.dt, bool(traffic_near[i])
                    )
                    if done is not None:
                        out[i], status[i] = done, _KIND_STATUS[int(decided[0][j])]
                        continue
                # undecided here: robot by robot
                path = ag._paths_of(batch, int(rows_a[i]), pred, excursions)
                out[i], status[i] = ag._nearest_on(
                    want[i],
                    vel[i],
                    path,
                    float(a_max[i]),
                    float(v_max[i]),
                    batch.dt,
                    bool(traffic_near[i]),
                )
        return out, status


def _desired_rows(desired: Any, n: int) -> NDArray[np.float64]:
    """``desired`` as n finite accelerations (n, 2) m/s^2 (n = 1: also a (2,) vector);
    else ValueError."""
    want = np.array(desired, dtype=np.float64)
    if want.shape != (n, 2) and not (n == 1 and want.shape == (2,)):
        raise ValueError(
            f"desired: expected {'(2,) or ' if n == 1 else ''}({n}, 2) "
            f"accelerations (m/s^2), got shape {want.shape}"
        )
    if not np.all(np.isfinite(want)):
        raise ValueError(f"desired: expected finite accelerations (m/s^2), got {want.tolist()}")
    return want.reshape(n, 2)


SHIELD_STATUSES: tuple[str, ...] = ("kept", "repaired", "adjusted", "infeasible")
"""How :meth:`NAOAgent.nearest_admissible` found its acceleration (see there)."""

_SELECTION_STATUS = {"desired": "kept", "adjusted": "adjusted", "infeasible": "infeasible"}
_KIND_STATUS: dict[int, str] = {  # looked up by the compiled kinds (int)
    REPAIRED: "repaired",
    DESIRED: "kept",
    ADJUSTED: "adjusted",
    INFEASIBLE: "infeasible",
}


_LIMITS: dict[float, AccelLimits] = {}


def _limits(a_max: float) -> AccelLimits:
    """AccelLimits(a_max), memoised (robots share a few limits)."""
    lim = _LIMITS.get(a_max)
    if lim is None:
        if len(_LIMITS) > 256:
            _LIMITS.clear()
        lim = _LIMITS[a_max] = AccelLimits(a_max)
    return lim


def _obstacle_lists(
    m: NDArray[np.int64],
    cols: AgentColumns,
    batch: SensingBatch,
    rows: NDArray[np.int64],
    pos: NDArray[np.float64],
    rad: NDArray[np.float64],
) -> ObstacleLists:
    """The obstacles each member (rows m of the agents' table) sees, as CSR lists
    (members' order): neighbours (nb_start, nb_index: body indices), then the walls in
    its range (wall_seg (W, 2, 2) m and wall_half (W,) m: every wall's ends and
    half-thickness; wall_start, wall_index)."""
    nb_start, nb_index = member_lists(
        np.ascontiguousarray(batch.nb_start, dtype=np.int64),
        np.ascontiguousarray(batch.nb_index, dtype=np.int64),
        np.ascontiguousarray(rows[m], dtype=np.int64),
    )
    wall_start = np.zeros(len(m) + 1, dtype=np.int64)
    walls = np.ascontiguousarray(batch.walls, dtype=np.float64).reshape(-1, 2, 2)
    half = np.ascontiguousarray(batch.wall_radius, dtype=np.float64)
    if not len(walls):
        return (nb_start, nb_index, walls, half, wall_start, np.zeros(0, dtype=np.int64))
    # the walls within each member's range: distance <= range + half-thickness + grow
    grow = rad[m] + cols.opt[m, MARGIN]
    reach = cols.opt[m, RANGE]
    dist = point_segment_distances(pos[m], walls)
    near = dist <= reach[:, None] + half[None, :] + grow[:, None]
    member, which = np.nonzero(near)
    np.cumsum(np.bincount(member, minlength=len(m)), out=wall_start[1:])
    return nb_start, nb_index, walls, half, wall_start, which.astype(np.int64)


def _holds(cols: AgentColumns, m: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Per row of m: whether the current acceleration is an avoidance adjustment young
    enough to keep (while admissible) even though it lies outside keep_band of the
    desired one (:func:`~nao_arena.agents._nao_columns.young_adjustments`)."""
    holds = np.empty(len(m), dtype=np.bool_)
    young_adjustments(m, cols.real, cols.whole, cols.opt, holds)
    return holds


def _keep_current(
    m: NDArray[np.int64],
    ag0: NAOAgent,
    cols: AgentColumns,
    pred: NDArray[np.float64],
    excursions: tuple[NDArray[np.float64], NDArray[np.bool_]],
    lists: ObstacleLists | None,
    nb_radius: NDArray[np.float64],
    pos: NDArray[np.float64],
    vel: NDArray[np.float64],
    rad: NDArray[np.float64],
    v_max: NDArray[np.float64],
    current: NDArray[np.float64],
    desired: NDArray[np.float64],
    a_max: NDArray[np.float64],
    holds: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """Per member (rows m of the agents' table, ag0's time grid): 1 keep the current
    acceleration (within keep_band of the desired one, or 0 while settling, and
    admissible), 0 select anew, 2 undecided here (decide from the full path).
    lists: :func:`_obstacle_lists` (None: an irregular time grid, nothing decided here);
    holds: per member, whether it holds a young adjustment."""
    status = np.zeros(len(m), dtype=np.int64)
    some = keep_candidates(
        m,
        np.ascontiguousarray(current, dtype=np.float64),
        np.ascontiguousarray(desired, dtype=np.float64),
        np.ascontiguousarray(a_max, dtype=np.float64),
        cols.whole,
        cols.opt,
        np.ascontiguousarray(holds, dtype=np.bool_),
        status,
    )
    if lists is None or some == 0:
        return status
    nb_start, nb_index, wall_seg, wall_half, wall_start, wall_index = lists
    todo = np.flatnonzero(status == 2)
    res = np.full(len(m), -1, dtype=np.int64)
    f = np.ascontiguousarray
    pos_m, vel_m, cur_m, v_max_m, rad_m = _members((pos, vel, current, v_max, rad), m)
    sampled_admissible_batch(
        f(ag0.times, dtype=np.float64),
        pred,
        nb_start,
        nb_index,
        f(nb_radius),
        wall_seg,
        wall_half,
        wall_start,
        wall_index,
        todo,
        pos_m,
        vel_m,
        cur_m,
        v_max_m,
        rad_m,
        cols.opt[m, MARGIN],
        excursions[0],
        excursions[1],
        res,
    )
    # 1: keep; 0: not admissible (select); -1: non-finite paths (the slow path reports it)
    status[todo] = np.where(res[todo] == 1, 1, np.where(res[todo] == 0, 0, 2))
    return status


def _members(arrays: tuple[NDArray[Any], ...], m: NDArray[np.int64]) -> list[NDArray[Any]]:
    """The rows m of each array (contiguous; the arrays themselves, when contiguous and m
    takes every row in order)."""
    every = all(len(m) == len(a) for a in arrays)  # m: distinct rows in order, so all
    return [np.ascontiguousarray(a) if every else np.ascontiguousarray(a[m]) for a in arrays]


def _decide(
    m: NDArray[np.int64],
    status: NDArray[np.int64],
    ag0: NAOAgent,
    cols: AgentColumns,
    pred: NDArray[np.float64],
    excursions: tuple[NDArray[np.float64], NDArray[np.bool_]],
    lists: ObstacleLists,
    nb_radius: NDArray[np.float64],
    pos: NDArray[np.float64],
    vel: NDArray[np.float64],
    rad: NDArray[np.float64],
    a_max: NDArray[np.float64],
    v_max: NDArray[np.float64],
    current: NDArray[np.float64],
    desired: NDArray[np.float64],
    holds: NDArray[np.bool_],
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]] | None:
    """The repairs (of the young adjustments, ``holds``) and selections of the members
    (rows m) with status 0, in one compiled call
    (:func:`~nao_arena.agents._nao_decide.decide`): (kind, accel m/s^2, tested) per
    member, or None when there are none."""
    todo = np.flatnonzero(status == 0)
    if len(todo) == 0:
        return None
    p, v, r, a, s, c, d = _members((pos, vel, rad, a_max, v_max, current, desired), m)
    return decide(
        ag0.times,
        pred,
        excursions,
        lists,
        nb_radius,
        todo,
        p,
        v,
        r + cols.opt[m, MARGIN],
        a,
        s,
        holds,
        c,
        d,
    )


def _brakes_when_infeasible(agent: NAOAgent, traffic: bool) -> bool:
    """Whether the agent brakes when nothing is admissible (``infeasible``), with
    (``traffic``) or without non-reactive traffic among its neighbours."""
    return agent.infeasible == "brake" or (agent.infeasible == "auto" and not traffic)


def _take_decision(
    ag: NAOAgent,
    decided: tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]],
    j: int,
    velocity: NDArray[np.float64],
    a_max: float,
    dt: float,
    traffic: bool,
) -> NDArray[np.float64] | None:
    """Apply member j's outcome of :func:`_decide` to its agent, as :meth:`NAOAgent._repair`
    and :meth:`NAOAgent._select` would: the acceleration (m/s^2), or None when it is left
    to the per-robot path (undecided, or no admissible acceleration and no braking).
    traffic: whether traffic is among the robot's neighbours."""
    kind, accel, tested = decided
    kd = int(kind[j])
    cols, r = ag._cols, ag._row
    if kd == REPAIRED:
        cols.real[r, CUR_X : CUR_Y + 1] = accel[j]
        return accel[j].copy()
    if kd == DESIRED or kd == ADJUSTED:
        cols.commit(r, accel[j], kd, int(tested[j]))
        return accel[j].copy()
    if kd == INFEASIBLE:
        fallback = ag._fallback(velocity, a_max, dt, traffic)
        if fallback is not None:
            chosen = _limits(a_max).project(fallback)
            cols.commit(r, chosen, INFEASIBLE, int(tested[j]))
            return np.array(chosen, dtype=np.float64)
    return None


# the last read-only kinds array and its traffic mask, replaced as one tuple (threads
# stepping other arenas see one pair or the other, never a mix)
_traffic_seen: tuple[Any, Any] = (None, None)


def _traffic_mask(kinds: NDArray[np.str_]) -> NDArray[np.bool_] | None:
    """Per body: whether it is traffic (None: no body is); worked out once per frozen
    kinds array (the arena's, which every step's batch shares; see
    :func:`nao_arena.sensing.read_only`)."""
    global _traffic_seen
    seen_kinds, seen_mask = _traffic_seen
    if kinds is seen_kinds:
        return seen_mask
    mask = kinds == "traffic"
    found = mask if mask.any() else None
    if is_frozen(kinds):
        _traffic_seen = (kinds, found)
    return found


def _own_rows(batch: SensingBatch, rows_a: NDArray[np.int64]) -> tuple[Any, ...]:
    """:func:`~nao_arena.agents._nao_batch.own_rows` of the batch rows ``rows_a``: per
    robot its position (m), velocity (m/s), radius (m), a_max (m/s^2), v_max (m/s),
    goal (m), whether traffic is among its neighbours; and whether every goal is
    finite."""
    return own_rows(*_own_inputs(batch, rows_a))


def _own_inputs(
    batch: SensingBatch, rows_a: NDArray[np.int64]
) -> tuple[
    NDArray[np.int64],
    NDArray[np.int64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.int64],
    NDArray[np.int64],
    NDArray[np.bool_],
]:
    """The arguments of :func:`~nao_arena.agents._nao_batch.own_rows` (and the first ones
    of ``prepare_rows``) for the batch rows ``rows_a``, as the kernels take them."""
    f = np.ascontiguousarray
    traffic = _traffic_mask(batch.kinds)
    return (
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


def _group_view(
    m: NDArray[np.int64],
    ag0: NAOAgent,
    cols: AgentColumns,
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    pos: NDArray[np.float64],
    rad: NDArray[np.float64],
    pred: NDArray[np.float64],
) -> tuple[tuple[NDArray[np.float64], NDArray[np.bool_]], ObstacleLists | None]:
    """What the agents of rows m (ag0's predictor and time grid) decide from, given the
    predictions ``pred`` of every body: their :func:`path_excursions` and the members'
    :func:`_obstacle_lists` (None: an irregular time grid). Each member keeps what it
    saw (:meth:`NAOAgent.last_obstacles`)."""
    excursions = path_excursions(pred)
    cols.whole[m, SEEN] = len(cols.seen)
    cols.whole[m, ROW] = rows_a[m]
    cols.seen.append((batch, pred, excursions))
    lists = _obstacle_lists(m, cols, batch, rows_a, pos, rad) if ag0._regular_grid() else None
    return excursions, lists


def _act_rows(
    agents: Sequence[NAOAgent], batch: SensingBatch, rows_a: NDArray[np.int64]
) -> tuple[NDArray[np.float64], dict[int, Exception]]:
    """:meth:`NAOAgent.act_batch` of agents that act as :class:`NAOAgent` does: the
    accelerations (n, 2) m/s^2 and, by agent, the exceptions of the robots whose step
    raised (their rows of the accelerations are meaningless). The common work runs in
    the compiled calls of :mod:`~nao_arena.agents._nao_batch`; only what they leave
    undecided runs robot by robot here."""
    cols = columns_of(agents)
    real, whole = cols.real, cols.whole
    errors: dict[int, Exception] = {}
    f = np.ascontiguousarray
    walls = f(batch.walls, dtype=np.float64).reshape(-1, 2, 2)
    wall_half = f(batch.wall_radius, dtype=np.float64)
    (
        pos,
        vel,
        rad,
        a_max,
        v_max,
        goals,
        live,
        n_live,
        out,
        turn,
        turns,
        traffic_near,
        desired,
        direct,
    ) = prepare_rows(
        *_own_inputs(batch, rows_a), walls, wall_half, float(batch.dt), real, whole, cols.opt
    )
    if not n_live:
        return out, errors  # holds (replan=False) keep their acceleration
    if turns:
        # liveness: crawling away from the goal turns the detour (angles drawn here)
        for i in np.flatnonzero(turn).tolist():
            agents[i]._turn_detour()
    if turns or not direct:
        # a turned detour, a goal missing or a wall in the way: the targets in Python
        desired = _desired(cols, batch, rows_a, goals, pos, vel, a_max, v_max)
    current = out.copy()
    cols.seen = []
    # predictions: once per (predictor, time grid) for every body
    for group in cols.grid_groups(agents):
        m = group if n_live == len(live) else group[live[group]]
        if not len(m):
            continue
        ag0 = agents[int(m[0])]
        try:
            pred = f(ag0.predict(ag0.times, batch.everyone()), dtype=np.float64)
        except Exception as exc:  # noqa: BLE001 - the agents' failure
            for i in m.tolist():
                errors[i] = exc
            continue
        excursions, lists = _group_view(m, ag0, cols, batch, rows_a, pos, rad, pred)
        if lists is None:
            # an irregular time grid: the keep test's first part only, the rest below
            status = _keep_current(
                m,
                ag0,
                cols,
                pred,
                excursions,
                lists,
                batch.radii,
                pos,
                vel,
                rad,
                v_max,
                current,
                desired,
                a_max,
                _holds(cols, m),
            )
            decided = None
            left = len(m)
            settled = np.zeros(len(m), dtype=bool)
        else:
            # the members' walls (wall_half above stays every wall's half-thickness)
            nb_start, nb_index, seg_m, half_m, start_m, index_m = lists
            status, kind, accel, tested, settled, left = settle_members(
                m,
                f(ag0.times, dtype=np.float64),
                pred,
                excursions[0],
                excursions[1],
                nb_start,
                nb_index,
                f(batch.radii, dtype=np.float64),
                seg_m,
                half_m,
                start_m,
                index_m,
                pos,
                vel,
                rad,
                a_max,
                v_max,
                current,
                desired,
                traffic_near,
                float(batch.dt),
                *selection_settings(a_max if len(m) == len(a_max) else a_max[m]),
                real,
                whole,
                cols.opt,
                out,
            )
            decided = kind, accel, tested
        if left:
            _undecided(
                agents,
                m,
                status,
                settled,
                decided,
                errors,
                out,
                batch,
                rows_a,
                pred,
                excursions,
                vel,
                a_max,
                v_max,
                current,
                desired,
                traffic_near,
            )
    failed = np.zeros(len(rows_a), dtype=np.bool_)
    if errors:
        failed[list(errors)] = True
    yield_rows(
        pos,
        vel,
        out,
        rad,
        a_max,
        v_max,
        failed,
        float(batch.dt),
        int(batch.substeps),
        PLAN_MARGIN,
        walls,
        wall_half,
        real,
        whole,
    )
    return out, errors


_NO_TRAFFIC = np.zeros(0, dtype=np.bool_)


def _undecided(
    agents: Sequence[NAOAgent],
    m: NDArray[np.int64],
    status: NDArray[np.int64],
    settled: NDArray[np.bool_],
    decided: tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]] | None,
    errors: dict[int, Exception],
    out: NDArray[np.float64],
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    pred: NDArray[np.float64],
    excursions: tuple[NDArray[np.float64], NDArray[np.bool_]],
    vel: NDArray[np.float64],
    a_max: NDArray[np.float64],
    v_max: NDArray[np.float64],
    current: NDArray[np.float64],
    desired: NDArray[np.float64],
    traffic_near: NDArray[np.bool_],
) -> None:
    """The members m (rows of the agents' table) that the compiled calls left
    unsettled, robot by robot: the fallback of an outcome that is not braking
    (:func:`_take_decision`), else the keep test, repair and selection in Python (non-finite
    paths, an irregular time grid). Writes ``out`` (n, 2) m/s^2; a robot whose step raises
    gets its exception in ``errors``."""
    for j in np.flatnonzero(~settled).tolist():
        i = int(m[j])
        ag = agents[i]
        try:
            if decided is not None and status[j] == 0:
                done = _take_decision(
                    ag, decided, j, vel[i], float(a_max[i]), batch.dt, bool(traffic_near[i])
                )
                if done is not None:
                    out[i] = done
                    continue
            path = ag._paths_of(batch, int(rows_a[i]), pred, excursions)
            if status[j] == 2 and ag._admissible(
                current[i], vel[i], float(a_max[i]), float(v_max[i]), path
            ):
                continue  # kept: out holds the current acceleration
            fixed = ag._repair(desired[i], vel[i], path, float(a_max[i]), float(v_max[i]))
            if fixed is not None:
                out[i] = fixed
                continue
            out[i] = ag._select(
                desired[i],
                vel[i],
                path,
                float(a_max[i]),
                float(v_max[i]),
                batch.dt,
                bool(traffic_near[i]),
            )
        except Exception as exc:  # noqa: BLE001 - the agent's failure
            errors[i] = exc


def _desired(
    cols: AgentColumns,
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    goals: NDArray[np.float64],
    pos: NDArray[np.float64],
    vel: NDArray[np.float64],
    a_max: NDArray[np.float64],
    v_max: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The goal-seeking accelerations (n, 2) m/s^2 (:func:`desired_rows`:
    goal seeking at min(v_pref, v_max), turned by each agent's detour; agents: the rows
    of ``cols``) toward the robots' :func:`_heading_targets`."""
    targets, has_target = _heading_targets(cols, batch, rows_a, goals, pos)
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


def _heading_targets(
    cols: AgentColumns,
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    goals: NDArray[np.float64],
    pos: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Where each robot heads (n, 2) m, and whether it has a target: its goal; a robot
    without a finite goal heads for its route's last waypoint, or has none (stands
    still); where a wall stands in the way, the way around it (:func:`_around_walls`)."""
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
        targets = _around_walls(cols, batch, rows_a, targets, pos)
    return targets, has_target


def _around_walls(
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
    for clearance, members in groups.items():
        grid = navigation_grid(walls, batch.wall_radius, clearance, box)
        m = np.asarray(members, dtype=np.int64)
        out[m], around = route_targets(grid, pos[m], targets[m], radii[m])
        cols.whole[m, AROUND] = around
    return out


class AOAgent(NAOAgent):
    """The same selection with constant-acceleration predictions (the AO); it takes
    every option of :class:`NAOAgent` except the predictor."""

    def __init__(
        self,
        horizon: float = 3.0,
        samples: int | None = None,
        margin: float = 0.15,
        keep_band: float = 0.3,
        v_pref: float | None = None,
        sensing_range: float = 30.0,
        detour_after: float = 1.0,
        replan: bool = True,
        reselect_after: float = 1.0,
        infeasible: str = "auto",
        goal_zone: float = 1.0,
        navigate: bool = True,
        stopping_plans: bool = True,
        switch_side_after: float = 20.0,
    ) -> None:
        super().__init__(
            horizon,
            samples,
            "constant_acceleration",
            margin,
            keep_band,
            v_pref,
            sensing_range,
            detour_after,
            replan,
            reselect_after,
            infeasible,
            goal_zone,
            navigate,
            stopping_plans,
            switch_side_after,
        )
