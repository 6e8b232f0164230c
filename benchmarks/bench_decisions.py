"""The ``nao`` agents' exact decisions in a crowd's densest 10 s, captured and replayed.

Runs one episode of a dense swap (``--map``, ``--size`` robots, seed 0), finds the
``--window`` seconds with the most costly re-selections (robots that cannot keep
their acceleration and are repaired, adjusted or find nothing admissible in the
compiled decision, ``decide_batch``, rather than take their desired one), records
that window's calls with copies of their inputs (rebuilt from the arguments of the
compiled step that makes them, ``settle_members``, and checked to give the same
outcomes), and
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
from numpy.typing import NDArray

import nao_arena.agents.nao as nao_module
from nao_arena.agents._nao_bundles import DecidingRobots, Decisions, GroupPaths, ObstacleLists
from nao_arena.agents._nao_columns import MARGIN, young_adjustments
from nao_arena.agents._nao_decide import decide_batch
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.geometry.outcome import Outcome
from nao_arena.maps import load_map

_ROWS = 3  # the position of decide_batch's rows (the robots it decides) in its arguments


def _episode(map_name: str, n: int) -> Arena:
    bound = max(10.0, 1.1 * n / math.pi) + 10.0
    options: dict[str, Any] = {"n": n, "lo": -bound, "hi": bound}
    if "perturbed" in map_name:
        options["seed"] = 0
    arena = Arena(load_map(map_name, **options), ArenaOptions(agent="nao"))
    arena.reset(0)
    return arena


def _decide_call(
    args: tuple[Any, ...], holds: NDArray[np.bool_], status: NDArray[np.int64]
) -> tuple[Any, ...] | None:
    """The ``decide_batch`` call that ``settle_members(*args)`` made inside (copied
    arguments, fresh outputs), from its arguments, the members' ``holds`` before it ran
    and the status it returned; None when it decided nothing."""
    m, paths, lists, nb_radius, own, current, desired, _, settings, table, _ = args
    todo = np.flatnonzero(status == 0)
    if not len(todo):
        return None
    every = len(m) == len(own.pos)
    p, v, r, a, s, c, d = (
        x.copy() if every else x[m]
        for x in (own.pos, own.vel, own.rad, own.a_max, own.v_max, current, desired)
    )
    grow = r + table.opt[m, MARGIN]
    k = len(m)
    return (
        GroupPaths(*(x.copy() for x in paths)),
        ObstacleLists(*(x.copy() for x in lists)),
        nb_radius.copy(),
        todo,
        DecidingRobots(p, v, grow, a, s),
        holds,
        c,
        d,
        settings,
        Decisions(
            np.full(k, Outcome.UNDECIDED, dtype=np.int64),
            np.zeros((k, 2)),
            np.zeros(k, dtype=np.int64),
        ),
    )


def capture(map_name: str, n: int, window: float) -> tuple[list[tuple[Any, ...]], float, int]:
    """The decide_batch calls of the episode's densest window (the most re-selections
    other than the desired acceleration, the first of equals: the same window in every
    run), the whole step's wall time in that window (s) and its steps. The calls are
    made inside the compiled ``settle_members``; each is rebuilt from that call's
    arguments and checked to give its outcomes. The episode runs twice (the same
    steps): timed, counting re-selections, then recorded (copies would distort the
    timing)."""
    original = nao_module.settle_members
    counts: list[int] = []

    def counting(*args: Any) -> Any:
        out = original(*args)
        status, kind = out[0], out[1]
        counts[-1] += int(np.count_nonzero((status == 0) & (kind != Outcome.DESIRED)))
        return out

    nao_module.settle_members = counting
    arena = _episode(map_name, n)
    step_time = []
    try:
        while not arena.done:
            counts.append(0)
            t0 = time.perf_counter()
            arena.step()
            step_time.append(time.perf_counter() - t0)
    finally:
        nao_module.settle_members = original
    steps = max(1, min(len(step_time), int(round(window / arena.world.dt))))
    first = int(np.argmax(np.convolve(counts, np.ones(steps, dtype=np.int64), mode="valid")))
    calls: list[tuple[Any, ...]] = []
    now = [0]  # the step being taken

    def recording(*args: Any) -> Any:
        if now[0] < first:
            return original(*args)
        m, table = args[0], args[9]
        holds = np.empty(len(m), dtype=np.bool_)
        young_adjustments(m, table.real, table.whole, table.opt, holds)  # before it commits
        out = original(*args)
        call = _decide_call(args, holds, out[0])
        if call is not None:
            expected = replay([call], keep=True)[1][0]
            rows = call[_ROWS]
            if any(
                not np.array_equal(e[rows], o[rows])
                for e, o in zip(expected, out[1:4], strict=True)
            ):
                raise AssertionError("a rebuilt decide_batch call gave other outcomes")
            calls.append(call)
        return out

    nao_module.settle_members = recording
    arena = _episode(map_name, n)
    try:
        for now[0] in range(first + steps):
            arena.step()
    finally:
        nao_module.settle_members = original
    return calls, float(sum(step_time[first : first + steps])), steps


def replay(
    calls: list[tuple[Any, ...]],
    digest: Any = None,
    kinds: Counter[str] | None = None,
    keep: bool = False,
) -> Any:
    """Wall time (s) of every call once (fresh outputs); the outcomes go into digest and
    are counted in kinds; keep: also return each call's outputs (kind, accel, tested)."""
    total = 0.0
    kept = []
    for args in calls:
        a = list(args)
        a[-1] = decided = Decisions(*(x.copy() for x in a[-1]))  # fresh kind, accel, tested
        t0 = time.perf_counter()
        decide_batch(*a)
        total += time.perf_counter() - t0
        if keep:
            kept.append(decided)
        rows = a[_ROWS]
        if digest is not None:
            for out in decided:
                digest.update(np.ascontiguousarray(out[rows]).tobytes())
        if kinds is not None:
            kinds.update(Outcome(int(decided.kind[k])).name.lower() for k in rows)
    return (total, kept) if keep else total


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
    rows = sum(len(c[_ROWS]) for c in calls)
    agent_steps = steps * args.size
    print(
        f"{args.map} n={args.size}: densest {steps} steps ({agent_steps} agent-steps), "
        f"{len(calls)} decide_batch calls, {rows} re-selections "
        f"({', '.join(f'{k} {v}' for k, v in sorted(kinds.items()))})"
    )
    print(
        f"replayed (least of {args.repeat}): {best * 1e3:.2f} ms = "
        f"{best * 1e6 / max(rows, 1):.2f} us per re-selection, "
        f"{best * 1e6 / agent_steps:.2f} us per agent-step"
    )
    print(
        f"whole step in that window (same run): {whole * 1e6 / agent_steps:.2f} us per "
        f"agent-step; the decisions' share {best / whole:.2f}"
    )
    print(f"outcomes hash {digest.hexdigest()[:16]}")


if __name__ == "__main__":
    main()
