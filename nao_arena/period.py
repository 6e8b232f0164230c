"""One control period of a world, its goal test and its statistics in one compiled call.

After the agents have acted, a step of :class:`~nao_arena.arena.Arena` advances the
world one control period, tests which robots are within their goals and updates the
statistics. :func:`control_period` does the three in compiled code, with the kernels
each of them runs on its own:

- the world's period straight in chipmunk (:func:`nao_arena.world.period_into`);
- the goal test (:func:`within_goal`);
- the statistics' step (:func:`nao_arena.stats.kernel.step_kernel`) and liveness
  (:func:`nao_arena.stats.kernel.liveness_kernel`).

The arena's step runs it through :func:`run_period`; the vector env runs it for each
of its copies (:func:`nao_arena.vector_step.step_copies`). Where it does not apply
(pymunk has something of its own to do around a step, recorded people are replayed
or have metrics of their own), the world's :meth:`~nao_arena.world.World.step` and the
statistics' :meth:`~nao_arena.stats.EpisodeStats.update` run the same kernels one by
one: the results are the same bits.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numba.core import types
from numba.experimental import structref
from numpy.typing import NDArray

from nao_arena.jit import kernel
from nao_arena.stats.kernel import StatsArrays, liveness_kernel, step_kernel
from nao_arena.stats.recorder import EpisodeStats, StepOutcome
from nao_arena.stats.records import ContactEvent
from nao_arena.world import (
    PeriodArrays,
    World,
    WorldState,
    _Bodies,
    _Chipmunk,
    period_into,
)

__all__ = [
    "EpisodePeriod",
    "GoalTest",
    "PeriodInputs",
    "control_period",
    "episode_inputs",
    "period_inputs",
    "run_period",
    "within_goal",
]

FloatArray = NDArray[np.float64]


class GoalTest(NamedTuple):
    """Which bodies are robots and where their goals are: the body of each robot
    ``robots`` (R,), their goals (R, 2) m and the tolerance (m) within which a robot is
    at its goal."""

    robots: NDArray[np.intp]
    goals: FloatArray
    tolerance: float


@structref.register
class PeriodInputsType(types.StructRef):
    """numba's type of :class:`PeriodInputs`."""

    def preprocess_fields(self, fields: Any) -> tuple[tuple[str, Any], ...]:
        return tuple((name, types.unliteral(t)) for name, t in fields)


class PeriodInputs(structref.StructRefProxy):
    """What :func:`control_period` reads of a world and its statistics that stays the same
    objects over an episode (:func:`period_inputs`): the world's chipmunk space and
    buffers (``chip``) and its bodies' limits and rows (``bodies``), the goal test
    (:class:`GoalTest`) and the statistics' arrays
    (:class:`~nao_arena.stats.kernel.StatsArrays`). One object rather than their ~45
    arrays: a compiled call takes it without typing and unpacking each array. Its fields
    are read by compiled code only."""

    if TYPE_CHECKING:  # the fields, as compiled code reads them
        chip: _Chipmunk
        bodies: _Bodies
        goal_test: GoalTest
        stats: StatsArrays


structref.define_constructor(
    PeriodInputs, PeriodInputsType, ["chip", "bodies", "goal_test", "stats"]
)
structref.define_boxing(PeriodInputsType, PeriodInputs)


@kernel
def period_inputs(
    chip: _Chipmunk, bodies: _Bodies, goal_test: GoalTest, stats: StatsArrays
) -> PeriodInputs:
    """The :class:`PeriodInputs` of these (the very arrays, not copies)."""
    return PeriodInputs(chip, bodies, goal_test, stats)


@kernel(error_model="numpy")
def within_goal(
    positions: NDArray[np.float64],
    robots: NDArray[np.intp],
    goals: NDArray[np.float64],
    tolerance: float,
    out: NDArray[np.bool_],
    by_body: bool,
) -> None:
    """Whether robot k's centre positions[robots[k]] (m) is within ``tolerance`` (m) of
    goals[k] (m), into out[k] (robot order), or into out[robots[k]] (``by_body``: the
    other bodies' rows untouched); the distance by hypot, as numpy's ``np.hypot`` (the
    same bits)."""
    for k in range(robots.shape[0]):
        b = robots[k]
        dx = positions[b, 0] - goals[k, 0]
        dy = positions[b, 1] - goals[k, 1]
        out[b if by_body else k] = math.hypot(dx, dy) <= tolerance


_NO_EVENTS = np.empty((0, 3), dtype=np.int64)


