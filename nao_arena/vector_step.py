"""The control period of many env copies in one compiled call (the vector env).

A copy is *batched* in a period when the env's own step would run nothing but compiled
code for it: every robot is the env's and acts (none has finished), the world is
plain (no recorded people, no traffic, no sensing or actuation imperfection, no
episode log, no NAO features in the observations; :func:`copy_arrays`) and pymunk is
idle (:meth:`CopyBatch.runnable`). :func:`step_copies` then runs, for every batched
copy, the very kernels of the env's step, in the env's order:

- the commands: the actions (in [-1, 1]) times the robots' a_max, into the world's
  command rows (:meth:`nao_arena.arena.Arena.step_robots`);
- the world's period, the goal test and the statistics' step, as the arena's step
  runs them (:func:`nao_arena.period.control_period`);
- the rewards (:func:`nao_arena.env_step.period_rewards`, then the contact term),
  the agents that finish (:func:`nao_arena.env_step.settle_finished`) and the
  observations (:func:`nao_arena.neighbours.in_range_lists`,
  :func:`nao_arena.env_observations.observation_rows`,
  :func:`nao_arena.env_step.clipped_float32`).

What is Python in the env's step is done after the call by the objects themselves: the
contact events (objects of the statistics) right away, for the copies that have some;
the rest (the world's command log, the trajectory hash, the last period's state and
result, the counters) when the copy's objects are next read (:class:`CopyBatch`). The
results are those of the env's step, bit for bit (tested against K separate envs).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple, cast

import numpy as np
from numba import typeof
from numba.core import types
from numba.experimental import structref
from numba.typed import List
from numpy.typing import NDArray

from nao_arena.arena import StepResult
from nao_arena.env_observations import ObservedRows, observation_rows
from nao_arena.env_step import clipped_float32, period_rewards, settle_finished
from nao_arena.jit import inner_kernel, kernel
from nao_arena.neighbours import in_range_lists
from nao_arena.period import PeriodInputs, control_period
from nao_arena.stats.kernel import EV_START
from nao_arena.stats.recorder import StepCounts
from nao_arena.stats.records import ContactEvent
from nao_arena.world import (
    _DIRECT_STEP,
    PeriodArrays,
    _pymunk_is_idle,
)

if TYPE_CHECKING:
    from nao_arena.environment import NaoArenaParallelEnv

__all__ = [
    "HISTORY",
    "CopyArrays",
    "CopyBatch",
    "CopyOutputs",
    "CopyState",
    "History",
    "copy_arrays",
    "copy_list",
    "set_copy",
    "step_copies",
]

FloatArray = NDArray[np.float64]

_TRUE = cast(bool, np.bool_(True))
"""True as the compiled callees get it from Python (a literal True would compile
another version of each; the slice assignments are element by element for the same
reason as :func:`nao_arena.world._put_rows`)."""


class CopyArrays(NamedTuple):
    """What the compiled period reads and updates of one env copy, built after each of
    its resets (:func:`copy_arrays`): the very
    arrays of the world, the statistics and the env, updated in place. N bodies, R
    agents (every robot, robot order), D observation entries."""

    period: PeriodInputs
    """The world's, the goal test's and the statistics' arrays as the compiled control
    period takes them (:func:`nao_arena.period.control_period`)."""
    radii: FloatArray
    """(N,) m."""
    reached: NDArray[np.bool_]
    """(N,) the statistics' bodies that have reached their goals."""
    agent_bodies: NDArray[np.int64]
    """(R,) the body of each agent."""
    agent_a_max: FloatArray
    """(R,) m/s^2."""
    agent_goals: FloatArray
    """(R, 2) m."""
    prev_cmd: FloatArray
    """(R, 2) m/s^2 the agents' last clipped commands."""
    goal_distance: FloatArray
    """(R,) m the agents' distances to their goals at the period's start."""
    alive: NDArray[np.bool_]
    """(R,) the agents that have not finished."""
    all_rows: NDArray[np.intp]
    """(R,) 0 .. R - 1."""
    reward_weights: FloatArray
    """(4,) progress, accel_change, step, goal."""
    observed: ObservedRows
    """The observation's bundle of every agent."""
    obs_low: FloatArray
    """(D,) the observation's bounds."""
    obs_high: FloatArray
    """(D,)"""
    dt: float
    """The control period (s)."""
    collision_weight: float
    """The reward's weight of a contact."""
    terminate_on_collision: bool
    """Whether a contact terminates an agent."""
    time_limit: float
    """s."""
    sensing_range: float
    """m."""
    neighbours: int
    """Neighbours per observation."""
    finished_column: int
    """The observation's ``finished`` entry."""


