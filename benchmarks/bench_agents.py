"""All-NAO circle swap: simulated seconds per wall-clock second.

Baseline measured in the same run: the same world stepped with the
goal-seeking agent (no avoidance), so the ratio shows what NAO avoidance
costs on top of sensing, physics and statistics. Run:

    python benchmarks/bench_agents.py [--sizes 10,30,100] [--steps 100] [--skip 0]
    python benchmarks/bench_agents.py --whole [--sizes 10,30,100] [--seeds 0,1,2]

``--skip N`` runs N control steps before the timing starts (e.g. 150 with 100
robots times the crowded middle of the swap instead of the approach).
``--whole`` times whole episodes instead (until every robot has arrived, time
limit 150 s) and also prints their contacts and arrivals: the crowded middle
is what costs most. With several ``--seeds`` the rate is total simulated time
over total wall time (a swap's duration varies by a few seconds from seed to
seed, and the crowded part with it). ``--horizon`` sets the NAO agents'
horizon (s; default: the agent's own).
"""

from __future__ import annotations

import argparse
import time

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map


def swap_arena(
    n: int, agent: str, time_limit: float | None = None, horizon: float | None = None
) -> Arena:
    """Circle swap of n robots on a circle of radius max(8, 0.35 n) m; horizon (s): the
    agents' horizon option (None: their default)."""
    radius = max(8.0, 0.35 * n)
    bound = radius + 4.0
    spec = load_map("circle_swap", n=n, radius=radius, lo=-bound, hi=bound)
    if time_limit is not None:
        spec = spec.model_copy(
            update={"episode": spec.episode.model_copy(update={"time_limit": time_limit})}
        )
    options = {} if horizon is None else {"horizon": horizon}
    return Arena(spec, ArenaOptions(agent=agent, agent_options=options))


def sim_rate(
    n: int, agent: str, steps: int, skip: int = 0, horizon: float | None = None
) -> tuple[float, float]:
    """(simulated s per wall s, wall us per agent-step) over ``steps`` control steps,
    timed after ``skip`` untimed ones."""
    arena = swap_arena(n, agent, horizon=horizon)
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


def whole_episode(
    n: int, agent: str, horizon: float | None = None, seed: int = 0
) -> tuple[float, float, float, int, int, int]:
    """(simulated s, wall s, episode duration s, contacts, robots arrived, timed steps)
    over one whole episode, the first step untimed."""
    arena = swap_arena(n, agent, time_limit=150.0, horizon=horizon)
    arena.reset(seed)
    arena.step()  # warm-up: compilation and caches outside the timing
    start = time.perf_counter()
    steps = 0
    while not arena.done:
        arena.step()
        steps += 1
    wall = time.perf_counter() - start
    summary = arena.summary()
    arrived = sum(r.reached_goal for r in summary.robots)
    return steps * arena.world.dt, wall, arena.time, len(summary.contacts), arrived, steps


def whole_episodes(
    n: int, agent: str, seeds: list[int], horizon: float | None = None
) -> tuple[float, float, str, int, int]:
    """:func:`whole_episode` over ``seeds``: (simulated s per wall s, wall us per
    agent-step, episode durations s (range), contacts, robots arrived), summed."""
    runs = [whole_episode(n, agent, horizon, seed) for seed in seeds]
    sim = sum(r[0] for r in runs)
    wall = sum(r[1] for r in runs)
    steps = sum(r[5] for r in runs)
    lo, hi = min(r[2] for r in runs), max(r[2] for r in runs)
    durations = f"{lo:.1f}" if lo == hi else f"{lo:.1f}-{hi:.1f}"
    return (
        sim / wall,
        1e6 * wall / max(steps * n, 1),
        durations,
        sum(r[3] for r in runs),
        sum(r[4] for r in runs),
    )


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", default="10,30,100")
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--skip", type=int, default=0, help="untimed steps first")
    parser.add_argument("--whole", action="store_true", help="time whole episodes")
    parser.add_argument("--horizon", type=float, default=None, help="NAO horizon (s)")
    parser.add_argument("--seeds", default="0", help="episodes' seeds (--whole)")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    if args.whole:
        seeds = [int(s) for s in args.seeds.split(",")]
        print(
            f"{'robots':>6} {'nao x real time':>16} {'us/agent-step':>14} {'episode s':>11} "
            f"{'contacts':>9} {'arrived':>9} {'goal x real time':>17} {'goal contacts':>14}"
        )
        for n in sizes:
            rate, us, durations, contacts, arrived = whole_episodes(n, "nao", seeds, args.horizon)
            g_rate, _, _, g_contacts, _ = whole_episodes(n, "goal", seeds)
            print(
                f"{n:>6} {rate:>16.2f} {us:>14.0f} {durations:>11} {contacts:>9} "
                f"{arrived:>5}/{n * len(seeds):<3} {g_rate:>17.1f} {g_contacts:>14}"
            )
        return
    print(
        f"{'robots':>6} {'nao x real time':>16} {'us/agent-step':>14} "
        f"{'goal x real time':>17} {'nao cost / goal':>16}"
    )
    for n in sizes:
        nao_rate, nao_us = sim_rate(n, "nao", args.steps, args.skip, args.horizon)
        goal_rate, _ = sim_rate(n, "goal", args.steps, args.skip)
        print(
            f"{n:>6} {nao_rate:>16.2f} {nao_us:>14.0f} {goal_rate:>17.1f} "
            f"{goal_rate / nao_rate:>16.1f}"
        )


if __name__ == "__main__":
    main()
