"""The walled scenes (doorway, intersection, warehouse_aisles, pillar_corridor): what each
agent does on them, seed by seed.

For every scene, its symmetric map (seed 0) and its ``_perturbed`` map on seeds
0 .. ``--seeds`` - 1 are run to the end (every robot within goal_tolerance of its goal
at once, or the map's time limit) with every robot driven by one agent (``--agents``).
Printed per scene: one row per seed, one cell per agent: the time (s) at which every
robot was at its goal at once, or ``timeout k/N`` (k of the N robots at their goals
at the time limit), followed by ``rr`` and ``rw`` counts of robot-robot and
robot-wall contact events where there were any. Then the summary, one row per map and
agent, with the count beside every rate. One process, sequential, at lowered priority
(``nice`` +10). With ``--json FILE`` every episode's outcome is appended to FILE as it
ends and episodes already there (same map, seed, agent and overrides) are not run again:
a long run (``vo`` costs about 0.2 s of wall time per step of these scenes) can be
resumed, or split by agent and printed together. Run:

    python benchmarks/scenes_table.py --seeds 20 [--agents nao,orca,vo,goal]
        [--maps doorway,intersection,warehouse_aisles,pillar_corridor] [--set n=4]
        [--json results/scenes.jsonl]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import parse_overrides
from nao_arena.trials import make_map

SCENES = ("doorway", "intersection", "warehouse_aisles", "pillar_corridor")
AGENTS = ("nao", "orca", "vo", "goal")


@dataclass(frozen=True)
class Outcome:
    """One episode: robots, robots at their goals at the end, whether all were at once
    before the time limit and when (s), contact events robot-robot and robot-wall."""

    robots: int
    at_goal: int
    all_at_goal: bool
    time: float
    robot_contacts: int
    wall_contacts: int
    seconds: float = math.nan

    def cell(self) -> str:
        """The per-seed cell: time or timeout k/N, then the contact counts if any."""
        text = f"{self.time:.1f}" if self.all_at_goal else f"timeout {self.at_goal}/{self.robots}"
        if self.robot_contacts:
            text += f" rr{self.robot_contacts}"
        if self.wall_contacts:
            text += f" rw{self.wall_contacts}"
        return text


def run_episode(name: str, seed: int, agent: str, overrides: dict) -> Outcome:
    """Run map ``name`` (its ``seed`` parameter set if it has one) with ``agent``;
    ``seconds`` is the wall time (s) of the run."""
    start = time.perf_counter()
    arena = Arena(make_map(name, seed, overrides), ArenaOptions(agent=agent))
    summary = arena.run(seed=seed)
    walls = sum(c.kind_b == "wall" for c in summary.contacts)
    robots = sum(c.kind_a == "robot" and c.kind_b == "robot" for c in summary.contacts)
    ended = arena.time < arena.spec.episode.time_limit - 1e-9
    return Outcome(
        len(summary.robots),
        sum(r.at_goal_at_end for r in summary.robots),
        ended,
        arena.time,
        robots,
        walls,
        time.perf_counter() - start,
    )


def _key(name: str, seed: int, agent: str, overrides: dict) -> str:
    return json.dumps([name, seed, agent, overrides], sort_keys=True)


def load_done(path: Path | None) -> dict[str, Outcome]:
    """The episodes already in the JSON-lines file ``path`` (none if absent)."""
    if path is None or not path.exists():
        return {}
    done = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.strip():
            row = json.loads(line)
            done[row["key"]] = Outcome(**row["outcome"])
    return done


def _share(k: int, n: int) -> str:
    return f"{k}/{n} ({100.0 * k / n:.0f} %)" if n else "0/0"


def _times(values: list[float]) -> str:
    if not values:
        return "-"
    lo, hi = min(values), max(values)
    if len(values) == 1:
        return f"{lo:.1f}"
    return f"{lo:.1f}-{hi:.1f} (median {statistics.median(values):.1f})"


def summary_row(name: str, agent: str, runs: list[Outcome]) -> str:
    """A markdown row: episodes; all at their goals at once (count, rate) and when;
    episodes with robot-robot and robot-wall contacts (count, rate, events); timeouts
    and the robots not at their goals then."""
    n = len(runs)
    done = [r.time for r in runs if r.all_at_goal]
    rr = [r.robot_contacts for r in runs]
    rw = [r.wall_contacts for r in runs]
    robots = sum(r.robots for r in runs)
    missing = sum(r.robots - r.at_goal for r in runs if not r.all_at_goal)
    timeouts = n - len(done)
    return (
        f"| `{name}` | {agent} | {n} | {_share(len(done), n)} | {_times(done)} | "
        f"{_share(sum(x > 0 for x in rr), n)}, {sum(rr)} events | "
        f"{_share(sum(x > 0 for x in rw), n)}, {sum(rw)} events | "
        f"{_share(timeouts, n)}; {missing}/{robots} robots not at their goals |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--seeds", type=int, default=20, help="seeds 0 .. SEEDS-1 of each _perturbed map"
    )
    parser.add_argument("--agents", default=",".join(AGENTS))
    parser.add_argument("--maps", default=",".join(SCENES), help="scenes (symmetric names)")
    parser.add_argument(
        "--set",
        nargs="*",
        default=[],
        metavar="KEY=VALUE",
        help="map parameter overrides for every map, e.g. n=4",
    )
    parser.add_argument(
        "--json",
        default=None,
        metavar="FILE",
        help="append each episode's outcome; skip the episodes already there",
    )
    args = parser.parse_args()
    if args.seeds < 1:
        parser.error(f"--seeds: expected a positive number of seeds, got {args.seeds}")
    os.nice(10)
    agents = [a.strip() for a in args.agents.split(",") if a.strip()]
    scenes = [s.strip() for s in args.maps.split(",") if s.strip()]
    overrides = parse_overrides(args.set)
    path = Path(args.json) if args.json else None
    done = load_done(path)
    start = time.perf_counter()
    ran = 0
    results: dict[tuple[str, str], list[Outcome]] = {}
    for scene in scenes:
        cases = [(scene, 0)] + [(f"{scene}_perturbed", s) for s in range(args.seeds)]
        width = max(12, *(len(a) for a in agents))
        print(f"\n{scene} (symmetric: seed 0; perturbed: seeds 0-{args.seeds - 1})")
        print(f"{'map':28} {'seed':>4}  " + "  ".join(f"{a:>{width + 10}}" for a in agents))
        for name, seed in cases:
            cells = []
            for agent in agents:
                key = _key(name, seed, agent, overrides)
                out = done.get(key)
                if out is None:
                    out = run_episode(name, seed, agent, overrides)
                    ran += 1
                    if path is not None:
                        with path.open("a", encoding="utf-8") as f:
                            f.write(json.dumps({"key": key, "outcome": asdict(out)}) + "\n")
                results.setdefault((name, agent), []).append(out)
                cells.append(f"{out.cell():>{width + 10}}")
            print(f"{name:28} {seed:>4}  " + "  ".join(cells), flush=True)
    print()
    print(
        "| map | agent | episodes | all at their goals at once | time until then (s) | "
        "episodes with robot-robot contact | episodes with robot-wall contact | "
        "timed out |"
    )
    print("| --- | --- | ---: | --- | --- | --- | --- | --- |")
    for (name, agent), runs in results.items():
        print(summary_row(name, agent, runs))
    minutes = (time.perf_counter() - start) / 60.0
    print(
        f"\n({ran} episodes run in {math.floor(minutes)} min {60 * (minutes % 1):.0f} s"
        f"{f', {len(done)} read from {path}' if done else ''})"
    )
    walls = {
        agent: [o.seconds for (_, a), runs in results.items() if a == agent for o in runs]
        for agent in agents
    }
    print(
        "wall time per episode (s): "
        + "; ".join(
            f"{agent} median {statistics.median(w):.1f}, max {max(w):.1f}"
            for agent, w in walls.items()
            if w
        )
    )


if __name__ == "__main__":
    main()
