"""A recorded episode as the viewer reads an arena: :class:`ReplayArena` answers what
:class:`~nao_arena.render.viewer.Viewer` reads of a live :class:`~nao_arena.arena.Arena`,
for one row of an :class:`~nao_arena.episode_log.EpisodeLog` at a time (see
:mod:`nao_arena.render.replay`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from nao_arena.agent import PanelAgent
from nao_arena.arena import Arena
from nao_arena.episode_log import STATUSES, EpisodeLog
from nao_arena.maps import MapSpec, RobotSpec
from nao_arena.predictors import get_predictor
from nao_arena.sensing import Observation, SensingBatch
from nao_arena.stats import ContactEvent
from nao_arena.traffic import LaneTraffic
from nao_arena.world import World, WorldState

__all__ = ["ReplayArena", "ReplayStats"]


class ReplayStats:
    """What the viewer reads of the statistics at one row: the contacts reported so far,
    the steps done and which robots have reached their goals."""

    def __init__(self, contacts: list[ContactEvent], n: int) -> None:
        self.all_contacts = contacts
        self.contacts: list[ContactEvent] = []
        self.steps = 0
        self.reached = np.zeros(n, dtype=bool)


class ReplayArena:
    """One logged row at a time, read-only, as the viewer reads a live arena.

    :meth:`seek` chooses the row. With ``decision=True`` the row's state is shown
    with the decision taken there (the command, detour and selection status of
    the next row): what the robots decided from, as ``explain`` shows it.
    """

    def __init__(self, log: EpisodeLog) -> None:
        self.log = log
        scene: Arena = log.scene()
        self.spec: MapSpec = scene.spec
        self.world: World = scene.world
        self.traffic: LaneTraffic = scene.traffic
        self.robots: list[RobotSpec] = scene.robots
        self.robot_ids = scene.robot_ids
        self.goals = scene.goals
        self.agent_names = log.agent_names
        self.agent_labels = [r.label for r in log.robots]
        self.agents: list[Any] = []  # none: the panel reads panel_agent()
        self.stats = ReplayStats(log.contacts, log.n_bodies)
        self.state: WorldState | None = None
        self.commanded = np.zeros((log.n_bodies, 2))
        self.step_index = -1
        self.decision_row = -1
        self._batch: tuple[int, SensingBatch] | None = None
        self._predictors = [
            None if r.predictor is None else get_predictor(r.predictor) for r in log.robots
        ]

    @property
    def time(self) -> float:
        """Time (s) of the row shown."""
        return 0.0 if self.state is None else self.state.time

    def seek(self, step: int, decision: bool = False, steps: int | None = None) -> None:
        """Show row ``step`` (with the decision taken there if ``decision``: needs a next
        row); ``steps``: the step count the statistics report (default: ``step``)."""
        log = self.log
        if not 0 <= step < log.n_steps:
            raise ValueError(f"step: expected 0 <= step < {log.n_steps}, got {step}")
        if decision and step + 1 >= log.n_steps:
            raise ValueError(f"step {step}: the last row has no decision taken there")
        self.step_index = step
        self.decision_row = step + 1 if decision else step
        self.state = log.state(step)
        self.commanded = log.commanded[self.decision_row]
        self.stats.contacts = self.stats.all_contacts[: log.contacts_by(step)]
        self.stats.steps = step if steps is None else steps
        self.stats.reached = log.reached[step]

    def sensing(self) -> SensingBatch:
        """What every robot sensed at the row shown (the live arena's sensing)."""
        if self._batch is None or self._batch[0] != self.step_index:
            self._batch = (self.step_index, self.log.sensing(self.step_index))
        return self._batch[1]

    def observations(self) -> list[Observation]:
        """One observation per robot (robot order), at the row shown."""
        batch = self.sensing()
        return [batch.observation(k) for k in range(len(self.robot_ids))]

    def panel_agent(self, k: int) -> PanelAgent:
        """What the acceleration panel shows of robot k's agent at the row shown."""
        info = self.log.robots[k]
        detour = float(self.log.detour[self.decision_row, k])
        return PanelAgent(
            times=info.times if self._predictors[k] is not None else None,
            predict=self._predictors[k],
            margin=info.margin,
            v_pref=info.v_pref,
            detour=0.0 if detour != detour else detour,
            status=self.log.selection_of(self.decision_row, k),
        )

    @property
    def controlled(self) -> list[int]:
        """Robots that were driven from outside at some step (the viewer colours them)."""
        code = STATUSES.index("external")
        return [int(k) for k in np.flatnonzero(np.any(self.log.status == code, axis=0))]
