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
   not stop for it); ``"brake"`` and ``"latest_contact"`` force either;
   ``"stop_in_time"`` brakes where braking brings the robot to rest before
   any predicted contact (a contact then finds it standing) and postpones
   contact longest elsewhere.

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
predictions once per step for all bodies, and the rest of the step in compiled
calls (:mod:`nao_arena.agents._nao_batch`: the robots' own state, liveness and
goal seeking; per group of shared predictions, the keep test (1.), the repairs
and the selections; the stopping plans (4.)). When the agents share one
predictor and regular time grid (the usual case), all of it is one call, the
built-in ``turn_rate`` predictions included, or two where Python finds the
heading targets between them (a detour turned, a wall in the way). Their state (current
acceleration, adjustment age, detours, last selection) and numeric options are
the rows of one table (:mod:`nao_arena.agents._nao_columns`), so no Python runs
per robot unless a robot needs what the compiled calls cannot decide (an
irregular time grid, non-finite input, the latest-contact fallback:
:mod:`nao_arena.agents._nao_per_robot`); the Python between the compiled calls
is :mod:`nao_arena.agents._nao_step`. :meth:`NAOAgent.act`
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
from nao_arena.geometry import PiecewisePath
from nao_arena.geometry.kernels import path_excursions
from nao_arena.geometry.selection import Selection
from nao_arena.imperfection import lag_factor
from nao_arena.predictors import TurnRateInputs, get_predictor, turn_rate, turn_rate_inputs
from nao_arena.sensing import Observation, SensingBatch
from nao_arena.stopping import NOISE_SIGMAS, Knowledge

from . import _nao_columns as col
from . import _nao_per_robot as per_robot
from ._kernel_inputs import wall_segments
from ._nao_batch import (
    DECIDED,
    PREPARED,
    SETTLED,
    decide_rows,
    prepare_rows,
    settle_members,
    settle_rows,
    yield_rows,
)
from ._nao_bundles import OneGroup, OwnInputs
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
)
from ._nao_decide import (
    ADJUSTED,
    DESIRED,
    INFEASIBLE,
    REPAIRED,
    apply_braking,
    apply_decisions,
    selection_settings,
)
from ._nao_knowledge import knowledge
from ._nao_latency import CommandLog, compensated
from ._nao_step import (
    Decisions,
    GroupView,
    RobotRows,
    decide_members,
    desired_accels,
    group_view,
    keep_current,
    own_inputs,
    own_rows_of,
    predictions,
)

if TYPE_CHECKING:
    from nao_arena.maps import RobotSpec

_SAMPLE_STEP = 0.1  # s between the samples of a predicted path by default
PLAN_MARGIN = 0.005  # m kept between stopping plans beyond the sum of the radii
_NO_ROWS = np.zeros(0)  # s, rad: the fine grid and headings of no body

SHIELD_STATUSES: tuple[str, ...] = ("kept", "repaired", "adjusted", "infeasible")
"""How :meth:`NAOAgent.nearest_admissible` found its acceleration (see there)."""

_KIND_STATUS: dict[int, str] = {  # looked up by the compiled kinds (int)
    REPAIRED: "repaired",
    DESIRED: "kept",
    ADJUSTED: "adjusted",
    INFEASIBLE: "infeasible",
}


