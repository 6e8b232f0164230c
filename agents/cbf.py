"""``cbf``: safety barrier certificates for double integrators (Wang, Ames, Egerstedt 2017).

The robot tracks the goal-seeking acceleration of :mod:`nao_arena.agents.goal` (u_nom,
m/s^2; options v_pref and time_constant as :class:`~nao_arena.agents.goal.GoalAgent`'s)
as closely as the barrier constraints of its neighbours and the walls allow: each control
step it solves the quadratic program

    minimise |u - u_nom|^2  subject to  a_k . u <= c_k  (every constraint row k)
                                        |u| <= a_max    (Euclidean, m/s^2)

exactly (a 2-D problem; see "The QP" below). This is the decentralized safety barrier
certificate of L. Wang, A. D. Ames and M. Egerstedt, "Safety barrier certificates for
collisions-free multirobot systems", IEEE T-RO 33(3), 2017, built on the braking
distance.

The barrier (one pair i, j)
---------------------------
dp = p_i - p_j (m), dv = v_i - v_j (m/s), du = u_i - u_j (m/s^2), d = |dp| (m), n = dp / d,
D_s = r_i + r_j + margin (m), g = d - D_s (m), alpha = the relative braking acceleration
the pair counts on (m/s^2).

If both brake along the line of centres n0 (robot i along +n0, j along -n0) with a
relative acceleration alpha, n0 . dp(t) = d + (n0 . dv) t + alpha t^2 / 2, whose minimum
over t is d - w^2 / (2 alpha) for an approach speed w = -n0 . dv > 0; and |dp(t)| >=
n0 . dp(t). So the pair can still avoid contact whenever w <= sqrt(2 alpha g), i.e.
whenever

    h = sqrt(2 alpha g) + n . dv >= 0      (m/s).

The paper writes sqrt(4 alpha (d - D_s)) with alpha the common per-robot limit: that is
this h with the pair's alpha = alpha + alpha. (sqrt(4 (a_i + a_j) g) would allow approach
speeds sqrt(2) times too high: a pair on its boundary would need twice the braking it
has.) Here alpha = braking (a_max_i + a_max_j) for two robots that both brake, and
braking a_max_i when only robot i does; ``braking`` (default 0.5, 1 is the paper's
exact limit) is the fraction of its limit a robot counts on for one pair, leaving the
rest for the other neighbours it may have to brake for at the same time (with 1, a robot
between two approaching neighbours that each ask for all of its braking has no feasible
acceleration).

Its time derivative along the double integrators (dp' = dv, dv' = du), for g > 0:

    h' = alpha (n . dv) / sqrt(2 alpha g) + (|dv|^2 - (n . dv)^2) / d + n . du   (m/s^2)

(d' = n . dv; d/dt (dp . dv / d) = (|dv|^2 + dp . du) / d - (dp . dv)^2 / d^3). The
certificate h' >= -gamma h^3 (option gamma > 0, in s/m^2: h^3 is m^3/s^3 and h' m/s^2)
is linear in the accelerations; multiplied by d > 0:

    -dp . u_i + dp . u_j <= b,
    b = gamma h^3 d + (n x dv)^2 + alpha (dp . dv) / sqrt(2 alpha g)      (m^2/s^2)

((n x dv)^2 = |dv|^2 - (dv . dp)^2 / d^2, the squared tangential relative speed; with
alpha -> alpha / 2 this is the paper's b). Each row is stored normalised by d: a = -n
(unit), c = b / d (m/s^2), so that a row's violation a . u - c is in m/s^2; with the
other's part in, c - a . u_i = h' + gamma h^3.

Who takes which part
--------------------
- Robot neighbours (kind "robot"), with option ``reciprocal`` (default True): assumed to
  run this same reciprocal controller. Robot i takes the share a_max_i / (a_max_i +
  a_max_j) of b: -dp . u_i <= share b; j, doing the same with the same b (b is symmetric
  in i and j), takes the rest, so that the pair's constraint holds. An observation does
  not tell a neighbour's a_max, so it is assumed equal to the robot's own: alpha =
  2 braking a_max_i and the share is 1/2 (the paper's homogeneous case). A robot
  neighbour whose agent does not reciprocate is not told apart: against it the robot
  does only its half (``reciprocal=False`` treats every robot as non-cooperative).
- Non-cooperative bodies (traffic; every robot too with ``reciprocal=False``): robot i
  takes the whole constraint, with u_j = the body's sensed acceleration a_j
  (``Neighbours.accelerations``, m/s^2; non-finite: 0), assumed to hold over the
  control period, and alpha = braking a_max_i alone (the body is assumed not to brake
  for the robot: the robot must be able to stop the approach on its own while the
  body keeps its velocity): -dp . u_i <= b - dp . a_j. Known paths and plans are not
  used.
- Walls (segments ``walls`` (W, 2, 2) m, half-thickness ``wall_radius`` (W,) m): static
  bodies (v_j = u_j = 0), whole constraint, alpha = braking a_max_i, D_s = r_i +
  wall_radius + margin, d measured to the nearest point q of the centre segment; walls
  whose surface is more than ``sensing_range`` m from the robot's centre are left out.
  The distance to a segment has gradient n = (p - q) / |p - q| and Hessian
  (I - n n^T) / d where q is an end point, 0 where q is interior: so near an end the row
  is the pair row of a static point, and along the segment's side the same row without
  the (n x v)^2 term (moving along a wall does not take the robot away from it). Both
  are exact.

Contact, the QP and its fallback
--------------------------------
- Contact (g <= 1e-9 m: within the margin, or touching; the barrier is undefined
  there): the row becomes n . u_i >= a_max_i (a = -n, c = -a_max_i): the robot must
  accelerate straight out of the contact at its limit, the only point of its disc on
  that row. n = dp / d (coincident centres: against dv, else +x). Counted (status).
- Rows whose c >= a_max can never bind (|a . u| <= a_max) and are left out.
- The QP is solved exactly by Seidel's incremental method in 2-D (the program RVO2's
  linearProgram2 solves for ORCA, written here for rows a . u <= c): start from u_nom
  projected onto the disc; at each row (in order: neighbours nearest first, then walls)
  the current point violates, the optimum of the rows so far lies on its line, where it
  is a clamped 1-D projection.
- Infeasible (the rows and the disc have no common point): the fallback finds the least
  largest violation s* = min over |u| <= a_max of max_k (a_k . u - c_k) (m/s^2; the 3-D
  program reduced to 2-D, as RVO2's linearProgram3), then returns the point nearest
  u_nom among those that violate no row by more than s* + 1e-9 m/s^2 (the same
  projection with every c_k raised by that). Counted (status, :class:`CBFStats`).
- Option ``detour`` (rad, default 0: off): when a row binds (u differs from u_nom), the
  QP is solved again with u_nom's target velocity turned clockwise by ``detour``
  (the goal-seeking heading offset), so that robots blocking each other symmetrically
  pass on their right instead of stopping face to face (the deadlock of CBFs in
  symmetric scenes). Not in the paper; off by default.

Not modelled: the world's speed limit (a body at v_max coasts instead of following a
command that would make it faster, see :mod:`nao_arena.world`): the applied acceleration
is then the command scaled by a factor in [0, 1], which still satisfies every row that
u = 0 satisfies (c >= 0); the zero-order hold over the control period dt (the rows are
continuous-time conditions; the margin and ``braking`` < 1 absorb the difference); and
bodies the robot does not sense (the map's sensing range and max_neighbours).

The computation is one compiled kernel (:func:`cbf_accelerations`): in the arena all
robots of the class act together (:meth:`CBFAgent.act_batch`, one call per step from the
bulk arrays), and :meth:`CBFAgent.act` passes one robot's observation, as a one-robot
:class:`~nao_arena.sensing.SensingBatch`, to the same code, so the two give the same
bits.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.agent import PanelAgent
from nao_arena.agents.goal import APPROACH_GAIN, Headings, goal_seeking_kernel
from nao_arena.jit import inner_kernel, kernel
from nao_arena.motion import limit_norm_sqrt
from nao_arena.sensing import Observation, SensingBatch

from ._kernel_inputs import (
    OptionTables,
    RobotTargets,
    act_rows,
    body_arrays,
    neighbour_lists,
    wall_segments,
)
from ._kernel_inputs import f64 as _f64
from ._kernel_inputs import i64 as _i64

__all__ = ["CBFAgent", "CBFStats", "cbf_accelerations", "constraint_rows", "solve_qp"]

CONTACT_GAP = 1e-9
"""Gap g = d - D_s (m) at or below which a pair counts as in contact (contact row)."""

RELAX_SLACK = 1e-9
"""How far (m/s^2) beyond the least largest violation the fallback's rows are raised."""

