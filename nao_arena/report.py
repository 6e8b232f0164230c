"""Plots and the table of a trial's results folder (see :mod:`nao_arena.trials`).

:func:`write_report` reads ``summary.json`` and ``episodes.parquet`` and
writes PNG figures (matplotlib, Agg canvas, no display needed):

- ``rates.png``: per map, the collision rate per agent (share of
  robot-episodes with a collision, with its 95 % Wilson interval; each bar
  labelled with its count, robot-episodes with a collision / robot-episodes)
  and the acceleration adjustments per second driven per agent, with a 95 %
  interval (:func:`adjustment_rate_ci95`) and the definition of an
  adjustment under the plots;
- ``time_to_goal.png``: per map, the distribution of the time to goal (s)
  of the robot-episodes that arrived, one box per agent (under each agent:
  robot-episodes that arrived / robot-episodes; tick labels are turned
  when they would overlap);
- ``min_separation.png``: histograms of the robot-episodes' minimum
  separation (m, surface to surface; below 0 = contact), one per agent
  (rows) and map (columns); robot-episodes that never came within the
  stats' ``separation_range`` are counted in each panel's note;
- where robots met people (:mod:`nao_arena.stats.people`), ``among_people.png``: per map
  and agent, the share of robot-episodes with a robot-caused contact with a person (95 %
  Wilson interval) and the discomfort share; and ``people_distance.png``: histograms of
  the robot-episodes' closest approach to a person (m, surface to surface; below 0 =
  contact), laid out as ``min_separation.png``, those never within the stats'
  ``separation_range`` of a person counted in each panel's note.

:func:`report_text` adds the episodes with contacts and their logs (see
:func:`contact_logs`): ``nao-arena replay LOG`` shows one, ``nao-arena
explain LOG --contact K`` explains its contact K.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from nao_arena.atomic import atomic_write_with
from nao_arena.stats import StatsConfig
from nao_arena.trials import format_table, load_summary, wilson_interval

__all__ = [
    "ADJUSTMENT_CAPTION",
    "PEOPLE_DISTANCE_FILE",
    "PEOPLE_FILE",
    "REPORT_FILES",
    "adjustment_rate_ci95",
    "contact_logs",
    "format_contact_logs",
    "rate_label",
    "report_text",
    "write_report",
]

REPORT_FILES = ("rates.png", "time_to_goal.png", "min_separation.png")
PEOPLE_FILE = "among_people.png"
"""The report's plot of the social-navigation metrics, written when robots met people."""
PEOPLE_DISTANCE_FILE = "people_distance.png"
"""The report's histograms of the closest approach to a person, written with
:data:`PEOPLE_FILE`."""
MAX_LISTED = 30
"""Episodes with contacts listed by :func:`format_contact_logs` (the others are counted)."""

ADJUSTMENT_CAPTION = (
    "Adjustment: a control step at which the robot's commanded acceleration changed by more "
    f"than {StatsConfig().adjustment_threshold:g} m/s^2 from the step before, counted until "
    "the robot reaches its goal; rate = adjustments / time driven (until the goal, or the "
    "episode's end), over all robot-episodes of the cell. Whiskers: 95 % intervals (collision "
    "rate: Wilson; adjustments: ratio +- 1.96 standard errors, episodes as clusters)."
)
"""The definition under ``rates.png``."""


def report_text(folder: str | Path) -> str:
    """The summary table of a results folder, with its notes and the columns' legend
    (see :func:`~nao_arena.trials.format_table`), then the episodes with contacts and
    their logs (:func:`format_contact_logs`)."""
    text = format_table(load_summary(folder))
    listing = format_contact_logs(folder)
    return f"{text}\n\n{listing}" if listing else text


