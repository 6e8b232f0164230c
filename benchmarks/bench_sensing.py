"""Sensing: the nearest k within range, by the grid's square rings, against sorting every
body within range and keeping the first k (what a capped list cost before the rings).

Both produce the same lists (checked here too); figures are microseconds per body after a
warm-up, for crowds of n robots laid out as the dense swap's phases: the start circle
(radius max(10, 1.1 n / pi) m, 2.2 m apart), a packed crowd (a square lattice 1.15 m
apart, the swap's centre) and half of each. Run:

    python benchmarks/bench_sensing.py [--sizes 100,300,1000] [--range 15] [--k 10]
"""

from __future__ import annotations

import argparse
import math
from functools import partial

import numpy as np
from bench_segment import per_call

from nao_arena.sensing import neighbour_lists


def crowds(n: int) -> dict[str, np.ndarray]:
    """Positions (n, 2) m of the three layouts."""
    radius = max(10.0, 1.1 * n / math.pi)
    angle = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    ring = np.c_[radius * np.cos(angle), radius * np.sin(angle)]
    side = math.isqrt(n - 1) + 1
    packed = np.array([(i * 1.15, j * 1.15) for i in range(side) for j in range(side)])[:n]
    packed -= packed.mean(axis=0)
    half = ring.copy()
    half[: n // 2] = packed[: n // 2]
    return {"circle": ring, "packed": packed, "half": half}


def sorted_then_cut(
    bodies: np.ndarray, pos: np.ndarray, reach: float, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """Every body within range, sorted, then the first k of each list (CSR)."""
    start, index = neighbour_lists(bodies, pos, reach, None)
    counts = np.minimum(np.diff(start), k)
    out_start = np.zeros(len(bodies) + 1, dtype=np.int64)
    np.cumsum(counts, out=out_start[1:])
    keep = np.concatenate([index[start[i] : start[i] + counts[i]] for i in range(len(bodies))])
    return out_start, keep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,300,1000")
    parser.add_argument("--range", type=float, default=15.0, help="sensing range (m)")
    parser.add_argument("--k", type=int, default=10, help="neighbours kept")
    args = parser.parse_args()
    print(f"us per body: nearest {args.k} within {args.range} m")
    print(f"{'n':>6} {'layout':8} {'rings':>8} {'sort all':>9} {'sort/rings':>11}")
    for n in (int(s) for s in args.sizes.split(",")):
        bodies = np.arange(n, dtype=np.int64)
        for name, pos in crowds(n).items():
            got = neighbour_lists(bodies, pos, args.range, args.k)
            ref = sorted_then_cut(bodies, pos, args.range, args.k)
            assert all(np.array_equal(a, b) for a, b in zip(got, ref, strict=True))
            rings = per_call(partial(neighbour_lists, bodies, pos, args.range, args.k), 0.5) / n
            full = per_call(partial(neighbour_lists, bodies, pos, args.range, None), 0.5) / n
            print(f"{n:>6} {name:8} {1e6 * rings:>8.2f} {1e6 * full:>9.2f} {full / rings:>10.1f}x")


if __name__ == "__main__":
    main()
