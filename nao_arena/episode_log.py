"""Episode logs: every control step of one episode, to replay it and explain its contacts.

An :class:`EpisodeRecorder` set as an arena's ``recorder`` (see
:mod:`nao_arena.arena`) takes in the state after the reset and after every
step; :meth:`EpisodeRecorder.finish` gives the :class:`EpisodeLog`,
:func:`write_log` writes it (atomically: a temporary file in the same
folder, then ``os.replace``) and :func:`read_log` reads it back, with the
same arrays bit for bit. Recording only reads the arena: trajectories are
the same with and without it.

File format (version :data:`LOG_VERSION`)
-----------------------------------------
One Parquet file (zstd, page checksums where pyarrow writes them), one row
per body per row of the log, row-major: log row ``step`` = 0 is the state
after the reset, row ``step`` >= 1 the state at the end of control step
``step`` with the decisions applied during that step (taken at the state of
row ``step - 1``). Columns:

``step`` int32, ``time`` float64 (s, the state's time), ``body`` int16 (body
index: robots first, then traffic, map order); ``x``, ``y`` (m), ``vx``,
``vy`` (m/s), ``ax``, ``ay`` (m/s^2, the world's mean acceleration over the
step) float64: the state; ``cmd_x``, ``cmd_y`` float64 (m/s^2): the
acceleration commanded during the step (0 in row 0); ``reached`` bool: the
robot has reached its goal (statistics' flag); robots only (null for
traffic): ``status`` (string, dictionary-encoded, null in row 0): the
decision of the step, one of :data:`STATUSES`; ``selection`` (string): the
status of the agent's last full selection (agents that report one, else
null); ``detour`` float64 (rad): the agent's detour (its goal direction is
turned by it; null for agents without one); ``neighbours`` list<int32>: the
bodies the robot sensed for the decision of the step, nearest first (robots
whose agent predicts its neighbours, e.g. ``nao``; null otherwise and in
row 0).

Statuses: ``desired`` (took its desired, goal-seeking acceleration),
``kept`` (kept its current acceleration), ``repaired`` (repaired a young
adjustment locally), ``adjusted`` (a full selection: the nearest admissible
acceleration), ``infeasible`` (nothing admissible: braked, or postponed the
contact), ``fault`` (the agent failed; zero acceleration), ``external`` (an
action from outside replaced the agent), ``yielded`` (braked: its choice would have
met another robot's stopping plan, :mod:`nao_arena.stopping`). Agents that report their decisions
(``nao``, ``ao``: ``last_decision()``) get all of them; the others get
``desired`` when the command equals the goal-seeking acceleration (within
1e-9 m/s^2), else ``adjusted``.

The neighbours' predictions are not stored: they are a function of the
stored states (and of the previous step's commands, the neighbours' shared
plans) and of the robot's predictor and time grid (both in the metadata);
:meth:`EpisodeLog.decision_inputs` computes them again with the same code
the agent used.

The file's key-value metadata ``nao_arena.episode_log`` is a JSON object:
``format`` ("nao-arena episode log"), ``version``, ``nao_arena`` (the
version that wrote it), ``map`` (the resolved map: every field, parameters
and seed included), ``seed`` (the agents' seed), ``run`` (how the episode
was started: map reference, overrides, time limit, trial cell), ``options``
(the arena's sensing options), ``time_grids`` (the agents' prediction time
grids, s), ``robots`` (per robot: name, body, agent, label, predictor,
times (an index into ``time_grids``), margin (m), v_pref (m/s),
neighbours (whether its neighbours are logged)), ``steps`` (rows),
``contact_steps`` (per contact of the summary, the row that reported it),
``fault_steps``, ``summary`` (the episode's summary, as ``run --json``
writes it). ``nao_arena.episode_log.sha256`` holds the SHA-256 of that JSON
text; the states are checked against the summary's trajectory hash (with
the page checksums, a flipped bit anywhere in a log either is found or
changes nothing that is read). Reading refuses a file whose version is not :data:`LOG_VERSION`, a
truncated or corrupt one, with a one-line :class:`LogError`.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from nao_arena import __version__
from nao_arena.arena import Arena, ArenaOptions, StepResult
from nao_arena.atomic import atomic_write_with
from nao_arena.maps import MapSpec
from nao_arena.motion import limit_norms
from nao_arena.predictors import PREDICTORS, get_predictor
from nao_arena.sensing import Observation, SensingBatch
from nao_arena.stats import ContactEvent, EpisodeSummary
from nao_arena.world import WorldState

__all__ = [
    "LOG_FORMAT",
    "LOG_VERSION",
    "SELECTIONS",
    "STATUSES",
    "DecisionInputs",
    "EpisodeLog",
    "EpisodeRecorder",
    "LogError",
    "RobotInfo",
    "read_log",
    "write_log",
]

LOG_FORMAT = "nao-arena episode log"
LOG_VERSION = 1
META_KEY = b"nao_arena.episode_log"
META_SHA_KEY = b"nao_arena.episode_log.sha256"

STATUSES: tuple[str, ...] = (
    "desired",
    "kept",
    "repaired",
    "adjusted",
    "infeasible",
    "fault",
    "external",
    "yielded",
)
"""Decision statuses, in the order of the codes of :attr:`EpisodeLog.status`."""
SELECTIONS: tuple[str, ...] = ("desired", "adjusted", "infeasible", "yielded")
"""Statuses of a full selection (:attr:`EpisodeLog.selection` codes)."""

_CODE = {s: i for i, s in enumerate(STATUSES)}
_SEL_CODE = {s: i for i, s in enumerate(SELECTIONS)}
_FLOATS = ("x", "y", "vx", "vy", "ax", "ay", "cmd_x", "cmd_y")
_SCHEMA = pa.schema(
    [
        pa.field("step", pa.int32(), nullable=False),
        pa.field("time", pa.float64(), nullable=False),
        pa.field("body", pa.int16(), nullable=False),
        *[pa.field(name, pa.float64(), nullable=False) for name in _FLOATS],
        pa.field("reached", pa.bool_(), nullable=False),
        pa.field("status", pa.dictionary(pa.int8(), pa.string())),
        pa.field("selection", pa.dictionary(pa.int8(), pa.string())),
        pa.field("detour", pa.float64()),
        pa.field("neighbours", pa.list_(pa.int32())),
    ]
)
_MATCH_TOL = 1e-9  # m/s^2: a command this close to the goal-seeking one is "desired"
_UNCLASSIFIED = -2  # a row's status of an agent that reports no decision, until finish()


class LogError(ValueError):
    """An episode log cannot be read: missing, truncated, corrupt, or another format version."""


# --------------------------------------------------------------------------- the log


@dataclass(frozen=True)
class RobotInfo:
    """One robot of a log: its name, body index, agent reference (as the arena names
    it) and label (as tables show it); for agents that predict their neighbours, the
    predictor's name and time grid (s); its safety margin (m) and preferred speed (m/s,
    None: v_max) as the viewer's panel reads them."""

    name: str
    body: int
    agent: str
    label: str
    predictor: str | None = None
    times: NDArray[np.float64] | None = None
    margin: float = 0.0
    v_pref: float | None = None