def contact_logs(folder: str | Path) -> list[dict[str, Any]]:
    """The episodes of ``folder/collisions.parquet`` with a contact involving a robot, in
    the table's order: map, agent, episode, seed, ``contacts`` (their number), ``first``
    (the time of the first, s) and ``log`` (the log's path, None without one)."""
    folder = Path(folder)
    table = folder / "collisions.parquet"
    if not table.is_file():
        return []
    rows = pq.read_table(table).to_pylist()
    episodes: dict[tuple[Any, ...], dict[str, Any]] = {}
    for r in rows:
        if "robot" not in (r["kind_a"], r["kind_b"]):
            continue
        key = (r["map"], r["agent"], r["episode"])
        ep = episodes.setdefault(
            key,
            {
                "map": r["map"],
                "agent": r["agent"],
                "episode": r["episode"],
                "seed": r["seed"],
                "contacts": 0,
                "first": r["time"],
                "log": None,
            },
        )
        ep["contacts"] += 1
        ep["first"] = min(ep["first"], r["time"])
        if r.get("log"):
            ep["log"] = str(folder / r["log"])
    return list(episodes.values())


def format_contact_logs(folder: str | Path) -> str:
    """The episodes with contacts and their logs as text ("" when there are none)."""
    episodes = contact_logs(folder)
    if not episodes:
        return ""
    logged = sum(1 for e in episodes if e["log"])
    lines = [
        f"episodes with contacts: {len(episodes)}, {logged} with a log (see one: "
        "nao-arena replay LOG; explain its contact K: nao-arena explain LOG --contact K)"
    ]
    head = ["map", "agent", "episode", "contacts", "first s", "log"]
    body = [
        [
            str(e["map"]),
            str(e["agent"]),
            str(e["episode"]),
            str(e["contacts"]),
            f"{e['first']:.1f}",
            e["log"] or "none (run the trial again with --log contacts)",
        ]
        for e in episodes[:MAX_LISTED]
    ]
    widths = [max(len(r[i]) for r in [head, *body]) for i in range(len(head) - 1)]
    for row in [head, *body]:
        cells = [
            c.ljust(w) if i < 2 else c.rjust(w)
            for i, (c, w) in enumerate(zip(row[:-1], widths, strict=True))
        ]
        lines.append("  " + "  ".join([*cells, row[-1]]))
    if len(episodes) > MAX_LISTED:
        lines.append(
            f"  ... and {len(episodes) - MAX_LISTED} more (collisions.parquet, "
            "columns episode and log)"
        )
    return "\n".join(lines)


def rate_label(row: Mapping[str, Any] | None) -> str:
    """A collision-rate bar's label: ``collided/robots`` (robot-episodes), "-" if none."""
    if row is None or row.get("collision_rate") is None:
        return "-"
    collided = row.get("robots_collided")
    if collided is None:  # a summary written before the counts were recorded
        collided = round(row["collision_rate"] * row["robots"])
    return f"{collided}/{row['robots']}"


def _driven(row: Mapping[str, Any]) -> float:
    """Time driven by a robot-episode (s): until its goal, else the whole episode."""
    if row.get("reached_goal") and row.get("time_to_goal") is not None:
        return float(row["time_to_goal"])
    return float(row["duration"])


def adjustment_rate_ci95(
    rows: Sequence[Mapping[str, Any]], repeats: float = 1.0
) -> tuple[float, float, float] | None:
    """(rate, low, high) of adjustments per second driven (1/s) over robot-episodes ``rows``
    (``episodes.parquet`` rows of one map x agent, failed episodes left out): the rate is
    sum(adjustments) / sum(time driven), as in ``summary.json``; the interval is the rate
    +- 1.96 standard errors of that ratio (delta method) with the episodes as clusters, the
    robots of one episode not being independent, clipped at 0 (a normal approximation:
    optimistic for a handful of episodes). repeats: completed / distinct episodes (>= 1),
    which scales the variance as exact repeats add no information. None: no time driven,
    or fewer than two episodes."""
    per_episode: dict[Any, list[float]] = {}
    for r in rows:
        if r.get("error") is not None or r.get("adjustments") is None:
            continue
        acc = per_episode.setdefault(r["episode"], [0.0, 0.0])
        acc[0] += r["adjustments"]
        acc[1] += _driven(r)
    n = len(per_episode)
    a = np.array([v[0] for v in per_episode.values()])
    d = np.array([v[1] for v in per_episode.values()])
    if n < 2 or d.sum() <= 0:
        return None
    rate = float(a.sum() / d.sum())
    var = n / (n - 1) * float(np.sum((a - rate * d) ** 2)) / float(d.sum()) ** 2
    half = 1.96 * math.sqrt(var * max(repeats, 1.0))
    return rate, max(rate - half, 0.0), rate + half


