"""``goal``: drive to the goal with no avoidance at all (the lower bound)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.agent import PanelAgent
from nao_arena.jit import kernel
from nao_arena.motion import limit_norm
from nao_arena.sensing import Observation, SensingBatch

APPROACH_GAIN = 1.0  # 1/s: the target speed near the goal, per metre to go (see below)


def goal_target(obs: Observation) -> NDArray[np.float64] | None:
    """The point the robot heads for (m): its goal, else its route's last waypoint."""
    if obs.goal is not None:
        return obs.goal
    if obs.route is not None and len(obs.route):
        return obs.route[-1]
    return None


def goal_seeking_accels(
    targets: NDArray[np.float64],
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64],
    a_max: NDArray[np.float64],
    speed_cap: NDArray[np.float64],
    heading_offset: Sequence[float] | None = None,
    time_constant: float | NDArray[np.float64] = 0.5,
    braking: float = 0.5,
    approach_gain: float = APPROACH_GAIN,
    has_target: NDArray[np.bool_] | None = None,
) -> NDArray[np.float64]:
    """Acceleration (n, 2) m/s^2 that tracks a velocity toward each robot's target.

    Per row: target point (m), position (m), velocity (m/s), a_max (m/s^2), speed cap
    (m/s), heading offset (rad, counter-clockwise positive; None: none) and time
    constant (s; one for all rows or one per row); rows where
    ``has_target`` is False (default: every row has one) track standing still.

    Target velocity: towards the target (turned by the heading offset) at
    min(cap, sqrt(2 b d + (b tau)^2) - b tau, k d) at distance d (m), with b =
    ``braking`` * a_max and tau = ``time_constant``: the speed from which the robot,
    lagging tau behind its target, stops at the goal braking at b; k =
    ``approach_gain`` (1/s): close to the goal the speed falls linearly with the
    distance (well damped: k tau = 1/2), so that the robot settles on the goal instead
    of overshooting or chattering around it. The acceleration closes the velocity
    error in tau s and is scaled to |a| <= a_max.
    """
    n = len(targets)
    f = np.ascontiguousarray
    if heading_offset is None:  # no turn: the kernel reads no cosine or sine
        offsets = cos_off = sin_off = np.zeros(n)
    else:
        offsets = f(heading_offset, dtype=np.float64)
        cos_off, sin_off = np.cos(offsets), np.sin(offsets)
    has = np.ones(n, dtype=np.bool_) if has_target is None else f(has_target, dtype=np.bool_)
    out = np.empty((n, 2))
    goal_seeking_kernel(
        f(targets, dtype=np.float64).reshape(n, 2),
        f(positions, dtype=np.float64),
        f(velocities, dtype=np.float64),
        f(a_max, dtype=np.float64),
        f(speed_cap, dtype=np.float64),
        Headings(offsets, cos_off, sin_off),
        _per_row(time_constant, n),
        float(braking),
        float(approach_gain),
        has,
        out,
    )
    return out


def _per_row(value: float | NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """``value`` as n float64 values: one for every row, or one per row."""
    if np.ndim(value) == 0:
        return np.full(n, float(value))
    return np.ascontiguousarray(np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)))


class Headings(NamedTuple):
    """Heading offsets (n,) rad (counter-clockwise positive) with their cosines and sines
    (n,), one per row."""

    offset: NDArray[np.float64]
    cos: NDArray[np.float64]
    sin: NDArray[np.float64]