_BINDS = 1e-12  # squared change of u_nom, per a_max^2, above which a row counts as binding
_PARALLEL = 1e-12  # |sin| of the angle between two rows below which they count as parallel

# columns of the per-robot option matrix handed to the kernel
_GAMMA, _MARGIN, _V_PREF, _TIME_CONSTANT, _SENSING_RANGE, _BRAKE, _DETOUR = range(7)

_BRAKING = 0.5  # the goal-seeking nominal's braking fraction of a_max (as GoalAgent's)

# status bits (per robot and step)
RELAXED = 1
"""Status bit: the QP was infeasible and the fallback (least largest violation) was used."""
CONTACT = 2
"""Status bit: a neighbour or wall was in contact (g <= CONTACT_GAP): a contact row."""


# ---------------------------------------------------------------- rows


@inner_kernel(error_model="numpy")
def _pair_row(dpx, dpy, dvx, dvy, ds, alpha, gamma, share, ajx, ajy, a_max, curved):
    """Robot i's row a . u_i <= c against one body: dp = p_i - p_j (m), dv = v_i - v_j
    (m/s), D_s (m), braking alpha (m/s^2), gamma (s/m^2), the share of b robot i takes,
    the body's assumed acceleration a_j (m/s^2), robot i's a_max (m/s^2), and whether the
    tangential term (n x dv)^2 counts (False: the side of a wall). Returns (a_x, a_y, c,
    in contact)."""
    d = math.sqrt(dpx * dpx + dpy * dpy)
    gap = d - ds
    if not gap > CONTACT_GAP:
        if d > 0.0:
            nx = dpx / d
            ny = dpy / d
        else:
            vv = math.sqrt(dvx * dvx + dvy * dvy)
            if vv > 0.0:
                nx = -dvx / vv
                ny = -dvy / vv
            else:
                nx = 1.0
                ny = 0.0
        return -nx, -ny, -a_max, True
    nx = dpx / d
    ny = dpy / d
    s = nx * dvx + ny * dvy  # m/s: separation speed n . dv
    root = math.sqrt(2.0 * alpha * gap)  # m/s: the approach speed braking can cancel
    h = root + s
    c = gamma * h * h * h + alpha * s / root  # b / d without the tangential term
    if curved:
        t = nx * dvy - ny * dvx  # m/s: n x dv
        c += t * t / d
    return -nx, -ny, share * c - (nx * ajx + ny * ajy), False


