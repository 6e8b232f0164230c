"""Many episodes: the grid maps x agents x episodes, seeds, workers, resume, results files.

A trial runs every episode of the grid headless through :meth:`Arena.run`
(the one control loop) and writes, into its output folder ``DIR``:

- ``episodes/<map>__<agent>__<episode>.json``: one file per (map, agent,
  episode), written atomically as soon as the episode ends. An interrupted
  trial resumes: an episode whose file exists (with the same map, agent,
  episode, seed, map parameters and time limit) is not run again.
- ``episodes.parquet``: one row per robot per episode (see
  :data:`EPISODE_SCHEMA`): ``map``, ``agent``, ``episode``, ``seed``,
  ``robot`` (the robot's name), the :class:`~nao_arena.stats.RobotSummary`
  fields (``index`` ... ``adjustment_rate``; null where the summary has a
  non-finite value: ``time_to_goal`` null = never arrived,
  ``min_separation`` null = never within the stats' ``separation_range``,
  ``min_ttc`` null = no time to collision within ``ttc_horizon``), the
  robot's agent ``faults``, the episode's ``duration`` (s) and ``steps``,
  and ``error``: null, or for an episode that raised, the error message
  (then the episode has a single row with ``robot`` and the metrics null);
  e.g. ``AgentError: ...`` when an agent's constructor or reset raised,
  ``EpisodeTimeout: ...`` when the episode ran past its wall-clock budget
  (``episode_timeout``, default 600 s).
- ``collisions.parquet``: one row per contact event (see
  :data:`COLLISION_SCHEMA`): ``map``, ``agent``, ``episode``, ``seed``, the
  :class:`~nao_arena.stats.ContactEvent` fields, ``contact`` (its number in
  the episode, 1 = the first: ``nao-arena explain LOG --contact K``) and
  ``log`` (the episode's log, relative to ``DIR``; null without one).
- with ``log`` (``--log``): ``logs/<map>__<agent>__<episode>.parquet``, the
  episode's log (:mod:`nao_arena.episode_log`), for every episode (``all``)
  or for those with a contact involving a robot or a stuck robot
  (``contacts``); written atomically by the process that runs the episode
  (on a Ray cluster: the node's file system). The episode's file names it
  (``log``). A trial resumed with ``log`` runs again the episodes done
  without the log they need (with the same results: episodes are
  deterministic).
- ``summary.json`` (and the printed table): see below.
- with ``csv``: ``episodes.csv``, ``collisions.csv``, ``summary.csv``.
- ``trial.json``: the trial's settings (``agent_refs``: label -> agent reference of
  the agents given as ``NAME=REFERENCE``).

Backends
--------
The episodes run on a backend (:mod:`nao_arena.backends`): ``local``
(default; ``workers`` processes of this machine, or this process) or
``ray`` (Ray tasks on a local Ray instance or on the cluster at
``address``; ``pip install nao-arena[ray]``). A backend only executes
:func:`compute_episode` on the episodes' :class:`EpisodeTask` and hands each
record back to this process, which writes the episode's file and counts it
on the progress line: resume, files and tables do not depend on the backend.

All these files are (re)built from the per-episode files at the end of a
run, in grid order (maps, then agents, then episodes, as given), and are
written to a temporary name then ``os.replace``-d.

Seeds
-----
One ``numpy.random.SeedSequence(seed)``; the episode ``e`` of map ``m``
gets the child with spawn key ``(crc32(m), e)``, reduced to an integer in
[0, 2^32) (:func:`episode_seed`). It depends on (trial seed, map, episode)
only: every agent faces the same scenes, and results do not depend on the
number of workers or the order in which episodes run. The integer is passed
as the map's ``seed`` parameter (when the map declares one) and to
``Arena.run(seed)`` (the agents' generators).

summary.json
------------
A JSON list, one object per map x agent (grid order), with the keys
(stable; others may be added). Every rate comes with the counts it was
computed from:

``map``, ``agent``: as given on the command line (``agent``: the agent's label
    for ``--agent NAME=REFERENCE``, see :class:`TrialConfig`).
``episodes``: episodes of the grid cell that have a result file;
``failed_episodes``: those that raised (excluded from every metric below).
``distinct_episodes``: distinct trajectories among the completed episodes
    (by ``trajectory_hash``, see :mod:`nao_arena.arena`); fewer than the
    completed episodes when some repeat another exactly (a map whose seed
    changes nothing, with agents that draw no random numbers).
``robots``: robot-episodes driven by the agent (robots x completed episodes);
    ``distinct_robots``: those of the distinct episodes (the first episode
    of each trajectory hash).
``collisions``: contact events involving at least one of those robots
    (robot-robot, robot-traffic and robot-wall; a robot-robot contact counts once).
``robots_collided``: robot-episodes with at least one collision;
    ``collision_rate`` = robots_collided / robots;
    ``collision_rate_ci95``: [low, high], Wilson score interval (95 %) of
    that rate with ``distinct_robots`` as the sample size (an exact repeat
    of an episode adds no information; with no repeats this is the plain
    interval over ``robots``). It treats robot-episodes as independent
    (robots of one episode are not, so the interval is optimistic for maps
    with many robots).
``robots_succeeded``: robot-episodes that reached the goal without any
    collision and were at it when the episode ended; ``success_rate`` = robots_succeeded / robots;
    ``success_rate_ci95``: its Wilson interval, as above.
``robot_hours``: sum over robot-episodes of the episode's duration (h);
    ``collisions_per_robot_hour``: collisions / robot_hours.
``robots_arrived``: robot-episodes that reached the goal (with or without
    a collision); ``median_time_to_goal_s``: the median of their time to goal (s).
``min_separation_m``: the smallest minimum separation (surface to surface,
    negative = overlap) of any robot-episode (m);
    ``median_min_separation_m``: the median over robot-episodes (m).
    Both only over robot-episodes that came within ``separation_range``.
``near_misses``: proximity episodes without contact, summed over robots.
``adjustments``: acceleration adjustments, summed over robot-episodes;
    ``driven_s``: time driven (until the goal, or the episode's end), summed
    over robot-episodes (s); ``adjustments_per_s`` = adjustments / driven_s (1/s).
``faults``: agent faults (exceptions or invalid actions, contained by the loop).
Liveness (see :mod:`nao_arena.stats`): ``robots_timed_out``: robot-episodes
    that never reached the goal; ``robots_stuck``: robot-episodes stuck at
    some time (away from the goal and less than 0.1 m closer to it over the
    last 5 s), ``stuck_s``: their stuck time summed (s);
    ``robots_left_goal``: robot-episodes that arrived and were later away from
    the goal; ``robots_away_at_end``: of those that arrived, the ones away from
    the goal at the episode's end; ``episodes_deadlocked``: completed episodes
    with a deadlock (a time at which every robot away from its goal was stuck).
Among people (maps with robots entries of kind ``person``, see
    :mod:`nao_arena.stats.people`): ``robots_among_people``: robot-episodes with
    people around (0 on maps without people, where the others are 0 or null);
    ``person_contacts``: their contacts with people; ``robot_caused_person_contacts``:
    those at whose first touch the robot was moving; ``robots_caused_person_contact``:
    robot-episodes with at least one of those; ``discomfort_s``: their time within the
    discomfort distance (0.2 m) of a person (s), ``discomfort_share``: that over their
    robot time; ``min_person_distance_m``: the smallest surface-to-surface gap to a
    person (m; null if no person came within ``separation_range``, 1 m).
Unavailable values (no robot-episode to compute them from) are null.

The printed table (:func:`format_table`) shows each share as
``count/total (percent)``, with enough digits that a non-zero count never
reads as zero, a note for every cell with repeated episodes, and a legend
of its columns.

The output folder
-----------------
While a trial runs it holds an exclusive lock on ``DIR/.lock``
(``fcntl.flock``, the holder's pid inside, released when the trial ends,
however it ends): a second trial on the same folder fails at once with
:class:`ResultsFolderError`. A trial in a folder whose ``trial.json``
records different settings is refused the same way, before anything is
written; only the settings that do not change results may differ
(:data:`FREE_SETTINGS`: ``workers``, ``backend``, ``address``, ``csv``,
``retry_failed``, ``episode_timeout``: a budget only decides whether a hung
episode fails, ``log``), the order of maps and agents does not matter, and
``episodes`` may grow (the earlier episodes are kept and the new ones run;
``trial.json`` then records the larger number) but not shrink.
"""

