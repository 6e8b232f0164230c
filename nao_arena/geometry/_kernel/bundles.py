"""The named bundles the geometry kernels take their arguments in.

numba passes a NamedTuple as its fields: a bundle costs nothing inside compiled code,
and two arrays given in the wrong order no longer compile. Built in Python, a bundle
costs about a microsecond per call (its construction and its typing at dispatch), so
the kernels that Python calls per robot take few of them, and the compiled callers
build theirs in compiled code. A kernel that borrows its arrays (see
:mod:`nao_arena.geometry.borrow`) unpacks the bundle, borrows the fields and builds the
bundle again from the borrowed ones; a bundle that Python passes never holds a numba
typed Dict or List (their dispatch is about ten times slower).

Frame and units are those of :mod:`nao_arena.geometry`: the robot at the origin at
t = 0 with velocity v (m/s), obstacle centres relative to it (m), accelerations in
m/s^2, times in s, radii grown by the robot's radius (m); the bundles of the batched
kernels (:class:`Predictions`, :class:`IndexLists`, :class:`WorldWalls`,
:class:`Robots`) are in the world frame.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "IndexLists",
    "Limits",
    "Motion",
    "Obstacles",
    "OutsideSearch",
    "Paths",
    "Predictions",
    "Robots",
    "Scratch",
    "SearchSettings",
    "Walls",
    "WorldWalls",
]


class Limits(NamedTuple):
    """The robot as the admissibility test takes it (frame of :mod:`nao_arena.geometry`:
    the robot at the origin): the limit disc |a| <= a_max (m/s^2), the robot's velocity
    (vx, vy) (m/s) and its speed limit v_max (m/s)."""

    a_max: float
    vx: float
    vy: float
    v_max: float


class Motion(NamedTuple):
    """One candidate's motion as the scans take it (frame of :mod:`nao_arena.geometry`:
    the robot at the origin at t = 0): the initial velocity (vx, vy) m/s, already scaled
    down to the speed limit, the constant acceleration (ax, ay) m/s^2 until the speed
    reaches the limit at time tau s (inf: never), then constant velocity; bound m/s: a
    bound on the speed over the horizon. vx, vy, tau and bound are what
    :func:`~nao_arena.geometry._kernel.robot_path.candidate_setup` returns."""

    vx: float
    vy: float
    ax: float
    ay: float
    tau: float
    bound: float


class Paths(NamedTuple):
    """The N moving obstacles (frame of :mod:`nao_arena.geometry`: positions relative to
    the robot's, times from now): piecewise-quadratic paths over the S pieces of the times
    seg_t (S+1,) s (seg_t[0] = 0; the last may be inf), per obstacle and piece the start
    centre seg_c (N, S, 2) m, velocity seg_w (N, S, 2) m/s and acceleration seg_b
    (N, S, 2) m/s^2; radius (N,) m (grown by the robot's). The fields of
    :attr:`~nao_arena.geometry.clearance.PiecewisePath.moving_arrays`, in order."""

    seg_t: NDArray[np.float64]
    seg_c: NDArray[np.float64]
    seg_w: NDArray[np.float64]
    seg_b: NDArray[np.float64]
    radius: NDArray[np.float64]


class Obstacles(NamedTuple):
    """The N moving obstacles the test checks (frame of :mod:`nao_arena.geometry`:
    positions relative to the robot's, times from now): piecewise-quadratic paths over
    the S pieces of the times seg_t (S+1,) s, per obstacle and piece the start centre
    seg_c (N, S, 2) m, velocity seg_w (N, S, 2) m/s and acceleration seg_b (N, S, 2)
    m/s^2; radius (N,) m (grown by the robot's); sweep (N, S) m: how far each obstacle
    moves within each piece at most
    (:func:`~nao_arena.geometry._kernel.exact.piece_sweep`). :class:`Paths` with their
    sweeps."""

    seg_t: NDArray[np.float64]
    seg_c: NDArray[np.float64]
    seg_w: NDArray[np.float64]
    seg_b: NDArray[np.float64]
    radius: NDArray[np.float64]
    sweep: NDArray[np.float64]


class Walls(NamedTuple):
    """The W walls the test checks: segment ends (W, 2, 2) m relative to the robot
    (frame of :mod:`nao_arena.geometry`), radius (W,) m (grown by the robot's; see
    :func:`~nao_arena.geometry._kernel.segment.wall_violation`)."""

    ends: NDArray[np.float64]
    radius: NDArray[np.float64]


class Scratch(NamedTuple):
    """The test's scratch arrays: buf (3,) and res (3,) (no units: the scans' working
    space and results) and hint (2,) int64, the (obstacle, piece) that last rejected a
    candidate (see :func:`~nao_arena.geometry._kernel.boundary.ok_disc`)."""

    buf: NDArray[np.float64]
    res: NDArray[np.float64]
    hint: NDArray[np.int64]


class OutsideSearch(NamedTuple):
    """The state of a search for the points nearest the query q outside the M disks
    (accelerations m/s^2 in the frame of :mod:`nao_arena.geometry`), as
    :func:`~nao_arena.geometry._kernel.outside.outside_setup` starts it and
    :func:`~nao_arena.geometry._kernel.outside.outside_advance` advances it: out
    (max_out, 3) the rows found (x, y, distance from q) m/s^2, lower (M + 1,) the
    distances from q to the circles (the limit circle last) m/s^2, order (M + 1,) int64
    the circles' visiting order, scale m/s^2 the bound for rounding, and the scratch
    arrays cand (2 M + 8, 2) m/s^2 (one circle's free-arc points), starts and ends
    (2 M + 4,) rad (arcs), cover (_WORDS,) uint64 (bins; see
    :mod:`~nao_arena.geometry._kernel.outside`)."""

    out: NDArray[np.float64]
    lower: NDArray[np.float64]
    order: NDArray[np.int64]
    scale: float
    cand: NDArray[np.float64]
    starts: NDArray[np.float64]
    ends: NDArray[np.float64]
    cover: NDArray[np.uint64]


class SearchSettings(NamedTuple):
    """How the disc search (:func:`~nao_arena.geometry._kernel.search.select_disc`) looks
    for an admissible acceleration: tol m/s^2 the tolerance of the steps onto the
    boundary; the fallback rings' radii ring_radii (R,) m/s^2 and their unit directions
    unit_rings (R, P, 2) (no unit); max_disks (int) the cap on the disks of the capped
    ball; the disk picture's sampling (see
    :func:`~nao_arena.geometry._kernel.disks.nao_disk_samples`): at least n_sub (int)
    samples per piece, per_second (1/s) samples per second of a piece, thin m/s^2 the
    sliver depth of the thinning (0: none)."""

    tol: float
    ring_radii: NDArray[np.float64]
    unit_rings: NDArray[np.float64]
    max_disks: int
    n_sub: int
    per_second: float
    thin: float


class Predictions(NamedTuple):
    """The bodies' sampled paths as the batched kernels take them (world frame): the
    predicted centres pred (B, T, 2) m at the times (T,) s (times[0] = 0, T >= 2), the
    bodies' radii (B,) m (not grown), and
    :func:`~nao_arena.geometry._kernel.sampled.path_excursions` of pred: excursion (B,) m
    the largest distance of a centre from the first, finite (B,) bool whether all of a
    body's centres are finite."""

    times: NDArray[np.float64]
    pred: NDArray[np.float64]
    radius: NDArray[np.float64]
    excursion: NDArray[np.float64]
    finite: NDArray[np.bool_]


class IndexLists(NamedTuple):
    """Per robot k a list of indices, CSR: ``indices[start[k]:start[k + 1]]`` (start
    (R + 1,) int64, indices int64): the bodies of :class:`Predictions` or the walls of
    :class:`WorldWalls` that robot k sees."""

    start: NDArray[np.int64]
    indices: NDArray[np.int64]


class WorldWalls(NamedTuple):
    """Walls in the world frame: segment ends (M, 2, 2) m and half-thicknesses half (M,) m
    (not grown)."""

    ends: NDArray[np.float64]
    half: NDArray[np.float64]


class Robots(NamedTuple):
    """The robots of a batch (world frame), one row each: positions pos (R, 2) m,
    velocities vel (R, 2) m/s, speed limits v_max (R,) m/s, radii radius (R,) m and
    clearance margins margin (R,) m."""

    pos: NDArray[np.float64]
    vel: NDArray[np.float64]
    v_max: NDArray[np.float64]
    radius: NDArray[np.float64]
    margin: NDArray[np.float64]
