"""Dense crowds: wall time of the arena step per agent-step, by agent and by phase.

Scenes: dense_swap_perturbed with n robots (``--sizes``; the circle has radius
R = max(10, 1.1 n / pi) m, the bounds are lo/hi = -(R + 10), R + 10 m, so
-360/360 m for n = 1000) and crossing_streams_perturbed with n robots per
stream (``--streams``). Every robot runs the same agent (``--agents``:
built-in names or plug-in references, optionally ``label=reference``; the
default nao, orca, goal).

For each scene and agent, in one process: an untimed warm-up (:func:`warm_up`:
a whole 10-robot swap, so that every compiled kernel is loaded before timing) and
one untimed step of the scene, then a fresh episode from the same seed, each
step timed for its first ``--seconds`` simulated seconds or until it ends. Printed per row: the
steps timed, the mean wall time per agent-step (us: total / (steps x
robots)), the worst window of ``--window`` simulated seconds (the largest sum
of wall time over that many consecutive steps / (steps x robots); the whole
run if shorter), whether the episode ended (every robot at its goal) and,
where ``goal`` is among the agents, both figures over those of ``goal`` in
the same run (goal seeking: no avoidance, so the ratio is what avoidance
costs on top of the rest of the step).

Where the time goes (:class:`PhaseClock`, mean us per agent-step over the
same steps): ``sense`` (``Arena.sensing``: neighbour lists within the
sensing range and the bulk arrays), ``agents`` (from the end of sensing to
the start of the period: the agents' decisions and the arena's checks of
them), of which ``act_batch`` (the agent classes' ``act_batch`` calls alone),
``period`` (``Arena._period``: pymunk at its substeps, the arrival check and the
statistics' swept contact check and metrics, in one compiled call,
:mod:`nao_arena.period`) and ``rest`` (the whole step less those three: the
trajectory hash, the result).

Then, for each agent, how its mean cost per agent-step scales with n on the
dense swaps: the ratio between consecutive sizes and the exponent k of a
least-squares fit of log(cost per agent-step) = k log(n) + c over the sizes
run (k = 0: total cost linear in n; k = 1: quadratic), for the whole step and
for each phase. The robots start 2.2 m apart along the circle at every n, but a
robot covers up to about 1.5 t m in t s, so the smaller circles reach their
crowded centre sooner: n = 100 (R = 35 m) is well into it at 20 s. For the
cost of the same crowd at each n, time a span all sizes spend approaching
(``--seconds 10`` for n >= 100). Run:

    python benchmarks/bench_crowds.py [--sizes 100,300,1000] [--streams 20] [--seconds 20]
        [--agents nao,orca,goal] [--seed 0] [--window 10]

``--sizes ''`` or ``--streams ''`` leaves that map out.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass
from itertools import pairwise
from types import SimpleNamespace
from typing import Any

import numpy as np

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import MapSpec, load_map

#: The phases of an arena step that :class:`PhaseClock` times (``rest`` is the whole
#: step less these).
PHASES = ("sense", "agents", "period")


class PhaseClock:
    """Wall time (s) of the phases of an arena's steps, summed over the steps from when
    it is attached (after the arena's last reset: a reset makes new statistics).

    Times by wrapping, on this arena's own objects only (nothing else is changed):
    ``arena.sensing`` (``sense``), ``arena._period`` (``period``; ``agents`` is the time
    from the end of sensing to its start) and the agent classes' ``act_batch`` as the
    arena calls it (``act_batch``)."""

    def __init__(self, arena: Arena) -> None:
        self.sums: dict[str, float] = dict.fromkeys((*PHASES, "act_batch"), 0.0)
        self._sensed = 0.0
        clock = time.perf_counter
        sums = self.sums
        sensing, period, act_batch = arena.sensing, arena._period, arena._act_batch

        def timed_sensing() -> Any:
            t0 = clock()
            out = sensing()
            self._sensed = t1 = clock()
            sums["sense"] += t1 - t0
            return out

        def timed_period(state: Any, commanded: Any) -> Any:
            t0 = clock()
            sums["agents"] += t0 - self._sensed
            out = period(state, commanded)
            sums["period"] += clock() - t0
            return out

        def timed_act_batch(cls: type, batch: Any, rows: list[int]) -> Any:
            inner = cls.act_batch

            def call(agents: Any, batch_: Any, rows_: Any) -> Any:
                t0 = clock()
                out = inner(agents, batch_, rows_)
                sums["act_batch"] += clock() - t0
                return out

            # the arena's checks run as they are; only the class's act_batch is timed
            return act_batch(SimpleNamespace(act_batch=call), batch, rows)

        arena.sensing = timed_sensing  # type: ignore[method-assign]
        arena._period = timed_period  # type: ignore[method-assign]
        arena._act_batch = timed_act_batch  # type: ignore[method-assign]


def swap_spec(n: int) -> MapSpec:
    """dense_swap_perturbed with n robots, bounds R + 10 m around its circle of radius R."""
    bound = max(10.0, 1.1 * n / math.pi) + 10.0
    return load_map("dense_swap_perturbed", n=n, lo=-bound, hi=bound)


@dataclass(frozen=True)
class Timing:
    """An episode's timed steps: steps, robots, mean and worst-window us per agent-step,
    whether it ended, mean us per agent-step by phase (with ``act_batch`` and ``rest``)."""

    steps: int
    robots: int
    mean_us: float
    worst_us: float
    ended: bool
    phases: dict[str, float]


_WARM: set[str] = set()


def warm_up(agent: str) -> None:
    """Run ``agent`` once through a whole 10-robot circle swap (dense_swap, at most 60
    simulated seconds), untimed: the compiled kernels its steps call load (from numba's
    cache, or compile) here, not inside a timed step. A kernel first called midway
    through a timed episode (one step does not reach them all: the keep test has
    nothing to keep at the start) adds its loading, about 20 ms, to one step."""
    if agent in _WARM:
        return
    arena = Arena(load_map("dense_swap", n=10), ArenaOptions(agent=agent))
    arena.reset(0)
    while not arena.done and arena.time < 60.0:
        arena.step()
    _WARM.add(agent)


def time_episode(spec: MapSpec, agent: str, seed: int, seconds: float, window: float) -> Timing:
    """The first ``seconds`` simulated seconds of an episode timed step by step (and
    phase by phase, :class:`PhaseClock`), after :func:`warm_up` and one untimed step
    of this scene."""
    warm_up(agent)
    arena = Arena(spec, ArenaOptions(agent=agent))
    arena.reset(seed)
    arena.step()  # this scene's caches outside the timing
    arena.reset(seed)
    phases = PhaseClock(arena)
    robots = len(arena.robots)
    limit = max(1, round(seconds / arena.world.dt))
    walls: list[float] = []
    while not arena.done and len(walls) < limit:
        t0 = time.perf_counter()
        arena.step()
        walls.append(time.perf_counter() - t0)
    w = np.array(walls)
    span = min(len(w), max(1, round(window / arena.world.dt)))
    sums = np.convolve(w, np.ones(span), mode="valid")
    per = 1e6 / robots
    by_phase = {name: per * total / len(w) for name, total in phases.sums.items()}
    by_phase["rest"] = per * float(w.mean()) - sum(by_phase[p] for p in PHASES)
    return Timing(
        len(w), robots, per * float(w.mean()), per * float(sums.max()) / span, arena.done, by_phase
    )


@dataclass(frozen=True)
class Row:
    """One scene and agent, and its timing."""

    scene: str
    agent: str
    timing: Timing


def scaling(sizes: list[int], costs: list[float]) -> tuple[list[float], float]:
    """(ratios of consecutive costs, exponent k of the least-squares fit of
    log(cost) = k log(size) + c) of costs per agent-step at increasing sizes; k is NaN
    with fewer than two sizes
    or a cost <= 0."""
    ratios = [b / a for a, b in pairwise(costs)]
    if len(sizes) < 2 or min(costs) <= 0.0:
        return ratios, math.nan
    k = float(np.polyfit(np.log(sizes), np.log(costs), 1)[0])
    return ratios, k


def _agents(text: str) -> list[tuple[str, str]]:
    """``label=ref`` or ``ref`` items, comma separated: (label, ref) pairs."""
    out = []
    for item in filter(None, (s.strip() for s in text.split(","))):
        label, _, ref = item.rpartition("=")
        out.append((label or ref, ref))
    return out


def _sizes(text: str) -> list[int]:
    return [int(s) for s in text.split(",") if s.strip()]


def print_rows(rows: list[Row]) -> None:
    """The rows: whole step (mean, worst window, both over goal's) and mean by phase."""
    header = (
        f"{'scene':36} {'agent':8} {'robots':>6} {'steps':>6} {'ended':>5} "
        f"{'mean us':>9} {'worst us':>9} {'mean/goal':>9} {'worst/goal':>10} | "
        f"{'sense':>7} {'agents':>7} {'(act_b)':>7} {'period':>7} {'rest':>7}"
    )
    print(header)
    print("-" * len(header))
    for r in rows:
        t = r.timing
        base = next((b.timing for b in rows if b.scene == r.scene and b.agent == "goal"), None)
        ratio_mean = f"{t.mean_us / base.mean_us:9.2f}" if base else f"{'-':>9}"
        ratio_worst = f"{t.worst_us / base.worst_us:10.2f}" if base else f"{'-':>10}"
        phases = " ".join(
            f"{t.phases[p]:7.1f}" for p in ("sense", "agents", "act_batch", "period", "rest")
        )
        print(
            f"{r.scene:36} {r.agent:8} {t.robots:6d} {t.steps:6d} {str(t.ended):>5} "
            f"{t.mean_us:9.1f} {t.worst_us:9.1f} {ratio_mean} {ratio_worst} | {phases}"
        )


def print_scaling(rows: list[Row], sizes: list[int]) -> None:
    """Per agent, over the dense swaps at ``sizes``: the ratios of the mean whole-step
    cost per agent-step between consecutive sizes and the fitted exponent k of
    cost ~ n^k, for the whole step and each phase."""
    if len(sizes) < 2:
        print("\nscaling with n: needs at least two --sizes")
        return
    order = sorted(set(sizes))
    parts = ("whole", "sense", "agents", "act_batch", "period")
    steps = [f"{a}->{b}" for a, b in pairwise(order)]
    print(
        f"\ncost per agent-step against n, dense_swap_perturbed n = "
        f"{', '.join(map(str, order))}: mean ratio between consecutive sizes; k of "
        f"cost ~ n^k (least squares on log-log over those {len(order)} sizes; "
        f"k = 0: total cost linear in n)"
    )
    header = (
        f"{'agent':8} "
        + " ".join(f"{s:>10}" for s in steps)
        + " | "
        + " ".join(f"{'k ' + p:>11}" for p in parts)
    )
    print(header)
    print("-" * len(header))
    agents = list(dict.fromkeys(r.agent for r in rows))
    for agent in agents:
        by_n = {
            int(r.scene.split("n=")[1]): r.timing
            for r in rows
            if r.agent == agent and r.scene.startswith("dense_swap")
        }
        if any(n not in by_n for n in order):
            continue
        timings = [by_n[n] for n in order]
        ratios, _ = scaling(order, [t.mean_us for t in timings])
        ks = [
            scaling(order, [t.mean_us if p == "whole" else t.phases[p] for t in timings])[1]
            for p in parts
        ]
        print(
            f"{agent:8} "
            + " ".join(f"{x:10.2f}" for x in ratios)
            + " | "
            + " ".join(f"{k:11.2f}" for k in ks)
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,300", help="dense swap robot counts")
    parser.add_argument("--streams", default="20", help="crossing streams: robots per stream")
    parser.add_argument("--agents", default="nao,orca,goal")
    parser.add_argument(
        "--seconds", type=float, default=60.0, help="simulated seconds timed per episode (at most)"
    )
    parser.add_argument(
        "--window", type=float, default=10.0, help="simulated seconds of the worst window"
    )
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    sizes = _sizes(args.sizes)
    scenes = [(f"dense_swap_perturbed n={n}", swap_spec(n)) for n in sizes]
    scenes += [
        (f"crossing_streams_perturbed n={n}x2", load_map("crossing_streams_perturbed", n=n))
        for n in _sizes(args.streams)
    ]
    rows: list[Row] = []
    for scene, spec in scenes:
        for label, ref in _agents(args.agents):
            t = time_episode(spec, ref, args.seed, args.seconds, args.window)
            rows.append(Row(scene, label, t))
            print(f"# {scene} {label}: {t.steps} steps, {t.mean_us:.1f} us", flush=True)
    print(
        "\nmean and worst-window us per agent-step of the whole step | mean us per "
        "agent-step by phase (act_b: the agents' act_batch, within agents)"
    )
    print_rows(rows)
    print_scaling(rows, sizes)


if __name__ == "__main__":
    main()
