"""Env steps per second through SuperSuit's vector env against the bare parallel env.

One versioned env (default crossing_v0: 12 robots, all controlled, ``keep_finished=True``)
stepped with random actions (pre-drawn, the same for every runner), measured in the same
run:

- bare: ``env.step`` on one parallel env with a dict of actions, reset when the episode
  ends;
- vec, num_cpus=0: ``ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), copies,
  num_cpus=0, base_class="gymnasium")``, every copy stepped in this process;
- vec, num_cpus=2: the same with the copies split over 2 worker processes.

An env step is one control period of one copy (all its agents); a vector step is
``copies`` env steps. Every runner makes the same number of env steps; rates are the best
of the interleaved repeats, ratios against the bare env. Construction, worker start-up and
the first reset are not timed.
Run: ``python benchmarks/bench_vec_env.py [--env crossing_v0] [--copies 4] [--steps 200]
[--repeats 3]``.
"""

from __future__ import annotations

import argparse
import time
import warnings
from typing import Any

import numpy as np
import supersuit as ss

from nao_arena.envs import available, load


def time_bare(par: Any, actions: np.ndarray, seed: int) -> float:
    """Seconds for len(actions) env steps of one parallel env (actions (S, agents, 2))."""
    agents = par.possible_agents
    par.reset(seed=seed)
    t0 = time.perf_counter()
    for acts in actions:
        if not par.agents:
            par.reset()
        par.step(dict(zip(agents, acts, strict=True)))
    return time.perf_counter() - t0


def time_vec(vec: Any, actions: np.ndarray, seed: int) -> float:
    """Seconds for len(actions) vector steps (actions (S, copies * agents, 2))."""
    vec.reset(seed=seed)
    t0 = time.perf_counter()
    for acts in actions:
        vec.step(acts)
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="crossing_v0", choices=available())
    parser.add_argument("--copies", type=int, default=4, help="envs in the vector env")
    parser.add_argument("--steps", type=int, default=200, help="vector steps per repeat")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore", UserWarning)  # PettingZoo's advice on bounds and names

    module = load(args.env)
    make = lambda: module.parallel_env(keep_finished=True)  # noqa: E731
    bare = make()
    n = len(bare.possible_agents)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (args.steps, args.copies * n, 2)).astype(np.float32)
    env_steps = args.steps * args.copies
    vecs = {
        cpus: ss.concat_vec_envs_v1(
            ss.pettingzoo_env_to_vec_env_v1(make()),
            args.copies,
            num_cpus=cpus,
            base_class="gymnasium",
        )
        for cpus in (0, 2)
    }
    best = {"bare": np.inf, 0: np.inf, 2: np.inf}
    try:
        for r in range(args.repeats):
            # the bare env makes the same env steps, copy after copy
            flat = acts.reshape(args.steps, args.copies, n, 2).transpose(1, 0, 2, 3)
            best["bare"] = min(best["bare"], time_bare(bare, flat.reshape(-1, n, 2), r))
            for cpus, vec in vecs.items():
                best[cpus] = min(best[cpus], time_vec(vec, acts, r))
    finally:
        for vec in vecs.values():
            vec.close()

    print(
        f"{args.env}: {n} agents, keep_finished=True; {args.copies} copies in the vector "
        f"env; {env_steps} env steps ({env_steps * n} agent-steps) per runner, best of "
        f"{args.repeats}"
    )
    print(
        f"{'runner':<22} {'env steps':>9} {'s':>7} {'env steps/s':>11} "
        f"{'agent-steps/s':>13} {'x bare':>7}"
    )
    base = env_steps / best["bare"]
    for key, label in (
        ("bare", "bare parallel env"),
        (0, "vec, num_cpus=0"),
        (2, "vec, num_cpus=2"),
    ):
        rate = env_steps / best[key]
        print(
            f"{label:<22} {env_steps:>9} {best[key]:>7.2f} {rate:>11.0f} {rate * n:>13.0f} "
            f"{rate / base:>7.2f}"
        )


if __name__ == "__main__":
    main()