class _RowSettings(NamedTuple):
    """How a robot's constraint rows are made: gamma (s/m^2), margin (m), reach (m: walls
    whose surface is within it count), brake (fraction of a_max), reciprocal (robots
    take half), drop (leave out the rows that cannot bind)."""

    gamma: float
    margin: float
    reach: float
    brake: float
    reciprocal: bool
    drop: bool


@kernel(error_model="numpy")
def _robot_rows(
    b,
    k,
    sensed,
    accelerations,
    neighbours,
    walls,
    settings,
    rows_a,
    rows_c,
):
    """The constraint rows of robot k (body b) into rows_a (.., 2), rows_c (..): its
    neighbours (nb_index[nb_start[k]:nb_start[k + 1]], in that order), then the walls
    whose surface is within ``reach`` m, in order; ``drop``: leave out rows that cannot
    bind (c >= a_max). ``sensed``: :class:`~nao_arena.agents._kernel_inputs.BodyArrays`;
    accelerations (N, 2) m/s^2; ``neighbours``:
    :class:`~nao_arena.geometry.kernels.IndexLists`; ``walls``:
    :class:`~nao_arena.geometry.kernels.WorldWalls`; ``settings``:
    :class:`_RowSettings`. Returns (number of rows, whether any is a contact row)."""
    reactive, positions, velocities, radii, a_max, _ = sensed
    nb_start, nb_index = neighbours
    walls, wall_radius = walls
    gamma, margin, reach, brake, reciprocal, drop = settings
    px = positions[b, 0]
    py = positions[b, 1]
    vx = velocities[b, 0]
    vy = velocities[b, 1]
    r = radii[b]
    am = a_max[b]
    m = 0
    contact = False
    for e in range(nb_start[k], nb_start[k + 1]):
        j = nb_index[e]
        if reciprocal and reactive[j]:
            alpha = 2.0 * brake * am  # a_max_j assumed equal to a_max_i
            share = 0.5  # a_max_i / alpha
            ajx = 0.0
            ajy = 0.0
        else:
            alpha = brake * am
            share = 1.0
            ajx = accelerations[j, 0]
            ajy = accelerations[j, 1]
            if not (math.isfinite(ajx) and math.isfinite(ajy)):
                ajx = 0.0
                ajy = 0.0
        gx, gy, c, touching = _pair_row(
            px - positions[j, 0],
            py - positions[j, 1],
            vx - velocities[j, 0],
            vy - velocities[j, 1],
            r + radii[j] + margin,
            alpha,
            gamma,
            share,
            ajx,
            ajy,
            am,
            True,
        )
        contact = contact or touching
        if drop and c >= am:
            continue
        rows_a[m, 0] = gx
        rows_a[m, 1] = gy
        rows_c[m] = c
        m += 1
    for w in range(walls.shape[0]):
        ax = walls[w, 0, 0]
        ay = walls[w, 0, 1]
        ex = walls[w, 1, 0] - ax
        ey = walls[w, 1, 1] - ay
        ll = ex * ex + ey * ey
        t = 0.0
        if ll > 0.0:
            t = ((px - ax) * ex + (py - ay) * ey) / ll
        interior = 0.0 < t < 1.0
        if not t > 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        dpx = px - (ax + t * ex)
        dpy = py - (ay + t * ey)
        d = math.sqrt(dpx * dpx + dpy * dpy)
        if d - wall_radius[w] - r > reach:
            continue
        gx, gy, c, touching = _pair_row(
            dpx,
            dpy,
            vx,
            vy,
            r + wall_radius[w] + margin,
            brake * am,
            gamma,
            1.0,
            0.0,
            0.0,
            am,
            not interior,
        )
        contact = contact or touching
        if drop and c >= am:
            continue
        rows_a[m, 0] = gx
        rows_a[m, 1] = gy
        rows_c[m] = c
        m += 1
    return m, contact