@dataclass(frozen=True)
class DecisionInputs:
    """What robot ``robot`` decided from at log row ``step`` (its decision applied
    during step ``step``, taken at the state of row ``step - 1``): its observation, the
    neighbours' predicted centres (n, T, 2) m at ``times`` (s, from then) with its own
    predictor (None: the agent predicts nothing)."""

    step: int
    robot: int
    observation: Observation
    times: NDArray[np.float64] | None
    predicted: NDArray[np.float64] | None


@dataclass
class EpisodeLog:
    """One episode, step by step (see the module docstring for what each row holds).

    Arrays (S rows, N bodies, R robots): ``time`` (S,) s; ``positions``,
    ``velocities``, ``accelerations``, ``commanded`` (S, N, 2); ``reached`` (S, N);
    ``status`` (S, R) int8 codes into :data:`STATUSES` (-1: none); ``selection``
    (S, R) codes into :data:`SELECTIONS` (-1: none); ``detour`` (S, R) rad (NaN: the
    agent has none); neighbours as CSR lists over the (row, robot) pairs in row-major
    order (``nb_offsets`` (S R + 1,), ``nb_index``), for the robots with
    ``nb_logged``.
    """

    spec: MapSpec
    seed: int | None
    options: dict[str, Any]
    robots: list[RobotInfo]
    summary: dict[str, Any]
    time: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    commanded: NDArray[np.float64]
    reached: NDArray[np.bool_]
    status: NDArray[np.int8]
    selection: NDArray[np.int8]
    detour: NDArray[np.float64]
    nb_offsets: NDArray[np.int64]
    nb_index: NDArray[np.int32]
    nb_logged: NDArray[np.bool_]
    contact_steps: NDArray[np.int64]
    fault_steps: NDArray[np.int64]
    run: dict[str, Any] = field(default_factory=dict)
    version: int = LOG_VERSION
    written_by: str = __version__
    path: Path | None = None
    _scene: Arena | None = field(default=None, repr=False, compare=False)

    # ------------------------------------------------------------------ sizes

    @property
    def n_steps(self) -> int:
        """Rows of the log (control steps + 1)."""
        return len(self.time)

    @property
    def n_bodies(self) -> int:
        return self.positions.shape[1]

    @property
    def dt(self) -> float:
        """Control period (s)."""
        return float(self.spec.physics.dt)

    @property
    def robot_ids(self) -> NDArray[np.intp]:
        """Body index of each robot (robot order)."""
        return np.array([r.body for r in self.robots], dtype=np.intp)

    @property
    def agent_names(self) -> list[str]:
        return [r.agent for r in self.robots]

    @property
    def names(self) -> list[str]:
        """Body names (body order)."""
        return [b.name for b in self.spec.bodies()]

    # ------------------------------------------------------------------ lookups

    def step_at(self, t: float) -> int:
        """The last row whose time is <= t (s) (row 0 before the start, the last row
        after the end)."""
        return int(
            np.clip(np.searchsorted(self.time, t + 1e-9, side="right") - 1, 0, self.n_steps - 1)
        )

    def status_of(self, step: int, robot: int) -> str | None:
        """Robot ``robot``'s decision status in row ``step`` (None in row 0)."""
        code = int(self.status[step, robot])
        return None if code < 0 else STATUSES[code]

    def selection_of(self, step: int, robot: int) -> str | None:
        """The status of robot ``robot``'s last full selection in row ``step`` (None: none)."""
        code = int(self.selection[step, robot])
        return None if code < 0 else SELECTIONS[code]

    def neighbours(self, step: int, robot: int) -> NDArray[np.int32] | None:
        """Body indices robot ``robot`` sensed for the decision of row ``step``, nearest
        first (None: not logged for this robot, or row 0)."""
        if step <= 0 or not self.nb_logged[robot]:
            return None
        i = step * len(self.robots) + robot
        return self.nb_index[self.nb_offsets[i] : self.nb_offsets[i + 1]]

    @property
    def contacts(self) -> list[ContactEvent]:
        """The episode's contact events (summary order; NaN where the summary has null)."""
        out = []
        for c in self.summary.get("contacts", []):
            fields: dict[str, Any] = {k: (math.nan if v is None else v) for k, v in c.items()}
            out.append(ContactEvent(**fields))
        return out

    def contacts_by(self, step: int) -> int:
        """How many contacts had been reported by the end of row ``step``."""
        return int(np.sum(self.contact_steps <= step))

    # ------------------------------------------------------------------ sensing

    def scene(self) -> Arena:
        """An arena of the logged map and options, never reset (no agents, no physics):
        the static parts (world geometry, traffic lanes, goals) and the sensing code."""
        if self._scene is None:
            o = self.options
            self._scene = Arena(
                self.spec,
                ArenaOptions(
                    sensing_range=o.get("sensing_range"),
                    max_neighbours=o.get("max_neighbours"),
                    known_path_horizon=float(o.get("known_path_horizon", 6.0)),
                    known_path_samples=int(o.get("known_path_samples", 61)),
                ),
            )
        return self._scene

    def state(self, step: int) -> WorldState:
        """The world state of row ``step``."""
        world = self.scene().world
        return WorldState(
            time=float(self.time[step]),
            positions=self.positions[step],
            velocities=self.velocities[step],
            accelerations=self.accelerations[step],
            radii=world.radii,
            names=world.names,
            kinds=world.kinds,
        )

    def sensing(self, step: int) -> SensingBatch:
        """What every robot sensed at the state of row ``step`` (the arena's own sensing:
        the shared plans are the commands of that row)."""
        arena = self.scene()
        arena.state = self.state(step)
        arena.commanded = self.commanded[step]
        return arena.sensing()

    def decision_inputs(self, step: int, robot: int) -> DecisionInputs:
        """The inputs of robot ``robot``'s decision of row ``step`` >= 1 (see
        :class:`DecisionInputs`)."""
        if not 1 <= step < self.n_steps:
            raise ValueError(f"step: expected 1 <= step < {self.n_steps}, got {step}")
        obs = self.sensing(step - 1).observation(robot)
        info = self.robots[robot]
        if info.predictor is None or info.times is None:
            return DecisionInputs(step, robot, obs, None, None)
        times = info.times
        nb = obs.neighbours
        predicted = (
            get_predictor(info.predictor)(times, nb) if len(nb) else np.zeros((0, len(times), 2))
        )
        return DecisionInputs(step, robot, obs, times, predicted)

    def trajectory_hash(self) -> str:
        """SHA-256 (hex) of the positions then velocities of every row, as the arena
        hashes an episode (see :mod:`nao_arena.arena`)."""
        digest = hashlib.sha256()
        # numpy's stubs give ndarray the buffer protocol (__buffer__) on Python >= 3.12 only
        for k in range(self.n_steps):
            digest.update(np.ascontiguousarray(self.positions[k]))  # type: ignore[arg-type]
            digest.update(np.ascontiguousarray(self.velocities[k]))  # type: ignore[arg-type]
        return digest.hexdigest()


