"""``orca``: optimal reciprocal collision avoidance, tracked by acceleration.

Each neighbour contributes a half-plane of permitted velocities: the
smallest change u of the relative velocity that leaves the velocity
obstacle truncated at ``horizon`` s, shared half-and-half with other robots
(traffic and walls do not react, so the robot takes all of it). The new
velocity is the one nearest the preferred velocity inside all half-planes
and |v| <= v_max, found by an incremental 2-D linear program; when the
half-planes have no common point, the velocity that minimises the largest
violation. The acceleration that reaches it in ``time_constant`` s is
applied within a_max, so, unlike in the velocity-controlled original, the
acceleration limit may keep the robot from following its ORCA velocity.

The computation is one compiled kernel (:func:`orca_accelerations`): in the
arena all robots of the class act together (:meth:`ORCAAgent.act_batch`,
one call per step from the bulk arrays), and :meth:`ORCAAgent.act` passes
one robot's observation to the same kernel. Its floating-point operations
are those of the earlier numpy implementation (kept as the test reference),
with every 2-vector dot product a . b evaluated as fma(a1, b1, fma(a0, b0, 0))
(each fma rounded once), the order in which numpy's OpenBLAS dot evaluates
it on x86-64 with FMA, so the accelerations are the same to the bit there.
"""

from __future__ import annotations

import dataclasses
import math
import operator
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from numpy.typing import NDArray

from nao_arena.agent import PanelAgent
from nao_arena.geometry.kernels import IndexLists
from nao_arena.imperfection import subset
from nao_arena.jit import inner_kernel, kernel
from nao_arena.motion import limit_norm
from nao_arena.obstacles import NO_WALLS, wall_discs_memo
from nao_arena.sensing import Neighbours, Observation, SensingBatch

from ._kernel_inputs import (
    BodyArrays,
    OptionTables,
    RobotTargets,
    act_rows,
    body_arrays,
    neighbour_lists,
)
from ._kernel_inputs import f64 as _f64
from ._kernel_inputs import i64 as _i64
from ._kernel_inputs import robot_mask as _reactive
from .goal import goal_target

__all__ = ["ORCAAgent", "orca_accelerations"]

_EPS = 1e-9

# columns of the per-robot option matrix handed to the kernel
_HORIZON, _MARGIN, _V_PREF, _TIME_CONSTANT, _SENSING_RANGE = range(5)


# ---------------------------------------------------------------- kernel


@intrinsic
def _fma(typingctx, x, y, z):
    """x * y + z rounded once (IEEE 754 fused multiply-add) of three float64."""
    if not all(isinstance(a, types.Float) for a in (x, y, z)):
        return None
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        double = ir.DoubleType()
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(double, [double, double, double]), "llvm.fma.f64"
        )
        return builder.call(fn, args)

    return sig, codegen


@inner_kernel(error_model="numpy")
def _dot(ax, ay, bx, by):
    """a . b as fma(a1, b1, fma(a0, b0, 0)) (see the module docstring)."""
    return _fma(ay, by, _fma(ax, bx, 0.0))


@inner_kernel(error_model="numpy")
def _det(ax, ay, bx, by):
    return ax * by - ay * bx


