"""Acceleration-obstacle geometry: arrays in, arrays out (numpy/numba only).

Frame: the robot at the origin with velocity v (m/s); obstacle centres
relative to the robot's current position (m); accelerations in m/s^2;
times in s; radii already grown by the robot's radius (m).
"""

from nao_arena.geometry.boundary import (
    ObstacleBoundary,
    ao_boundary,
    ao_boundary_paper,
    bao_boundary,
    nao_boundary,
    path_boundary,
    vo_cone,
)
from nao_arena.geometry.clearance import (
    Clearance,
    PiecewisePath,
    ao_clearance,
    ao_path,
    grown_with_time,
    nao_clearance,
    nao_query,
    path_clearance,
    sampled_path,
    vo_clearance,
)
from nao_arena.geometry.outcome import Outcome
from nao_arena.geometry.selection import (
    AccelLimits,
    Selection,
    repair_acceleration,
    select_acceleration,
)

__all__ = [
    "AccelLimits",
    "Clearance",
    "ObstacleBoundary",
    "Outcome",
    "PiecewisePath",
    "Selection",
    "ao_boundary",
    "ao_boundary_paper",
    "ao_clearance",
    "ao_path",
    "grown_with_time",
    "bao_boundary",
    "nao_boundary",
    "nao_clearance",
    "nao_query",
    "path_boundary",
    "path_clearance",
    "sampled_path",
    "repair_acceleration",
    "select_acceleration",
    "vo_clearance",
    "vo_cone",
]
