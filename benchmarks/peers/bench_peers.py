"""nao_arena beside RVO2 (ORCA) and AVO2 on the same scenes, in one sitting, on one core.

Scenes (nao_arena's shipped maps; every method starts from the same positions):
dense_swap and dense_swap_perturbed with n robots (``--sizes``; circle radius
max(10, 1.1 n / pi) m, bounds 10 m beyond it), crossing_streams and
crossing_streams_perturbed with n robots per stream (``--streams``). Robots:
radius 0.5 m, v_max 1.5 m/s, a_max 2 m/s^2 (nao_arena and AVO2; RVO2 has no
acceleration limit), dt 0.1 s, arrival within 0.1 m, time limit ``--time-limit``
(500 s). The perturbed maps take their start noise from ``--seed``.

Methods: ``rvo2``, ``avo2`` and ``avo2-dt`` (the peers' simulators, driven by our driver.cc,
built once with CMake, Release -O3, from the user's own checkouts: ``--rvo2 DIR``,
``--avo2 DIR`` or the environment variables RVO2_DIR, AVO2_DIR), and nao_arena's
``nao`` agent and compiled ``orca`` baseline (``--agents``). The peers' positions
after every step are re-checked with nao_arena's own swept contact check
(:class:`nao_arena.stats.EpisodeStats`, straight lines between the recorded
positions: the peers move in straight lines within a step), so contacts are
counted the same way for everybody; nao_arena's rows use the arena's own
statistics (exact over its physics substeps).

Timing: the wall time of each peer doStep (steady_clock, in the driver) and of
each whole arena step (sensing, agents, pymunk physics, statistics;
perf_counter, after an untimed warm-up: a whole 10-robot swap, then one step
of the scene), over each episode's first
``--seconds`` simulated seconds. nao_arena episodes stop there too (``cut`` in
the arrival column; their contacts then cover that span); the peers always run
to arrival or the time limit. The process and its children are pinned to one
core, numba to one thread.

Printed per scene and method: the simulated span (s) and steps, the mean wall
time per agent-step (us) with the agent-steps it is over, the worst window of
``--window`` simulated seconds (us per agent-step) with its agent-steps, the
contacts (count, deepest overlap mm) and the time at which every robot was at
its goal at once (s; ``timeout`` at the time limit, ``cut`` when stopped at
``--seconds``).

Then, for nao_arena's agents, the decision with its neighbour finding alone
beside the peer doing the same (mean us per agent-step over the same timed
steps): ``sense`` (``Arena.sensing``: neighbour lists within the sensing
range, no cap, and the bulk arrays) plus ``act_batch`` (the agent class's
``act_batch``), as ``benchmarks/bench_crowds.py`` times them
(:class:`bench_crowds.PhaseClock`), over the peer's mean doStep in the same
run (which also finds its neighbours, with its k-d tree): ``orca`` over
``rvo2``, ``nao`` over ``avo2`` and ``avo2-dt``. Run:

    python benchmarks/peers/bench_peers.py --rvo2 ~/src/RVO2 --avo2 ~/src/AVO2 \
        [--sizes 10,30,100] [--streams 20] [--seconds 500] [--seed 0] [--repeat 3]
        [--peers-only]

``--repeat K`` runs every method K times per scene, alternating, and reports each
step at its least wall time over the K runs (every run is deterministic: the same
steps, checked), which takes most of the machine's noise out of both sides alike.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
DEFAULT_BUILD = HERE / "build"

#: The peers' neighbour settings: those of their Circle examples (neighborDist 15 m,
#: maxNeighbors 10, timeHorizon 10 s, RVO2's timeHorizonObst 10 s); radius, speed
#: and acceleration are the scenes'.
PEER_SETTINGS: dict[str, float] = {
    "neighbor-dist": 15.0,
    "max-neighbors": 10,
    "time-horizon": 10.0,
    "time-horizon-obst": 10.0,
}

#: Peer methods: (driver, AVO2's accelInterval in s; None: the control period dt).
#: AVO2 bounds the velocity change of one step by maxAccel x accelInterval and then
#: takes the new velocity at once, so only accelInterval = dt keeps the acceleration
#: of a step within a_max; ``avo2`` uses its Circle example's 2 s.
PEER_METHODS: dict[str, tuple[str, float | None]] = {
    "rvo2": ("rvo2", None),
    "avo2": ("avo2", 2.0),
    "avo2-dt": ("avo2", None),
}


@dataclass(frozen=True)
class Scene:
    """A named scene: its map and robot count."""

    name: str
    map_name: str
    overrides: dict[str, Any]


@dataclass(frozen=True)
class Row:
    """One scene and method: simulated span (s), steps, robots, mean and worst-window
    wall time per agent-step (us) and the agent-steps of each, the largest speed
    (m/s) and acceleration (m/s^2) of the recorded steps, contacts, deepest
    overlap (m), arrival (text)."""

    scene: str
    method: str
    span: float
    steps: int
    robots: int
    mean_us: float
    worst_us: float
    window_steps: int
    max_speed: float
    max_accel: float
    contacts: int
    deepest: float
    arrival: str
    sense_us: float = math.nan
    act_us: float = math.nan


#: --variants: which maps of each scene run (perturbed or not).
VARIANTS: dict[str, tuple[bool, ...]] = {
    "both": (False, True),
    "symmetric": (False,),
    "perturbed": (True,),
}


def swap_scene(n: int, perturbed: bool, seed: int, time_limit: float) -> Scene:
    """dense_swap(_perturbed) with n robots, bounds 10 m beyond the circle's radius."""
    bound = max(10.0, 1.1 * n / math.pi) + 10.0
    over: dict[str, Any] = {"n": n, "lo": -bound, "hi": bound, "time_limit": time_limit}
    name = "dense_swap_perturbed" if perturbed else "dense_swap"
    if perturbed:
        over["seed"] = seed
    return Scene(f"{name} n={n}", name, over)