def _ordered(values: Sequence[str]) -> list[str]:
    return list(dict.fromkeys(values))


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    atomic_write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    return path


def _grid(n_maps: int, width: float = 5.0, height: float = 3.6) -> tuple[Figure, list[Axes]]:
    cols = min(n_maps, 3)
    rows = -(-n_maps // cols)
    fig = Figure(figsize=(width * cols, height * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False).ravel().tolist()
    for ax in axes[n_maps:]:
        ax.set_visible(False)
    return fig, axes[:n_maps]


def _rates(
    summary: Sequence[Mapping[str, Any]],
    robot_rows: Sequence[Mapping[str, Any]],
    maps: list[str],
    agents: list[str],
) -> Figure:
    fig_w = max(7.0, 1.1 * len(agents) * len(maps) + 3)
    fig = Figure(figsize=(fig_w, 4.6), layout="constrained")
    ax_c, ax_a = fig.subplots(1, 2)
    cell = {(r["map"], r["agent"]): r for r in summary}
    width = 0.8 / len(maps)
    x = np.arange(len(agents))
    colors = [f"C{k % 10}" for k in range(len(maps))]
    for k, m in enumerate(maps):
        pos = x - 0.4 + width * (k + 0.5)
        cells = [cell.get((m, a)) for a in agents]
        rate = np.array(
            [
                np.nan if r is None or r["collision_rate"] is None else r["collision_rate"]
                for r in cells
            ]
        )
        lo = np.array(
            [
                np.nan
                if r is None or r["collision_rate_ci95"] is None
                else r["collision_rate_ci95"][0]
                for r in cells
            ]
        )
        hi = np.array(
            [
                np.nan
                if r is None or r["collision_rate_ci95"] is None
                else r["collision_rate_ci95"][1]
                for r in cells
            ]
        )
        err = np.vstack([np.nan_to_num(rate - lo), np.nan_to_num(hi - rate)])
        bars = ax_c.bar(
            pos,
            np.nan_to_num(rate),
            width,
            yerr=err,
            capsize=3,
            color=colors[k],
            label=m,
            error_kw={"elinewidth": 1, "alpha": 0.7},
        )
        ax_c.bar_label(bars, labels=[rate_label(r) for r in cells], fontsize="x-small", padding=2)
        adj = np.array(
            [
                np.nan if r is None or r["adjustments_per_s"] is None else r["adjustments_per_s"]
                for r in cells
            ]
        )
        ci = [_adjustment_ci(robot_rows, r, m, a) for r, a in zip(cells, agents, strict=True)]
        err = np.array(
            [
                [0.0, 0.0] if c is None or v != v else [v - c[1], c[2] - v]
                for c, v in zip(ci, adj, strict=True)
            ]
        ).T
        bars = ax_a.bar(
            pos,
            np.nan_to_num(adj),
            width,
            yerr=np.maximum(err, 0.0),
            capsize=3,
            color=colors[k],
            label=m,
            error_kw={"elinewidth": 1, "alpha": 0.7},
        )
        ax_a.bar_label(
            bars, labels=["-" if v != v else f"{v:.1f}" for v in adj], fontsize="x-small", padding=2
        )
    ax_c.set_ylim(0.0, 1.12)
    ax_c.set_ylabel("share of robot-episodes with a collision")
    ax_c.set_title("Collision rate (95% Wilson interval)")
    ax_a.set_ylabel("adjustments per second driven (1/s)")
    ax_a.set_title("Acceleration adjustments (95% interval)")
    _agent_axes(fig, (ax_c, ax_a), agents, maps)
    chars = int(fig_w * 110 / 7)  # about 7 px per character at the caption's size
    fig.supxlabel(
        "\n".join(textwrap.wrap(ADJUSTMENT_CAPTION, chars)), fontsize="small", color="0.25"
    )
    return fig


def _adjustment_ci(
    robot_rows: Sequence[Mapping[str, Any]], cell: Mapping[str, Any] | None, m: str, a: str
) -> tuple[float, float, float] | None:
    """The adjustment rate's interval of one map x agent (see :func:`adjustment_rate_ci95`)."""
    if cell is None:
        return None
    completed = (cell.get("episodes") or 0) - (cell.get("failed_episodes") or 0)
    distinct = cell.get("distinct_episodes") or completed
    repeats = completed / distinct if distinct else 1.0
    return adjustment_rate_ci95(
        [r for r in robot_rows if r["map"] == m and r["agent"] == a], repeats
    )


def _column(rows: Sequence[Mapping[str, Any]], m: str, a: str, name: str) -> list[Any]:
    return [r[name] for r in rows if r["map"] == m and r["agent"] == a and r["error"] is None]


def _time_to_goal(rows: Sequence[Mapping[str, Any]], maps: list[str], agents: list[str]) -> Figure:
    fig, axes = _grid(len(maps))
    for ax, m in zip(axes, maps, strict=True):
        data, labels = [], []
        for a in agents:
            reached = _column(rows, m, a, "reached_goal")
            times = [
                t
                for t, ok in zip(_column(rows, m, a, "time_to_goal"), reached, strict=True)
                if ok and t is not None
            ]
            data.append(times)
            share = f"{len(times)}/{len(reached)}" if reached else "0/0"
            labels.append(f"{a}\n{share}")
        positions = np.arange(1, len(agents) + 1)
        filled = [k for k, d in enumerate(data) if d]
        if filled:
            ax.boxplot(
                [data[k] for k in filled],
                positions=positions[filled],
                widths=0.6,
                showmeans=True,
                meanprops={"markersize": 5},
            )
        for k, d in enumerate(data):
            if not d:
                ax.text(
                    positions[k],
                    0.5,
                    "none arrived",
                    ha="center",
                    va="center",
                    rotation=90,
                    fontsize="small",
                    transform=ax.get_xaxis_transform(),
                    color="0.4",
                )
        ax.set_xticks(positions, labels, fontsize="small")
        ax.set_xlim(0.4, len(agents) + 0.6)
        ax.set_xlabel("agent, and its robot-episodes that arrived / all")
        ax.set_ylabel("time to goal (s)")
        ax.set_title(m)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Time to goal (robot-episodes that arrived; box: quartiles, triangle: mean)")
    _turn_overlapping_ticks(fig, axes)
    return fig


def _overlapping(boxes: Sequence[Any]) -> bool:
    """Whether any two of the display-space boxes overlap."""
    return any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1 :])


