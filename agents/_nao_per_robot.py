"""The ``nao`` agents' robot-by-robot path: what their compiled calls leave undecided.

The compiled calls (:mod:`nao_arena.agents._nao_batch`) decide every robot of a batch
except those whose inputs they cannot take: a time grid that does not start at 0 and
increase (the obstacle paths are then built by
:func:`~nao_arena.obstacles.obstacle_paths`), non-finite velocities or predicted
paths (the error reaches the caller), and, where nothing is admissible and the
``infeasible`` fallback is not braking, the search for the acceleration that postpones
contact longest (with ``"stop_in_time"``, first the test whether braking stops the robot
before any contact). For those robots the agent's obstacle paths are built here one
robot at a time and the keep test, repair and selection run on them
(:func:`~nao_arena.geometry.repair_acceleration`,
:func:`~nao_arena.geometry.select_acceleration`), committed into the agent's row of its
table as the compiled calls commit theirs. Obstacle paths are robot-relative (m),
accelerations world-frame (m/s^2).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry import (
    AccelLimits,
    PiecewisePath,
    grown_with_time,
    path_clearance,
    repair_acceleration,
    select_acceleration,
)
from nao_arena.geometry.kernels import (
    Obstacles,
    Walls,
    admissible_kernel,
    piece_sweep,
    relevant_sampled_paths,
    relevant_walls,
)
from nao_arena.geometry.selection import Selection
from nao_arena.motion import braking
from nao_arena.obstacles import obstacle_paths, relative_walls
from nao_arena.sensing import SensingBatch

from ._nao_columns import KEEP_UNTESTED

if TYPE_CHECKING:
    from ._nao_step import GroupView, RobotRows
    from .nao import NAOAgent

Excursions = tuple[NDArray[np.float64], NDArray[np.bool_]]
""":func:`~nao_arena.geometry.kernels.path_excursions` of a step's predictions."""

#: how :meth:`~nao_arena.agents.nao.NAOAgent.nearest_admissible` reports a full selection
SELECTION_STATUS = {"desired": "kept", "adjusted": "adjusted", "infeasible": "infeasible"}


def brakes_when_infeasible(agent: NAOAgent, traffic: bool) -> bool:
    """Whether the agent brakes when nothing is admissible (``infeasible``), with
    (``traffic``) or without non-reactive traffic among its neighbours."""
    return agent.infeasible == "brake" or (agent.infeasible == "auto" and not traffic)


def stops_before_contact(velocity: NDArray[np.float64], a_max: float, path: PiecewisePath) -> bool:
    """Whether braking at a_max (m/s^2) from ``velocity`` (m/s) brings the robot to rest
    before it touches any obstacle of ``path`` (robot-relative, radii grown): the first
    contact (:func:`~nao_arena.geometry.path_clearance`) of that constant deceleration
    comes no earlier than the stop, |velocity| / a_max (s). A robot at rest stops at once."""
    speed = math.hypot(float(velocity[0]), float(velocity[1]))
    if speed == 0.0 or path.n_obstacles == 0:
        return True
    decel = -np.asarray(velocity, dtype=np.float64) / speed * a_max
    first = path_clearance(decel, velocity, path).time_of_first_contact
    return bool(np.min(first) >= speed / a_max)


def fallback(
    agent: NAOAgent,
    velocity: NDArray[np.float64],
    a_max: float,
    dt: float,
    traffic: bool,
    path: PiecewisePath,
) -> NDArray[np.float64] | None:
    """The acceleration (m/s^2) taken when nothing is admissible against ``path``:
    braking towards standing still within one step dt (s) from ``velocity`` (m/s)
    (:func:`nao_arena.motion.braking`), or None: the one that postpones contact longest
    (see ``infeasible``; :func:`~nao_arena.agents._nao_decide.apply_braking` does the
    same for many robots). ``"stop_in_time"`` brakes where braking stops the robot
    before any contact with ``path`` (:func:`stops_before_contact`)."""
    in_time = agent.infeasible == "stop_in_time" and stops_before_contact(velocity, a_max, path)
    if in_time or brakes_when_infeasible(agent, traffic):
        vx, vy = float(velocity[0]), float(velocity[1])
        return np.array(braking(vx, vy, float(a_max), float(dt)))
    return None


