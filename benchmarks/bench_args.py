"""Command-line arguments of the benchmark scripts: the command line's parser whose
errors are one line on stderr and exit status 2 (no usage; ``OneLineParser``), and
integer arguments checked by range."""

from __future__ import annotations

import argparse

from nao_arena._cli_common import OneLineParser

__all__ = ["OneLineParser", "non_negative", "positive", "robot_counts"]


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