# The package: config (settings, the grid of episodes, seeds, paths), episode (one
# episode and its result file), run (the results folder and running the grid), results
# (the results files and the summary) and table (the summary as text).

from nao_arena.trials.config import (
    FREE_SETTINGS,
    LOG_MODES,
    EpisodeTask,
    TrialConfig,
    TrialResult,
    episode_path,
    episode_seed,
    log_path,
    make_map,
    map_overrides,
    split_agent,
)
from nao_arena.trials.episode import compute_episode, run_episode
from nao_arena.trials.results import (
    COLLISION_SCHEMA,
    EPISODE_SCHEMA,
    SUMMARY_KEYS,
    build_results,
    load_summary,
    summarize,
    wilson_interval,
)
from nao_arena.trials.run import ResultsFolderError, check_folder, folder_lock, run_trial
from nao_arena.trials.table import TABLE_LEGEND, format_table

__all__ = [
    "COLLISION_SCHEMA",
    "EPISODE_SCHEMA",
    "FREE_SETTINGS",
    "LOG_MODES",
    "SUMMARY_KEYS",
    "TABLE_LEGEND",
    "EpisodeTask",
    "ResultsFolderError",
    "TrialConfig",
    "TrialResult",
    "build_results",
    "check_folder",
    "compute_episode",
    "episode_path",
    "episode_seed",
    "folder_lock",
    "format_table",
    "load_summary",
    "log_path",
    "make_map",
    "map_overrides",
    "run_episode",
    "run_trial",
    "split_agent",
    "summarize",
    "wilson_interval",
]