def _turn_overlapping_ticks(fig: Figure, axes: Sequence[Axes]) -> None:
    """Turn the x tick labels of axes whose labels overlap (long agent names) by 30 deg."""
    canvas = FigureCanvasAgg(fig)  # now fig.canvas
    fig.draw_without_rendering()
    renderer = canvas.get_renderer()
    for ax in axes:
        ticks = [t for t in ax.get_xticklabels() if t.get_text()]
        if _overlapping([t.get_window_extent(renderer) for t in ticks]):
            for t in ticks:
                t.set_rotation(30)
                t.set_horizontalalignment("right")
                t.set_rotation_mode("anchor")


@dataclass(frozen=True)
class _Histograms:
    """What :func:`_histograms` plots: the per-robot ``column`` of the robot-episodes that
    ``keep`` selects (all by default), a null value meaning never within range."""

    column: str
    xlabel: str
    title: str
    keep: Callable[[Mapping[str, Any]], bool] = lambda row: True


MIN_SEPARATION = _Histograms(
    "min_separation",
    "minimum separation (m); < 0: contact",
    "Minimum separation per robot-episode (count of robot-episodes per bin)",
)
PEOPLE_DISTANCE = _Histograms(
    "min_person_distance",
    "closest approach to a person (m, surface to surface); < 0: contact",
    "Closest approach to a person per robot-episode among people (count of robot-episodes per bin)",
    keep=lambda row: bool(row.get("among_people")),
)


