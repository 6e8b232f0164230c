"""PettingZoo env step cost against the bare arena loop.

Scenes (render_mode None):

- roundabout: one controlled robot (west_east, random actions), the other
  robot driven by its NAO agent, all traffic scripted;
- circle_swap with 30 robots: one controlled (random actions), 29 driven by
  their NAO agents inside the step (the issue's all-NAO scene);
- circle_swap with 30 robots, all controlled, random actions (the env's
  own cost per agent against physics and statistics alone);
- the same with the optional NAO observation block (nao_features=True).

For each scene this times, in the same run and on the same pre-drawn
actions, ``Arena.step`` with the accelerations (m/s^2) in a dict (bare) and
``env.step`` with the normalized actions (observations, rewards, infos
included). Times are per control step, best of the interleaved repeats; the
ratio is env / bare (the issue's target: <= 1.2 without the NAO block).
The last column is the env's own cost per controlled agent and step (us).
Run: ``python benchmarks/bench_env.py [--steps 300] [--repeats 5]``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from nao_arena.arena import Arena
from nao_arena.environment import parallel_env

SCENES: list[tuple[str, str, dict[str, Any]]] = [
    ("roundabout, 1 controlled", "roundabout", {"controlled": ["west_east"]}),
    (
        "circle_swap n=30, 29 NAO + 1",
        "circle_swap",
        {"n": 30, "radius": 10.0, "controlled": ["swap0"]},
    ),
    ("circle_swap n=30, all", "circle_swap", {"n": 30, "radius": 10.0}),
    (
        "circle_swap n=30, all, NAO block",
        "circle_swap",
        {"n": 30, "radius": 10.0, "nao_features": True},
    ),
]


def time_bare(arena: Arena, actions: list[dict[int, np.ndarray]], seed: int) -> float:
    """Seconds per Arena.step."""
    arena.reset(seed)
    t0 = time.perf_counter()
    for acts in actions:
        arena.step(acts)
    return (time.perf_counter() - t0) / len(actions)


def time_env(env: Any, actions: list[dict[str, np.ndarray]], seed: int) -> float:
    """Seconds per env.step (the episode outlasts the actions)."""
    env.reset(seed=seed)
    t0 = time.perf_counter()
    for acts in actions:
        env.step(acts)
    return (time.perf_counter() - t0) / len(actions)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rows = []
    for label, map_name, kwargs in SCENES:
        env = parallel_env(map_name, time_limit=1e4, **kwargs)
        env.reset(seed=0)
        arena = Arena(env.spec, env.options.arena)
        rng = np.random.default_rng(0)
        # float32 like the env's actions, so both loops follow the same trajectories
        norm = rng.uniform(-1.0, 1.0, (args.steps, len(env.possible_agents), 2))
        norm = norm.astype(np.float32).astype(np.float64)
        robots = env.controlled_robots
        a_max = arena.world.a_max[arena.robot_ids[robots]]
        env_actions = [
            {a: norm[s, i].astype(np.float32) for i, a in enumerate(env.possible_agents)}
            for s in range(args.steps)
        ]
        bare_actions = [
            {k: norm[s, i] * a_max[i] for i, k in enumerate(robots)} for s in range(args.steps)
        ]
        time_env(env, env_actions[:5], 0)  # warm-up: numba kernels, caches
        time_bare(arena, bare_actions[:5], 0)
        bare, wrapped = np.inf, np.inf
        for _ in range(args.repeats):  # interleaved: both see the same machine load
            bare = min(bare, time_bare(arena, bare_actions, 0))
            wrapped = min(wrapped, time_env(env, env_actions, 0))
        rows.append((label, bare, wrapped, len(env.possible_agents)))
    head = (
        f"{'scene':34s} {'bare ms/step':>12s} {'env ms/step':>12s} {'env/bare':>9s} "
        f"{'us/agent':>9s}"
    )
    print(head)
    print("-" * len(head))
    for label, bare, wrapped, m in rows:
        print(
            f"{label:34s} {bare * 1e3:12.3f} {wrapped * 1e3:12.3f} {wrapped / bare:9.2f} "
            f"{(wrapped - bare) * 1e6 / m:9.1f}"
        )


if __name__ == "__main__":
    main()
