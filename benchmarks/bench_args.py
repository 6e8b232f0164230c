"""Command-line arguments of the benchmark scripts: the command line's parser whose
errors are one line on stderr and exit status 2 (no usage; ``OneLineParser``), and
integer arguments checked by range."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any, TypeVar

from nao_arena._cli_common import OneLineParser

__all__ = ["OneLineParser", "best_of_alternating", "non_negative", "positive", "robot_counts"]

Run = TypeVar("Run", bound=tuple[Any, ...])


def _at_least(text: str, low: int) -> int:
    try:
        value = int(text)
    except ValueError:
        value = low - 1
    if value < low:
        raise argparse.ArgumentTypeError(f"expected an integer >= {low}, got {text!r}")
    return value


def positive(text: str) -> int:
    """An integer >= 1 (argparse type)."""
    return _at_least(text, 1)


def non_negative(text: str) -> int:
    """An integer >= 0 (argparse type)."""
    return _at_least(text, 0)


def robot_counts(text: str) -> list[int]:
    """Comma-separated integers >= 1, at least one (argparse type)."""
    counts = [positive(part) for part in text.split(",") if part.strip()]
    if not counts:
        raise argparse.ArgumentTypeError(f"expected robot counts >= 1, got {text!r}")
    return counts


def best_of_alternating(
    timed: Callable[[bool], Run],
    repeats: int,
    label: str,
    warm_up: Callable[[bool], object] | None = None,
) -> tuple[Run, Run]:
    """A measured way against its baseline in the same run: each once untimed first
    (``warm_up``, default ``timed``: every kernel loaded), then ``repeats`` runs of each,
    alternating, ``timed(False)`` the way measured and ``timed(True)`` the baseline.
    Each run is a tuple, its time first and its trajectory hash last. Returns the best
    (least time) of each; SystemExit naming ``label`` when some run's trajectory differs."""
    warm = warm_up or timed
    warm(False)
    warm(True)
    measured: list[Run] = []
    baseline: list[Run] = []
    for _ in range(repeats):
        measured.append(timed(False))
        baseline.append(timed(True))
    if {run[-1] for run in measured + baseline} != {measured[0][-1]}:
        raise SystemExit(f"{label}: the two ways gave different trajectories")
    return min(measured), min(baseline)
