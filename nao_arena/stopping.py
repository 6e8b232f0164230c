"""Stopping plans: the rule under which robots that plan together never touch.

Each control period a robot commits to a *stopping plan*: its acceleration for
the coming period, then braking to a standstill (each later period the
acceleration -min(a_max, |v| / dt) v / |v|, :func:`nao_arena.motion.braking`, which
stops it exactly at the end of the last one), then standing still. A plan is written
out as the robot's positions at every physics substep (world frame, m), by the same
arithmetic as the world (:mod:`nao_arena.world`: the command scaled to |a| <= a_max,
the speed limit's saturation time, pymunk's integration: each substep of h =
dt / substeps moves the body by h times its velocity, then adds the
acceleration's share of the substep to the velocity), so a plan is the path
the world drives, between substeps in straight lines as the contact check of
:mod:`nao_arena.stats` reads it.

The rule (:func:`commit_plans`), for the robots of one group (the robots of
one agent class acting together, :meth:`nao_arena.agents.nao.NAOAgent.act_batch`):

- every robot has a desired acceleration (its avoidance's choice) and its
  *standing plan*: braking from now, which is the tail of the plan it
  committed to one period earlier, because it has since driven that plan's
  first period;
- a robot takes its desired acceleration only if that plan keeps every
  other robot's final plan and every wall at least the sum of the radii plus
  ``margin`` away (exactly, substep by substep); otherwise it brakes (its
  standing plan). Starting from "everyone desires", robots whose plan
  conflicts switch to braking, in robot order, until no plan conflicts
  (switching is one-way, so this ends; a conflict between two braking robots
  is impossible while the rule has held, see below).

Why it never touches: if the standing plans were pairwise clear at a step,
they are after it (each robot either keeps its standing plan or takes one
checked against all final plans), and next period's standing plans are
exactly these plans' tails. Robots start at rest and apart, so by induction
the plans stay clear and, as every robot drives its plan's first period,
no two robots (and no robot and wall) ever come closer than the sum of their
radii plus ``margin``. Assumptions: every robot of the group drives its command
(the world's model; no contact with a body outside the group pushes it off
its plan), and the standing plans are clear at the first step (true for
robots at rest apart). Pairs whose plans could meet are found through the
neighbour index (:mod:`nao_arena.neighbours`) with cells of the rule's own width,
not through sensing, so sensing range and caps do not weaken it. Bodies outside
the group (traffic, other agents) are left to the avoidance.

Imperfect communication (:mod:`nao_arena.communication`; :class:`Knowledge`). The
rule above needs every pair to agree within the period: it runs on the *linked*
pairs only. For a pair (i, j) that is not linked, robot i knows of j only a state
from some time ago: what it sensed (with the sensing's age), or j's last message.
Since then j has been free to drive any acceleration for ``free`` periods (the
periods since that state, this one included), and then it brakes.
Robot i takes its desired plan only if it keeps clear of every plan j could be on:
of j's *tube* (:func:`tube_clearance`), around the plan that coasts from the
known state for those periods and then brakes (:func:`tube_reference`). Two plans
from the same state whose accelerations differ by at most a_j for T = free dt
seconds are at most a_j T^2 / 2 apart then (the substep integration too), and
their velocities a_j T; braking, one period after another, never draws two
velocities apart (it is the identity minus a fraction of the projection onto the
disc of radius a_j dt: nonexpansive), so the gap grows no faster than that, nor
than the two speeds together, until both stand. Sensed states carry noise: the
tube may grow by ``sigmas`` times (sigma_p + sigma_v tau) (:class:`Knowledge`;
none by default, :data:`NOISE_SIGMAS`).

Why it still never touches (exact knowledge, every robot driving its command):
for a pair that is not linked, each robot's desired plan clears every plan the
other could commit now, its standing plan among them; two standing plans are the
tails of plans that were clear. A pair neither linked nor known to each other is
not protected (a robot cannot avoid what it does not know), nor is knowledge
older than :data:`FORGET_PERIODS` periods used (the tube of a robot unheard of
for long covers everything near and would stop its neighbours for good).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.geometry.kernels import point_segment_dist2, segment_segment_dist2
from nao_arena.jit import inner_kernel, kernel
from nao_arena.motion import brake_factor, clip_norm, limit_norm, saturation_time
from nao_arena.motion import braking as braking_accel
from nao_arena.neighbours import around, extent, grid, range_grid

__all__ = [
    "FORGET_PERIODS",
    "NOISE_SIGMAS",
    "Group",
    "Knowledge",
    "Noise",
    "commit_plans",
    "max_plan_points",
    "no_knowledge",
    "plan_clearance",
    "stopping_plan",
    "tube_clearance",
    "tube_reference",
]

NOISE_SIGMAS = 0.0
"""How many standard deviations of the sensing noise a tube grows by (position noise,
plus velocity noise times the time since the state was sensed), by default: none, the
tubes take what was sensed as exact. 3 makes a sensed state's error fall outside the
tube with probability exp(-9 / 2) = 1.1 % (a 2-D Gaussian error's norm), at a large
cost in liveness (see docs/results/robustness.md); the ``nao`` agents' option
``noise_sigmas`` sets it."""

FORGET_PERIODS = 10
"""Knowledge of a robot older than this many control periods (``free`` larger) is not
used (see the module)."""


class Knowledge(NamedTuple):
    """What each robot of a group knows of each other (rows i, j of the group; world
    frame). linked (n, n): the pairs that agree on their plans this period (shape
    (0, 0): every pair, perfect communication); for the others: position (n, n, 2) m
    and velocity (n, n, 2) m/s of j as i knows it, free (n, n): the periods j has been
    free to drive since then, this one included (0: i knows nothing of j); spread
    (n, n, 2): the standard deviations (m, m/s) of the noise on that state; sigmas: how
    many of them the tubes grow by (:data:`NOISE_SIGMAS` by default)."""

    linked: NDArray[np.bool_]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    free: NDArray[np.int64]
    spread: NDArray[np.float64]
    sigmas: float


class Group(NamedTuple):
    """The robots of a group (rows i; world frame): position (n, 2) m, velocity (n, 2)
    m/s, radius (n,) m, the acceleration limit a_max (n,) m/s^2 and the speed limit
    v_max (n,) m/s."""

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    radius: NDArray[np.float64]
    a_max: NDArray[np.float64]
    v_max: NDArray[np.float64]


class Noise(NamedTuple):
    """The noise a tube grows by (:func:`tube_clearance`): the standard deviations of
    the noise on the known state, spread_p m on the position and spread_v m/s on the
    velocity, and how many of them (sigmas) the tube grows by."""

    spread_p: float
    spread_v: float
    sigmas: float


_NO_KNOWLEDGE = Knowledge(
    np.zeros((0, 0), dtype=np.bool_),
    np.zeros((0, 0, 2)),
    np.zeros((0, 0, 2)),
    np.zeros((0, 0), dtype=np.int64),
    np.zeros((0, 0, 2)),
    NOISE_SIGMAS,
)


def no_knowledge() -> Knowledge:
    """The :class:`Knowledge` of perfect communication: every pair linked (one shared
    value, made once: its arrays are empty, so nothing can change them)."""
    return _NO_KNOWLEDGE


FloatArray = NDArray[np.float64]


@kernel
def max_plan_points(speed: float, a_max: float, dt: float, substeps: int) -> int:
    """Substep positions of the longest stopping plan of a robot at ``speed`` (m/s) with
    a_max (m/s^2) and dt (s): the start, the commanded period and the braking periods
    (from at most speed + a_max dt)."""
    brake = math.ceil(speed / (a_max * dt) + 1e-9) + 2
    return (1 + brake) * substeps + 1


@inner_kernel(error_model="numpy")
def _period(
    px: float,
    py: float,
    vx: float,
    vy: float,
    ax: float,
    ay: float,
    tau: float,
    h: float,
    substeps: int,
    out: FloatArray,
    k: int,
) -> tuple[float, float, float, float, int]:
    """One control period of the world's integration from (p, v) under acceleration a
    (m/s^2) that stops at saturation time tau (s); appends the substep positions to
    out from row k on; returns the end position, velocity and next row."""
    for j in range(substeps):
        w = min(max((tau - j * h) / h, 0.0), 1.0)
        px += vx * h
        py += vy * h
        vx += w * ax * h
        vy += w * ay * h
        out[k, 0] = px
        out[k, 1] = py
        k += 1
    return px, py, vx, vy, k


@inner_kernel(error_model="numpy")
def _brake_to_stop(
    px: float,
    py: float,
    vx: float,
    vy: float,
    a_max: float,
    dt: float,
    substeps: int,
    out: FloatArray,
    k: int,
) -> int:
    """Brake from (p, v) period by period (:func:`nao_arena.motion.brake_factor`: -b v,
    to a standstill within a period once |v| <= a_max dt), appending the substep
    positions to out from row k on while it has room for a period; returns the next
    row."""
    h = dt / substeps
    limit = out.shape[0] - substeps
    while k <= limit:
        speed = math.hypot(vx, vy)
        if speed == 0.0:
            break
        b = brake_factor(speed, a_max, dt)
        px, py, vx, vy, k = _period(px, py, vx, vy, -b * vx, -b * vy, math.inf, h, substeps, out, k)
        if b * dt >= 1.0:  # this period stopped it (up to rounding)
            break
    return k


@kernel(error_model="numpy")
def _fill_plan(
    px: float,
    py: float,
    vx: float,
    vy: float,
    ax: float,
    ay: float,
    a_max: float,
    v_max: float,
    dt: float,
    substeps: int,
    out: FloatArray,
) -> int:
    """The stopping plan from (p, v) with acceleration a for the first period (scaled to
    |a| <= a_max, the speed limit as the world applies it) into out; returns its number
    of points (out must hold :func:`max_plan_points`)."""
    h = dt / substeps
    vx, vy, _ = limit_norm(vx, vy, v_max)
    ax, ay = clip_norm(ax, ay, a_max)
    out[0, 0] = px
    out[0, 1] = py
    tau = saturation_time(vx, vy, ax, ay, v_max)
    px, py, vx, vy, k = _period(px, py, vx, vy, ax, ay, tau, h, substeps, out, np.int64(1))
    return _brake_to_stop(px, py, vx, vy, a_max, dt, substeps, out, k)


@kernel(error_model="numpy")
def _pair_min_dist2(
    pa: FloatArray, na: int, pb: FloatArray, nb: int, substeps: int, stop2: float, skip: float
) -> float:
    """Smallest squared distance (m^2) between two synchronous plans (points pa[:na],
    pb[:nb]; a plan that ended stands at its last point), in straight lines between
    substeps; returns early with a value below stop2 once one is found. skip (m): a
    bound on how far a period's relative path strays from its chord (periods whose
    chord clears sqrt(stop2) + skip are not looked into)."""
    n = max(na, nb)
    best = math.inf
    reach = math.sqrt(stop2) + skip
    k = 0
    while k < n - 1:
        e = min(k + substeps, n - 1)
        ia0, ia1 = min(k, na - 1), min(e, na - 1)
        ib0, ib1 = min(k, nb - 1), min(e, nb - 1)
        ax, ay = pa[ia0, 0] - pb[ib0, 0], pa[ia0, 1] - pb[ib0, 1]
        bx, by = pa[ia1, 0] - pb[ib1, 0], pa[ia1, 1] - pb[ib1, 1]
        chord = point_segment_dist2(ax, ay, bx, by)
        if chord > reach * reach:
            best = min(best, chord)
        else:
            for j in range(k, e):
                i0, i1 = min(j, na - 1), min(j + 1, na - 1)
                j0, j1 = min(j, nb - 1), min(j + 1, nb - 1)
                d2 = point_segment_dist2(
                    pa[i0, 0] - pb[j0, 0],
                    pa[i0, 1] - pb[j0, 1],
                    pa[i1, 0] - pb[j1, 0],
                    pa[i1, 1] - pb[j1, 1],
                )
                if d2 < best:
                    best = d2
                    if best < stop2:
                        return best
        k = e
    if n == 1:
        dx, dy = pa[0, 0] - pb[0, 0], pa[0, 1] - pb[0, 1]
        best = dx * dx + dy * dy
    return best


@inner_kernel(error_model="numpy")
def _plan_clears_wall(
    p: FloatArray, n: int, cx: float, cy: float, dx: float, dy: float, reach: float
) -> bool:
    """Whether the plan p[:n] (straight between substeps) keeps more than reach (m) from
    the wall segment [c, d] (m)."""
    r2 = reach * reach
    for j in range(n - 1):
        if segment_segment_dist2(p[j, 0], p[j, 1], p[j + 1, 0], p[j + 1, 1], cx, cy, dx, dy) < r2:
            return False
    return True


@inner_kernel(error_model="numpy")
def tube_reference(
    px: float,
    py: float,
    vx: float,
    vy: float,
    free: int,
    a_max: float,
    v_max: float,
    dt: float,
    substeps: int,
    out: FloatArray,
) -> int:
    """The centre of a tube (see the module): from the state p (m), v (m/s) known
    (free - 1) periods ago, coasting (no acceleration) for ``free`` periods of dt (s),
    then braking to a standstill as the world does, into out (substep positions, the
    start first; out must hold (free + 1) * substeps + :func:`max_plan_points`);
    returns the number of points."""
    h = dt / substeps
    vx, vy, _ = limit_norm(vx, vy, v_max)
    out[0, 0] = px
    out[0, 1] = py
    k = np.int64(1)
    for _ in range(free):
        px, py, vx, vy, k = _period(px, py, vx, vy, 0.0, 0.0, math.inf, h, substeps, out, k)
    return _brake_to_stop(px, py, vx, vy, a_max, dt, substeps, out, k)


@inner_kernel(error_model="numpy")
def tube_clearance(
    plan: FloatArray,
    n_plan: int,
    ref: FloatArray,
    n_ref: int,
    speed: float,
    free: int,
    a_max: float,
    v_max: float,
    dt: float,
    substeps: int,
    noise: Noise,
) -> float:
    """The smallest distance (m) between a plan (points plan[:n_plan], from now; straight
    between substeps; it stands at its last point once ended) and another robot's tube
    (see the module): around ref[:n_ref] (:func:`tube_reference` of a state with
    ``speed`` m/s known (free - 1) periods ago), of radius

    - a_max tau^2 / 2 while the robot is free (tau <= T = free dt, from the known state);
    - then growing by min(a_max T, s(tau) + s_ref(tau)) per unit time, where s and s_ref
      bound the speeds of any braking plan and of the centre (each at most its speed at
      T less a_max (tau - T - dt));

    plus ``sigmas`` (spread_p + spread_v tau) for the noise on the known state (m, m/s;
    :class:`Noise`). Negative: the plan enters the tube. Each substep's segment counts
    with the radius at its end (it never shrinks)."""
    spread_p, spread_v, sigmas = noise.spread_p, noise.spread_v, noise.sigmas
    h = dt / substeps
    offset = (free - 1) * substeps
    big_t = free * dt
    noise_v = sigmas * spread_v
    v0 = min(speed + noise_v, v_max)
    v_any = min(v_max, v0 + a_max * big_t)  # fastest any plan can be at T
    stop = big_t + v_any / a_max + dt  # every plan stands still by then
    last = max(n_plan - 1, n_ref - 1 - offset, int(math.ceil(stop / h)) - offset, 1)
    rho = 0.0
    best = math.inf
    for k in range(last):
        i0, i1 = min(k, n_plan - 1), min(k + 1, n_plan - 1)
        j0, j1 = min(k + offset, n_ref - 1), min(k + 1 + offset, n_ref - 1)
        d2 = point_segment_dist2(
            plan[i0, 0] - ref[j0, 0],
            plan[i0, 1] - ref[j0, 1],
            plan[i1, 0] - ref[j1, 0],
            plan[i1, 1] - ref[j1, 1],
        )
        tau = (k + 1 + offset) * h
        if tau <= big_t:
            rho = 0.5 * a_max * tau * tau
        else:
            late = tau - big_t - dt
            s_any = max(0.0, v_any - a_max * late)
            s_ref = max(0.0, v0 - a_max * late)
            rho += h * min(a_max * big_t, s_any + s_ref)
        widened = rho + sigmas * spread_p + noise_v * min(tau, stop)
        best = min(best, math.sqrt(d2) - widened)
    return best


@inner_kernel(error_model="numpy")
def _tube_conflicts(
    i: int,
    want: FloatArray,
    n_want: int,
    ext: float,
    group: Group,
    dt: float,
    substeps: int,
    margin: float,
    know: Knowledge,
    scratch: FloatArray,
) -> bool:
    """Whether robot i's wanted plan (want[:n_want], reaching ext m from its centre)
    meets the tube (:func:`tube_clearance`) of a robot of the group it knows of and is
    not linked with (:class:`Knowledge`) at the sum of the radii plus margin (m)."""
    pos, radius, a_max, v_max = group.position, group.radius, group.a_max, group.v_max
    n = pos.shape[0]
    for j in range(n):
        f = know.free[i, j]
        if j == i or f <= 0 or f > FORGET_PERIODS or know.linked[i, j]:
            continue
        px, py = know.position[i, j, 0], know.position[i, j, 1]
        vx, vy = know.velocity[i, j, 0], know.velocity[i, j, 1]
        sp, sv = know.spread[i, j, 0], know.spread[i, j, 1]
        reach = radius[i] + radius[j] + margin
        horizon = f * dt + v_max[j] / a_max[j] + dt
        # every plan of j stays within v_max horizon (and the noise) of the known state
        far = reach + ext + v_max[j] * horizon + know.sigmas * (sp + sv * horizon)
        dx, dy = px - pos[i, 0], py - pos[i, 1]
        if dx * dx + dy * dy > far * far:
            continue
        speed = math.hypot(vx, vy)
        need = (f + 1) * substeps + max_plan_points(min(speed, v_max[j]), a_max[j], dt, substeps)
        if scratch.shape[0] < need:
            scratch = np.empty((need, 2))
        n_ref = tube_reference(px, py, vx, vy, f, a_max[j], v_max[j], dt, substeps, scratch)
        clear = tube_clearance(
            want,
            n_want,
            scratch,
            n_ref,
            speed,
            f,
            a_max[j],
            v_max[j],
            dt,
            substeps,
            Noise(sp, sv, know.sigmas),
        )
        if clear < reach:
            return True
    return False


@inner_kernel
def _largest(values: FloatArray) -> float:
    """``np.max(values)``: the largest of values (n >= 1), NaN if any is NaN (a loop:
    numba's ``np.max`` links a ``take`` of its own into the caller)."""
    if values.shape[0] == 0:
        raise ValueError("zero-size array to reduction operation maximum which has no identity")
    top = values[0]
    for i in range(1, values.shape[0]):
        x = values[i]
        if x != x:
            return x
        if x > top:
            top = x
    return top


@inner_kernel(error_model="numpy")
def _near_pairs(
    pos: FloatArray, ext: FloatArray, radius: FloatArray, margin: float
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """CSR lists (start, index) of the robots whose plans could come within margin (m) of
    robot i's: centres closer than the radii + margin + both plans' extents ext (m), in
    index order; found through the neighbour index (:mod:`nao_arena.neighbours`: a
    uniform grid of cells at least as wide as the largest such reach)."""
    n = pos.shape[0]
    x0, y0, x1, y1 = extent(pos)
    # bounds |radius_i + radius_j + margin + ext_i + ext_j| (radii and extents >= 0)
    widest = 2.0 * (_largest(ext) + _largest(radius)) + abs(margin)
    h, gx, gy = range_grid(widest, n, x0, y0, x1, y1)
    cell, cell_start, members = grid(pos, x0, y0, h, gx, gy)
    near = np.empty(n, dtype=np.int64)
    start = np.zeros(n + 1, dtype=np.int64)
    index = np.empty(16 * n, dtype=np.int64)
    m = 0
    for i in range(n):
        c_n = around(cell[i], cell_start, members, gx, gy, near)
        for q in range(c_n):
            j = near[q]
            if j == i:
                continue
            dx, dy = pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1]
            reach = radius[i] + radius[j] + margin + ext[i] + ext[j]
            if dx * dx + dy * dy <= reach * reach:
                if m == index.shape[0]:
                    grown = np.empty(2 * m, dtype=np.int64)
                    for c in range(m):  # no broadcasting (its checks compile long)
                        grown[c] = index[c]
                    index = grown
                index[m] = j
                m += 1
        start[i + 1] = m
    return start, index[:m]


@kernel(error_model="numpy")
def commit_plans_kernel(
    group: Group,
    desired: FloatArray,
    dt: float,
    substeps: int,
    margin: float,
    walls: FloatArray,
    wall_half: FloatArray,
    know: Knowledge,
    brake: NDArray[np.bool_],
    braking: FloatArray,
) -> int:
    """:func:`commit_plans` on arrays: the robots (:class:`Group`), their desired
    accelerations (n, 2) m/s^2; writes brake (n,) and the standing plans'
    accelerations braking (n, 2), returns the number of pair checks made (nothing is
    written, and 0 returned, when a position, velocity or desired acceleration is not
    finite). ``know``: what the robots know of each other (:class:`Knowledge`; every
    pair linked when its ``linked`` is empty)."""
    pos, vel, radius = group.position, group.velocity, group.radius
    a_max, v_max = group.a_max, group.v_max
    n = pos.shape[0]
    if n == 0:
        return 0
    for i in range(n):
        if not (
            math.isfinite(pos[i, 0])
            and math.isfinite(pos[i, 1])
            and math.isfinite(vel[i, 0])
            and math.isfinite(vel[i, 1])
            and math.isfinite(desired[i, 0])
            and math.isfinite(desired[i, 1])
        ):
            return 0
    # the longest plan: that of the robot with the most speed per a_max (the first of equals)
    k = 0
    best = -math.inf
    for i in range(n):
        ratio = min(math.hypot(vel[i, 0], vel[i, 1]), v_max[i]) / a_max[i]
        if ratio > best:
            best = ratio
            k = i
    points = max_plan_points(
        min(math.hypot(vel[k, 0], vel[k, 1]), v_max[k]), a_max[k], dt, substeps
    )
    want = np.empty((n, points, 2))
    stand = np.empty((n, points, 2))
    n_want = np.empty(n, dtype=np.int64)
    n_stand = np.empty(n, dtype=np.int64)
    ext = np.zeros(n)
    for i in range(n):
        n_want[i] = _fill_plan(
            pos[i, 0],
            pos[i, 1],
            vel[i, 0],
            vel[i, 1],
            desired[i, 0],
            desired[i, 1],
            a_max[i],
            v_max[i],
            dt,
            substeps,
            want[i],
        )
        # zero at rest (the velocities are finite: checked above)
        bx, by = braking_accel(vel[i, 0], vel[i, 1], a_max[i], dt)
        braking[i, 0], braking[i, 1] = bx, by
        n_stand[i] = _fill_plan(
            pos[i, 0],
            pos[i, 1],
            vel[i, 0],
            vel[i, 1],
            bx,
            by,
            a_max[i],
            v_max[i],
            dt,
            substeps,
            stand[i],
        )
        far2 = 0.0
        for k in range(n_want[i]):
            dx, dy = want[i, k, 0] - pos[i, 0], want[i, k, 1] - pos[i, 1]
            far2 = max(far2, dx * dx + dy * dy)
        for k in range(n_stand[i]):
            dx, dy = stand[i, k, 0] - pos[i, 0], stand[i, k, 1] - pos[i, 1]
            far2 = max(far2, dx * dx + dy * dy)
        ext[i] = math.sqrt(far2)
    # a wanted plan that meets a wall is out (walls within reach of the plan only)
    near = np.empty(walls.shape[0], dtype=np.bool_)
    for i in range(n):
        m = 0
        for w in range(walls.shape[0]):
            d2 = point_segment_dist2(
                walls[w, 0, 0] - pos[i, 0],
                walls[w, 0, 1] - pos[i, 1],
                walls[w, 1, 0] - pos[i, 0],
                walls[w, 1, 1] - pos[i, 1],
            )
            reach = radius[i] + wall_half[w] + margin + ext[i]
            near[w] = d2 <= reach * reach
            m += near[w]
        if m == 0:
            continue
        for w in range(walls.shape[0]):
            if near[w] and not _plan_clears_wall(
                want[i],
                n_want[i],
                walls[w, 0, 0],
                walls[w, 0, 1],
                walls[w, 1, 0],
                walls[w, 1, 1],
                radius[i] + wall_half[w] + margin,
            ):
                brake[i] = True
                break
    every = know.linked.shape[0] == 0
    if not every:
        # a pair not linked: the wanted plan must clear every plan the other could be on
        scratch = np.empty((points, 2))
        for i in range(n):
            if not brake[i] and _tube_conflicts(
                i,
                want[i],
                n_want[i],
                ext[i],
                group,
                dt,
                substeps,
                margin,
                know,
                scratch,
            ):
                brake[i] = True
    nb_start, nb_index = _near_pairs(pos, ext, radius, margin)
    h2 = (dt / substeps) ** 2
    checks = 0
    changed = True
    while changed:
        changed = False
        for i in range(n):
            if brake[i]:
                continue
            for q in range(nb_start[i], nb_start[i + 1]):
                j = nb_index[q]
                if not every and not know.linked[i, j]:
                    continue
                reach = radius[i] + radius[j] + margin
                # a period's relative path strays from its chord by at most
                # (a_i + a_j) dt^2 / 8 (second differences of h^2 (a_i + a_j))
                skip = (a_max[i] + a_max[j]) * h2 * substeps * substeps / 8.0 + 1e-12
                checks += 1
                if brake[j]:
                    d2 = _pair_min_dist2(
                        want[i], n_want[i], stand[j], n_stand[j], substeps, reach * reach, skip
                    )
                else:
                    d2 = _pair_min_dist2(
                        want[i], n_want[i], want[j], n_want[j], substeps, reach * reach, skip
                    )
                if d2 < reach * reach:
                    brake[i] = True
                    changed = True
                    break
    return checks


def stopping_plan(
    position: NDArray[np.float64],
    velocity: NDArray[np.float64],
    accel: NDArray[np.float64],
    a_max: float,
    v_max: float,
    dt: float,
    substeps: int,
) -> FloatArray:
    """The stopping plan of a robot at ``position`` (m) with ``velocity`` (m/s) that
    drives ``accel`` (m/s^2) for one period dt (s) and then brakes to a standstill:
    its positions (P, 2) m at every substep, the start first."""
    speed = min(float(np.hypot(*velocity)), v_max)
    out = np.empty((max_plan_points(speed, a_max, dt, substeps), 2))
    n = _fill_plan(
        float(position[0]),
        float(position[1]),
        float(velocity[0]),
        float(velocity[1]),
        float(accel[0]),
        float(accel[1]),
        float(a_max),
        float(v_max),
        float(dt),
        int(substeps),
        out,
    )
    return out[:n].copy()


def plan_clearance(plan_a: FloatArray, plan_b: FloatArray, substeps: int) -> float:
    """Smallest distance (m) between the centres of two robots driving their plans
    (:func:`stopping_plan`, same dt and substeps); a plan that ended stands still."""
    a = np.ascontiguousarray(plan_a, dtype=np.float64)
    b = np.ascontiguousarray(plan_b, dtype=np.float64)
    return math.sqrt(_pair_min_dist2(a, len(a), b, len(b), int(substeps), -1.0, -1.0))


def commit_plans(
    positions: FloatArray,
    velocities: FloatArray,
    desired: FloatArray,
    radii: FloatArray,
    a_max: FloatArray,
    v_max: FloatArray,
    dt: float,
    substeps: int,
    margin: float,
    walls: FloatArray | None = None,
    wall_half: FloatArray | None = None,
    know: Knowledge | None = None,
) -> tuple[NDArray[np.bool_], FloatArray]:
    """Which robots of a group must brake (True) instead of driving their desired
    acceleration (see the module docstring), and each robot's braking acceleration
    (n, 2) m/s^2 (its standing plan's: -min(a_max, |v| / dt) v / |v|, zero at rest).

    positions (n, 2) m, velocities (n, 2) m/s, desired (n, 2) m/s^2, radii (m), a_max
    (m/s^2), v_max (m/s) (n,); dt (s) and substeps of the world; margin (m) kept beyond
    the sum of the radii (and beyond radius + half-thickness from the walls: segments
    (W, 2, 2) m with half-thicknesses wall_half (W,) m). Every pair of the group is
    considered (found through a grid, not through sensing). ``know``: what the robots
    know of each other under imperfect communication (:class:`Knowledge`); None: every
    pair linked.
    """
    n = len(positions)
    if walls is None or wall_half is None:
        walls, wall_half = np.zeros((0, 2, 2)), np.zeros(0)
    brake = np.zeros(n, dtype=np.bool_)
    braking = np.zeros((n, 2))
    f = np.ascontiguousarray
    commit_plans_kernel(
        Group(
            f(positions, dtype=np.float64),
            f(velocities, dtype=np.float64),
            f(radii, dtype=np.float64),
            f(a_max, dtype=np.float64),
            f(v_max, dtype=np.float64),
        ),
        f(desired, dtype=np.float64),
        float(dt),
        int(substeps),
        float(margin),
        f(walls, dtype=np.float64).reshape(-1, 2, 2),
        f(wall_half, dtype=np.float64),
        no_knowledge() if know is None else know,
        brake,
        braking,
    )
    return brake, braking
