"""All-NAO circle swap: simulated seconds per wall-clock second.

Baseline measured in the same run: the same world stepped with the
goal-seeking agent (no avoidance), so the ratio shows what NAO avoidance
costs on top of sensing, physics and statistics. Run:

    python benchmarks/bench_agents.py [--sizes 10,30,100] [--steps 100] [--skip 0]

``--skip N`` runs N control steps before the timing starts (e.g. 150 with 100
robots times the crowded middle of the swap instead of the approach).
"""

from __future__ import annotations

import argparse
import time

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map


def sim_rate(n: int, agent: str, steps: int, skip: int = 0) -> tuple[float, float]:
    """(simulated s per wall s, wall us per agent-step) over ``steps`` control steps,
    timed after ``skip`` untimed ones."""
    radius = max(8.0, 0.35 * n)
    bound = radius + 4.0
    spec = load_map("circle_swap", n=n, radius=radius, lo=-bound, hi=bound)
    arena = Arena(spec, ArenaOptions(agent=agent))
    arena.reset(0)
    arena.step()  # warm-up: compilation and caches outside the timing
    for _ in range(skip):
        if not arena.done:
            arena.step()
    start = time.perf_counter()
    done = 0
    while done < steps and not arena.done:
        arena.step()
        done += 1
    wall = time.perf_counter() - start
    if done == 0:
        return float("nan"), float("nan")
    return done * arena.world.dt / wall, 1e6 * wall / (done * n)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", default="10,30,100")
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--skip", type=int, default=0, help="untimed steps first")
    args = parser.parse_args()
    print(f"{'robots':>6} {'nao x real time':>16} {'us/agent-step':>14} "
          f"{'goal x real time':>17} {'nao cost / goal':>16}")
    for n in (int(s) for s in args.sizes.split(",")):
        nao_rate, nao_us = sim_rate(n, "nao", args.steps, args.skip)
        goal_rate, _ = sim_rate(n, "goal", args.steps, args.skip)
        print(f"{n:>6} {nao_rate:>16.2f} {nao_us:>14.0f} {goal_rate:>17.1f} "
              f"{goal_rate / nao_rate:>16.1f}")


if __name__ == "__main__":
    main()
