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

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import re
import sys
import time
import zlib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from nao_arena.agent import available_agents, describe, load_agent
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.atomic import atomic_write_text, atomic_write_with
from nao_arena.backends import BACKENDS, make_backend
from nao_arena.maps import MapError, MapSpec, load_map
from nao_arena.stats import ContactEvent, RobotSummary
from nao_arena.watchdog import wall_clock_budget

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

FORMAT = 1

SUMMARY_KEYS: tuple[str, ...] = (
    "map", "agent", "episodes", "failed_episodes", "robots", "collisions",
    "collision_rate", "collision_rate_ci95", "success_rate", "success_rate_ci95",
    "robot_hours", "collisions_per_robot_hour", "median_time_to_goal_s",
    "min_separation_m", "median_min_separation_m", "near_misses", "adjustments_per_s",
    "faults",
    "distinct_episodes", "distinct_robots", "robots_collided", "robots_succeeded",
    "robots_arrived", "adjustments", "driven_s",
    "robots_timed_out", "robots_stuck", "stuck_s", "robots_left_goal", "robots_away_at_end",
    "episodes_deadlocked",
)

FREE_SETTINGS = frozenset({"workers", "backend", "address", "csv", "retry_failed",
                           "episode_timeout", "log"})
"""Settings that do not change results: they may differ from the ``trial.json`` of the
output folder (``episodes`` may also grow)."""

_KEY_COLUMNS = [
    pa.field("map", pa.string()),
    pa.field("agent", pa.string()),
    pa.field("episode", pa.int64()),
    pa.field("seed", pa.int64()),
]
_ARROW_TYPES = {int: pa.int64(), float: pa.float64(), bool: pa.bool_(), str: pa.string()}


def _arrow_fields(cls: type, skip: Iterable[str] = ()) -> list[pa.Field]:
    hints = {"int": int, "float": float, "bool": bool, "str": str}
    out = []
    for f in fields(cls):
        if f.name in skip:
            continue
        tp = f.type if isinstance(f.type, type) else hints[str(f.type)]
        out.append(pa.field(f.name, _ARROW_TYPES[tp]))
    return out


EPISODE_SCHEMA = pa.schema(
    _KEY_COLUMNS
    + [pa.field("robot", pa.string())]
    + _arrow_fields(RobotSummary, skip=("name",))
    + [
        pa.field("faults", pa.int64()),
        pa.field("duration", pa.float64()),
        pa.field("steps", pa.int64()),
        pa.field("error", pa.string()),
    ]
)
"""Columns of ``episodes.parquet``: one row per robot per episode."""

COLLISION_SCHEMA = pa.schema(_KEY_COLUMNS + _arrow_fields(ContactEvent) + [
    pa.field("contact", pa.int64()),
    pa.field("log", pa.string()),
])
"""Columns of ``collisions.parquet``: one row per contact event."""

LOG_MODES = ("all", "contacts")
"""What ``TrialConfig.log`` may be: log every episode, or those with a contact or a
stuck robot."""


# --------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class TrialConfig:
    """A trial: the grid ``maps`` x ``agents`` x ``episodes`` and how to run it.

    maps: shipped map names or map file paths; agents: the agents' names in
    the grid (what the files, tables and plots show): agent references
    (built-in names, ``FILE.py:Class``, ``module:Class``, plug-in names) or
    labels; agent_refs: label -> agent reference for the agents named by a
    label (``--agent mine=path/to/mine.py:Mine``; see :func:`split_agent`);
    seed: the trial's root seed; workers: local processes (1 = in this
    process), or the CPUs of the local Ray instance; out: the results
    folder; overrides: map parameters (``name -> value``), each applied to
    the maps of the grid that declare it; time_limit: episode time limit
    (s) replacing the maps' own (None: keep them); csv: also write CSV
    files; retry_failed: run again the episodes whose recorded result is an
    error; backend: ``local`` or ``ray`` (see :mod:`nao_arena.backends`);
    address: the Ray cluster to connect to (None: a local Ray instance;
    only with ``backend="ray"``); episode_timeout: each episode's
    wall-clock budget (s; None or 0: none), an episode that exceeds it is
    recorded as failed (``EpisodeTimeout: ...``) and the trial goes on (see
    :mod:`nao_arena.watchdog` for where it is enforced); log: write episode logs
    (:data:`LOG_MODES`; None: none; see the module docstring).
    """

    maps: tuple[str, ...]
    agents: tuple[str, ...]
    episodes: int = 10
    seed: int = 0
    workers: int = 1
    out: Path = Path("results")
    overrides: Mapping[str, Any] = field(default_factory=dict)
    time_limit: float | None = None
    csv: bool = False
    retry_failed: bool = False
    backend: str = "local"
    address: str | None = None
    episode_timeout: float | None = 600.0
    agent_refs: Mapping[str, str] = field(default_factory=dict)
    log: str | None = None

    def __post_init__(self) -> None:
        if not self.maps:
            raise ValueError("a trial needs at least one map")
        if not self.agents:
            raise ValueError("a trial needs at least one agent")
        for kind, names in (("map", self.maps), ("agent", self.agents)):
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"{kind} listed twice: {', '.join(dup)}")
        if self.episodes < 1:
            raise ValueError(f"episodes: expected >= 1, got {self.episodes}")
        if self.seed < 0:
            raise ValueError(f"seed: expected >= 0, got {self.seed}")
        if self.workers < 1:
            raise ValueError(f"workers: expected >= 1, got {self.workers}")
        if self.backend not in BACKENDS:
            raise ValueError(f"unknown backend {self.backend!r}; choose from "
                             f"{', '.join(BACKENDS)}")
        if self.address is not None and self.backend != "ray":
            raise ValueError("an address is for the ray backend (--backend ray)")
        if self.time_limit is not None and not 0 < self.time_limit < math.inf:
            raise ValueError(f"time limit: expected a finite time > 0 s, got {self.time_limit}")
        if self.episode_timeout is not None and not 0 <= self.episode_timeout < math.inf:
            raise ValueError(f"episode timeout: expected a number of s >= 0 (0: none), "
                             f"got {self.episode_timeout}")
        if self.log is not None and self.log not in LOG_MODES:
            raise ValueError(f"log: expected one of {', '.join(LOG_MODES)} (or none), got "
                             f"{self.log!r}")
        if "seed" in self.overrides:
            raise ValueError("the map parameter 'seed' is set per episode by the trial; "
                             "choose the trial's root seed instead (--seed)")
        for label, ref in self.agent_refs.items():
            if label not in self.agents:
                raise ValueError(f"agent label {label!r} is not one of the agents "
                                 f"{', '.join(self.agents)}")
            _check_label(label, ref)

    def reference(self, agent: str) -> str:
        """The agent reference to load for ``agent`` (a label or a reference itself)."""
        return self.agent_refs.get(agent, agent)