# ---------------------------------------------------------------- the 2-D programs


@inner_kernel(error_model="numpy")
def _on_line(rows_a, rows_c, k, radius):
    """Row k's line a . u = c within |u| <= radius and rows[:k]: (found, point x, y,
    direction x, y, lo, hi): the points are point + t direction for lo <= t <= hi."""
    gx = rows_a[k, 0]
    gy = rows_a[k, 1]
    c = rows_c[k]
    disc = radius * radius - c * c
    if disc < 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    half = math.sqrt(disc)
    px = c * gx
    py = c * gy
    wx = -gy
    wy = gx
    lo = -half
    hi = half
    for j in range(k):
        den = rows_a[j, 0] * wx + rows_a[j, 1] * wy
        num = rows_c[j] - (rows_a[j, 0] * px + rows_a[j, 1] * py)
        if abs(den) <= _PARALLEL:
            if num < -_PARALLEL * (1.0 + abs(rows_c[j]) + abs(c)):
                return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            continue
        t = num / den
        if den > 0.0:
            if t < hi:
                hi = t
        elif t > lo:
            lo = t
        if lo > hi:
            return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return True, px, py, wx, wy, lo, hi


@inner_kernel(error_model="numpy")
def _seidel(rows_a, rows_c, m, radius, ox, oy, direction):
    """The point of |u| <= radius and rows[:m] nearest (ox, oy) (direction False), or
    furthest along the unit vector (ox, oy) (True): (index of the first row that could
    not be met, or m; x; y). Seidel's incremental 2-D program in the order of the rows."""
    if direction:
        x = ox * radius
        y = oy * radius
    else:
        x = ox
        y = oy
        n2 = ox * ox + oy * oy
        if n2 > radius * radius:
            f = radius / math.sqrt(n2)
            x = ox * f
            y = oy * f
    for k in range(m):
        if rows_a[k, 0] * x + rows_a[k, 1] * y > rows_c[k]:
            found, px, py, wx, wy, lo, hi = _on_line(rows_a, rows_c, k, radius)
            if not found:
                return k, x, y
            if direction:
                t = hi if ox * wx + oy * wy > 0.0 else lo
            else:
                t = wx * (ox - px) + wy * (oy - py)
                if t < lo:
                    t = lo
                if t > hi:
                    t = hi
            x = px + t * wx
            y = py + t * wy
    return m, x, y