# --------------------------------------------------------------------------- recording


def _panel_settings(agent: Any) -> tuple[str | None, NDArray[np.float64] | None]:
    """(predictor name, time grid) of an agent that predicts its neighbours with a
    registered predictor, else (None, None)."""
    times = getattr(agent, "times", None)
    predict = getattr(agent, "predict", None)
    if times is None or predict is None:
        return None, None
    name = getattr(agent, "predictor_name", None)
    if name not in PREDICTORS or PREDICTORS[name] is not predict:
        name = next((n for n, f in PREDICTORS.items() if f is predict), None)
    if name is None:
        return None, None
    return name, np.array(times, dtype=np.float64)


class EpisodeRecorder:
    """Records an episode as the arena runs it (set it as ``arena.recorder``).

    context: how the episode was started (stored as the log's ``run``: map reference,
    overrides, time limit ...); labels: the agents' labels per robot (default: their
    references). :meth:`finish` returns the :class:`EpisodeLog` of what ran so far.
    """

    def __init__(
        self, context: Mapping[str, Any] | None = None, labels: Sequence[str] | None = None
    ) -> None:
        self.context = dict(context or {})
        self.labels = list(labels) if labels is not None else None
        self._arena: Arena | None = None

    def begin(self, arena: Arena, seed: int | None) -> None:
        """Row 0: the state after the reset; the robots' static settings."""
        assert arena.state is not None and arena.stats is not None
        self._arena = arena
        self.seed = seed
        n_robots = len(arena.robots)
        labels = self.labels or arena.agent_labels
        self._info: list[RobotInfo] = []
        self._reporting: list[int] = []  # agents with last_decision()
        self._detours: list[int] = []  # other agents with a detour attribute
        self._plain: list[int] = []  # agents classified by goal seeking
        self._prev: dict[int, tuple[Any, NDArray[np.float64]]] = {}
        for k, (agent, body) in enumerate(zip(arena.agents, arena.robot_ids, strict=True)):
            predictor, times = _panel_settings(agent)
            v_pref = getattr(agent, "v_pref", None)
            self._info.append(
                RobotInfo(
                    name=arena.robots[k].name or f"robot{k}",
                    body=int(body),
                    agent=arena.agent_names[k],
                    label=labels[k] if k < len(labels) else arena.agent_names[k],
                    predictor=predictor,
                    times=times,
                    margin=float(getattr(agent, "margin", 0.0)),
                    v_pref=None if v_pref is None else float(v_pref),
                )
            )
            if callable(getattr(agent, "last_decision", None)):
                self._reporting.append(k)
                sel, cur, _ = agent.last_decision()
                self._prev[k] = (sel, cur)
            else:
                self._plain.append(k)
                if hasattr(agent, "detour"):
                    self._detours.append(k)
        self._nb_robots = np.array([r.predictor is not None for r in self._info], dtype=bool)
        plain = self._plain
        self._cap_pref = np.array(
            [
                math.inf
                if getattr(arena.agents[k], "v_pref", None) is None
                else float(arena.agents[k].v_pref)
                for k in plain
            ]
        )
        self._tau = np.array([float(getattr(arena.agents[k], "time_constant", 0.5)) for k in plain])
        state = arena.state
        self._time = [state.time]
        self._pos = [state.positions]
        self._vel = [state.velocities]
        self._acc = [state.accelerations]
        self._cmd = [np.zeros((arena.world.n, 2))]
        self._reached = [arena.stats.reached.copy()]
        self._n_contacts = [len(arena.stats.contacts)]
        self._n_faults = [len(arena.stats.faults)]
        _, selection, detour = self._decisions(arena, n_robots)
        self._status = [np.full(n_robots, -1, dtype=np.int8)]
        self._selection = [selection]
        self._detour = [detour]
        self._nb: list[tuple[NDArray[np.int64], NDArray[np.int64]] | None] = [None]

    def _decisions(
        self, arena: Arena, n_robots: int
    ) -> tuple[NDArray[np.int8], NDArray[np.int8], NDArray[np.float64]]:
        """(status, selection, detour) per robot of the agents that report decisions
        (status -1 for the others), updating what was seen last."""
        status = np.full(n_robots, -1, dtype=np.int8)
        selection = np.full(n_robots, -1, dtype=np.int8)
        detour = np.full(n_robots, np.nan)
        agents = arena.agents
        for k in self._reporting:
            sel, cur, det = agents[k].last_decision()
            before, was = self._prev[k]
            if sel is not before:
                status[k] = _CODE.get(sel.status, _CODE["adjusted"])
            elif cur[0] != was[0] or cur[1] != was[1]:
                status[k] = _CODE["repaired"]
            else:
                status[k] = _CODE["kept"]
            if sel is not None:
                selection[k] = _SEL_CODE.get(sel.status, -1)
            detour[k] = det
            self._prev[k] = (sel, cur)
        for k in self._detours:
            detour[k] = float(agents[k].detour)
        return status, selection, detour

    def _plain_status(
        self,
        arena: Arena,
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64],
        commanded: NDArray[np.float64],
    ) -> NDArray[np.int8]:
        """desired / adjusted (S - 1, P) for the P agents that report no decision, rows
        1 ..: whether the command equals the goal-seeking acceleration
        (:func:`~nao_arena.agents.goal.goal_seeking_accel` with the agent's v_pref and
        time constant) at the state they decided from (the row before)."""
        rows = np.asarray(self._plain, dtype=np.int64)
        bodies = arena.robot_ids[rows]
        p, v = positions[:-1, bodies], velocities[:-1, bodies]
        a_max, v_max = arena.world.a_max[bodies], arena.world.v_max[bodies]
        to_goal = arena.goals[rows] - p
        dist = np.hypot(to_goal[..., 0], to_goal[..., 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            speed = np.minimum(np.minimum(self._cap_pref, v_max), np.sqrt(a_max * dist))
            v_target = np.where(
                (dist < 1e-9)[..., None], 0.0, to_goal / dist[..., None] * speed[..., None]
            )
        acc = limit_norms((v_target - v) / self._tau[:, None], a_max)
        cmd = commanded[1:, bodies]
        off = np.hypot(cmd[..., 0] - acc[..., 0], cmd[..., 1] - acc[..., 1])
        return np.where(
            off <= _MATCH_TOL * (1.0 + a_max), _CODE["desired"], _CODE["adjusted"]
        ).astype(np.int8)

    def step(
        self, arena: Arena, sensing: SensingBatch, result: StepResult, actions: Mapping[int, Any]
    ) -> None:
        """One row: the state at the step's end, the commands and decisions of the step."""
        state = result.state
        self._time.append(state.time)
        self._pos.append(state.positions)
        self._vel.append(state.velocities)
        self._acc.append(state.accelerations)
        self._cmd.append(result.commanded)
        assert arena.stats is not None
        self._reached.append(arena.stats.reached.copy())
        self._n_contacts.append(len(arena.stats.contacts))
        self._n_faults.append(len(arena.stats.faults))
        status, selection, detour = self._decisions(arena, len(arena.robots))
        status[self._plain] = _UNCLASSIFIED  # see _plain_status, at the end
        for fault in result.faults:
            status[fault.robot] = _CODE["fault"]
        for k in actions:
            status[k] = _CODE["external"]
        self._status.append(status)
        self._selection.append(selection)
        self._detour.append(detour)
        # the neighbours' body indices (the lists point at rows of their own with sensing noise)
        nb = (sensing.nb_start, sensing.body_of(sensing.nb_index))
        self._nb.append(nb if self._nb_robots.any() else None)

    def finish(
        self, arena: Arena | None = None, summary: EpisodeSummary | None = None
    ) -> EpisodeLog:
        """The log of the episode so far, with its summary (``arena.summary()`` unless
        given: the summary of the episode as it is now)."""
        arena = arena or self._arena
        assert arena is not None, "the recorder has not seen a reset"
        summary = summary or arena.summary()
        n_rows, n_robots = len(self._time), len(self._info)
        offsets = np.zeros(n_rows * n_robots + 1, dtype=np.int64)
        parts: list[NDArray[np.int32]] = []
        counts = np.zeros((n_rows, n_robots), dtype=np.int64)
        logged = self._nb_robots
        every = bool(np.all(logged))
        for s, nb in enumerate(self._nb):
            if nb is None:
                continue
            start, index = nb
            per_robot = np.diff(start)
            counts[s] = np.where(logged, per_robot, 0)
            if every:
                parts.append(index[start[0] : start[-1]].astype(np.int32))
            else:
                parts.append(
                    index[start[0] : start[-1]][np.repeat(logged, per_robot)].astype(np.int32)
                )
        np.cumsum(counts.ravel(), out=offsets[1:])
        positions, velocities = np.stack(self._pos), np.stack(self._vel)
        commanded, status = np.stack(self._cmd), np.stack(self._status)
        if self._plain and n_rows > 1:
            plain = status[1:, self._plain]
            todo = plain == _UNCLASSIFIED
            plain[todo] = self._plain_status(arena, positions, velocities, commanded)[todo]
            status[1:, self._plain] = plain
        return EpisodeLog(
            spec=arena.spec,
            seed=self.seed,
            options=_options_dict(arena.options),
            robots=list(self._info),
            summary=summary.to_dict(),
            time=np.array(self._time, dtype=np.float64),
            positions=positions,
            velocities=velocities,
            accelerations=np.stack(self._acc),
            commanded=commanded,
            reached=np.stack(self._reached),
            status=status,
            selection=np.stack(self._selection),
            detour=np.stack(self._detour),
            nb_offsets=offsets,
            nb_index=np.concatenate(parts) if parts else np.zeros(0, dtype=np.int32),
            nb_logged=logged.copy(),
            contact_steps=_steps_of(self._n_contacts),
            fault_steps=_steps_of(self._n_faults),
            run=dict(self.context),
        )


def _steps_of(counts: Sequence[int]) -> NDArray[np.int64]:
    """Per event (in the order the statistics list them), the row that reported it,
    from the running counts per row."""
    c = np.asarray(counts, dtype=np.int64)
    return np.repeat(np.arange(len(c), dtype=np.int64), np.diff(np.concatenate([[0], c])))


def _jsonable(value: Any) -> Any:
    try:
        json.dumps(value)
    except (TypeError, ValueError):
        return repr(value)
    return value


def _options_dict(options: ArenaOptions) -> dict[str, Any]:
    return {
        "sensing_range": options.sensing_range,
        "max_neighbours": options.max_neighbours,
        "known_path_horizon": options.known_path_horizon,
        "known_path_samples": options.known_path_samples,
        "agent": options.agent,
        "agent_options": {k: _jsonable(v) for k, v in options.agent_options.items()},
    }


# --------------------------------------------------------------------------- writing


def _checksum_options() -> tuple[dict[str, bool], dict[str, bool]]:
    """(write, read) keyword arguments for Parquet page checksums, where pyarrow has them."""
    write = "write_page_checksum" in inspect.signature(pq.write_table).parameters
    read = "page_checksum_verification" in inspect.signature(pq.ParquetFile).parameters
    return (
        {"write_page_checksum": True} if write else {},
        {"page_checksum_verification": True} if read else {},
    )


def _metadata(log: EpisodeLog) -> dict[str, Any]:
    grids: list[list[float]] = []
    for r in log.robots:
        if r.times is not None and r.times.tolist() not in grids:
            grids.append(r.times.tolist())
    return {
        "format": LOG_FORMAT,
        "version": LOG_VERSION,
        "nao_arena": log.written_by,
        "map": log.spec.model_dump(mode="json"),
        "seed": log.seed,
        "run": log.run,
        "options": log.options,
        "time_grids": grids,
        "robots": [
            {
                "name": r.name,
                "body": r.body,
                "agent": r.agent,
                "label": r.label,
                "predictor": r.predictor,
                "times": None if r.times is None else grids.index(r.times.tolist()),
                "margin": r.margin,
                "v_pref": r.v_pref,
                "neighbours": bool(logged),
            }
            for r, logged in zip(log.robots, log.nb_logged, strict=True)
        ],
        "steps": log.n_steps,
        "contact_steps": log.contact_steps.tolist(),
        "fault_steps": log.fault_steps.tolist(),
        "summary": log.summary,
    }


def _dictionary(
    codes: NDArray[np.int8], mask: NDArray[np.bool_], names: Sequence[str]
) -> pa.DictionaryArray:
    indices = pa.array(np.where(mask, 0, codes).astype(np.int8), mask=mask)
    return pa.DictionaryArray.from_arrays(indices, pa.array(list(names), pa.string()))


def to_table(log: EpisodeLog) -> pa.Table:
    """The log's rows as an Arrow table (the file's columns, without its metadata)."""
    n_rows, n, n_robots = log.n_steps, log.n_bodies, len(log.robots)
    robot_of = np.full(n, -1, dtype=np.int64)
    robot_of[log.robot_ids] = np.arange(n_robots)
    is_robot = robot_of >= 0
    # per (row, body): the robot columns spread over the bodies (traffic: masked)
    take = np.where(is_robot, robot_of, 0)
    status = log.status[:, take]
    selection = log.selection[:, take]
    detour = log.detour[:, take]
    traffic = np.broadcast_to(~is_robot, (n_rows, n))
    columns: dict[str, Any] = {
        "step": pa.array(np.repeat(np.arange(n_rows, dtype=np.int32), n)),
        "time": pa.array(np.repeat(log.time, n)),
        "body": pa.array(np.tile(np.arange(n, dtype=np.int16), n_rows)),
    }
    for name, arr, j in (
        ("x", log.positions, 0),
        ("y", log.positions, 1),
        ("vx", log.velocities, 0),
        ("vy", log.velocities, 1),
        ("ax", log.accelerations, 0),
        ("ay", log.accelerations, 1),
        ("cmd_x", log.commanded, 0),
        ("cmd_y", log.commanded, 1),
    ):
        columns[name] = pa.array(np.ascontiguousarray(arr[:, :, j]).ravel())
    columns["reached"] = pa.array(log.reached.ravel())
    columns["status"] = _dictionary(status.ravel(), (traffic | (status < 0)).ravel(), STATUSES)
    columns["selection"] = _dictionary(
        selection.ravel(), (traffic | (selection < 0)).ravel(), SELECTIONS
    )
    columns["detour"] = pa.array(detour.ravel(), mask=(traffic | np.isnan(detour)).ravel())
    # neighbours: the robots' CSR lists spread over the bodies
    counts = np.diff(log.nb_offsets).reshape(n_rows, n_robots)
    has = np.zeros((n_rows, n), dtype=bool)
    has[1:, log.robot_ids] = log.nb_logged[None, :]
    body_counts = np.where(is_robot[None, :], counts[:, take], 0) * has
    offsets = np.zeros(n_rows * n + 1, dtype=np.int32)
    np.cumsum(body_counts.ravel(), out=offsets[1:])
    columns["neighbours"] = pa.ListArray.from_arrays(
        pa.array(offsets),
        pa.array(log.nb_index.astype(np.int32), pa.int32()),
        mask=pa.array(~has.ravel()),
    )
    return pa.Table.from_pydict(columns, schema=_SCHEMA)


def write_log(log: EpisodeLog, path: str | Path) -> Path:
    """Write the log to ``path`` (Parquet, see the module docstring) atomically; returns
    the path."""
    path = Path(path)
    meta = json.dumps(_metadata(log), separators=(",", ":"), allow_nan=False)
    kv = {
        META_KEY: meta.encode("utf-8"),
        META_SHA_KEY: hashlib.sha256(meta.encode("utf-8")).hexdigest().encode("ascii"),
    }
    table = to_table(log)
    # the file's own key-value pairs; where pyarrow cannot add them, the schema's (which
    # pyarrow then also keeps in its serialized schema)
    own_kv = hasattr(pq.ParquetWriter, "add_key_value_metadata")
    if not own_kv:
        table = table.replace_schema_metadata(kv)
    write_checks, _ = _checksum_options()

    def write(tmp: str) -> None:
        # plain float64 pages compress better with zstd here than byte-stream-split ones
        with pq.ParquetWriter(
            tmp,
            table.schema,
            compression="zstd",
            compression_level=3,
            use_dictionary=["step", "time", "status", "selection", "neighbours"],
            write_statistics=False,
            **write_checks,
        ) as writer:
            writer.write_table(table, row_group_size=max(table.num_rows, 1))
            if own_kv:
                writer.add_key_value_metadata(kv)

    atomic_write_with(path, write, suffix=".tmp.parquet")
    return path


# --------------------------------------------------------------------------- reading


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def _codes(column: pa.ChunkedArray, names: Sequence[str], where: str) -> NDArray[np.int8]:
    """Codes (int8, -1 for null) of a dictionary column of strings."""
    arr = column.combine_chunks()
    if isinstance(arr, pa.DictionaryArray):
        values = arr.dictionary.to_pylist()
        indices = arr.indices.fill_null(0).to_numpy(zero_copy_only=False).astype(np.int64)
        valid = arr.is_valid().to_numpy(zero_copy_only=False)
    else:
        values = sorted({v for v in arr.to_pylist() if v is not None})
        lookup = {v: i for i, v in enumerate(values)}
        indices = np.array([lookup.get(v, 0) for v in arr.to_pylist()], dtype=np.int64)
        valid = arr.is_valid().to_numpy(zero_copy_only=False)
    unknown = [v for v in values if v not in names]
    if unknown:
        raise LogError(f"{where}: unknown value {unknown[0]!r}; expected one of {', '.join(names)}")
    lut = np.array([names.index(v) for v in values] or [0], dtype=np.int8)
    return np.where(valid, lut[indices] if len(values) else 0, -1).astype(np.int8)


def read_log(path: str | Path) -> EpisodeLog:
    """Read an episode log (see the module docstring). Raises :class:`LogError` with a
    one-line message naming the file for a missing, truncated or corrupt file, a
    Parquet file that is not an episode log, or another format version."""
    path = Path(path)
    if not path.is_file():
        raise LogError(f"{path}: no such file (expected an episode log written with --log)")
    _, read_checks = _checksum_options()
    try:
        pf = pq.ParquetFile(path, **read_checks)
        kv = pf.metadata.metadata or {}  # the file's own key-value pairs
    except Exception as exc:  # noqa: BLE001 - pyarrow raises several types for a bad file
        raise LogError(
            f"{path}: not a complete episode log (truncated, or not a Parquet "
            f"file: {_first_line(exc)})"
        ) from None
    if META_KEY not in kv:
        raise LogError(
            f"{path}: not an episode log (a Parquet file without the "
            f"{META_KEY.decode()} metadata; expected a file written with --log)"
        )
    raw = kv[META_KEY]
    if kv.get(META_SHA_KEY, b"").decode("ascii", "replace") != hashlib.sha256(raw).hexdigest():
        raise LogError(f"{path}: corrupt episode log (its metadata do not match their checksum)")
    try:
        meta = json.loads(raw.decode("utf-8"))
        if not isinstance(meta, dict):
            raise ValueError("not a JSON object")
    except ValueError as exc:
        raise LogError(f"{path}: corrupt episode log (metadata: {_first_line(exc)})") from None
    if meta.get("format") != LOG_FORMAT:
        raise LogError(
            f"{path}: not an episode log (format {meta.get('format')!r}, expected {LOG_FORMAT!r})"
        )
    version = meta.get("version")
    if version != LOG_VERSION:
        raise LogError(
            f"{path}: episode log format version {version!r} (written by "
            f"nao-arena {meta.get('nao_arena', '?')}); this nao-arena "
            f"({__version__}) reads version {LOG_VERSION}"
        )
    try:
        table = pf.read()
    except Exception as exc:  # noqa: BLE001
        raise LogError(f"{path}: corrupt episode log ({_first_line(exc)})") from None
    try:
        return _from_table(path, table, meta)
    except LogError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise LogError(
            f"{path}: corrupt episode log ({type(exc).__name__}: {_first_line(exc)})"
        ) from None


def _from_table(path: Path, table: pa.Table, meta: dict[str, Any]) -> EpisodeLog:
    missing = [f.name for f in _SCHEMA if f.name not in table.column_names]
    if missing:
        raise LogError(f"{path}: corrupt episode log (missing column {missing[0]!r})")
    from pydantic import ValidationError

    try:
        spec = MapSpec.model_validate(meta["map"])
    except ValidationError as exc:
        raise LogError(
            f"{path}: corrupt episode log (its map does not validate: {_first_line(exc)})"
        ) from None
    n = len(spec.bodies())
    n_rows = int(meta["steps"])
    if table.num_rows != n_rows * n:
        raise LogError(
            f"{path}: corrupt episode log ({table.num_rows} rows, expected "
            f"{n_rows} steps x {n} bodies = {n_rows * n})"
        )

    def col(name: str) -> NDArray[Any]:
        return table.column(name).to_numpy()

    if not (
        np.array_equal(col("step"), np.repeat(np.arange(n_rows), n))
        and np.array_equal(col("body"), np.tile(np.arange(n), n_rows))
    ):
        raise LogError(f"{path}: corrupt episode log (rows out of step/body order)")

    def pair(a: str, b: str) -> NDArray[np.float64]:
        return np.stack([col(a), col(b)], axis=-1).reshape(n_rows, n, 2)

    robots = []
    grids = [np.array(g, dtype=np.float64) for g in meta.get("time_grids", [])]
    for r in meta["robots"]:
        robots.append(
            RobotInfo(
                name=str(r["name"]),
                body=int(r["body"]),
                agent=str(r["agent"]),
                label=str(r["label"]),
                predictor=r.get("predictor"),
                times=None if r.get("times") is None else grids[int(r["times"])],
                margin=float(r.get("margin", 0.0)),
                v_pref=None if r.get("v_pref") is None else float(r["v_pref"]),
            )
        )
    if [r.body for r in robots] != list(range(spec.n_robots)):
        raise LogError(
            f"{path}: corrupt episode log (its robot list names bodies "
            f"{[r.body for r in robots]}, expected the map's {spec.n_robots} "
            f"robots, bodies 0 .. {spec.n_robots - 1})"
        )
    if len(meta["summary"].get("robots", [])) != spec.n_robots:
        raise LogError(
            f"{path}: corrupt episode log (its summary has "
            f"{len(meta['summary'].get('robots', []))} robots, expected the map's "
            f"{spec.n_robots})"
        )
    ids = np.array([r.body for r in robots], dtype=np.intp)
    n_robots = len(robots)
    status = _codes(table.column("status"), STATUSES, f"{path}: column status")
    selection = _codes(table.column("selection"), SELECTIONS, f"{path}: column selection")
    detour_col = table.column("detour").combine_chunks()
    detour = detour_col.fill_null(np.nan).to_numpy(zero_copy_only=False)
    nb_col = table.column("neighbours").combine_chunks()
    offsets_b = nb_col.offsets.to_numpy().astype(np.int64)
    values = nb_col.values.to_numpy(zero_copy_only=False).astype(np.int32)
    # the robots' lists (row-major over (row, robot)), from the lists per (row, body)
    starts = offsets_b[:-1].reshape(n_rows, n)[:, ids]
    ends = offsets_b[1:].reshape(n_rows, n)[:, ids]
    counts = (ends - starts).ravel()
    offsets = np.zeros(n_rows * n_robots + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    gather = np.repeat(starts.ravel() - offsets[:-1], counts) + np.arange(
        offsets[-1], dtype=np.int64
    )
    log = EpisodeLog(
        spec=spec,
        seed=meta.get("seed"),
        options=dict(meta.get("options") or {}),
        robots=robots,
        summary=meta["summary"],
        time=np.ascontiguousarray(col("time").reshape(n_rows, n)[:, 0]),
        positions=pair("x", "y"),
        velocities=pair("vx", "vy"),
        accelerations=pair("ax", "ay"),
        commanded=pair("cmd_x", "cmd_y"),
        reached=col("reached").reshape(n_rows, n).copy(),
        status=status.reshape(n_rows, n)[:, ids].copy(),
        selection=selection.reshape(n_rows, n)[:, ids].copy(),
        detour=detour.reshape(n_rows, n)[:, ids].copy(),
        nb_offsets=offsets,
        nb_index=values[gather] if len(gather) else values[:0],
        nb_logged=np.array([bool(r.get("neighbours")) for r in meta["robots"]], dtype=bool),
        contact_steps=np.array(meta.get("contact_steps", []), dtype=np.int64),
        fault_steps=np.array(meta.get("fault_steps", []), dtype=np.int64),
        run=dict(meta.get("run") or {}),
        version=int(meta["version"]),
        written_by=str(meta.get("nao_arena", "?")),
        path=path,
    )
    if len(log.contact_steps) != len(log.summary.get("contacts", [])):
        raise LogError(
            f"{path}: corrupt episode log (contact_steps and the summary's "
            "contacts differ in number)"
        )
    expected = log.summary.get("trajectory_hash") or ""
    if expected and log.trajectory_hash() != expected:
        raise LogError(
            f"{path}: corrupt episode log (its states do not match the episode's trajectory hash)"
        )
    return log
