"""RL throughput with random actions on one core: the vector envs against the bare env.

circle_swap_v0 with its default 10 robots, all controlled, stepped with random actions
(uniform in [-1, 1], pre-drawn with a seeded numpy generator), measured in the same run:

- bare: one ``load("circle_swap_v0").parallel_env(keep_finished=True)`` stepped with a
  dict of actions (``env.step({agent: action})``, the dict built in the timed loop),
  reset (no seed) when ``env.agents`` is empty: the baseline;
- vector K: ``nao_arena.vector.VectorEnv("circle_swap_v0", K, seed=0)``, ``step`` with
  actions (K, 10, 2), auto-reset inside, for every K of ``--copies``;
- sb3 vector / sb3 supersuit: ``nao_arena.sb3.vec_env("circle_swap_v0", copies=K,
  seed=0, backend=...)``, SB3 vector envs with one entry per robot stepped with actions
  (K * 10, 2), K = ``--sb3-copies`` (skipped with a note without the ``rl`` extra);
- vmas N: VMAS's ``navigation`` scenario with 10 agents and N batched envs on the CPU
  (``vmas.make_env(..., continuous_actions=True, n_agents=10, seed=0)``), stepped with 10
  tensors (N, 2) of random actions within each agent's action space, never reset, for
  every N of ``--vmas-envs`` (skipped with a note when vmas is not installed). VMAS is
  another simulator with another scene: its row says how fast a batched torch simulator
  steps 10 agents, not how it would run this scene.

PyTorch runs on one thread (``torch.set_num_threads(1)``); the numba kernels of
nao_arena run on one thread anyway. An env step is one control period of one copy (all
its agents); a vector step is K env steps. Every runner makes ``--steps`` vector steps
per repeat, the runners one after another in each of ``--repeats`` interleaved repeats
(so all see the same machine load); the rates are those of each runner's best repeat.
Construction, the first reset and ``--warmup`` steps (numba compiles on first use) are
not timed, and the NAO agent's kernels are loaded first; the resets at the end of an
episode (circle_swap_v0: every 400 steps, as random actions bring few robots to their
goals) are timed, and so is the NAO agent of every robot that reached its goal (the
env's default ``after_done="agent"`` drives a finished robot by its own agent). The
default ``--steps``, 400, is one such episode: every repeat times one reset of every
copy, whichever repeat is the best (VMAS's envs are never reset). Every
row gives the agent-steps it timed beside its rates, and its agent-steps/s against the
bare row's and, when VMAS ran, the best VMAS row's.
Run: ``python benchmarks/bench_vector_env.py [--copies 1 4 16 64] [--sb3-copies 16]
[--vmas-envs 1 256] [--steps 400] [--repeats 3] [--warmup 20] [--json PATH]``
(VMAS: ``pip install vmas``).
"""

from __future__ import annotations

import importlib
import json
import os
import platform
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from bench_args import OneLineParser, non_negative, positive

from nao_arena.atomic import atomic_write_text
from nao_arena.envs import load
from nao_arena.kernels import parts_for_agents, preload
from nao_arena.vector import VectorEnv

ENV = "circle_swap_v0"


@dataclass
class Runner:
    """One row: ``step(s)`` makes vector step s (of ``len`` pre-drawn actions)."""

    name: str
    copies: int  # env steps per vector step
    agents: int  # agents per copy
    step: Callable[[int], Any]
    close: Callable[[], Any]
    vmas: bool = False
    best: float = float("inf")  # seconds of the best repeat


@dataclass
class Row:
    runner: str
    env_steps: int
    agent_steps: int
    seconds: float
    env_steps_per_s: float
    agent_steps_per_s: float
    x_bare: float
    x_vmas: float | None


def uniform(seed: int, shape: tuple[int, ...]) -> np.ndarray:
    """Random actions in [-1, 1], float32 like the envs' action spaces."""
    return np.random.default_rng(seed).uniform(-1.0, 1.0, shape).astype(np.float32)


def bare_runner(steps: int, seed: int) -> Runner:
    env = load(ENV).parallel_env(keep_finished=True)
    agents = list(env.possible_agents)
    acts = uniform(seed, (steps, len(agents), 2))
    env.reset(seed=seed)

    def step(s: int) -> None:
        if not env.agents:
            env.reset()
        env.step(dict(zip(agents, acts[s], strict=True)))

    return Runner("bare", 1, len(agents), step, env.close)


def vector_runner(copies: int, steps: int, seed: int) -> Runner:
    vec = VectorEnv(ENV, copies, seed=seed)
    acts = uniform(seed, (steps, copies, vec.num_agents, 2))
    vec.reset()
    return Runner(
        f"vector K={copies}", copies, vec.num_agents, lambda s: vec.step(acts[s]), vec.close
    )


def sb3_runner(sb3: Any, backend: str, copies: int, steps: int, seed: int) -> Runner:
    vec = sb3.vec_env(ENV, copies=copies, seed=seed, backend=backend)
    agents = vec.num_envs // copies
    acts = uniform(seed, (steps, vec.num_envs, 2))
    vec.reset()
    return Runner(
        f"sb3 {backend} K={copies}", copies, agents, lambda s: vec.step(acts[s]), vec.close
    )