@inner_kernel(error_model="numpy")
def _least_violation(rows_a, rows_c, m, begin, radius, x, y, pa, pc):
    """From (x, y), which meets rows[:begin], the point of |u| <= radius whose largest
    violation max_k (a_k . u - c_k) over rows[:m] is least (RVO2's linearProgram3 for
    rows a . u <= c); pa, pc: scratch (>= m) for the projected rows."""
    worst = 0.0
    for i in range(begin, m):
        gix = rows_a[i, 0]
        giy = rows_a[i, 1]
        if gix * x + giy * y - rows_c[i] > worst:
            # where row j is violated no more than row i: (a_j - a_i) . u <= c_j - c_i
            q = 0
            for j in range(i):
                ex = rows_a[j, 0] - gix
                ey = rows_a[j, 1] - giy
                nn = math.sqrt(ex * ex + ey * ey)
                if nn <= _PARALLEL:
                    continue  # the same direction: row j is never the larger violation here
                pa[q, 0] = ex / nn
                pa[q, 1] = ey / nn
                pc[q] = (rows_c[j] - rows_c[i]) / nn
                q += 1
            fail, cx, cy = _seidel(pa, pc, q, radius, -gix, -giy, True)
            if fail == q:
                x = cx
                y = cy
            worst = gix * x + giy * y - rows_c[i]
    return x, y


@kernel(error_model="numpy")
def _qp(rows_a, rows_c, m, radius, ox, oy, lifted, pa, pc):
    """The QP: the point of |u| <= radius meeting rows[:m] nearest (ox, oy), else the
    fallback (see the module docstring): (x, y, relaxed, largest violation s* (m/s^2,
    0 when feasible)); lifted, pa, pc: scratch (>= m)."""
    fail, x, y = _seidel(rows_a, rows_c, m, radius, ox, oy, False)
    if fail == m:
        return x, y, False, 0.0
    x, y = _least_violation(rows_a, rows_c, m, fail, radius, x, y, pa, pc)
    worst = 0.0
    for k in range(m):
        v = rows_a[k, 0] * x + rows_a[k, 1] * y - rows_c[k]
        if v > worst:
            worst = v
    for k in range(m):
        lifted[k] = rows_c[k] + (worst + RELAX_SLACK)
    fail, nx, ny = _seidel(rows_a, lifted, m, radius, ox, oy, False)
    if fail == m:
        x = nx
        y = ny
    return x, y, True, worst


# ---------------------------------------------------------------- kernel


