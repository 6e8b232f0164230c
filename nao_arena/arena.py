"""The one control loop: sense -> act -> physics -> stats.

:class:`Arena` owns a :class:`~nao_arena.world.World`, one agent per robot,
the scripted lane followers of the map's traffic and the episode's
:class:`~nao_arena.stats.EpisodeStats`. Each :meth:`Arena.step`:

1. reads the world state (bulk arrays);
2. senses for every robot at once (:class:`~nao_arena.sensing.SensingBatch`):
   own state, goal/route, neighbours within ``sensing_range`` (with the true
   future paths of traffic and the accelerations other robots committed
   to, i.e. their last commands as the world applied them, scaled to
   |a| <= a_max), walls; a per-robot agent gets it as an
   :class:`~nao_arena.sensing.Observation`; all of it read-only;
3. asks every robot's agent for an acceleration (m/s^2, world frame) —
   external actions (e.g. from the PettingZoo env) replace the agents of
   the robots they name; a failing agent gets zero acceleration and a fault
   is recorded; traffic gets its lane followers' accelerations. Agent
   classes with a ``act_batch(agents, batch, rows)`` classmethod are asked
   once per class for all their robots (one acceleration or exception per
   row, or an array (rows, 2) of accelerations; checked like
   :func:`~nao_arena.agent.safe_act`); the result must be
   what ``act`` would give robot by robot;
4. steps the world (limits enforced there);
5. updates the statistics (swept contact check over every physics substep,
   metrics) and the episode's trajectory hash.

The imperfect world (map sections ``sensing``, ``actuation`` and
``communication``, or the :class:`ArenaOptions` that override them; all off by
default, see :mod:`nao_arena.imperfection`), in the order they apply: in step 2, the
field of view narrows the neighbour lists (the nearest ``max_neighbours`` in view;
:meth:`Arena.sensing` and :meth:`Arena.observations` include it), then, in
:meth:`Arena.sensed` (what :meth:`Arena.step` and the env read), the dropout
removes neighbours and the sensing noise is added to what each robot senses of each
remaining neighbour (own states stay exact), the latency delays that imperfect
batch (the agents receive the batch sensed ``latency`` s ago, noise, dropout and
all, as frozen read-only arrays; the recorder gets it too), and the communication
channel (:mod:`nao_arena.communication`) adds what the robots heard this period and
hides the plans of pairs that are not linked. After step 3, the actuation noise is added to the
robots' commands and the actuation lag filters them; the world gets the result
(``StepResult.commanded``) and enforces its limits on it. The statistics use the
truth. Each random model draws from a generator of its own, spawned from the
episode's seed after the agents' generators.

The trajectory hash (``EpisodeSummary.trajectory_hash``) is a SHA-256 over
the positions (m) then the velocities (m/s) of every body, in body order, as
float64 bytes, of the state after :meth:`Arena.reset` and after each step:
two episodes with the same hash followed the same trajectory.

The PettingZoo env and the trial runner both drive this loop; neither has a
loop of its own.

Recording: an arena whose ``recorder`` is set (a :class:`StepRecorder`, e.g.
:class:`nao_arena.episode_log.EpisodeRecorder`) hands it the state after
:meth:`Arena.reset` and every step's sensing and result; it only reads them
(with ``recorder = None``, the default, nothing else happens).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import math
import os
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.agent import (
    UNCONTAINED,
    AgentError,
    AgentFault,
    BatchAgent,
    TooManyFaults,
    check_agent_class,
    describe,
    load_agent,
    safe_act,
    safe_act_batch,
)
from nao_arena.communication import Channel
from nao_arena.imperfection import (
    drop,
    headings,
    imperfections,
    in_view,
    lag_factor,
    lag_step,
    subset,
    with_neighbour_noise,
)
from nao_arena.kernels import watch_compiles
from nao_arena.maps import MapSpec, RobotSpec, map_from_dict
from nao_arena.occlusion import visible
from nao_arena.period import EpisodePeriod, GoalTest, episode_inputs, run_period, within_goal
from nao_arena.sensing import (
    Observation,
    ReadOnlyRoutes,
    SensingBatch,
    neighbour_lists,
    read_only,
)
from nao_arena.stats import ContactEvent, EpisodeStats, EpisodeSummary, StatsConfig
from nao_arena.traffic import LaneTraffic
from nao_arena.world import PeriodArrays, World, WorldState, applied_plans

watch_compiles()  # the kernels' compiles are timed and logged (logger nao_arena.kernels)

__all__ = ["Arena", "ArenaOptions", "StepRecorder", "StepResult", "make_agent"]


@dataclass(frozen=True)
class ArenaOptions:
    """Settings of the control loop; a None field takes the map's value."""

    sensing_range: float | None = None
    """Radius (m) within which a robot senses bodies; None: the map's ``sensing.range``."""
    max_neighbours: int | None = None
    """The most bodies a robot senses, nearest first; None: the map's
    ``sensing.max_neighbours``."""
    sensing_latency: float | None = None
    """Age (s) of what the agents sense (whole control periods); None: the map's
    ``sensing.latency``."""
    actuation_noise: float | None = None
    """Standard deviation (m/s^2) of the Gaussian noise added to each component of the
    robots' commands; None: the map's ``actuation.noise``."""
    sensing_noise: Mapping[str, float] | None = None
    """Standard deviations of the Gaussian noise on what a robot senses of each neighbour,
    by key ``position`` (m), ``velocity`` (m/s), ``acceleration`` (m/s^2) (a missing key:
    0); None: the map's ``sensing.noise``."""
    sensing_dropout: float | None = None
    """Probability in [0, 1] that a robot misses a neighbour in a step; None: the map's
    ``sensing.dropout``."""
    sensing_field_of_view: float | None = None
    """Angle (rad, in (0, 2 pi]) around a robot's heading within which it senses bodies;
    None: the map's ``sensing.field_of_view``."""
    sensing_occlusion: bool | None = None
    """Whether a robot senses only the bodies it can see past the bodies and walls in front
    of them (:mod:`nao_arena.occlusion`); None: the map's ``sensing.occlusion``."""
    actuation_lag: float | None = None
    """Time constant (s, >= 0) of the first-order response of the robots' applied
    accelerations to their commands; None: the map's ``actuation.lag``."""
    communication_range: float | None = None
    """Distance (m, >= 0; inf: everywhere, 0: no communication) within which robots
    share their states and plans (:mod:`nao_arena.communication`); None: the map's
    ``communication.range``."""
    communication_latency: float | None = None
    """Time (s, >= 0) a message takes (whole control periods); None: the map's
    ``communication.latency``."""
    communication_loss: float | None = None
    """Probability in [0, 1] that a pair's exchange of a control period is lost; None:
    the map's ``communication.loss``."""
    known_path_horizon: float = 6.0
    """Horizon (s) of the true future paths of traffic handed to agents."""
    known_path_samples: int = 61
    """Time samples of those paths over the horizon."""
    agent: str | None = None
    """If set, replaces every robot's agent (built-in name or plug-in reference); people
    (robots entries of kind "person") keep theirs."""
    agent_options: Mapping[str, Any] = field(default_factory=dict)
    """Keyword options passed to the robots' agents' constructors (not the people's)."""
    stats: StatsConfig = field(default_factory=StatsConfig)
    """Thresholds of the statistics (:class:`~nao_arena.stats.StatsConfig`)."""
    max_faults: int | None = None
    """The episode fails (:class:`~nao_arena.agent.TooManyFaults` from
    :meth:`Arena.step`) once its agents have faulted more than this many times; None:
    never."""

    def __post_init__(self) -> None:
        if self.max_faults is not None and (
            isinstance(self.max_faults, bool)
            or not isinstance(self.max_faults, int)
            or self.max_faults < 0
        ):
            raise ValueError(
                f"max_faults: expected an integer >= 0 or None, got {self.max_faults!r}"
            )


