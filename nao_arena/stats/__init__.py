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
as the numpy reference in tests/reference/stats_reference.py, so bit-identical
results), and only the rare contact events are handled in Python.

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

# The package: records (config, events, summaries), files (CSV output), kernel (the
# compiled step), events (first touch of a new contact) and recorder (EpisodeStats).

from nao_arena.stats.kernel import sweep_pairs
from nao_arena.stats.recorder import EpisodeStats
from nao_arena.stats.records import (
    ContactEvent,
    EpisodeSummary,
    FaultEvent,
    RobotSummary,
    StatsConfig,
)

__all__ = [
    "ContactEvent",
    "EpisodeStats",
    "EpisodeSummary",
    "FaultEvent",
    "RobotSummary",
    "StatsConfig",
    "sweep_pairs",
]
