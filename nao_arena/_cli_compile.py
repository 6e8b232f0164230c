"""Compiling the numba kernels from the command line (:mod:`nao_arena.cli`): the compile
messages on stderr, the progress of a compile ahead, and ``nao-arena compile``."""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import sys
import time
from collections.abc import Iterable, Iterator

from nao_arena._cli_common import _err, _split


@contextlib.contextmanager
def _compile_messages() -> Iterator[None]:
    """While the block runs: the kernels' compile messages (:mod:`nao_arena.kernels`,
    INFO) are printed on stderr as ``nao-arena: ...``."""
    from nao_arena.kernels import LOG, watch_compiles

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("nao-arena: %(message)s"))
    handler.setLevel(logging.INFO)
    level = LOG.level
    LOG.addHandler(handler)
    LOG.setLevel(logging.INFO)
    watch_compiles()
    try:
        yield
    finally:
        LOG.removeHandler(handler)
        LOG.setLevel(level)


class _CompileProgress:
    """``on_done`` of :func:`nao_arena.kernels.compile_ahead`: one line on stderr at
    most every :data:`~nao_arena.kernels.PROGRESS_INTERVAL` s (and at the end): kernels
    done of all, seconds so far."""

    def __init__(self) -> None:
        self.started = time.monotonic()
        self.shown = -math.inf

    def __call__(self, done: int, total: int, key: str) -> None:
        now = time.monotonic()
        from nao_arena.kernels import PROGRESS_INTERVAL

        if done < total and now - self.shown < PROGRESS_INTERVAL:
            return
        self.shown = now
        name = key.partition("(")[0]
        print(
            f"nao-arena: compiled {done}/{total} kernels in {now - self.started:.0f} s "
            f"(last: {name})",
            file=sys.stderr,
            flush=True,
        )


def compile_parts(parts: list[str], jobs: int | None = None, force: bool = False) -> None:
    """Compile the kernels of ``parts`` ahead of time in ``jobs`` processes (default:
    every core) when the cache lacks some of them (``force``: look at each anyway),
    with progress on stderr; nothing when they are cached or when the environment sets
    ``NAO_ARENA_COMPILE_AHEAD=0``."""
    from nao_arena.kernels import compile_ahead, ensure_compiled

    progress = _CompileProgress()
    report = (
        compile_ahead(parts, jobs, on_done=progress)
        if force
        else ensure_compiled(parts, jobs, on_done=progress)
    )
    if report is None:
        return
    cached = " (cached for later runs)" if report.compiled else ""
    print(f"nao-arena: {report.summary(cached)}", file=sys.stderr, flush=True)


def _parts(agents: Iterable[str], render: bool = False) -> list[str]:
    """The kernel parts (:mod:`nao_arena.kernels`) of an episode with these agents."""
    from nao_arena.kernels import parts_for_agents

    return [*parts_for_agents(agents), *(["render"] if render else [])]


def _cmd_compile(args: argparse.Namespace) -> int:
    from nao_arena.agent import BUILTIN_AGENTS
    from nao_arena.kernels import RECORD_PARTS, parts_for_agents

    if args.jobs is not None and args.jobs < 1:
        return _err(f"--jobs: expected an integer >= 1, got {args.jobs}")
    parts = list(RECORD_PARTS)
    if args.agent:
        unknown = [a for a in _split(args.agent) if a not in BUILTIN_AGENTS]
        if unknown:
            return _err(
                f"--agent: expected built-in agents ({', '.join(BUILTIN_AGENTS)}), "
                f"got {', '.join(unknown)}"
            )
        parts = parts_for_agents(_split(args.agent))
    compile_parts(parts, args.jobs, force=True)
    return 0