def _histograms(
    rows: Sequence[Mapping[str, Any]], maps: list[str], agents: list[str], what: _Histograms
) -> Figure:
    """Small multiples: one histogram per agent (rows) and map (columns) of the column
    ``what`` names, with a line at 0 (contact) and, per panel, the robot-episodes, those
    below 0 and those never within range (a null value, also NaN)."""
    rows = [r for r in rows if what.keep(r)]
    fig = Figure(figsize=(4.6 * len(maps) + 0.6, 1.5 * len(agents) + 1.0), layout="constrained")
    axes = fig.subplots(len(agents), len(maps), squeeze=False, sharex="col")
    for col, m in enumerate(maps):
        per_agent = {a: _column(rows, m, a, what.column) for a in agents}
        finite = [v for vals in per_agent.values() for v in vals if _within(v)]
        lo = min([*finite, 0.0])
        hi = max([*finite, 0.0])
        pad = 0.05 * (hi - lo) or 0.05
        bins = np.linspace(lo - pad, hi + pad, 41)
        for row, a in enumerate(agents):
            ax = axes[row, col]
            vals = [v for v in per_agent[a] if _within(v)]
            far = len(per_agent[a]) - len(vals)
            top = 1.0
            if vals:
                counts, _, _ = ax.hist(vals, bins=bins, color=f"C{row % 10}", alpha=0.85)
                top = max(float(np.max(counts)), 1.0)
            ax.set_ylim(0.0, 1.4 * top)
            contact = sum(v < 0.0 for v in vals)
            note = f"{len(per_agent[a])} robot-episodes, {contact} with contact"
            if far:
                note += f", {far} never within range"
            ax.text(
                0.98, 0.92, note, ha="right", va="top", fontsize="small", transform=ax.transAxes
            )
            ax.axvline(0.0, color="k", linestyle="--", linewidth=1)
            ax.yaxis.get_major_locator().set_params(integer=True)
            ax.grid(alpha=0.3)
            if col == 0:
                ax.set_ylabel(a, rotation=0, ha="right", va="center", fontsize="medium")
            if row == 0:
                ax.set_title(m)
        axes[-1, col].set_xlabel(what.xlabel)
    # wrapped to the figure's width (about 10 characters per inch at the title's size)
    fig.suptitle(textwrap.fill(what.title, width=int(10 * fig.get_figwidth())))
    return fig


def _within(value: Any) -> bool:
    """A measured distance (not null, not NaN: the robot came within range)."""
    return value is not None and value == value


def write_report(folder: str | Path, out: str | Path | None = None) -> list[Path]:
    """Write the report's PNGs (:data:`REPORT_FILES`) for the results in ``folder``
    into ``out`` (default: ``folder``); returns their paths."""
    folder = Path(folder)
    out = Path(out) if out is not None else folder
    out.mkdir(parents=True, exist_ok=True)
    summary = load_summary(folder)
    table = folder / "episodes.parquet"
    if not table.is_file():
        raise FileNotFoundError(f"{table}: no such file (is {folder} a trial's output folder?)")
    rows = pq.read_table(table).to_pylist()
    if not summary:
        raise ValueError(f"{folder / 'summary.json'}: no results to plot")
    maps = _ordered([r["map"] for r in summary])
    agents = _ordered([r["agent"] for r in summary])
    written = [
        _save(_rates(summary, rows, maps, agents), out / REPORT_FILES[0]),
        _save(_time_to_goal(rows, maps, agents), out / REPORT_FILES[1]),
        _save(_histograms(rows, maps, agents, MIN_SEPARATION), out / REPORT_FILES[2]),
    ]
    people = [r for r in summary if r.get("robots_among_people")]
    if people:
        people_maps = _ordered([r["map"] for r in people])
        written.append(_save(_among_people(people, people_maps, agents), out / PEOPLE_FILE))
        written.append(
            _save(
                _histograms(rows, people_maps, agents, PEOPLE_DISTANCE),
                out / PEOPLE_DISTANCE_FILE,
            )
        )
    return written