@dataclass(frozen=True)
class EpisodeTask:
    """One episode of a trial, as sent to a worker.

    agent: the agent's name in the grid; seed: the episode's integer seed;
    overrides: the map parameters for this map (without ``seed``); path: its
    result file; episode_timeout: its wall-clock budget (s; None or 0: none;
    not part of its key); agent_ref: the agent reference to load (None:
    ``agent`` itself; not part of its key, ``trial.json`` records it); log: which
    episodes write a log (:data:`LOG_MODES`; None: none) and log_path: where (neither
    is part of its key).
    """

    map: str
    agent: str
    episode: int
    seed: int
    overrides: Mapping[str, Any]
    time_limit: float | None
    path: str
    episode_timeout: float | None = None
    agent_ref: str | None = None
    log: str | None = None
    log_path: str | None = None

    def key(self) -> dict[str, Any]:
        """What identifies the episode's result (compared on resume)."""
        return {
            "map": self.map, "agent": self.agent, "episode": self.episode, "seed": self.seed,
            "overrides": dict(self.overrides), "time_limit": self.time_limit,
        }


@dataclass
class TrialResult:
    """What :func:`run_trial` did: the summary rows, episodes run now and skipped
    (already done), and the files written."""

    summary: list[dict[str, Any]]
    ran: int
    skipped: int
    files: list[Path]


# --------------------------------------------------------------------------- agent labels


def split_agent(text: str) -> tuple[str, str]:
    """``"NAME=REFERENCE"`` -> (label, reference); any other text is its own label.

    A label names the agent in tables, plots and results files (e.g.
    ``mine=path/to/mine.py:Mine``); text whose part before the first ``=``
    holds ``/``, ``\\`` or ``:`` is a reference. ValueError for an empty
    label or reference, or a label that names another known agent.
    """
    label, sep, ref = text.partition("=")
    label, ref = label.strip(), ref.strip()
    if not sep or any(c in label for c in "/:\\"):
        return text.strip(), text.strip()
    if not label or not ref:
        raise ValueError(f"agent {text!r}: expected NAME=REFERENCE, e.g. "
                         "mine=path/to/mine.py:Mine")
    _check_label(label, ref)
    return label, ref


def _check_label(label: str, ref: str) -> None:
    """ValueError unless ``label`` is a plain name that names no other known agent."""
    if not label or any(c in label for c in "/:\\,=") or label != label.strip():
        raise ValueError(f"agent label {label!r}: expected a short name without "
                         "'/', ':', ',', '=' or surrounding spaces, e.g. mine")
    known = available_agents()
    if label in known and label != ref:
        raise ValueError(f"agent label {label!r} is the name of the agent {known[label]}: "
                         f"choose another label for {ref}")


# --------------------------------------------------------------------------- seeds and maps


def episode_seed(seed: int, map_name: str, episode: int) -> int:
    """The integer seed in [0, 2^32) of episode ``episode`` of map ``map_name`` in a trial
    with root seed ``seed``: a child of ``SeedSequence(seed)`` with spawn key
    ``(crc32(map_name), episode)``."""
    root = np.random.SeedSequence(seed)
    key = (zlib.crc32(map_name.encode("utf-8")), int(episode))
    child = np.random.SeedSequence(root.entropy, spawn_key=root.spawn_key + key)
    return int(child.generate_state(1, dtype=np.uint32)[0])