@inner_kernel(error_model="numpy")
def _half_plane(rpx, rpy, rvx, rvy, radius, vx, vy, horizon, dt, share):
    """ORCA half-plane (point x, y; direction x, y: permitted velocities are on its left)
    for a neighbour at rel_pos (m) with relative velocity rel_vel = v_own - v_other
    (m/s); radius: combined radius (m); share: the part of the avoidance this robot
    takes (0.5 reciprocal, 1 against non-reacting obstacles); dt: control period (s),
    used when the discs already overlap."""
    dist2 = _dot(rpx, rpy, rpx, rpy)
    r2 = radius * radius
    if dist2 > r2:
        wx = rvx - rpx / horizon
        wy = rvy - rpy / horizon
        w2 = _dot(wx, wy, wx, wy)
        dot = _dot(wx, wy, rpx, rpy)
        if dot < 0.0 and dot * dot > r2 * w2:
            # nearest boundary point is on the truncation circle
            wl = math.sqrt(w2)
            ux = wx / wl
            uy = wy / wl
            dx = uy
            dy = -ux
            c = radius / horizon - wl
            ux = c * ux
            uy = c * uy
        else:
            leg = math.sqrt(dist2 - r2)
            if _det(rpx, rpy, wx, wy) > 0.0:
                dx = (rpx * leg - rpy * radius) / dist2
                dy = (rpx * radius + rpy * leg) / dist2
            else:
                dx = -(rpx * leg + rpy * radius) / dist2
                dy = -(-rpx * radius + rpy * leg) / dist2
            s = _dot(rvx, rvy, dx, dy)
            ux = s * dx - rvx
            uy = s * dy - rvy
    else:
        # already overlapping: leave within one control period
        wx = rvx - rpx / dt
        wy = rvy - rpy / dt
        wl = math.sqrt(_dot(wx, wy, wx, wy))
        if _EPS > wl:
            wl = _EPS
        ux = wx / wl
        uy = wy / wl
        dx = uy
        dy = -ux
        c = radius / dt - wl
        ux = c * ux
        uy = c * uy
    return vx + share * ux, vy + share * uy, dx, dy


@inner_kernel(error_model="numpy")
def _lp1(lp, ld, i, radius, ox, oy, direction_opt):
    """Best point on line i within |v| <= radius and lines[:i]: (found, x, y)."""
    px = lp[i, 0]
    py = lp[i, 1]
    dx = ld[i, 0]
    dy = ld[i, 1]
    dot = _dot(px, py, dx, dy)
    disc = dot * dot + radius * radius - _dot(px, py, px, py)
    if disc < 0.0:
        return False, 0.0, 0.0
    sq = math.sqrt(disc)
    t_left = -dot - sq
    t_right = -dot + sq
    for j in range(i):
        denom = _det(dx, dy, ld[j, 0], ld[j, 1])
        numer = _det(ld[j, 0], ld[j, 1], px - lp[j, 0], py - lp[j, 1])
        if abs(denom) <= _EPS:
            if numer < 0.0:
                return False, 0.0, 0.0
            continue
        t = numer / denom
        if denom >= 0.0:
            if t < t_right:
                t_right = t
        elif t > t_left:
            t_left = t
        if t_left > t_right:
            return False, 0.0, 0.0
    if direction_opt:
        t = t_right if _dot(ox, oy, dx, dy) > 0.0 else t_left
    else:
        t = _dot(dx, dy, ox - px, oy - py)
        if t_left > t:
            t = t_left
        if t_right < t:
            t = t_right
    return True, px + t * dx, py + t * dy


@inner_kernel(error_model="numpy")
def _lp2(lp, ld, n, radius, ox, oy, direction_opt):
    """Velocity nearest opt (or furthest along the direction opt) in lines[:n] and
    |v| <= radius: (index of the first line that could not be satisfied, or n; x; y)."""
    if direction_opt:
        rx = ox * radius
        ry = oy * radius
    elif _dot(ox, oy, ox, oy) > radius * radius:
        s = math.sqrt(_dot(ox, oy, ox, oy))
        rx = ox / s * radius
        ry = oy / s * radius
    else:
        rx = ox
        ry = oy
    for i in range(n):
        if _det(ld[i, 0], ld[i, 1], lp[i, 0] - rx, lp[i, 1] - ry) > 0.0:
            found, x, y = _lp1(lp, ld, i, radius, ox, oy, direction_opt)
            if not found:
                return i, rx, ry
            rx = x
            ry = y
    return n, rx, ry


