"""Compiling the numba kernels from the command line (:mod:`nao_arena.cli`): the compile
messages on stderr, the progress of a compile ahead, and ``nao-arena compile``."""

from __future__ import annotations

import argparse
import contextlib
import logging
import sys
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


def compile_parts(parts: list[str], jobs: int | None = None, force: bool = False) -> None:
    """Compile the kernels of ``parts`` ahead of time in ``jobs`` processes (default:
    every core) when the cache lacks some of them (``force``: look at each anyway),
    after loading the shipped precompiled ones it lacks; nothing when they are cached or
    when the environment sets ``NAO_ARENA_COMPILE_AHEAD=0``. The progress and the
    summary are logged (:func:`nao_arena.kernels.compile_ahead`): on stderr within
    :func:`_compile_messages`."""
    from nao_arena.kernels import ahead_enabled, compile_ahead, ensure_compiled, load_shipped

    if force:
        if ahead_enabled():
            load_shipped(parts)
        compile_ahead(parts, jobs)
    else:
        ensure_compiled(parts, jobs)


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
