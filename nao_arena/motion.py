"""The motion rules, in one place: the speed limit, scaling to a maximum norm, braking.

Units: m, s, m/s, m/s^2. The compiled functions (numba, ``cache=True``) take and return
scalars, so that compiled callers (the world, the stopping plans, the planner's and the
agents' kernels) call them in their loops and LLVM inlines them; the numpy functions do
the same arithmetic over rows, for callers that are numpy code.

The speed limit
---------------
A body commanded a constant acceleration a (m/s^2) from a velocity v (m/s) with
|v| <= v_max accelerates until its speed |v + a t| reaches v_max (m/s), at the
saturation time tau (s), and coasts at constant velocity from then on.
:class:`nao_arena.world.World` drives exactly this model (up to contacts), and the
geometry kernels predict the robot's own path with it, so the planner predicts the
path the world drives by construction: both call :func:`saturation_time`
(:func:`speed_limit_time` per row).

Scaling to a maximum norm
-------------------------
A vector (x, y) longer than a limit is scaled down to it, keeping its direction. The
callers do this with five arithmetics, each kept to the bit (the trajectories depend on
it); they agree but in the corner cases named:

- :func:`clip_norm` (rows: :func:`clip_accelerations`): the world's clip of the commands,
  x min(1, limit / max(|a|, 1e-300)), always multiplied. The world, the stopping plans,
  the lane followers, the env.
- :func:`limit_norm`: x limit / |a| only when |a| > limit (hypot). The world's and the
  stopping plans' speed limit (a velocity above v_max scaled to it), the goal, ORCA and
  VO agents' tracking accelerations (rows: :func:`limit_norms`, the episode log's
  reconstruction of the goal agent). Equal to :func:`clip_norm` for every input,
  non-finite ones included, unless limit < 1e-300 and limit != 0.
- :func:`limit_norm_sqrt`: the same with |a| = sqrt(x^2 + y^2) (faster than hypot, which
  it may differ from in the last bit): the planner kernels' speed limit
  (:func:`~nao_arena.geometry._kernel.robot_path.candidate_setup`, relevance pruning) and
  the CBF agent.
- :func:`onto_disc`: x limit / max(|a|, 1e-300) only when |a| > limit: the compiled
  selection's projection onto the limit disc (candidates, repair, sliding). Equal to
  :func:`limit_norm` unless limit < |a| < 1e-300.
- :func:`project_onto_disc`: :meth:`nao_arena.geometry.AccelLimits.project` on the disc:
  non-finite components taken as 0, scaled by limit / |a| when not |a| <= limit, and
  normalised first when that factor would be subnormal. The selection's projection and
  the compiled braking fallback of the ``nao`` agents.

Braking to a standstill
-----------------------
A body at velocity v brakes towards standing still within one control period dt (s)
with the acceleration -min(a_max, |v| / dt) v / |v| (:func:`braking`; the factor
b = min(a_max, |v| / dt) / |v| (1/s) is :func:`brake_factor`): it stops exactly at the
period's end when |v| <= a_max dt. The stopping plans' braking periods and standing
plans, and the ``nao`` agents' fallback when nothing is admissible.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nao_arena.jit import inner_kernel, kernel

__all__ = [
    "SMALLEST_NORMAL",
    "brake_factor",
    "braking",
    "clip_accelerations",
    "clip_norm",
    "limit_norm",
    "limit_norm_sqrt",
    "limit_norms",
    "onto_disc",
    "project_onto_disc",
    "saturation_time",
    "speed_limit_time",
]

FloatArray = NDArray[np.float64]

SMALLEST_NORMAL = float(np.finfo(np.float64).tiny)
"""The smallest positive normal float64 (2.2e-308): a smaller scale factor loses digits."""


# ----------------------------------------------------------------------- the speed limit


@inner_kernel(error_model="numpy")
def saturation_time(vx: float, vy: float, ax: float, ay: float, v_max: float) -> float:
    """Time tau (s) at which |v + a tau| reaches v_max: the positive root, inf if never.

    v = (vx, vy) m/s must satisfy |v| <= v_max (m/s; rounding tolerated, inf allowed);
    a = (ax, ay) m/s^2. At |v| = v_max, tau = 0 unless a points backwards (a . v < 0),
    when tau = -2 a.v / |a|^2.
    """
    if not math.isfinite(v_max):
        return math.inf
    aa = ax * ax + ay * ay
    if aa == 0.0:
        return math.inf
    b = ax * vx + ay * vy
    c = min(vx * vx + vy * vy - v_max * v_max, 0.0)
    # positive root of aa t^2 + 2 b t + c = 0 (c <= 0)
    root = math.sqrt(b * b - aa * c)
    if b >= 0.0:
        # numerically stable form of (root - b) / aa
        forward = b + root
        return (0.0 - c) / (forward if forward > 0.0 else 1.0)
    return (root - b) / aa


@kernel(error_model="numpy")
def _saturation_times(v: FloatArray, a: FloatArray, v_max: FloatArray) -> FloatArray:
    out = np.empty(v.shape[0])
    for i in range(v.shape[0]):
        out[i] = saturation_time(v[i, 0], v[i, 1], a[i, 0], a[i, 1], v_max[i])
    return out


def speed_limit_time(v: ArrayLike, a: ArrayLike, v_max: ArrayLike) -> FloatArray:
    """:func:`saturation_time` per row: tau (N,) s for v (N, 2) m/s, a (N, 2) m/s^2 and
    v_max (N,) m/s (or one v_max for all rows)."""
    v = np.ascontiguousarray(v, dtype=float)
    a = np.ascontiguousarray(a, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2 or a.shape != v.shape:
        raise ValueError(f"expected v and a of shape (N, 2), got {v.shape} and {a.shape}")
    limit = np.ascontiguousarray(np.broadcast_to(np.asarray(v_max, dtype=float), v.shape[:1]))
    return _saturation_times(v, a, limit)


# ------------------------------------------------------------- scaling to a maximum norm


@inner_kernel(error_model="numpy")
def clip_norm(x: float, y: float, limit: float) -> tuple[float, float]:
    """(x, y) scaled to norm <= limit, direction kept: the world's clip of a command (m/s^2),
    (x, y) min(1, limit / max(|(x, y)|, 1e-300)), with |.| by hypot."""
    norm = math.hypot(x, y)
    scale = min(1.0, limit / max(norm, 1e-300))
    return x * scale, y * scale


def clip_accelerations(accels: ArrayLike, a_max: ArrayLike) -> FloatArray:
    """Rows of accels (N, 2) m/s^2 scaled to |a| <= a_max (N,) (or one a_max for all rows),
    direction kept: :func:`clip_norm` row by row (the same bits for finite rows; numpy's
    minimum carries a NaN into both components)."""
    a = np.asarray(accels, dtype=float)
    norm = np.hypot(a[:, 0], a[:, 1])
    scale = np.minimum(1.0, np.asarray(a_max, float) / np.maximum(norm, 1e-300))
    return a * scale[:, None]


@kernel(error_model="numpy")
def limit_norm(x: float, y: float, limit: float) -> tuple[float, float, float]:
    """(x, y) times limit / |(x, y)| if |(x, y)| > limit, else unchanged, and |(x, y)| before
    (hypot): a velocity (m/s) to the speed limit, an acceleration (m/s^2) to a_max. The
    caller tests norm > limit to know whether it scaled."""
    norm = math.hypot(x, y)
    if norm > limit:
        f = limit / norm
        x, y = x * f, y * f
    return x, y, norm


def limit_norms(a: ArrayLike, limit: ArrayLike) -> FloatArray:
    """:func:`limit_norm` over the rows of a (..., 2), limit broadcast against a[..., 0]
    (the same bits, NaN rows included)."""
    arr = np.asarray(a, dtype=float)
    lim = np.asarray(limit, dtype=float)
    norm = np.hypot(arr[..., 0], arr[..., 1])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        scale = np.where(norm > lim, lim / norm, 1.0)
    return arr * scale[..., None]


@inner_kernel(error_model="numpy")
def limit_norm_sqrt(x: float, y: float, limit: float) -> tuple[float, float, float]:
    """:func:`limit_norm` with |(x, y)| = sqrt(x^2 + y^2) (faster than hypot, but it may
    differ from it in the last bit and overflows beyond 1e154): the planner kernels'
    speed limit."""
    norm = math.sqrt(x * x + y * y)
    if norm > limit:
        x = x * (limit / norm)
        y = y * (limit / norm)
    return x, y, norm


@inner_kernel(error_model="numpy")
def onto_disc(x: float, y: float, limit: float) -> tuple[float, float]:
    """(x, y) m/s^2 projected onto the disc |a| <= limit: scaled by
    limit / max(|(x, y)|, 1e-300) when |(x, y)| > limit (the compiled selection's)."""
    norm = math.hypot(x, y)
    scale = limit / max(norm, 1e-300) if norm > limit else 1.0
    return x * scale, y * scale


@kernel(error_model="numpy")
def project_onto_disc(x: float, y: float, limit: float) -> tuple[float, float]:
    """(x, y) m/s^2 projected onto the disc |a| <= limit (limit >= 0) as
    :meth:`nao_arena.geometry.AccelLimits.project` does it: a non-finite component taken
    as 0, then scaled by limit / |(x, y)| unless |(x, y)| <= limit, dividing by the norm
    first where that factor would be subnormal (it would lose digits)."""
    x = x if math.isfinite(x) else 0.0
    y = y if math.isfinite(y) else 0.0
    norm = math.hypot(x, y)
    if norm <= limit:
        return x, y
    scale = limit / norm
    if scale < SMALLEST_NORMAL:
        return x / norm * limit, y / norm * limit
    return x * scale, y * scale


# ------------------------------------------------------------------------------ braking


@inner_kernel(error_model="numpy")
def brake_factor(speed: float, a_max: float, dt: float) -> float:
    """b = min(a_max, speed / dt) / speed (1/s) for speed = |v| > 0 (m/s), a_max (m/s^2)
    and the control period dt (s): -b v is the acceleration that brakes towards standing
    still within dt, reached when b dt >= 1."""
    return min(a_max, speed / dt) / speed


@kernel(error_model="numpy")
def braking(vx: float, vy: float, a_max: float, dt: float) -> tuple[float, float]:
    """The acceleration (m/s^2) -min(a_max, |v| / dt) v / |v| (-:func:`brake_factor` v) of
    a body at velocity v = (vx, vy) m/s braking towards standing still within dt (s);
    (0, 0) at rest."""
    speed = math.hypot(vx, vy)
    if speed == 0.0:
        return 0.0, 0.0
    b = brake_factor(speed, a_max, dt)
    return -b * vx, -b * vy