@inner_kernel(error_model="numpy")
def _lp3(lp, ld, n, begin, radius, rx, ry, pp, pd):
    """Minimise the largest violation of lines[begin:n] (all soft here), from (rx, ry);
    pp, pd: scratch (>= n, 2) for the projected lines."""
    distance = 0.0
    for i in range(begin, n):
        pix = lp[i, 0]
        piy = lp[i, 1]
        dix = ld[i, 0]
        diy = ld[i, 1]
        if _det(dix, diy, pix - rx, piy - ry) > distance:
            m = 0
            for j in range(i):
                pjx = lp[j, 0]
                pjy = lp[j, 1]
                djx = ld[j, 0]
                djy = ld[j, 1]
                det = _det(dix, diy, djx, djy)
                if abs(det) <= _EPS:
                    if _dot(dix, diy, djx, djy) > 0.0:
                        continue
                    qx = 0.5 * (pix + pjx)
                    qy = 0.5 * (piy + pjy)
                else:
                    s = _det(djx, djy, pix - pjx, piy - pjy) / det
                    qx = pix + s * dix
                    qy = piy + s * diy
                ex = djx - dix
                ey = djy - diy
                nn = math.sqrt(_dot(ex, ey, ex, ey))
                if nn <= _EPS:
                    continue
                pp[m, 0] = qx
                pp[m, 1] = qy
                pd[m, 0] = ex / nn
                pd[m, 1] = ey / nn
                m += 1
            fail, cx, cy = _lp2(pp, pd, m, radius, -diy, dix, True)
            if fail == m:
                rx = cx
                ry = cy
            distance = _det(dix, diy, pix - rx, piy - ry)
    return rx, ry


@inner_kernel(error_model="numpy")
def _before(da, ia, db, ib):
    """Whether key (da, ia) sorts before (db, ib): by distance, NaN last, ties by index
    (numpy's stable argsort)."""
    if da < db:
        return True
    if da == db:
        return ia < ib
    if db != db and da == da:
        return True
    if db != db and da != da:
        return ia < ib
    return False


class WallDiscs(NamedTuple):
    """The walls as discs, in sets: centres (D, 2) m and radii (D,) m (grown by a robot's
    radius and margin), set s the discs ``start[s]:start[s + 1]``; the set of each row
    of a kernel call (rows,) (-1: none)."""

    centres: NDArray[np.float64]
    radii: NDArray[np.float64]
    start: NDArray[np.int64]
    of_row: NDArray[np.int64]