def map_overrides(
    maps: Sequence[str], overrides: Mapping[str, Any]
) -> dict[str, dict[str, Any]]:
    """Per map, the overrides among ``overrides`` that it declares as parameters.

    Raises :class:`~nao_arena.maps.MapError` for an unknown map, and for an
    override that no map of the list declares (naming the declared ones).
    """
    declared = {m: set(load_map(m).parameters) for m in maps}
    for key in overrides:
        if not any(key in names for names in declared.values()):
            listing = "; ".join(
                f"{m}: {', '.join(sorted(names)) or 'none'}" for m, names in declared.items()
            )
            raise MapError(f"parameter override {key!r}: no map declares it (declared: {listing})")
    return {m: {k: v for k, v in overrides.items() if k in declared[m]} for m in maps}


def make_map(
    name: str, seed: int | None, overrides: Mapping[str, Any] | None = None,
    time_limit: float | None = None,
) -> MapSpec:
    """Load map ``name`` with ``overrides``; ``seed`` becomes its ``seed`` parameter if it
    declares one; ``time_limit`` (s) replaces its episode time limit if given."""
    params = dict(overrides or {})
    if seed is not None and "seed" in load_map(name).parameters:
        params["seed"] = seed
    spec = load_map(name, **params)
    if time_limit is not None:
        episode = spec.episode.model_copy(update={"time_limit": float(time_limit)})
        spec = spec.model_copy(update={"episode": episode})
    return spec


def _slug(text: str) -> str:
    """A file-name-safe, unique form of a map or agent reference."""
    clean = re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("._")[:40] or "x"
    if clean == text:
        return clean
    return f"{clean}-{zlib.crc32(text.encode('utf-8')):08x}"


def episode_path(out: Path, map_name: str, agent: str, episode: int) -> Path:
    """The result file of one episode."""
    return Path(out) / "episodes" / f"{_slug(map_name)}__{_slug(agent)}__{episode:05d}.json"


def log_path(out: Path, map_name: str, agent: str, episode: int) -> Path:
    """The log file of one episode (with ``--log``)."""
    return Path(out) / "logs" / f"{_slug(map_name)}__{_slug(agent)}__{episode:05d}.parquet"


def _tasks(config: TrialConfig, per_map: Mapping[str, Mapping[str, Any]]) -> list[EpisodeTask]:
    """All episodes of the grid, in grid order (maps, agents, episodes)."""
    return [
        EpisodeTask(
            map=m, agent=a, episode=e, seed=episode_seed(config.seed, m, e),
            overrides=dict(per_map[m]), time_limit=config.time_limit,
            path=str(episode_path(config.out, m, a, e)), episode_timeout=config.episode_timeout,
            agent_ref=config.agent_refs.get(a), log=config.log,
            log_path=str(log_path(config.out, m, a, e)) if config.log else None,
        )
        for m in config.maps
        for a in config.agents
        for e in range(config.episodes)
    ]


# --------------------------------------------------------------------------- one episode


def _read_record(path: str | Path) -> dict[str, Any] | None:
    try:
        with open(path, encoding="utf-8") as fh:
            rec = json.load(fh)
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) else None


def _done_record(task: EpisodeTask, retry_failed: bool) -> dict[str, Any] | None:
    """The task's existing result record, if it needs not run again."""
    rec = _read_record(task.path)
    if rec is None or rec.get("format") != FORMAT or rec.get("key") != task.key():
        return None
    if _lacks_log(task, rec):
        return None
    return None if retry_failed and rec.get("error") is not None else rec


def _wants_log(mode: str | None, result: Mapping[str, Any] | None) -> bool:
    """Whether an episode with this result gets a log in ``mode`` (:data:`LOG_MODES`):
    all, or those with a contact involving a robot or a stuck robot."""
    if mode is None or result is None:
        return False
    if mode == "all":
        return True
    return _robot_contacts(result) > 0 or any(
        (r.get("stuck_time") or 0.0) > 0.0 for r in result["robots"])


def _lacks_log(task: EpisodeTask, rec: Mapping[str, Any]) -> bool:
    """A completed episode that should have a log (task.log) but has none (or it is gone)."""
    if rec.get("error") is not None or not _wants_log(task.log, rec.get("result")):
        return False
    return not (rec.get("log") and task.log_path and Path(task.log_path).is_file())


