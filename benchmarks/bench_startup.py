"""Start-up cost: cold (empty numba cache) and warm wall time, CPU time and peak memory.

Workloads, each run as a fresh child process:

- ``run``: ``nao-arena run roundabout`` (a whole episode, the map's 40 s time limit);
- ``trial``: ``nao-arena trial --map crossing --agent nao --episodes 2 --workers 1
  --seed 0 --out DIR`` (one worker: the episodes run in the child itself);
- ``env``: ``python -c`` importing nao_arena, ``nao_arena.parallel_env("circle_swap")``,
  ``reset(seed=0)`` and one ``step`` with random actions from the action spaces;
- ``gif``: ``nao-arena run crossing --render gif --out DIR/x.gif --max-steps 20``.

Cold: ``NUMBA_CACHE_DIR`` points to a fresh, empty folder of that workload and kernel
source only. With the kernel source ``shipped`` (what a first run does), the
precompiled kernels shipped for this Python (:mod:`nao_arena.precompiled`) are written
into it and whatever they lack is compiled; with ``compiled``
(``NAO_ARENA_PRECOMPILED=0``: a Python, numba or platform without shipped kernels, or
changed sources), every kernel the workload needs is compiled. Warm: the same command
again with the same folder, so the kernels are loaded from it. Only the numba cache is
cold: Python's bytecode and the operating system's file cache are warm in both. Every
run gets its own output folder (``trial`` would otherwise resume its results).

Per run, of the child and the descendants it waited for: wall time (s, from starting
the child to reaping it), CPU time (s, user + system, from ``os.wait4``) and peak
resident memory (MB = 2^20 bytes, ``ru_maxrss`` from ``os.wait4``: the largest of
the child and those descendants, not their sum). The warm figures are those of the
warm run with the least wall time (``--repeat-warm K`` runs, default 3); the cold ones
are from a single run; the ``n`` columns give the number of runs. ``cold/warm`` is the
ratio of the wall times. The CPU count and the load average (1 min) before and after
the runs tell whether the machine was busy. After the table, the numba cache each
workload wrote (files, MB) and the cache files a warm run added (should be 0: else
it compiled again, e.g. because a source file changed while the benchmark ran).
A child that fails (non-zero exit status) has its stderr tail printed; the benchmark
then goes on with the other workloads and exits with status 1.
Run: ``python benchmarks/bench_startup.py [--only run,env] [--kernels shipped,compiled]
[--repeat-warm 3]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ENV_CODE = """\
import nao_arena
env = nao_arena.parallel_env("circle_swap")
env.reset(seed=0)
actions = {}
for i, agent in enumerate(env.agents):
    space = env.action_space(agent)
    space.seed(i)
    actions[agent] = space.sample()
env.step(actions)
env.close()
"""
"""The ``env`` workload's child program: build, reset and step the circle_swap env."""


@dataclass(frozen=True)
class Measurement:
    """One child process run: wall time (s), CPU time user + system (s), peak RSS (MB)."""

    wall_s: float
    cpu_s: float
    peak_mb: float
    status: int
    """Exit status (negative: killed by that signal)."""
    stderr_tail: str


@dataclass(frozen=True)
class Workload:
    """A command to time; ``argv(run_dir)`` builds it with a fresh output folder."""

    name: str
    argv: Callable[[Path], list[str]]


def cli() -> list[str]:
    """The ``nao-arena`` script next to this interpreter, else ``python -m nao_arena.cli``."""
    script = Path(sys.executable).with_name("nao-arena")
    if script.is_file() and os.access(script, os.X_OK):
        return [str(script)]
    return [sys.executable, "-m", "nao_arena.cli"]


TRIAL_ARGS = "trial --map crossing --agent nao --episodes 2 --workers 1 --seed 0"
GIF_ARGS = "run crossing --render gif --max-steps 20"


def workloads() -> dict[str, Workload]:
    """The four workloads by name, in the order they run."""
    nao = cli()
    return {
        w.name: w
        for w in (
            Workload("run", lambda d: [*nao, "run", "roundabout"]),
            Workload("trial", lambda d: [*nao, *TRIAL_ARGS.split(), "--out", str(d / "trial")]),
            Workload("env", lambda d: [sys.executable, "-c", ENV_CODE]),
            Workload("gif", lambda d: [*nao, *GIF_ARGS.split(), "--out", str(d / "x.gif")]),
        )
    }


