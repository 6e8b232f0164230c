"""All-NAO circle swap: simulated seconds per wall-clock second.

Baseline measured in the same run: the same world stepped with the
goal-seeking agent (no avoidance), so the ratio shows what NAO avoidance
costs on top of sensing, physics and statistics. Run:

    python benchmarks/bench_agents.py [--sizes 10,30,100] [--steps 100] [--skip 0]
    python benchmarks/bench_agents.py --whole [--sizes 10,30,100]

``--skip N`` runs N control steps before the timing starts (e.g. 150 with 100
robots times the crowded middle of the swap instead of the approach).
``--whole`` times whole episodes instead (until every robot has arrived, time
limit 150 s) and also prints their contacts and arrivals: the crowded middle
is what costs most.
"""

from __future__ import annotations

import argparse
import time

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map


def swap_arena(n: int, agent: str, time_limit: float | None = None) -> Arena:
    """Circle swap of n robots on a circle of radius max(8, 0.35 n) m."""
    radius = max(8.0, 0.35 * n)
    bound = radius + 4.0
    spec = load_map("circle_swap", n=n, radius=radius, lo=-bound, hi=bound)
    if time_limit is not None:
        spec = spec.model_copy(
            update={"episode": spec.episode.model_copy(update={"time_limit": time_limit})})
    return Arena(spec, ArenaOptions(agent=agent))


def sim_rate(n: int, agent: str, steps: int, skip: int = 0) -> tuple[float, float]:
    """(simulated s per wall s, wall us per agent-step) over ``steps`` control steps,
    timed after ``skip`` untimed ones."""
    arena = swap_arena(n, agent)
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


def whole_episode(n: int, agent: str) -> tuple[float, float, float, int, int]:
    """(simulated s per wall s, wall us per agent-step, episode duration s, contacts,
    robots arrived) over one whole episode (seed 0), the first step untimed."""
    arena = swap_arena(n, agent, time_limit=150.0)
    arena.reset(0)
    arena.step()  # warm-up: compilation and caches outside the timing
    start = time.perf_counter()
    steps = 0
    while not arena.done:
        arena.step()
        steps += 1
    wall = time.perf_counter() - start
    summary = arena.summary()
    arrived = sum(r.reached_goal for r in summary.robots)
    return (steps * arena.world.dt / wall, 1e6 * wall / max(steps * n, 1), arena.time,
            len(summary.contacts), arrived)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", default="10,30,100")
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--skip", type=int, default=0, help="untimed steps first")
    parser.add_argument("--whole", action="store_true", help="time whole episodes")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    if args.whole:
        print(f"{'robots':>6} {'nao x real time':>16} {'us/agent-step':>14} {'episode s':>10} "
              f"{'contacts':>9} {'arrived':>8} {'goal x real time':>17} {'goal contacts':>14}")
        for n in sizes:
            rate, us, duration, contacts, arrived = whole_episode(n, "nao")
            g_rate, _, _, g_contacts, _ = whole_episode(n, "goal")
            print(f"{n:>6} {rate:>16.2f} {us:>14.0f} {duration:>10.1f} {contacts:>9} "
                  f"{arrived:>5}/{n:<2} {g_rate:>17.1f} {g_contacts:>14}")
        return
    print(f"{'robots':>6} {'nao x real time':>16} {'us/agent-step':>14} "
          f"{'goal x real time':>17} {'nao cost / goal':>16}")
    for n in sizes:
        nao_rate, nao_us = sim_rate(n, "nao", args.steps, args.skip)
        goal_rate, _ = sim_rate(n, "goal", args.steps, args.skip)
        print(f"{n:>6} {nao_rate:>16.2f} {nao_us:>14.0f} {goal_rate:>17.1f} "
              f"{goal_rate / nao_rate:>16.1f}")


if __name__ == "__main__":
    main()
