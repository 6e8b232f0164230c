"""How safe each method stays in an imperfect world: every method on the same episodes
under each model of :mod:`nao_arena.imperfection` (and their combination).

For each scene, setting and agent, whole episodes are run for the seeds given; printed
per row: the robot-episodes with a contact involving a robot (of all robot-episodes, with
the 95 % Wilson interval), the contact events, the robot-episodes that succeeded (at
their goals, no contact) and the episodes. Run:

    python benchmarks/robustness.py [--seeds 5] [--agents nao,orca,cbf,goal]
        [--scenes crossing circle_swap_perturbed:n=30 ...]
        [--settings perfect latency=0.1 position=0.05,velocity=0.1 ...]
        [--workers 2] [--markdown]

A scene is a map name with optional parameters (``name:key=value,...``). A setting is
``perfect`` or comma-separated ``key=value`` pairs: ``latency`` (s), ``position`` (m),
``velocity`` (m/s), ``acceleration`` (m/s^2): sensing noise; ``dropout``
(probability); ``fov`` (field of view, degrees); ``occlusion`` (1: on); ``actuation``
(actuation noise, m/s^2); ``lag`` (actuation lag, s).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

from nao_arena.arena import Arena, ArenaOptions
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
    events, robots that succeeded, robots."""

    hit: int
    events: int
    succeeded: int
    robots: int


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
    return Tally(len(touched), events, sum(r.success for r in summary.robots), len(summary.robots))


def _run(task: tuple[str, str, str, int]) -> Tally:
    return episode(*task)


def table(
    scenes: Sequence[str],
    settings: Sequence[str],
    agents: Sequence[str],
    seeds: int,
    workers: int,
) -> list[list[str]]:
    """The rows (header first): every scene, setting and agent over seeds 0 .. seeds - 1."""
    cells = [(sc, se, a) for sc in scenes for se in settings for a in agents]
    tasks = [(sc, se, a, seed) for sc, se, a in cells for seed in range(seeds)]
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            tallies = list(pool.map(_run, tasks, chunksize=1))
    else:
        tallies = [_run(t) for t in tasks]
    per_cell: Mapping[tuple[str, str, str], list[Tally]] = {c: [] for c in cells}
    for (sc, se, a, _), t in zip(tasks, tallies, strict=True):
        per_cell[(sc, se, a)].append(t)
    rows = [
        [
            "scene",
            "setting",
            "agent",
            "robot-episodes with a contact",
            "contacts",
            "succeeded",
            "episodes",
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
            ]
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--agents", default="nao,orca,cbf,goal")
    parser.add_argument("--scenes", nargs="+", default=["crossing", "circle_swap_perturbed:n=30"])
    parser.add_argument("--settings", nargs="+", default=list(DEFAULT_SETTINGS))
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--markdown", action="store_true", help="print a markdown table")
    args = parser.parse_args()
    for setting in args.settings:
        options(setting)  # a bad setting stops here, before any episode
    rows = table(args.scenes, args.settings, args.agents.split(","), args.seeds, args.workers)
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