def compute_episode(task: EpisodeTask) -> dict[str, Any]:
    """Run one episode; returns its record (what the episode's result file holds).

    This is what every backend executes, wherever it runs: it writes no file
    but the episode's log (``task.log``; the record's ``log`` names it relative
    to the results folder, null without one; ``log_error``: why it could not be
    written). An exception while loading the map, building the arena or running is
    recorded (``error``: its type and message, ``result``: null) instead of
    propagating; so is exceeding ``task.episode_timeout`` (``EpisodeTimeout:
    episode exceeded its wall-clock budget of N s``). Only KeyboardInterrupt
    propagates. The record's ``wall_time_s`` is informative only (it is in
    no results table).
    """
    start = time.perf_counter()
    record: dict[str, Any] = {"format": FORMAT, "key": task.key(), "error": None, "result": None}
    recorder = None
    try:
        with wall_clock_budget(task.episode_timeout):
            spec = make_map(task.map, task.seed, task.overrides, task.time_limit)
            arena = Arena(spec, ArenaOptions(agent=task.agent_ref or task.agent))
            recorder = _episode_recorder(task, arena)
            record["result"] = arena.run(task.seed).to_dict()
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a failing episode must not stop the trial
        record["error"] = describe(exc)
    if recorder is not None and _wants_log(task.log, record["result"]):
        _write_episode_log(task, recorder, arena, record)
    record["wall_time_s"] = time.perf_counter() - start
    return record


def _episode_recorder(task: EpisodeTask, arena: Arena) -> Any:
    """With ``task.log``: an episode recorder set on the arena (else None)."""
    if task.log is None or task.log_path is None:
        return None
    from nao_arena.episode_log import EpisodeRecorder

    recorder = EpisodeRecorder(
        context={"command": "trial", "map": task.map, "agent": task.agent,
                 "agent_ref": task.agent_ref, "episode": task.episode, "seed": task.seed,
                 "overrides": dict(task.overrides), "time_limit": task.time_limit},
        labels=[task.agent] * len(arena.robots))
    arena.recorder = recorder
    return recorder


def _write_episode_log(task: EpisodeTask, recorder: Any, arena: Arena,
                       record: dict[str, Any]) -> None:
    """Write the episode's log; the record names it (``log``, relative to the results
    folder) or says why it could not be written (``log_error``)."""
    from nao_arena.episode_log import write_log

    assert task.log_path is not None
    try:
        write_log(recorder.finish(arena), task.log_path)
        record["log"] = f"logs/{Path(task.log_path).name}"
    except OSError as exc:
        record["log"] = None
        record["log_error"] = f"{task.log_path}: cannot be written ({exc.strerror or exc})"


def _write_record(task: EpisodeTask, record: Mapping[str, Any]) -> None:
    """Write an episode's result file atomically."""
    atomic_write_text(task.path, json.dumps(record, indent=1) + "\n")


def run_episode(task: EpisodeTask) -> dict[str, Any]:
    """Run one episode here and write its result file atomically; returns the record."""
    record = compute_episode(task)
    _write_record(task, record)
    return record


def _robot_contacts(result: Mapping[str, Any]) -> int:
    return sum(
        1 for c in result["contacts"] if c["kind_a"] == "robot" or c["kind_b"] == "robot"
    )


# --------------------------------------------------------------------------- progress


class Progress:
    """A progress line on a stream: episodes done/total, ETA, collisions so far.

    On a terminal the line is redrawn in place; otherwise a line is printed
    at most every ``interval`` seconds (and at the end).
    """

    def __init__(self, total: int, done: int = 0, stream: TextIO | None = None,
                 interval: float = 5.0) -> None:
        self.total, self.done, self.resumed = total, done, done
        self.collisions = 0
        self.failed = 0
        self.stream = stream
        self.interval = interval
        self.start = time.perf_counter()
        self._last = -math.inf
        self._tty = bool(stream is not None and getattr(stream, "isatty", lambda: False)())

    def count(self, record: Mapping[str, Any]) -> None:
        """Account for one finished episode (without redrawing)."""
        self.done += 1
        if record.get("error") is not None:
            self.failed += 1
        elif record.get("result") is not None:
            self.collisions += _robot_contacts(record["result"])

    def update(self, record: Mapping[str, Any]) -> None:
        """Account for one finished episode and redraw."""
        self.count(record)
        self.show()

    def line(self) -> str:
        elapsed = time.perf_counter() - self.start
        ran = self.done - self.resumed
        left = self.total - self.done
        eta = f"{_duration(elapsed / ran * left)}" if ran else "?"
        text = (f"episodes {self.done}/{self.total}  elapsed {_duration(elapsed)}  ETA {eta}"
                f"  collisions {self.collisions}")
        if self.failed:
            text += f"  failed {self.failed}"
        return text

    def show(self, final: bool = False) -> None:
        if self.stream is None:
            return
        now = time.perf_counter()
        if self._tty:
            self.stream.write("\r\033[K" + self.line() + ("\n" if final else ""))
        elif final or now - self._last >= self.interval:
            self.stream.write(self.line() + "\n")
        else:
            return
        self._last = now
        self.stream.flush()


def _duration(seconds: float) -> str:
    s = int(round(seconds))
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}h{m:02d}m{s:02d}s" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


# --------------------------------------------------------------------------- the trial


