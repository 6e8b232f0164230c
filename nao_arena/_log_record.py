"""Recording an episode log while the arena runs: :class:`EpisodeRecorder` (see
:mod:`nao_arena.episode_log`)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena._log_data import EpisodeLog, RobotInfo
from nao_arena._log_schema import _CODE, _SEL_CODE
from nao_arena.arena import Arena, ArenaOptions, StepResult
from nao_arena.motion import limit_norms
from nao_arena.predictors import PREDICTORS
from nao_arena.sensing import SensingBatch
from nao_arena.stats import EpisodeSummary

_MATCH_TOL = 1e-9  # m/s^2: a command this close to the goal-seeking one is "desired"
_UNCLASSIFIED = -2  # a row's status of an agent that reports no decision, until finish()


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
