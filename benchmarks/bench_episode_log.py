"""Episode logs: size per robot-step and the cost of logging every step.

For each scene, the same episode (map, seed, agents) runs unlogged and logged,
alternately, ``--repeats`` times each in this process; the logged time includes
recording every step, building the log and writing it (Parquet, zstd, atomic).
Printed per scene: the median wall times, the overhead of logging in % of the
unlogged episode's time (target: <= 20 %) from the medians and from the
fastest runs (less sensitive to other load on the machine), the part of the
logged time spent after the episode (building and writing the log), the
file size in bytes per robot-step (robots x log rows) and per body-step
(bodies, traffic included), and the time to read the log back. The
trajectories are checked to be the same.
Run: ``python benchmarks/bench_episode_log.py [--repeats 5] [--scenes NAME,...]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.episode_log import EpisodeRecorder, read_log, write_log
from nao_arena.trials import make_map

SCENES = {
    # name: (map, map parameters, agent (None: the map's), seed)
    "swap10-nao": ("circle_swap", {"n": 10}, None, 0),
    "swap30-nao": ("circle_swap", {"n": 30, "radius": 10.5}, None, 0),
    "roundabout-nao": ("roundabout", {}, None, 0),
    "crossing-nao": ("crossing", {}, None, 0),
    "swap10-goal": ("circle_swap_perturbed", {"n": 10}, "goal", 0),
    "swap30-orca": ("circle_swap", {"n": 30, "radius": 10.5}, "orca", 0),
}


def episode(scene: str, folder: Path | None) -> tuple[float, float, str, int, int, int]:
    """(wall time s, of which after the episode s, trajectory hash, log bytes, log rows,
    bodies) of one episode, logged into ``folder`` if given."""
    map_name, params, agent, seed = SCENES[scene]
    spec = make_map(map_name, seed, params)
    start = time.perf_counter()
    arena = Arena(spec, ArenaOptions(agent=agent))
    if folder is not None:
        arena.recorder = EpisodeRecorder()
    summary = arena.run(seed)
    ran = time.perf_counter()
    size = rows = 0
    if folder is not None:
        assert arena.recorder is not None
        log = arena.recorder.finish(arena, summary)
        path = write_log(log, folder / f"{scene}.parquet")
        rows = log.n_steps
    end = time.perf_counter()
    if folder is not None:
        size = path.stat().st_size
    return end - start, end - ran, summary.trajectory_hash, size, rows, arena.world.n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--scenes", default=",".join(SCENES), help=f"comma-separated, from {', '.join(SCENES)}"
    )
    args = parser.parse_args()
    print(
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}; "
        f"{args.repeats} runs of each scene unlogged and logged, alternating; medians"
    )
    head = (
        f"{'scene':15s} {'robots':>6s} {'bodies':>6s} {'rows':>5s} {'plain s':>8s} "
        f"{'logged s':>8s} {'overhead':>9s} {'(fastest)':>9s} {'write s':>7s} "
        f"{'B/robot-step':>12s} {'B/body-step':>11s} {'read s':>7s}"
    )
    print(head)
    print("-" * len(head))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for scene in args.scenes.split(","):
            episode(scene, folder)  # warm-up: kernels, imports, caches
            plain, logged, ends = [], [], []
            for _ in range(args.repeats):
                t0, _, h0, _, _, _ = episode(scene, None)
                t1, end, h1, size, rows, bodies = episode(scene, folder)
                assert h0 == h1, f"{scene}: logging changed the trajectory"
                plain.append(t0)
                logged.append(t1)
                ends.append(end)
            start = time.perf_counter()
            log = read_log(folder / f"{scene}.parquet")
            read = time.perf_counter() - start
            robots = len(log.robots)
            p, q = statistics.median(plain), statistics.median(logged)
            fastest = 100 * (min(logged) - min(plain)) / min(plain)
            print(
                f"{scene:15s} {robots:6d} {bodies:6d} {rows:5d} {p:8.3f} {q:8.3f} "
                f"{100 * (q - p) / p:8.1f}% {fastest:8.1f}% {statistics.median(ends):7.3f} "
                f"{size / (robots * rows):12.1f} {size / (bodies * rows):11.1f} "
                f"{read:7.3f}"
            )


if __name__ == "__main__":
    main()