def _validate(config: TrialConfig) -> dict[str, dict[str, Any]]:
    """Check maps, overrides and agents before running anything; per-map overrides."""
    per_map = map_overrides(config.maps, config.overrides)
    for m in config.maps:
        make_map(m, 0, per_map[m], config.time_limit)
    for a in config.agents:
        load_agent(config.reference(a))
    return per_map


class ResultsFolderError(ValueError):
    """The output folder is in use by another trial, or holds a trial with other settings."""


@contextlib.contextmanager
def folder_lock(out: Path) -> Iterator[None]:
    """Hold the exclusive lock ``out/.lock`` (the holder's pid inside) while the block runs.

    Raises :class:`ResultsFolderError` at once, naming the folder and the holder's pid,
    if another trial holds it.
    """
    with open(Path(out) / ".lock", "a+", encoding="utf-8") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "?"
            raise ResultsFolderError(
                f"results folder {out} is in use by another trial (pid {holder}); wait for "
                "it to end or choose another --out") from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"{os.getpid()}\n")
        fh.flush()
        yield  # closing the file releases the lock


def _settings(config: TrialConfig) -> dict[str, Any]:
    """The trial's settings as ``trial.json`` holds them (JSON types)."""
    settings = {k: v for k, v in asdict(config).items() if k != "out"}
    settings.update(maps=list(config.maps), agents=list(config.agents),
                    overrides=dict(config.overrides), agent_refs=dict(config.agent_refs))
    return json.loads(json.dumps(settings))


def _setting_default(name: str) -> Any:
    f = TrialConfig.__dataclass_fields__.get(name)
    if f is None:
        return None
    if f.default_factory is not MISSING:
        return f.default_factory()
    return None if f.default is MISSING else f.default


def check_folder(out: Path, settings: Mapping[str, Any]) -> None:
    """Refuse (:class:`ResultsFolderError`) a trial whose settings differ from the
    ``trial.json`` already in ``out``, except :data:`FREE_SETTINGS`, the order of maps
    and agents, and more episodes; a setting the file lacks counts as its default."""
    path = Path(out) / "trial.json"
    if not path.exists():
        return
    try:
        before = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(before, dict):
            raise ValueError("not a JSON object")
    except (OSError, ValueError) as exc:
        raise ResultsFolderError(f"{path}: cannot read it ({exc}); expected the settings of "
                                 f"the trial in {out}: repair it or choose another --out") from None
    diffs = []
    for key, now in settings.items():
        if key in FREE_SETTINGS:
            continue
        was = before.get(key, _setting_default(key))
        if key == "episodes":
            if isinstance(was, int) and now < was:
                diffs.append(f"episodes {now} < {was} (episodes may only grow)")
        elif key in ("maps", "agents"):
            if sorted(map(str, was or [])) != sorted(now):
                diffs.append(f"{key} {was} there, {now} now")
        elif was != now:
            diffs.append(f"{key} {was!r} there, {now!r} now")
    if diffs:
        raise ResultsFolderError(
            f"results folder {out} holds another trial ({'; '.join(diffs)}): choose another "
            "--out, or repeat its settings (only workers, backend, address, csv and "
            "retry_failed may change, and episodes may grow)")


def run_trial(
    config: TrialConfig,
    progress: TextIO | None = sys.stderr,
    on_episode: Callable[[dict[str, Any]], None] | None = None,
) -> TrialResult:
    """Run the episodes of the grid not done yet, then (re)build the results files.

    progress: stream for the progress line (None: silent); on_episode: called
    in this process with each new episode's record. The episodes run on
    ``config.backend``; their records come back to this process, which
    writes each episode's file as soon as it arrives. Raises ValueError /
    :class:`~nao_arena.maps.MapError` for unknown maps or agents and bad
    overrides, :class:`~nao_arena.backends.BackendError` if the backend is
    not installed, and :class:`ResultsFolderError` if the output folder is in
    use or holds a trial with other settings, before any episode runs.
    """
    per_map = _validate(config)
    backend = make_backend(config.backend, config.workers, config.address)
    out = Path(config.out)
    (out / "episodes").mkdir(parents=True, exist_ok=True)
    settings = _settings(config)
    with folder_lock(out):
        check_folder(out, settings)
        atomic_write_text(out / "trial.json", json.dumps(settings, indent=2) + "\n")
        return _run_locked(config, per_map, backend, progress, on_episode)