class NAOAgent:
    """NAO avoidance. Options (keyword-only): horizon (s), samples (per horizon; None:
    one every 0.1 s), predictor name, margin (m), keep_band (m/s^2), v_pref (m/s),
    sensing_range (m), detour_after (s), replan, reselect_after (s), infeasible ("auto",
    "brake", "latest_contact" or "stop_in_time"), goal_zone (m), navigate (heads around
    walls that stand between the robot and its goal, see :mod:`nao_arena.navigation`),
    stopping_plans (commits to stopping plans with the other robots of its batch and
    brakes where its choice would meet theirs, see :mod:`nao_arena.stopping`),
    switch_side_after (s),
    noise_sigmas (how many standard deviations of the sensing noise the stopping plans'
    tubes of robots it is not linked with grow by, see :mod:`nao_arena.stopping`;
    fewer keeps robots moving, at a higher chance of a contact under noise),
    uncertainty_growth (m/s; 0, the default: off): each step, first the selection
    toward the desired acceleration against the predictions with every moving
    obstacle's radius grown by this much per second of prediction
    (:func:`nao_arena.geometry.grown_with_time`); where that finds an admissible
    acceleration it is the command, elsewhere the decision against the predictions
    themselves stands (for people whose predictions grow less certain the further
    ahead they look, see docs/results/people.md).

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

    # the agent's options, keyword-only: each is named at every call (maps pass them by
    # name), so none can be given in another's place
    def __init__(  # noqa: PLR0913
        self,
        *,
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
        noise_sigmas: float = NOISE_SIGMAS,
        uncertainty_growth: float = 0.0,
    ) -> None:
        if infeasible not in col.FALLBACKS:
            raise ValueError(
                f"infeasible: expected one of {', '.join(map(repr, col.FALLBACKS))}, "
                f"got {infeasible!r}"
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
        self.noise_sigmas = float(noise_sigmas)
        self.uncertainty_growth = float(uncertainty_growth)
        if not (math.isfinite(self.uncertainty_growth) and self.uncertainty_growth >= 0.0):
            raise ValueError(
                f"uncertainty_growth: expected a number >= 0 (m/s), got {uncertainty_growth!r}"
            )
        if not (math.isfinite(self.noise_sigmas) and self.noise_sigmas >= 0.0):
            raise ValueError(f"noise_sigmas: expected a number >= 0, got {noise_sigmas!r}")
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
        self._command_log: CommandLog | None = None  # kept under a sensing latency only
        self._lag_state = np.zeros(2)  # the applied acceleration under an actuation lag

    def _log_for(self, batch: SensingBatch) -> CommandLog:
        """The log of the commands this robot issued, kept for ``batch.latency``."""
        if self._command_log is None:
            self._command_log = CommandLog(round(batch.latency / batch.dt) + 1)
        return self._command_log

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

    def _holds_adjustment(self) -> bool:
        """Whether the current acceleration is an avoidance adjustment young enough to keep
        (while admissible) even though it lies outside keep_band of the desired one."""
        return bool(self._cols.holds(np.array([self._row]))[0])

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
        seen = self._seen
        return None if seen is None else per_robot.paths_of(self, *seen)

    def admissible(self, obs: Observation, accel: NDArray[np.float64]) -> bool:
        """Whether ``accel`` (2,) m/s^2 is within a_max and keeps the robot of ``obs`` clear
        of every obstacle the agent would see there (its keep test; changes nothing)."""
        batch = SensingBatch.of_observation(obs)
        pred = predictions(self, batch)
        path = per_robot.paths_of(self, batch, 0, pred, path_excursions(pred))
        return per_robot.admissible(
            np.asarray(accel, dtype=np.float64), batch.velocities[0], obs.a_max, obs.v_max, path
        )

    def _turn_detour(self) -> None:
        """Turn the detour once more, by an angle in [30, 60] degrees (drawn from the
        agent's generator) to its side."""
        self.detour += self.side * float(self.rng.uniform(np.pi / 6, np.pi / 3))

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
        compiled call, the repairs and selections of the others in another, their
        commits (and braking where nothing is admissible) in two more (as
        :meth:`act_batch`). Returns the accelerations (n, 2) m/s^2 and the statuses."""
        n = len(rows)
        rows_a = np.asarray(rows, dtype=np.int64)
        want = _desired_rows(desired, n)
        out = np.zeros((n, 2))
        status = [""] * n
        cols = columns_of(agents)
        pos, vel, rad, a_max, v_max, _, traffic_near, _ = own_rows_of(batch, rows_a, cols.memo)
        own = RobotRows(pos, vel, rad, a_max, v_max, traffic_near)
        cols.real[:, AGE] += batch.dt
        previous = cols.real[:, CUR_X : CUR_Y + 1].copy()
        cols.seen = []
        for m in cols.grid_groups(agents):
            ag0 = agents[int(m[0])]
            view = group_view(
                m, ag0, cols, batch, rows_a, own, predictions(ag0, batch), wall_segments(batch)
            )
            # the keep test with the desired accelerations as the ones to keep
            every = np.ones(len(m), dtype=bool)
            keep = keep_current(view, cols, batch.radii, own, want, want, every)
            settled = keep == 1
            for i in m[settled].tolist():
                cols.real[i, CUR_X : CUR_Y + 1] = want[i]
                out[i], status[i] = want[i], "kept"
            if view.lists is not None:
                holds = cols.holds(m)
                decided = decide_members(view, keep, cols, batch.radii, own, previous, want, holds)
                if decided is not None:
                    _commit_decisions(m, keep, decided, own, float(batch.dt), cols, out, settled)
                    for j in np.flatnonzero(settled & (keep == 0)).tolist():
                        status[int(m[j])] = _KIND_STATUS[int(decided[0][j])]
            # undecided here: robot by robot
            for j in np.flatnonzero(~settled).tolist():
                i = int(m[j])
                path = per_robot.paths_of(
                    agents[i], batch, int(rows_a[i]), view.pred, view.excursions
                )
                out[i], status[i] = per_robot.nearest_on(
                    agents[i],
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


def _commit_decisions(
    m: NDArray[np.int64],
    status: NDArray[np.int64],
    decided: Decisions,
    own: RobotRows,
    dt: float,
    cols: AgentColumns,
    out: NDArray[np.float64],
    settled: NDArray[np.bool_],
) -> None:
    """The outcomes ``decided`` of the members m with status 0 committed into the agents'
    table and ``out`` (n, 2) m/s^2 (settled[j] = True for each): the repairs and the
    admissible selections (:func:`~nao_arena.agents._nao_decide.apply_decisions`), and
    where nothing is admissible and the fallback is braking, braking within dt s
    (:func:`~nao_arena.agents._nao_decide.apply_braking`)."""
    kind, accel, tested = decided
    apply_decisions(m, status, kind, accel, tested, cols.real, cols.whole, out, settled)
    apply_braking(
        m,
        status,
        kind,
        tested,
        own.traffic_near,
        own.vel,
        own.a_max,
        dt,
        cols.real,
        cols.whole,
        out,
        settled,
    )


def _act_rows(
    agents: Sequence[NAOAgent], batch: SensingBatch, rows_a: NDArray[np.int64]
) -> tuple[NDArray[np.float64], dict[int, Exception]]:
    """:meth:`NAOAgent.act_batch` of agents that act as :class:`NAOAgent` does: the
    accelerations (n, 2) m/s^2 and, by agent, the exceptions of the robots whose step
    raised (their rows of the accelerations are meaningless). The common work runs in
    the compiled calls of :mod:`~nao_arena.agents._nao_batch`, in one
    (:func:`~nao_arena.agents._nao_batch.decide_rows`) when every agent re-plans and
    they share one predictor and regular time grid; only what they leave undecided runs
    robot by robot here."""
    logs = None
    know = knowledge(batch, rows_a, agents[0].noise_sigmas if agents else NOISE_SIGMAS)
    if batch.latency > 0.0:  # bring what was sensed batch.age s ago up to now
        logs = [ag._log_for(batch) for ag in agents]
        batch = compensated(batch, rows_a, logs)
    cols = columns_of(agents)
    errors: dict[int, Exception] = {}
    walls = wall_segments(batch)
    inputs = own_inputs(batch, rows_a, cols.memo)
    dt = float(batch.dt)
    one = _one_group(agents, cols, batch, inputs, know)
    # the predictions of the first group (or its predictor's failure), once made
    first: NDArray[np.float64] | Exception | None = None
    stage = PREPARED
    if isinstance(one, OneGroup):
        stage, prepared, rest, out, made, excursion, finite = decide_rows(
            inputs, walls, dt, cols.table, one
        )
        if stage == DECIDED:
            cols.seen = [(batch, made, (excursion, finite))]
            return _commands(agents, batch, logs, out), errors
        one, first = one._replace(pred=made), made
    else:
        first = one
        prepared = prepare_rows(inputs, walls, dt, cols.table)
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
    ) = prepared
    own = RobotRows(pos, vel, rad, a_max, v_max, traffic_near)
    if stage == PREPARED:
        if not n_live:
            return _commands(agents, batch, logs, out), errors  # holds keep their acceleration
        if turns:
            # liveness: crawling away from the goal turns the detour (angles drawn here)
            for i in np.flatnonzero(turn).tolist():
                agents[i]._turn_detour()
        if turns or not direct:
            # a turned detour, a goal missing or a wall in the way: the targets in Python
            desired = desired_accels(cols, batch, rows_a, goals, pos, vel, a_max, v_max)
        if isinstance(one, OneGroup) and n_live == len(live):
            stage, excursion, finite, rest = settle_rows(
                inputs, walls, dt, cols.table, one, own, desired, out
            )
            if stage == DECIDED:
                cols.seen = [(batch, one.pred, (excursion, finite))]
                return _commands(agents, batch, logs, out), errors
    if stage == SETTLED:
        assert isinstance(one, OneGroup)
        cols.seen = [(batch, one.pred, (excursion, finite))]
        lists, status, settled, left, current = rest
        if left:
            every = np.arange(len(rows_a), dtype=np.int64)
            view = GroupView(every, agents[0], one.pred, (excursion, finite), lists)
            per_robot.undecided(
                agents, view, status, settled, errors, out, batch, rows_a, own, current, desired
            )
    else:
        current = out.copy()
        cols.seen = []
        # predictions: once per (predictor, time grid) for every body
        for g, group in enumerate(cols.grid_groups(agents)):
            m = group if n_live == len(live) else group[live[group]]
            if not len(m):
                continue
            ag0 = agents[int(m[0])]
            if g == 0 and first is not None:
                pred = first  # made above, by an agent of the same group
            else:
                try:
                    pred = predictions(ag0, batch)
                except Exception as exc:  # noqa: BLE001 - the agents' failure
                    pred = exc
            if isinstance(pred, Exception):
                for i in m.tolist():
                    errors[i] = pred
                continue
            view = group_view(m, ag0, cols, batch, rows_a, own, pred, walls)
            if view.lists is None:
                # an irregular time grid: the keep test's first part only, the rest below
                status = keep_current(view, cols, batch.radii, own, current, desired, cols.holds(m))
                left = len(m)
                settled = np.zeros(len(m), dtype=bool)
            else:
                status, _, _, _, settled, left = settle_members(
                    m,
                    view.paths,
                    view.lists,
                    inputs.radii,
                    own,
                    current,
                    desired,
                    dt,
                    selection_settings(a_max if len(m) == len(a_max) else a_max[m], cols.memo),
                    cols.table,
                    out,
                )
            if left:
                per_robot.undecided(
                    agents, view, status, settled, errors, out, batch, rows_a, own, current, desired
                )
    per_robot.robust(agents, live, errors, out, own, desired)
    failed = np.zeros(len(rows_a), dtype=np.bool_)
    if errors:
        failed[list(errors)] = True
    yield_rows(
        own,
        out,
        failed,
        dt,
        int(batch.substeps),
        PLAN_MARGIN,
        walls,
        know,
        cols.table,
    )
    return _commands(agents, batch, logs, out), errors


def _commands(
    agents: Sequence[NAOAgent],
    batch: SensingBatch,
    logs: Sequence[CommandLog] | None,
    out: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The commands (n, 2) m/s^2 that apply the decided accelerations ``out`` (n, 2) m/s^2
    through the actuation lag (:func:`_through_lag`), each robot's logged
    (:func:`_log_commands`)."""
    _log_commands(logs, batch.time, out)
    return _through_lag(agents, out, batch)


def _one_group(
    agents: Sequence[NAOAgent],
    cols: AgentColumns,
    batch: SensingBatch,
    inputs: OwnInputs,
    know: Knowledge,
) -> OneGroup | Exception | None:
    """What :func:`~nao_arena.agents._nao_batch.decide_rows` takes of a batch whose agents
    share one predictor and regular time grid (:func:`_shared_predictor`): the
    :class:`~nao_arena.agents._nao_bundles.OneGroup` with the predictions of every body,
    or with their turn-rate inputs for the built-in ``turn_rate`` predictor (made in
    the compiled call); the exception of a predictor that raised; None for other
    batches."""
    shared = _shared_predictor(agents, cols)
    if shared is None:
        return None
    times = np.ascontiguousarray(shared.times, dtype=np.float64)
    if shared.predict is turn_rate:
        arcs = turn_rate_inputs(times, batch.positions, batch.velocities, batch.accelerations)
        pred = np.zeros((0, len(times), 2))
    else:
        # no body's turn-rate inputs: the batch's own arrays cut empty, of the types
        # decide_rows is compiled for
        arcs = TurnRateInputs(
            batch.positions[:0],
            batch.velocities[:0],
            batch.accelerations[:0],
            _NO_ROWS,
            _NO_ROWS,
            _NO_ROWS,
        )
        try:
            pred = predictions(shared, batch)
        except Exception as exc:  # noqa: BLE001 - the agents' failure, reported by the caller
            return exc
    return OneGroup(
        times,
        pred,
        arcs,
        selection_settings(inputs.a_max[inputs.bodies[inputs.rows]], cols.memo),
        know,
        int(batch.substeps),
        PLAN_MARGIN,
        all(ag.uncertainty_growth <= 0.0 for ag in agents),
    )


def _shared_predictor(agents: Sequence[NAOAgent], cols: AgentColumns) -> NAOAgent | None:
    """The agent whose predictor and time grid every agent of the batch shares (the
    first), when that grid is regular: the case
    :func:`~nao_arena.agents._nao_batch.decide_rows` takes (whole when every agent
    decides this step); else None."""
    if len(cols.grid_groups(agents)) != 1 or not agents[0]._regular_grid():
        return None
    return agents[0]


def _through_lag(
    agents: Sequence[NAOAgent], out: NDArray[np.float64], batch: SensingBatch
) -> NDArray[np.float64]:
    """The commands (n, 2) m/s^2 that make the actuation lag apply ``out``: with the lag's
    fraction f (:func:`~nao_arena.imperfection.lag_factor`) and each robot's applied
    acceleration a, a + (out - a) / f, which the lag turns into a + f (command - a) = out;
    ``out`` itself without a lag. Each robot's applied acceleration becomes its ``out``."""
    if batch.actuation_lag <= 0.0:
        return out
    f = lag_factor(float(batch.dt), float(batch.actuation_lag))
    applied = np.array([ag._lag_state for ag in agents], dtype=np.float64).reshape(-1, 2)
    commands = applied + (out - applied) / f
    for ag, a in zip(agents, out, strict=True):
        ag._lag_state = np.array(a, dtype=np.float64)
    return commands


def _log_commands(logs: Sequence[CommandLog] | None, now: float, out: NDArray[np.float64]) -> None:
    """Log each robot's command ``out[i]`` (m/s^2) for the period starting at ``now`` (s)."""
    if logs is not None:
        for log, command in zip(logs, out, strict=True):
            log.add(now, command)


class AOAgent(NAOAgent):
    """The same selection with constant-acceleration predictions (the AO); it takes
    every option of :class:`NAOAgent` except the predictor."""

    def __init__(  # noqa: PLR0913 - keyword-only options, as NAOAgent's
        self,
        *,
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
        noise_sigmas: float = NOISE_SIGMAS,
    ) -> None:
        super().__init__(
            horizon=horizon,
            samples=samples,
            predictor="constant_acceleration",
            margin=margin,
            keep_band=keep_band,
            v_pref=v_pref,
            sensing_range=sensing_range,
            detour_after=detour_after,
            replan=replan,
            reselect_after=reselect_after,
            infeasible=infeasible,
            goal_zone=goal_zone,
            navigate=navigate,
            stopping_plans=stopping_plans,
            switch_side_after=switch_side_after,
            noise_sigmas=noise_sigmas,
        )
