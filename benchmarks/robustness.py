"""How safe each method stays in an imperfect world: every method on the same episodes
under each model of :mod:`nao_arena.imperfection` (and their combination).

For each scene, setting and agent, whole episodes are run for the seeds given; printed
per row: the robot-episodes with a contact involving a robot (of all robot-episodes, with
the 95 % Wilson interval), the contact events, the robot-episodes that succeeded (at
their goals, no contact), the episodes, ``deadlocked``: the robot-episodes (of all
robot-episodes) in which the robot was not at its goal when the episode ended and had no
contact at all (with a robot, person, traffic or wall): it timed out without touching
anything (not the stuck-based ``deadlock_time`` of the episode summary); and
``all at goal (s)``: the median, over the episodes in which every robot reached its
goal, of the time at which the last robot first arrived (s, the largest
:attr:`RobotSummary.time_to_goal`; a robot that arrived and was pushed away later still
counts as arrived), with the number of such episodes of all episodes (``23.4 (18/20)``;
``- (0/20)`` when there is none). Run:

    python benchmarks/robustness.py [--seeds 5] [--agents nao,orca,cbf,goal]
        [--scenes crossing circle_swap_perturbed:n=30 ...]
        [--settings perfect latency=0.1 position=0.05,velocity=0.1 ...]
        [--workers 2] [--markdown] [--json PATH] [--plot DIR]

A scene is a map name with optional parameters (``name:key=value,...``). A setting is
``perfect`` or comma-separated ``key=value`` pairs: ``latency`` (s), ``position`` (m),
``velocity`` (m/s), ``acceleration`` (m/s^2): sensing noise; ``dropout``
(probability); ``fov`` (field of view, degrees); ``occlusion`` (1: on); ``actuation``
(actuation noise, m/s^2); ``lag`` (actuation lag, s); ``comm_range`` (m; 0:
communication off), ``comm_latency`` (s), ``comm_loss`` (probability): the
communication channel (:mod:`nao_arena.communication`).

``--json PATH`` writes every cell's raw counts (written atomically): ``{"seeds": S,
"cells": [{"scene", "setting", "agent", "episodes": [{"seed", "robots",
"robots_with_contact", "contact_events", "succeeded", "deadlocked",
"all_at_goal_time"}, ...]}, ...]}``, one entry per seed 0 .. S - 1; the counts are
robot-episodes (``contact_events``: contact events involving a robot) and
``all_at_goal_time`` is the time (s) at which the last robot first arrived, null unless
every robot reached its goal.

``--plot DIR`` writes two PNG figures (atomically) into DIR: ``contact_vs_noise.png``,
the robot-episodes with a contact (%, with the 95 % Wilson interval as error bars)
against the position noise's standard deviation (m), over the settings ``perfect``
(0 m) and ``position=X``; and ``contact_vs_latency.png``, the same against the sensing
latency (s), over ``perfect`` (0 s) and ``latency=X``. One panel per scene, one line
per agent (points of different agents offset a little sideways so that their error bars
stay apart); a figure for which the settings give fewer than two values on its x axis is
skipped, with a line on stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.atomic import atomic_write_text, atomic_write_with
from nao_arena.maps import load_map
from nao_arena.trials.results import wilson_interval

DEFAULT_SETTINGS = (
    "perfect",
    "position=0.05",
    "velocity=0.1",
    "latency=0.1",
    "latency=0.2",
    "dropout=0.2",
    "fov=120",
    "occlusion=1",
    "actuation=0.3",
    "lag=0.1",
    "position=0.05,velocity=0.1,latency=0.1",
)
NOISE_KEYS = {"position", "velocity", "acceleration"}

Cell = tuple[str, str, str]
"""(scene, setting, agent)."""

FIGURES = (
    ("contact_vs_noise.png", "position", "position noise σ (m)"),
    ("contact_vs_latency.png", "latency", "sensing latency (s)"),
)
"""(file name, the setting key on the x axis, the x axis' label) of the ``--plot`` figures."""


def options(setting: str) -> dict[str, Any]:
    """The :class:`ArenaOptions` keyword arguments of a setting (see the module)."""
    if setting == "perfect":
        return {}
    out: dict[str, Any] = {}
    noise: dict[str, float] = {}
    for pair in setting.split(","):
        key, _, text = pair.partition("=")
        value = float(text)
        if key in NOISE_KEYS:
            noise[key] = value
        elif key == "latency":
            out["sensing_latency"] = value
        elif key == "dropout":
            out["sensing_dropout"] = value
        elif key == "fov":
            out["sensing_field_of_view"] = math.radians(value)
        elif key == "occlusion":
            out["sensing_occlusion"] = bool(value)
        elif key == "actuation":
            out["actuation_noise"] = value
        elif key == "lag":
            out["actuation_lag"] = value
        elif key in ("comm_range", "comm_latency", "comm_loss"):
            out["communication_" + key.removeprefix("comm_")] = value
        else:
            raise SystemExit(f"robustness.py: unknown setting key {key!r} in {setting!r}")
    if noise:
        out["sensing_noise"] = noise
    return out


def scene_parameters(scene: str) -> tuple[str, dict[str, Any]]:
    """(map name, parameters) of ``name:key=value,...``; values as YAML numbers."""
    name, _, rest = scene.partition(":")
    params: dict[str, Any] = {}
    for pair in filter(None, rest.split(",")):
        key, _, text = pair.partition("=")
        params[key] = float(text) if "." in text else int(text)
    return name, params


@dataclass(frozen=True)
class Tally:
    """One episode's counts: robots with a contact involving a robot, such contact
    events, robots that succeeded, robots; robots deadlocked (not at their goals at the
    end, no contact of any kind) and the time (s) at which the last robot first arrived
    (None unless every robot reached its goal)."""

    hit: int
    events: int
    succeeded: int
    robots: int
    deadlocked: int = 0
    all_at_goal: float | None = None


def episode(scene: str, setting: str, agent: str, seed: int) -> Tally:
    """Run one episode and count it."""
    name, params = scene_parameters(scene)
    if "seed" in load_map(name, **params).parameters:
        params = {**params, "seed": seed}
    arena = Arena(load_map(name, **params), ArenaOptions(agent=agent, **options(setting)))
    summary = arena.run(seed)
    robot_bodies = {int(b) for b in arena.robot_ids}
    touched: set[int] = set()
    events = 0
    for c in summary.contacts:
        if "robot" in (c.kind_a, c.kind_b):
            events += 1
            touched |= {
                x for x, kind in ((c.a, c.kind_a), (c.b, c.kind_b)) if kind == "robot"
            } & robot_bodies
    # every contact event of a robot involves a robot, so touched holds every robot body
    # with a contact of any kind (a is always a body; b is a wall's index for a wall)
    deadlocked = sum(not r.at_goal_at_end and r.index not in touched for r in summary.robots)
    arrived = bool(summary.robots) and all(r.reached_goal for r in summary.robots)
    return Tally(
        len(touched),
        events,
        sum(r.success for r in summary.robots),
        len(summary.robots),
        deadlocked,
        max(r.time_to_goal for r in summary.robots) if arrived else None,
    )


def _run(task: tuple[str, str, str, int]) -> Tally:
    return episode(*task)


def run_cells(
    scenes: Sequence[str],
    settings: Sequence[str],
    agents: Sequence[str],
    seeds: int,
    workers: int,
) -> dict[Cell, list[Tally]]:
    """Every scene, setting and agent (in that order) over seeds 0 .. seeds - 1: each
    cell's tallies, in seed order."""
    cells = [(sc, se, a) for sc in scenes for se in settings for a in agents]
    tasks = [(sc, se, a, seed) for sc, se, a in cells for seed in range(seeds)]
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            tallies = list(pool.map(_run, tasks, chunksize=1))
    else:
        tallies = [_run(t) for t in tasks]
    per_cell: dict[Cell, list[Tally]] = {c: [] for c in cells}
    for (sc, se, a, _), t in zip(tasks, tallies, strict=True):
        per_cell[(sc, se, a)].append(t)
    return per_cell


def _all_at_goal(ts: Sequence[Tally]) -> str:
    """``median (k/episodes)`` of the times (s) of the episodes in which every robot
    reached its goal; ``- (0/episodes)`` if none did."""
    times = [t.all_at_goal for t in ts if t.all_at_goal is not None]
    median = f"{statistics.median(times):.1f}" if times else "-"
    return f"{median} ({len(times)}/{len(ts)})"


def rows_of(per_cell: Mapping[Cell, Sequence[Tally]]) -> list[list[str]]:
    """The table's rows (header first) of :func:`run_cells`' tallies."""
    rows = [
        [
            "scene",
            "setting",
            "agent",
            "robot-episodes with a contact",
            "contacts",
            "succeeded",
            "episodes",
            "deadlocked",
            "all at goal (s)",
        ]
    ]
    for (sc, se, a), ts in per_cell.items():
        hit, robots = sum(t.hit for t in ts), sum(t.robots for t in ts)
        lo, hi = wilson_interval(hit, robots)
        rows.append(
            [
                sc,
                se,
                a,
                f"{hit}/{robots} [{100 * lo:.1f}, {100 * hi:.1f}] %",
                str(sum(t.events for t in ts)),
                f"{sum(t.succeeded for t in ts)}/{robots}",
                str(len(ts)),
                f"{sum(t.deadlocked for t in ts)}/{robots}",
                _all_at_goal(ts),
            ]
        )
    return rows


def table(
    scenes: Sequence[str],
    settings: Sequence[str],
    agents: Sequence[str],
    seeds: int,
    workers: int,
) -> list[list[str]]:
    """The rows (header first): every scene, setting and agent over seeds 0 .. seeds - 1."""
    return rows_of(run_cells(scenes, settings, agents, seeds, workers))


def write_json(path: str | Path, per_cell: Mapping[Cell, Sequence[Tally]], seeds: int) -> None:
    """Every cell's raw counts, per seed, as JSON at path (atomically; see the module)."""
    doc = {
        "seeds": seeds,
        "cells": [
            {
                "scene": sc,
                "setting": se,
                "agent": a,
                "episodes": [
                    {
                        "seed": seed,
                        "robots": t.robots,
                        "robots_with_contact": t.hit,
                        "contact_events": t.events,
                        "succeeded": t.succeeded,
                        "deadlocked": t.deadlocked,
                        "all_at_goal_time": t.all_at_goal,
                    }
                    for seed, t in enumerate(ts)
                ],
            }
            for (sc, se, a), ts in per_cell.items()
        ],
    }
    atomic_write_text(path, json.dumps(doc, indent=2, allow_nan=False) + "\n")


def sweep_value(setting: str, key: str) -> float | None:
    """The x value of setting on a figure over ``key``: 0 for ``perfect``, X for
    ``key=X`` alone, None for any other setting."""
    if setting == "perfect":
        return 0.0
    name, sep, text = setting.partition("=")
    if name != key or not sep or "," in text:
        return None
    return float(text)


def plot(
    folder: str | Path,
    per_cell: Mapping[Cell, Sequence[Tally]],
    scenes: Sequence[str],
    settings: Sequence[str],
    agents: Sequence[str],
) -> list[Path]:
    """Write the ``--plot`` figures (see the module) into folder; returns the paths
    written. A figure with fewer than two x values is skipped, with a line on stderr."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    written: list[Path] = []
    for file_name, key, x_label in FIGURES:
        xs: dict[float, str] = {}  # x value -> its setting (the first one of a value)
        for se in settings:
            x = sweep_value(se, key)
            if x is not None and x not in xs:
                xs[x] = se
        if len(xs) < 2:
            print(
                f"robustness.py: {file_name} skipped: the settings give {len(xs)} "
                f"{key} value(s), it needs 2 (perfect or {key}=X)",
                file=sys.stderr,
            )
            continue
        order = sorted(xs)
        span = order[-1] - order[0]
        ncols = 2 if len(scenes) == 4 else min(len(scenes), 3)
        nrows = math.ceil(len(scenes) / ncols)
        fig = Figure(
            figsize=(max(6.4, 5.2 * ncols), 4.2 * nrows + 0.6), dpi=110, layout="constrained"
        )
        FigureCanvasAgg(fig)
        axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
        for ax, sc in zip(axes, scenes, strict=False):
            counts: set[int] = set()
            for j, a in enumerate(agents):
                shift = (j - (len(agents) - 1) / 2) * 0.012 * span
                ys, lows, highs = [], [], []
                for x in order:
                    ts = per_cell[(sc, xs[x], a)]
                    hit, robots = sum(t.hit for t in ts), sum(t.robots for t in ts)
                    counts.add(robots)
                    lo, hi = wilson_interval(hit, robots)
                    share = 100 * hit / robots if robots else math.nan
                    ys.append(share)
                    lows.append(share - 100 * lo)
                    highs.append(100 * hi - share)
                ax.errorbar(
                    [x + shift for x in order],
                    ys,
                    yerr=[lows, highs],
                    marker="o",
                    markersize=4,
                    capsize=3,
                    label=a,
                )
            n = "-".join(str(c) for c in sorted(counts))
            ax.set_title(f"{sc}\nn = {n} robot-episodes per point", fontsize=10)
            ax.set_xlabel(x_label)
            ax.set_ylabel("robot-episodes with a contact (%)")
            ax.set_xticks(order)
            ax.set_ylim(-3.0, 103.0)
            ax.grid(True, alpha=0.3)
        for ax in axes[len(scenes) :]:
            ax.set_visible(False)
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, title="agent", loc="outside lower center", ncols=len(agents))
        fig.suptitle(
            f"Robot-episodes with a contact vs {x_label}\n"
            "error bars: 95 % Wilson intervals; agents' points offset a little sideways",
            fontsize=10,
        )
        path = Path(folder) / file_name

        def write_png(tmp: str, fig: Figure = fig) -> None:
            fig.savefig(tmp, format="png")

        atomic_write_with(path, write_png, suffix=".png")
        written.append(path)
    return written


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--agents", default="nao,orca,cbf,goal")
    parser.add_argument("--scenes", nargs="+", default=["crossing", "circle_swap_perturbed:n=30"])
    parser.add_argument("--settings", nargs="+", default=list(DEFAULT_SETTINGS))
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--markdown", action="store_true", help="print a markdown table")
    parser.add_argument("--json", metavar="PATH", help="write every cell's raw counts as JSON")
    parser.add_argument(
        "--plot", metavar="DIR", help="write contact_vs_noise.png and contact_vs_latency.png"
    )
    args = parser.parse_args(argv)
    for setting in args.settings:
        options(setting)  # a bad setting stops here, before any episode
    agents = args.agents.split(",")
    per_cell = run_cells(args.scenes, args.settings, agents, args.seeds, args.workers)
    rows = rows_of(per_cell)
    if args.json:
        write_json(args.json, per_cell, args.seeds)
    if args.plot:
        plot(args.plot, per_cell, args.scenes, args.settings, agents)
    if args.markdown:
        print("| " + " | ".join(rows[0]) + " |")
        print("|" + " --- |" * len(rows[0]))
        for r in rows[1:]:
            print("| " + " | ".join(r) + " |")
        return
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip())


if __name__ == "__main__":
    main()