def vmas_runner(vmas: Any, torch: Any, num_envs: int, agents: int, steps: int, seed: int) -> Runner:
    env = vmas.make_env(
        "navigation",
        num_envs=num_envs,
        device="cpu",
        continuous_actions=True,
        wrapper=None,
        n_agents=agents,
        seed=seed,
    )
    env.reset()
    low = np.array([space.low for space in env.action_space], dtype=np.float32)
    high = np.array([space.high for space in env.action_space], dtype=np.float32)
    if low.shape != (agents, 2) or not (np.isfinite(low).all() and np.isfinite(high).all()):
        raise RuntimeError(f"vmas navigation: unexpected action spaces {env.action_space}")
    # (steps, agents, N, 2): every agent's (N, 2) block contiguous, mapped onto its bounds
    u = uniform(seed, (steps, agents, num_envs, 2))
    u = low[None, :, None] + (u + 1.0) / 2.0 * (high - low)[None, :, None]
    tensor = torch.from_numpy(np.ascontiguousarray(u, dtype=np.float32))
    acts = [list(tensor[s].unbind(0)) for s in range(steps)]
    return Runner(
        f"vmas N={num_envs}", num_envs, agents, lambda s: env.step(acts[s]), lambda: None, True
    )


def time_runner(runner: Runner, steps: int) -> float:
    """Seconds for ``steps`` vector steps."""
    step = runner.step
    t0 = time.perf_counter()
    for s in range(steps):
        step(s)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--copies", type=positive, nargs="+", default=[1, 4, 16, 64], help="K of the vector env"
    )
    parser.add_argument("--sb3-copies", type=positive, default=16, help="K of the SB3 rows")
    parser.add_argument(
        "--vmas-envs", type=positive, nargs="+", default=[1, 256], help="N of the VMAS rows"
    )
    parser.add_argument("--steps", type=positive, default=400, help="vector steps per repeat")
    parser.add_argument("--repeats", type=positive, default=3)
    parser.add_argument("--warmup", type=non_negative, default=20, help="untimed steps")
    parser.add_argument("--seed", type=non_negative, default=0)
    parser.add_argument("--json", metavar="PATH", help="write the results as JSON")
    args = parser.parse_args(argv)
    if args.json and os.path.isdir(args.json):
        parser.error(f"--json: {args.json} is a folder, expected a file name")
    warnings.simplefilter("ignore", UserWarning)  # PettingZoo's and Gym's advice
    steps = args.steps
    notes: list[str] = []

    runners = [bare_runner(steps, args.seed)]
    runners += [vector_runner(k, steps, args.seed) for k in dict.fromkeys(args.copies)]
    try:
        sb3 = importlib.import_module("nao_arena.sb3")
    except ImportError as exc:
        notes.append(f"sb3 rows skipped: {exc} (pip install -e '.[rl]')")
    else:
        for backend in ("vector", "supersuit"):
            runners.append(sb3_runner(sb3, backend, args.sb3_copies, steps, args.seed))
    try:
        vmas = importlib.import_module("vmas")
        torch = importlib.import_module("torch")
    except ImportError as exc:
        notes.append(f"vmas rows skipped: {exc} (pip install vmas)")
    else:
        torch.set_num_threads(1)
        agents = runners[0].agents
        for n in dict.fromkeys(args.vmas_envs):
            runners.append(vmas_runner(vmas, torch, n, agents, steps, args.seed))
    for note in notes:
        print(note, flush=True)

    # the kernels of the robots' own agent (NAO drives the robots that finish) load now,
    # not when the first robot finishes inside a timed repeat
    preload(parts_for_agents(["nao"]))
    try:
        for runner in runners:  # numba, torch and the caches warm up
            for s in range(args.warmup):
                runner.step(s % steps)
        for _ in range(args.repeats):
            for runner in runners:
                runner.best = min(runner.best, time_runner(runner, steps))
    finally:
        for runner in runners:
            runner.close()

    def rate(runner: Runner) -> float:
        return steps * runner.copies * runner.agents / runner.best

    base = rate(runners[0])
    vmas_best = max((rate(r) for r in runners if r.vmas), default=None)
    rows = [
        Row(
            runner=r.name,
            env_steps=steps * r.copies,
            agent_steps=steps * r.copies * r.agents,
            seconds=r.best,
            env_steps_per_s=steps * r.copies / r.best,
            agent_steps_per_s=rate(r),
            x_bare=rate(r) / base,
            x_vmas=None if vmas_best is None else rate(r) / vmas_best,
        )
        for r in runners
    ]
    load_avg = os.getloadavg() if hasattr(os, "getloadavg") else None
    print(
        f"{ENV}: {runners[0].agents} agents, all controlled; {steps} vector steps per "
        f"repeat, best of {args.repeats}, {args.warmup} warm-up steps; "
        f"{os.cpu_count()} cores, load average "
        f"{'n/a' if load_avg is None else ' '.join(f'{x:.2f}' for x in load_avg)}"
    )
    print()
    print(table(rows, vmas_best is not None))
    if args.json:
        data = {
            "env": ENV,
            "agents": runners[0].agents,
            "steps": steps,
            "repeats": args.repeats,
            "warmup": args.warmup,
            "seed": args.seed,
            "cores": os.cpu_count(),
            "load_average": load_avg,
            "python": platform.python_version(),
            "notes": notes,
            "rows": [asdict(row) for row in rows],
        }
        atomic_write_text(args.json, json.dumps(data, indent=1) + "\n")
    return 0


def table(rows: list[Row], with_vmas: bool) -> str:
    """The rows as a markdown table."""
    head = ["runner", "env steps", "agent-steps", "s", "env steps/s", "agent-steps/s", "x bare"]
    if with_vmas:
        head.append("x vmas")
    align = [":---"] + ["---:"] * (len(head) - 1)  # names left, figures right
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(align) + "|"]
    for r in rows:
        cells = [
            r.runner,
            str(r.env_steps),
            str(r.agent_steps),
            f"{r.seconds:.3f}",
            f"{r.env_steps_per_s:.0f}",
            f"{r.agent_steps_per_s:.0f}",
            f"{r.x_bare:.2f}",
        ]
        if with_vmas:
            cells.append(f"{r.x_vmas:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