def _among_people(
    summary: Sequence[Mapping[str, Any]], maps: list[str], agents: list[str]
) -> Figure:
    """Per map and agent: the share of robot-episodes with a robot-caused contact with a
    person (95 % Wilson interval) and the discomfort share (time within the discomfort
    distance of a person over robot time)."""
    fig_w = max(7.0, 1.1 * len(agents) * len(maps) + 3)
    fig = Figure(figsize=(fig_w, 4.4), layout="constrained")
    ax_c, ax_d = fig.subplots(1, 2)
    cell = {(r["map"], r["agent"]): r for r in summary}
    width = 0.8 / len(maps)
    x = np.arange(len(agents))
    for k, m in enumerate(maps):
        pos = x - 0.4 + width * (k + 0.5)
        cells = [cell.get((m, a)) for a in agents]
        counts = [(0, 0) if r is None else _caused(r) for r in cells]
        rate = np.array([c / n if n else np.nan for c, n in counts])
        ci = np.array([wilson_interval(c, n) if n else (np.nan, np.nan) for c, n in counts])
        err = np.vstack([np.nan_to_num(rate - ci[:, 0]), np.nan_to_num(ci[:, 1] - rate)])
        bars = ax_c.bar(
            pos, np.nan_to_num(rate), width, yerr=err, capsize=3, color=f"C{k % 10}", label=m
        )
        ax_c.bar_label(
            bars, labels=[f"{c}/{n}" if n else "-" for c, n in counts], fontsize="x-small"
        )
        share = np.array(
            [
                np.nan if r is None or r["discomfort_share"] is None else r["discomfort_share"]
                for r in cells
            ]
        )
        bars = ax_d.bar(pos, 100.0 * np.nan_to_num(share), width, color=f"C{k % 10}", label=m)
        ax_d.bar_label(
            bars, labels=["-" if v != v else f"{100 * v:.1f}" for v in share], fontsize="x-small"
        )
    ax_c.set_ylim(0.0, 1.12)
    ax_c.set_ylabel("share of robot-episodes")
    ax_c.set_title("Robot-caused contact with a person\n(95% Wilson interval)")
    ax_d.set_ylabel("% of robot time")
    ax_d.set_title("Discomfort:\na person within 0.2 m")
    _agent_axes(fig, (ax_c, ax_d), agents, maps)
    return fig


def _agent_axes(fig: Figure, axes: Sequence[Axes], agents: list[str], maps: list[str]) -> None:
    """Bar charts of agents (x) by map (bars): the agents as ticks, a grid, and the maps
    in the first one's legend (one map: its name as the title)."""
    x = np.arange(len(agents))
    for ax in axes:
        ax.set_xticks(x, agents)
        ax.set_xlabel("agent")
        ax.grid(axis="y", alpha=0.3)
    if len(maps) > 1:
        axes[0].legend(title="map", fontsize="small")
    else:
        fig.suptitle(maps[0])


def _caused(row: Mapping[str, Any]) -> tuple[int, int]:
    """(robot-episodes with a robot-caused contact with a person, robot-episodes among
    people) of a summary row."""
    return int(row["robots_caused_person_contact"]), int(row["robots_among_people"])