@kernel(error_model="numpy")
def control_period(
    inputs: PeriodInputs,
    start: FloatArray,
    v_start: FloatArray,
    commanded: FloatArray,
    out: PeriodArrays,
    seen_path: FloatArray,
    t: float,
    steps: int,
    has_prev: bool,
    n_prox: int,
) -> tuple[bool, NDArray[np.int64], FloatArray, int, bool]:
    """One control period [t, t + dt] (s) of a world whose pymunk is idle
    (:meth:`~nao_arena.world.World.direct_period`), the bodies at ``start`` (N, 2) m with
    velocities ``v_start`` (N, 2) m/s, with the commanded accelerations ``commanded``
    (N, 2) m/s^2: the world's period into ``out``
    (:class:`~nao_arena.world.PeriodArrays`; ``seen_path``: its path as the statistics
    read it, a read-only view), the goal test and the statistics' step number ``steps``
    (the arrays of ``inputs`` updated in place; ``has_prev``: whether they have a last
    command, ``n_prox`` open proximity episodes). Returns whether every command was
    finite (else nothing ran), the statistics' event rows (code, a, b) and values, the
    open proximity episodes after the step and whether the robots are deadlocked
    (:func:`~nao_arena.stats.kernel.liveness_kernel`)."""
    bodies = inputs.bodies
    if not period_into(inputs.chip, bodies, commanded, start, v_start, out):
        return False, _NO_EVENTS, np.empty(0), n_prox, False
    pos = out.positions
    at_goal = np.zeros(pos.shape[0], dtype=np.bool_)
    goal_test = inputs.goal_test
    within_goal(pos, goal_test.robots, goal_test.goals, goal_test.tolerance, at_goal, True)
    stats = inputs.stats
    codes, values, n_prox = step_kernel(
        t,
        bodies.dt,
        seen_path,
        out.velocities,
        commanded,
        stats.a_prev,
        has_prev,
        at_goal,
        n_prox,
        stats.episode,
    )
    deadlocked = liveness_kernel(
        bodies.dt,
        seen_path[seen_path.shape[0] - 1],
        stats.goals,
        at_goal,
        stats.is_robot,
        stats.episode.reached,
        stats.goal_dist,
        steps % stats.window,
        stats.stuck_progress,
        stats.at_goal,
        stats.time_away,
        stats.stuck_time,
    )
    return True, codes, values, n_prox, deadlocked


class EpisodePeriod(NamedTuple):
    """An episode's :class:`PeriodInputs` (:func:`episode_inputs`) and the world buffers
    and statistics they were made from: a reset of the world alone, or other statistics,
    leave them behind (:func:`run_period` then does nothing)."""

    inputs: PeriodInputs
    chip: _Chipmunk
    stats: EpisodeStats


def run_period(
    world: World,
    stats: EpisodeStats,
    episode: EpisodePeriod | None,
    commanded: FloatArray,
) -> tuple[WorldState, list[ContactEvent]] | None:
    """One control period of ``world`` with the commanded accelerations (N, 2) m/s^2 and
    the step of its statistics, in one compiled call (:func:`control_period`; their
    inputs: ``episode``, :func:`episode_inputs`): the new state and the contacts that
    started, as :meth:`~nao_arena.world.World.step` and
    :meth:`~nao_arena.stats.EpisodeStats.update` give them; None (nothing done) where it
    does not apply (see the module; ``episode`` None, or made for another world state or
    other statistics). ValueError for a non-finite command."""
    direct = world.direct_period()
    if (
        direct is None
        or episode is None
        or episode.stats is not stats
        or episode.chip is not world.compiled_space()[0]
    ):
        return None
    n = world.n
    period = PeriodArrays(
        np.empty((world.substeps + 1, n, 2)),
        np.empty((n, 2)),
        np.empty((n, 2)),
        np.empty((n, 2)),
        np.empty((n, 2)),
    )
    seen_path = period.path.view()
    seen_path.flags.writeable = False
    t = world.time
    finite, codes, values, n_prox, deadlocked = control_period(
        episode.inputs,
        direct.start,
        direct.v_start,
        commanded,
        period,
        seen_path,
        t,
        stats.steps,
        stats.has_last_command,
        stats.open_proximity_episodes,
    )
    if not finite:
        raise ValueError("expected finite accelerations")
    state = world.adopt_period(commanded, period)
    contacts = stats.adopt_step(
        t, StepOutcome(codes, values, n_prox, deadlocked), seen_path, period.velocities
    )
    return state, contacts


def episode_inputs(world: World, stats: EpisodeStats, goal_test: GoalTest) -> EpisodePeriod | None:
    """The :class:`EpisodePeriod` of a world and its statistics after a reset, or None
    when the statistics' steps cannot run compiled whole (recorded people's metrics)."""
    if not stats.compiled_steps:
        return None
    chip, bodies = world.compiled_space()
    return EpisodePeriod(period_inputs(chip, bodies, goal_test, stats.period_arrays), chip, stats)
