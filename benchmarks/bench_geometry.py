"""Geometry speed: clearance evaluations per second and selection time.

Figures are printed next to a baseline measured in the same run: a
vectorised numpy check of the distance at the sample times only (the
cheap, inexact test that the exact kernel replaces). Run:

    python benchmarks/bench_geometry.py
"""

from __future__ import annotations

import time

import numpy as np

from nao_arena.geometry import AccelLimits, path_clearance, sampled_path, select_acceleration
from nao_arena.geometry._kernel.bundles import Obstacles, Walls
from nao_arena.geometry._kernel.exact import admissible_kernel, piece_sweep


def _timeit(fn, min_time: float = 1.0) -> float:
    fn()  # warm-up (compilation, caches) outside the timing
    n, start = 0, time.perf_counter()
    while time.perf_counter() - start < min_time:
        fn()
        n += 1
    return (time.perf_counter() - start) / n


def _scene(rng: np.random.Generator, n: int, t: np.ndarray) -> np.ndarray:
    """n obstacles on circular arcs within ~3-20 m of the robot (m)."""
    ang0 = rng.uniform(0, 2 * np.pi, n)[:, None]
    rad = rng.uniform(3, 20, n)[:, None]
    om = rng.uniform(-0.5, 0.5, n)[:, None]
    off = rng.normal(0, 3, 2)
    return np.stack([rad * np.cos(ang0 + om * t), rad * np.sin(ang0 + om * t)], -1) + off


def numpy_samples_only(accels, v, t, centers, radius):
    """Baseline: min over the sample times only of distance - radius, (K, N)."""
    x = v[None, None, :] * t[None, :, None] + 0.5 * accels[:, None, :] * t[None, :, None] ** 2
    d = np.linalg.norm(x[:, None, :, :] - centers[None], axis=-1)
    return d.min(axis=-1) - radius


def main() -> None:
    rng = np.random.default_rng(0)
    t = np.linspace(0, 4, 40)
    v = np.array([2.0, 0.5])
    print("clearance evaluations (K candidates x N obstacles x T samples per second), one core")
    print(
        f"{'K':>6} {'N':>4} {'T':>4} {'exact':>10} {'admissible':>11} {'numpy@samples':>14} "
        f"{'exact/numpy':>12}"
    )
    for k, n in ((1000, 10), (1000, 30), (200, 100)):
        c = _scene(rng, n, t)
        path = sampled_path(t, c, 1.0)
        a = rng.uniform(-3, 3, (k, 2))
        evals = k * n * len(t)
        dt_exact = _timeit(lambda a=a, path=path: path_clearance(a, v, path))
        sweep = piece_sweep(path.t, path.velocity, path.acceleration)
        ok = np.empty(k, dtype=bool)
        vv = np.ascontiguousarray(np.broadcast_to(v, a.shape))
        dt_adm = _timeit(
            lambda a=a, path=path, sweep=sweep, ok=ok, vv=vv: admissible_kernel(
                vv,
                a,
                np.inf,
                Obstacles(*path.moving_arrays, sweep),
                Walls(path.walls, path.wall_radius),
                0.0,
                ok,
            )
        )
        dt_np = _timeit(lambda a=a, c=c: numpy_samples_only(a, v, t, c, 1.0))
        print(
            f"{k:>6} {n:>4} {len(t):>4} {evals / dt_exact:>10.3g} {evals / dt_adm:>11.3g} "
            f"{evals / dt_np:>14.3g} {dt_np / dt_exact:>12.2f}"
        )
    print()
    print("selection: nearest admissible acceleration, T = 40, a_max = 3 m/s^2 (200 scenes)")
    print(
        f"{'N':>4} {'median ms':>10} {'p90 ms':>8} {'max ms':>8} {'desired':>8} "
        f"{'adjusted':>9} {'infeasible':>11} {'vs 1 exact clearance':>21}"
    )
    limits = AccelLimits(3.0)
    for n in (10, 30):
        times, status = [], {"desired": 0, "adjusted": 0, "infeasible": 0}
        one = []
        for _ in range(200):
            path = sampled_path(t, _scene(rng, n, t), 1.0)
            vel = rng.normal(0, 2, 2)
            des = rng.normal(0, 2, 2)
            select_acceleration(des, vel, path, limits)
            start = time.perf_counter()
            sel = select_acceleration(des, vel, path, limits)
            times.append(time.perf_counter() - start)
            status[sel.status] += 1
            start = time.perf_counter()
            path_clearance(des, vel, path)
            one.append(time.perf_counter() - start)
        ms = 1e3 * np.array(times)
        ratio = np.median(times) / np.median(one)
        print(
            f"{n:>4} {np.median(ms):>10.3f} {np.percentile(ms, 90):>8.3f} {ms.max():>8.3f} "
            f"{status['desired']:>8} {status['adjusted']:>9} {status['infeasible']:>11} "
            f"{ratio:>20.1f}x"
        )


if __name__ == "__main__":
    main()
