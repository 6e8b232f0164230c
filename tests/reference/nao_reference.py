"""Reference for the ``nao`` agent's bookkeeping, one robot at a time: what the compiled
calls of :mod:`nao_arena.agents._nao_decide` and :mod:`nao_arena.agents._nao_columns`
do for many robots, as the agent once did it robot by robot, for the tests that check
them bit for bit."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from nao_arena.agents._nao_columns import CUR_X, CUR_Y, detour_row
from nao_arena.agents._nao_decide import ADJUSTED, DESIRED, INFEASIBLE, REPAIRED
from nao_arena.agents._nao_per_robot import brakes_when_infeasible
from nao_arena.agents.nao import NAOAgent
from nao_arena.geometry import AccelLimits
from nao_arena.motion import braking


def take_decision(
    ag: NAOAgent,
    decided: tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]],
    j: int,
    velocity: NDArray[np.float64],
    a_max: float,
    dt: float,
    traffic: bool,
) -> NDArray[np.float64] | None:
    """Member j's outcome (kind, accel m/s^2, tested) of
    :func:`~nao_arena.agents._nao_decide.decide` applied to its agent (what
    ``apply_decisions`` and ``apply_braking`` do for many): the acceleration (m/s^2), or
    None when it is left to the per-robot path (undecided, or no admissible acceleration
    and no braking). velocity (m/s), a_max (m/s^2), dt (s); traffic: whether traffic is
    among the robot's neighbours."""
    kind, accel, tested = decided
    kd = int(kind[j])
    cols, r = ag._cols, ag._row
    if kd == REPAIRED:
        cols.real[r, CUR_X : CUR_Y + 1] = accel[j]
        return accel[j].copy()
    if kd == DESIRED or kd == ADJUSTED:
        cols.commit(r, accel[j], kd, int(tested[j]))
        return accel[j].copy()
    if kd == INFEASIBLE and brakes_when_infeasible(ag, traffic):
        brake = np.array(braking(float(velocity[0]), float(velocity[1]), a_max, dt))
        chosen = AccelLimits(a_max).project(brake)
        cols.commit(r, chosen, INFEASIBLE, int(tested[j]))
        return np.array(chosen, dtype=np.float64)
    return None


def detour_step(
    ag: NAOAgent, far: bool, crawling: bool, dt: float, to_goal: float, held: bool = True
) -> None:
    """One step (dt s) of the agent's liveness bookkeeping (the ``nao`` module's
    Liveness) from precomputed tests: far from the goal, crawling (below v_max / 4), the
    distance to the goal (m), and held (its nearest neighbour stands still close by:
    only such time counts toward switching sides); ``detour_row`` on the agent's row,
    then the turn's angle drawn from the agent's generator."""
    cols = ag._cols
    if detour_row(
        ag._row,
        bool(far),
        bool(crawling),
        float(dt),
        float(to_goal),
        bool(held),
        cols.real,
        cols.whole,
        cols.opt,
    ):
        ag._turn_detour()
