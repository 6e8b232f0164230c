"""Social-navigation metrics: how each robot fares among people (bodies of kind "person").

Per robot, over the world's exact path (its centres after every physics substep, each
body moving in a straight line between two substeps, as the contact check reads it):

- ``min_person_distance`` (m): the smallest surface-to-surface gap to any person
  (centre distance less both radii; negative: overlapping), exact for that motion (the
  closest approach of two points moving linearly within a substep), tracked below the
  statistics' ``separation_range`` (1 m; NaN: no person ever came that close);
- ``discomfort_time`` (s): how long the gap to at least one person was below the
  discomfort distance (0.2 m by default, CrowdNav's), exact for that motion: within each
  substep the times at which a person is that close form an interval (the roots of a
  quadratic), and the union of the people's intervals is measured.

:func:`robot_caused` says which contacts with people a robot caused: those at whose
first touch the robot was moving (``speed_a`` or ``speed_b`` of the
:class:`~nao_arena.stats.ContactEvent` at least ``moving_speed``) and that did not begin
overlapping (``began_overlapping``: a recorded person appearing on the robot); a person
who walks into a robot standing still is not the robot's doing.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from nao_arena.stats.records import ContactEvent

__all__ = ["PeopleMetrics", "robot_caused"]

FloatArray = NDArray[np.float64]


def _pair_motion(
    path: FloatArray, robots: NDArray[np.intp], people: NDArray[np.intp]
) -> tuple[FloatArray, FloatArray]:
    """Relative positions d0 (S, R, P, 2) m of each person from each robot at the start of
    each substep, and their change w (S, R, P, 2) m over the substep."""
    rel = path[:, None, people, :] - path[:, robots, None, :]  # (S + 1, R, P, 2)
    return rel[:-1], rel[1:] - rel[:-1]


def closest_gaps(d0: FloatArray, w: FloatArray, reach: FloatArray) -> FloatArray:
    """The smallest gap (m) |d0 + w s| - reach over s in [0, 1], per pair (leading
    axes of d0 and w; reach broadcasts to them)."""
    ww = np.einsum("...k,...k->...", w, w)
    dw = np.einsum("...k,...k->...", d0, w)
    s = np.clip(np.where(ww > 0.0, -dw / np.where(ww > 0.0, ww, 1.0), 0.0), 0.0, 1.0)
    closest = d0 + s[..., None] * w
    return np.asarray(np.hypot(closest[..., 0], closest[..., 1]) - reach)


def near_intervals(
    d0: FloatArray, w: FloatArray, reach: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The part [lo, hi] of s in [0, 1] in which |d0 + w s| < reach, per pair (lo >= hi:
    never): the roots of |w|^2 s^2 + 2 (d0 . w) s + |d0|^2 - reach^2 = 0, clipped."""
    a = np.einsum("...k,...k->...", w, w)
    b = np.einsum("...k,...k->...", d0, w)
    c = np.einsum("...k,...k->...", d0, d0) - reach * reach
    disc = b * b - a * c
    moving = a > 0.0
    root = np.sqrt(np.maximum(disc, 0.0))
    safe_a = np.where(moving, a, 1.0)
    lo = np.where(moving, (-b - root) / safe_a, np.where(c < 0.0, 0.0, 1.0))
    hi = np.where(moving, (-b + root) / safe_a, np.where(c < 0.0, 1.0, 0.0))
    never = moving & (disc <= 0.0)
    lo, hi = np.where(never, 1.0, lo), np.where(never, 0.0, hi)
    return np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)


def union_length(lo: FloatArray, hi: FloatArray) -> FloatArray:
    """The length of the union of the intervals [lo, hi] along the last axis (empty where
    lo >= hi)."""
    hi = np.where(hi > lo, hi, lo)
    order = np.argsort(lo, axis=-1, kind="stable")
    lo_s = np.take_along_axis(lo, order, axis=-1)
    hi_s = np.take_along_axis(hi, order, axis=-1)
    reach_before = np.maximum.accumulate(hi_s, axis=-1)
    start = np.concatenate(
        [lo_s[..., :1], np.maximum(lo_s[..., 1:], reach_before[..., :-1])], axis=-1
    )
    return np.asarray(np.maximum(hi_s - start, 0.0).sum(axis=-1))


class PeopleMetrics:
    """The social-navigation metrics of the robots among the people of one episode.

    robots, people: body indices; radii (N,) m of every body; discomfort_distance (m);
    dt: control period (s); separation_range (m): gaps are tracked below it. Arrays are
    per robot, in the order of ``robots``.
    """

    def __init__(
        self,
        robots: NDArray[np.intp],
        people: NDArray[np.intp],
        radii: FloatArray,
        discomfort_distance: float,
        dt: float,
        separation_range: float = math.inf,
    ) -> None:
        self.separation_range = float(separation_range)
        self.robots = np.asarray(robots, dtype=np.intp)
        self.people = np.asarray(people, dtype=np.intp)
        self.reach = radii[self.robots][:, None] + radii[self.people][None, :]  # (R, P) m
        self.discomfort_distance = float(discomfort_distance)
        self.dt = float(dt)
        self.min_person_distance = np.full(len(self.robots), math.inf)
        self.discomfort_time = np.zeros(len(self.robots))

    def update(self, path: FloatArray) -> None:
        """Account for one control step whose substep centres are ``path`` (S + 1, N, 2)
        m (row 0: the step's start)."""
        if not len(self.robots) or not len(self.people):
            return
        d0, w = _pair_motion(path, self.robots, self.people)
        gaps = closest_gaps(d0, w, self.reach).min(axis=(0, 2))
        self.min_person_distance = np.minimum(self.min_person_distance, gaps)
        lo, hi = near_intervals(d0, w, self.reach + self.discomfort_distance)
        covered = union_length(lo, hi)  # (S, R): share of each substep
        self.discomfort_time += covered.sum(axis=0) * (self.dt / (len(path) - 1))

    def of_body(self, body: int) -> tuple[float, float]:
        """(min_person_distance m, NaN unless a person came within the separation range;
        discomfort_time s) of the robot with body index ``body``."""
        k = int(np.flatnonzero(self.robots == body)[0])
        closest = float(self.min_person_distance[k])
        if not len(self.people) or closest >= self.separation_range:
            return math.nan, float(self.discomfort_time[k])
        return closest, float(self.discomfort_time[k])


def robot_caused(event: ContactEvent, body: int, moving_speed: float) -> bool:
    """Whether robot ``body`` was moving (speed >= moving_speed, m/s) when the contact
    ``event`` (one it took part in) first touched, the two not already overlapping when
    its step began (placed on each other, or a recorded person appearing on the robot)."""
    speed = event.speed_a if event.a == body else event.speed_b
    return bool(speed >= moving_speed) and not event.began_overlapping