@kernel(error_model="numpy")
def orca_accelerations(
    sensed,
    robots,
    neighbours,
    rows,
    wall_discs,
    options,
    has_v_pref,
    limit,
    dt,
):
    """ORCA accelerations (len(rows), 2) m/s^2 of the robots ``rows`` (robot order).

    Bodies (N): ``sensed`` (:class:`~nao_arena.agents._kernel_inputs.BodyArrays`; the
    reactive ones take half of the avoidance). Robots (R): ``robots``
    (:class:`~nao_arena.agents._kernel_inputs.RobotTargets`: the goals), their
    ``neighbours`` (:class:`~nao_arena.geometry.kernels.IndexLists`). Per row:
    the wall discs of its set (:class:`WallDiscs`), options (rows, 5): horizon (s), margin (m),
    v_pref (m/s; used where has_v_pref), time_constant (s), sensing_range (m) (wall
    discs within it count), limit: how many of the nearest obstacles count (< 0: all).
    dt: control period (s).
    """
    reactive, positions, velocities, radii, a_max, v_max = sensed
    bodies, goals, has_goal = robots
    nb_start, nb_index = neighbours
    wall_c, wall_r, wall_start, wall_set = wall_discs
    n = rows.shape[0]
    out = np.zeros((n, 2))
    # scratch sized for the row with the most obstacles
    most = 0
    for i in range(n):
        k = rows[i]
        c = nb_start[k + 1] - nb_start[k]
        s = wall_set[i]
        if s >= 0:
            c += wall_start[s + 1] - wall_start[s]
        most = max(most, c)
    cp = np.empty((most, 2))
    cv = np.empty((most, 2))
    cr = np.empty(most)
    cs = np.empty(most)
    cd = np.empty(most)
    order = np.empty(most, dtype=np.int64)
    lp = np.empty((most, 2))
    ld = np.empty((most, 2))
    pp = np.empty((most, 2))
    pd = np.empty((most, 2))
    for i in range(n):
        k = rows[i]
        b = bodies[k]
        px = positions[b, 0]
        py = positions[b, 1]
        vx = velocities[b, 0]
        vy = velocities[b, 1]
        horizon = options[i, _HORIZON]
        # the obstacles: neighbours, then the wall discs within sensing range
        m = 0
        for e in range(nb_start[k], nb_start[k + 1]):
            j = nb_index[e]
            cp[m, 0] = positions[j, 0] - px
            cp[m, 1] = positions[j, 1] - py
            cv[m, 0] = velocities[j, 0]
            cv[m, 1] = velocities[j, 1]
            cr[m] = radii[j] + radii[b] + options[i, _MARGIN]
            cs[m] = 0.5 if reactive[j] else 1.0
            m += 1
        s = wall_set[i]
        if s >= 0:
            reach = options[i, _SENSING_RANGE]
            for w in range(wall_start[s], wall_start[s + 1]):
                wx = wall_c[w, 0] - px
                wy = wall_c[w, 1] - py
                if math.hypot(wx, wy) <= reach + wall_r[w]:
                    cp[m, 0] = wx
                    cp[m, 1] = wy
                    cv[m, 0] = 0.0
                    cv[m, 1] = 0.0
                    cr[m] = wall_r[w]
                    cs[m] = 1.0
                    m += 1
        # the nearest `limit` of them, nearest first (ties: in the order above)
        cap = m if limit[i] < 0 else min(limit[i], m)
        taken = 0
        for c in range(m):
            if taken == cap:
                if cap == 0:
                    break
                # hypot(x, y) >= max(|x|, |y|): no nearer than the last one taken
                worst = cd[order[cap - 1]]
                if max(abs(cp[c, 0]), abs(cp[c, 1])) >= worst:
                    continue
            cd[c] = math.hypot(cp[c, 0], cp[c, 1])
            if taken < cap:
                q = taken
                taken += 1
            elif cap > 0 and _before(cd[c], c, cd[order[cap - 1]], order[cap - 1]):
                q = cap - 1
            else:
                continue
            while q > 0 and _before(cd[c], c, cd[order[q - 1]], order[q - 1]):
                order[q] = order[q - 1]
                q -= 1
            order[q] = c
        for q in range(taken):
            c = order[q]
            x, y, ex, ey = _half_plane(
                cp[c, 0], cp[c, 1], vx - cv[c, 0], vy - cv[c, 1], cr[c], vx, vy, horizon, dt, cs[c]
            )
            lp[q, 0] = x
            lp[q, 1] = y
            ld[q, 0] = ex
            ld[q, 1] = ey
        # the preferred velocity: toward the goal, slowing down to stop at it
        fx = 0.0
        fy = 0.0
        am = a_max[b]
        vm = v_max[b]
        if has_goal[k]:
            tx = goals[k, 0] - px
            ty = goals[k, 1] - py
            dist = math.hypot(tx, ty)
            if not dist < 1e-9:
                top = vm
                if has_v_pref[i]:
                    vp = options[i, _V_PREF]
                    top = vm if vm < vp else vp
                sp = math.sqrt(am * dist)
                sp = sp if sp < top else top
                fx = tx / dist * sp
                fy = ty / dist * sp
        fail, rx, ry = _lp2(lp, ld, taken, vm, fx, fy, False)
        if fail < taken:
            rx, ry = _lp3(lp, ld, taken, fail, vm, rx, ry, pp, pd)
        # track the ORCA velocity within a_max
        tc = options[i, _TIME_CONSTANT]
        ax = (rx - vx) / tc
        ay = (ry - vy) / tc
        ax, ay, _ = limit_norm(ax, ay, am)
        out[i, 0] = ax
        out[i, 1] = ay
    return out