class CopyState(NamedTuple):
    """The copies' state (K,) beyond their arrays, which the compiled period reads and
    advances: world steps since the reset, statistics steps, open proximity episodes,
    whether the statistics have a last command, whether every agent is unfinished, the
    deadlock duration (s) and its start (s, NaN: none yet), and the periods run since
    the copy's objects last took them (:class:`History`)."""

    world_steps: NDArray[np.int64]
    stats_steps: NDArray[np.int64]
    n_prox: NDArray[np.int64]
    has_prev: NDArray[np.bool_]
    all_alive: NDArray[np.bool_]
    deadlock_duration: FloatArray
    deadlock_time: FloatArray
    pending: NDArray[np.int64]


class History(NamedTuple):
    """The periods each copy ran since its objects last took them (``pending`` of
    :class:`CopyState`; T of them at most): the bodies' positions (m) and velocities
    (m/s) after each, ``states`` (K, T, 2, N, 2) (per period the positions, then the
    velocities: the bytes of the arena's trajectory hash, in its order), and the
    commands (m/s^2) of each, ``commands`` (K, T, N, 2)."""

    states: FloatArray
    commands: FloatArray


class CopyOutputs(NamedTuple):
    """What the compiled period writes per copy k (K copies, N bodies, R agents, S
    substeps, D observation entries): the world's period
    (:class:`~nao_arena.world.PeriodArrays`, stacked), with a read-only view of
    its path (the statistics read it as the world hands it out, read-only); the env's
    step arrays (:class:`~nao_arena.env_step.StepArrays`, stacked; rows of copies not batched are
    left as they are); per copy whether its episode ended and the number of contact
    event rows of the statistics (``event_count[k]`` rows of the returned ``codes``
    and ``values`` from ``event_start[k]``)."""

    period: PeriodArrays
    path_read_only: FloatArray
    observations: NDArray[np.float32]
    rewards: FloatArray
    terminated: NDArray[np.bool_]
    truncated: NDArray[np.bool_]
    reached: NDArray[np.bool_]
    collisions: NDArray[np.int64]
    faults: NDArray[np.int64]
    finished: NDArray[np.bool_]
    time: FloatArray
    ended: NDArray[np.bool_]
    event_start: NDArray[np.int64]
    event_count: NDArray[np.int64]


