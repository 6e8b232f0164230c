"""A custom agent: goal seeking, pushed away from bodies that come close.

An agent is any class with ``reset(robot_spec, rng)`` and
``act(observation) -> acceleration (2,) m/s^2`` (world frame; longer than
``a_max`` is scaled down). Use this one from the command line, named
``polite`` in the table:

    nao-arena run crossing --agent polite=examples/custom_agent.py:Polite

or run this file, which runs one episode through the Python API:

    python examples/custom_agent.py [--map crossing] [--seed 0] [--set n=4] [--time-limit S]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import RobotSpec, load_map, parse_overrides
from nao_arena.sensing import Observation


class Polite:
    """Heads for its goal at up to v_max; each body whose surface is closer than
    ``reach`` (m) pushes the desired velocity away from it (up to v_max at contact)."""

    def __init__(self, reach: float = 1.5, gain: float = 2.0) -> None:
        self.reach = reach  # m
        self.gain = gain  # 1/s: how fast the velocity follows the desired one

    def reset(self, spec: RobotSpec, rng: np.random.Generator) -> None:
        self.rng = rng  # the robot's seeded generator (unused here)

    def act(self, obs: Observation) -> np.ndarray:
        to_goal = obs.goal - obs.position  # m
        distance = float(np.hypot(*to_goal))
        desired = obs.v_max * min(1.0, distance) * to_goal / max(distance, 1e-9)  # m/s
        nb = obs.neighbours  # the bodies within sensing range, nearest first
        if len(nb):
            away = obs.position - nb.positions  # (n, 2) m
            centres = np.maximum(np.hypot(away[:, 0], away[:, 1]), 1e-9)
            gaps = centres - nb.radii - obs.radius  # surface to surface, m
            near = gaps < self.reach
            push = np.clip(1.0 - gaps[near] / self.reach, 0.0, 1.0)  # 0 .. 1
            directions = away[near] / centres[near, None]
            desired = desired + obs.v_max * (push[:, None] * directions).sum(axis=0)
        return self.gain * (desired - obs.velocity)  # m/s^2


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="One episode of the Polite agent.")
    parser.add_argument("--map", default="crossing", help="shipped map name or map file")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--set", nargs="*", default=[], metavar="KEY=VALUE", help="map parameters, e.g. n=4"
    )
    parser.add_argument("--time-limit", type=float, default=None, metavar="S")
    args = parser.parse_args(argv)

    spec = load_map(args.map, **parse_overrides(args.set))
    if args.time_limit is not None:
        spec = spec.model_copy(
            update={"episode": spec.episode.model_copy(update={"time_limit": args.time_limit})}
        )
    # the same reference as on the command line: FILE.py:CLASS
    arena = Arena(spec, ArenaOptions(agent=f"{Path(__file__).resolve()}:Polite"))
    summary = arena.run(args.seed)
    print(f"{spec.name}: {summary.duration:.1f} s")
    for r in summary.robots:
        arrived = f"arrived after {r.time_to_goal:.1f} s" if r.reached_goal else "did not arrive"
        gap = f"{r.min_separation:.2f} m" if np.isfinite(r.min_separation) else "> 1 m"
        print(f"  {r.name}: {arrived}, {r.collisions} collisions, closest gap {gap}")


if __name__ == "__main__":
    main()