@dataclass(frozen=True)
class StepResult:
    """What one control step produced: time at its end (s), the commanded
    accelerations (N, 2) m/s^2 as the world got them (the robots' after the actuation
    noise and lag), the contacts that started and the agents' faults."""

    time: float
    state: WorldState
    commanded: NDArray[np.float64]
    contacts: list[ContactEvent]
    faults: list[AgentFault]


class StepRecorder(Protocol):
    """Receives an episode as it runs (see :attr:`Arena.recorder`); reads, never writes."""

    def begin(self, arena: Arena, seed: int | None) -> None:
        """The arena was just reset with ``seed``: its state, agents and statistics are fresh."""

    def step(
        self, arena: Arena, sensing: SensingBatch, result: StepResult, actions: Mapping[int, Any]
    ) -> None:
        """One step ended: what the robots sensed before it, its result, the external
        actions (robot index -> acceleration) that replaced agents."""


def make_agent(ref: str | type, robot: RobotSpec, options: Mapping[str, Any] | None = None) -> Any:
    """Instantiate the agent ``ref`` (a reference, or the class it names) for ``robot``.

    The robot's predictor and the map's ``agent_options`` for it are passed
    where the constructor takes them (by name, or all of them to a constructor with
    ``**kwargs``; and, when the map names the agent they are for, ``agent_options_for``,
    only to that agent); ``options`` (from the caller) are passed as given and take
    precedence.
    """
    cls = load_agent(ref) if isinstance(ref, str) else check_agent_class(ref.__name__, ref)
    params = _constructor_parameters(cls)
    takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    meant = robot.agent_options_for is None or load_agent(robot.agent_options_for) is cls
    kwargs = (
        {k: v for k, v in robot.agent_options.items() if takes_any or k in params} if meant else {}
    )
    if takes_any or "predictor" in params:
        kwargs["predictor"] = robot.predictor
    kwargs.update(options or {})
    return cls(**kwargs)


@functools.cache
def _constructor_parameters(cls: type) -> Mapping[str, inspect.Parameter]:
    """The parameters of an agent class's constructor (none when Python cannot tell);
    looked up once per class (every reset makes every robot's agent)."""
    try:
        return inspect.signature(cls).parameters
    except (TypeError, ValueError):
        return {}


