"""Wall time of NAO episodes on maps with walls, this checkout against an earlier one.

Each episode runs in its own process (warm numba caches: a 3-step episode first, outside
the timing) with this checkout's map files, so an earlier checkout that still treats
walls as chains of discs runs the very same scenes. Runs alternate between the two
interpreters seed by seed, in one sitting. Prints wall time per episode, the median
ratio per map, and the outcomes beside them (robots at their goal, contacts), so a
faster run that fails shows as such.

    python benchmarks/bench_walls.py --before-python /path/to/old/checkout/.venv/bin/python
    python benchmarks/bench_walls.py --maps two_lane_road,doorway --seeds 0,1,2,3,4

Without --before-python only this checkout runs (its times alone, no ratio).
The earlier interpreter must have its checkout installed (``pip install -e .``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

EPISODE = r"""
import json, sys, time
from nao_arena.arena import Arena
from nao_arena.trials import make_map
path, seed, params = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
arena = Arena(make_map(path, seed, params))
arena.run(seed=seed, max_steps=3)  # compile / load the kernels outside the timing
start = time.perf_counter()
summary = arena.run(seed=seed)
wall = time.perf_counter() - start
print(json.dumps({"wall": wall, "steps": summary.steps,
                  "arrived": sum(bool(r.success) for r in summary.robots),
                  "robots": len(summary.robots), "contacts": len(summary.contacts)}))
"""

PARAMS = {"doorway": {"agent": "nao"}, "two_lane_road": {"agent": "nao"}}
"""Map parameters per scene (the doorway's defaults: 10 robots on each side)."""


def run_episode(python: str, map_file: Path, seed: int, params: dict) -> dict:
    """One timed episode in a fresh process of ``python``."""
    out = subprocess.run([python, "-c", EPISODE, str(map_file), str(seed), json.dumps(params)],
                         capture_output=True, text=True, check=False, cwd="/")
    if out.returncode != 0:
        raise SystemExit(f"{python}: episode {map_file.name} seed {seed} failed:\n"
                         f"{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before-python", help="interpreter of the earlier checkout")
    ap.add_argument("--maps", default="two_lane_road,doorway")
    ap.add_argument("--seeds", default="0,1,2,3,4")
    args = ap.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    pythons = {"after": sys.executable}
    if args.before_python:
        pythons = {"before": args.before_python, **pythons}
    print(f"{'map':<14} {'seed':>4} " + " ".join(
        f"{k + ' s':>9} {k + ' arrived':>15} {k + ' contacts':>15}" for k in pythons))
    for name in args.maps.split(","):
        map_file = ROOT / "maps" / f"{name}.yaml"
        walls: dict[str, list[float]] = {k: [] for k in pythons}
        for seed in seeds:
            row = []
            for label, python in pythons.items():
                res = run_episode(python, map_file, seed, PARAMS.get(name, {}))
                walls[label].append(res["wall"])
                row.append(f"{res['wall']:>9.2f} {res['arrived']:>7}/{res['robots']:<7} "
                           f"{res['contacts']:>15}")
            print(f"{name:<14} {seed:>4} " + " ".join(row), flush=True)
        if "before" in walls:
            ratios = [b / a for b, a in zip(walls["before"], walls["after"], strict=True)]
            print(f"{name:<14} median before/after over {len(ratios)} episodes: "
                  f"{statistics.median(ratios):.1f}x (range {min(ratios):.1f}-"
                  f"{max(ratios):.1f}x; total {sum(walls['before']):.1f} s -> "
                  f"{sum(walls['after']):.1f} s)")
        else:
            print(f"{name:<14} total {sum(walls['after']):.1f} s over {len(seeds)} episodes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
