"""What the ``nao-arena`` sub-commands share (:mod:`nao_arena.cli`): the one-line error,
the checks of numbers, output paths and displays, the agents loaded ahead, and the
handler that stops a run or a trial like Ctrl-C."""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NoReturn

RENDER_SUFFIX = {"gif": ".gif", "mp4": ".mp4"}


class OneLineParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose errors are one line, ``PROG: error: MESSAGE (PROG
    --help)``, without the usage block, and exit status 2 (its sub-command parsers are of
    this class too)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _err(message: str) -> int:
    print(f"nao-arena: error: {message}", file=sys.stderr)
    return 2


def _split(text: str) -> tuple[str, ...]:
    return tuple(part.strip() for part in text.split(",") if part.strip())


def _plural(n: int, noun: str, nouns: str | None = None) -> str:
    """``1 robot``, ``2 robots`` (``nouns``: the plural, if not ``noun`` + s)."""
    return f"{n} {noun}" if n == 1 else f"{n} {nouns or noun + 's'}"


def _timeout(text: str) -> float | None:
    """``--episode-timeout``: seconds >= 0, or ``none`` / 0 for no budget."""
    if text.strip().lower() in ("none", "0", ""):
        return None
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(
            f"expected a number of seconds >= 0 (0 or none: no budget), got {text!r}"
        )
    return value or None


def _overrides(items: list[str] | None) -> dict[str, Any]:
    from nao_arena.maps import parse_overrides

    return parse_overrides(items or [])


_RANGES = {  # option -> (expectation, test) of the numbers of `run` and `trial`
    "seed": ("an integer >= 0", lambda v: v >= 0),
    "time_limit": ("a number of seconds > 0 and <= 100000", lambda v: 0 < v <= 1e5),
    "max_steps": ("an integer >= 1", lambda v: v >= 1),
    "fps": ("a finite number > 0", lambda v: 0 < v < math.inf),
    "episodes": ("an integer >= 1", lambda v: v >= 1),
    "workers": ("an integer >= 1", lambda v: v >= 1),
    "max_faults": ("an integer >= 0", lambda v: v >= 0),
}


def _bad_number(args: argparse.Namespace) -> str | None:
    """The first numeric option given out of its range, as an error message (else None)."""
    for name, (expected, ok) in _RANGES.items():
        value = getattr(args, name, None)
        if value is not None and not ok(value):
            return f"--{name.replace('_', '-')}: expected {expected}, got {value}"
    return None


def _unwritable(path: str, folder: bool = False) -> str | None:
    """Why the output file (or folder) ``path`` cannot be written, as an error message.

    Missing parent folders are created when writing, so the nearest existing
    one must be a folder this process may write into.
    """
    target = Path(path)
    if target.exists() and target.is_dir() != folder:
        want, got = ("a folder", "file") if folder else ("a file", "folder")
        return f"{path}: expected {want}, got an existing {got}"
    place = target if folder and target.exists() else target.parent
    while not place.exists() and place != place.parent:
        place = place.parent
    if not place.is_dir():
        return f"{path}: cannot be written: {place} is not a folder"
    if not os.access(place, os.W_OK | os.X_OK):
        return f"{path}: cannot be written: no permission to write in {place}"
    return None


def _load_agents(refs: Iterable[str]) -> None:
    """Load each agent reference now: a failure is a one-line ValueError before any episode."""
    from nao_arena.agent import load_agent

    for ref in dict.fromkeys(refs):
        try:
            load_agent(ref)
        except ValueError:
            raise
        except Exception as exc:  # noqa: BLE001 - plug-in code may raise anything on import
            first = (str(exc).splitlines() or [""])[0]
            raise ValueError(
                f"agent {ref}: cannot be loaded ({type(exc).__name__}: {first})"
            ) from exc


def _no_display() -> str | None:
    """Why a window cannot open here (None if it can, as far as the environment tells)."""
    if os.environ.get("SDL_VIDEODRIVER", "").lower() in ("dummy", "offscreen"):
        return f"SDL_VIDEODRIVER={os.environ['SDL_VIDEODRIVER']} draws off-screen"
    if sys.platform.startswith(("darwin", "win", "cygwin")):
        return None
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        return "no display (DISPLAY and WAYLAND_DISPLAY are unset)"
    return None


def _terminate_as_interrupt(signum: int, frame: object) -> None:
    """SIGTERM handler: stop a trial like Ctrl-C (workers stopped, finished episodes kept)."""
    raise KeyboardInterrupt
