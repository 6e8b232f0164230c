"""Dense crowds: wall time of the whole arena step per agent-step, by agent.

Scenes: dense_swap_perturbed with n robots (``--sizes``; the circle has radius
R = max(10, 1.1 n / pi) m, the bounds are lo/hi = -(R + 10), R + 10 m) and
crossing_streams_perturbed with n robots per stream (``--streams``). Every
robot runs the same agent (``--agents``: built-in names or plug-in
references, optionally ``label=reference``; the default nao, orca, goal).

For each scene and agent, in one process: one untimed step (compilation and
caches), then a fresh episode from the same seed, each step timed (sensing,
agents, physics, statistics) for its first ``--seconds`` simulated seconds or
until it ends. Printed per row: the steps timed, the mean wall time per
agent-step (us: total / (steps x robots)), the worst window of ``--window``
simulated seconds (the largest sum of wall time over that many consecutive
steps / (steps x robots); the whole run if shorter), whether the episode
ended (every robot at its goal) and, where ``goal`` is among the agents, both
figures over those of ``goal`` in the same run (goal seeking: no avoidance, so
the ratio is what avoidance costs on top of the rest of the step). Run:

    python benchmarks/bench_crowds.py [--sizes 100,300] [--streams 20] [--seconds 60]
        [--agents nao,orca,goal] [--seed 0] [--window 10]

``--sizes ''`` or ``--streams ''`` leaves that map out.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import numpy as np

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import MapSpec, load_map


@dataclass(frozen=True)
class Row:
    """One scene and agent: steps timed, robots, mean and worst-window wall time per
    agent-step (us), whether the episode ended."""

    scene: str
    agent: str
    robots: int
    steps: int
    mean_us: float
    worst_us: float
    ended: bool


def swap_spec(n: int) -> MapSpec:
    """dense_swap_perturbed with n robots, bounds R + 10 m around its circle of radius R."""
    bound = max(10.0, 1.1 * n / math.pi) + 10.0
    return load_map("dense_swap_perturbed", n=n, lo=-bound, hi=bound)


def time_episode(spec: MapSpec, agent: str, seed: int, seconds: float,
                 window: float) -> tuple[int, int, float, float, bool]:
    """(steps, robots, mean us, worst-window us per agent-step, ended) of the first
    ``seconds`` simulated seconds of an episode, after one untimed warm-up step."""
    arena = Arena(spec, ArenaOptions(agent=agent))
    arena.reset(seed)
    arena.step()  # compilation and caches outside the timing
    arena.reset(seed)
    robots = len(arena.robots)
    limit = max(1, round(seconds / arena.world.dt))
    walls: list[float] = []
    while not arena.done and len(walls) < limit:
        t0 = time.perf_counter()
        arena.step()
        walls.append(time.perf_counter() - t0)
    w = np.array(walls)
    span = min(len(w), max(1, round(window / arena.world.dt)))
    sums = np.convolve(w, np.ones(span), mode="valid")
    per = 1e6 / robots
    return len(w), robots, per * float(w.mean()), per * float(sums.max()) / span, arena.done


def _agents(text: str) -> list[tuple[str, str]]:
    """``label=ref`` or ``ref`` items, comma separated: (label, ref) pairs."""
    out = []
    for item in filter(None, (s.strip() for s in text.split(","))):
        label, _, ref = item.rpartition("=")
        out.append((label or ref, ref))
    return out


def _sizes(text: str) -> list[int]:
    return [int(s) for s in text.split(",") if s.strip()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,300", help="dense swap robot counts")
    parser.add_argument("--streams", default="20", help="crossing streams: robots per stream")
    parser.add_argument("--agents", default="nao,orca,goal")
    parser.add_argument("--seconds", type=float, default=60.0,
                        help="simulated seconds timed per episode (at most)")
    parser.add_argument("--window", type=float, default=10.0,
                        help="simulated seconds of the worst window")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    scenes = [(f"dense_swap_perturbed n={n}", swap_spec(n)) for n in _sizes(args.sizes)]
    scenes += [(f"crossing_streams_perturbed n={n}x2",
                load_map("crossing_streams_perturbed", n=n)) for n in _sizes(args.streams)]
    rows: list[Row] = []
    for scene, spec in scenes:
        for label, ref in _agents(args.agents):
            steps, robots, mean, worst, ended = time_episode(spec, ref, args.seed,
                                                             args.seconds, args.window)
            rows.append(Row(scene, label, robots, steps, mean, worst, ended))
            print(f"# {scene} {label}: {steps} steps, {mean:.1f} us", flush=True)
    header = (f"{'scene':36} {'agent':8} {'robots':>6} {'steps':>6} {'ended':>5} "
              f"{'mean us':>9} {'worst us':>9} {'mean/goal':>9} {'worst/goal':>10}")
    print(header)
    print("-" * len(header))
    for r in rows:
        base = next((b for b in rows if b.scene == r.scene and b.agent == "goal"), None)
        ratio_mean = f"{r.mean_us / base.mean_us:9.2f}" if base else f"{'-':>9}"
        ratio_worst = f"{r.worst_us / base.worst_us:10.2f}" if base else f"{'-':>10}"
        print(f"{r.scene:36} {r.agent:8} {r.robots:6d} {r.steps:6d} {str(r.ended):>5} "
              f"{r.mean_us:9.1f} {r.worst_us:9.1f} {ratio_mean} {ratio_worst}")


if __name__ == "__main__":
    main()
