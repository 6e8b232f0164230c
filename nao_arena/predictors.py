"""Where an agent thinks its neighbours will be: sampled centres over the horizon.

Every predictor maps (times (T,) s, neighbours) to predicted centres
(n, T, 2) in the world frame (m), the input of
:func:`nao_arena.geometry.nao_clearance` once the robot's own position is
subtracted.

- ``constant_velocity``: c(t) = p + v t.
- ``constant_acceleration``: c(t) = p + v t + a t^2 / 2 (the AO's model).
- ``turn_rate``: constant turn rate and tangential acceleration estimated
  from the observed velocity and acceleration (arcs: curved traffic without
  map knowledge).
- ``known_path``: the true future path where the map provides it (scripted
  traffic), else ``turn_rate``.
- ``shared_plan``: the acceleration a cooperative neighbour committed to,
  else ``known_path``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from nao_arena.sensing import Neighbours

__all__ = ["PREDICTORS", "get_predictor"]

Predictor = Callable[[NDArray[np.float64], Neighbours], NDArray[np.float64]]


def constant_velocity(times: NDArray[np.float64], nb: Neighbours) -> NDArray[np.float64]:
    """c(t) = p + v t, (n, T, 2) m."""
    return nb.positions[:, None, :] + nb.velocities[:, None, :] * times[None, :, None]


def constant_acceleration(times: NDArray[np.float64], nb: Neighbours) -> NDArray[np.float64]:
    """c(t) = p + v t + a t^2 / 2, (n, T, 2) m."""
    t = times[None, :, None]
    return (
        nb.positions[:, None, :]
        + nb.velocities[:, None, :] * t
        + 0.5 * nb.accelerations[:, None, :] * t * t
    )


def turn_rate(times: NDArray[np.float64], nb: Neighbours) -> NDArray[np.float64]:
    """Constant turn rate omega = (v x a) / |v|^2 and tangential acceleration a.v / |v|.

    The speed is held at >= 0 (a vehicle does not reverse by braking), and a
    neighbour at rest stays at rest (its observed acceleration is the braking
    that stopped it). The
    path is integrated exactly for the arc on a fine internal grid (8 steps
    per sample interval, midpoint rule), (n, T, 2) m. The integration is
    compiled (:func:`_arcs`).
    """
    if len(nb) == 0:
        return np.zeros((0, len(times), 2))
    m = turn_rate_motion(times, nb)
    out = _arcs(
        np.ascontiguousarray(nb.positions, dtype=np.float64), m.speed, m.omega, m.a_t,
        m.heading, np.ascontiguousarray(m.mid), np.ascontiguousarray(m.fine), len(times),
    )
    return hold_still(out, nb, m.moving)


@dataclass(frozen=True)
class TurnRateMotion:
    """Per neighbour: speed (m/s), omega (rad/s), a_t (m/s^2), heading (rad), moving
    (speed above 1e-6 m/s); the fine grid's midpoints ``mid`` (s) and steps ``fine`` (s),
    8 per sample interval."""

    speed: NDArray[np.float64]
    omega: NDArray[np.float64]
    a_t: NDArray[np.float64]
    heading: NDArray[np.float64]
    moving: NDArray[np.bool_]
    mid: NDArray[np.float64]
    fine: NDArray[np.float64]


def turn_rate_motion(times: NDArray[np.float64], nb: Neighbours) -> TurnRateMotion:
    """The motion :func:`turn_rate` integrates, from the neighbours' observed state."""
    v = nb.velocities
    a = nb.accelerations
    speed = np.hypot(v[:, 0], v[:, 1])
    moving = speed > 1e-6
    safe = np.where(moving, speed, 1.0)
    omega = np.where(moving, (v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0]) / safe**2, 0.0)
    a_t = np.where(moving, (v[:, 0] * a[:, 0] + v[:, 1] * a[:, 1]) / safe, 0.0)
    heading = np.arctan2(v[:, 1], v[:, 0])
    fine = np.concatenate([[0.0], np.repeat(np.diff(np.concatenate([[0.0], times])) / 8, 8)])
    t_fine = np.cumsum(fine)
    mid = t_fine[:-1] + 0.5 * fine[1:]
    return TurnRateMotion(speed, omega, a_t, heading, moving, mid, fine[1:])