@kernel
def goal_seeking_kernel(
    targets,
    positions,
    velocities,
    a_max,
    speed_cap,
    headings,
    tau,
    braking,
    approach_gain,
    has_target,
    out,
):
    """:func:`goal_seeking_accels` row by row into ``out`` (n, 2) m/s^2; the heading
    offsets: :class:`Headings`."""
    offset, cos_off, sin_off = headings
    for i in range(targets.shape[0]):
        dx = targets[i, 0] - positions[i, 0]
        dy = targets[i, 1] - positions[i, 1]
        dist = math.hypot(dx, dy)
        lag = braking * a_max[i] * tau[i]
        # min(cap, stopping speed, k d), the first of equals (Python's min, also with NaN)
        stop = math.sqrt(2.0 * braking * a_max[i] * dist + lag * lag) - lag
        speed = stop if stop < speed_cap[i] else speed_cap[i]
        near = approach_gain * dist
        speed = near if near < speed else speed
        vx = 0.0
        vy = 0.0
        if not (dist < 1e-9 or not has_target[i]):  # else standing still: no direction
            vx = dx / dist * speed
            vy = dy / dist * speed
            if offset[i] != 0.0:
                c = cos_off[i]
                s = sin_off[i]
                vx, vy = c * vx - s * vy, s * vx + c * vy
        ax = (vx - velocities[i, 0]) / tau[i]
        ay = (vy - velocities[i, 1]) / tau[i]
        ax, ay, _ = limit_norm(ax, ay, a_max[i])
        out[i, 0] = ax
        out[i, 1] = ay


def goal_seeking_accel(
    obs: Observation,
    v_pref: float | None = None,
    time_constant: float = 0.5,
    braking: float = 0.5,
    heading_offset: float = 0.0,
    approach_gain: float = APPROACH_GAIN,
) -> NDArray[np.float64]:
    """:func:`goal_seeking_accels` of one robot (2,) m/s^2: toward its
    :func:`goal_target` (none: stand still) at speeds up to min(v_pref, v_max) m/s."""
    target = goal_target(obs)
    speed_cap = obs.v_max if v_pref is None else min(v_pref, obs.v_max)
    return goal_seeking_accels(
        _NO_TARGET if target is None else np.asarray(target, dtype=np.float64)[None],
        obs.position[None],
        obs.velocity[None],
        np.array([obs.a_max], dtype=np.float64),
        np.array([speed_cap], dtype=np.float64),
        (heading_offset,) if heading_offset else None,
        time_constant,
        braking,
        approach_gain,
        _NONE if target is None else None,
    )[0]


_NO_TARGET = np.zeros((1, 2))
_NONE = np.zeros(1, dtype=bool)


class GoalAgent:
    """Goal seeking with no avoidance; options: v_pref (m/s), time_constant (s)."""

    def __init__(self, v_pref: float | None = None, time_constant: float = 0.5) -> None:
        self.v_pref = v_pref
        self.time_constant = time_constant

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """Nothing to reset: the controller is stateless."""

    def act(self, obs: Observation) -> NDArray[np.float64]:
        return goal_seeking_accel(obs, self.v_pref, self.time_constant)

    def panel(self) -> PanelAgent:
        """What the viewer's acceleration panel shows of this agent: its v_pref."""
        return PanelAgent(v_pref=self.v_pref)

    @classmethod
    def act_batch(
        cls, agents: Sequence[GoalAgent], batch: SensingBatch, rows: Sequence[int]
    ) -> list[NDArray[np.float64] | Exception]:
        """:meth:`act` of every robot ``rows`` of ``batch`` at once (agent i drives robot
        rows[i]): the accelerations (m/s^2), one per row. A subclass that overrides
        ``act`` gets its ``act`` called robot by robot."""
        rows_a = np.asarray(rows, dtype=np.int64)
        if any(type(ag).act is not GoalAgent.act for ag in agents):
            return [_act_one(ag, batch, k) for ag, k in zip(agents, rows_a.tolist(), strict=True)]
        bodies = batch.bodies[rows_a]
        v_max = batch.v_max[bodies]
        cap = np.array(
            [
                v if ag.v_pref is None else min(ag.v_pref, v)
                for ag, v in zip(agents, v_max.tolist(), strict=True)
            ]
        )
        tau = np.array([ag.time_constant for ag in agents], dtype=np.float64)
        acc = goal_seeking_accels(
            batch.goals[rows_a],
            batch.positions[bodies],
            batch.velocities[bodies],
            batch.a_max[bodies],
            cap,
            time_constant=tau,
        )
        return list(acc)


def _act_one(agent: GoalAgent, batch: SensingBatch, k: int) -> NDArray[np.float64] | Exception:
    """``agent.act`` of robot k of ``batch``, or the exception it raised."""
    try:
        return agent.act(batch.observation(k))
    except Exception as exc:  # noqa: BLE001 - the agent's failure
        return exc