def maxrss_mb(maxrss: int) -> float:
    """``ru_maxrss`` in MB (2^20 bytes): kilobytes on Linux, bytes on macOS."""
    return maxrss / 2**20 if sys.platform == "darwin" else maxrss / 2**10


def tail(path: Path, lines: int = 20) -> str:
    """The last ``lines`` lines of the text file ``path``."""
    return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])


KERNEL_SOURCES = {"shipped": "1", "compiled": "0"}
"""Kernel source -> the value of ``NAO_ARENA_PRECOMPILED`` the children get."""


def measure(argv: list[str], cache_dir: Path, run_dir: Path, source: str) -> Measurement:
    """Run ``argv`` in ``run_dir`` with ``NUMBA_CACHE_DIR=cache_dir`` and the kernel
    source ``source`` (:data:`KERNEL_SOURCES`); its costs."""
    run_dir.mkdir(parents=True)
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(cache_dir),
        "NAO_ARENA_PRECOMPILED": KERNEL_SOURCES[source],
    }
    out_path, err_path = run_dir / "stdout.txt", run_dir / "stderr.txt"
    with out_path.open("wb") as out, err_path.open("wb") as err:
        start = time.perf_counter()
        proc = subprocess.Popen(
            argv, cwd=run_dir, env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=err
        )
        _, wait_status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(wait_status)  # reaped here, not by Popen
    return Measurement(
        wall_s=wall,
        cpu_s=usage.ru_utime + usage.ru_stime,
        peak_mb=maxrss_mb(usage.ru_maxrss),
        status=proc.returncode,
        stderr_tail=tail(err_path) if proc.returncode != 0 else "",
    )


def cache_files(cache_dir: Path) -> tuple[int, float]:
    """(number of files, total size in MB) of the numba cache folder ``cache_dir``."""
    files = [p for p in cache_dir.rglob("*") if p.is_file()]
    return len(files), sum(p.stat().st_size for p in files) / 2**20


@dataclass(frozen=True)
class Result:
    """A workload's cold run, its warm runs and what its numba cache holds."""

    name: str
    source: str
    """Where its cold run's kernels came from (:data:`KERNEL_SOURCES`)."""
    cold: Measurement
    warm: list[Measurement]
    cache_after_cold: tuple[int, float]
    """(files, MB) of the numba cache after the cold run."""
    added_by_warm: int
    """Cache files the warm runs added (0 unless they compiled again)."""

    @property
    def failed(self) -> bool:
        return any(m.status != 0 for m in (self.cold, *self.warm))

    @property
    def best_warm(self) -> Measurement | None:
        """The successful warm run with the least wall time (None if there is none)."""
        ok = [m for m in self.warm if m.status == 0]
        return min(ok, key=lambda m: m.wall_s) if ok else None


def report_failure(name: str, label: str, m: Measurement, argv: list[str]) -> None:
    """A failed run's command, exit status and stderr tail, on stderr."""
    print(
        f"{name} ({label}) FAILED with exit status {m.status}: {' '.join(argv)}\n"
        f"stderr tail:\n{m.stderr_tail}",
        file=sys.stderr,
    )


def bench(workload: Workload, source: str, root: Path, repeat_warm: int) -> Result:
    """Cold run, then ``repeat_warm`` warm runs, of ``workload`` with the kernel source
    ``source`` and a cache of its own."""
    folder = root / f"{workload.name}_{source}"
    cache_dir = folder / "numba_cache"
    cache_dir.mkdir(parents=True)
    runs: list[Measurement] = []
    caches: list[tuple[int, float]] = []
    for i in range(1 + repeat_warm):
        label = "cold" if i == 0 else f"warm {i}"
        run_dir = folder / f"run{i}"
        argv = workload.argv(run_dir)
        m = measure(argv, cache_dir, run_dir, source)
        runs.append(m)
        caches.append(cache_files(cache_dir))
        print(
            f"  {workload.name:<6} {source:<8} {label:<7} {m.wall_s:7.2f} s wall "
            f"{m.cpu_s:7.2f} s CPU "
            f"{m.peak_mb:7.1f} MB peak, exit {m.status}, load {os.getloadavg()[0]:.2f}",
            flush=True,
        )
        if m.status != 0:
            report_failure(workload.name, label, m, argv)
            if i == 0:
                break  # no warm runs after a failed cold one
    return Result(
        name=workload.name,
        source=source,
        cold=runs[0],
        warm=runs[1:],
        cache_after_cold=caches[0],
        added_by_warm=caches[-1][0] - caches[0][0],
    )