# ---------------------------------------------------------------- agent


def _number(name: str, value: Any, low: float, strict: bool, unit: str) -> float:
    """``value`` as a float > low (strict) or >= low; else ValueError naming the option."""
    bad = isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))
    if not bad:
        x = float(value)
        bad = math.isnan(x) or (x <= low if strict else x < low)
    if bad:
        rel = ">" if strict else ">="
        raise ValueError(
            f"orca option {name}: expected a number {rel} {low:g} ({unit}), got {value!r}"
        )
    return x


def _wall_sets(
    walls: NDArray[np.float64], wall_radius: NDArray[np.float64], grow: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """The wall discs per grown radius (m) the rows have: centres, radii, set starts and
    each row's set (-1: no walls)."""
    if not len(walls):
        return (
            NO_WALLS[0],
            NO_WALLS[1],
            np.zeros(1, dtype=np.int64),
            np.full(len(grow), -1, dtype=np.int64),
        )
    values = list(dict.fromkeys(grow.tolist()))
    parts = [wall_discs_memo(walls, wall_radius, g) for g in values]
    start = np.zeros(len(parts) + 1, dtype=np.int64)
    np.cumsum([len(r) for _, r in parts], out=start[1:])
    which = {g: s for s, g in enumerate(values)}
    wall_set = np.array([which[g] for g in grow.tolist()], dtype=np.int64)
    return (
        np.concatenate([c for c, _ in parts]).reshape(-1, 2),
        np.concatenate([r for _, r in parts]),
        start,
        wall_set,
    )


class ORCAAgent:
    """Options: horizon (s), margin (m), v_pref (m/s), time_constant (s), sensing_range (m),
    max_neighbours, sees_robots (False: robots are left out of what it senses, CrowdNav's
    invisible robot). Driving a person (a robots entry of kind "person", CrowdNav's ORCA
    humans), it counts on the other people, not only the robots, to take half of the
    avoidance."""

    def __init__(
        self,
        horizon: float = 3.0,
        margin: float = 0.05,
        v_pref: float | None = None,
        time_constant: float = 0.3,
        sensing_range: float = 30.0,
        max_neighbours: int = 16,
        sees_robots: bool = True,
    ) -> None:
        if not isinstance(sees_robots, bool | np.bool_):
            raise ValueError(
                f"orca option sees_robots: expected true or false, got {sees_robots!r}"
            )
        self.sees_robots = bool(sees_robots)
        self.as_person = False
        self.horizon = _number("horizon", horizon, 0.0, True, "s")
        margin_ = _number("margin", margin, -math.inf, False, "m")
        if not math.isfinite(margin_):
            raise ValueError(f"orca option margin: expected a finite number (m), got {margin!r}")
        self.margin = margin_
        self.v_pref = None if v_pref is None else _number("v_pref", v_pref, 0.0, False, "m/s")
        self.time_constant = _number("time_constant", time_constant, 0.0, True, "s")
        self.sensing_range = _number("sensing_range", sensing_range, 0.0, False, "m")
        if max_neighbours is not None:
            try:
                count = operator.index(max_neighbours)
            except TypeError:
                count = -1
            if isinstance(max_neighbours, bool) or count < 0:
                raise ValueError(
                    "orca option max_neighbours: expected an integer >= 0 or "
                    f"None (all), got {max_neighbours!r}"
                )
            max_neighbours = count
        self.max_neighbours = max_neighbours

    def __setattr__(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)
        _option_table.clear()  # an option changed: the memoised option tables are stale

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """Stateless but for whom it drives: a person (``spec.kind``) or a robot."""
        self.as_person = getattr(spec, "kind", "robot") == "person"

    def panel(self) -> PanelAgent:
        """What the viewer's acceleration panel shows of this agent: margin and v_pref."""
        return PanelAgent(margin=float(self.margin), v_pref=self.v_pref)

    def act(self, obs: Observation) -> NDArray[np.float64]:
        """The ORCA acceleration (m/s^2) of the robot ``obs`` describes."""
        nb = obs.neighbours
        if not self.sees_robots:
            nb = _seen(nb, np.asarray(nb.kinds) != "robot")
        m = len(nb)
        positions = _f64(
            np.concatenate([np.reshape(obs.position, (1, 2)), np.reshape(nb.positions, (m, 2))])
        )
        velocities = _f64(
            np.concatenate([np.reshape(obs.velocity, (1, 2)), np.reshape(nb.velocities, (m, 2))])
        )
        radii = _f64(np.concatenate([[obs.radius], np.reshape(nb.radii, m)]))
        reactive = np.array(
            [False] + [_reciprocal(k, self.as_person) for k in nb.kinds], dtype=np.bool_
        )
        target = goal_target(obs)
        goals = _f64(np.zeros((1, 2)) if target is None else np.reshape(target, (1, 2)))
        options, has_v_pref, limit = _options_of([self])
        wall_c, wall_r, wall_start, wall_set = _wall_sets(
            obs.walls, obs.wall_radius, np.array([obs.radius + self.margin])
        )
        sensed = BodyArrays(
            reactive,
            positions,
            velocities,
            radii,
            _f64(np.full(m + 1, obs.a_max)),
            _f64(np.full(m + 1, obs.v_max)),
        )
        robot = RobotTargets(np.zeros(1, dtype=np.int64), goals, np.array([target is not None]))
        neighbours = IndexLists(
            np.array([0, m], dtype=np.int64), np.arange(1, m + 1, dtype=np.int64)
        )
        acc = orca_accelerations(
            sensed,
            robot,
            neighbours,
            np.zeros(1, dtype=np.int64),
            WallDiscs(wall_c, wall_r, wall_start, wall_set),
            options,
            has_v_pref,
            limit,
            float(obs.dt),
        )
        return acc[0]

    @classmethod
    def act_batch(
        cls, agents: Sequence[ORCAAgent], batch: SensingBatch, rows: Sequence[int]
    ) -> NDArray[np.float64] | list[NDArray[np.float64] | Exception]:
        """:meth:`act` for many robots at once, in one compiled call from the bulk arrays
        (the same accelerations, m/s^2): an array (len(rows), 2). Agents of a subclass
        with its own ``act`` act robot by robot: then one acceleration or exception per
        row (a list)."""
        return act_rows(agents, batch, rows, _ACT, _batch_accelerations)


_ACT = ORCAAgent.act
_OPTIONS = operator.attrgetter(
    "horizon", "margin", "v_pref", "time_constant", "sensing_range", "max_neighbours"
)


_Table = tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]


