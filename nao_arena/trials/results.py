"""The results files of a trial, rebuilt from its per-episode files: ``episodes.parquet``,
``collisions.parquet``, ``summary.json`` (and CSVs), with the summary's statistics
(rates with Wilson intervals over distinct trajectories)."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from nao_arena.atomic import atomic_write_text, atomic_write_with
from nao_arena.stats import ContactEvent, RobotSummary
from nao_arena.trials.config import EpisodeTask, TrialConfig, grid_tasks, map_overrides
from nao_arena.trials.episode import read_record, robot_contacts

__all__ = [
    "COLLISION_SCHEMA",
    "EPISODE_SCHEMA",
    "SUMMARY_KEYS",
    "build_results",
    "load_summary",
    "summarize",
    "wilson_interval",
]


SUMMARY_KEYS: tuple[str, ...] = (
    "map",
    "agent",
    "episodes",
    "failed_episodes",
    "robots",
    "collisions",
    "collision_rate",
    "collision_rate_ci95",
    "success_rate",
    "success_rate_ci95",
    "robot_hours",
    "collisions_per_robot_hour",
    "median_time_to_goal_s",
    "min_separation_m",
    "median_min_separation_m",
    "near_misses",
    "adjustments_per_s",
    "faults",
    "distinct_episodes",
    "distinct_robots",
    "robots_collided",
    "robots_succeeded",
    "robots_arrived",
    "adjustments",
    "driven_s",
    "robots_timed_out",
    "robots_stuck",
    "stuck_s",
    "robots_left_goal",
    "robots_away_at_end",
    "episodes_deadlocked",
    "robots_among_people",
    "person_contacts",
    "robot_caused_person_contacts",
    "robots_caused_person_contact",
    "discomfort_s",
    "discomfort_share",
    "min_person_distance_m",
)

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

COLLISION_SCHEMA = pa.schema(
    _KEY_COLUMNS
    + _arrow_fields(ContactEvent)
    + [
        pa.field("contact", pa.int64()),
        pa.field("log", pa.string()),
    ]
)
"""Columns of ``collisions.parquet``: one row per contact event."""


def _episode_rows(rec: Mapping[str, Any]) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Rows of episodes.parquet and collisions.parquet for one record."""
    key = rec["key"]
    base = {
        "map": key["map"],
        "agent": key["agent"],
        "episode": key["episode"],
        "seed": key["seed"],
    }
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
        row.update(
            faults=faults.get(r["index"], 0),
            duration=result["duration"],
            steps=result["steps"],
            error=None,
        )
        robots.append(row)
    contacts = [
        {**base, **c, "contact": k, "log": rec.get("log")}
        for k, c in enumerate(result["contacts"], start=1)
    ]
    return robots, contacts


def _table(rows: Sequence[Mapping[str, Any]], schema: pa.Schema) -> pa.Table:
    return pa.Table.from_pylist(
        [{name: row.get(name) for name in schema.names} for row in rows], schema=schema
    )


def wilson_interval(successes: float, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
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


def summarize(
    records: Sequence[Mapping[str, Any]],
    maps: Sequence[str] | None = None,
    agents: Sequence[str] | None = None,
) -> list[dict[str, Any]]:
    """The summary.json rows (see :mod:`nao_arena.trials`) of episode records, one per
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
    collisions = sum(robot_contacts(res) for res in ok)
    robot_seconds = sum(res["duration"] * len(res["robots"]) for res in ok)
    driven = sum(
        (
            r["time_to_goal"]
            if r["reached_goal"] and r["time_to_goal"] is not None
            else res["duration"]
        )
        for res in ok
        for r in res["robots"]
    )
    times = [
        r["time_to_goal"] for r in robots if r["reached_goal"] and r["time_to_goal"] is not None
    ]
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
        "robots_left_goal": sum(
            1 for r in robots if (r.get("time_away_after_arrival") or 0.0) > 0.0
        ),
        "robots_away_at_end": sum(
            1 for r in robots if r["reached_goal"] and not r.get("at_goal_at_end", True)
        ),
        "episodes_deadlocked": sum(1 for res in ok if res.get("deadlock_time") is not None),
        **_among_people(ok),
    }


def _among_people(results: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The summary's social-navigation entries of the results of one cell (see
    :mod:`nao_arena.stats.people`): counts over the robot-episodes with people around,
    None where no robot met people."""
    robots = [(res, r) for res in results for r in res["robots"] if r.get("among_people")]
    seconds = sum(res["duration"] for res, _ in robots)
    closest = [
        float(r["min_person_distance"])
        for _, r in robots
        if r.get("min_person_distance") is not None
    ]
    discomfort = sum(r.get("discomfort_time") or 0.0 for _, r in robots)
    return {
        "robots_among_people": len(robots),
        "person_contacts": sum(r.get("person_contacts") or 0 for _, r in robots),
        "robot_caused_person_contacts": sum(
            r.get("caused_person_contacts") or 0 for _, r in robots
        ),
        "robots_caused_person_contact": sum(
            1 for _, r in robots if (r.get("caused_person_contacts") or 0) > 0
        ),
        "discomfort_s": discomfort,
        "discomfort_share": discomfort / seconds if seconds > 0 else None,
        "min_person_distance_m": min(closest) if closest else None,
    }


def build_results(
    config: TrialConfig, tasks: Sequence[EpisodeTask] | None = None
) -> tuple[list[dict[str, Any]], list[Path]]:
    """(Re)build episodes.parquet, collisions.parquet, summary.json (and CSVs) from the
    per-episode files of the grid; returns the summary rows and the files written.

    Episodes of the grid without a (matching) result file are left out.
    """
    if tasks is None:
        tasks = grid_tasks(config, map_overrides(config.maps, config.overrides))
    out = Path(config.out)
    records = []
    for task in tasks:
        rec = read_record(task.path)
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
        flat = [
            {
                **{k: v for k, v in row.items() if not k.endswith("_ci95")},
                **{
                    f"{k}_{side}": (row[k][i] if row[k] is not None else None)
                    for k in ("collision_rate_ci95", "success_rate_ci95")
                    for i, side in enumerate(("low", "high"))
                },
            }
            for row in summary
        ]
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