@kernel(error_model="numpy")
def step_copies(
    copies: Any,
    which: NDArray[np.int64],
    actions: FloatArray,
    start: FloatArray,
    v_start: FloatArray,
    state: CopyState,
    history: History,
    out: CopyOutputs,
) -> tuple[NDArray[np.int64], FloatArray]:
    """One control period of the copies ``which`` (batched; see the module docstring):
    copies (a typed list of :class:`CopyArrays`), actions (K, R, 2) in [-1, 1], the
    bodies' positions ``start`` (K, N, 2) m and velocities ``v_start`` (K, N, 2) m/s at
    the period's start (replaced by those at its end). Writes ``out``, advances
    ``state`` and appends the period to ``history``; returns the statistics' event rows
    (code, a, b) and values of all these copies, copy after copy (``out.event_start``).
    A copy with a non-finite command is not stepped (its ``event_start`` entry is -1):
    the actions are checked before."""
    n_codes = 0
    codes_all = np.empty((0, 3), dtype=np.int64)
    values_all = np.empty(0)
    path_all = out.period.path
    for w in range(which.shape[0]):
        k = which[w]
        c = copies[k]
        p = state.pending[k]
        commanded = history.commands[k, p]
        period = PeriodArrays(
            path_all[k],
            out.period.positions[k],
            out.period.velocities[k],
            out.period.accelerations[k],
            out.period.applied[k],
        )
        r = c.agent_bodies.shape[0]
        cmd = np.empty((r, 2))
        for b in range(commanded.shape[0]):
            commanded[b, 0] = 0.0
            commanded[b, 1] = 0.0
        for i in range(r):
            for j in range(2):
                cmd[i, j] = actions[k, i, j] * c.agent_a_max[i]
                commanded[c.agent_bodies[i], j] = cmd[i, j]
        t = state.world_steps[k] * c.dt
        finite, codes, values, n_prox, deadlocked = control_period(
            c.period,
            start[k],
            v_start[k],
            commanded,
            period,
            out.path_read_only[k],
            t,
            state.stats_steps[k],
            state.has_prev[k],
            state.n_prox[k],
        )
        if not finite:
            out.event_start[k] = -1
            continue
        state.world_steps[k] += 1
        time = state.world_steps[k] * c.dt
        pos, vel = period.positions, period.velocities
        n = pos.shape[0]
        for b in range(n):
            for j in range(2):
                history.states[k, p, 0, b, j] = pos[b, j]
                history.states[k, p, 1, b, j] = vel[b, j]
                start[k, b, j] = pos[b, j]
                v_start[k, b, j] = vel[b, j]
        state.pending[k] = p + 1
        state.has_prev[k] = True
        state.n_prox[k] = n_prox
        if deadlocked:  # EpisodeStats._deadlock's arithmetic
            state.deadlock_duration[k] += c.dt
            if math.isnan(state.deadlock_time[k]):
                state.deadlock_time[k] = t + c.dt
        state.stats_steps[k] += 1
        out.event_start[k] = n_codes
        out.event_count[k] = codes.shape[0]
        if codes.shape[0]:
            codes_all = np.concatenate((codes_all, codes))
            values_all = np.concatenate((values_all, values))
            n_codes += codes.shape[0]
        state.all_alive[k] = _env_period(
            c, cmd, pos, vel, period.accelerations, time, codes, out, k
        )
    return codes_all, values_all