@kernel(error_model="numpy")
def cbf_accelerations(
    sensed,
    accelerations,
    robots,
    neighbours,
    rows,
    walls,
    options,
    has_v_pref,
    reciprocal,
    out,
    status,
    violation,
):
    """CBF accelerations of the robots ``rows`` (robot order) into out (len(rows), 2)
    m/s^2, with each one's status bits (RELAXED, CONTACT) and largest violation (m/s^2).

    Bodies (N): ``sensed`` (:class:`~nao_arena.agents._kernel_inputs.BodyArrays`), their
    accelerations (N, 2) m/s^2. Robots (R): ``robots``
    (:class:`~nao_arena.agents._kernel_inputs.RobotTargets`), their ``neighbours``
    (:class:`~nao_arena.geometry.kernels.IndexLists`). ``walls``:
    :class:`~nao_arena.geometry.kernels.WorldWalls`. Per row: options (rows, 7):
    gamma (s/m^2), margin (m), v_pref (m/s; used where has_v_pref), time_constant (s),
    sensing_range (m; walls), braking (fraction of a_max), detour (rad); reciprocal
    (rows,).
    """
    reactive, positions, velocities, radii, a_max, v_max = sensed
    bodies, targets, has_target = robots
    nb_start, nb_index = neighbours
    n = rows.shape[0]
    # the nominal: goal seeking (agents/goal.py), all rows at once
    tg = np.empty((n, 2))
    pos = np.empty((n, 2))
    vel = np.empty((n, 2))
    am = np.empty(n)
    cap = np.empty(n)
    tau = np.empty(n)
    has = np.empty(n, dtype=np.bool_)
    zero = np.zeros(n)
    offset = np.empty(n)
    cos_off = np.empty(n)
    sin_off = np.empty(n)
    nominal = np.empty((n, 2))
    turned = np.empty((n, 2))
    most = 0
    for i in range(n):
        k = rows[i]
        b = bodies[k]
        pos[i, 0] = positions[b, 0]
        pos[i, 1] = positions[b, 1]
        vel[i, 0] = velocities[b, 0]
        vel[i, 1] = velocities[b, 1]
        has[i] = has_target[k]
        tg[i, 0] = targets[k, 0] if has[i] else pos[i, 0]
        tg[i, 1] = targets[k, 1] if has[i] else pos[i, 1]
        am[i] = a_max[b]
        vm = v_max[b]
        cap[i] = vm
        if has_v_pref[i]:
            vp = options[i, _V_PREF]
            cap[i] = vp if vp < vm else vm
        tau[i] = options[i, _TIME_CONSTANT]
        offset[i] = -options[i, _DETOUR]  # clockwise: pass on the right
        cos_off[i] = math.cos(offset[i])
        sin_off[i] = math.sin(offset[i])
        most = max(most, nb_start[k + 1] - nb_start[k])
    straight = Headings(zero, zero, zero)
    goal_seeking_kernel(tg, pos, vel, am, cap, straight, tau, _BRAKING, APPROACH_GAIN, has, nominal)
    detour = Headings(offset, cos_off, sin_off)
    goal_seeking_kernel(tg, pos, vel, am, cap, detour, tau, _BRAKING, APPROACH_GAIN, has, turned)
    most += walls.ends.shape[0]
    rows_a = np.empty((most, 2))
    rows_c = np.empty(most)
    lifted = np.empty(most)
    pa = np.empty((most, 2))
    pc = np.empty(most)
    for i in range(n):
        k = rows[i]
        b = bodies[k]
        settings = _RowSettings(
            options[i, _GAMMA],
            options[i, _MARGIN],
            options[i, _SENSING_RANGE],
            options[i, _BRAKE],
            reciprocal[i],
            True,
        )
        m, contact = _robot_rows(
            b, k, sensed, accelerations, neighbours, walls, settings, rows_a, rows_c
        )
        radius = a_max[b]
        nx = nominal[i, 0]
        ny = nominal[i, 1]
        x, y, relaxed, worst = _qp(rows_a, rows_c, m, radius, nx, ny, lifted, pa, pc)
        if (
            offset[i] != 0.0
            and (x - nx) * (x - nx) + (y - ny) * (y - ny) > _BINDS * radius * radius
        ):
            # a row binds: track the goal direction turned by the detour instead
            x, y, relaxed, worst = _qp(
                rows_a, rows_c, m, radius, turned[i, 0], turned[i, 1], lifted, pa, pc
            )
        # within a_max = radius but for rounding (the world would scale it anyway)
        x, y, _ = limit_norm_sqrt(x, y, radius)
        out[i, 0] = x
        out[i, 1] = y
        status[i] = (RELAXED if relaxed else 0) | (CONTACT if contact else 0)
        violation[i] = worst


# ---------------------------------------------------------------- test and debug views