def streams_scene(n: int, perturbed: bool, seed: int, time_limit: float) -> Scene:
    """crossing_streams(_perturbed) with n robots per stream."""
    over: dict[str, Any] = {"n": n, "time_limit": time_limit}
    name = "crossing_streams_perturbed" if perturbed else "crossing_streams"
    if perturbed:
        over["seed"] = seed
    return Scene(f"{name} n={n}x2", name, over)


def window_figures(
    walls: np.ndarray, dt: float, window: float, robots: int
) -> tuple[float, float, int]:
    """(mean, worst-window us per agent-step, steps in the window) of per-step wall
    times (s); the window is ``window`` simulated seconds (the whole run if shorter)."""
    span = min(len(walls), max(1, round(window / dt)))
    sums = np.convolve(walls, np.ones(span), mode="valid")
    per = 1e6 / robots
    return per * float(walls.mean()), per * float(sums.max()) / span, span


def motion_peaks(path: np.ndarray, dt: float) -> tuple[float, float]:
    """(largest speed m/s, largest acceleration m/s^2) of positions (S + 1, N, 2) m
    sampled every dt s: step displacements / dt and their changes / dt, from rest."""
    v = np.diff(path, axis=0) / dt
    if not len(v):
        return 0.0, 0.0
    dv = np.diff(np.concatenate([np.zeros((1, *v.shape[1:])), v]), axis=0)
    return float(np.hypot(*v.transpose(2, 0, 1)).max()), float(
        np.hypot(*dv.transpose(2, 0, 1)).max() / dt
    )


def configured_source(build: Path) -> Path | None:
    """The source folder the CMake build folder ``build`` was configured from (None: not
    configured yet)."""
    cache = build / "CMakeCache.txt"
    if not cache.is_file():
        return None
    for line in cache.read_text(errors="replace").splitlines():
        if line.startswith("CMAKE_HOME_DIRECTORY:"):
            return Path(line.partition("=")[2]).resolve()
    return None