@inner_kernel(error_model="numpy", inline="always")
def _env_period(
    c: CopyArrays,
    cmd: FloatArray,
    pos: FloatArray,
    vel: FloatArray,
    acc: FloatArray,
    time: float,
    codes: NDArray[np.int64],
    out: CopyOutputs,
    k: int,
) -> bool:
    """The env's part of a batched copy's period (every agent acting): rewards with the
    contact term, the agents that finish, the observations; into row k of ``out``.
    Returns whether every agent is still unfinished.
    ``cmd`` (R, 2) m/s^2 the commands; the bodies' end state ``pos``, ``vel``, ``acc``;
    ``time`` s at the period's end; ``codes`` the statistics' event rows."""
    r = c.agent_bodies.shape[0]
    reached = out.reached[k]
    for i in range(r):
        reached[i] = c.reached[c.agent_bodies[i]]
    reward = np.empty(r)
    period_rewards(
        pos,
        c.agent_bodies,
        c.all_rows,
        cmd,
        c.agent_goals,
        c.agent_a_max,
        c.prev_cmd,
        c.goal_distance,
        reached,
        c.reward_weights,
        reward,
    )
    # contacts that began: one per robot involved (a, and b unless it is a wall)
    contacts = np.zeros(pos.shape[0], dtype=np.int64)
    started = False
    for e in range(codes.shape[0]):
        code = codes[e, 0]
        if code == EV_START or code == EV_START + 3:
            started = True
            contacts[codes[e, 1]] += 1
            if code == EV_START:
                contacts[codes[e, 2]] += 1
    collisions = out.collisions[k]
    terminated = np.empty(r, dtype=np.bool_)
    for i in range(r):
        collisions[i] = contacts[c.agent_bodies[i]]
        terminated[i] = reached[i]
        if started:
            reward[i] = reward[i] - c.collision_weight * collisions[i]
            if c.terminate_on_collision:
                terminated[i] = terminated[i] or collisions[i] > 0
    time_up = time >= c.time_limit - 1e-9
    finished_before = np.empty(r, dtype=np.bool_)
    finished = out.finished[k]
    someone_left, _, all_alive = settle_finished(
        c.alive, c.all_rows, terminated, reward, finished_before, finished, out.rewards[k]
    )
    end = time_up or not someone_left
    # the observations of the end state (NaoArenaParallelEnv._observe, every agent)
    d = c.obs_low.shape[0]
    m = c.neighbours
    obs = np.zeros((r, d))
    idx = np.zeros((r, m), dtype=np.int64)
    present = np.zeros((r, m), dtype=np.bool_)
    nb_start, nb_index = in_range_lists(c.agent_bodies, pos, c.sensing_range, m, _TRUE)
    observation_rows(
        pos,
        vel,
        acc,
        c.radii,
        c.observed,
        max(c.time_limit - time, 0.0),
        nb_start,
        nb_index,
        obs,
        idx,
        present,
    )
    for i in range(r):
        obs[i, c.finished_column] = 0.0 if c.alive[i] else 1.0
    clipped = clipped_float32(obs, c.obs_low, c.obs_high)
    for i in range(r):
        for j in range(d):
            out.observations[k, i, j] = clipped[i, j]
    for i in range(r):
        out.terminated[k, i] = finished[i] and end
        out.truncated[k, i] = not finished[i] and end and time_up
    if end:
        for i in range(r):
            c.alive[i] = False
    for i in range(r):
        out.faults[k, i] = 0
    out.time[k] = time
    out.ended[k] = end
    return all_alive and not end


def copy_arrays(env: NaoArenaParallelEnv) -> CopyArrays | None:
    """The :class:`CopyArrays` of an env after a reset, or None when its steps are never
    batched: a robot that is not the env's, recorded people or traffic, a sensing or
    actuation imperfection, an episode log, NAO features in the observations, a window
    to draw, no ``keep_finished``, or a pymunk version whose step is not chipmunk's."""
    arena, opts = env.arena, env.options
    world, stats = arena.world, arena.stats
    assert stats is not None, "call reset() first"
    plain = (
        _DIRECT_STEP
        and opts.keep_finished
        and env.render_mode != "human"
        and env._cand is None
        and len(env._controlled) == len(arena.robot_ids)
        and arena.recorder is None
        and arena.senses_the_truth
        and not arena._sensing_draws
        and arena.actuation_noise == 0.0
        and arena.imperfections.lag == 0.0
        and len(arena.traffic.indices) == 0
        and not world.replayed.any()
        and stats._people is None
    )
    if not plain:
        return None
    episode = arena._period_inputs
    if episode is None:
        return None
    return CopyArrays(
        period=episode.inputs,
        radii=world.radii,
        reached=stats.reached,
        agent_bodies=env._bodies,
        agent_a_max=env._a_max,
        agent_goals=env._goals,
        prev_cmd=env._prev_cmd,
        goal_distance=env._dist,
        alive=env._alive,
        all_rows=env._all_rows,
        reward_weights=env._reward_weights,
        observed=env._observed_rows,
        obs_low=env._obs_low,
        obs_high=env._obs_high,
        dt=world.dt,
        collision_weight=float(opts.rewards.collision),
        terminate_on_collision=bool(opts.terminate_on_collision),
        time_limit=env._time_limit,
        sensing_range=env._sensing_range,
        neighbours=env._k,
        finished_column=env._finished_column,
    )


@kernel
def copy_list(first: CopyArrays, size: int) -> Any:
    """A typed list of ``size`` entries, each ``first``, for :func:`step_copies` (made
    and filled by compiled code, whose versions are cached, rather than by the typed
    list's own methods, which compile in every process)."""
    copies = List()
    for _ in range(size):
        copies.append(first)
    return copies