def constraint_rows(
    batch: SensingBatch,
    k: int,
    gamma: float = 1.0,
    margin: float = 0.05,
    sensing_range: float = math.inf,
    braking: float = 1.0,
    reciprocal: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    """The rows a . u <= c (a (m, 2) unit, c (m,) m/s^2) that robot k of ``batch`` gets,
    every one kept (the kernel leaves out those with c >= a_max): its neighbours in
    their order, then the walls within ``sensing_range`` m, in order; and whether one is
    a contact row. The kernel's own code (:func:`_robot_rows`)."""
    nb = int(batch.nb_start[k + 1] - batch.nb_start[k]) + len(batch.walls)
    rows_a = np.empty((nb, 2))
    rows_c = np.empty(nb)
    settings = _RowSettings(
        float(gamma), float(margin), float(sensing_range), float(braking), bool(reciprocal), False
    )
    m, contact = _robot_rows(
        int(batch.bodies[k]),
        int(k),
        body_arrays(batch),
        _f64(batch.accelerations),
        neighbour_lists(batch),
        wall_segments(batch),
        settings,
        rows_a,
        rows_c,
    )
    return rows_a[:m], rows_c[:m], bool(contact)


def solve_qp(
    rows_a: NDArray[np.float64],
    rows_c: NDArray[np.float64],
    a_max: float,
    nominal: NDArray[np.float64],
) -> tuple[NDArray[np.float64], bool, float]:
    """The kernel's program on given rows a . u <= c (a (m, 2) unit normals, c (m,)
    m/s^2) and disc |u| <= a_max (m/s^2): (u (2,) m/s^2, whether it was infeasible (the
    fallback), the least largest violation (m/s^2))."""
    rows_a = np.ascontiguousarray(rows_a, dtype=np.float64).reshape(-1, 2)
    rows_c = np.ascontiguousarray(rows_c, dtype=np.float64).reshape(-1)
    m = len(rows_c)
    x, y, relaxed, worst = _qp(
        rows_a,
        rows_c,
        m,
        float(a_max),
        float(nominal[0]),
        float(nominal[1]),
        np.empty(m),
        np.empty((m, 2)),
        np.empty(m),
    )
    return np.array([x, y]), bool(relaxed), float(worst)


# ---------------------------------------------------------------- agent


def _number(name: str, value: Any, low: float, strict: bool, unit: str, finite: bool) -> float:
    """``value`` as a float > low (strict) or >= low (and finite if ``finite``); else
    ValueError naming the option."""
    bad = isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))
    x = math.nan
    if not bad:
        x = float(value)
        bad = math.isnan(x) or (x <= low if strict else x < low) or (finite and math.isinf(x))
    if bad:
        rel = ">" if strict else ">="
        kind = "a finite number" if finite else "a number"
        raise ValueError(
            f"cbf option {name}: expected {kind} {rel} {low:g} ({unit}), got {value!r}"
        )
    return x


@dataclass
class CBFStats:
    """What one robot's CBF did since its agent's reset: control steps, steps whose QP
    was infeasible (the fallback: ``relaxed``), steps with a contact row (``contacts``),
    the largest violation of a relaxed step (m/s^2), and the last step's status."""

    steps: int = 0
    relaxed: int = 0
    contacts: int = 0
    worst_violation: float = 0.0
    last_status: str = "none"

    def record(self, status: int, violation: float) -> None:
        """Count one step's status bits and violation (m/s^2)."""
        self.steps += 1
        if status & RELAXED:
            self.relaxed += 1
            self.worst_violation = max(self.worst_violation, violation)
        if status & CONTACT:
            self.contacts += 1
        self.last_status = _STATUS_TEXT[status & (RELAXED | CONTACT)]


_STATUS_TEXT = ("ok", "relaxed", "contact", "contact, relaxed")


class CBFAgent:
    """Safety barrier certificates over goal seeking (see the module docstring).

    Options: gamma (s/m^2, > 0): the class-K gain of h' >= -gamma h^3; margin (m, >= 0):
    added to D_s; v_pref (m/s; None: v_max) and time_constant (s): the goal-seeking
    nominal's; sensing_range (m): walls whose surface is within it count; braking (in
    (0, 1]): the fraction of a_max the barrier counts on; detour (rad, [0, pi/2)): turn
    the nominal clockwise while a row binds (0: off); reciprocal: robot neighbours take
    their half (False: every body is non-cooperative). ``stats`` (:class:`CBFStats`)
    counts the infeasible steps and contact rows since :meth:`reset`."""

    def __init__(
        self,
        gamma: float = 1.0,
        margin: float = 0.05,
        v_pref: float | None = None,
        time_constant: float = 0.5,
        sensing_range: float = 30.0,
        braking: float = 0.5,
        detour: float = 0.0,
        reciprocal: bool = True,
    ) -> None:
        self.gamma = _number("gamma", gamma, 0.0, True, "s/m^2", True)
        self.margin = _number("margin", margin, 0.0, False, "m", True)
        self.v_pref = (
            None if v_pref is None else _number("v_pref", v_pref, 0.0, False, "m/s", False)
        )
        self.time_constant = _number("time_constant", time_constant, 0.0, True, "s", True)
        self.sensing_range = _number("sensing_range", sensing_range, 0.0, False, "m", False)
        self.braking = _number("braking", braking, 0.0, True, "fraction of a_max", True)
        if self.braking > 1.0:
            raise ValueError(
                f"cbf option braking: expected a fraction of a_max in (0, 1], got {braking!r}"
            )
        self.detour = _number("detour", detour, 0.0, False, "rad", True)
        if self.detour >= math.pi / 2:
            raise ValueError(
                f"cbf option detour: expected an angle in [0, pi/2) (rad), got {detour!r}"
            )
        if not isinstance(reciprocal, (bool, np.bool_)):
            raise ValueError(f"cbf option reciprocal: expected True or False, got {reciprocal!r}")
        self.reciprocal = bool(reciprocal)
        self.stats = CBFStats()

    def __setattr__(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)
        _option_table.clear()  # an option may have changed: the memoised option tables are stale

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """Fresh statistics (the controller itself is stateless)."""
        self.stats = CBFStats()

    def panel(self) -> PanelAgent:
        """What the viewer's acceleration panel shows: margin, v_pref, last status."""
        return PanelAgent(
            margin=float(self.margin), v_pref=self.v_pref, status=self.stats.last_status
        )

    def act(self, obs: Observation) -> NDArray[np.float64]:
        """The CBF acceleration (2,) m/s^2 of the robot ``obs`` describes (the kernel on
        the one-robot batch of ``obs``)."""
        batch = SensingBatch.of_observation(obs)
        return _batch_accelerations([self], batch, _ROW0)[0]

    @classmethod
    def act_batch(
        cls, agents: Sequence[CBFAgent], batch: SensingBatch, rows: Sequence[int]
    ) -> NDArray[np.float64] | list[NDArray[np.float64] | Exception]:
        """:meth:`act` for many robots at once, in one compiled call from the bulk arrays
        (the same accelerations, m/s^2): an array (len(rows), 2). Agents of a subclass
        with its own ``act`` act robot by robot: then one acceleration or exception per
        row (a list)."""
        return act_rows(agents, batch, rows, _ACT, _batch_accelerations)