def _run_locked(
    config: TrialConfig, per_map: dict[str, dict[str, Any]], backend: Any,
    progress: TextIO | None, on_episode: Callable[[dict[str, Any]], None] | None,
) -> TrialResult:
    """:func:`run_trial` once the output folder is locked and checked."""
    out = Path(config.out)
    tasks = _tasks(config, per_map)
    bar = Progress(len(tasks), 0, progress)
    todo = []
    for task in tasks:
        rec = _done_record(task, config.retry_failed)
        if rec is None:
            todo.append(task)
        else:
            bar.count(rec)
    bar.resumed = bar.done
    if progress is not None and config.episodes > 1:
        for m in config.maps:
            if "seed" not in load_map(m, **per_map[m]).parameters:
                progress.write(f"note: map {m} declares no seed parameter: its episodes "
                               "differ only by the agents' seeds\n")
    if progress is not None and len(todo) < len(tasks):
        progress.write(f"resuming: {len(tasks) - len(todo)} of {len(tasks)} episodes "
                       f"already in {out / 'episodes'}\n")

    def finished(task: EpisodeTask, record: dict[str, Any]) -> None:
        _write_record(task, record)
        bar.update(record)
        if on_episode is not None:
            on_episode(record)

    with backend:
        if todo:
            backend.prepare()
            bar.start = time.perf_counter()  # the ETA leaves out starting the backend
        backend.run(compute_episode, todo, finished)
    bar.show(final=True)
    summary, files = build_results(config, tasks)
    return TrialResult(summary, len(todo), len(tasks) - len(todo), files)


# --------------------------------------------------------------------------- results files


