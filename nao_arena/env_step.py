"""What one env step produces, as arrays (see
:meth:`nao_arena.environment.NaoArenaParallelEnv.step_arrays`)."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.arena import StepResult
from nao_arena.jit import kernel

__all__ = ["StepArrays", "clipped_float32", "period_rewards", "settle_finished"]


class StepArrays(NamedTuple):
    """One control period of an env's agents, one row per agent (``possible_agents``
    order with ``keep_finished``): what :meth:`~nao_arena.environment.NaoArenaParallelEnv.step`
    returns in its dicts."""

    observations: NDArray[np.float32]
    """(agents, D) observation vectors (layout:
    :func:`~nao_arena.env_options.observation_layout`)."""
    rewards: NDArray[np.float64]
    """(agents,) rewards of the period."""
    terminated: NDArray[np.bool_]
    """(agents,) the agent terminated (with ``keep_finished``: the episode ended and it
    had finished)."""
    truncated: NDArray[np.bool_]
    """(agents,) the agent was truncated (time limit)."""
    reached: NDArray[np.bool_]
    """(agents,) the robot has reached its goal (the infos' ``reached``)."""
    collisions: NDArray[np.int64]
    """(agents,) contact events of the robot that began in the period."""
    faults: NDArray[np.int64]
    """(agents,) faults of the robot's agent in the period."""
    finished: NDArray[np.bool_]
    """(agents,) the agent has finished (``keep_finished``; else all False)."""
    time: float
    """Episode time (s) at the end of the period."""


class _Period(NamedTuple):
    """One arena period of an env step, before the step's ending: the live agents'
    rows, the acting ones among them (``rows``), their rewards and terminations, whether
    the time limit is reached, the contact and fault event dicts by body, the arena's
    result."""

    live_rows: NDArray[np.intp]
    rows: NDArray[np.intp]
    reward: NDArray[np.float64]
    terminated: NDArray[np.bool_]
    time_up: bool
    events: dict[int, list[dict[str, Any]]]
    faults: dict[int, list[dict[str, Any]]]
    result: StepResult


@kernel(error_model="numpy")
def period_rewards(
    positions: NDArray[np.float64],
    bodies: NDArray[np.int64],
    rows: NDArray[np.intp],
    commands: NDArray[np.float64],
    goals: NDArray[np.float64],
    a_max: NDArray[np.float64],
    previous: NDArray[np.float64],
    distances: NDArray[np.float64],
    reached: NDArray[np.bool_],
    weights: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    """The rewards (m,) of the acting agents ``rows`` (m,) (robots ``bodies`` (m,)) for a
    period, before the contact term, into ``out``; ``previous`` and ``distances`` (by
    agent row) are updated in place.

    positions (N, 2) m at the period's end; commands (m, 2) m/s^2 as commanded, clipped
    here to |a| <= a_max as the world clips them; goals (agents, 2) m; a_max (agents,)
    m/s^2; previous (agents, 2) m/s^2 the last clipped commands; distances (agents,) m to
    the goals at the period's start; reached (m,) at its end; weights: progress,
    accel_change, step, goal (see :class:`~nao_arena.env_options.RewardWeights`). The
    arithmetic is numpy's over the rows, in the same order (the same bits)."""
    progress, accel_change, step, goal = weights[0], weights[1], weights[2], weights[3]
    for i in range(rows.shape[0]):
        r = rows[i]
        b = bodies[i]
        dist = math.hypot(positions[b, 0] - goals[r, 0], positions[b, 1] - goals[r, 1])
        ax, ay = commands[i, 0], commands[i, 1]
        scale = min(1.0, a_max[r] / max(math.hypot(ax, ay), 1e-300))
        ax, ay = ax * scale, ay * scale
        change = math.hypot(ax - previous[r, 0], ay - previous[r, 1]) / a_max[r]
        previous[r, 0], previous[r, 1] = ax, ay
        reward = progress * (distances[r] - dist) - accel_change * change - step
        out[i] = reward + goal * (1.0 if reached[i] else 0.0)
        distances[r] = dist


@kernel
def clipped_float32(
    values: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64]
) -> NDArray[np.float32]:
    """values (m, D) clipped to [low, high] (D,) per column, as float32: numpy's
    ``np.clip`` then ``astype(np.float32)`` (the same bits: NaN and -0.0 kept)."""
    m, d = values.shape
    out = np.empty((m, d), dtype=np.float32)
    for i in range(m):
        for j in range(d):
            x = values[i, j]
            if x < low[j]:
                x = low[j]
            elif x > high[j]:
                x = high[j]
            out[i, j] = x
    return out


@kernel
def settle_finished(
    alive: NDArray[np.bool_],
    live_rows: NDArray[np.intp],
    terminated: NDArray[np.bool_],
    reward: NDArray[np.float64],
    finished_before: NDArray[np.bool_],
    finished: NDArray[np.bool_],
    rewards: NDArray[np.float64],
) -> tuple[bool, bool, bool]:
    """The agents that finish in a period of an env with ``keep_finished``: ``alive``
    (agents,) is updated; ``terminated`` and ``reward`` are those of the acting agents,
    the live ones (``live_rows``, m) not finished before, in order. Writes per live
    agent whether it had finished before the period, whether it has now, and its reward
    (0 once finished before). Returns whether some agent is still unfinished, whether
    some live agent had finished before, and whether every agent is still unfinished."""
    j = 0
    some_before = False
    for i in range(live_rows.shape[0]):
        r = live_rows[i]
        before = not alive[r]
        finished_before[i] = before
        if before:
            some_before = True
            rewards[i] = 0.0
        else:
            rewards[i] = reward[j]
            if terminated[j]:
                alive[r] = False
            j += 1
        finished[i] = not alive[r]
    some_alive, all_alive = False, True
    for r in range(alive.shape[0]):
        some_alive = some_alive or alive[r]
        all_alive = all_alive and alive[r]
    return some_alive, some_before, all_alive
