"""The ``nao`` agents' step: their decision in one compiled call against the calls one by one.

Every robot of ``dense_swap_perturbed`` (n robots, bounds -20/20 m: the swap meets in
the middle) is a ``nao`` agent. Two ways of running the agents' step are timed in the
same run, alternating, on the same episode (the same trajectory hash):

- ``one call``: the batch's decision in one compiled call where the agents share one
  predictor and time grid (``decide_rows`` in ``agents/_nao_batch.py``; two calls where
  Python finds heading targets between them);
- ``one by one``: the same kernels called one after another from Python (what the
  agents fall back to for several predictor groups or irregular time grids; the same
  bits): the baseline.

Printed per n: steps timed (whole episodes of ``--repeats``, best of them), us per
agent-step of each, their ratio, and the share of the agents' step (``act_batch``) in
the one-call step. Run:

    python benchmarks/bench_nao_step.py [--sizes 2,10,30] [--repeats 5]
"""

from __future__ import annotations

import time
from functools import partial
from typing import Any

from bench_args import OneLineParser, best_of_alternating, positive, robot_counts

import nao_arena.agents.nao as nao_module
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map


def _timed(n: int, one_by_one: bool) -> tuple[float, float, int, str]:
    """One whole episode of the n-robot swap: us per agent-step, the share of the agents'
    step in it, the steps and the trajectory hash; ``one_by_one``: the agents' compiled
    calls one after another (no batch is taken in one call)."""
    arena = Arena(load_map("dense_swap_perturbed", n=n, lo=-20.0, hi=20.0), ArenaOptions())
    arena.reset(seed=0)
    clock = time.perf_counter
    spent = [0.0]
    act = arena._act_batch

    def timed_act(*args: Any) -> Any:
        t0 = clock()
        out = act(*args)
        spent[0] += clock() - t0
        return out

    arena._act_batch = timed_act  # type: ignore[method-assign]
    saved = nao_module._shared_predictor
    if one_by_one:
        nao_module._shared_predictor = lambda agents, cols: None  # type: ignore[assignment]
    try:
        steps = 0
        t0 = clock()
        while not arena.done:
            arena.step()
            steps += 1
        wall = clock() - t0
    finally:
        nao_module._shared_predictor = saved
    return 1e6 * wall / (steps * n), spent[0] / wall, steps, arena.summary().trajectory_hash


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=robot_counts, default=[2, 10, 30], help="robot counts")
    parser.add_argument("--repeats", type=positive, default=5)
    args = parser.parse_args(argv)
    print(
        f"{'robots':>6} {'steps':>6} {'one call us':>11} {'one by one us':>13} "
        f"{'ratio':>6} {'agents %':>8}"
    )
    for n in args.sizes:
        best, base = best_of_alternating(partial(_timed, n), args.repeats, f"n = {n}")
        print(
            f"{n:6d} {best[2]:6d} {best[0]:11.2f} {base[0]:13.2f} "
            f"{best[0] / base[0]:6.2f} {100 * best[1]:8.1f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
