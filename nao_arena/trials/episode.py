"""One episode of a trial: run it (with its time budget and optional log), and read or
write its result file (``episodes/<map>__<agent>__<episode>.json``)."""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nao_arena.agent import describe
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.atomic import atomic_write_text
from nao_arena.isolation import run_isolated
from nao_arena.kernels import parts_for_agents, preload
from nao_arena.trials.config import EpisodeTask, make_map
from nao_arena.watchdog import wall_clock_budget

__all__ = [
    "FORMAT",
    "compute_episode",
    "done_record",
    "read_record",
    "robot_contacts",
    "run_episode",
    "write_record",
]


FORMAT = 1


def read_record(path: str | Path) -> dict[str, Any] | None:
    try:
        with open(path, encoding="utf-8") as fh:
            rec = json.load(fh)
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) else None


def done_record(task: EpisodeTask, retry_failed: bool) -> dict[str, Any] | None:
    """The task's existing result record, if it needs not run again."""
    rec = read_record(task.path)
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
    return robot_contacts(result) > 0 or any(
        (r.get("stuck_time") or 0.0) > 0.0 for r in result["robots"]
    )


def _lacks_log(task: EpisodeTask, rec: Mapping[str, Any]) -> bool:
    """A completed episode that should have a log (task.log) but has none (or it is gone)."""
    if rec.get("error") is not None or not _wants_log(task.log, rec.get("result")):
        return False
    return not (rec.get("log") and task.log_path and Path(task.log_path).is_file())


def compute_episode(task: EpisodeTask) -> dict[str, Any]:
    """Run one episode; returns its record (what the episode's result file holds).

    This is what every backend executes, wherever it runs. The episode runs in a
    process of its own, forked from this one and watched from here
    (:func:`nao_arena.isolation.run_isolated`): whatever an agent does to its process
    (ends it, forks, ignores the budget's alarm, leaves threads running) fails this
    episode only. This process loads the episode's kernels first (once; see
    :func:`nao_arena.kernels.preload`), so neither that warm-up nor a compile counts
    against ``task.episode_timeout``.

    It writes no file but the episode's log (``task.log``; the record's ``log`` names it
    relative to the results folder, null without one; ``log_error``: why it could not
    be written). An exception while loading the map, building the arena or running is
    recorded (``error``: its type and message, ``result``: null) instead of
    propagating; so are exceeding ``task.episode_timeout`` (``EpisodeTimeout:
    episode exceeded its wall-clock budget of N s``) and the episode's process ending
    without a result (``EpisodeProcessEnded: ...``). Only KeyboardInterrupt
    propagates. The record's ``wall_time_s`` is informative only (it is in no results
    table).
    """
    start = time.perf_counter()
    _warm_up(task)
    try:
        record = run_isolated(_compute_here, task, task.episode_timeout)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a failing episode must not stop the trial
        record = _record(task)
        record["error"] = describe(exc)
    record["wall_time_s"] = time.perf_counter() - start
    return record


def _record(task: EpisodeTask) -> dict[str, Any]:
    return {"format": FORMAT, "key": task.key(), "error": None, "result": None}


def _warm_up(task: EpisodeTask) -> None:
    """Load the kernels of the task's agent into this process (once per agent), so that
    the episode's process starts warm."""
    preload(parts_for_agents([task.agent_ref or task.agent]))
    Arena.warm_up()


def _compute_here(task: EpisodeTask) -> dict[str, Any]:
    """:func:`compute_episode` in this process (no isolation), without ``wall_time_s``."""
    record = _record(task)
    recorder = None
    try:
        with wall_clock_budget(task.episode_timeout):
            spec = make_map(
                task.map,
                task.seed,
                task.overrides,
                task.time_limit,
                trusted=task.trust_map,
                agents=task.named_agents,
            )
            arena = Arena(
                spec, ArenaOptions(agent=task.agent_ref or task.agent, max_faults=task.max_faults)
            )
            recorder = _episode_recorder(task, arena)
            record["result"] = arena.run(task.seed).to_dict()
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a failing episode must not stop the trial
        record["error"] = describe(exc)
    if recorder is not None and _wants_log(task.log, record["result"]):
        _write_episode_log(task, recorder, arena, record)
    return record


def _episode_recorder(task: EpisodeTask, arena: Arena) -> Any:
    """With ``task.log``: an episode recorder set on the arena (else None)."""
    if task.log is None or task.log_path is None:
        return None
    from nao_arena.episode_log import EpisodeRecorder

    recorder = EpisodeRecorder(
        context={
            "command": "trial",
            "map": task.map,
            "agent": task.agent,
            "agent_ref": task.agent_ref,
            "episode": task.episode,
            "seed": task.seed,
            "overrides": dict(task.overrides),
            "time_limit": task.time_limit,
        },
        labels=arena.labels_with(task.agent),
    )
    arena.recorder = recorder
    return recorder


def _write_episode_log(
    task: EpisodeTask, recorder: Any, arena: Arena, record: dict[str, Any]
) -> None:
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


def write_record(task: EpisodeTask, record: Mapping[str, Any]) -> None:
    """Write an episode's result file atomically."""
    atomic_write_text(task.path, json.dumps(record, indent=1) + "\n")


def run_episode(task: EpisodeTask) -> dict[str, Any]:
    """Run one episode here and write its result file atomically; returns the record."""
    record = compute_episode(task)
    write_record(task, record)
    return record


def robot_contacts(result: Mapping[str, Any]) -> int:
    return sum(1 for c in result["contacts"] if c["kind_a"] == "robot" or c["kind_b"] == "robot")
