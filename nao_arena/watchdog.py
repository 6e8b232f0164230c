"""A wall-clock budget for an episode, so that a stuck agent cannot hang a run or a trial.

:func:`wall_clock_budget` is a context manager: if its block runs longer
than ``seconds`` of wall-clock time, :class:`EpisodeTimeout` is raised in
it (and raised again every second until the block exits, so that an agent
that catches it once is still stopped). EpisodeTimeout derives from
BaseException: the loop's containment of agent failures (which contains
every other exception but KeyboardInterrupt) lets it through.

The time numba spends compiling kernels inside the block does not count
(:func:`nao_arena.kernels.compile_seconds`): a cold kernel cache or a busy
machine while compiling changes no result.

It uses ``SIGALRM`` and ``signal.setitimer(ITIMER_REAL)``; the previous
SIGALRM handler and timer are restored when the block exits.

Limitations: the budget is enforced only on the main thread of a process on
a platform with SIGALRM (Linux, macOS); elsewhere (Windows, or a block run
on another thread) it does nothing and the block runs to its end. Python
checks for signals between bytecodes, so a loop that never returns to the
interpreter (inside a C extension or a compiled numba function) is stopped
only when it does.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

from nao_arena.kernels import compile_seconds, watch_compiles

__all__ = ["EpisodeTimeout", "budget_available", "wall_clock_budget"]

_REPEAT = 1.0
"""Interval (s) at which EpisodeTimeout is raised again after the budget is spent."""


class EpisodeTimeout(BaseException):
    """An episode ran longer than its wall-clock budget (s)."""

    def __init__(self, seconds: float) -> None:
        super().__init__(f"episode exceeded its wall-clock budget of {seconds:g} s")
        self.seconds = seconds

    def __reduce__(self) -> tuple[type[EpisodeTimeout], tuple[float]]:
        return EpisodeTimeout, (self.seconds,)


def budget_available() -> bool:
    """Whether :func:`wall_clock_budget` is enforced here (SIGALRM, on the main thread)."""
    return (
        hasattr(signal, "SIGALRM")
        and hasattr(signal, "setitimer")
        and threading.current_thread() is threading.main_thread()
    )


@contextmanager
def wall_clock_budget(seconds: float | None) -> Iterator[bool]:
    """Raise :class:`EpisodeTimeout` in the block once it has run ``seconds`` (s, wall clock).

    ``seconds`` None or 0: no budget. Yields whether the budget is enforced
    (see the module's limitations). Raises ValueError for a negative or
    non-finite ``seconds``.
    """
    if seconds is not None and not 0 <= seconds < float("inf"):
        raise ValueError(f"wall-clock budget: expected a number of s >= 0, got {seconds}")
    if not seconds or not budget_available():
        yield False
        return
    budget = float(seconds)
    watch_compiles()
    started = time.monotonic()
    compiled_before = compile_seconds()

    def expired(signum: int, frame: FrameType | None) -> None:
        # the budget's time is the wall clock less the kernels' compiles in the meantime
        left = budget - (time.monotonic() - started - (compile_seconds() - compiled_before))
        if left > 0.0:
            signal.setitimer(signal.ITIMER_REAL, left, _REPEAT)
            return
        raise EpisodeTimeout(budget)

    previous_handler = signal.signal(signal.SIGALRM, expired)
    previous_delay, previous_interval = signal.setitimer(signal.ITIMER_REAL, budget, _REPEAT)
    try:
        yield True
    finally:
        try:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
        finally:
            signal.signal(signal.SIGALRM, previous_handler)
            if previous_delay > 0.0:
                # an outer timer keeps running for what remains of it
                left = previous_delay - (time.monotonic() - started)
                signal.setitimer(signal.ITIMER_REAL, max(left, 1e-6), previous_interval)