def _episode_rows(rec: Mapping[str, Any]) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Rows of episodes.parquet and collisions.parquet for one record."""
    key = rec["key"]
    base = {"map": key["map"], "agent": key["agent"], "episode": key["episode"],
            "seed": key["seed"]}
    result = rec.get("result")
    if rec.get("error") is not None or result is None:
        return [{**base, "error": rec.get("error") or "no result"}], []
    faults: dict[int, int] = {}
    for f in result["faults"]:
        faults[f["robot"]] = faults.get(f["robot"], 0) + 1
    robots = []
    for r in result["robots"]:
        row = {**base, "robot": r["name"]}
        row.update({k: v for k, v in r.items() if k != "name"})
        row.update(faults=faults.get(r["index"], 0), duration=result["duration"],
                   steps=result["steps"], error=None)
        robots.append(row)
    contacts = [{**base, **c, "contact": k, "log": rec.get("log")}
                for k, c in enumerate(result["contacts"], start=1)]
    return robots, contacts


def _table(rows: Sequence[Mapping[str, Any]], schema: pa.Schema) -> pa.Table:
    return pa.Table.from_pylist(
        [{name: row.get(name) for name in schema.names} for row in rows], schema=schema
    )


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval of a proportion successes/n (default 95 %); (0, 1) if n == 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    low = 0.0 if successes <= 0 else max(0.0, centre - half)
    high = 1.0 if successes >= n else min(1.0, centre + half)
    return low, high


def _median(values: Sequence[float]) -> float | None:
    return float(np.median(values)) if values else None


def summarize(records: Sequence[Mapping[str, Any]], maps: Sequence[str] | None = None,
              agents: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """The summary.json rows (see the module docstring) of episode records, one per
    map x agent, in the order of ``maps`` x ``agents`` (default: first appearance)."""
    cells: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for rec in records:
        cells.setdefault((rec["key"]["map"], rec["key"]["agent"]), []).append(rec)
    maps = list(maps) if maps is not None else list(dict.fromkeys(m for m, _ in cells))
    agents = list(agents) if agents is not None else list(dict.fromkeys(a for _, a in cells))
    out = []
    for m in maps:
        for a in agents:
            if (m, a) in cells:
                out.append(_summarize_cell(m, a, cells[(m, a)]))
    return out


def _distinct(results: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """The results whose trajectory hash no earlier one has (those without a hash count
    as distinct)."""
    seen: set[str] = set()
    out = []
    for res in results:
        digest = res.get("trajectory_hash") or ""
        if digest and digest in seen:
            continue
        seen.add(digest)
        out.append(res)
    return out


def _interval(count: int, n: int, n_distinct: int) -> list[float] | None:
    """Wilson interval of the rate count/n with n_distinct as the sample size."""
    if not n:
        return None
    if n_distinct == n:
        return list(wilson_interval(count, n))
    return list(wilson_interval(count * n_distinct / n, n_distinct))


def _summarize_cell(map_name: str, agent: str, recs: Sequence[Mapping[str, Any]]) -> dict:
    ok = [r["result"] for r in recs if r.get("error") is None and r.get("result") is not None]
    distinct = _distinct(ok)
    robots = [rob for res in ok for rob in res["robots"]]
    n = len(robots)
    n_distinct = sum(len(res["robots"]) for res in distinct)
    collided = sum(1 for r in robots if r["collisions"] > 0)
    succeeded = sum(1 for r in robots if r["success"])
    collisions = sum(_robot_contacts(res) for res in ok)
    robot_seconds = sum(res["duration"] * len(res["robots"]) for res in ok)
    driven = sum(
        (r["time_to_goal"] if r["reached_goal"] and r["time_to_goal"] is not None
         else res["duration"])
        for res in ok for r in res["robots"]
    )
    times = [r["time_to_goal"] for r in robots if r["reached_goal"] and
             r["time_to_goal"] is not None]
    seps = [r["min_separation"] for r in robots if r["min_separation"] is not None]
    adjustments = sum(r["adjustments"] for r in robots)
    hours = robot_seconds / 3600.0
    return {
        "map": map_name,
        "agent": agent,
        "episodes": len(recs),
        "failed_episodes": len(recs) - len(ok),
        "robots": n,
        "collisions": collisions,
        "collision_rate": collided / n if n else None,
        "collision_rate_ci95": _interval(collided, n, n_distinct),
        "success_rate": succeeded / n if n else None,
        "success_rate_ci95": _interval(succeeded, n, n_distinct),
        "robot_hours": hours,
        "collisions_per_robot_hour": collisions / hours if hours > 0 else None,
        "median_time_to_goal_s": _median(times),
        "min_separation_m": float(min(seps)) if seps else None,
        "median_min_separation_m": _median(seps),
        "near_misses": sum(r["near_misses"] for r in robots),
        "adjustments_per_s": adjustments / driven if driven > 0 else None,
        "faults": sum(len(res["faults"]) for res in ok),
        "distinct_episodes": len(distinct),
        "distinct_robots": n_distinct,
        "robots_collided": collided,
        "robots_succeeded": succeeded,
        "robots_arrived": len(times),
        "adjustments": adjustments,
        "driven_s": driven,
        "robots_timed_out": sum(1 for r in robots if not r["reached_goal"]),
        "robots_stuck": sum(1 for r in robots if (r.get("stuck_time") or 0.0) > 0.0),
        "stuck_s": sum(r.get("stuck_time") or 0.0 for r in robots),
        "robots_left_goal": sum(1 for r in robots
                                if (r.get("time_away_after_arrival") or 0.0) > 0.0),
        "robots_away_at_end": sum(1 for r in robots
                                  if r["reached_goal"] and not r.get("at_goal_at_end", True)),
        "episodes_deadlocked": sum(1 for res in ok if res.get("deadlock_time") is not None),
    }


def build_results(
    config: TrialConfig, tasks: Sequence[EpisodeTask] | None = None
) -> tuple[list[dict[str, Any]], list[Path]]:
    """(Re)build episodes.parquet, collisions.parquet, summary.json (and CSVs) from the
    per-episode files of the grid; returns the summary rows and the files written.

    Episodes of the grid without a (matching) result file are left out.
    """
    if tasks is None:
        tasks = _tasks(config, map_overrides(config.maps, config.overrides))
    out = Path(config.out)
    records = []
    for task in tasks:
        rec = _read_record(task.path)
        if rec is not None and rec.get("key") == task.key():
            records.append(rec)
    robot_rows: list[dict[str, Any]] = []
    contact_rows: list[dict[str, Any]] = []
    for rec in records:
        r, c = _episode_rows(rec)
        robot_rows += r
        contact_rows += c
    episodes = _table(robot_rows, EPISODE_SCHEMA)
    collisions = _table(contact_rows, COLLISION_SCHEMA)
    summary = summarize(records, config.maps, config.agents)
    files = [out / "episodes.parquet", out / "collisions.parquet", out / "summary.json"]
    atomic_write_with(files[0], lambda p: pq.write_table(episodes, p))
    atomic_write_with(files[1], lambda p: pq.write_table(collisions, p))
    atomic_write_text(files[2], json.dumps(summary, indent=2) + "\n")
    if config.csv:
        csv_files = [out / "episodes.csv", out / "collisions.csv", out / "summary.csv"]
        atomic_write_with(csv_files[0], lambda p: pa_csv.write_csv(episodes, p))
        atomic_write_with(csv_files[1], lambda p: pa_csv.write_csv(collisions, p))
        flat = [{**{k: v for k, v in row.items() if not k.endswith("_ci95")},
                 **{f"{k}_{side}": (row[k][i] if row[k] is not None else None)
                    for k in ("collision_rate_ci95", "success_rate_ci95")
                    for i, side in enumerate(("low", "high"))}} for row in summary]
        flat_table = pa.Table.from_pylist(flat) if flat else pa.table({})
        atomic_write_with(csv_files[2], lambda p: pa_csv.write_csv(flat_table, p))
        files += csv_files
    return summary, files


def load_summary(folder: str | Path) -> list[dict[str, Any]]:
    """The rows of ``folder/summary.json``; FileNotFoundError names the file."""
    path = Path(folder) / "summary.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file (is {folder} a trial's output folder?)")
    return json.loads(path.read_text(encoding="utf-8"))


# --------------------------------------------------------------------------- the table


TABLE_LEGEND = """\
episodes: episodes with a result ("failed": raised, left out of every other column);
  distinct: distinct trajectories among the completed episodes (exact repeats counted once)
success: robot-episodes that reached the goal without any contact and were at it at the
  episode's end / robot-episodes (%)
collision rate: robot-episodes with at least one contact / robot-episodes (%),
  [95 % Wilson interval; sample size: the robot-episodes of distinct episodes]
