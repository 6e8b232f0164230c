"""An episode log in memory: :class:`EpisodeLog`, its robots and the inputs of a logged
decision (see :mod:`nao_arena.episode_log`)."""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena import __version__
from nao_arena._log_schema import LOG_VERSION, SELECTIONS, STATUSES
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import MapSpec
from nao_arena.predictors import get_predictor
from nao_arena.sensing import Observation, SensingBatch
from nao_arena.stats import ContactEvent
from nao_arena.world import WorldState


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
    """One episode, step by step (see :mod:`nao_arena.episode_log` for what each row holds).

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