def _non_negative(name: str, value: float) -> float:
    """``value`` (a finite number >= 0) as a float; ValueError naming ``name`` otherwise."""
    if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name}: expected a finite number >= 0, got {value!r}")
    return float(value)


def _end_if_forked(pid: int) -> None:
    """End this process at once if it is not ``pid``: a process an agent forked while
    acting returns from ``act`` here, and the episode is not its to run."""
    if os.getpid() != pid:
        os._exit(0)


class AgentPlan(NamedTuple):
    """Which robots' agents act together (:meth:`Arena._dispatch`): ``classes``, each
    robot's agent class (robot order), the plan's key; ``batched``: per class with an
    ``act_batch``, its robots (robot order); ``single``: the robots that act one by one;
    ``bodies``: per class of ``batched``, its robots' body indices."""

    classes: list[type]
    batched: dict[type[BatchAgent], list[int]]
    single: list[int]
    bodies: dict[type[BatchAgent], NDArray[np.intp]]


class Arena:
    """One map's world, agents, traffic and statistics. Call :meth:`reset` first."""

    def __init__(self, spec: MapSpec, options: ArenaOptions | None = None) -> None:
        self.spec = spec
        self.options = options or ArenaOptions()
        self.world = World(spec)
        self.traffic = LaneTraffic.from_map(spec)
        self.robot_ids = self.world.robot_indices  # body index of robot k (robot order)
        self.robots = list(spec.robots)
        # ArenaOptions.agent replaces the robots' agents, never the people's
        self.agent_names = [
            (self.options.agent if r.kind == "robot" else None) or r.agent for r in self.robots
        ]
        self.agent_labels = list(self.agent_names)
        """What tables, the viewer and logs show for each robot's agent (robot order):
        its name or reference unless a caller gave a label (``--agent LABEL=REF``)."""
        # what agents sense is read-only (see SensingBatch): goals, routes, walls, times
        self._goal_tolerance = float(spec.episode.goal_tolerance)
        self.goals = read_only(np.array([r.goal for r in self.robots], dtype=float).reshape(-1, 2))
        self._goal_test = GoalTest(self.robot_ids, self.goals, self._goal_tolerance)
        self.routes = ReadOnlyRoutes.of(
            [None if r.route is None else np.array(r.route, float) for r in self.robots]
        )
        walls, wall_radius = self.world.wall_segments()
        self.walls, self.wall_radius = read_only(walls), read_only(wall_radius)
        self.path_times = read_only(
            np.linspace(0.0, self.options.known_path_horizon, self.options.known_path_samples)
        )
        self._bodies = read_only(np.array(self.robot_ids, dtype=np.int64))
        self._replayed_rows = np.flatnonzero(self.world.replayed)
        # the bodies no agent of the arena drives (traffic, replayed people): no shared plan
        self._undriven = np.setdiff1d(np.arange(self.world.n), self._bodies)
        self._radii = read_only(self.world.radii)
        self._a_max = read_only(self.world.a_max)
        self._v_max = read_only(self.world.v_max)
        self._robot_a_max = self.world.a_max[self.robot_ids]
        self.sensing_range = (
            spec.sensing.range if self.options.sensing_range is None else self.options.sensing_range
        )
        self.max_neighbours = (
            spec.sensing.max_neighbours
            if self.options.max_neighbours is None
            else self.options.max_neighbours
        )
        self.sensing_latency = _non_negative(
            "sensing_latency",
            spec.sensing.latency
            if self.options.sensing_latency is None
            else self.options.sensing_latency,
        )
        self.actuation_noise = _non_negative(
            "actuation_noise",
            spec.actuation.noise
            if self.options.actuation_noise is None
            else self.options.actuation_noise,
        )
        # the batches of the last latency_steps + 1 control periods: agents act on the oldest
        self._latency_steps = int(round(self.sensing_latency / self.world.dt))
        self._sensed: deque[SensingBatch] = deque(maxlen=self._latency_steps + 1)
        self._noise_rng = np.random.default_rng(0)
        self.imperfections = imperfections(spec, self.options)
        """Sensing noise, dropout and field of view, actuation lag (the map's, or the
        options'; see :mod:`nao_arena.imperfection`)."""
        self._sensing_rng = np.random.default_rng(0)
        self._dropout_rng = np.random.default_rng(0)
        imp = self.imperfections
        self._truth = (
            not self._latency_steps
            and not imp.noisy
            and imp.dropout == 0.0
            and imp.all_around
            and not imp.occlusion
        )
        # the robots' applied accelerations (R, 2) m/s^2 under the actuation lag
        self._applied = np.zeros((len(self.robot_ids), 2))
        # the episode's messages (None: perfect communication)
        self._channel: Channel | None = None
        # this period's sensed batch, with the state it was drawn for (see sensed())
        self._sensed_now: tuple[WorldState, SensingBatch] | None = None
        self.agents: list[Any] = []
        self.stats: EpisodeStats | None = None
        self.state: WorldState | None = None
        self._period_inputs: EpisodePeriod | None = None
        """The compiled period's inputs of this episode
        (:func:`~nao_arena.period.episode_inputs`)."""
        self.commanded = np.zeros((self.world.n, 2))
        self._kinds: NDArray[np.str_] | None = None
        self._plan: AgentPlan | None = None
        self._trajectory = hashlib.sha256()
        self.recorder: StepRecorder | None = None

    @property
    def commanded(self) -> NDArray[np.float64]:
        """The commanded accelerations (N, 2) m/s^2 of the last step, as given to the world
        (zeros after a reset)."""
        return self._commanded

    @commanded.setter
    def commanded(self, value: NDArray[np.float64]) -> None:
        # commands set from outside (an episode log's row) were not stepped: the shared
        # plans of sensing are then clipped from them, not taken from the world
        self._commanded = value
        self._stepped_plans: NDArray[np.float64] | None = None

    def labels_with(self, label: str) -> list[str]:
        """Agent labels (robot order) in which every robot's is ``label`` and every
        person keeps its agent's name (what ``--agent LABEL=REF`` shows)."""
        return [
            label if r.kind == "robot" else name
            for r, name in zip(self.robots, self.agent_names, strict=True)
        ]

    def __getstate__(self) -> dict[str, Any]:
        """The attributes without the trajectory hash (a C object; see __setstate__)."""
        state = self.__dict__.copy()
        del state["_trajectory"]
        state["_period_inputs"] = None  # compiled code's object, made again below
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Restore a copy: what agents sense made read-only again, and the trajectory
        hash recomputed from a replay of the world's commands since its reset (the
        arena hashes the world's state after each reset and step)."""
        self.__dict__.update(state)
        for name in (
            "goals",
            "walls",
            "wall_radius",
            "path_times",
            "_bodies",
            "_radii",
            "_a_max",
            "_v_max",
            "_kinds",
        ):
            if getattr(self, name) is not None:
                setattr(self, name, read_only(getattr(self, name)))
        self.routes = ReadOnlyRoutes(None if r is None else read_only(r) for r in self.routes)
        self._goal_test = GoalTest(self.robot_ids, self.goals, self._goal_tolerance)
        if self.stats is not None:
            self._period_inputs = episode_inputs(self.world, self.stats, self._goal_test)
        # the kept batches, frozen again (a copy's arrays are its own)
        self._sensed = deque(
            (dataclasses.replace(b) for b in self._sensed), maxlen=self._latency_steps + 1
        )
        self._trajectory = hashlib.sha256()
        if self.state is not None:
            replica = World(self.spec)
            self._hash_state(replica.state())
            for accels in self.world.commands:
                self._hash_state(replica.step(accels))

    @staticmethod
    def warm_up() -> None:
        """Load (or, the first time, compile) the kernels of a control period's physics
        and statistics: the first period's, through pymunk's step, and the later ones',
        in one compiled call (:mod:`nao_arena.period`), by stepping an arena of one robot
        twice with external actions (no agent acts), once per process. The episodes of
        this process, and those of the processes forked from it, then start warm."""
        _step_a_small_arena()

    # ------------------------------------------------------------------ episode

    def reset(self, seed: int | None = None) -> WorldState:
        """Fresh world, fresh agents (one seeded generator each), fresh statistics.

        An agent whose constructor or ``reset`` raises (anything but
        KeyboardInterrupt or EpisodeTimeout) raises :class:`~nao_arena.agent.AgentError`
        naming the agent, its robot and the exception."""
        self.state = self.world.reset()
        # one generator per agent, then the actuation noise's, the sensing noise's and the
        # dropout's (each stream is the same whether or not the others draw)
        root = np.random.SeedSequence(seed)
        *seeds, noise_seed, sensing_seed, dropout_seed = root.spawn(len(self.robots) + 3)
        self._noise_rng = np.random.default_rng(noise_seed)
        self._sensing_rng = np.random.default_rng(sensing_seed)
        self._dropout_rng = np.random.default_rng(dropout_seed)
        self._channel = None
        comm = self.imperfections.communication
        if not comm.perfect:
            (comm_seed,) = root.spawn(1)
            key = int(comm_seed.generate_state(1, np.uint64)[0])
            self._channel = Channel(comm, len(self.robot_ids), self.world.dt, key)
        self._applied = np.zeros((len(self.robot_ids), 2))
        self._sensed.clear()
        self._sensed_now = None
        self.agents = []
        for k, (robot, name, ss) in enumerate(
            zip(self.robots, self.agent_names, seeds, strict=True)
        ):
            cls = load_agent(name)
            stage = "constructor"
            try:
                options = self.options.agent_options if robot.kind == "robot" else None
                agent = make_agent(cls, robot, options)
                stage = "reset"
                agent.reset(robot, np.random.default_rng(ss))
            except UNCONTAINED:
                raise
            except BaseException as exc:  # noqa: BLE001 - reported as the episode's error
                who = robot.name or f"robot {k}"
                raise AgentError(
                    f"agent {name!r} of {who}: its {stage} raised {describe(exc)}"
                ) from exc
            self.agents.append(agent)
        self.stats = EpisodeStats(
            self.world.radii,
            self.world.kinds,
            self.world.names,
            walls=(self.walls, self.wall_radius),
            dt=self.world.dt,
            config=self.options.stats,
            velocities=self.state.velocities,
            goals=self._body_goals(),
            replayed=self.world.replayed,
        )
        self._period_inputs = episode_inputs(self.world, self.stats, self._goal_test)
        self.commanded = np.zeros((self.world.n, 2))
        self._trajectory = hashlib.sha256()
        self._hash_state(self.state)
        if self.recorder is not None:
            self.recorder.begin(self, seed)
        return self.state

    def _body_goals(self) -> NDArray[np.float64]:
        """(N, 2) goals (m) by body: the robots' goals, NaN for traffic."""
        goals = np.full((self.world.n, 2), np.nan)
        goals[self.robot_ids] = self.goals
        return goals

    def _hash_state(self, state: WorldState) -> None:
        """Add a state's positions (m) and velocities (m/s), body order, float64 bytes
        to the trajectory hash."""
        self._trajectory.update(np.ascontiguousarray(state.positions, np.float64).data)
        self._trajectory.update(np.ascontiguousarray(state.velocities, np.float64).data)

    @property
    def time(self) -> float:
        return self.world.time

    @property
    def reached(self) -> NDArray[np.bool_]:
        """(R,) robots within the goal tolerance of their goals now."""
        assert self.state is not None
        out = np.empty(len(self.robot_ids), dtype=np.bool_)
        within_goal(
            self.state.positions, self.robot_ids, self.goals, self._goal_tolerance, out, False
        )
        return out

    @property
    def done(self) -> bool:
        """The time limit is reached, or every robot is at its goal (within the goal
        tolerance) at the same time: robots that arrived early must have stayed, or
        come back."""
        if self.time >= self.spec.episode.time_limit - 1e-9:
            return True
        assert self.stats is not None, "call reset() first"
        return bool(len(self.robots)) and bool(self.stats.at_goal[self.robot_ids].all())

    # ------------------------------------------------------------------ sensing

    def _known_paths(self, state: WorldState) -> NDArray[np.float64]:
        """(N, T, 2) true future centres of traffic and of recorded people (NaN for the
        bodies agents drive, and for recorded people out of the scene)."""
        out = np.full((self.world.n, len(self.path_times), 2), np.nan)
        idx = self.traffic.indices
        if len(idx):
            out[idx] = self.traffic.future_paths(state.positions, self.path_times)
        if self._replayed_rows.size:
            out[self._replayed_rows] = self.spec.recorded_paths(
                int(round(state.time / self.world.dt)), self.path_times
            )
        return out

    def sensing(self) -> SensingBatch:
        """Every robot's view of the current state as bulk arrays (see
        :class:`~nao_arena.sensing.SensingBatch`); :meth:`observations` unpacks it. Its
        neighbour lists honour the field of view; the dropout and the sensing noise (random)
        are added by :meth:`step` only."""
        state = self.state
        assert state is not None
        known = (
            self._known_paths(state)
            if len(self.traffic.indices) or self._replayed_rows.size
            else None
        )
        # the accelerations the world applied (scaled to |a| <= a_max), not the raw commands:
        # handed over by the world after a step, NaN for the bodies agents do not drive
        if self._stepped_plans is not None:
            plans = self._stepped_plans
            if len(self._undriven):
                plans = plans.copy()
                plans[self._undriven] = np.nan
        else:
            plans = applied_plans(self.commanded, self._bodies, self._robot_a_max, self.world.n)
        if self._kinds is None:
            # frozen once (see read_only): every step's batch shares this one array, so
            # agents may cache what they derive from it by its identity
            self._kinds = read_only(np.array(self.world.kinds))
        start, index = self._neighbour_lists(state)
        return SensingBatch(
            time=state.time,
            dt=self.world.dt,
            positions=state.positions,
            velocities=state.velocities,
            accelerations=state.accelerations,
            radii=self._radii,
            a_max=self._a_max,
            v_max=self._v_max,
            kinds=self._kinds,
            plans=plans,
            known_paths=known,
            path_times=self.path_times,
            bodies=self._bodies,
            goals=self.goals,
            routes=self.routes,
            walls=self.walls,
            wall_radius=self.wall_radius,
            nb_start=start,
            nb_index=index,
            substeps=self.world.substeps,
            actuation_lag=self.imperfections.lag,
            sensing_noise=self.imperfections.noise,
        )

    def _neighbour_lists(self, state: WorldState) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The robots' neighbour lists (CSR, robot order, nearest first): the bodies within
        the sensing range and, with occlusion, visible past the others within it and the
        walls (:func:`~nao_arena.occlusion.visible`), with a field of view narrower than
        2 pi in view of the robot (:func:`~nao_arena.imperfection.in_view`), the nearest
        ``max_neighbours`` of them."""
        imp = self.imperfections
        if imp.all_around and not imp.occlusion:
            return neighbour_lists(
                self.robot_ids,
                state.positions,
                self.sensing_range,
                self.max_neighbours,
            )
        start, index = neighbour_lists(self.robot_ids, state.positions, self.sensing_range)
        rows = self._bodies
        keep = np.ones(len(index), dtype=bool)
        if imp.occlusion:
            keep &= visible(
                start,
                index,
                rows,
                start,
                index,
                state.positions,
                self.world.radii,
                self.walls,
                self.wall_radius,
            )
        if not imp.all_around:
            heading = headings(state.positions[rows], state.velocities[rows], self.goals)
            keep &= in_view(start, index, rows, state.positions, heading, imp.field_of_view)
        return subset(start, index, keep, self.max_neighbours)

    def sensed(self) -> SensingBatch:
        """What the agents sense this control period, through every model of the imperfect
        world (dropout, noise, latency, communication; :meth:`sensing` is the truth). It
        is drawn once per period: :meth:`step` acts on this same batch, so reading it (the
        env's observations do) changes nothing."""
        state = self.state
        assert state is not None, "call reset() first"
        if self._sensed_now is None or self._sensed_now[0] is not state:
            batch = self._communicated(self._as_sensed(self._imperfect(self.sensing())))
            self._sensed_now = (state, batch)
        return self._sensed_now[1]

    @property
    def senses_the_truth(self) -> bool:
        """Whether the robots sense the exact current state of every body within range:
        no sensing noise, dropout, latency, occlusion or narrow field of view."""
        return self._truth

    def observations(self) -> list[Observation]:
        """One observation per robot (robot order), for the current state."""
        batch = self.sensing()
        return [batch.observation(k) for k in range(len(self.robot_ids))]

    # ------------------------------------------------------------------ step

    def step(self, actions: Mapping[int, ArrayLike] | None = None) -> StepResult:
        """One control period. ``actions`` maps robot index (robot order, 0 <= k < number
        of robots; else ValueError) to an acceleration (2,) m/s^2 that replaces that
        robot's agent this step."""
        actions = actions or {}
        robots = np.zeros(len(actions), dtype=np.intp)
        accelerations = np.zeros((len(actions), 2))
        for i, (k, acc) in enumerate(actions.items()):
            if not 0 <= k < len(self.robot_ids):
                raise ValueError(
                    f"actions: robot index {k} is not one of the "
                    f"{len(self.robot_ids)} robots (0 .. {len(self.robot_ids) - 1})"
                )
            robots[i] = k
            accelerations[i] = acc
        return self._step(robots, accelerations, actions)

    def step_robots(
        self, robots: NDArray[np.intp], accelerations: NDArray[np.float64]
    ) -> StepResult:
        """:meth:`step` with the replacing accelerations as arrays: robot indices (m,)
        (robot order, distinct, each 0 <= k < number of robots) and accelerations
        (m, 2) m/s^2, world frame."""
        robots = np.asarray(robots, dtype=np.intp)
        if robots.ndim != 1:
            raise ValueError(f"robots: expected a 1-d array of indices, got shape {robots.shape}")
        if robots.size and not (0 <= robots.min() and robots.max() < len(self.robot_ids)):
            raise ValueError(
                f"robots: expected robot indices 0 .. {len(self.robot_ids) - 1}, "
                f"got {robots.tolist()}"
            )
        accelerations = np.asarray(accelerations, dtype=np.float64)
        if accelerations.shape != (len(robots), 2):
            raise ValueError(
                f"accelerations: expected shape ({len(robots)}, 2), got {accelerations.shape}"
            )
        if len(set(robots.tolist())) != len(robots):
            raise ValueError(f"robots: expected distinct robot indices, got {robots.tolist()}")
        actions = (
            None
            if self.recorder is None
            else dict(zip(robots.tolist(), accelerations, strict=True))
        )
        return self._step(robots, accelerations, actions)

    @property
    def _sensing_draws(self) -> bool:
        """Whether sensing a period draws from the episode's generators or keeps state
        (noise, dropout, latency, communication): then it happens every period, whether
        or not an agent reads it."""
        return not self._truth or self._channel is not None

    def _step(
        self,
        robots: NDArray[np.intp],
        accelerations: NDArray[np.float64],
        actions: Mapping[int, Any] | None,
    ) -> StepResult:
        """:meth:`step` with the replacing accelerations (m, 2) m/s^2 of ``robots`` (m,)
        checked; ``actions``: the same as a mapping, for the recorder."""
        assert self.state is not None and self.stats is not None, "call reset() first"
        state = self.state
        commanded = np.zeros((self.world.n, 2))
        faults: list[AgentFault] = []
        batch = self.sensed() if self._sensing_draws else None
        found: dict[int, AgentFault] = {}
        batched: dict[type[BatchAgent], list[int]] = {}
        single: list[int] = []
        if len(robots) == len(self.robot_ids):
            # every robot replaced (distinct indices): no agent acts
            commanded[self.robot_ids[robots]] = accelerations
        else:
            batched, single = self._dispatch()
        if 0 < len(robots) < len(self.robot_ids):
            commanded[self.robot_ids[robots]] = accelerations
            taken = set(robots.tolist())
            single = [k for k in single if k not in taken]
            batched = {cls: [k for k in rows if k not in taken] for cls, rows in batched.items()}
        if batch is None and (single or any(batched.values()) or self.recorder is not None):
            # the exact state, sensed only when something reads it
            batch = self.sensed()
        pid = os.getpid()
        for k in single:
            assert batch is not None
            acc, fault = safe_act(self.agents[k], batch.observation(k), self.agent_names[k])
            _end_if_forked(pid)
            commanded[self.robot_ids[k]] = acc
            if fault is not None:
                found[k] = fault
        for cls, rows in batched.items():
            if not rows:
                continue
            assert batch is not None
            accs, faults_of = self._act_batch(cls, batch, list(rows))
            _end_if_forked(pid)
            commanded[self._bodies_of(cls, rows)] = accs
            found.update(faults_of)
        for k in sorted(found):
            fault = found[k]
            faults.append(fault)
            self.stats.record_fault(fault.time, int(self.robot_ids[k]), fault.message)
        limit = self.options.max_faults
        if faults and limit is not None and len(self.stats.faults) > limit:
            first = self.stats.faults[0]
            raise TooManyFaults(
                f"{len(self.stats.faults)} agent faults by t = {state.time:.1f} s, more than "
                f"the {limit} allowed (max_faults); the first: robot "
                f"{first.name} at t = {first.time:.1f} s: {first.message}"
            )
        if self.actuation_noise > 0.0:
            commanded[self.robot_ids] += self._noise_rng.normal(
                0.0, self.actuation_noise, (len(self.robot_ids), 2)
            )
        if self.imperfections.lag > 0.0:
            factor = lag_factor(self.world.dt, self.imperfections.lag)
            commanded[self.robot_ids] = lag_step(self._applied, commanded[self.robot_ids], factor)
        idx = self.traffic.indices
        if len(idx):
            commanded[idx] = self.traffic.accelerations(state.positions, state.velocities)
        new_state, contacts = self._period(state, commanded)
        self.commanded = commanded
        self._stepped_plans = self.world.applied_accelerations
        self.state = new_state
        self._hash_state(new_state)
        result = StepResult(new_state.time, new_state, commanded, contacts, faults)
        if self.recorder is not None:
            assert batch is not None and actions is not None
            self.recorder.step(self, batch, result, actions)
        return result

    def _period(
        self, state: WorldState, commanded: NDArray[np.float64]
    ) -> tuple[WorldState, list[ContactEvent]]:
        """The world's control period from ``state`` with the commanded accelerations
        (N, 2) m/s^2, the goal test and the statistics' step: in one compiled call
        (:func:`~nao_arena.period.run_period`) where it applies, else one by one. Returns
        the new state and the contacts that started."""
        stats = self.stats
        assert stats is not None
        done = run_period(self.world, stats, self._period_inputs, commanded)
        if done is not None:
            return done
        new_state = self.world.step(commanded)
        reached = np.zeros(self.world.n, dtype=bool)
        within_goal(
            new_state.positions, self.robot_ids, self.goals, self._goal_tolerance, reached, True
        )
        contacts = stats.update(
            state.time,
            state.positions,
            new_state.positions,
            new_state.velocities,
            commanded,
            reached,
            substeps=self.world.substep_positions,
        )
        return new_state, contacts

    def adopt_periods(
        self, commands: NDArray[np.float64], states: NDArray[np.float64], last: PeriodArrays
    ) -> WorldState:
        """Take control periods that ran in a batch (:mod:`nao_arena.vector_step`: every
        robot replaced, a plain world): their commands (P, N, 2) m/s^2, the bodies'
        positions and velocities after each, ``states`` (P, 2, N, 2), and the last one's
        world results. What :meth:`step` keeps of its own in the world and here (the
        statistics take theirs apart); returns the new state."""
        world = self.world
        world.adopt_periods(commands, last)
        self.commanded = commands[-1].copy()  # commands may be a reused buffer
        self._stepped_plans = world.applied_accelerations
        self.state = WorldState(
            world.time,
            last.positions,
            last.velocities,
            last.accelerations,
            world.radii,
            world.names,
            world.kinds,
        )
        self._trajectory.update(np.ascontiguousarray(states).data)  # _hash_state's bytes
        return self.state

    def _imperfect(self, batch: SensingBatch) -> SensingBatch:
        """``batch`` as the robots' sensors deliver it: each neighbour missed with the
        dropout probability, then the sensing noise on what is left (see
        :mod:`nao_arena.imperfection`); ``batch`` itself with neither. It draws from the
        episode's generators: once per step, before the latency (:meth:`_as_sensed`
        delays the imperfect batch)."""
        imp = self.imperfections
        if imp.dropout > 0.0:
            start, index = drop(batch.nb_start, batch.nb_index, imp.dropout, self._dropout_rng)
            batch = dataclasses.replace(batch, nb_start=start, nb_index=index)
        if imp.noisy:
            batch = with_neighbour_noise(batch, imp.noise, self._sensing_rng)
        return batch

    def _communicated(self, batch: SensingBatch) -> SensingBatch:
        """``batch`` with what the robots heard this period (see
        :mod:`nao_arena.communication`): ``batch`` itself under perfect communication;
        otherwise its ``heard`` set, the neighbour lists on rows of their own, and the
        shared plans NaN for every pair of robots not linked now."""
        if self._channel is None:
            return batch
        state = self.state
        assert state is not None
        rows = self.robot_ids
        heard = self._channel.exchange(state.time, state.positions[rows], state.velocities[rows])
        if batch.row_bodies is None:
            batch = with_neighbour_noise(batch, (0.0, 0.0, 0.0), self._sensing_rng)
        plans = batch.plans
        if plans is not None:
            robot_of = np.full(self.world.n, -1, dtype=np.int64)
            robot_of[rows] = np.arange(len(rows))
            observer = np.repeat(np.arange(len(rows)), np.diff(batch.nb_start))
            other = robot_of[batch.body_of(batch.nb_index)]
            unlinked = np.ones(len(other), dtype=bool)
            robot = other >= 0
            unlinked[robot] = ~heard.linked[observer[robot], other[robot]]
            plans = np.array(plans)
            plans[batch.nb_index[unlinked]] = np.nan
        return dataclasses.replace(batch, plans=plans, heard=heard, _everyone=None)

    def _as_sensed(self, batch: SensingBatch) -> SensingBatch:
        """What the agents sense this step: ``batch`` itself, or with a sensing latency the
        batch of ``round(latency / dt)`` steps ago (the oldest kept, at the start), its
        ``latency`` and ``age`` (s) set (see :class:`~nao_arena.sensing.SensingBatch`)."""
        if not self._latency_steps:
            return batch
        self._sensed.append(batch)
        oldest = self._sensed[0]
        return dataclasses.replace(
            oldest,
            latency=self._latency_steps * self.world.dt,
            age=batch.time - oldest.time,
        )

    def _dispatch(self) -> tuple[dict[type[BatchAgent], list[int]], list[int]]:
        """Robots whose agents act together (per class with an ``act_batch``, robot
        order) and the others; worked out again only when the agents change."""
        key = [type(a) for a in self.agents]
        if self._plan is None or self._plan.classes != key:
            batched: dict[type[BatchAgent], list[int]] = {}
            single: list[int] = []
            for k, cls in enumerate(key):
                if callable(getattr(cls, "act_batch", None)):
                    # agents of one class that act on the bulk arrays all at once
                    batched.setdefault(cast("type[BatchAgent]", cls), []).append(k)
                else:
                    single.append(k)
            bodies = {cls: self.robot_ids[rows] for cls, rows in batched.items()}
            self._plan = AgentPlan(key, batched, single, bodies)
        return self._plan.batched, self._plan.single

    def _bodies_of(self, cls: type[BatchAgent], rows: list[int]) -> NDArray[np.intp]:
        """The bodies of the robots ``rows`` (robot order) of class ``cls``: the plan's
        array when they are all of its robots of that class."""
        plan = self._plan
        if plan is not None and plan.batched.get(cls) is rows:
            return plan.bodies[cls]
        return self.robot_ids[rows]

    def _act_batch(
        self, cls: type[BatchAgent], batch: SensingBatch, rows: list[int]
    ) -> tuple[NDArray[np.float64], dict[int, AgentFault]]:
        """:func:`~nao_arena.agent.safe_act_batch` for the agents of ``rows`` (robot order),
        all of class ``cls``."""
        return safe_act_batch(cls, [self.agents[k] for k in rows], batch, rows, self.agent_names)

    def run(self, seed: int | None = None, max_steps: int | None = None) -> EpisodeSummary:
        """Reset, step until done (or max_steps), return the episode's summary."""
        self.reset(seed)
        steps = 0
        while not self.done and (max_steps is None or steps < max_steps):
            self.step()
            steps += 1
        return self.summary()

    def summary(self) -> EpisodeSummary:
        """The episode so far (see :meth:`EpisodeStats.summary`), with its trajectory hash."""
        assert self.stats is not None
        return dataclasses.replace(
            self.stats.summary(), trajectory_hash=self._trajectory.hexdigest()
        )


@functools.cache
def _step_a_small_arena() -> None:
    """:meth:`Arena.warm_up`, done once per process."""
    spec = map_from_dict(
        {
            "name": "warm-up",
            "bounds": {"min": [-1.0, -1.0], "max": [1.0, 1.0]},
            "robots": [{"start": [0.0, 0.0], "goal": [0.5, 0.0]}],
        }
    )
    arena = Arena(spec, ArenaOptions(agent="goal"))
    arena.reset(seed=0)
    for _ in range(2):
        arena.step_robots(np.zeros(1, dtype=np.intp), np.zeros((1, 2)))
