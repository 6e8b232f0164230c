"""Trial throughput: episodes per minute on ``roundabout`` with 1 and 2 workers.

The scene: the map's two robots driven by ``nao`` and its 30 traffic
vehicles (lane followers). The episode length is the map's own time limit
(it declares no parameter for it, so it is not overridden); an episode also
ends when both robots have arrived, so the mean simulated duration is
printed too. Each measurement is a full :func:`nao_arena.trials.run_trial`
(pool start-up, result files and the final Parquet/summary included) in a
fresh temporary folder, with the same episodes for every worker count.
Run: ``python benchmarks/bench_trials.py [--episodes 16] [--workers 1,2]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from nao_arena.maps import load_map
from nao_arena.trials import TrialConfig, run_trial


def measure(episodes: int, workers: int, seed: int) -> tuple[float, float, float]:
    """(wall time s, mean simulated episode duration s, mean in-episode wall time s)."""
    with tempfile.TemporaryDirectory() as tmp:
        config = TrialConfig(
            maps=("roundabout",),
            agents=("nao",),
            episodes=episodes,
            seed=seed,
            workers=workers,
            out=Path(tmp),
        )
        start = time.perf_counter()
        run_trial(config, progress=None)
        wall = time.perf_counter() - start
        records = [json.loads(p.read_text()) for p in (Path(tmp) / "episodes").glob("*.json")]
    durations = [r["result"]["duration"] for r in records if r["result"] is not None]
    sim = sum(durations) / max(len(durations), 1)
    per_episode = sum(r["wall_time_s"] for r in records) / max(len(records), 1)
    return wall, sim, per_episode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    spec = load_map("roundabout")
    print(
        f"roundabout: {spec.n_robots} robots (nao), {sum(g.count for g in spec.traffic)} "
        f"traffic vehicles, time limit {spec.episode.time_limit:g} s (the map's own), "
        f"dt {spec.physics.dt:g} s; {args.episodes} episodes per run; "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} before the runs"
    )
    # warm-up: numba caches and imports in this process
    measure(1, 1, args.seed + 1)
    rates: dict[int, float] = {}
    for w in (int(x) for x in args.workers.split(",")):
        wall, sim, per_episode = measure(args.episodes, w, args.seed)
        rates[w] = args.episodes / wall * 60.0
        print(
            f"workers {w}: {wall:6.1f} s wall, {rates[w]:6.1f} episodes/min "
            f"(mean simulated episode {sim:.1f} s, {per_episode:.2f} s wall inside a worker, "
            f"{sim / per_episode:.1f}x real time)"
        )
    if 1 in rates:
        for w, r in rates.items():
            if w != 1:
                print(f"scaling {w} workers / 1 worker: {r / rates[1]:.2f}x")
    print(
        f"load average after the runs {os.getloadavg()[0]:.2f} (other processes on the "
        "machine distort the scaling)"
    )


if __name__ == "__main__":
    main()