def relevant_paths(
    agent: NAOAgent,
    predicted: NDArray[np.float64],
    excursions: Excursions,
    idx: NDArray[np.int64],
    nb_radii: NDArray[np.float64],
    position: NDArray[np.float64],
    radius: float,
    walls: NDArray[np.float64],
    wall_radius: NDArray[np.float64],
    velocity: NDArray[np.float64],
    a_max: float,
    v_max: float,
) -> PiecewisePath:
    """:func:`~nao_arena.obstacles.obstacle_paths` of the neighbours predicted[idx] (world
    frame, m; radii nb_radii[idx] m) and the walls in the agent's sensing range, relative
    to ``position`` (m), without the obstacles that no acceleration within a_max
    (m/s^2) can reach (velocity m/s, speed limit v_max m/s): what every selection drops
    first, built in one compiled pass (where the time grid is regular and the velocity
    finite). excursions: of ``predicted`` (shared by the robots of a step)."""
    times = agent.times
    grow = radius + agent.margin
    if not (agent._regular_grid() and math.isfinite(velocity[0]) and math.isfinite(velocity[1])):
        return obstacle_paths(
            times,
            predicted[idx],
            nb_radii[idx] + grow,
            position,
            walls,
            wall_radius + grow,
            agent.sensing_range,
        )
    # writable copies, as the compiled step passes them: a read-only array is a version
    # of its own to compile
    idx, position, velocity = np.array(idx), np.array(position), np.array(velocity)
    c, w, b, rad, finite = relevant_sampled_paths(
        times,
        predicted,
        idx,
        position,
        nb_radii,
        grow,
        velocity,
        float(a_max) * (1.0 + 1e-9),
        float(v_max),
        excursions[0],
        excursions[1],
    )
    if not finite:
        raise ValueError("centers: expected finite values")
    wall_rel, wall_r = relative_walls(walls, wall_radius + grow, position, agent.sensing_range)
    wall_rel, wall_r = relevant_walls(
        velocity,
        float(a_max) * (1.0 + 1e-9),
        float(v_max),
        float(times[-1]),
        wall_rel,
        wall_r,
        0.0,
    )
    return PiecewisePath(times, c, w, b, rad, wall_rel, wall_r)


def paths_of(
    agent: NAOAgent,
    batch: SensingBatch,
    k: int,
    pred: NDArray[np.float64],
    excursions: Excursions,
) -> PiecewisePath:
    """:func:`relevant_paths` of robot k of ``batch`` (predictions ``pred`` (bodies, T,
    2) m of every body, with their excursions)."""
    body = int(batch.bodies[k])
    return relevant_paths(
        agent,
        pred,
        excursions,
        batch.neighbour_ids(k),
        batch.radii,
        batch.positions[body],
        float(batch.radii[body]),
        batch.walls,
        batch.wall_radius,
        batch.velocities[body],
        float(batch.a_max[body]),
        float(batch.v_max[body]),
    )


def admissible(
    a: NDArray[np.float64],
    v: NDArray[np.float64],
    a_max: float,
    v_max: float,
    path: PiecewisePath,
) -> bool:
    """Whether acceleration a (m/s^2) is within a_max and keeps the robot (velocity v m/s,
    speed limit v_max m/s) clear of every obstacle of ``path`` over the horizon."""
    if float(np.hypot(*a)) > a_max * (1 + 1e-9):
        return False
    if path.n_obstacles == 0:
        return True
    ok = np.empty(1, dtype=bool)
    admissible_kernel(
        v[None].copy(),
        a[None].copy(),
        v_max,
        Obstacles(*path.moving_arrays, piece_sweep(path.t, path.velocity, path.acceleration)),
        Walls(path.walls, path.wall_radius),
        0.0,
        ok,
    )
    return bool(ok[0])


def select(
    agent: NAOAgent,
    desired: NDArray[np.float64],
    velocity: NDArray[np.float64],
    path: PiecewisePath,
    a_max: float,
    v_max: float,
    dt: float,
    traffic: bool = False,
) -> NDArray[np.float64]:
    """The full selection (m/s^2) toward ``desired`` (m/s^2); it becomes the agent's
    current acceleration and last selection. traffic: whether non-reactive traffic is
    among the neighbours (``infeasible="auto"`` then postpones contact)."""
    sel = select_acceleration(
        desired,
        velocity,
        path,
        AccelLimits(a_max),
        v_max=v_max,
        with_clearance=False,
        fallback=fallback(agent, velocity, a_max, dt, traffic, path),
    )
    return commit(agent, sel)


def commit(agent: NAOAgent, sel: Selection) -> NDArray[np.float64]:
    """A full selection becomes the agent's current acceleration (m/s^2, a copy
    returned); its age restarts."""
    agent.last_selection = sel
    agent.age = 0.0
    agent.current = sel.accel
    return agent.current.copy()


def repair(
    agent: NAOAgent,
    desired: NDArray[np.float64],
    velocity: NDArray[np.float64],
    path: PiecewisePath,
    a_max: float,
    v_max: float,
) -> NDArray[np.float64] | None:
    """For a young adjustment that has become inadmissible: a nearby admissible
    acceleration (m/s^2, :func:`~nao_arena.geometry.repair_acceleration`), which becomes
    the current one without restarting the adjustment's age; None: select in full."""
    if not agent._holds_adjustment():
        return None
    fixed = repair_acceleration(
        agent.current, desired, velocity, path, AccelLimits(a_max), v_max=v_max
    )
    if fixed is not None:
        agent.current = fixed
    return fixed