def _options_of(agents: Sequence[ORCAAgent]) -> _Table:
    """The kernel's options of ``agents``: (n, 5) horizon, margin, v_pref (NaN: none),
    time_constant, sensing_range; whether v_pref is set; max_neighbours (-1: all)."""
    table = np.array(list(map(_OPTIONS, agents)), dtype=np.float64).reshape(-1, 6)
    has_v_pref = ~np.isnan(table[:, _V_PREF])
    limit = np.where(np.isnan(table[:, 5]), -1.0, np.minimum(table[:, 5], 2.0**62))
    return np.ascontiguousarray(table[:, :5]), has_v_pref, limit.astype(np.int64)


_option_table = OptionTables(_options_of)
""":func:`_options_of`, memoised per group of agents (see :class:`OptionTables`)."""


def _seen(nb: Neighbours, keep: NDArray[np.bool_]) -> Neighbours:
    """The neighbours ``keep`` marks (what ORCA reads of them: ids, kinds, positions,
    velocities, radii)."""
    return Neighbours(
        ids=nb.ids[keep],
        kinds=tuple(k for k, kept in zip(nb.kinds, keep, strict=True) if kept),
        positions=nb.positions[keep],
        velocities=nb.velocities[keep],
        accelerations=nb.accelerations[keep],
        radii=nb.radii[keep],
    )


