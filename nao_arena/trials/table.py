"""The summary as a text table (what ``nao-arena trial`` and ``report`` print), with its
legend."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = [
    "PEOPLE_LEGEND",
    "TABLE_LEGEND",
    "format_table",
]


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

PEOPLE_LEGEND = """\
among people (maps with people, nao_arena.stats.people): robot-caused: robot-episodes
  with a contact with a person at whose first touch the robot was moving (>= 0.05 m/s)
  and that did not begin overlapping (a recorded person appearing on the robot) /
  robot-episodes with people around (%); person contacts:
  every robot-person contact, a person walking into a robot standing still included;
  discomfort: time within 0.2 m (surface to surface) of a person / robot time (%);
  min dist m: smallest surface-to-surface gap to a person of any robot-episode"""
"""The definitions of the columns of the table "among people"."""


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
                "sample size"
            )
    return notes


def format_table(
    summary: Sequence[Mapping[str, Any]],
    legend: bool = True,
    map_names: Mapping[str, str] | None = None,
) -> str:
    """The summary rows as an aligned text table, then a note for each cell with
    repeated episodes and (if legend) :data:`TABLE_LEGEND`. ``map_names``: what to show
    for a map reference (e.g. a map file's ``name`` for its path; default: the reference)."""
    map_names = map_names or {}
    head = [
        "map",
        "agent",
        "episodes",
        "distinct",
        "success",
        "collision rate [95% CI]",
        "contacts",
        "contacts/robot-h",
        "median TTG s",
        "min sep m",
        "adj/s",
        "timed out",
        "stuck",
        "left goal",
        "deadlocks",
    ]
    body = []
    for row in summary:
        episodes = str(row["episodes"])
        if row.get("failed_episodes"):
            episodes += f" ({row['failed_episodes']} failed)"
        distinct = row.get("distinct_episodes")
        body.append(
            [
                str(map_names.get(row["map"], row["map"])),
                str(row["agent"]),
                episodes,
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
            ]
        )
    widths = [max(len(r[i]) for r in [head, *body]) for i in range(len(head))]
    left = {0, 1}

    def line(cells: Sequence[str]) -> str:
        return "  ".join(
            c.ljust(w) if i in left else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        ).rstrip()

    rule = "  ".join("-" * w for w in widths)
    lines = [line(head), rule, *(line(r) for r in body), *_repeat_notes(summary)]
    people = [row for row in summary if row.get("robots_among_people")]
    if people:
        lines += ["", "among people:", _people_table(people, map_names)]
    if legend:
        lines += ["", TABLE_LEGEND]
        if people:
            lines += [PEOPLE_LEGEND]
    return "\n".join(lines)


def _people_table(summary: Sequence[Mapping[str, Any]], map_names: Mapping[str, str]) -> str:
    """The social-navigation columns of the rows whose robots met people."""
    head = ["map", "agent", "robot-caused", "person contacts", "discomfort"]
    head.append("min dist m")
    body = []
    for row in summary:
        n = row["robots_among_people"]
        caused = row["robots_caused_person_contact"]
        share = row.get("discomfort_share")
        body.append(
            [
                str(map_names.get(row["map"], row["map"])),
                str(row["agent"]),
                f"{caused}/{n} ({_percent(caused / n)} %)",
                str(row["person_contacts"]),
                "-" if share is None else f"{_percent(share)} %",
                _num(row.get("min_person_distance_m"), 3),
            ]
        )
    widths = [max(len(r[i]) for r in [head, *body]) for i in range(len(head))]
    lines = [
        "  ".join(
            c.ljust(w) if i < 2 else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        ).rstrip()
        for cells in [head, *body]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)
