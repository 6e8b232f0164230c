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
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from nao_arena.jit import kernel
from nao_arena.sensing import Neighbours

__all__ = [
    "PREDICTORS",
    "TurnRateInputs",
    "get_predictor",
    "resample_paths",
    "turn_rate_arcs",
    "turn_rate_inputs",
]

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
    neighbour at rest (speed 1e-6 m/s or below) stays at rest: its observed
    acceleration, the mean over the last period, is the braking that stopped
    it (one that sets off from rest is already moving when observed). The
    path is integrated exactly for the arc on a fine internal grid (8 steps
    per sample interval, midpoint rule), (n, T, 2) m, in one compiled pass
    (:func:`turn_rate_arcs` of :func:`turn_rate_inputs`).
    """
    if len(nb) == 0:
        return np.zeros((0, len(times), 2))
    return turn_rate_arcs(
        turn_rate_inputs(times, nb.positions, nb.velocities, nb.accelerations), len(times)
    )


class TurnRateInputs(NamedTuple):
    """What :func:`turn_rate_arcs` takes: per body its position (m), velocity (m/s),
    acceleration (m/s^2) (each (n, 2)) and heading (n,) rad, the velocity's angle; the
    fine grid's midpoints ``mid`` and steps ``fine`` (s), 8 per sample of the time grid
    (equal within a sample; :func:`_fine_grid`)."""

    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    heading: NDArray[np.float64]
    mid: NDArray[np.float64]
    fine: NDArray[np.float64]


def turn_rate_inputs(
    times: NDArray[np.float64],
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64],
    accelerations: NDArray[np.float64],
) -> TurnRateInputs:
    """The :class:`TurnRateInputs` of bodies at ``positions`` (n, 2) m with
    ``velocities`` (n, 2) m/s and ``accelerations`` (n, 2) m/s^2 for the sample times
    (T,) s (the headings by numpy's arctan2)."""
    mid, fine = _fine_grid(times)
    f = np.ascontiguousarray
    v = f(velocities, dtype=np.float64)
    return TurnRateInputs(
        f(positions, dtype=np.float64),
        v,
        f(accelerations, dtype=np.float64),
        np.arctan2(v[:, 1], v[:, 0]),
        mid,
        fine,
    )


_FINE: dict[bytes, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}


def _fine_grid(times: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The fine grid of :func:`turn_rate` for the sample times (T,) s: its midpoints and
    steps (s), 8 per sample interval (the first from 0); memoised per grid."""
    key = np.asarray(times, dtype=np.float64).tobytes()
    grid = _FINE.get(key)
    if grid is None:
        fine = np.concatenate([[0.0], np.repeat(np.diff(np.concatenate([[0.0], times])) / 8, 8)])
        t_fine = np.cumsum(fine)
        if len(_FINE) > 64:
            _FINE.clear()
        grid = _FINE[key] = (t_fine[:-1] + 0.5 * fine[1:], fine[1:].copy())
    return grid


@kernel
def turn_rate_arcs(inputs, n_times):
    """Midpoint-rule arcs of the bodies of ``inputs`` (:class:`TurnRateInputs`): the
    centres at every 8th fine step, (n, n_times, 2) m; a body at rest stays at its
    position. The heading's cosine and sine are evaluated at the first midpoint of each
    sample and turned by omega * fine step (a rotation) for the other seven."""
    positions, velocities, accelerations, heading, mid, fine = inputs
    n = positions.shape[0]
    out = np.empty((n, n_times, 2))
    for i in range(n):
        vx = velocities[i, 0]
        vy = velocities[i, 1]
        speed = math.hypot(vx, vy)
        if not speed > 1e-6:  # at rest: stays at rest
            for j in range(n_times):
                out[i, j, 0] = positions[i, 0]
                out[i, j, 1] = positions[i, 1]
            continue
        omega = (vx * accelerations[i, 1] - vy * accelerations[i, 0]) / (speed * speed)
        a_t = (vx * accelerations[i, 0] + vy * accelerations[i, 1]) / speed
        sx = 0.0
        sy = 0.0
        j = 0
        c = 1.0
        s = 0.0
        rc = 1.0
        rs = 0.0
        for m in range(mid.shape[0]):
            if m % 8 == 0:
                th = heading[i] + omega * mid[m]
                c = math.cos(th)
                s = math.sin(th)
                turn = omega * fine[m]
                rc = math.cos(turn)
                rs = math.sin(turn)
            else:
                c, s = c * rc - s * rs, s * rc + c * rs
            sp = speed + a_t * mid[m]
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


def resample_paths(
    path_times: NDArray[np.float64], paths: NDArray[np.float64], times: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Paths (n, P, 2) m sampled at ``path_times`` (P,) s, read at ``times`` (T,) s:
    interpolated linearly, and past the last sample moved on at the last piece's velocity
    (m/s). Returns (n, T, 2) m."""
    out = np.empty((paths.shape[0], len(times), 2))
    for k in range(2):
        for i in range(paths.shape[0]):
            out[i, :, k] = np.interp(times, path_times, paths[i, :, k])
    if len(path_times) >= 2:
        # continue at the last segment's velocity past the known horizon
        last_v = (paths[:, -1] - paths[:, -2]) / (path_times[-1] - path_times[-2])
        beyond = times > path_times[-1]
        out[:, beyond] = (
            paths[:, -1:, :] + last_v[:, None, :] * (times[beyond] - path_times[-1])[None, :, None]
        )
    return out


def known_path(times: NDArray[np.float64], nb: Neighbours) -> NDArray[np.float64]:
    """True future centres where known (times relative to now), else ``turn_rate``."""
    out = turn_rate(times, nb)
    if nb.known_paths is None or len(nb) == 0:
        return out
    known = np.all(np.isfinite(nb.known_paths), axis=(1, 2))
    if np.any(known):
        out[known] = resample_paths(nb.path_times, nb.known_paths[known], times)
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
            nb.positions[has, None, :]
            + nb.velocities[has, None, :] * t
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
