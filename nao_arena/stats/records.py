"""What the statistics record: the thresholds (:class:`StatsConfig`), contact and fault
events, and the per-robot and per-episode summaries with their JSON and CSV forms."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from nao_arena.atomic import atomic_write_text
from nao_arena.stats.files import write_csv

__all__ = ["ContactEvent", "EpisodeSummary", "FaultEvent", "RobotSummary", "StatsConfig"]


@dataclass(frozen=True)
class StatsConfig:
    """Thresholds of the statistics."""

    near_miss_distance: float = 0.2
    """Separation (m, between surfaces) below which a proximity episode (near miss)
    starts."""
    hysteresis: float = 0.01
    """A proximity episode ends when the separation exceeds its threshold by this much
    (m)."""
    adjustment_threshold: float = 0.1
    """A change of the commanded acceleration larger than this (m/s^2) is an
    adjustment."""
    separation_range: float = 1.0
    """Minimum separations (m) are tracked exactly below this separation."""
    ttc_horizon: float = 5.0
    """Times to collision longer than this (s) count as none."""
    stuck_window: float = 5.0
    """A robot away from its goal is stuck while it came less than ``stuck_progress``
    closer to its goal over the last this many seconds (s)."""
    stuck_progress: float = 0.1
    """See ``stuck_window`` (m)."""
    discomfort_distance: float = 0.2
    """A robot whose surface-to-surface gap to a person is below this (m) makes that
    person uncomfortable (CrowdNav's discomfort distance)."""
    moving_speed: float = 0.05
    """A robot slower than this (m/s) when it first touched a person was standing: the
    contact is not counted as caused by the robot."""

    def __post_init__(self) -> None:
        if self.separation_range < self.near_miss_distance + self.hysteresis:
            raise ValueError("separation_range must be >= near_miss_distance + hysteresis")
        if not (self.stuck_window > 0 and math.isfinite(self.stuck_window)):
            raise ValueError(f"stuck_window: expected a finite time > 0 s, got {self.stuck_window}")
        if not self.stuck_progress >= 0:
            raise ValueError(f"stuck_progress: expected >= 0 m, got {self.stuck_progress}")
        for name in ("discomfort_distance", "moving_speed"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: expected a finite number >= 0, got {value}")


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
    kinds "robot", "person", "traffic" or "wall"; impact_speed: relative normal
    speed at first contact (m/s, >= 0); max_penetration: deepest overlap (m);
    speed_a, speed_b: the speeds of a and b while they first touched (m/s, world
    frame; 0 for a wall): whether each was moving (a person who walks into a
    robot standing still touches it at speed_a 0); began_overlapping: the two
    already overlapped at the start of the control step in which the contact
    started (placed on each other at t = 0, or a recorded person appeared there):
    no one's motion brought it about (False for walls, which no start may overlap).
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
    speed_a: float = math.nan
    speed_b: float = math.nan
    began_overlapping: bool = False

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
    """One robot's metrics over an episode (see :mod:`nao_arena.stats`; units m, s).

    Among people (:mod:`nao_arena.stats.people`; among_people: the map has people):
    person_contacts, the contact episodes with people; caused_person_contacts, those in
    which the robot was moving when they first touched; min_person_distance (m, NaN
    unless a person came within the separation range); discomfort_time (s)."""

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
    among_people: bool = False
    person_contacts: int = 0
    caused_person_contacts: int = 0
    min_person_distance: float = math.nan
    discomfort_time: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (non-finite numbers as None)."""
        return {k: _clean(v) for k, v in asdict(self).items()}


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
        write_csv(robots_path, [r.to_dict() for r in self.robots], cols)
        if contacts_path is not None:
            ccols = [f.name for f in fields(ContactEvent)]
            write_csv(contacts_path, [c.to_dict() for c in self.contacts], ccols)