def nearest_on(
    agent: NAOAgent,
    desired: NDArray[np.float64],
    velocity: NDArray[np.float64],
    path: PiecewisePath,
    a_max: float,
    v_max: float,
    dt: float,
    traffic: bool,
) -> tuple[NDArray[np.float64], str]:
    """:meth:`~nao_arena.agents.nao.NAOAgent.nearest_admissible` on the robot's obstacle
    paths ``path`` (velocity m/s, limits a_max m/s^2 and v_max m/s, control period dt s;
    traffic: whether traffic is among the neighbours)."""
    if admissible(desired, velocity, a_max, v_max, path):
        agent.current = desired.copy()
        return agent.current, "kept"
    fixed = repair(agent, desired, velocity, path, a_max, v_max)
    if fixed is not None:
        return fixed, "repaired"
    accel = select(agent, desired, velocity, path, a_max, v_max, dt, traffic)
    assert agent.last_selection is not None
    return accel, SELECTION_STATUS[agent.last_selection.status]


def undecided(
    agents: Sequence[NAOAgent],
    view: GroupView,
    status: NDArray[np.int64],
    settled: NDArray[np.bool_],
    errors: dict[int, Exception],
    out: NDArray[np.float64],
    batch: SensingBatch,
    rows_a: NDArray[np.int64],
    own: RobotRows,
    current: NDArray[np.float64],
    desired: NDArray[np.float64],
) -> None:
    """The members m of ``view`` (rows of the agents' table; agent i drives batch row
    rows_a[i]; the view's predictions and their excursions) that the compiled calls left
    unsettled, robot by robot: status KEEP_UNTESTED (undecided there: an irregular time
    grid, non-finite paths) keeps its current acceleration current[i] (m/s^2) where that
    is admissible; then a young adjustment is repaired, else the full selection toward
    desired[i] (m/s^2) with the agent's fallback. Writes ``out``
    (n, 2) m/s^2; a robot whose step raises gets its exception in ``errors``."""
    m, pred, excursions = view.m, view.pred, view.excursions
    vel, a_max, v_max = own.vel, own.a_max, own.v_max
    for j in np.flatnonzero(~settled).tolist():
        i = int(m[j])
        ag = agents[i]
        try:
            path = paths_of(ag, batch, int(rows_a[i]), pred, excursions)
            if status[j] == KEEP_UNTESTED and admissible(
                current[i], vel[i], float(a_max[i]), float(v_max[i]), path
            ):
                continue  # kept: out holds the current acceleration
            fixed = repair(ag, desired[i], vel[i], path, float(a_max[i]), float(v_max[i]))
            if fixed is not None:
                out[i] = fixed
                continue
            out[i] = select(
                ag,
                desired[i],
                vel[i],
                path,
                float(a_max[i]),
                float(v_max[i]),
                batch.dt,
                bool(own.traffic_near[i]),
            )
        except Exception as exc:  # noqa: BLE001 - the agent's failure
            errors[i] = exc


def robust(
    agents: Sequence[NAOAgent],
    live: NDArray[np.bool_],
    errors: dict[int, Exception],
    out: NDArray[np.float64],
    own: RobotRows,
    desired: NDArray[np.float64],
) -> None:
    """The live robots (``live``) whose agent has an ``uncertainty_growth`` (m/s) > 0,
    after their decision of this step: the full selection toward desired[i] (m/s^2)
    against this step's obstacles (those the plain selection tests: within reach of
    their plain radii, a neighbour already inside its radius capped at its distance)
    with the radii grown with prediction time
    (:func:`~nao_arena.geometry.grown_with_time`; a grown neighbour that already
    overlaps the robot leaves nothing admissible). Where an acceleration is admissible
    there, it replaces out[i] (m/s^2) and becomes the agent's current acceleration and
    last selection; elsewhere the decision against the predictions themselves stands.
    A robot whose step raises gets its exception in ``errors``."""
    for i, ag in enumerate(agents):
        if ag.uncertainty_growth <= 0.0 or not live[i] or i in errors:
            continue
        try:
            path = ag.last_obstacles()
            if path is None:
                continue
            sel = select_acceleration(
                desired[i],
                own.vel[i],
                grown_with_time(path, ag.uncertainty_growth),
                AccelLimits(float(own.a_max[i])),
                v_max=float(own.v_max[i]),
                with_clearance=False,
                # any fallback spares the search for the latest contact: an infeasible
                # result is dropped
                fallback=np.zeros(2),
            )
        except Exception as exc:  # noqa: BLE001 - the agent's failure
            errors[i] = exc
            continue
        if sel.feasible:
            out[i] = sel.accel
            ag.current = np.array(sel.accel, dtype=np.float64)
            ag.last_selection = sel
