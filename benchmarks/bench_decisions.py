"""The ``nao`` agents' exact decisions in a crowd's densest 10 s, captured and replayed.

Runs one episode of a dense swap (``--map``, ``--size`` robots, seed 0), finds the
``--window`` seconds with the most costly re-selections (robots that cannot keep
their acceleration and are repaired, adjusted or find nothing admissible in the
compiled decision, ``decide_batch``, rather than take their desired one), records
that window's calls with copies of their inputs, and
replays them ``--repeat`` times, printing the least time: us per re-selection and
per agent-step, next to the whole step of the same window in the same run (the
decisions' share of it), how many robots re-decided and with what outcome, and a
hash of the outcomes (kind, acceleration, candidates tested), which a change that
keeps the decisions bit for bit leaves unchanged.
Run:

    python benchmarks/bench_decisions.py [--map dense_swap_perturbed] [--size 100]
        [--window 10] [--repeat 7]

To compare two versions of the code, run this once for each (the episodes, and so
the captured calls, are the same) and compare the least times; alternate the runs
on a noisy machine.
"""

from __future__ import annotations

import argparse
import hashlib
import math
import time
from collections import Counter
from typing import Any

import numpy as np
from bench_crowds import warm_up

import nao_arena.agents._nao_decide as decide_module
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.geometry.outcome import Outcome
from nao_arena.maps import load_map


def _episode(map_name: str, n: int) -> Arena:
    bound = max(10.0, 1.1 * n / math.pi) + 10.0
    options: dict[str, Any] = {"n": n, "lo": -bound, "hi": bound}
    if "perturbed" in map_name:
        options["seed"] = 0
    arena = Arena(load_map(map_name, **options), ArenaOptions(agent="nao"))
    arena.reset(0)
    return arena


def capture(map_name: str, n: int, window: float) -> tuple[list[tuple[Any, ...]], float, int]:
    """The decide_batch calls (copied arguments) of the episode's densest window (the
    most re-selections other than the desired acceleration, the first of equals: the
    same window in every run), the whole
    step's wall time in that window (s) and its steps. The episode runs twice (the
    same steps): timed, counting re-selections, then recorded (copies would distort the
    timing)."""
    original = decide_module.decide_batch
    counts: list[int] = []

    def counting(*args: Any) -> None:
        original(*args)
        kind, rows = args[-3], args[11]
        counts[-1] += int(np.count_nonzero(kind[rows] != Outcome.DESIRED))

    decide_module.decide_batch = counting
    arena = _episode(map_name, n)
    step_time = []
    try:
        while not arena.done:
            counts.append(0)
            t0 = time.perf_counter()
            arena.step()
            step_time.append(time.perf_counter() - t0)
    finally:
        decide_module.decide_batch = original
    steps = max(1, min(len(step_time), int(round(window / arena.world.dt))))
    first = int(np.argmax(np.convolve(counts, np.ones(steps, dtype=np.int64), mode="valid")))
    calls: list[tuple[Any, ...]] = []
    now = [0]  # the step being taken

    def recording(*args: Any) -> None:
        if now[0] >= first:
            calls.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        original(*args)

    decide_module.decide_batch = recording
    arena = _episode(map_name, n)
    try:
        for now[0] in range(first + steps):
            arena.step()
    finally:
        decide_module.decide_batch = original
    return calls, float(sum(step_time[first:first + steps])), steps


def replay(calls: list[tuple[Any, ...]], digest: Any = None,
           kinds: Counter[str] | None = None) -> float:
    """Wall time (s) of every call once (fresh outputs); the outcomes go into digest and
    are counted in kinds."""
    total = 0.0
    for args in calls:
        a = list(args)
        a[-3], a[-2], a[-1] = a[-3].copy(), a[-2].copy(), a[-1].copy()  # kind, accel, tested
        t0 = time.perf_counter()
        decide_module.decide_batch(*a)
        total += time.perf_counter() - t0
        if digest is not None:
            rows = a[11]
            for out in a[-3:]:
                digest.update(np.ascontiguousarray(out[rows]).tobytes())
        if kinds is not None:
            kinds.update(Outcome(int(a[-3][k])).name.lower() for k in a[11])
    return total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--map", default="dense_swap_perturbed")
    parser.add_argument("--size", type=int, default=100)
    parser.add_argument("--window", type=float, default=10.0, help="seconds")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    warm_up("nao")
    calls, whole, steps = capture(args.map, args.size, args.window)
    digest = hashlib.sha256()
    kinds: Counter[str] = Counter()
    replay(calls, digest, kinds)
    best = min(replay(calls) for _ in range(max(1, args.repeat)))
    rows = sum(len(c[11]) for c in calls)
    agent_steps = steps * args.size
    print(f"{args.map} n={args.size}: densest {steps} steps ({agent_steps} agent-steps), "
          f"{len(calls)} decide_batch calls, {rows} re-selections "
          f"({', '.join(f'{k} {v}' for k, v in sorted(kinds.items()))})")
    print(f"replayed (least of {args.repeat}): {best * 1e3:.2f} ms = "
          f"{best * 1e6 / max(rows, 1):.2f} us per re-selection, "
          f"{best * 1e6 / agent_steps:.2f} us per agent-step")
    print(f"whole step in that window (same run): {whole * 1e6 / agent_steps:.2f} us per "
          f"agent-step; the decisions' share {best / whole:.2f}")
    print(f"outcomes hash {digest.hexdigest()[:16]}")


if __name__ == "__main__":
    main()
