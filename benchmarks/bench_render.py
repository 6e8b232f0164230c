"""Headless rendering speed: frames per second at 1200 x 800 with the panel on.

For two_lane_road and corridor (maps with walls) and circle_swap (no walls)
this times, in the same run, :meth:`nao_arena.render.Viewer.draw` (headless,
``SDL_VIDEODRIVER=dummy``, the acceleration panel of robot 0) after one
warm-up frame, and the arena's own step (the agents included) as the
baseline: the ratio is frames per second / steps per second. The arena is
advanced (untimed) between frames so that each frame shows a new state.
Best of the repeats. The issue's target: >= 20 frames per second on maps
with walls.
Run: ``python benchmarks/bench_render.py [--frames 10] [--repeats 3]
[--maps two_lane_road corridor circle_swap] [--profile]``.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import time

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

from nao_arena.arena import Arena  # noqa: E402
from nao_arena.maps import load_map  # noqa: E402
from nao_arena.render import Viewer  # noqa: E402


def measure(name: str, frames: int, repeats: int) -> tuple[float, float]:
    """(frames per second, arena steps per second) of map ``name``, best of ``repeats``."""
    arena = Arena(load_map(name))
    arena.reset(0)
    viewer = Viewer()
    viewer.draw(arena)  # warm-up: fonts, numba kernels, caches
    arena.step()
    best_draw = best_step = float("inf")
    for _ in range(repeats):
        draw = step = 0.0
        for _ in range(frames):
            t0 = time.perf_counter()
            arena.step()
            t1 = time.perf_counter()
            viewer.draw(arena)
            t2 = time.perf_counter()
            step += t1 - t0
            draw += t2 - t1
        best_draw = min(best_draw, draw / frames)
        best_step = min(best_step, step / frames)
    return 1.0 / best_draw, 1.0 / best_step


def profile(name: str, frames: int) -> None:
    """cProfile of ``frames`` frames of map ``name`` (the top 25 by cumulative time)."""
    arena = Arena(load_map(name))
    arena.reset(0)
    viewer = Viewer()
    viewer.draw(arena)
    prof = cProfile.Profile()
    for _ in range(frames):
        arena.step()
        prof.enable()
        viewer.draw(arena)
        prof.disable()
    print(f"--- {name}")
    pstats.Stats(prof).sort_stats("cumulative").print_stats(25)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--maps", nargs="+", default=["two_lane_road", "corridor", "circle_swap"])
    ap.add_argument("--profile", action="store_true", help="print a cProfile instead")
    args = ap.parse_args()
    if args.profile:
        for name in args.maps:
            profile(name, args.frames)
        return
    print(f"{'map':<16} {'frames/s':>9} {'steps/s':>9} {'ratio':>7}")
    for name in args.maps:
        fps, sps = measure(name, args.frames, args.repeats)
        print(f"{name:<16} {fps:9.1f} {sps:9.1f} {fps / sps:7.3f}")


if __name__ == "__main__":
    main()