HEADER = (
    f"{'workload':<9} {'kernels':<8} {'cold wall s':>11} {'cold CPU s':>10} {'cold peak MB':>12} "
    f"{'n':>2} {'warm wall s':>11} {'warm CPU s':>10} {'warm peak MB':>12} {'n':>2} "
    f"{'cold/warm':>9} {'n':>5}"
)


def row(r: Result) -> str:
    """A table row: the cold run, the best warm run (n: runs each is from), the ratio."""
    c, w = r.cold, r.best_warm
    cold = (
        f"{c.wall_s:11.2f} {c.cpu_s:10.2f} {c.peak_mb:12.1f} {1:>2}"
        if c.status == 0
        else f"{'failed':>11} {'':>10} {'':>12} {1:>2}"
    )
    n_warm = sum(m.status == 0 for m in r.warm)
    if w is None:
        name = f"{r.name:<9} {r.source:<8}"
        return f"{name} {cold} {'-':>11} {'':>10} {'':>12} {n_warm:>2} {'-':>9} {'':>5}"
    ratio = f"{c.wall_s / w.wall_s:9.1f}" if c.status == 0 else f"{'-':>9}"
    return (
        f"{r.name:<9} {r.source:<8} {cold} {w.wall_s:11.2f} {w.cpu_s:10.2f} {w.peak_mb:12.1f} "
        f"{n_warm:>2} {ratio} {f'1:{n_warm}':>5}"
    )


def print_table(results: list[Result]) -> None:
    """The table, then each workload's numba cache size and what the warm runs added."""
    print(HEADER)
    print("-" * len(HEADER))
    for r in results:
        print(row(r))
    print("(warm: the run with the least wall time of n; cold/warm n: cold runs:warm runs)")
    for r in results:
        files, mb = r.cache_after_cold
        print(
            f"numba cache of {r.name} ({r.source}): {files} files, {mb:.1f} MB after the cold run; "
            f"the warm runs added {r.added_by_warm} files"
        )


def parse_args(names: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--only",
        default=",".join(names),
        help=f"comma-separated workloads (default: {','.join(names)})",
    )
    parser.add_argument(
        "--kernels",
        default=",".join(KERNEL_SOURCES),
        help="comma-separated kernel sources of the cold runs: shipped (the precompiled "
        "kernels loaded), compiled (every kernel compiled); default: both",
    )
    parser.add_argument(
        "--repeat-warm",
        type=int,
        default=3,
        metavar="K",
        help="warm runs per workload; the least wall time is reported",
    )
    args = parser.parse_args()
    args.only = [n.strip() for n in args.only.split(",") if n.strip()]
    if unknown := [n for n in args.only if n not in names]:
        parser.error(
            f"--only: unknown workload(s) {', '.join(unknown)}; expected some of {', '.join(names)}"
        )
    args.kernels = [n.strip() for n in args.kernels.split(",") if n.strip()]
    if not args.kernels or (unknown := [n for n in args.kernels if n not in KERNEL_SOURCES]):
        parser.error(f"--kernels: expected some of {', '.join(KERNEL_SOURCES)}, got {args.kernels}")
    if args.repeat_warm < 1:
        parser.error(f"--repeat-warm: expected an integer >= 1, got {args.repeat_warm}")
    return args


def cpu_note() -> str:
    """The machine's CPU count (and this process's usable CPUs, where known)."""
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return f"{os.cpu_count()} CPUs" + (f" ({usable} usable)" if usable is not None else "")


def main() -> int:
    table = workloads()
    args = parse_args(list(table))
    print(
        f"start-up cost of {', '.join(args.only)}: 1 cold + {args.repeat_warm} warm runs "
        f"each; command {' '.join(cli())}; Python {sys.version.split()[0]}; {cpu_note()}; "
        f"load average (1, 5, 15 min) before: "
        f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}",
        flush=True,
    )
    with tempfile.TemporaryDirectory(prefix="bench_startup_") as tmp:
        results = [
            bench(table[name], source, Path(tmp), args.repeat_warm)
            for name in args.only
            for source in args.kernels
        ]
    print()
    print_table(results)
    print(
        f"{cpu_note()}; load average (1, 5, 15 min) after: "
        f"{', '.join(f'{x:.2f}' for x in os.getloadavg())} (other processes inflate the "
        "wall times; CPU times less so)"
    )
    return 1 if any(r.failed for r in results) else 0


if __name__ == "__main__":
    raise SystemExit(main())
