"""How safe each method stays in an imperfect world: contacts under sensing latency and
actuation noise, every method on the same episodes.

For each scene, agent and setting (latency s, actuation noise m/s^2), whole episodes are
run for the seeds given; printed per row: the robot-episodes with a contact involving a
robot (of all robot-episodes, with the 95 % Wilson interval), the contact events, the
robot-episodes at their goals at the end, and the episodes. Run:

    python benchmarks/robustness.py [--seeds 5] [--agents nao,orca,cbf,goal]
        [--latencies 0,0.1,0.2] [--noises 0.1,0.3] [--scenes crossing,circle_swap_perturbed]
"""

from __future__ import annotations

import argparse

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map
from nao_arena.trials.results import wilson_interval


def settings(latencies: list[float], noises: list[float]) -> list[tuple[float, float]]:
    """(latency s, noise m/s^2): each latency without noise, then each noise without it."""
    return [(lat, 0.0) for lat in latencies] + [(0.0, s) for s in noises if s > 0]


def row(scene: str, agent: str, latency: float, noise: float, seeds: int) -> list[str]:
    """One table row over ``seeds`` episodes (seeds 0 .. seeds - 1)."""
    hit = events = arrived = robots = 0
    for seed in range(seeds):
        spec = (
            load_map(scene, seed=seed)
            if "seed" in load_map(scene).parameters
            else (load_map(scene))
        )
        arena = Arena(
            spec, ArenaOptions(agent=agent, sensing_latency=latency, actuation_noise=noise)
        )
        summary = arena.run(seed)
        robot_bodies = set(int(b) for b in arena.robot_ids)
        touched = set()
        for c in summary.contacts:
            if "robot" in (c.kind_a, c.kind_b):
                events += 1
                touched |= {
                    x for x, kind in ((c.a, c.kind_a), (c.b, c.kind_b)) if kind == "robot"
                } & robot_bodies
        hit += len(touched)
        arrived += sum(r.success for r in summary.robots)
        robots += len(summary.robots)
    lo, hi = wilson_interval(hit, robots)
    return [
        scene,
        agent,
        f"{latency:g}",
        f"{noise:g}",
        f"{hit}/{robots} [{100 * lo:.1f}, {100 * hi:.1f}] %",
        str(events),
        f"{arrived}/{robots}",
        str(seeds),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--agents", default="nao,orca,cbf,goal")
    parser.add_argument("--latencies", default="0,0.1,0.2")
    parser.add_argument("--noises", default="0.1,0.3")
    parser.add_argument("--scenes", default="crossing,circle_swap_perturbed")
    args = parser.parse_args()
    head = [
        "scene",
        "agent",
        "latency s",
        "noise m/s^2",
        "robot-episodes with a contact",
        "contacts",
        "at goal",
        "episodes",
    ]
    rows = [head]
    for scene in args.scenes.split(","):
        for latency, noise in settings(
            [float(v) for v in args.latencies.split(",")],
            [float(v) for v in args.noises.split(",")],
        ):
            for agent in args.agents.split(","):
                rows.append(row(scene, agent, latency, noise, args.seeds))
                print("  ".join(rows[-1]), flush=True)
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    print()
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip())


if __name__ == "__main__":
    main()
