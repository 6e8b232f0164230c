"""Collision statistics and per-robot metrics of one episode (numpy only).

The caller (the control loop) makes one call per control step::

    stats = EpisodeStats(radii, kinds, names, walls=world.wall_segments(),
                         dt=world.dt, velocities=state.velocities)
    for each step:
        before = world.state()
        after = world.step(accels)
        stats.update(before.time, before.positions, after.positions,
                     after.velocities, accels, goal_reached)
    summary = stats.summary()          # EpisodeSummary: to_dict(), write_json(), write_csv()

``t`` is the time at the start of the step (s); the step spans
[t, t + dt]. Positions are (N, 2) m, velocities (N, 2) m/s, commanded
accelerations (N, 2) m/s^2 (what the agents asked for, before clipping),
``goal_reached`` (N,) bool at the end of the step (ignored for non-robots).

Contacts are detected by our own exact check, independent of the physics
engine: between two control steps every centre is taken to move linearly
from its start to its end position, and the minimum distance of each pair
over the step is computed in closed form (a quadratic in t for two discs;
segment-to-segment distance for a disc against a wall), so that two fast
discs that pass through each other within one step are still counted. A
contact episode starts when the separation (surface distance, m) drops
below 0 and ends when the separation at a step's end exceeds the
hysteresis; it is recorded once, with its start time, the bodies, the
relative normal speed at impact (m/s, from the velocities at the step's
start) and the maximum penetration depth over the episode (m). Pairs are
found by a sort-and-sweep broad phase on the swept bounding boxes, in
numpy.

Per robot: collisions (contact episodes it took part in, walls included),
near misses (proximity episodes with another body, separation below
``near_miss_distance`` and no contact in the episode), minimum separation
to another body (m, negative while overlapping; exact when below
``separation_range``, else reported as inf), minimum constant-velocity
time to collision with another body at the step ends (s; inf beyond
``ttc_horizon``), time to goal (s, NaN if never),
path length until the goal (m), success (goal reached without any
collision), acceleration adjustments (steps where the commanded
acceleration changed by more than ``adjustment_threshold`` m/s^2, until the
goal) and their rate (1/s).
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
    ttc_horizon (s): longer times to collision count as none.
    """

    near_miss_distance: float = 0.2
    hysteresis: float = 0.01
    adjustment_threshold: float = 0.1
    separation_range: float = 1.0
    ttc_horizon: float = 5.0

    def __post_init__(self) -> None:
        if self.separation_range < self.near_miss_distance + self.hysteresis:
            raise ValueError("separation_range must be >= near_miss_distance + hysteresis")


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
    """An agent's fault at time (s): the robot index, its name and what went wrong."""

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

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (non-finite numbers as None)."""
        return {k: _clean(v) for k, v in asdict(self).items()}


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write text to path atomically: a temporary file in the same folder, then os.replace."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
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
    """An episode's results: duration (s), steps, per-robot rows, contact events, faults."""

    duration: float
    steps: int
    robots: list[RobotSummary] = field(default_factory=list)
    contacts: list[ContactEvent] = field(default_factory=list)
    faults: list[FaultEvent] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (JSON-ready)."""
        return {
            "duration": self.duration,
            "steps": self.steps,
            "robots": [r.to_dict() for r in self.robots],
            "contacts": [c.to_dict() for c in self.contacts],
            "faults": [f.to_dict() for f in self.faults],
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

    Deterministic order (stable sort on lo x); cost O(n log n + pairs).
    """
    n = len(lo)
    if n < 2:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    order = np.argsort(lo[:, 0], kind="stable")
    slo, shi = lo[order], hi[order]
    idx = np.arange(n)
    counts = np.searchsorted(slo[:, 0], shi[:, 0], side="right") - idx - 1
    np.maximum(counts, 0, out=counts)
    total = int(counts.sum())
    if total == 0:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    first = np.repeat(idx, counts)
    second = np.arange(total) - np.repeat(np.cumsum(counts) - counts - idx - 1, counts)
    keep = (slo[second, 1] <= shi[first, 1]) & (slo[first, 1] <= shi[second, 1])
    a, b = order[first[keep]], order[second[keep]]
    return np.minimum(a, b), np.maximum(a, b)


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


