"""The text tables of the command line (:mod:`nao_arena.cli`): an episode's per-robot
results, its results among people, and a map's bodies in one line."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from nao_arena._cli_common import _plural

if TYPE_CHECKING:
    from nao_arena.maps import MapSpec


def _bodies_line(spec: MapSpec) -> str:
    """``2 robots, 5 people, 30 traffic vehicles`` (people and recorded people only where
    the map has them)."""
    parts = [_plural(spec.n_robots, "robot")]
    if spec.n_people:
        parts.append(_plural(spec.n_people, "person", "people"))
    if spec.n_recorded:
        parts.append(_plural(spec.n_recorded, "recorded person", "recorded people"))
    parts.append(_plural(sum(g.count for g in spec.traffic), "traffic vehicle"))
    return ", ".join(parts)


def people_table(summary: Any) -> str:
    """An episode's per-robot results among people (an EpisodeSummary): contacts with
    people, those the robot caused (it was moving), discomfort (s, and its share of the
    episode) and the closest approach (m)."""
    head = [
        "robot",
        "person contacts",
        "robot-caused",
        "discomfort s",
        "discomfort %",
        "min dist m",
    ]
    body = []
    for r in summary.robots:
        share = 100.0 * r.discomfort_time / summary.duration if summary.duration > 0 else 0.0
        closest = r.min_person_distance
        body.append(
            [
                r.name,
                str(r.person_contacts),
                str(r.caused_person_contacts),
                f"{r.discomfort_time:.1f}",
                f"{share:.1f}",
                f"{closest:.3f}" if closest == closest and abs(closest) != float("inf") else "-",
            ]
        )
    return "among people:\n" + _aligned(head, body)


def episode_table(summary: Any, agents: list[str]) -> str:
    """An episode's per-robot results (an EpisodeSummary) as an aligned text table."""
    head = [
        "robot",
        "agent",
        "success",
        "goal s",
        "path m",
        "collisions",
        "near misses",
        "min sep m",
        "min TTC s",
        "adj/s",
    ]

    def num(v: float, spec: str) -> str:
        return format(v, spec) if v == v and abs(v) != float("inf") else "-"

    body = [
        [
            r.name,
            agents[k] if k < len(agents) else "?",
            "yes" if r.success else "no",
            num(r.time_to_goal, ".1f"),
            num(r.path_length, ".1f"),
            str(r.collisions),
            str(r.near_misses),
            num(r.min_separation, ".3f"),
            num(r.min_ttc, ".2f"),
            num(r.adjustment_rate, ".2f"),
        ]
        for k, r in enumerate(summary.robots)
    ]
    return _aligned(head, body, left=3)


def _aligned(head: list[str], body: list[list[str]], left: int = 1) -> str:
    """A text table: the header, a rule, the rows; the first ``left`` columns aligned
    left, the others right."""
    widths = [max(len(row[i]) for row in [head, *body]) for i in range(len(head))]
    lines = [
        "  ".join(
            c.ljust(w) if i < left else c.rjust(w)
            for i, (c, w) in enumerate(zip(row, widths, strict=True))
        ).rstrip()
        for row in [head, *body]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)
