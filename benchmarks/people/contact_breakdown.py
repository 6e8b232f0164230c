"""Where a trial's crossings of people went wrong: the first contact with a person of each
robot-episode that had one, sorted by what the robot and the person were doing.

Reads a trial folder run with episode logs for the contacts (``nao-arena trial ... --log
contacts``, or ``--log``) and prints a table of counts.

One row per map and agent of the trial, in its order:

- crossings with a contact: robot-episodes with at least one contact with a person;
- robot at rest: of them, those whose first touch found the robot standing (slower than
  ``StatsConfig.moving_speed``, 0.05 m/s: a person walking into it);
- robot-caused: the trial's ``caused_person_contacts`` column (robot-episodes with a
  contact it caused, :func:`nao_arena.stats.people.robot_caused`);
- seen late: those whose first touch was with a person who had been in the scene for
  less than ``--seen-within`` s (default 1 s) before it; in brackets, how many of them
  were robot-caused. A recorded person is in the scene where the log has them on the
  map (:func:`nao_arena.explain.on_map`); before appearing they wait far outside it.
  From rest, a robot at 2 m/s^2 needs 0.77 s to move 0.6 m (the sum of the crossing
  maps' radii) sideways, and a control period (0.1 s) to see them.

Run: ``python benchmarks/people/contact_breakdown.py RESULTS [--seen-within 1.0]``, with
RESULTS the trial's ``--out`` folder. A folder without ``collisions.parquet``, or whose
contacts have no log, is a one-line error (exit status 2).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq

from nao_arena.episode_log import read_log
from nao_arena.explain import on_map
from nao_arena.stats.records import StatsConfig


@dataclass(frozen=True)
class FirstTouch:
    """The first contact with a person of one robot-episode."""

    map: str
    agent: str
    at_rest: bool
    caused: bool
    seen_for: float  # s the person had been in the scene before the touch


def seen_for(results: Path, log: str, person: int, time: float) -> float:
    """How long (s) body ``person`` had been in the scene at ``time`` (s) in the episode
    log ``log`` (relative to ``results``): from its first logged step on the map
    (:func:`nao_arena.explain.on_map`) up to ``time``."""
    ep = read_log(results / log)
    here = ~np.isnan(on_map(ep, ep.positions[:, person])[:, 0]) & (ep.time <= time + 1e-9)
    if not here.any():
        return 0.0
    return float(time - ep.time[int(np.argmax(here))])


def _rows(path: Path, columns: list[str]) -> list[dict[str, Any]]:
    """The rows of a trial's Parquet file, as dicts of the named columns."""
    return pq.read_table(path, columns=columns).to_pylist()


def first_touches(results: Path) -> list[FirstTouch]:
    """The first contact with a person of each robot-episode of the trial in ``results``
    that had one (robots are the contacts' ``a`` side)."""
    episode_columns = ["map", "agent", "episode", "robot", "caused_person_contacts"]
    caused = {
        (r["map"], r["agent"], r["episode"], r["robot"]): r["caused_person_contacts"]
        for r in _rows(results / "episodes.parquet", episode_columns)
    }
    contact_columns = ["map", "agent", "episode", "name_a", "kind_a", "kind_b", "b", "time"]
    first: dict[tuple[Any, ...], dict[str, Any]] = {}
    for c in _rows(results / "collisions.parquet", [*contact_columns, "speed_a", "log"]):
        if c["kind_a"] != "robot" or c["kind_b"] != "person":
            continue
        key = (c["map"], c["agent"], c["episode"], c["name_a"])
        if key not in first or c["time"] < first[key]["time"]:
            first[key] = c
    moving = StatsConfig().moving_speed
    out = []
    for key, c in first.items():
        if not isinstance(c["log"], str):
            raise ValueError(
                f"{results}: episode {c['episode']} of {c['map']} ({c['agent']}) has no log: "
                "run the trial with --log contacts"
            )
        out.append(
            FirstTouch(
                map=Path(str(c["map"])).stem,
                agent=str(c["agent"]),
                at_rest=float(c["speed_a"]) < moving,
                caused=(caused.get(key) or 0) > 0,
                seen_for=seen_for(results, c["log"], int(c["b"]), float(c["time"])),
            )
        )
    return out


def trial_pairs(results: Path) -> list[tuple[str, str]]:
    """The (map, agent) pairs of the trial in ``results``, in the order it ran them (map
    by its file's stem)."""
    pairs = [
        (Path(str(r["map"])).stem, str(r["agent"]))
        for r in _rows(results / "episodes.parquet", ["map", "agent"])
    ]
    return list(dict.fromkeys(pairs))


def table(pairs: list[tuple[str, str]], touches: list[FirstTouch], within: float) -> str:
    """The printed table: one row per (map, agent) pair of ``pairs``, in their order (a
    pair without contacts has a row of zeros)."""
    rows = [
        f"| map | agent | crossings with a contact | robot at rest | robot-caused | "
        f"seen less than {within:g} s before (robot-caused) |",
        "| --- | --- | ---: | ---: | ---: | ---: |",
    ]
    for map_name, agent in pairs:
        ts = [t for t in touches if (t.map, t.agent) == (map_name, agent)]
        late = [t for t in ts if t.seen_for < within]
        rows.append(
            f"| {map_name} | {agent} | {len(ts)} | {sum(t.at_rest for t in ts)} | "
            f"{sum(t.caused for t in ts)} | {len(late)} ({sum(t.caused for t in late)}) |"
        )
    return "\n".join(rows)


def _error(message: str) -> int:
    """One line on stderr, prefixed with the script's name; the exit status 2."""
    print(f"contact_breakdown: error: {message}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path, help="the trial's --out folder")
    parser.add_argument("--seen-within", type=float, default=1.0, metavar="S")
    args = parser.parse_args(argv)
    if not (math.isfinite(args.seen_within) and args.seen_within > 0):
        seconds = args.seen_within
        return _error(f"--seen-within: expected a positive number of seconds, got {seconds}")
    if not (args.results / "collisions.parquet").is_file():
        return _error(f"{args.results}: expected a trial folder with collisions.parquet")
    try:
        touches = first_touches(args.results)
    except (ValueError, OSError) as exc:
        return _error(str(exc).splitlines()[0])
    print(table(trial_pairs(args.results), touches, args.seen_within))
    return 0


if __name__ == "__main__":
    sys.exit(main())