@kernel
def set_copy(copies: Any, k: int, arrays: CopyArrays) -> None:
    """Entry k of the typed list ``copies`` (:func:`copy_list`) set to ``arrays``."""
    copies[k] = arrays


def _layout(value: Any) -> Any:
    """What numba's type of ``value`` (:class:`CopyArrays` and what it holds) depends on:
    per array its dtype, dimensions, contiguity, alignment and whether it is writeable;
    per named tuple its class and its fields'; per compiled code's object
    (:class:`~nao_arena.period.PeriodInputs`) its numba type; per other value its Python
    type."""
    if isinstance(value, structref.StructRefProxy):
        return value._numba_type_
    if isinstance(value, np.ndarray):
        f = value.flags
        return (value.dtype.str, value.ndim, f.c_contiguous, f.f_contiguous, f.aligned, f.writeable)
    if isinstance(value, tuple):
        return (type(value), *(_layout(v) for v in value))
    return type(value)


HISTORY = 64
"""The periods a copy runs in the batch before its objects take them (at the latest)."""


class CopyBatch:
    """The copies of a vector env stepped in the batch: their :class:`CopyArrays` (a
    typed list), :class:`CopyState` and :class:`History`. A copy's own objects (its
    world, arena, statistics and env) take the periods it ran here when they are read
    (:meth:`sync`: before the copy takes a step of its own, when the vector env's
    ``envs`` are read, and every :data:`HISTORY` periods); the contact events, objects
    of the statistics, are made at the step they happen."""

    def __init__(self, envs: list[NaoArenaParallelEnv]) -> None:
        self.envs = envs
        k_envs = len(envs)
        n = envs[0].arena.world.n
        self.copies: Any = None
        """The typed list of the copies' arrays (None until a copy can be batched)."""
        self.batchable = np.zeros(k_envs, dtype=bool)
        """Per copy: whether its steps can be batched in this episode."""
        self.idle = np.zeros(k_envs, dtype=bool)
        """Per copy: pymunk had nothing of its own to do when the copy was last loaded."""
        self.state = CopyState(
            np.zeros(k_envs, np.int64),
            np.zeros(k_envs, np.int64),
            np.zeros(k_envs, np.int64),
            np.zeros(k_envs, bool),
            np.zeros(k_envs, bool),
            np.zeros(k_envs),
            np.zeros(k_envs),
            np.zeros(k_envs, np.int64),
        )
        self.history = History(
            np.empty((k_envs, HISTORY, 2, n, 2)), np.empty((k_envs, HISTORY, n, 2))
        )
        self.start = np.empty((k_envs, n, 2))
        self.v_start = np.empty((k_envs, n, 2))
        self.last: CopyOutputs | None = None
        """The outputs of the last batched step (the last period of every copy with
        periods pending)."""
        self._setters: dict[tuple[Any, ...], Any] = {}
        self._contacts: list[list[ContactEvent]] = [[] for _ in envs]
        self._contacts_step = np.full(k_envs, -1, dtype=np.int64)
        for k in range(k_envs):
            self.restart(k)

    def restart(self, k: int) -> None:
        """Copy k after a reset of its env: its arrays (if it can be batched) and state."""
        arrays = copy_arrays(self.envs[k])
        self.batchable[k] = arrays is not None
        if arrays is None:
            return
        if self.copies is None:
            self.copies = copy_list(arrays, len(self.envs))
        else:
            self._set(k, arrays)
        self.load(k)

    def _set(self, k: int, arrays: CopyArrays) -> None:
        """:func:`set_copy` of entry k, without numba's typing of the arrays of
        ``arrays`` on every call (half a millisecond): the compiled version is called
        directly when ``arrays`` has the layout (:func:`_layout`) of an entry set before,
        whose numba type it then has."""
        layout = _layout(arrays)
        call = self._setters.get(layout)
        if call is None:
            set_copy(self.copies, k, arrays)
            dispatcher: Any = set_copy
            signature = (typeof(self.copies), types.int64, typeof(arrays))
            self._setters[layout] = dispatcher.overloads[signature].entry_point
        else:
            call(self.copies, k, arrays)

    def load(self, k: int) -> None:
        """Copy k's state read from its objects (after a reset, or a step of its own)."""
        env = self.envs[k]
        world, stats = env.arena.world, env.arena.stats
        assert stats is not None  # reset() made it
        self.start[k] = world._pos
        self.v_start[k] = world._vel
        s = self.state
        s.world_steps[k] = world._steps
        s.stats_steps[k] = stats.steps
        s.n_prox[k] = stats.open_proximity_episodes
        s.has_prev[k] = stats.has_last_command
        s.all_alive[k] = env._all_alive and bool(env.agents)
        s.deadlock_duration[k] = stats.deadlock_duration
        s.deadlock_time[k] = stats.deadlock_time
        s.pending[k] = 0
        self.idle[k] = _pymunk_is_idle(world._space)

    def runnable(self) -> NDArray[np.intp]:
        """The copies whose next step is batched (their objects synced first when their
        history is full)."""
        s = self.state
        for k in np.flatnonzero(s.pending >= HISTORY).tolist():
            self.sync(k)
        return np.flatnonzero(self.batchable & self.idle & s.all_alive)

    def step(self, which: NDArray[np.intp], actions: FloatArray, out: CopyOutputs) -> None:
        """One period of the copies ``which`` (:func:`step_copies`) with the clipped
        actions (K, R, 2) into their rows of ``out``; the contact events made."""
        codes, values = step_copies(
            self.copies,
            which.astype(np.int64),
            actions,
            self.start,
            self.v_start,
            self.state,
            self.history,
            out,
        )
        out.period.path.setflags(write=False)
        out.period.applied.setflags(write=False)
        self.last = out
        if not len(codes):
            return
        s = self.state
        for k in np.flatnonzero(out.event_count).tolist():
            first = int(out.event_start[k])
            last = first + int(out.event_count[k])
            stats = self.envs[k].arena.stats
            assert stats is not None
            p = int(s.pending[k])
            if p >= 2:  # the velocities after the period before (the objects hold p == 1's)
                stats._v_prev = self.history.states[k, p - 2, 1].copy()
            steps = int(s.world_steps[k])
            dt = self.envs[k].arena.world.dt
            self._contacts[k] = stats._events(
                (steps - 1) * dt, codes[first:last], values[first:last], out.period.path[k]
            )
            self._contacts_step[k] = steps

    def sync(self, k: int) -> None:
        """Copy k's objects take the periods it ran in the batch since they last did."""
        p = int(self.state.pending[k])
        if not p:
            return
        assert self.last is not None
        env = self.envs[k]
        arena = env.arena
        assert arena.stats is not None
        period = self.last.period
        last = PeriodArrays(
            period.path[k],
            period.positions[k],
            period.velocities[k],
            period.accelerations[k],
            period.applied[k],
        )
        commands = self.history.commands[k, :p]
        state = arena.adopt_periods(commands, self.history.states[k, :p], last)
        commanded = arena.commanded
        s = self.state
        steps = int(s.world_steps[k])
        dt = arena.world.dt
        arena.stats.adopt_steps(
            StepCounts(
                int(s.stats_steps[k]),
                (steps - 1) * dt + dt,  # EpisodeStats.update's t + dt
                int(s.n_prox[k]),
                float(s.deadlock_duration[k]),
                float(s.deadlock_time[k]),
            ),
            last.velocities,
        )
        contacts = self._contacts[k] if self._contacts_step[k] == steps else []
        env.adopt_period(
            StepResult(state.time, state, commanded, contacts, []), bool(s.all_alive[k])
        )
        s.pending[k] = 0

    def sync_all(self) -> None:
        """Every copy's objects up to date (:meth:`sync`)."""
        for k in np.flatnonzero(self.state.pending).tolist():
            self.sync(k)
