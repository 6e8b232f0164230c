"""Wall time of NAO episodes on maps with walls, this checkout against an earlier one.

Each episode runs in its own process (warm numba caches: a 3-step episode first, outside
the timing) on this checkout's map, loaded here and handed over with its robots written
out (no layout builder needed), so an earlier checkout that still treats walls as chains
of discs runs the very same scene. Runs alternate between the two
interpreters seed by seed, in one sitting. Prints wall time per episode, the median
ratio per map, and the outcomes beside them (robots at their goal, contacts), so a
faster run that fails shows as such.

    python benchmarks/bench_walls.py --before-python /path/to/old/checkout/.venv/bin/python
    python benchmarks/bench_walls.py --maps two_lane_road,doorway_perturbed --seeds 0,1,2,3,4

Without --before-python only this checkout runs (its times alone, no ratio).
The earlier interpreter must have its checkout installed (``pip install -e .``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

EPISODE = r"""
import json, sys, time
from nao_arena.arena import Arena
from nao_arena.maps import map_from_dict
seed = int(sys.argv[1])
arena = Arena(map_from_dict(json.loads(sys.stdin.read())))
arena.run(seed=seed, max_steps=3)  # compile / load the kernels outside the timing
start = time.perf_counter()
summary = arena.run(seed=seed)
wall = time.perf_counter() - start
print(json.dumps({"wall": wall, "steps": summary.steps,
                  "arrived": sum(bool(r.success) for r in summary.robots),
                  "robots": len(summary.robots), "contacts": len(summary.contacts)}))
"""

PARAMS = {"doorway_perturbed": {"agent": "nao"}, "two_lane_road": {"agent": "nao"}}
"""Map parameters per scene (the doorway's defaults: 10 robots on each side)."""


def scene(name: str, seed: int, params: dict) -> str:
    """Map ``name`` for ``seed`` as JSON with its robots written out."""
    from nao_arena.trials import make_map

    spec = make_map(name, seed, params).model_dump(mode="json", exclude_none=True)
    for key in ("source", "parameters"):
        spec.pop(key, None)
    return json.dumps(spec)


def run_episode(python: str, spec: str, seed: int) -> dict:
    """One timed episode of the map ``spec`` (JSON) in a fresh process of ``python``."""
    out = subprocess.run(
        [python, "-c", EPISODE, str(seed)],
        input=spec,
        capture_output=True,
        text=True,
        check=False,
        cwd="/",
    )
    if out.returncode != 0:
        raise SystemExit(f"{python}: episode seed {seed} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before-python", help="interpreter of the earlier checkout")
    ap.add_argument("--maps", default="two_lane_road,doorway_perturbed")
    ap.add_argument("--seeds", default="0,1,2,3,4")
    args = ap.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    pythons = {"after": sys.executable}
    if args.before_python:
        pythons = {"before": args.before_python, **pythons}
    print(
        f"{'map':<18} {'seed':>4} "
        + " ".join(
            f"{k + ' s':>9} {'ms/step':>8} {k + ' arrived':>15} {k + ' contacts':>15}"
            for k in pythons
        )
    )
    for name in args.maps.split(","):
        walls: dict[str, list[float]] = {k: [] for k in pythons}
        per_step: dict[str, list[float]] = {k: [] for k in pythons}
        for seed in seeds:
            row = []
            spec = scene(name, seed, PARAMS.get(name, {}))
            for label, python in pythons.items():
                res = run_episode(python, spec, seed)
                walls[label].append(res["wall"])
                per_step[label].append(res["wall"] / res["steps"])
                row.append(
                    f"{res['wall']:>9.2f} {1e3 * res['wall'] / res['steps']:>8.2f} "
                    f"{res['arrived']:>7}/{res['robots']:<7} {res['contacts']:>15}"
                )
            print(f"{name:<18} {seed:>4} " + " ".join(row), flush=True)
        if "before" in walls:
            ratios = [b / a for b, a in zip(walls["before"], walls["after"], strict=True)]
            step_ratios = [
                b / a for b, a in zip(per_step["before"], per_step["after"], strict=True)
            ]
            print(
                f"{name:<18} before/after over {len(ratios)} episodes: episode wall time "
                f"median {statistics.median(ratios):.1f}x (range {min(ratios):.1f}-"
                f"{max(ratios):.1f}x; total {sum(walls['before']):.1f} s -> "
                f"{sum(walls['after']):.1f} s), per step median "
                f"{statistics.median(step_ratios):.1f}x"
            )
        else:
            print(f"{name:<18} total {sum(walls['after']):.1f} s over {len(seeds)} episodes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
