"""Static walls: the exact segment kernel against the same wall as a chain of discs.

One query, two ways, in the same run: K candidate accelerations against W walls (m),
minimum distance over the horizon (exact clearance) and admissibility (stop at the first
violation). The segment kernel (nao_arena.geometry._kernel.segment) takes the walls as
segments; the disc chain covers each wall with the discs the agents use
(nao_arena.geometry.walls.wall_discs, grown by the robot radius) and runs the existing
point-obstacle kernels (nao_arena.geometry._kernel.exact). Both loop over the candidates
in compiled code; figures are wall-candidate evaluations per second after a warm-up.
Run:

    python benchmarks/bench_segment.py
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from numba import njit

from nao_arena.geometry._kernel.bundles import Obstacles, Paths, Walls
from nao_arena.geometry._kernel.exact import admissible_kernel, clearance_kernel, piece_sweep
from nao_arena.geometry._kernel.segment import segments_admissible, segments_min_distance
from nao_arena.geometry.clearance import ao_path
from nao_arena.geometry.walls import wall_discs

RADIUS = 0.3  # robot radius (m)
HALF = 0.05  # wall half-thickness (m)
V_MAX = 1.5  # m/s
HORIZON = 3.0  # s


def per_call(fn: Callable[[], object], min_time: float = 1.0) -> float:
    """Seconds per call of fn, after a warm-up call (compilation, caches)."""
    fn()
    n, start = 0, time.perf_counter()
    while time.perf_counter() - start < min_time:
        fn()
        n += 1
    return (time.perf_counter() - start) / n


@njit
def _segment_clearances(v, accels, v_max, walls, half, horizon, out):
    for k in range(accels.shape[0]):
        out[k] = segments_min_distance(v, accels[k], v_max, walls, half, horizon)[0]


@njit
def _segment_admissible(v, accels, v_max, walls, half, radius, horizon, out):
    for k in range(accels.shape[0]):
        out[k] = segments_admissible(v, accels[k], v_max, walls, half, radius, 0.0, horizon)


def _walls(rng: np.random.Generator, w: int, length: float) -> np.ndarray:
    """w walls of the given length (m) with centres 1.5-6 m from the robot, random directions."""
    ang = rng.uniform(0.0, 2.0 * np.pi, w)
    dist = rng.uniform(1.5, 6.0, w)
    mid = np.stack([dist * np.cos(ang), dist * np.sin(ang)], -1)
    phi = rng.uniform(0.0, np.pi, w)
    half = 0.5 * length * np.stack([np.cos(phi), np.sin(phi)], -1)
    return np.ascontiguousarray(np.stack([mid - half, mid + half], 1))


def main() -> None:
    rng = np.random.default_rng(0)
    k = 1000
    v = np.array([0.8, 0.3])
    accels = rng.uniform(-1.5, 1.5, (k, 2))
    vv = np.ascontiguousarray(np.broadcast_to(v, accels.shape))
    print(f"K = {k} candidates, horizon {HORIZON} s, v_max {V_MAX} m/s, robot radius {RADIUS} m")
    print(
        "evaluations = candidates x walls per second (one core); speedup = disc chain time / "
        "segment time; loss = max over candidates of exact minus disc-chain clearance (m)"
    )
    print(
        f"{'W':>3} {'length m':>9} {'discs':>6} {'clear seg':>10} {'clear discs':>12} "
        f"{'speedup':>7} {'adm seg':>9} {'adm discs':>10} {'speedup':>7} {'loss m':>7}"
    )
    for w, length in ((1, 2.0), (1, 6.0), (4, 6.0), (12, 4.0)):
        walls = _walls(rng, w, length)
        half = np.full(w, HALF)
        centres, radii = wall_discs(walls, half, RADIUS)
        path = ao_path(centres, radii, horizon=HORIZON)
        sweep = piece_sweep(path.t, path.velocity, path.acceleration)
        seg_out = np.empty(k)
        seg_ok = np.empty(k, dtype=np.bool_)
        clear = np.empty((k, len(radii)))
        tmin = np.empty_like(clear)
        tfirst = np.empty_like(clear)
        disc_ok = np.empty(k, dtype=bool)
        dt_seg = per_call(
            lambda walls=walls, half=half, seg_out=seg_out: _segment_clearances(
                v, accels, V_MAX, walls, half, HORIZON, seg_out
            )
        )
        dt_disc = per_call(
            lambda path=path, clear=clear, tmin=tmin, tfirst=tfirst: clearance_kernel(
                vv,
                accels,
                V_MAX,
                Paths(*path.moving_arrays),
                Walls(path.walls, path.wall_radius),
                clear,
                tmin,
                tfirst,
            )
        )
        dt_seg_adm = per_call(
            lambda walls=walls, half=half, seg_ok=seg_ok: _segment_admissible(
                v, accels, V_MAX, walls, half, RADIUS, HORIZON, seg_ok
            )
        )
        dt_disc_adm = per_call(
            lambda path=path, sweep=sweep, disc_ok=disc_ok: admissible_kernel(
                vv,
                accels,
                V_MAX,
                Obstacles(*path.moving_arrays, sweep),
                Walls(path.walls, path.wall_radius),
                0.0,
                disc_ok,
            )
        )
        # the disc chain is conservative: its clearance (to grown discs) never exceeds the
        # exact surface clearance; the gap is what the chain gives away
        exact_clear = seg_out - RADIUS
        loss = (exact_clear - clear.min(axis=1)).max()
        evals = k * w
        print(
            f"{w:>3} {length:>9.1f} {len(radii):>6} {evals / dt_seg:>10.3g} "
            f"{evals / dt_disc:>12.3g} {dt_disc / dt_seg:>7.1f} {evals / dt_seg_adm:>9.3g} "
            f"{evals / dt_disc_adm:>10.3g} {dt_disc_adm / dt_seg_adm:>7.1f} {loss:>7.3f}"
        )
        print(
            f"{'':>4}admitted: segment {int(seg_ok.sum())} / {k}, disc chain "
            f"{int(disc_ok.sum())} / {k}"
        )


if __name__ == "__main__":
    main()
