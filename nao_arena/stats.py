"""Collision statistics and per-robot metrics of one episode (numpy and numba).

The caller (the control loop) makes one call per control step::

    stats = EpisodeStats(radii, kinds, names, walls=world.wall_segments(),
                         dt=world.dt, velocities=state.velocities)
    for each step:
        before = world.state()
        after = world.step(accels)
        stats.update(before.time, before.positions, after.positions,
                     after.velocities, accels, goal_reached,
                     substeps=world.substep_positions)
    summary = stats.summary()          # EpisodeSummary: to_dict(), write_json(), write_csv()

``t`` is the time at the start of the step (s); the step spans
[t, t + dt]. Positions are (N, 2) m, velocities (N, 2) m/s, commanded
accelerations (N, 2) m/s^2 (what the agents asked for, before clipping),
``goal_reached`` (N,) bool at the end of the step (ignored for non-robots).

Contacts are detected by our own exact check, independent of the physics
engine: given the centres after every physics substep (``substeps`` of
:meth:`EpisodeStats.update`; the engine moves each body in a straight line
between two substeps), the minimum distance of each pair over every substep
is computed in closed form (a quadratic in t for two discs;
segment-to-segment distance for a disc against a wall), so that contacts
that start and end inside one control step, and fast discs that pass
through each other, are still counted (without ``substeps``, one straight
line per control step). A
contact episode starts when the separation (surface distance, m) drops
below 0 and ends when the separation at a step's end exceeds the
hysteresis; it is recorded once, with its start time, the bodies, the
relative normal speed at impact (m/s, from the displacement in the substep
of first contact; without substeps, from the velocities at the step's start)
and the maximum penetration depth over the episode (m). Pairs are
found by a sort-and-sweep broad phase on the swept bounding boxes; the
per-pair work of a step is one numba-compiled kernel (same float operations
as the numpy functions here, so bit-identical results), and only the rare
contact events are handled in Python.

Per robot: collisions (contact episodes it took part in, walls included),
near misses (proximity episodes with another body, separation below
``near_miss_distance`` and no contact in the episode), minimum separation
to another body (m, negative while overlapping; exact when below
``separation_range``, else reported as inf), minimum constant-velocity
time to collision with another body at the step ends (s; inf beyond
``ttc_horizon``), time to goal (s, NaN if never),
path length until the goal (m), success (goal reached without any
collision, and at the goal when the episode ended: arrived and stayed, or
came back), acceleration adjustments (steps where the commanded
acceleration changed by more than ``adjustment_threshold`` m/s^2, until the
goal) and their rate (1/s).

Liveness, per robot (given the robots' goals): stuck time (s: control steps
during which the robot was away from its goal and had come less than
``stuck_progress`` m closer to it over the last ``stuck_window`` s; the
first window of the episode never counts), time away from the goal after
first arriving (s: steps that ended outside the goal tolerance after the
first arrival), the distance to the goal at the episode's end (m), whether
it was within the goal tolerance then, and whether it never arrived
(``timed_out``: the episode ended first). Per episode: the deadlock time
(s, NaN if none), the first step end at which every robot away from its
goal was stuck, and the total time spent so (s).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit, types
from numba.typed import Dict
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "ContactEvent",
    "EpisodeStats",
    "EpisodeSummary",
    "FaultEvent",
    "RobotSummary",
    "StatsConfig",
    "atomic_write_text",
    "segment_distances",
    "swept_disc_distances",
    "sweep_pairs",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class StatsConfig:
    """Thresholds of the statistics.

    near_miss_distance (m): separation below which a proximity episode
    starts; hysteresis (m): an episode ends when the separation exceeds its
    threshold by this much; adjustment_threshold (m/s^2): a change of the
    commanded acceleration larger than this is an adjustment;
    separation_range (m): minimum separations are tracked exactly below it;
    ttc_horizon (s): longer times to collision count as none; stuck_window (s) and
    stuck_progress (m): a robot away from its goal is stuck while it came less than
    stuck_progress closer to its goal over the last stuck_window.
    """

    near_miss_distance: float = 0.2
    hysteresis: float = 0.01
    adjustment_threshold: float = 0.1
    separation_range: float = 1.0
    ttc_horizon: float = 5.0
    stuck_window: float = 5.0
    stuck_progress: float = 0.1

    def __post_init__(self) -> None:
        if self.separation_range < self.near_miss_distance + self.hysteresis:
            raise ValueError("separation_range must be >= near_miss_distance + hysteresis")
        if not (self.stuck_window > 0 and math.isfinite(self.stuck_window)):
            raise ValueError(f"stuck_window: expected a finite time > 0 s, got {self.stuck_window}")
        if not self.stuck_progress >= 0:
            raise ValueError(f"stuck_progress: expected >= 0 m, got {self.stuck_progress}")


def _clean(value: Any) -> Any:
    """JSON-friendly value: numpy scalars to Python, non-finite floats to None."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


@dataclass
class ContactEvent:
    """One contact episode between body ``a`` and body or wall ``b``.

    time: start (s); end_time: step end at which it ended (s, NaN while
    ongoing); a, b: body indices (for a wall, b is the wall index);
    kinds "robot", "traffic" or "wall"; impact_speed: relative normal speed
    at first contact (m/s, >= 0); max_penetration: deepest overlap (m).
    """

    time: float
    a: int
    b: int
    kind_a: str
    kind_b: str
    name_a: str
    name_b: str
    impact_speed: float
    max_penetration: float
    end_time: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (non-finite numbers as None)."""
        return {k: _clean(v) for k, v in asdict(self).items()}


@dataclass
class FaultEvent:
    """An agent's fault at time (s): the robot's body index in the world (``robot``, the
    numbering of contacts; not its robot index), its name and what went wrong."""

    time: float
    robot: int
    name: str
    message: str

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict."""
        return {k: _clean(v) for k, v in asdict(self).items()}