def _reciprocal(kind: str, as_person: bool) -> bool:
    """Whether a neighbour of this kind takes half of the avoidance: robots do; for an
    agent that drives a person (``as_person``), people do too (traffic never does)."""
    return kind == "robot" or (as_person and kind == "person")


def _batch_accelerations(
    agents: Sequence[ORCAAgent], batch: SensingBatch, rows: NDArray[np.int64]
) -> NDArray[np.float64]:
    """The kernel on the bulk arrays for ``agents`` at robot rows ``rows``: (n, 2) m/s^2;
    one call per kind of view (robots; people, seeing the robots or not)."""
    views = [(ag.as_person, ag.sees_robots) for ag in agents]
    if all(v == (False, True) for v in views):
        return _view_accelerations(agents, batch, rows, _reactive(batch.kinds))
    out = np.zeros((len(rows), 2))
    for view in dict.fromkeys(views):
        which = [i for i, v in enumerate(views) if v == view]
        as_person, sees_robots = view
        kinds = np.asarray(batch.kinds)
        reactive = (kinds == "robot") | (as_person & (kinds == "person"))
        view_batch = batch if sees_robots else _without_robots(batch)
        out[which] = _view_accelerations(
            [agents[i] for i in which], view_batch, rows[which], reactive
        )
    return out


def _without_robots(batch: SensingBatch) -> SensingBatch:
    """``batch`` with the bodies of kind robot left out of every neighbour list."""
    keep = np.asarray(batch.kinds)[batch.nb_index] != "robot"
    start, index = subset(batch.nb_start, batch.nb_index, keep)
    return dataclasses.replace(batch, nb_start=start, nb_index=index)


def _view_accelerations(
    agents: Sequence[ORCAAgent],
    batch: SensingBatch,
    rows: NDArray[np.int64],
    reactive: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """The kernel on the bulk arrays for ``agents`` at robot rows ``rows`` with the
    neighbours ``reactive`` marks as taking half of the avoidance: (n, 2) m/s^2."""
    bodies = _i64(batch.bodies)
    options, has_v_pref, limit = _option_table(agents)
    if len(batch.walls):
        grow = _f64(batch.radii)[bodies[rows]] + options[:, _MARGIN]
        wall_c, wall_r, wall_start, wall_set = _wall_sets(batch.walls, batch.wall_radius, grow)
    else:
        wall_c, wall_r, wall_start, wall_set = _no_wall_sets(len(rows))
    return orca_accelerations(
        body_arrays(batch, reactive),
        RobotTargets(bodies, _f64(batch.goals), _every_goal(len(bodies))),
        neighbour_lists(batch),
        rows,
        WallDiscs(wall_c, wall_r, wall_start, wall_set),
        options,
        has_v_pref,
        limit,
        float(batch.dt),
    )


_NO_WALL_SETS: dict[int, tuple[NDArray[Any], ...]] = {}
_EVERY_GOAL: dict[int, NDArray[np.bool_]] = {}


def _no_wall_sets(n: int) -> tuple[NDArray[Any], ...]:
    """:func:`_wall_sets` of n rows and no walls, memoised per n (shared: the kernel
    only reads them)."""
    sets = _NO_WALL_SETS.get(n)
    if sets is None:
        if len(_NO_WALL_SETS) > 64:
            _NO_WALL_SETS.clear()
        sets = _NO_WALL_SETS[n] = _wall_sets(NO_WALLS[0].reshape(0, 2, 2), NO_WALLS[1], np.zeros(n))
    return sets


def _every_goal(n: int) -> NDArray[np.bool_]:
    """n True values (every robot of a batch has its goal), memoised per n (shared: the
    kernel only reads them)."""
    every = _EVERY_GOAL.get(n)
    if every is None:
        if len(_EVERY_GOAL) > 64:
            _EVERY_GOAL.clear()
        every = _EVERY_GOAL[n] = np.ones(n, dtype=np.bool_)
    return every