_ACT = CBFAgent.act
_ROW0 = np.zeros(1, dtype=np.int64)
_OPTIONS = operator.attrgetter(
    "gamma", "margin", "v_pref", "time_constant", "sensing_range", "braking", "detour"
)

_Table = tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]


def _options_of(agents: Sequence[CBFAgent]) -> _Table:
    """The kernel's options of ``agents``: (n, 7) gamma, margin, v_pref (NaN: none),
    time_constant, sensing_range, braking, detour; whether v_pref is set; reciprocal."""
    table = np.array(
        [[math.nan if v is None else v for v in _OPTIONS(ag)] for ag in agents],
        dtype=np.float64,
    ).reshape(-1, 7)
    recip = np.array([ag.reciprocal for ag in agents], dtype=np.bool_)
    return table, ~np.isnan(table[:, _V_PREF]), recip


_option_table = OptionTables(_options_of)
""":func:`_options_of`, memoised per group of agents (see :class:`OptionTables`)."""


def _targets(
    batch: SensingBatch, rows: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Each robot's target (R, 2) m and whether it has one: its goal, else its route's
    last waypoint (:func:`nao_arena.agents.goal.goal_target`); only the rows' are looked
    at (the others' are the goals as they are)."""
    goals = np.array(batch.goals, dtype=np.float64)  # a copy: routes may fill in targets
    has = np.asarray(np.isfinite(goals).all(axis=1), dtype=np.bool_)
    if has[rows].all():
        return goals, has
    for k in rows.tolist():
        route = batch.routes[k]
        if not has[k] and route is not None and len(route):
            goals[k] = np.asarray(route, dtype=np.float64)[-1]
            has[k] = bool(np.isfinite(goals[k]).all())
    return goals, has


def _batch_accelerations(
    agents: Sequence[CBFAgent], batch: SensingBatch, rows: NDArray[np.int64]
) -> NDArray[np.float64]:
    """The kernel on the bulk arrays for ``agents`` at robot rows ``rows``: (n, 2)
    m/s^2; each agent's :class:`CBFStats` records its step."""
    options, has_v_pref, recip = _option_table(agents)
    targets, has_target = _targets(batch, rows)
    n = len(rows)
    out = np.empty((n, 2))
    status = np.empty(n, dtype=np.int64)
    violation = np.empty(n)
    cbf_accelerations(
        body_arrays(batch),
        _f64(batch.accelerations),
        RobotTargets(_i64(batch.bodies), targets, has_target),
        neighbour_lists(batch),
        rows,
        wall_segments(batch),
        options,
        has_v_pref,
        recip,
        out,
        status,
        violation,
    )
    for ag, s, v in zip(agents, status.tolist(), violation.tolist(), strict=True):
        ag.stats.record(s, v)
    return out
