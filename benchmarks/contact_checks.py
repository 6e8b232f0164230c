"""Contacts found by the substep check against the step-end check, on the same episodes.

Each episode runs once; beside the arena's own statistics (the swept check over
every physics substep) a second recorder sees only the control steps' end
points (straight lines between them), as the statistics did before the
substep check. Prints, per map and agent, the contact events of both and the
episodes where they differ.

    python benchmarks/contact_checks.py --maps roundabout,crossing,circle_swap \
        --agents goal,orca --seeds 0-9
"""

from __future__ import annotations

import argparse

import numpy as np

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map
from nao_arena.stats import EpisodeStats


def seeds_of(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def episode(map_name: str, agent: str, seed: int) -> tuple[int, int, int]:
    """(contacts with the substep check, with the step-end check, steps) of one episode."""
    spec = load_map(map_name, **({"seed": seed} if "seed" in load_map(map_name).parameters else {}))
    arena = Arena(spec, ArenaOptions(agent=agent))
    state = arena.reset(seed)
    ends = EpisodeStats(
        arena.world.radii,
        arena.world.kinds,
        arena.world.names,
        walls=(arena.walls, arena.wall_radius),
        dt=arena.world.dt,
        velocities=state.velocities,
    )
    steps = 0
    while not arena.done:
        before = arena.state
        result = arena.step()
        reached = np.zeros(arena.world.n, dtype=bool)
        reached[arena.robot_ids] = arena.reached
        ends.update(
            before.time,
            before.positions,
            result.state.positions,
            result.state.velocities,
            result.commanded,
            reached,
        )
        steps += 1
    return len(arena.stats.contacts), len(ends.contacts), steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", default="roundabout,crossing,circle_swap")
    parser.add_argument("--agents", default="goal,orca")
    parser.add_argument("--seeds", default="0-9", help="range, e.g. 0-9")
    args = parser.parse_args()
    print(
        f"{'map':<12} {'agent':<6} {'episodes':>8} {'substep check':>14} "
        f"{'step-end check':>15} {'episodes differing':>19}"
    )
    for map_name in args.maps.split(","):
        for agent in args.agents.split(","):
            sub = ends = differ = 0
            seeds = seeds_of(args.seeds)
            for seed in seeds:
                a, b, _ = episode(map_name, agent, seed)
                sub, ends, differ = sub + a, ends + b, differ + (a != b)
            print(f"{map_name:<12} {agent:<6} {len(seeds):>8} {sub:>14} {ends:>15} {differ:>19}")


if __name__ == "__main__":
    main()
