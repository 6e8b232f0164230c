"""Running a trial: the results folder (lock, settings check), the episodes of the grid
in order on a backend with resume, the progress line, then the results files."""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import MISSING, asdict
from pathlib import Path
from typing import Any, TextIO

from nao_arena.agent import load_agent
from nao_arena.atomic import atomic_write_text
from nao_arena.backends import make_backend
from nao_arena.trials.config import (
    FREE_SETTINGS,
    EpisodeTask,
    TrialConfig,
    TrialResult,
    grid_tasks,
    make_map,
    map_overrides,
)
from nao_arena.trials.episode import (
    compute_episode,
    done_record,
    robot_contacts,
    write_record,
)
from nao_arena.trials.results import build_results

__all__ = [
    "Progress",
    "ResultsFolderError",
    "check_folder",
    "folder_lock",
    "run_trial",
]


class Progress:
    """A progress line on a stream: episodes done/total, ETA, collisions so far.

    On a terminal the line is redrawn in place; otherwise a line is printed
    at most every ``interval`` seconds (and at the end).
    """

    def __init__(
        self, total: int, done: int = 0, stream: TextIO | None = None, interval: float = 5.0
    ) -> None:
        self.total, self.done, self.resumed = total, done, done
        self.collisions = 0
        self.failed = 0
        self.stream = stream
        self.interval = interval
        self.start = time.perf_counter()
        self._last = -math.inf
        self._tty = bool(stream is not None and getattr(stream, "isatty", lambda: False)())

    def count(self, record: Mapping[str, Any]) -> None:
        """Account for one finished episode (without redrawing)."""
        self.done += 1
        if record.get("error") is not None:
            self.failed += 1
        elif record.get("result") is not None:
            self.collisions += robot_contacts(record["result"])

    def update(self, record: Mapping[str, Any]) -> None:
        """Account for one finished episode and redraw."""
        self.count(record)
        self.show()

    def line(self) -> str:
        elapsed = time.perf_counter() - self.start
        ran = self.done - self.resumed
        left = self.total - self.done
        eta = f"{_duration(elapsed / ran * left)}" if ran else "?"
        text = (
            f"episodes {self.done}/{self.total}  elapsed {_duration(elapsed)}  ETA {eta}"
            f"  collisions {self.collisions}"
        )
        if self.failed:
            text += f"  failed {self.failed}"
        return text

    def show(self, final: bool = False) -> None:
        if self.stream is None:
            return
        now = time.perf_counter()
        if self._tty:
            self.stream.write("\r\033[K" + self.line() + ("\n" if final else ""))
        elif final or now - self._last >= self.interval:
            self.stream.write(self.line() + "\n")
        else:
            return
        self._last = now
        self.stream.flush()


def _duration(seconds: float) -> str:
    s = int(round(seconds))
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}h{m:02d}m{s:02d}s" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


# --------------------------------------------------------------------------- the trial


def _validate(config: TrialConfig) -> dict[str, dict[str, Any]]:
    """Check maps, overrides and agents before running anything; per-map overrides."""
    per_map = map_overrides(config.maps, config.overrides)
    for m in config.maps:
        make_map(
            m, 0, per_map[m], config.time_limit, trusted=config.trust_map, agents=config.agent_refs
        )
    for a in config.agents:
        load_agent(config.reference(a))
    return per_map


class ResultsFolderError(ValueError):
    """The output folder is in use by another trial, or holds a trial with other settings."""


@contextlib.contextmanager
def folder_lock(out: Path) -> Iterator[None]:
    """Hold the exclusive lock ``out/.lock`` (the holder's pid inside) while the block runs.

    Raises :class:`ResultsFolderError` at once, naming the folder and the holder's pid,
    if another trial holds it.
    """
    with open(Path(out) / ".lock", "a+", encoding="utf-8") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "?"
            raise ResultsFolderError(
                f"results folder {out} is in use by another trial (pid {holder}); wait for "
                "it to end or choose another --out"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"{os.getpid()}\n")
        fh.flush()
        yield  # closing the file releases the lock


def _settings(config: TrialConfig) -> dict[str, Any]:
    """The trial's settings as ``trial.json`` holds them (JSON types)."""
    settings = {k: v for k, v in asdict(config).items() if k != "out"}
    settings.update(
        maps=list(config.maps),
        agents=list(config.agents),
        overrides=dict(config.overrides),
        agent_refs=dict(config.agent_refs),
    )
    return json.loads(json.dumps(settings))


