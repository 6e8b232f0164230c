"""The ``orca`` agent as a Python/numpy program, robot by robot: the reference that
the compiled agent (nao_arena.agents.orca, tests/test_orca_compiled.py) must match.

``orca``: optimal reciprocal collision avoidance, tracked by acceleration.

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.agents._obstacles import observed_discs, preferred_velocity, track_velocity
from nao_arena.sensing import Observation

_EPS = 1e-9


@dataclass(frozen=True)
class HalfPlane:
    """Permitted velocities: those on the left of the directed line point + s direction."""

    point: NDArray[np.float64]
    direction: NDArray[np.float64]


def _det(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def orca_half_plane(
    rel_pos: NDArray[np.float64],
    rel_vel: NDArray[np.float64],
    radius: float,
    v_own: NDArray[np.float64],
    horizon: float,
    dt: float,
    share: float,
) -> HalfPlane:
    """Half-plane for one neighbour at rel_pos (m) with relative velocity v_own - v_other.

    radius: combined radius (m); share: the part of the avoidance this robot takes
    (0.5 reciprocal, 1 against non-reacting obstacles); dt: control period (s),
    used when the discs already overlap.
    """
    dist2 = float(rel_pos @ rel_pos)
    r2 = radius * radius
    if dist2 > r2:
        w = rel_vel - rel_pos / horizon
        w2 = float(w @ w)
        dot = float(w @ rel_pos)
        if dot < 0.0 and dot * dot > r2 * w2:
            # nearest boundary point is on the truncation circle
            wl = math.sqrt(w2)
            unit = w / wl
            direction = np.array([unit[1], -unit[0]])
            u = (radius / horizon - wl) * unit
        else:
            leg = math.sqrt(dist2 - r2)
            if _det(rel_pos, w) > 0.0:
                direction = (
                    np.array(
                        [
                            rel_pos[0] * leg - rel_pos[1] * radius,
                            rel_pos[0] * radius + rel_pos[1] * leg,
                        ]
                    )
                    / dist2
                )
            else:
                direction = (
                    -np.array(
                        [
                            rel_pos[0] * leg + rel_pos[1] * radius,
                            -rel_pos[0] * radius + rel_pos[1] * leg,
                        ]
                    )
                    / dist2
                )
            u = float(rel_vel @ direction) * direction - rel_vel
    else:
        # already overlapping: leave within one control period
        w = rel_vel - rel_pos / dt
        wl = max(math.sqrt(float(w @ w)), _EPS)
        unit = w / wl
        direction = np.array([unit[1], -unit[0]])
        u = (radius / dt - wl) * unit
    return HalfPlane(v_own + share * u, direction)


def _lp1(lines, i, radius, opt, direction_opt):
    """Best point on line i within the disc |v| <= radius and lines[:i]; None if empty."""
    line = lines[i]
    dot = float(line.point @ line.direction)
    disc = dot * dot + radius * radius - float(line.point @ line.point)
    if disc < 0.0:
        return None
    sq = math.sqrt(disc)
    t_left, t_right = -dot - sq, -dot + sq
    for j in range(i):
        denom = _det(line.direction, lines[j].direction)
        numer = _det(lines[j].direction, line.point - lines[j].point)
        if abs(denom) <= _EPS:
            if numer < 0.0:
                return None
            continue
        t = numer / denom
        if denom >= 0.0:
            t_right = min(t_right, t)
        else:
            t_left = max(t_left, t)
        if t_left > t_right:
            return None
    if direction_opt:
        t = t_right if float(opt @ line.direction) > 0.0 else t_left
    else:
        t = min(max(float(line.direction @ (opt - line.point)), t_left), t_right)
    return line.point + t * line.direction


def _lp2(lines, radius, opt, direction_opt):
    """Velocity nearest opt (or furthest along opt) in all half-planes and the disc.

    Returns (index of the first line that could not be satisfied or len(lines), result).
    """
    if direction_opt:
        result = opt * radius
    elif float(opt @ opt) > radius * radius:
        result = opt / math.sqrt(float(opt @ opt)) * radius
    else:
        result = opt.copy()
    for i, line in enumerate(lines):
        if _det(line.direction, line.point - result) > 0.0:
            found = _lp1(lines, i, radius, opt, direction_opt)
            if found is None:
                return i, result
            result = found
    return len(lines), result


def _lp3(lines, begin, radius, result):
    """Minimise the largest violation of lines[begin:] (all lines are soft here)."""
    distance = 0.0
    for i in range(begin, len(lines)):
        if _det(lines[i].direction, lines[i].point - result) > distance:
            projected = []
            for j in range(i):
                det = _det(lines[i].direction, lines[j].direction)
                if abs(det) <= _EPS:
                    if float(lines[i].direction @ lines[j].direction) > 0.0:
                        continue
                    point = 0.5 * (lines[i].point + lines[j].point)
                else:
                    point = (
                        lines[i].point
                        + (_det(lines[j].direction, lines[i].point - lines[j].point) / det)
                        * lines[i].direction
                    )
                d = lines[j].direction - lines[i].direction
                n = math.sqrt(float(d @ d))
                if n <= _EPS:
                    continue
                projected.append(HalfPlane(point, d / n))
            opt = np.array([-lines[i].direction[1], lines[i].direction[0]])
            fail, candidate = _lp2(projected, radius, opt, True)
            if fail == len(projected):
                result = candidate
            distance = _det(lines[i].direction, lines[i].point - result)
    return result


def orca_velocity(
    lines: list[HalfPlane], v_pref: NDArray[np.float64], v_max: float
) -> NDArray[np.float64]:
    """The ORCA velocity (m/s): nearest v_pref in all half-planes with |v| <= v_max."""
    fail, result = _lp2(lines, v_max, v_pref, False)
    if fail < len(lines):
        result = _lp3(lines, fail, v_max, result)
    return result


class ORCAAgent:
    """Options: horizon (s), margin (m), v_pref (m/s), time_constant (s), sensing_range (m),
    max_neighbours."""

    def __init__(
        self,
        horizon: float = 3.0,
        margin: float = 0.05,
        v_pref: float | None = None,
        time_constant: float = 0.3,
        sensing_range: float = 30.0,
        max_neighbours: int = 16,
    ) -> None:
        self.horizon = horizon
        self.margin = margin
        self.v_pref = v_pref
        self.time_constant = time_constant
        self.sensing_range = sensing_range
        self.max_neighbours = max_neighbours

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """Stateless."""

    def act(self, obs: Observation) -> NDArray[np.float64]:
        pref = preferred_velocity(obs, self.v_pref)
        discs = observed_discs(obs, self.margin, self.sensing_range)
        order = np.argsort(np.hypot(*discs.positions.T), kind="stable")[: self.max_neighbours]
        lines = [
            orca_half_plane(
                discs.positions[k],
                obs.velocity - discs.velocities[k],
                float(discs.radii[k]),
                obs.velocity,
                self.horizon,
                obs.dt,
                0.5 if discs.reactive[k] else 1.0,
            )
            for k in order
        ]
        v_new = orca_velocity(lines, pref, obs.v_max)
        return track_velocity(obs, v_new, self.time_constant)