contacts: contact events involving a robot (robot-robot counted once)
contacts/robot-h: contacts per hour of robot time (episode duration x robots)
median TTG s: median time to goal of the robot-episodes that arrived (s)
min sep m: smallest surface-to-surface gap of any robot-episode (m; < 0: discs overlapped)
adj/s: acceleration adjustments per second driven (until the goal or the episode's end)
timed out: robot-episodes that never reached the goal / robot-episodes (%)
stuck: robot-episodes that were stuck at some time (away from the goal and less than
  0.1 m closer to it over the last 5 s)
left goal: robot-episodes that arrived and were later away from the goal again
deadlocks: episodes with a time at which every robot away from its goal was stuck"""
"""The definitions of the columns of :func:`format_table`."""


def _num(value: float | None, decimals: int) -> str:
    """value with ``decimals`` decimals, or 2 significant digits where those would
    round a non-zero value to zero; "-" for None."""
    if value is None:
        return "-"
    text = f"{value:.{decimals}f}"
    if value != 0 and float(text) == 0:
        text = f"{value:.2g}"
    return text


def _percent(share: float) -> str:
    """A share in [0, 1] as a percentage with at least 2 significant digits of both it
    and its complement: only 0 reads 0 and only 1 reads 100."""
    v = 100.0 * share
    if v <= 0.0 or v >= 100.0:
        return f"{v:.0f}"
    decimals = max(1, 1 - math.floor(math.log10(min(v, 100.0 - v))))
    return f"{v:.{decimals}f}"


def _count(row: Mapping[str, Any], key: str, rate_key: str) -> int | None:
    """A count of the summary row (summaries without it: from its rate x robots)."""
    if row.get(key) is not None:
        return int(row[key])
    rate = row.get(rate_key)
    return None if rate is None else round(rate * row["robots"])


def _share(row: Mapping[str, Any], key: str, rate_key: str, ci: bool = False) -> str:
    """``count/robots (percent %)``, with ``[low, high] %`` (95 % interval) if ci."""
    count, n = _count(row, key, rate_key), row.get("robots") or 0
    if count is None or not n:
        return "-"
    text = f"{count}/{n} ({_percent(count / n)} %)"
    interval = row.get(f"{rate_key}_ci95")
    if ci and interval is not None:
        text += f" [{_percent(interval[0])}, {_percent(interval[1])}] %"
    return text


def _plain(value: int | None) -> str:
    return "-" if value is None else str(value)


def _repeat_notes(summary: Sequence[Mapping[str, Any]]) -> list[str]:
    """One line per cell whose completed episodes include exact repeats."""
    notes = []
    for row in summary:
        done = row["episodes"] - (row.get("failed_episodes") or 0)
        distinct = row.get("distinct_episodes")
        if distinct is not None and distinct < done:
            noun = "trajectory" if distinct == 1 else "trajectories"
            notes.append(
                f"note: {row['map']} x {row['agent']}: {done} episodes but only {distinct} "
                f"distinct {noun} (the others repeat one exactly); the intervals take the "
                f"{row.get('distinct_robots')} robot-episodes of distinct episodes as the "
                "sample size")
    return notes


def format_table(summary: Sequence[Mapping[str, Any]], legend: bool = True) -> str:
    """The summary rows as an aligned text table, then a note for each cell with
    repeated episodes and (if legend) :data:`TABLE_LEGEND`."""
    head = ["map", "agent", "episodes", "distinct", "success", "collision rate [95% CI]",
            "contacts", "contacts/robot-h", "median TTG s", "min sep m", "adj/s",
            "timed out", "stuck", "left goal", "deadlocks"]
    body = []
    for row in summary:
        episodes = str(row["episodes"])
        if row.get("failed_episodes"):
            episodes += f" ({row['failed_episodes']} failed)"
        distinct = row.get("distinct_episodes")
        body.append([
            str(row["map"]), str(row["agent"]), episodes,
            "-" if distinct is None else str(distinct),
            _share(row, "robots_succeeded", "success_rate"),
            _share(row, "robots_collided", "collision_rate", ci=True),
            str(row["collisions"]),
            _num(row.get("collisions_per_robot_hour"), 1),
            _num(row.get("median_time_to_goal_s"), 1),
            _num(row.get("min_separation_m"), 3),
            _num(row.get("adjustments_per_s"), 2),
            _share(row, "robots_timed_out", ""),
            _plain(row.get("robots_stuck")),
            _plain(row.get("robots_left_goal")),
            _plain(row.get("episodes_deadlocked")),
        ])
    widths = [max(len(r[i]) for r in [head, *body]) for i in range(len(head))]
    left = {0, 1}

    def line(cells: Sequence[str]) -> str:
        return "  ".join(c.ljust(w) if i in left else c.rjust(w)
                         for i, (c, w) in enumerate(zip(cells, widths, strict=True))).rstrip()

    rule = "  ".join("-" * w for w in widths)
    lines = [line(head), rule, *(line(r) for r in body), *_repeat_notes(summary)]
    if legend:
        lines += ["", TABLE_LEGEND]
    return "\n".join(lines)