def build_drivers(rvo2: Path | None, avo2: Path | None, build: Path) -> dict[str, Path]:
    """Configure and build the drivers (once: CMake rebuilds only what changed);
    {peer: executable}."""
    peers = {"rvo2": rvo2, "avo2": avo2}
    for peer, src in peers.items():
        if src is not None and not (src / "src").is_dir():
            raise SystemExit(
                f"--{peer} {src}: expected a checkout of the peer (a folder with src/), not found"
            )
    defs = [f"-D{p.upper()}_DIR={s.resolve() if s else ''}" for p, s in peers.items()]
    source = configured_source(build)
    if source is not None and source != HERE:
        raise SystemExit(
            f"--build {build}: expected a build folder of {HERE} (or a new "
            f"folder), got one configured from {source}"
        )
    build.mkdir(parents=True, exist_ok=True)
    quiet = {"stdout": subprocess.DEVNULL}
    subprocess.run(
        ["cmake", "-S", str(HERE), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release", *defs],
        check=True,
        **quiet,
    )
    subprocess.run(["cmake", "--build", str(build), "-j", "1"], check=True, **quiet)
    return {p: build / f"driver_{p}" for p, s in peers.items() if s is not None}


def _arena(scene: Scene, agent: str) -> Any:
    """The scene's map with every robot running ``agent``; the maps sense what the peers
    query (the 10 nearest within 15 m)."""
    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.maps import load_map

    spec = load_map(scene.map_name, **scene.overrides)
    return Arena(spec, ArenaOptions(agent=agent))


def run_peer(
    method: str, driver: Path, scene: Scene, seed: int, seconds: float, window: float, workdir: Path
) -> tuple[Row, np.ndarray]:
    """One peer method on one scene: the driver's run, re-checked with nao_arena's
    statistics; with the wall time (s) of each timed step."""
    from nao_arena.stats import EpisodeStats

    arena = _arena(scene, "goal")
    state = arena.reset(seed)
    ids = arena.robot_ids
    starts, goals = state.positions[ids], np.asarray(arena.goals)
    radii = arena.world.radii[ids]
    robot = arena.robots[0]
    n, dt = len(ids), arena.world.dt
    ep = arena.spec.episode
    scene_file, out_file = workdir / "scene.txt", workdir / "out.bin"
    lines = [str(n)] + [
        " ".join(repr(float(v)) for v in (*s, *g)) for s, g in zip(starts, goals, strict=True)
    ]
    scene_file.write_text("\n".join(lines) + "\n")
    opts = {
        "dt": dt,
        "time-limit": ep.time_limit,
        "tolerance": ep.goal_tolerance,
        "radius": robot.radius,
        "max-speed": robot.v_max,
        "max-accel": robot.a_max,
        **PEER_SETTINGS,
    }
    if driver.name == "driver_avo2":
        interval = PEER_METHODS[method][1]
        opts["accel-interval"] = dt if interval is None else interval
    cmd = [str(driver), str(scene_file), str(out_file)]
    for key, value in opts.items():
        cmd += [f"--{key}", repr(float(value))]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    rows = np.fromfile(out_file, dtype=np.float64).reshape(-1, 1 + 2 * n)
    walls, path = rows[1:, 0], rows[:, 1:].reshape(-1, n, 2)
    steps = len(walls)
    stats = EpisodeStats(
        radii,
        ["robot"] * n,
        walls=(arena.walls, arena.wall_radius),
        dt=dt,
        velocities=np.zeros((n, 2)),
        goals=goals,
    )
    v_prev = np.zeros((n, 2))
    for k in range(steps):
        v = (path[k + 1] - path[k]) / dt
        reached = np.hypot(*(path[k + 1] - goals).T) <= ep.goal_tolerance
        stats.update(k * dt, path[k], path[k + 1], v, (v - v_prev) / dt, reached)
        v_prev = v
    timed = walls[: max(1, round(seconds / dt))]
    mean, worst, span = window_figures(timed, dt, window, n)
    all_in = np.all(np.hypot(*(path[1:] - goals).transpose(2, 0, 1)) <= ep.goal_tolerance, axis=1)
    arrival = f"{(int(np.argmax(all_in)) + 1) * dt:.1f}" if all_in.any() else "timeout"
    deepest = max((c.max_penetration for c in stats.contacts), default=0.0)
    return Row(
        scene.name,
        method,
        steps * dt,
        steps,
        n,
        mean,
        worst,
        span,
        *motion_peaks(path, dt),
        len(stats.contacts),
        deepest,
        arrival,
    ), timed


def run_arena(
    scene: Scene, agent: str, seed: int, seconds: float, window: float
) -> tuple[Row, np.ndarray]:
    """One nao_arena agent on one scene: each whole arena step timed, and its sensing
    and act_batch calls, for at most ``seconds`` simulated seconds, after the untimed
    warm-up (``bench_crowds.warm_up``) and one untimed step; with the wall time (s) of
    each timed step."""
    if str(HERE.parent) not in sys.path:
        sys.path.insert(0, str(HERE.parent))
    from bench_crowds import PhaseClock, warm_up

    warm_up(agent)
    arena = _arena(scene, agent)
    arena.reset(seed)
    arena.step()  # this scene's caches outside the timing
    arena.reset(seed)
    phases = PhaseClock(arena)
    dt, n = arena.world.dt, len(arena.robots)
    limit = max(1, round(seconds / dt))
    walls: list[float] = []
    path = [arena.state.positions[arena.robot_ids]]
    while not arena.done and len(walls) < limit:
        t0 = time.perf_counter()
        arena.step()
        walls.append(time.perf_counter() - t0)
        path.append(arena.state.positions[arena.robot_ids])
    mean, worst, span = window_figures(np.array(walls), dt, window, n)
    at_goal = bool(np.all(arena.stats.at_goal[arena.robot_ids]))
    if arena.done and at_goal:
        arrival = f"{arena.time:.1f}"
    elif arena.done:
        arrival = "timeout"
    else:
        arrival = "cut"
    contacts = arena.stats.contacts
    deepest = max((c.max_penetration for c in contacts), default=0.0)
    per = 1e6 / (n * len(walls))
    return Row(
        scene.name,
        agent,
        len(walls) * dt,
        len(walls),
        n,
        mean,
        worst,
        span,
        *motion_peaks(np.array(path), dt),
        len(contacts),
        deepest,
        arrival,
        per * phases.sums["sense"],
        per * phases.sums["act_batch"],
    ), np.array(walls)


def fastest(runs: list[tuple[Row, np.ndarray]], window: float) -> Row:
    """One row from repeated runs of the same method on the same scene (``--repeat``):
    each step's wall time is its least over the runs (the runs are deterministic: the
    same steps, contacts and arrival, checked), the mean and worst window recomputed
    from those; ``sense`` and ``act_batch`` the least of the runs' means."""
    first = runs[0][0]
    for row, _ in runs[1:]:
        if (row.steps, row.contacts, row.arrival) != (first.steps, first.contacts, first.arrival):
            raise SystemExit(
                f"{first.scene} {first.method}: repeated runs differ "
                f"({first.steps} steps, {first.contacts} contacts, arrival "
                f"{first.arrival} against {row.steps}, {row.contacts}, "
                f"{row.arrival}): expected deterministic runs"
            )
    if len(runs) == 1:
        return first
    walls = np.min(np.stack([w for _, w in runs]), axis=0)
    dt = first.span / first.steps  # the scene's control period (s)
    mean, worst, span = window_figures(walls, dt, window, first.robots)
    return replace(
        first,
        mean_us=mean,
        worst_us=worst,
        window_steps=span,
        sense_us=min(r.sense_us for r, _ in runs),
        act_us=min(r.act_us for r, _ in runs),
    )


def _ints(text: str) -> list[int]:
    return [int(s) for s in text.split(",") if s.strip()]


def _dir(value: str | None) -> Path | None:
    return Path(value).expanduser() if value else None


def pin_one_core() -> int:
    """Pin this process (and the children it starts) to one core; numba to one thread."""
    core = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    os.environ["NUMBA_NUM_THREADS"] = "1"
    os.environ["OMP_NUM_THREADS"] = "1"
    return core


def print_table(rows: list[Row], window: float) -> None:
    """The rows as a fixed-width table; window: the worst window's simulated seconds."""
    header = (
        f"{'scene':34} {'method':7} {'robots':>6} {'span s':>6} {'steps':>5} "
        f"{'mean us (agent-steps)':>22} {f'worst{window:g}s us (agent-steps)':>26} "
        f"{'v max':>5} {'a max':>5} {'contacts':>8} {'deepest mm':>10} {'all at goal s':>13}"
    )
    print(header)
    print("-" * len(header))
    for r in rows:
        mean = f"{r.mean_us:9.2f} ({r.steps * r.robots})"
        worst = f"{r.worst_us:9.2f} ({r.window_steps * r.robots})"
        print(
            f"{r.scene:34} {r.method:7} {r.robots:6d} {r.span:6.1f} {r.steps:5d} "
            f"{mean:>22} {worst:>26} {r.max_speed:5.2f} {r.max_accel:5.1f} "
            f"{r.contacts:8d} {1e3 * r.deepest:10.2f} {r.arrival:>13}"
        )


#: The peer methods each nao_arena agent's decision is set beside.
PEER_OF: dict[str, tuple[str, ...]] = {"orca": ("rvo2",), "nao": ("avo2", "avo2-dt")}


def print_decisions(rows: list[Row]) -> None:
    """For nao_arena's rows: whole step, sense, act_batch and their sum (mean us per
    agent-step), beside the mean doStep of the peer (:data:`PEER_OF`) on the same
    scene in the same run, and the sum over it."""
    header = (
        f"{'scene':34} {'agent':6} {'whole us':>9} {'sense us':>9} {'act_batch us':>12} "
        f"{'sense+act us':>12} {'peer':>7} {'doStep us':>9} {'(sense+act)/doStep':>18}"
    )
    print(
        "\nnao_arena's decision with its neighbour finding (sense + act_batch) against "
        "the peer's doStep (its own neighbour search included), mean us per agent-step"
    )
    print(header)
    print("-" * len(header))
    for r in rows:
        if math.isnan(r.sense_us):
            continue
        own = r.sense_us + r.act_us
        peers = [p for p in rows if p.scene == r.scene and p.method in PEER_OF.get(r.method, ())]
        for p in peers or [None]:
            tail = (
                f"{p.method:>7} {p.mean_us:9.2f} {own / p.mean_us:18.1f}"
                if p
                else f"{'-':>7} {'-':>9} {'-':>18}"
            )
            print(
                f"{r.scene:34} {r.method:6} {r.mean_us:9.2f} {r.sense_us:9.2f} "
                f"{r.act_us:12.2f} {own:12.2f} {tail}"
            )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--rvo2",
        default=os.environ.get("RVO2_DIR"),
        help="checkout of github.com/snape/RVO2 (or env RVO2_DIR)",
    )
    parser.add_argument(
        "--avo2",
        default=os.environ.get("AVO2_DIR"),
        help="checkout of github.com/snape/AVO2 (or env AVO2_DIR)",
    )
    parser.add_argument(
        "--build",
        default=str(DEFAULT_BUILD),
        help="build folder of the drivers (default benchmarks/peers/build)",
    )
    parser.add_argument("--sizes", default="10,30,100", help="circle swap robot counts")
    parser.add_argument("--streams", default="20", help="crossing streams: robots per stream")
    parser.add_argument("--agents", default="nao,orca", help="nao_arena agents")
    parser.add_argument(
        "--peer-methods",
        default=",".join(PEER_METHODS),
        help=f"peer methods, of {', '.join(PEER_METHODS)}",
    )
    parser.add_argument(
        "--seconds",
        type=float,
        default=500.0,
        help="simulated seconds timed (nao_arena episodes stop there)",
    )
    parser.add_argument("--time-limit", type=float, default=500.0, help="episode time limit (s)")
    parser.add_argument(
        "--window", type=float, default=10.0, help="simulated seconds of the worst window"
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="start noise of the perturbed maps and nao_arena's agents",
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="runs of every method per scene, alternating; each step's "
        "time is its least over the runs (less noise from the machine)",
    )
    parser.add_argument("--peers-only", action="store_true", help="leave nao_arena's agents out")
    parser.add_argument(
        "--variants",
        choices=sorted(VARIANTS),
        default="both",
        help="the symmetric maps, the perturbed ones or both",
    )
    args = parser.parse_args(argv)
    rvo2, avo2 = _dir(args.rvo2), _dir(args.avo2)
    if rvo2 is None and avo2 is None:
        raise SystemExit(
            "--rvo2/--avo2: expected the path of a checkout of at least one "
            "peer (or RVO2_DIR / AVO2_DIR), got neither"
        )
    methods = [m for m in args.peer_methods.split(",") if m.strip()]
    for m in methods:
        if m not in PEER_METHODS:
            raise SystemExit(
                f"--peer-methods: unknown method {m!r}, expected one of {', '.join(PEER_METHODS)}"
            )
    core = pin_one_core()
    drivers = build_drivers(rvo2, avo2, Path(args.build))
    missing = {PEER_METHODS[m][0] for m in methods} - set(drivers)
    if missing:
        raise SystemExit(
            f"--peer-methods {args.peer_methods}: needs the checkout of "
            f"{', '.join(sorted(missing))} (--{'/--'.join(sorted(missing))})"
        )
    print(
        f"# one core (cpu {core}); peers' settings: {PEER_SETTINGS}, "
        f"AVO2 accelInterval (s, None = dt): "
        f"{ {m: PEER_METHODS[m][1] for m in methods if PEER_METHODS[m][0] == 'avo2'} }",
        flush=True,
    )
    scenes = [
        make(n, p, args.seed, args.time_limit)
        for make, sizes in ((swap_scene, args.sizes), (streams_scene, args.streams))
        for n in _ints(sizes)
        for p in VARIANTS[args.variants]
    ]
    agents = [] if args.peers_only else [a for a in args.agents.split(",") if a.strip()]
    if args.repeat < 1:
        raise SystemExit(f"--repeat: expected at least 1 run, got {args.repeat}")
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            runs: dict[str, list[tuple[Row, np.ndarray]]] = {}
            for _ in range(args.repeat):  # every method once per round: noise hits all
                for method in methods:
                    driver = drivers[PEER_METHODS[method][0]]
                    runs.setdefault(method, []).append(
                        run_peer(
                            method, driver, scene, args.seed, args.seconds, args.window, Path(tmp)
                        )
                    )
                    print(f"# {runs[method][-1][0]}", flush=True)
                for agent in agents:
                    runs.setdefault(agent, []).append(
                        run_arena(scene, agent, args.seed, args.seconds, args.window)
                    )
                    print(f"# {runs[agent][-1][0]}", flush=True)
            rows += [fastest(r, args.window) for r in runs.values()]
    print_table(rows, args.window)
    if agents:
        print_decisions(rows)


if __name__ == "__main__":
    sys.exit(main())