@dataclass
class RobotSummary:
    """One robot's metrics over an episode (see the module docstring; units m, s)."""

    index: int
    name: str
    reached_goal: bool
    success: bool
    time_to_goal: float
    path_length: float
    collisions: int
    wall_collisions: int
    near_misses: int
    min_separation: float
    min_ttc: float
    adjustments: int
    adjustment_rate: float
    stuck_time: float = 0.0
    time_away_after_arrival: float = 0.0
    final_goal_distance: float = math.nan
    at_goal_at_end: bool = False
    timed_out: bool = False

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (non-finite numbers as None)."""
        return {k: _clean(v) for k, v in asdict(self).items()}


def temporary_sibling(path: str | Path, suffix: str = ".tmp") -> tuple[int, str]:
    """(fd, name) of a new temporary file next to ``path`` with the permissions an ordinary
    new file gets (mkstemp's 0600 widened to 0666 minus the umask), for atomic replaces."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    umask = os.umask(0o022)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return fd, tmp


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write text to path atomically: a temporary file in the same folder, then os.replace."""
    fd, tmp = temporary_sibling(path)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _csv_text(rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row[k] is None else row[k]) for k in columns})
    return buf.getvalue()


@dataclass
class EpisodeSummary:
    """An episode's results: duration (s), steps, per-robot rows, contact events, faults,
    the first time (s, NaN if never) and total time (s) of deadlock, and the SHA-256
    (hex) of its trajectory (see :mod:`nao_arena.arena`; "" if unknown)."""

    duration: float
    steps: int
    robots: list[RobotSummary] = field(default_factory=list)
    contacts: list[ContactEvent] = field(default_factory=list)
    faults: list[FaultEvent] = field(default_factory=list)
    deadlock_time: float = math.nan
    deadlock_duration: float = 0.0
    trajectory_hash: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (JSON-ready)."""
        return {
            "duration": self.duration,
            "steps": self.steps,
            "deadlock_time": _clean(self.deadlock_time),
            "deadlock_duration": self.deadlock_duration,
            "robots": [r.to_dict() for r in self.robots],
            "contacts": [c.to_dict() for c in self.contacts],
            "faults": [f.to_dict() for f in self.faults],
            "trajectory_hash": self.trajectory_hash,
        }

    def to_json(self, indent: int | None = 2) -> str:
        """JSON text (non-finite numbers as null)."""
        return json.dumps(self.to_dict(), indent=indent)

    def write_json(self, path: str | Path) -> None:
        """Write :meth:`to_json` atomically."""
        atomic_write_text(path, self.to_json() + "\n")

    def write_csv(self, robots_path: str | Path, contacts_path: str | Path | None = None) -> None:
        """Per-robot rows (and contact events if contacts_path) as CSV, atomically."""
        cols = [f.name for f in fields(RobotSummary)]
        atomic_write_text(robots_path, _csv_text([r.to_dict() for r in self.robots], cols))
        if contacts_path is not None:
            ccols = [f.name for f in fields(ContactEvent)]
            atomic_write_text(contacts_path, _csv_text([c.to_dict() for c in self.contacts], ccols))


# --------------------------------------------------------------------------- geometry


def sweep_pairs(lo: FloatArray, hi: FloatArray) -> tuple[IntArray, IntArray]:
    """All pairs (i < j) of overlapping axis-aligned boxes lo, hi (n, 2): sort and sweep on x.

    Deterministic order: by the boxes' rank in a stable sort on lo x, first of the pair,
    then second (i, j are the pair's smaller and larger index); cost O(n log n + pairs).
    Compiled with numba.
    """
    lo = np.ascontiguousarray(lo, dtype=float).reshape(-1, 2)
    hi = np.ascontiguousarray(hi, dtype=float).reshape(-1, 2)
    return _sweep_pairs_kernel(lo, hi)


def swept_disc_distances(
    d0: FloatArray, d1: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Minimum centre distance over a step and its time fraction, for linear relative motion.

    d0, d1: (K, 2) relative positions (m) at the start and end of the step;
    d(t) = d0 + (d1 - d0) t, t in [0, 1]. Returns (min |d(t)| (K,) m, argmin t (K,)).
    """
    w = d1 - d0
    ww = w[:, 0] * w[:, 0] + w[:, 1] * w[:, 1]
    dw = d0[:, 0] * w[:, 0] + d0[:, 1] * w[:, 1]
    t = np.clip(-dw / np.where(ww > 0.0, ww, 1.0), 0.0, 1.0)
    m = d0 + w * t[:, None]
    return np.hypot(m[:, 0], m[:, 1]), t


def _point_segment(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    ab = b - a
    ll = ab[:, 0] * ab[:, 0] + ab[:, 1] * ab[:, 1]
    ap = p - a
    t = np.clip((ap[:, 0] * ab[:, 0] + ap[:, 1] * ab[:, 1]) / np.where(ll > 0, ll, 1.0), 0, 1)
    d = ap - ab * t[:, None]
    return np.hypot(d[:, 0], d[:, 1])


def _cross(u: FloatArray, v: FloatArray) -> FloatArray:
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def segment_distances(
    p0: FloatArray, p1: FloatArray, a: FloatArray, b: FloatArray
) -> FloatArray:
    """Minimum distance (K,) m between segments p0-p1 and a-b, all (K, 2) m.

    With p0-p1 a centre's linear path over a step, this is the exact
    minimum over the step of the distance from the centre to wall a-b.
    """
    e = p1 - p0
    f = b - a
    o1, o2 = _cross(f, p0 - a), _cross(f, p1 - a)
    o3, o4 = _cross(e, a - p0), _cross(e, b - p0)
    crossing = (o1 * o2 < 0) & (o3 * o4 < 0)
    d = np.minimum(
        np.minimum(_point_segment(p0, a, b), _point_segment(p1, a, b)),
        np.minimum(_point_segment(a, p0, p1), _point_segment(b, p0, p1)),
    )
    return np.where(crossing, 0.0, d)


def _first_root(px: float, py: float, ex: float, ey: float, reach: float) -> float:
    """First t in [0, 1] with |(px, py) + (ex, ey) t| <= reach (inf if none)."""
    c = px * px + py * py - reach * reach
    if c <= 0.0:
        return 0.0
    b = px * ex + py * ey
    a = ex * ex + ey * ey
    disc = b * b - a * c
    if b >= 0.0 or disc < 0.0:
        return math.inf
    t = c / (math.sqrt(disc) - b)
    return t if t <= 1.0 else math.inf


def _first_wall_touch(
    p0: np.ndarray, p1: np.ndarray, a: np.ndarray, b: np.ndarray, reach: float
) -> tuple[float, np.ndarray]:
    """First t in [0, 1] at which the moving point p0 + (p1 - p0) t comes within reach (m)
    of segment a-b (closed form: the end discs and the side lines of the capsule), and
    the unit contact normal from the wall to the point then."""
    x0, y0, x1, y1 = float(p0[0]), float(p0[1]), float(p1[0]), float(p1[1])
    ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    ex, ey = x1 - x0, y1 - y0
    dx, dy = bx - ax, by - ay
    length = math.hypot(dx, dy)
    if length > 0.0:
        dx, dy = dx / length, dy / length
    nx, ny = -dy, dx

    def gap(t: float) -> tuple[float, float]:
        px, py = x0 + ex * t - ax, y0 + ey * t - ay
        u = min(max(px * dx + py * dy, 0.0), length)
        return px - u * dx, py - u * dy

    ox, oy = gap(0.0)
    if ox * ox + oy * oy <= reach * reach:
        t = 0.0
    else:
        t = min(_first_root(x0 - ax, y0 - ay, ex, ey, reach),
                _first_root(x0 - bx, y0 - by, ex, ey, reach))
        side0 = (x0 - ax) * nx + (y0 - ay) * ny
        rate = ex * nx + ey * ny
        if rate != 0.0 and length > 0.0:
            ts = (math.copysign(reach, side0) - side0) / rate
            if 0.0 <= ts <= 1.0:
                u = (x0 + ex * ts - ax) * dx + (y0 + ey * ts - ay) * dy
                if 0.0 <= u <= length:
                    t = min(t, ts)
        t = min(t, 1.0)
    ox, oy = gap(t)
    norm = math.hypot(ox, oy)
    if norm > 1e-12:
        return t, np.array([ox / norm, oy / norm])
    side = (x0 - ax) * nx + (y0 - ay) * ny
    return t, np.array([nx, ny]) if side >= 0 else np.array([-nx, -ny])


def _first_touching_substep(distances: FloatArray, reach: float) -> int:
    """The first substep whose minimum distance (m) is below reach (m); if none (rounding),
    the closest one."""
    below = np.flatnonzero(distances < reach)
    return int(below[0]) if len(below) else int(np.argmin(distances))


def _first_disc_touch(d0: np.ndarray, d1: np.ndarray, reach: float) -> tuple[float, np.ndarray]:
    """First t in [0, 1] with |d0 + (d1 - d0) t| <= reach, and the unit normal there (a to b)."""
    px, py = float(d0[0]), float(d0[1])
    wx, wy = float(d1[0]) - px, float(d1[1]) - py
    t = min(_first_root(px, py, wx, wy, reach), 1.0)
    if t == 1.0:  # the sampled minimum said "touching": take the closest approach
        ww = wx * wx + wy * wy
        t = min(max(-(px * wx + py * wy) / ww, 0.0), 1.0) if ww > 0 else 0.0
    mx, my = px + wx * t, py + wy * t
    norm = math.hypot(mx, my)
    if norm > 1e-12:
        return t, np.array([mx / norm, my / norm])
    wn = math.hypot(wx, wy)
    return t, (np.array([-wx / wn, -wy / wn]) if wn > 0 else np.array([1.0, 0.0]))


# --------------------------------------------------------------------------- compiled step
#
# A step's work (robot metrics, broad phase, TTC, swept distances, episode flags)
# runs in one numba kernel, pairs in the broad phase's order; where it computes a
# value it uses the same float operations in the same order as the numpy formulas
# above (no fastmath), so its results are bit-identical to them. Cheap squared-distance
# tests with a wide margin skip work whose outcome is certain. Rare events (contacts
# starting, getting deeper, ending) come back as a short list of rows that Python
# turns into ContactEvent objects.

_EV_DEEPER, _EV_START, _EV_END = 0, 1, 2  # + 3 for the wall family
_MARGIN = 1.0 + 1e-9  # relative margin of squared-distance pre-tests before hypot


@njit(cache=True)
def _new_depth_map() -> Any:
    """Deepest penetration (m) of each open contact episode, by pair key (see _step_kernel)."""
    return Dict.empty(key_type=types.int64, value_type=types.float64)


@njit(cache=True)
def _sweep_pairs_kernel(lo: FloatArray, hi: FloatArray) -> tuple[IntArray, IntArray]:
    """sweep_pairs, compiled: the same pairs in the same order."""
    n = lo.shape[0]
    if n < 2:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    order = np.argsort(lo[:, 0], kind="mergesort")
    slo_x = np.empty(n)
    for r in range(n):
        slo_x[r] = lo[order[r], 0]
    total = 0
    for r in range(n):
        top = hi[order[r], 0]
        s = r + 1
        while s < n and slo_x[s] <= top:
            s += 1
        total += s - r - 1
    out_a = np.empty(total, dtype=np.intp)
    out_b = np.empty(total, dtype=np.intp)
    k = 0
    for r in range(n):
        a = order[r]
        top = hi[a, 0]
        lo_y, hi_y = lo[a, 1], hi[a, 1]
        s = r + 1
        while s < n and slo_x[s] <= top:
            b = order[s]
            if lo[b, 1] <= hi_y and lo_y <= hi[b, 1]:
                out_a[k] = min(a, b)
                out_b[k] = max(a, b)
                k += 1
            s += 1
    return out_a[:k], out_b[:k]


@njit(cache=True, inline="always")
def _end_separation(p1: FloatArray, radii: FloatArray, i: int, j: int, out: FloatArray,
                    q: int) -> None:
    """out[q] = separation (m) of bodies i, j at positions p1, unless already computed."""
    if math.isnan(out[q]):
        out[q] = math.hypot(p1[j, 0] - p1[i, 0], p1[j, 1] - p1[i, 1]) - (radii[i] + radii[j])


@njit(cache=True, inline="always")
def _sorts_after(xa: float, a: int, xb: float, b: int) -> bool:
    """Whether key (xa, a) comes after (xb, b) in a stable sort on x (NaN last, as numpy)."""
    if xa > xb:
        return True
    if xa < xb:
        return False
    if xa == xb:
        return a > b
    na, nb = math.isnan(xa), math.isnan(xb)
    return (na and not nb) or (na and nb and a > b)


@njit(cache=True, inline="always")
def _clip01(x: float) -> float:
    return min(max(x, 0.0), 1.0)


@njit(cache=True, inline="always")
def _point_segment_1(px: float, py: float, ax: float, ay: float, bx: float,
                     by: float) -> float:
    """_point_segment for one point and segment (same operations)."""
    abx, aby = bx - ax, by - ay
    ll = abx * abx + aby * aby
    apx, apy = px - ax, py - ay
    t = _clip01((apx * abx + apy * aby) / (ll if ll > 0 else 1.0))
    return math.hypot(apx - abx * t, apy - aby * t)


@njit(cache=True, inline="always")
def _segment_distance_1(p0x: float, p0y: float, p1x: float, p1y: float, ax: float,
                        ay: float, bx: float, by: float) -> float:
    """segment_distances for one pair (same operations)."""
    ex, ey = p1x - p0x, p1y - p0y
    fx, fy = bx - ax, by - ay
    o1 = fx * (p0y - ay) - fy * (p0x - ax)
    o2 = fx * (p1y - ay) - fy * (p1x - ax)
    o3 = ex * (ay - p0y) - ey * (ax - p0x)
    o4 = ex * (by - p0y) - ey * (bx - p0x)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return 0.0
    return min(
        min(_point_segment_1(p0x, p0y, ax, ay, bx, by),
            _point_segment_1(p1x, p1y, ax, ay, bx, by)),
        min(_point_segment_1(ax, ay, p0x, p0y, p1x, p1y),
            _point_segment_1(bx, by, p0x, p0y, p1x, p1y)),
    )


@njit(cache=True, inline="always")
def _swept_path_distance(path: FloatArray, i: int, j: int) -> float:
    """Minimum distance (m) between the centres of bodies i and j over the substep path
    (S + 1, N, 2), each moving in a straight line between rows: per substep the closest
    point as in swept_disc_distances, the square root of the smallest squared norm."""
    best = math.inf
    for s in range(path.shape[0] - 1):
        d0x, d0y = path[s, j, 0] - path[s, i, 0], path[s, j, 1] - path[s, i, 1]
        d1x, d1y = path[s + 1, j, 0] - path[s + 1, i, 0], path[s + 1, j, 1] - path[s + 1, i, 1]
        wx, wy = d1x - d0x, d1y - d0y
        ww = wx * wx + wy * wy
        dw = d0x * wx + d0y * wy
        tt = _clip01(-dw / (ww if ww > 0.0 else 1.0))
        mx, my = d0x + wx * tt, d0y + wy * tt
        best = min(best, mx * mx + my * my)
    return math.sqrt(best)


@njit(cache=True, error_model="numpy")
def _step_kernel(
    t: float, dt: float, path: FloatArray, v1: FloatArray, acc: FloatArray,
    a_prev: FloatArray, has_prev: bool, goal: NDArray[np.bool_],
    radii: FloatArray, is_robot: NDArray[np.bool_],
    wall_lo: FloatArray, wall_hi: FloatArray, wall_segs: FloatArray, wall_radii: FloatArray,
    wall_normals: FloatArray, cfg: FloatArray, order: IntArray, n_prox: int,
    touch_bb: NDArray[np.bool_], touch_bw: NDArray[np.bool_], prox: NDArray[np.bool_],
    prox_contact: NDArray[np.bool_], depth: Any, path_length: FloatArray,
    adjustments: NDArray[np.int64],
    reached: NDArray[np.bool_], time_to_goal: FloatArray, min_sep: FloatArray,
    min_ttc: FloatArray, near_misses: NDArray[np.int64],
) -> tuple[NDArray[np.int64], FloatArray, int]:
    """One control step of EpisodeStats (see EpisodeStats.update); arrays updated in place.

    cfg = (separation_range, ttc_horizon, near_miss_distance, hysteresis,
    adjustment_threshold) in m, s, m, m, m/s^2; depth: the deepest penetration (m)
    of each open contact episode (see _new_depth_map). Returns the contact events as
    rows (code, a, b) with a value each (code _EV_DEEPER: the new deepest penetration
    m; _EV_START: the separation m; _EV_END: unused; +3 for walls, b the wall index),
    in the order to apply them, and the new proximity count.
    """
    sep_range, ttc_h, near_d, hyst, adj = cfg[0], cfg[1], cfg[2], cfg[3], cfg[4]
    n = radii.shape[0]
    nw = wall_radii.shape[0]
    last = path.shape[0] - 1  # substeps: the bodies move in straight lines between rows
    p0 = path[0]
    p1 = path[last]
    # per robot: path length and adjustments until the goal, time to goal
    for k in range(n):
        active = is_robot[k] and not reached[k]
        if active:
            path_length[k] += math.hypot(p1[k, 0] - p0[k, 0], p1[k, 1] - p0[k, 1])
            if has_prev:
                dax, day = acc[k, 0] - a_prev[k, 0], acc[k, 1] - a_prev[k, 1]
                sq = dax * dax + day * day  # hypot is slow: decided by sq unless close
                if adj >= 0.0 and sq > adj * adj * _MARGIN:
                    adjustments[k] += 1
                elif (adj < 0.0 or sq >= adj * adj / _MARGIN) and math.hypot(dax, day) > adj:
                    adjustments[k] += 1
            if goal[k]:
                time_to_goal[k] = t + dt
                reached[k] = True
        a_prev[k, 0] = acc[k, 0]
        a_prev[k, 1] = acc[k, 1]

    # broad phase: sort and sweep (as in sweep_pairs, same order) over boxes that cover
    # each body's swept step, its look-ahead path and the separation range, and the
    # wall boxes; each pair is handled where the sweep finds it
    pad = 0.5 * sep_range
    total = n + nw
    lo_x = np.empty(total)
    hi_x = np.empty(total)
    lo_y = np.empty(total)
    hi_y = np.empty(total)
    # step boxes grown by radius + pad + tol: bodies whose step boxes do not overlap
    # are surely beyond the separation range (tol >> rounding of the exact distance)
    scale = pad
    for k in range(n):
        scale = max(scale, radii[k])
        for s in range(last + 1):
            scale = max(scale, abs(path[s, k, 0]), abs(path[s, k, 1]))
    tol = 1e-9 * (1.0 + 4.0 * scale)
    # dev[k]: how far (m) body k's substep path strays from the chord p0 -> p1 (at equal
    # times), plus tol; a pair's distance on the substep paths differs from its distance
    # on the chords by at most dev[i] + dev[j] at every instant
    dev = np.zeros(n)
    step_box = np.empty((n, 4))
    for k in range(n):
        grow = radii[k] + pad
        x0, x1 = min(p0[k, 0], p1[k, 0]), max(p0[k, 0], p1[k, 0])
        y0, y1 = min(p0[k, 1], p1[k, 1]), max(p0[k, 1], p1[k, 1])
        if last > 1:
            ex, ey = p1[k, 0] - p0[k, 0], p1[k, 1] - p0[k, 1]
            worst = 0.0
            for s in range(1, last):
                px, py = path[s, k, 0], path[s, k, 1]
                x0, x1 = min(x0, px), max(x1, px)
                y0, y1 = min(y0, py), max(y1, py)
                f = s / last
                ox, oy = px - (p0[k, 0] + ex * f), py - (p0[k, 1] + ey * f)
                worst = max(worst, ox * ox + oy * oy)
            dev[k] = math.sqrt(worst) * _MARGIN + tol
        ax = p1[k, 0] + v1[k, 0] * ttc_h
        ay = p1[k, 1] + v1[k, 1] * ttc_h
        lo_x[k], hi_x[k] = min(x0, ax) - grow, max(x1, ax) + grow
        lo_y[k], hi_y[k] = min(y0, ay) - grow, max(y1, ay) + grow
        step_box[k, 0], step_box[k, 1] = x0 - grow - tol, x1 + grow + tol
        step_box[k, 2], step_box[k, 3] = y0 - grow - tol, y1 + grow + tol
    for w in range(nw):
        lo_x[n + w], hi_x[n + w] = wall_lo[w, 0], wall_hi[w, 0]
        lo_y[n + w], hi_y[n + w] = wall_lo[w, 1], wall_hi[w, 1]
    # the stable order of lo_x (as np.argsort(kind="stable")): insertion sort from the
    # previous step's order, which the boxes change little
    for r in range(1, total):
        o = order[r]
        x = lo_x[o]
        s = r - 1
        while s >= 0 and _sorts_after(lo_x[order[s]], order[s], x, o):
            order[s + 1] = order[s]
            s -= 1
        order[s + 1] = o
    slo_x = lo_x[order]
    shi_x = hi_x[order]
    slo_y = lo_y[order]
    shi_y = hi_y[order]
    # x overlaps: box r meets boxes r + 1 .. ends[r] - 1 (in sorted order)
    ends = np.empty(total, dtype=np.intp)
    count = 0
    for r in range(total):
        top = shi_x[r]
        s = r + 1
        while s < total and slo_x[s] <= top:
            s += 1
        ends[r] = s
        count += s - r - 1
    # those whose y ranges overlap too (branch-free: unpredictable tests are costly)
    pa = np.empty(count, dtype=np.intp)
    pb = np.empty(count, dtype=np.intp)
    m = 0
    for r in range(total):
        y_lo, y_hi, first = slo_y[r], shi_y[r], order[r]
        for s in range(r + 1, ends[r]):
            pa[m] = min(first, order[s])
            pb[m] = max(first, order[s])
            m += (slo_y[s] <= y_hi) & (y_lo <= shi_y[s])

    # body pairs: constant-velocity TTC at the step's end (pairs with a robot); those
    # whose step boxes meet are candidates for the exact swept separation
    cand = np.empty(m, dtype=np.intp)
    wall_pairs = np.empty(m, dtype=np.intp)
    nc = 0
    nwp = 0
    for q in range(m):
        i, j = pa[q], pb[q]
        if j >= n:
            wall_pairs[nwp] = q
            nwp += i < n
            continue
        reach = radii[i] + radii[j]
        d1x, d1y = p1[j, 0] - p1[i, 0], p1[j, 1] - p1[i, 1]
        wx, wy = v1[j, 0] - v1[i, 0], v1[j, 1] - v1[i, 1]
        aa = wx * wx + wy * wy
        bb = d1x * wx + d1y * wy
        cc = d1x * d1x + d1y * d1y - reach * reach
        disc = bb * bb - aa * cc
        # first root of |d + w t| = reach, stable form c / (-b + sqrt(disc)); 0 if overlapping
        ttc = cc / max(math.sqrt(max(disc, 0.0)) - bb, 1e-300)
        ttc = 0.0 if cc <= 0.0 else ttc
        hit = (((bb < 0.0) & (disc >= 0.0)) | (cc <= 0.0)) & (is_robot[i] | is_robot[j])
        ttc = ttc if hit & (ttc <= ttc_h) else math.inf
        min_ttc[i] = min(min_ttc[i], ttc)
        min_ttc[j] = min(min_ttc[j], ttc)
        cand[nc] = q
        nc += ((step_box[i, 0] <= step_box[j, 1]) & (step_box[j, 0] <= step_box[i, 1])
               & (step_box[i, 2] <= step_box[j, 3]) & (step_box[j, 2] <= step_box[i, 3]))

    # exact minimum separation over the step; the pairs within range are kept. hypot is
    # slow: it is skipped where squared distances (with a margin far above rounding)
    # show that the pair is beyond the range, or within it but with a separation that
    # changes nothing (not below either minimum, the near-miss distance or 0; then inf
    # is stored). The separation at the step's end (bend) is computed when needed.
    bi = np.empty(nc, dtype=np.intp)
    bj = np.empty(nc, dtype=np.intp)
    bsep = np.empty(nc)
    bend = np.full(nc, np.nan)
    nb = 0
    any_near = False
    for c in range(nc):
        i, j = pa[cand[c]], pb[cand[c]]
        reach = radii[i] + radii[j]
        d0x, d0y = p0[j, 0] - p0[i, 0], p0[j, 1] - p0[i, 1]
        d1x, d1y = p1[j, 0] - p1[i, 0], p1[j, 1] - p1[i, 1]
        wx, wy = d1x - d0x, d1y - d0y
        ww = wx * wx + wy * wy
        dw = d0x * wx + d0y * wy
        tt = _clip01(-dw / (ww if ww > 0.0 else 1.0))
        mx, my = d0x + wx * tt, d0y + wy * tt
        msq = mx * mx + my * my  # on the chords
        slack = dev[i] + dev[j]
        far = (reach + sep_range + slack) * (reach + sep_range + slack)
        if msq > far * _MARGIN:
            continue  # surely beyond the range
        low = max(max(min_sep[i], min_sep[j]), max(near_d, 0.0))
        near = (reach + low + slack) * (reach + low + slack)
        inner = max(reach + sep_range - slack, 0.0)
        if low < sep_range and msq < inner * inner / _MARGIN and msq > near * _MARGIN:
            sep = math.inf  # surely within the range, and surely >= low
        else:
            exact = math.hypot(mx, my) if last == 1 else _swept_path_distance(path, i, j)
            sep = exact - reach
            if not sep < sep_range:
                continue
            min_sep[i] = min(min_sep[i], sep)
            min_sep[j] = min(min_sep[j], sep)
            any_near |= sep < near_d
        bi[nb], bj[nb], bsep[nb] = i, j, sep
        nb += 1

    # body-wall pairs: cheap bound by the wall's supporting line, then the exact
    # distance; open contacts stay candidates until they end
    wi = np.empty(nwp, dtype=np.intp)
    wj = np.empty(nwp, dtype=np.intp)
    wsep = np.empty(nwp)
    wend = np.empty(nwp)
    nwc = 0
    for c in range(nwp):
        i, w = pa[wall_pairs[c]], pb[wall_pairs[c]] - n
        reach = radii[i] + wall_radii[w]
        ax, ay = wall_segs[w, 0, 0], wall_segs[w, 0, 1]
        bx, by = wall_segs[w, 1, 0], wall_segs[w, 1, 1]
        nx, ny = wall_normals[w, 0], wall_normals[w, 1]
        side0 = (p0[i, 0] - ax) * nx + (p0[i, 1] - ay) * ny
        side1 = (p1[i, 0] - ax) * nx + (p1[i, 1] - ay) * ny
        bound = 0.0 if side0 * side1 <= 0.0 else min(abs(side0), abs(side1))
        if bound - dev[i] < reach or touch_bw[i, w]:
            wi[nwc], wj[nwc] = i, w
            dist = math.inf
            for s in range(last):
                dist = min(dist, _segment_distance_1(
                    path[s, i, 0], path[s, i, 1], path[s + 1, i, 0], path[s + 1, i, 1],
                    ax, ay, bx, by))
            wsep[nwc] = dist - reach
            wend[nwc] = _point_segment_1(p1[i, 0], p1[i, 1], ax, ay, bx, by) - reach
            nwc += 1

    # contact episodes of both families -> event rows
    codes = np.empty((2 * (nb + nwc), 3), dtype=np.int64)
    vals = np.empty(2 * (nb + nwc))
    ne = 0
    stride = n + nw  # pair key: i * stride + j (bodies), i * stride + n + w (walls)
    for fam in range(2):
        cnt = nb if fam == 0 else nwc
        ii = bi if fam == 0 else wi
        jj = bj if fam == 0 else wj
        ss = bsep if fam == 0 else wsep
        ee = bend if fam == 0 else wend
        state = touch_bb if fam == 0 else touch_bw
        base = 3 * fam
        for q in range(cnt):  # open episodes that got deeper than ever
            if state[ii[q], jj[q]] and ss[q] < 0.0:
                key = ii[q] * stride + jj[q] + fam * n
                if -ss[q] > depth[key]:
                    depth[key] = -ss[q]
                    codes[ne, 0], codes[ne, 1], codes[ne, 2] = base + _EV_DEEPER, ii[q], jj[q]
                    vals[ne] = -ss[q]
                    ne += 1
        start = ne
        for q in range(cnt):  # new episodes
            if ss[q] < 0.0 and not state[ii[q], jj[q]]:
                codes[ne, 0], codes[ne, 1], codes[ne, 2] = base + _EV_START, ii[q], jj[q]
                vals[ne] = ss[q]
                ne += 1
                depth[ii[q] * stride + jj[q] + fam * n] = -ss[q]
        for q in range(cnt):  # ended episodes (a new one may end at once)
            live = state[ii[q], jj[q]] or ss[q] < 0.0
            if live and fam == 0:
                _end_separation(p1, radii, ii[q], jj[q], ee, q)
            if live and ee[q] > hyst:
                codes[ne, 0], codes[ne, 1], codes[ne, 2] = base + _EV_END, ii[q], jj[q]
                vals[ne] = 0.0
                ne += 1
                depth.pop(ii[q] * stride + jj[q] + fam * n)
        for r in range(start, ne):
            if codes[r, 0] == base + _EV_START:
                state[codes[r, 1], codes[r, 2]] = True
        for r in range(start, ne):
            if codes[r, 0] == base + _EV_END:
                state[codes[r, 1], codes[r, 2]] = False

    # proximity episodes (near misses)
    if nb > 0 and (n_prox != 0 or any_near):
        limit = near_d + hyst
        n_prox = 0
        for q in range(nb):
            i, j = bi[q], bj[q]
            live = prox[i, j] or bsep[q] < near_d
            had = prox_contact[i, j] or bsep[q] < 0.0
            if live:
                _end_separation(p1, radii, i, j, bend, q)
            ended = live and bend[q] > limit
            if ended and not had:
                near_misses[i] += 1
                near_misses[j] += 1
            keep = live and not ended
            prox[i, j] = keep
            prox_contact[i, j] = had and keep
            n_prox += keep
    return codes[:ne], vals[:ne], n_prox


# --------------------------------------------------------------------------- the recorder


def _c_array(x: ArrayLike, dtype: type, shape: tuple[int, ...]) -> np.ndarray:
    """x as a C-contiguous array of dtype and shape, broadcast if need be (x itself when
    it already is one)."""
    a = np.ascontiguousarray(x, dtype=dtype)
    return a if a.shape == shape else np.ascontiguousarray(np.broadcast_to(a, shape))


class EpisodeStats:
    """Contact episodes and per-robot metrics, updated once per control step.

    radii (N,) m; kinds (N,) "robot" or "traffic"; names (N,) (default
    "body<i>"); walls: (segments (W, 2, 2) m, half-thicknesses (W,) m) or
    None; dt: control period (s); velocities: (N, 2) m/s at t = 0 (used for
    the impact speed of contacts in the first step; else the step's mean
    velocity is used); goals: (N, 2) m, the robots' goals (rows of other
    bodies ignored), for the liveness metrics (None: not tracked).

    Episode flags are kept per pair in dense boolean (N, N) and (N, W) arrays
    (N^2 bytes each: 9 MB for 3000 bodies), the depth of open contacts in a small
    map; candidate pairs come from one sort-and-sweep per step over boxes that
    cover each body's swept step, its constant-velocity path over the TTC horizon
    and the separation range. The first update in a process loads (or, the first
    time, compiles and caches) the numba kernel.
    """

    def __init__(
        self,
        radii: ArrayLike,
        kinds: Sequence[str],
        names: Sequence[str] | None = None,
        walls: tuple[ArrayLike, ArrayLike] | None = None,
        dt: float = 0.1,
        config: StatsConfig | None = None,
        velocities: ArrayLike | None = None,
        goals: ArrayLike | None = None,
    ) -> None:
        self.config = config or StatsConfig()
        self.radii = np.ascontiguousarray(radii, dtype=float).reshape(-1)
        self.n = n = len(self.radii)
        self.kinds = tuple(kinds)
        self.names = tuple(names) if names is not None else tuple(f"body{i}" for i in range(n))
        self.dt = float(dt)
        if walls is None:
            segs, wr = np.zeros((0, 2, 2)), np.zeros(0)
        else:
            segs = np.ascontiguousarray(walls[0], dtype=float).reshape(-1, 2, 2)
            wr = np.ascontiguousarray(walls[1], dtype=float).reshape(-1)
        self.wall_segments, self.wall_radii = segs, wr
        self.n_walls = len(wr)
        pad = 0.5 * self.config.separation_range
        self._wall_lo = np.minimum(segs[:, 0], segs[:, 1]) - (wr + pad)[:, None]
        self._wall_hi = np.maximum(segs[:, 0], segs[:, 1]) + (wr + pad)[:, None]
        along = segs[:, 1] - segs[:, 0]
        length = np.hypot(along[:, 0], along[:, 1])
        unit = along / np.where(length > 0, length, 1.0)[:, None]
        self._wall_normals = np.stack([-unit[:, 1], unit[:, 0]], axis=1)
        self.is_robot = np.array([k == "robot" for k in self.kinds], dtype=bool)
        self._v_prev = None if velocities is None else np.asarray(velocities, float).copy()
        self.contacts: list[ContactEvent] = []
        self.faults: list[FaultEvent] = []
        # pair state: body-body (upper triangle used) and body-wall
        self._touch_bb = np.zeros((n, n), dtype=bool)
        self._touch_bw = np.zeros((n, self.n_walls), dtype=bool)
        self._open_events: dict[tuple[int, int, bool], ContactEvent] = {}
        self._depth = _new_depth_map()
        self._prox = np.zeros((n, n), dtype=bool)
        self._prox_contact = np.zeros((n, n), dtype=bool)
        self._n_prox = 0
        self.collisions = np.zeros(n, dtype=np.int64)
        self.wall_collisions = np.zeros(n, dtype=np.int64)
        self.near_misses = np.zeros(n, dtype=np.int64)
        self.min_separation = np.full(n, np.inf)
        self.min_ttc = np.full(n, np.inf)
        self.reached = np.zeros(n, dtype=bool)
        self.time_to_goal = np.full(n, np.nan)
        self.path_length = np.zeros(n)
        self.adjustments = np.zeros(n, dtype=np.int64)
        self._a_prev: FloatArray | None = None
        cfg = self.config
        self._cfg = np.array([cfg.separation_range, cfg.ttc_horizon, cfg.near_miss_distance,
                              cfg.hysteresis, cfg.adjustment_threshold], dtype=float)
        self._order = np.arange(n + self.n_walls)  # broad phase order, kept between steps
        self.time = 0.0
        self.steps = 0
        # liveness: distances to the goals over the last stuck window (a ring of steps)
        self._goals = None if goals is None else _c_array(goals, np.float64, (n, 2))
        self._window = max(1, int(round(self.config.stuck_window / self.dt)))
        self._goal_dist = np.full((self._window, n), np.nan)
        self.stuck_time = np.zeros(n)
        self.time_away = np.zeros(n)
        self.at_goal = np.zeros(n, dtype=bool)
        self.deadlock_time = math.nan
        self.deadlock_duration = 0.0

    def __getstate__(self) -> dict[str, Any]:
        """The attributes, the depth map (a numba typed dict) as a plain dict."""
        state = self.__dict__.copy()
        state["_depth"] = dict(self._depth)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Restore the attributes; the depth map is refilled in its insertion order."""
        self.__dict__.update(state)
        depth = _new_depth_map()
        for key, value in state["_depth"].items():
            depth[key] = value
        self._depth = depth

    # ------------------------------------------------------------------ update

    def update(
        self,
        t: float,
        positions_before: ArrayLike,
        positions_after: ArrayLike,
        velocities_after: ArrayLike,
        commanded_accels: ArrayLike,
        goal_reached: ArrayLike,
        substeps: ArrayLike | None = None,
    ) -> list[ContactEvent]:
        """Account for one control step [t, t + dt]; returns the contacts that started in it.

        positions_before/after (N, 2) m; velocities_after (N, 2) m/s;
        commanded_accels (N, 2) m/s^2; goal_reached (N,) bool at the step's end;
        substeps: the centres (S + 1, N, 2) m after each physics substep, rows 0 and S
        being positions_before and positions_after (see
        :attr:`nao_arena.world.World.substep_positions`); contacts and separations are
        then exact for straight motion between rows. None: one straight line per step.
        """
        n = self.n
        if substeps is None:
            path = np.stack([_c_array(positions_before, np.float64, (n, 2)),
                             _c_array(positions_after, np.float64, (n, 2))])
        else:
            path = np.ascontiguousarray(substeps, dtype=np.float64)
            if path.ndim != 3 or path.shape[0] < 2 or path.shape[1:] != (n, 2):
                raise ValueError(f"substeps: expected shape (S + 1, {n}, 2) with S >= 1, "
                                 f"got {path.shape}")
        v1 = _c_array(velocities_after, np.float64, (n, 2))
        acc = _c_array(commanded_accels, np.float64, (n, 2))
        goal = _c_array(goal_reached, np.bool_, (n,))
        t = float(t)
        has_prev = self._a_prev is not None
        if not has_prev:
            self._a_prev = np.empty((n, 2))
        codes, vals, self._n_prox = _step_kernel(
            t, self.dt, path, v1, acc, self._a_prev, has_prev, goal,
            self.radii, self.is_robot, self._wall_lo, self._wall_hi, self.wall_segments,
            self.wall_radii, self._wall_normals, self._cfg, self._order, self._n_prox,
            self._touch_bb, self._touch_bw, self._prox, self._prox_contact, self._depth,
            self.path_length, self.adjustments, self.reached, self.time_to_goal,
            self.min_separation, self.min_ttc, self.near_misses,
        )
        started: list[ContactEvent] = []
        if len(codes):
            self._apply_events(t, codes.tolist(), vals.tolist(), path, started)
        self._v_prev = v1.copy()
        self._liveness(t, path[-1], goal)
        self.steps += 1
        self.time = t + self.dt
        started.sort(key=lambda e: (e.time, e.a, e.b, e.kind_b))
        return started

    def _liveness(self, t: float, p1: FloatArray, goal: NDArray[np.bool_]) -> None:
        """Stuck, away-after-arrival and deadlock time of the step that ends at t + dt
        (after the kernel marked new arrivals)."""
        robots = self.is_robot
        self.at_goal = goal & robots
        self.time_away += self.dt * (self.reached & ~goal & robots)
        if self._goals is None:
            return
        dist = np.hypot(p1[:, 0] - self._goals[:, 0], p1[:, 1] - self._goals[:, 1])
        slot = self.steps % self._window
        before = self._goal_dist[slot]  # the distance one window ago (NaN: too early)
        away = robots & ~goal
        stuck = away & (before - dist < self.config.stuck_progress)
        self._goal_dist[slot] = dist
        self.stuck_time += self.dt * stuck
        if np.any(away) and np.array_equal(stuck, away):
            self.deadlock_duration += self.dt
            if math.isnan(self.deadlock_time):
                self.deadlock_time = t + self.dt

    def record_fault(self, t: float, body: int, message: str) -> FaultEvent:
        """Record an agent's fault at time t (s) for the robot of body index ``body``."""
        ev = FaultEvent(float(t), int(body), self.names[body], str(message))
        self.faults.append(ev)
        return ev

    def _apply_events(
        self, t: float, codes: list[list[int]], vals: list[float], path: FloatArray,
        started: list[ContactEvent],
    ) -> None:
        """Contact episodes that deepened, started or ended in this step (the kernel's rows);
        path: the step's substep centres (S + 1, N, 2) m."""
        for (code, a, b), val in zip(codes, vals, strict=True):
            wall = code >= 3
            kind = code - 3 if wall else code
            if kind == _EV_DEEPER:
                ev = self._open_events[(a, b, wall)]
                ev.max_penetration = max(ev.max_penetration, val)
            elif kind == _EV_START:
                if wall:
                    ev = self._wall_event(t, a, b, path, val)
                    self.wall_collisions[a] += 1
                else:
                    ev = self._disc_event(t, a, b, path, val)
                    self.collisions[b] += 1
                self.collisions[a] += 1
                self._open_events[(a, b, wall)] = ev
                self.contacts.append(ev)
                started.append(ev)
            else:
                self._open_events.pop((a, b, wall)).end_time = t + self.dt

    def _approach_velocity(self, path: FloatArray, s: int, body: int) -> FloatArray:
        """Velocity (2,) m/s of ``body`` while it first touched, in substep s of path: the
        substep's displacement over its duration (S > 1), else the velocity at the step's
        start (the step's mean velocity for the first step without start velocities)."""
        substeps = len(path) - 1
        if substeps > 1:
            return (path[s + 1, body] - path[s, body]) / (self.dt / substeps)
        if self._v_prev is not None:
            return self._v_prev[body]
        return (path[1, body] - path[0, body]) / self.dt

    def _disc_event(self, t: float, a: int, b: int, path: FloatArray, sep: float) -> ContactEvent:
        reach = float(self.radii[a] + self.radii[b])
        rel = path[:, b] - path[:, a]
        s = _first_touching_substep(swept_disc_distances(rel[:-1], rel[1:])[0], reach)
        tc, nrm = _first_disc_touch(rel[s], rel[s + 1], reach)
        vrel = self._approach_velocity(path, s, b) - self._approach_velocity(path, s, a)
        return ContactEvent(
            time=t + (s + tc) / (len(path) - 1) * self.dt, a=a, b=b,
            kind_a=self.kinds[a], kind_b=self.kinds[b], name_a=self.names[a],
            name_b=self.names[b], impact_speed=max(0.0, -float(vrel @ nrm)),
            max_penetration=-sep,
        )

    def _wall_event(self, t: float, body: int, wall: int, path: FloatArray,
                    sep: float) -> ContactEvent:
        reach = float(self.radii[body] + self.wall_radii[wall])
        seg = self.wall_segments[wall]
        own = path[:, body]
        ends = np.broadcast_to(seg, (len(own) - 1, 2, 2))
        s = _first_touching_substep(
            segment_distances(own[:-1], own[1:], ends[:, 0], ends[:, 1]), reach)
        tc, nrm = _first_wall_touch(own[s], own[s + 1], seg[0], seg[1], reach)
        v = self._approach_velocity(path, s, body)
        return ContactEvent(
            time=t + (s + tc) / (len(path) - 1) * self.dt, a=body, b=wall,
            kind_a=self.kinds[body], kind_b="wall", name_a=self.names[body],
            name_b=f"wall{wall}", impact_speed=max(0.0, -float(v @ nrm)),
            max_penetration=-sep,
        )

    # ------------------------------------------------------------------ results

    def summary(self) -> EpisodeSummary:
        """The episode so far: per-robot rows (robots only, in body order) and all events.

        Open contact episodes have end_time NaN; open proximity episodes without
        contact count as near misses.
        """
        pending = np.zeros(self.n, dtype=np.int64)
        ii, jj = np.nonzero(self._prox & ~self._prox_contact)
        np.add.at(pending, ii, 1)
        np.add.at(pending, jj, 1)
        if self._goals is None or self.steps == 0:
            final = [math.nan] * self.n
        else:
            last = self._goal_dist[(self.steps - 1) % self._window]
            final = [float(d) for d in last]
        rows = []
        for k in np.flatnonzero(self.is_robot).tolist():
            active_time = self.time_to_goal[k] if self.reached[k] else self.time
            rows.append(
                RobotSummary(
                    index=k,
                    name=self.names[k],
                    reached_goal=bool(self.reached[k]),
                    success=bool(self.reached[k] and self.collisions[k] == 0
                                 and self.at_goal[k]),
                    time_to_goal=float(self.time_to_goal[k]),
                    path_length=float(self.path_length[k]),
                    collisions=int(self.collisions[k]),
                    wall_collisions=int(self.wall_collisions[k]),
                    near_misses=int(self.near_misses[k] + pending[k]),
                    min_separation=float(self.min_separation[k]),
                    min_ttc=float(self.min_ttc[k]),
                    adjustments=int(self.adjustments[k]),
                    adjustment_rate=(
                        float(self.adjustments[k] / active_time) if active_time > 0 else 0.0
                    ),
                    stuck_time=float(self.stuck_time[k]),
                    time_away_after_arrival=float(self.time_away[k]),
                    final_goal_distance=final[k],
                    at_goal_at_end=bool(self.at_goal[k]),
                    timed_out=not bool(self.reached[k]),
                )
            )
        return EpisodeSummary(
            duration=self.time, steps=self.steps, robots=rows,
            contacts=list(self.contacts), faults=list(self.faults),
            deadlock_time=self.deadlock_time, deadlock_duration=self.deadlock_duration,
        )
