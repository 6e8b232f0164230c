"""The arena's own step: what a control period costs besides the agents' decisions.

Every robot of ``dense_swap_perturbed`` (n robots, bounds -60/60 m) is driven by an agent
whose ``act_batch`` returns zero accelerations (:class:`StillAgent`: it decides nothing),
so a step is the arena's own work: sensing, the arena's checks of the agents' results,
the world's period, the goal test and the statistics, the trajectory hash.

Two ways of running the period are timed in the same run, alternating, on the same
episode (the same trajectory hash):

- ``compiled``: the arena's own step, the period in one compiled call
  (:func:`nao_arena.period.run_period`);
- ``one by one``: ``World.step``, the goal test and ``EpisodeStats.update`` called
  one after another (what the arena falls back to where the compiled period does not
  apply; the same kernels, the same bits): the baseline.

Printed per n: steps timed, us per step of each (best of ``--repeats`` episodes of
``--steps`` steps after one untimed step), their ratio, and the share of the compiled
step spent in sensing (``Arena.sensing``) and in the period (``Arena._period``). Run:

    python benchmarks/bench_arena_step.py [--sizes 2,10,100] [--steps 300] [--repeats 5]
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
from bench_args import OneLineParser, best_of_alternating, positive, robot_counts

import nao_arena.arena as arena_module
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map


class StillAgent:
    """An agent that decides nothing: zero acceleration for every robot it drives."""

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """Stateless."""

    def act(self, obs: Any) -> np.ndarray:
        return np.zeros(2)

    @classmethod
    def act_batch(cls, agents: Any, batch: Any, rows: Any) -> np.ndarray:
        return np.zeros((len(rows), 2))


def _arena(n: int) -> Arena:
    spec = load_map("dense_swap_perturbed", n=n, lo=-60.0, hi=60.0)
    arena = Arena(spec, ArenaOptions(agent=f"{StillAgent.__module__}:StillAgent"))
    arena.reset(seed=0)
    arena.step()  # the first period (pymunk checks its new bodies) outside the timing
    return arena


def _timed(n: int, steps: int, one_by_one: bool) -> tuple[float, float, float, str]:
    """us per step of ``steps`` steps, the sensing's and the period's shares of it, and
    the trajectory hash; ``one_by_one``: the period without the compiled call."""
    arena = _arena(n)
    clock = time.perf_counter
    sums = {"sense": 0.0, "period": 0.0}

    def timer(name: str, call: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any) -> Any:
            t0 = clock()
            out = call(*args)
            sums[name] += clock() - t0
            return out

        return timed

    arena.sensing = timer("sense", arena.sensing)  # type: ignore[method-assign]
    arena._period = timer("period", arena._period)  # type: ignore[method-assign]
    saved = arena_module.run_period
    if one_by_one:
        arena_module.run_period = lambda *args: None  # type: ignore[assignment]
    try:
        t0 = clock()
        for _ in range(steps):
            arena.step()
        wall = clock() - t0
    finally:
        arena_module.run_period = saved
    return (
        1e6 * wall / steps,
        sums["sense"] / wall,
        sums["period"] / wall,
        arena.summary().trajectory_hash,
    )


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=robot_counts, default=[2, 10, 100], help="robot counts")
    parser.add_argument("--steps", type=positive, default=300)
    parser.add_argument("--repeats", type=positive, default=5)
    args = parser.parse_args(argv)
    sizes = args.sizes
    print(
        f"{'robots':>6} {'steps':>6} {'compiled us':>11} {'one by one us':>13} "
        f"{'ratio':>6} {'sense %':>7} {'period %':>8}"
    )
    for n in sizes:
        best, base = best_of_alternating(
            partial(_timed, n, args.steps),
            args.repeats,
            f"n = {n}",
            warm_up=partial(_timed, n, 10),
        )
        print(
            f"{n:6d} {args.steps:6d} {best[0]:11.1f} {base[0]:13.1f} "
            f"{best[0] / base[0]:6.2f} {100 * best[1]:7.1f} {100 * best[2]:8.1f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
