"""The NAO safety shield's cost per agent-step against the bare env step.

Scenes (every robot controlled, seeded random actions, render_mode None):
circle_swap with 10 robots and crossing (12 robots).

For each scene this runs, in the same process and interleaved, ``env.step``
of the bare env and ``NAOShield.step`` of a shielded one on the same
pre-drawn actions (the trajectories differ where the shield replaces
actions). Of the shielded step it times the shield's own part
(:meth:`NAOShield.shield`: the arena's sensing, predictions, the
admissibility test and the selections) apart from the env step it then
calls. Times are per agent-step (us), best of the repeats; the ratio is the
shield's part over the bare env step. The statuses are those of the last
repeat (how many agent-steps kept their action, were repaired, adjusted or
infeasible).
Run: ``python benchmarks/bench_shield.py [--steps 200] [--repeats 5]``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from nao_arena.environment import parallel_env
from nao_arena.shield import NAOShield

SCENES: list[tuple[str, str, dict[str, Any]]] = [
    ("circle_swap n=10", "circle_swap", {"n": 10}),
    ("crossing (12)", "crossing", {}),
]


def time_bare(env: Any, actions: list[dict[str, np.ndarray]], seed: int) -> float:
    """Seconds per env.step."""
    env.reset(seed=seed)
    t0 = time.perf_counter()
    for acts in actions:
        env.step(acts)
    return (time.perf_counter() - t0) / len(actions)


def time_shielded(
    env: NAOShield, actions: list[dict[str, np.ndarray]], seed: int
) -> tuple[float, float]:
    """Seconds per step in the shield's own part, and in the whole shielded step."""
    env.reset(seed=seed)
    in_shield = 0.0
    shield = env.shield
    t0 = time.perf_counter()
    for acts in actions:
        t1 = time.perf_counter()
        shielded, _ = shield(acts)
        in_shield += time.perf_counter() - t1
        env.env.step(shielded)
    total = time.perf_counter() - t0
    return in_shield / len(actions), total / len(actions)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rows = []
    for label, map_name, kwargs in SCENES:
        bare = parallel_env(map_name, time_limit=1e4, **kwargs)
        shielded = NAOShield(parallel_env(map_name, time_limit=1e4, **kwargs))
        agents = bare.possible_agents
        rng = np.random.default_rng(0)
        norm = rng.uniform(-1.0, 1.0, (args.steps, len(agents), 2)).astype(np.float32)
        actions = [{a: norm[s, i] for i, a in enumerate(agents)} for s in range(args.steps)]
        time_bare(bare, actions[:5], 0)  # compile and warm up
        time_shielded(shielded, actions[:5], 0)
        best_bare = best_shield = best_total = np.inf
        for _ in range(args.repeats):
            best_bare = min(best_bare, time_bare(bare, actions, 0))
            own, total = time_shielded(shielded, actions, 0)
            best_shield, best_total = min(best_shield, own), min(best_total, total)
        n = len(agents)
        statuses = dict(sorted(shielded.statuses.items()))
        rows.append(
            (
                label,
                n,
                args.steps,
                1e6 * best_bare / n,
                1e6 * best_shield / n,
                best_shield / best_bare,
                1e6 * best_total / n,
                statuses,
            )
        )
    print(
        f"{'scene':<18} {'agents':>6} {'steps':>5} {'env us/ag-step':>14} "
        f"{'shield us/ag-step':>17} {'shield/env':>10} {'shielded step':>13}  statuses"
    )
    for label, n, steps, env_us, shield_us, ratio, total_us, statuses in rows:
        print(
            f"{label:<18} {n:>6} {steps:>5} {env_us:>14.1f} {shield_us:>17.1f} "
            f"{ratio:>10.2f} {total_us:>13.1f}  {statuses}"
        )
    print(
        "us per agent-step, best of the repeats; shield/env: the shield's own part over "
        "the bare env step; shielded step: the shield and the env step it calls"
    )


if __name__ == "__main__":
    main()