def _setting_default(name: str) -> Any:
    f = TrialConfig.__dataclass_fields__.get(name)
    if f is None:
        return None
    if f.default_factory is not MISSING:
        return f.default_factory()
    return None if f.default is MISSING else f.default


def check_folder(out: Path, settings: Mapping[str, Any]) -> None:
    """Refuse (:class:`ResultsFolderError`) a trial whose settings differ from the
    ``trial.json`` already in ``out``, except :data:`FREE_SETTINGS`, the order of maps
    and agents, and more episodes; a setting the file lacks counts as its default."""
    path = Path(out) / "trial.json"
    if not path.exists():
        return
    try:
        before = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(before, dict):
            raise ValueError("not a JSON object")
    except (OSError, ValueError) as exc:
        raise ResultsFolderError(
            f"{path}: cannot read it ({exc}); expected the settings of "
            f"the trial in {out}: repair it or choose another --out"
        ) from None
    diffs = []
    for key, now in settings.items():
        if key in FREE_SETTINGS:
            continue
        was = before.get(key, _setting_default(key))
        if key == "episodes":
            if isinstance(was, int) and now < was:
                diffs.append(f"episodes {now} < {was} (episodes may only grow)")
        elif key in ("maps", "agents"):
            if sorted(map(str, was or [])) != sorted(now):
                diffs.append(f"{key} {was} there, {now} now")
        elif was != now:
            diffs.append(f"{key} {was!r} there, {now!r} now")
    if diffs:
        raise ResultsFolderError(
            f"results folder {out} holds another trial ({'; '.join(diffs)}): choose another "
            "--out, or repeat its settings (only workers, backend, address, csv and "
            "retry_failed may change, and episodes may grow)"
        )


def run_trial(
    config: TrialConfig,
    progress: TextIO | None = sys.stderr,
    on_episode: Callable[[dict[str, Any]], None] | None = None,
) -> TrialResult:
    """Run the episodes of the grid not done yet, then (re)build the results files.

    progress: stream for the progress line (None: silent); on_episode: called
    in this process with each new episode's record. The episodes run on
    ``config.backend``; their records come back to this process, which
    writes each episode's file as soon as it arrives. Raises ValueError /
    :class:`~nao_arena.maps.MapError` for unknown maps or agents and bad
    overrides, :class:`~nao_arena.backends.BackendError` if the backend is
    not installed, and :class:`ResultsFolderError` if the output folder is in
    use or holds a trial with other settings, before any episode runs.
    """
    per_map = _validate(config)
    backend = make_backend(config.backend, config.workers, config.address)
    out = Path(config.out)
    (out / "episodes").mkdir(parents=True, exist_ok=True)
    settings = _settings(config)
    with folder_lock(out):
        check_folder(out, settings)
        atomic_write_text(out / "trial.json", json.dumps(settings, indent=2) + "\n")
        return _run_locked(config, per_map, backend, progress, on_episode)


def _run_locked(
    config: TrialConfig,
    per_map: dict[str, dict[str, Any]],
    backend: Any,
    progress: TextIO | None,
    on_episode: Callable[[dict[str, Any]], None] | None,
) -> TrialResult:
    """:func:`run_trial` once the output folder is locked and checked."""
    out = Path(config.out)
    tasks = grid_tasks(config, per_map)
    bar = Progress(len(tasks), 0, progress)
    todo = []
    for task in tasks:
        rec = done_record(task, config.retry_failed)
        if rec is None:
            todo.append(task)
        else:
            bar.count(rec)
    bar.resumed = bar.done
    if progress is not None and config.episodes > 1:
        for m in config.maps:
            if (
                "seed"
                not in make_map(
                    m, None, per_map[m], trusted=config.trust_map, agents=config.agent_refs
                ).parameters
            ):
                progress.write(
                    f"note: map {m} declares no seed parameter: its episodes "
                    "differ only by the agents' seeds\n"
                )
    if progress is not None and len(todo) < len(tasks):
        progress.write(
            f"resuming: {len(tasks) - len(todo)} of {len(tasks)} episodes "
            f"already in {out / 'episodes'}\n"
        )

    def finished(task: EpisodeTask, record: dict[str, Any]) -> None:
        write_record(task, record)
        bar.update(record)
        if on_episode is not None:
            on_episode(record)

    with backend:
        if todo:
            backend.prepare()
            bar.start = time.perf_counter()  # the ETA leaves out starting the backend
        backend.run(compute_episode, todo, finished)
    bar.show(final=True)
    summary, files = build_results(config, tasks)
    return TrialResult(summary, len(todo), len(tasks) - len(todo), files)
