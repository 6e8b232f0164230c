"""Latency compensation of the ``nao`` agents: what they sensed ``age`` s ago, brought to now.

With a sensing latency (:mod:`nao_arena.imperfection`), a batch reaches the agents
``batch.age`` s after it was sensed (whole control periods). A robot knows what it
commanded since, so it brings what it knows up to now before it acts:

- its own state and that of every robot of its group (the robots acting together in
  :meth:`~nao_arena.agents.nao.NAOAgent.act_batch`, which share their plans): the sensed
  position and velocity driven through the commands issued since, period by period, by
  the world's own model (the command scaled to ``|a| <= a_max``, the speed limit and its
  saturation time, the physics substeps: :mod:`nao_arena.world`). Without actuation
  noise, lag or a push from a contact this is the robot's exact state now, so the
  stopping plans (:mod:`nao_arena.stopping`) start from where the robots are;
- everything else it senses (other robots, people, traffic): moved on at its sensed
  velocity for ``age`` s (constant velocity), the velocities kept; known paths are read
  ``age`` s further on.

The batch's ``time`` becomes the current time. With no latency the batch is unchanged.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from nao_arena.motion import clip_accelerations, limit_norms, speed_limit_time
from nao_arena.predictors import resample_paths
from nao_arena.sensing import SensingBatch

__all__ = ["CommandLog", "compensated", "drive"]

FloatArray = NDArray[np.float64]


class CommandLog:
    """The commands (m/s^2) one robot issued, with the times (s) of the periods they
    drove, the latest ``keep`` of them."""

    def __init__(self, keep: int) -> None:
        self.keep = max(int(keep), 1)
        self.times: list[float] = []
        self.commands: list[FloatArray] = []

    def add(self, time: float, command: FloatArray) -> None:
        """Log ``command`` (2,) as the one for the period starting at ``time``."""
        self.times.append(float(time))
        self.commands.append(np.array(command, dtype=np.float64))
        if len(self.times) > self.keep:
            del self.times[0], self.commands[0]

    def since(self, start: float, periods: int, dt: float) -> FloatArray:
        """(periods, 2): the commands of the ``periods`` periods from ``start`` (s) on,
        oldest first; a period with no logged command counts as 0 (the robot had not
        acted yet)."""
        out = np.zeros((periods, 2))
        for t, a in zip(self.times, self.commands, strict=True):
            k = int(round((t - start) / dt))
            if 0 <= k < periods:
                out[k] = a
        return out


def drive(
    pos: FloatArray,
    vel: FloatArray,
    commands: FloatArray,
    a_max: FloatArray,
    v_max: FloatArray,
    dt: float,
    substeps: int,
) -> tuple[FloatArray, FloatArray]:
    """Positions (n, 2) m and velocities (n, 2) m/s after the periods of ``commands``
    (periods, n, 2) m/s^2 from ``pos`` and ``vel``, as the world drives them: each
    period the start velocity scaled to |v| <= v_max, the command to |a| <= a_max, the
    acceleration applied until the saturation time, each substep the position moved by
    the velocity before the velocity takes its share of the acceleration."""
    p = np.array(pos, dtype=np.float64)
    v = np.array(vel, dtype=np.float64)
    h = dt / substeps
    for command in commands:
        v = limit_norms(v, v_max)
        a = clip_accelerations(command, a_max)
        tau = speed_limit_time(v, a, v_max)
        for j in range(substeps):
            w = np.clip((tau - j * h) / h, 0.0, 1.0)
            p = p + v * h
            v = v + (w * h)[:, None] * a
    return p, limit_norms(v, v_max)


def compensated(
    batch: SensingBatch, rows: NDArray[np.int64], logs: Sequence[CommandLog]
) -> SensingBatch:
    """``batch`` brought up to now (see the module): ``rows`` are the group's robots
    (robot order), ``logs`` their command logs. ``batch`` itself when its age is 0."""
    age = float(batch.age)
    if age <= 0.0:
        return batch
    dt = float(batch.dt)
    periods = int(round(age / dt))
    own = np.asarray(batch.bodies, dtype=np.int64)[rows]
    commands = np.stack([log.since(float(batch.time), periods, dt) for log in logs], axis=1)
    p_own, v_own = drive(
        batch.positions[own],
        batch.velocities[own],
        commands,
        np.asarray(batch.a_max, dtype=np.float64)[own],
        np.asarray(batch.v_max, dtype=np.float64)[own],
        dt,
        int(batch.substeps),
    )
    positions = batch.positions + age * np.nan_to_num(batch.velocities)
    positions[own] = p_own
    velocities = np.array(batch.velocities, dtype=np.float64)
    velocities[own] = v_own
    known = batch.known_paths
    if known is not None:
        times = np.asarray(batch.path_times, dtype=np.float64)
        known = resample_paths(times, np.asarray(known, dtype=np.float64), times + age)
    return dataclasses.replace(
        batch,
        time=float(batch.time) + age,
        positions=positions,
        velocities=velocities,
        known_paths=known,
        age=0.0,
        _everyone=None,
    )