def hold_still(out: NDArray[np.float64], nb: Neighbours,
               moving: NDArray[np.bool_]) -> NDArray[np.float64]:
    """``out`` (n, T, 2) m with the neighbours at rest held at their positions: a
    neighbour at rest (no heading) stays at rest, its observed acceleration, the mean over
    the last period, being the braking that stopped it (one that sets off from rest is
    already moving when observed)."""
    still = ~moving
    if np.any(still):
        out[still] = nb.positions[still][:, None, :]
    return out


@njit(cache=True)
def _arcs(positions, speed, omega, a_t, heading, mid, fine, n_times):
    """Midpoint-rule arcs: positions (n, 2) m, speed (m/s), omega (rad/s), a_t (m/s^2),
    heading (rad) per row; fine-grid midpoints ``mid`` and steps ``fine`` (s), 8 per
    sample (equal within a sample). Returns the centres at every 8th fine step,
    (n, n_times, 2) m. The heading's cosine and sine are evaluated at the first
    midpoint of each sample and turned by omega * fine step (a rotation) for the
    other seven."""
    n = positions.shape[0]
    out = np.empty((n, n_times, 2))
    for i in range(n):
        sx = 0.0
        sy = 0.0
        j = 0
        c = 1.0
        s = 0.0
        rc = 1.0
        rs = 0.0
        for m in range(mid.shape[0]):
            if m % 8 == 0:
                th = heading[i] + omega[i] * mid[m]
                c = math.cos(th)
                s = math.sin(th)
                turn = omega[i] * fine[m]
                rc = math.cos(turn)
                rs = math.sin(turn)
            else:
                c, s = c * rc - s * rs, s * rc + c * rs
            sp = speed[i] + a_t[i] * mid[m]
            if sp < 0.0:
                sp = 0.0
            sx = sx + sp * c * fine[m]
            sy = sy + sp * s * fine[m]
            if m % 8 == 7:
                if j < n_times:
                    out[i, j, 0] = positions[i, 0] + sx
                    out[i, j, 1] = positions[i, 1] + sy
                j += 1
    return out


def _resample(path_times, paths, times):
    """Linear interpolation of (n, P, 2) paths at times (T,); beyond the end: extrapolate."""
    out = np.empty((paths.shape[0], len(times), 2))
    for k in range(2):
        for i in range(paths.shape[0]):
            out[i, :, k] = np.interp(times, path_times, paths[i, :, k])
    if len(path_times) >= 2:
        # continue at the last segment's velocity past the known horizon
        last_v = (paths[:, -1] - paths[:, -2]) / (path_times[-1] - path_times[-2])
        beyond = times > path_times[-1]
        out[:, beyond] = paths[:, -1:, :] + last_v[:, None, :] * (
            times[beyond] - path_times[-1]
        )[None, :, None]
    return out


def known_path(times: NDArray[np.float64], nb: Neighbours) -> NDArray[np.float64]:
    """True future centres where known (times relative to now), else ``turn_rate``."""
    out = turn_rate(times, nb)
    if nb.known_paths is None or len(nb) == 0:
        return out
    known = np.all(np.isfinite(nb.known_paths), axis=(1, 2))
    if np.any(known):
        out[known] = _resample(nb.path_times, nb.known_paths[known], times)
    return out


def shared_plan(times: NDArray[np.float64], nb: Neighbours) -> NDArray[np.float64]:
    """Committed acceleration of cooperative neighbours, else ``known_path``."""
    out = known_path(times, nb)
    if nb.plans is None or len(nb) == 0:
        return out
    has = np.all(np.isfinite(nb.plans), axis=1)
    if np.any(has):
        t = times[None, :, None]
        out[has] = (
            nb.positions[has, None, :] + nb.velocities[has, None, :] * t
            + 0.5 * nb.plans[has, None, :] * t * t
        )
    return out


PREDICTORS: dict[str, Predictor] = {
    "constant_velocity": constant_velocity,
    "constant_acceleration": constant_acceleration,
    "turn_rate": turn_rate,
    "known_path": known_path,
    "shared_plan": shared_plan,
}


def get_predictor(name: str) -> Predictor:
    """The predictor registered under ``name``; ValueError naming the choices otherwise."""
    try:
        return PREDICTORS[name]
    except KeyError:
        raise ValueError(
            f"unknown predictor {name!r}; expected one of {', '.join(PREDICTORS)}"
        ) from None