# --------------------------------------------------------------------------- the recorder


class EpisodeStats:
    """Contact episodes and per-robot metrics, updated once per control step.

    radii (N,) m; kinds (N,) "robot" or "traffic"; names (N,) (default
    "body<i>"); walls: (segments (W, 2, 2) m, half-thicknesses (W,) m) or
    None; dt: control period (s); velocities: (N, 2) m/s at t = 0 (used for
    the impact speed of contacts in the first step; else the step's mean
    velocity is used).

    Episode flags are kept per pair in dense boolean (N, N) and (N, W) arrays
    (N^2 bytes each: 9 MB for 3000 bodies); candidate pairs come from one sort-and-sweep
    per step over boxes that cover each body's swept step, its
    constant-velocity path over the TTC horizon and the separation range.
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
    ) -> None:
        self.config = config or StatsConfig()
        self.radii = np.asarray(radii, dtype=float)
        self.n = n = len(self.radii)
        self.kinds = tuple(kinds)
        self.names = tuple(names) if names is not None else tuple(f"body{i}" for i in range(n))
        self.dt = float(dt)
        if walls is None:
            segs, wr = np.zeros((0, 2, 2)), np.zeros(0)
        else:
            segs = np.asarray(walls[0], dtype=float).reshape(-1, 2, 2)
            wr = np.asarray(walls[1], dtype=float).reshape(-1)
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
        self._open_bb = self._open_bw = 0
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
        self.time = 0.0
        self.steps = 0

    # ------------------------------------------------------------------ update

    def update(
        self,
        t: float,
        positions_before: ArrayLike,
        positions_after: ArrayLike,
        velocities_after: ArrayLike,
        commanded_accels: ArrayLike,
        goal_reached: ArrayLike,
    ) -> list[ContactEvent]:
        """Account for one control step [t, t + dt]; returns the contacts that started in it.

        positions_before/after (N, 2) m; velocities_after (N, 2) m/s;
        commanded_accels (N, 2) m/s^2; goal_reached (N,) bool at the step's end.
        """
        p0 = np.asarray(positions_before, dtype=float)
        p1 = np.asarray(positions_after, dtype=float)
        v1 = np.asarray(velocities_after, dtype=float)
        acc = np.asarray(commanded_accels, dtype=float)
        dt = self.dt
        v0 = self._v_prev if self._v_prev is not None else (p1 - p0) / dt
        self._robot_metrics(t, p0, p1, acc, np.asarray(goal_reached, dtype=bool))

        cfg = self.config
        n = self.n
        pad = 0.5 * cfg.separation_range
        ahead = p1 + v1 * cfg.ttc_horizon
        grow = (self.radii + pad)[:, None]
        lo = np.minimum(np.minimum(p0, p1), ahead) - grow
        hi = np.maximum(np.maximum(p0, p1), ahead) + grow
        if self.n_walls:
            lo = np.concatenate([lo, self._wall_lo])
            hi = np.concatenate([hi, self._wall_hi])
        i, j = sweep_pairs(lo, hi)
        bodies = j < n
        started: list[ContactEvent] = []
        self._body_pairs(t, i[bodies], j[bodies], p0, p1, v0, v1, started)
        if self.n_walls:
            walls = (i < n) & ~bodies
            self._wall_pairs(t, i[walls], j[walls] - n, p0, p1, v0, started)
        self._v_prev = v1.copy()
        self.steps += 1
        self.time = t + dt
        started.sort(key=lambda e: (e.time, e.a, e.b, e.kind_b))
        return started

    def record_fault(self, t: float, robot: int, message: str) -> FaultEvent:
        """Record an agent's fault at time t (s) for robot index ``robot``."""
        ev = FaultEvent(float(t), int(robot), self.names[robot], str(message))
        self.faults.append(ev)
        return ev

    def _robot_metrics(
        self, t: float, p0: FloatArray, p1: FloatArray, acc: FloatArray,
        goal: NDArray[np.bool_],
    ) -> None:
        """Path length and adjustments until the goal; time to goal."""
        active = self.is_robot & ~self.reached
        step = p1 - p0
        self.path_length += np.where(active, np.hypot(step[:, 0], step[:, 1]), 0.0)
        if self._a_prev is not None:
            da = acc - self._a_prev
            change = np.hypot(da[:, 0], da[:, 1]) > self.config.adjustment_threshold
            self.adjustments += active & change
        self._a_prev = acc.copy()
        new_goal = goal & active
        if np.any(new_goal):
            self.time_to_goal[new_goal] = t + self.dt
            self.reached |= new_goal

    def _body_pairs(
        self, t: float, i: IntArray, j: IntArray, p0: FloatArray, p1: FloatArray,
        v0: FloatArray, v1: FloatArray, started: list[ContactEvent],
    ) -> None:
        cfg = self.config
        reach = self.radii[i] + self.radii[j]
        d0 = p0[j] - p0[i]
        d1 = p1[j] - p1[i]
        self._ttc(i, j, d1, v1[j] - v1[i], reach)
        dmin, _ = swept_disc_distances(d0, d1)
        sep = dmin - reach
        # every open episode has sep < separation_range (its separation at the step's
        # start was below it), so pairs beyond it can be dropped here
        near = np.flatnonzero(sep < cfg.separation_range)
        if len(near) == 0:
            return
        if len(near) < len(sep):
            i, j, sep, reach, d0, d1 = i[near], j[near], sep[near], reach[near], d0[near], d1[near]
        np.minimum.at(self.min_separation, i, sep)
        np.minimum.at(self.min_separation, j, sep)
        sep_end = np.hypot(d1[:, 0], d1[:, 1]) - reach
        touching = sep < 0.0
        if self._open_bb or np.any(touching):
            self._contacts(t, i, j, sep, sep_end, touching, False, started,
                           lambda k: self._disc_event(t, int(i[k]), int(j[k]), d0[k], d1[k],
                                                      float(reach[k]), v0, float(sep[k])))
        # proximity episodes (near misses)
        new = sep < cfg.near_miss_distance
        if self._n_prox == 0 and not np.any(new):
            return
        was = self._prox[i, j]
        had = self._prox_contact[i, j] | touching
        live = was | new
        ended = live & (sep_end > cfg.near_miss_distance + cfg.hysteresis)
        missed = ended & ~had
        if np.any(missed):
            np.add.at(self.near_misses, i[missed], 1)
            np.add.at(self.near_misses, j[missed], 1)
        keep = live & ~ended
        self._prox[i, j] = keep
        self._prox_contact[i, j] = had & keep
        self._n_prox = int(np.count_nonzero(keep))

    def _contacts(
        self, t: float, i: IntArray, j: IntArray, sep: FloatArray, sep_end: FloatArray,
        touching: NDArray[np.bool_], wall: bool, started: list[ContactEvent],
        make: Any,
    ) -> None:
        """Advance the contact episodes of candidate pairs (i, j) of one family."""
        state = self._touch_bw if wall else self._touch_bb
        was = state[i, j]
        new = touching & ~was
        live = was | new
        if not np.any(live):
            return
        ended = live & (sep_end > self.config.hysteresis)
        for k in np.flatnonzero(was).tolist():
            ev = self._open_events[(int(i[k]), int(j[k]), wall)]
            ev.max_penetration = max(ev.max_penetration, float(-sep[k]))
        for k in np.flatnonzero(new).tolist():
            ev = make(k)
            a, b = int(i[k]), int(j[k])
            self._open_events[(a, b, wall)] = ev
            self.contacts.append(ev)
            started.append(ev)
            self.collisions[a] += 1
            if wall:
                self.wall_collisions[a] += 1
            else:
                self.collisions[b] += 1
        for k in np.flatnonzero(ended).tolist():
            self._open_events.pop((int(i[k]), int(j[k]), wall)).end_time = t + self.dt
        state[i[live], j[live]] = (live & ~ended)[live]
        n_open = sum(1 for key in self._open_events if key[2] == wall)
        if wall:
            self._open_bw = n_open
        else:
            self._open_bb = n_open

    def _disc_event(
        self, t: float, a: int, b: int, d0: FloatArray, d1: FloatArray, reach: float,
        v0: FloatArray, sep: float,
    ) -> ContactEvent:
        tc, nrm = _first_disc_touch(d0, d1, reach)
        vrel = v0[b] - v0[a]
        return ContactEvent(
            time=t + tc * self.dt, a=a, b=b, kind_a=self.kinds[a], kind_b=self.kinds[b],
            name_a=self.names[a], name_b=self.names[b],
            impact_speed=max(0.0, -float(vrel @ nrm)), max_penetration=-sep,
        )

    def _wall_pairs(
        self, t: float, i: IntArray, w: IntArray, p0: FloatArray, p1: FloatArray,
        v0: FloatArray, started: list[ContactEvent],
    ) -> None:
        segs = self.wall_segments
        reach = self.radii[i] + self.wall_radii[w]
        # cheap lower bound: distance of the path to the wall's supporting line
        side0 = np.einsum("kd,kd->k", p0[i] - segs[w, 0], self._wall_normals[w])
        side1 = np.einsum("kd,kd->k", p1[i] - segs[w, 0], self._wall_normals[w])
        bound = np.where(side0 * side1 <= 0.0, 0.0, np.minimum(np.abs(side0), np.abs(side1)))
        cand = np.flatnonzero(bound < reach)
        if len(cand) == 0 and self._open_bw == 0:
            return
        i, w, reach = i[cand], w[cand], reach[cand]
        a, b = segs[w, 0], segs[w, 1]
        sep = segment_distances(p0[i], p1[i], a, b) - reach
        sep_end = _point_segment(p1[i], a, b) - reach

        def make(k: int) -> ContactEvent:
            body, wall = int(i[k]), int(w[k])
            tc, nrm = _first_wall_touch(p0[body], p1[body], a[k], b[k], float(reach[k]))
            return ContactEvent(
                time=t + tc * self.dt, a=body, b=wall, kind_a=self.kinds[body], kind_b="wall",
                name_a=self.names[body], name_b=f"wall{wall}",
                impact_speed=max(0.0, -float(v0[body] @ nrm)), max_penetration=float(-sep[k]),
            )

        self._contacts(t, i, w, sep, sep_end, sep < 0.0, True, started, make)

    def _ttc(
        self, i: IntArray, j: IntArray, d: FloatArray, w: FloatArray, reach: FloatArray
    ) -> None:
        """Constant-velocity time to collision at the step's end, for pairs with a robot.

        d, w: relative positions (m) and velocities (m/s) of j with respect to i.
        """
        aa = w[:, 0] * w[:, 0] + w[:, 1] * w[:, 1]
        bb = d[:, 0] * w[:, 0] + d[:, 1] * w[:, 1]
        cc = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] - reach * reach
        disc = bb * bb - aa * cc
        # first root of |d + w t| = reach, stable form c / (-b + sqrt(disc)); 0 if overlapping
        hit = ((bb < 0.0) & (disc >= 0.0)) | (cc <= 0.0)
        hit &= self.is_robot[i] | self.is_robot[j]
        if not np.any(hit):
            return
        k = np.flatnonzero(hit)
        root = np.sqrt(np.maximum(disc[k], 0.0))
        ttc = np.where(cc[k] <= 0.0, 0.0, cc[k] / np.maximum(root - bb[k], 1e-300))
        soon = ttc <= self.config.ttc_horizon
        np.minimum.at(self.min_ttc, i[k[soon]], ttc[soon])
        np.minimum.at(self.min_ttc, j[k[soon]], ttc[soon])

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
        rows = []
        for k in np.flatnonzero(self.is_robot).tolist():
            active_time = self.time_to_goal[k] if self.reached[k] else self.time
            rows.append(
                RobotSummary(
                    index=k,
                    name=self.names[k],
                    reached_goal=bool(self.reached[k]),
                    success=bool(self.reached[k] and self.collisions[k] == 0),
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
                )
            )
        return EpisodeSummary(
            duration=self.time, steps=self.steps, robots=rows,
            contacts=list(self.contacts), faults=list(self.faults),
        )
