"""The compiled geometry functions that other packages call: one public door.

The kernels themselves live in the private package :mod:`nao_arena.geometry._kernel`
(one module per concept; its docstring gives the rules they follow for compile time and
reference counting). Code outside :mod:`nao_arena.geometry` (agents, stopping plans,
navigation, obstacles, the renderer) imports them from here, so that the private modules
can be split or renamed without touching their callers.

Every name is a numba-compiled function (``cache=True``), a constant, or a named bundle
that the kernels take their arguments in (:mod:`nao_arena.geometry._kernel.bundles`),
with the frame and units of :mod:`nao_arena.geometry`: the robot at the origin with
velocity v (m/s), obstacle centres relative to it (m), accelerations in m/s^2, times in
s, radii already grown by the robot's radius (m).
"""

from nao_arena.geometry._kernel.batch import (
    admissible_row,
    admissible_scratch,
    sampled_admissible_batch,
)
from nao_arena.geometry._kernel.bundles import (
    IndexLists,
    Motion,
    Obstacles,
    Paths,
    Predictions,
    Robots,
    SearchSettings,
    Walls,
    WorldWalls,
)
from nao_arena.geometry._kernel.exact import (
    admissible_kernel,
    candidate_setup,
    piece_sweep,
    robot_state,
    scan_obstacle,
)
from nao_arena.geometry._kernel.relevance import relevant_obstacles, relevant_sampled_paths
from nao_arena.geometry._kernel.sampled import RADIUS_CUT, path_excursions
from nao_arena.geometry._kernel.search import repair_relevant, select_relevant
from nao_arena.geometry._kernel.segment import (
    nearby_walls,
    point_segment_dist2,
    point_segment_distance,
    relevant_walls,
    segment_min_distance,
    segment_segment_dist2,
    segment_segment_distance,
)

__all__ = [
    "RADIUS_CUT",
    "IndexLists",
    "Motion",
    "Obstacles",
    "Paths",
    "Predictions",
    "Robots",
    "SearchSettings",
    "Walls",
    "WorldWalls",
    "admissible_kernel",
    "admissible_row",
    "admissible_scratch",
    "candidate_setup",
    "nearby_walls",
    "path_excursions",
    "piece_sweep",
    "point_segment_dist2",
    "point_segment_distance",
    "relevant_obstacles",
    "relevant_sampled_paths",
    "relevant_walls",
    "repair_relevant",
    "robot_state",
    "sampled_admissible_batch",
    "scan_obstacle",
    "segment_min_distance",
    "segment_segment_dist2",
    "segment_segment_distance",
    "select_relevant",
]
