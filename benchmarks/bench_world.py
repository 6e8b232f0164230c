"""World stepping cost per body-step against bare pymunk.

For each scene (crowd and circle_swap with 30, 100 and 300 robots) this
times, in the same run:

- bare: ``space.step(h)`` x substeps on a plain pymunk space with the same
  discs, positions and velocities (no forces, no I/O);
- world: :meth:`nao_arena.world.World.step` (command clipping, speed limit,
  batched force writes per substep, batched state read);
- world+stats: the same plus :meth:`nao_arena.stats.EpisodeStats.update` (the
  contact check over every physics substep, as the arena runs it).

Robots are driven by proportional goal seeking (plus a little noise); the
time spent computing those commands is excluded, so no agent cost is
included. Before every control step the bare space is set (untimed) to the
world's state, so both step through the same configurations and contacts.
The numba kernel of the statistics is loaded (compiled the first time)
before any timing. Times are per body-step; the ratios are to bare pymunk
in the same run; best of the repeats. The issue's target: world + stats
<= 3x bare at 100 robots.
Run: ``python benchmarks/bench_world.py [--steps 200] [--repeats 3]
[--sizes 30 100 300] [--scenes crowd circle_swap]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import pymunk

from nao_arena.maps import MapSpec, load_map
from nao_arena.stats import EpisodeStats
from nao_arena.world import World


def scene(kind: str, n: int) -> MapSpec:
    """A crowd at ~4 m^2 per robot, or a circle swap with ~1 m between neighbours."""
    if kind == "crowd":
        half = math.sqrt(4.0 * n) / 2
        return load_map("crowd", n=n, lo=-half, hi=half, seed=0)
    radius = max(8.0, n * 1.0 / (2 * math.pi))
    extent = radius + 4.0
    return load_map("circle_swap", n=n, radius=radius, lo=-extent, hi=extent)


def bare_space(world: World) -> tuple[pymunk.Space, list[pymunk.Body]]:
    """A plain pymunk space with the world's discs and walls (same material and solver)."""
    phys = world.spec.physics
    space = pymunk.Space()
    space.iterations = phys.iterations
    space.collision_slop = phys.collision_slop
    bodies = []
    for k in range(world.n):
        body = pymunk.Body(float(world.masses[k]), float("inf"))
        shape = pymunk.Circle(body, float(world.radii[k]))
        shape.elasticity = phys.elasticity
        shape.friction = phys.friction
        space.add(body, shape)
        bodies.append(body)
    segs, radii = world.wall_segments()
    for (a, b), r in zip(segs, radii, strict=True):
        space.add(pymunk.Segment(space.static_body, tuple(a), tuple(b), float(max(r, 0.01))))
    return space, bodies


def goal_seeking(
    world: World, goals: np.ndarray, pos: np.ndarray, vel: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Proportional goal seeking plus a little noise (m/s^2): the robots' commands."""
    to_goal = goals - pos
    dist = np.hypot(*to_goal.T)
    speed = np.minimum(world.v_max, np.sqrt(world.a_max * dist))
    v_target = to_goal / np.maximum(dist, 1e-9)[:, None] * speed[:, None]
    return (v_target - vel) / 0.5 + rng.normal(size=pos.shape) * 0.3


def run(spec: MapSpec, steps: int, with_stats: bool, seed: int) -> tuple[float, float]:
    """Mean seconds per control step: (bare pymunk, world.step [+ stats.update]).

    Before each control step the bare space is set (untimed) to the world's
    positions and velocities, so both step through the same configurations
    and contacts; commands are computed untimed.
    """
    world = World(spec)
    rng = np.random.default_rng(seed)
    goals = np.array([r.goal for r in spec.robots], float)
    for _ in range(30):  # get the robots moving before timing
        world.step(goal_seeking(world, goals, world.positions, world.velocities, rng))
    space, bodies = bare_space(world)
    h = world.dt / world.substeps
    no_goal = np.zeros(world.n, dtype=bool)
    stats = None
    if with_stats:
        stats = EpisodeStats(
            world.radii,
            world.kinds,
            world.names,
            world.wall_segments(),
            world.dt,
            velocities=world.velocities,
        )
    state = world.state()
    bare = spent = 0.0
    for _ in range(steps):
        for body, p, v in zip(
            bodies, state.positions.tolist(), state.velocities.tolist(), strict=True
        ):
            body.position = p
            body.velocity = v
        t0 = time.perf_counter()
        for _ in range(world.substeps):
            space.step(h)
        bare += time.perf_counter() - t0
        a = goal_seeking(world, goals, state.positions, state.velocities, rng)
        t0 = time.perf_counter()
        new = world.step(a)
        if stats is not None:
            stats.update(
                state.time,
                state.positions,
                new.positions,
                new.velocities,
                a,
                no_goal,
                substeps=world.substep_positions,
            )
        spent += time.perf_counter() - t0
        state = new
    return bare / steps, spent / steps


def warm_up() -> None:
    """Load (or compile) the numba kernels of the statistics outside any timing."""
    stats = EpisodeStats(
        [0.3, 0.3],
        ["robot", "robot"],
        dt=0.1,
        walls=(np.array([[[0.0, -1.0], [0.0, 1.0]]]), np.array([0.05])),
    )
    p = np.array([[-0.5, 0.0], [0.5, 0.0]])
    for k in range(3):
        stats.update(0.1 * k, p, p * 0.5, -p, np.zeros((2, 2)), np.zeros(2, bool))


def measure(kind: str, n: int, steps: int, repeats: int) -> dict[str, float]:
    """Best-of-repeats seconds per control step: bare pymunk, world, world + stats."""
    spec = scene(kind, n)
    best = {"bare": math.inf, "world": math.inf, "stats": math.inf}
    for rep in range(repeats):
        for label in ("world", "stats"):
            bare, spent = run(spec, steps, label == "stats", rep)
            best["bare"] = min(best["bare"], bare)
            best[label] = min(best[label], spent)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="control steps per timing")
    parser.add_argument("--repeats", type=int, default=3, help="best of this many")
    parser.add_argument("--sizes", type=int, nargs="+", default=[30, 100, 300])
    parser.add_argument("--scenes", nargs="+", default=["crowd", "circle_swap"])
    args = parser.parse_args()
    warm_up()
    print(
        f"pymunk {pymunk.version}; dt 0.1 s, 10 substeps; best of {args.repeats} x "
        f"{args.steps} steps"
    )
    print("us per body-step: bare pymunk, world.step, world.step + stats.update, and the")
    print("difference (stats alone); ratios to bare pymunk in the same run")
    print("target: world+stats/bare <= 3 at N = 100")
    header = (
        f"{'scene':<12}{'N':>5}{'bare':>8}{'world':>8}{'+stats':>8}{'stats':>8}"
        f"{'world/bare':>12}{'world+stats/bare':>18}"
    )
    print(header)
    print("-" * len(header))
    for kind in args.scenes:
        for n in args.sizes:
            r = measure(kind, n, args.steps, args.repeats)
            per = {k: v / n * 1e6 for k, v in r.items()}
            print(
                f"{kind:<12}{n:>5}{per['bare']:>8.2f}{per['world']:>8.2f}{per['stats']:>8.2f}"
                f"{per['stats'] - per['world']:>8.2f}"
                f"{r['world'] / r['bare']:>12.2f}{r['stats'] / r['bare']:>18.2f}"
            )


if __name__ == "__main__":
    main()
