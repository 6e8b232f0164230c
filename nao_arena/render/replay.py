"""Replaying an episode log in the viewer: the recorded states, no physics, no agents.

:class:`ReplayArena` answers what :class:`~nao_arena.render.viewer.Viewer`
reads of a live :class:`~nao_arena.arena.Arena` (state, commands, sensing,
statistics, map, traffic lanes, goals, agent names, and through
:meth:`ReplayArena.panel_agent` what the acceleration panel shows of each
robot's agent), for one row of an :class:`~nao_arena.episode_log.EpisodeLog`
at a time; the same drawing code draws both. :class:`Replayer` draws rows in
any order: consecutive rows like the live viewer, a jump after forgetting the
trails and taking in the rows of the last ``trail_seconds`` first, so that a
frame is the live frame of the same step, pixel for pixel, except the HUD's
steps-per-second line, which measures wall-clock speed (a still frame shows
``--``).

- :func:`write_frame`: one frame as a PNG (``nao-arena replay LOG --at T --png FILE``);
- :func:`record_replay`: a GIF or MP4 of a time span (``--render gif|mp4 --out FILE``);
- :func:`play`: the window, with the keys of :data:`KEYS`.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from numpy.typing import NDArray

from nao_arena.atomic import atomic_write_with
from nao_arena.episode_log import EpisodeLog
from nao_arena.render.recording import Recorder
from nao_arena.render.replay_arena import ReplayArena
from nao_arena.render.replay_arena import ReplayStats as ReplayStats
from nao_arena.render.viewer import Viewer, ViewerOptions

__all__ = ["KEYS", "ReplayArena", "Replayer", "play", "record_replay", "robot_index", "write_frame"]

KEYS = """\
space: play / pause        right, left: one step forward, back
up, down: faster, slower   page up, page down: 10 s forward, back   home, end: start, end
n, p: next, previous contact   e: explain the next contact (any key: back)
tab: next robot            digits then enter: go to that time (s)   q, escape: quit"""
"""The replay window's keys."""


class Replayer:
    """Draws the rows of a log with one :class:`Viewer` (see the module docstring)."""

    def __init__(
        self, log: EpisodeLog, viewer: Viewer | None = None, options: ViewerOptions | None = None
    ) -> None:
        self.log = log
        self.viewer = viewer or Viewer(options)
        self.arena = ReplayArena(log)
        self._last: tuple[int, bool] | None = None
        self._controlled = self.arena.controlled

    def frame(self, step: int, selected: int = 0, decision: bool = False) -> NDArray[np.uint8]:
        """Draw row ``step`` (see :meth:`ReplayArena.seek`); returns the frame (H, W, 3)."""
        last = self._last
        if not (
            last is not None and not last[1] and not decision and step in (last[0], last[0] + 1)
        ):
            # a jump: the trails of the last trail_seconds, without a steps/s estimate
            self.viewer.forget()
            keep = max(2, int(self.viewer.options.trail_seconds / self.log.dt) + 1)
            for j in range(max(0, step - keep + 1), step):
                self.arena.seek(j, steps=step)
                self.viewer.track(self.arena)
        self.arena.seek(step, decision=decision)
        self._last = (step, decision)
        return self.viewer.draw(self.arena, selected=selected, controlled=self._controlled)


def robot_index(log: EpisodeLog, robot: int | str | None) -> int:
    """A robot's index (robot order) from its index or name; ValueError naming the robots."""
    names = [r.name for r in log.robots]
    if robot is None:
        return 0
    if isinstance(robot, str) and not robot.isdigit():
        if robot not in names:
            raise ValueError(f"robot {robot!r}: not in the log (robots: {', '.join(names)})")
        return names.index(robot)
    k = int(robot)
    if not 0 <= k < len(names):
        raise ValueError(
            f"robot {k}: expected an index 0 .. {len(names) - 1} or a name ({', '.join(names)})"
        )
    return k


def _check_time(log: EpisodeLog, t: float, what: str) -> None:
    end = float(log.time[-1])
    if not (0.0 <= t <= end + 1e-9):
        raise ValueError(f"{what}: expected a time within the episode, 0 .. {end:g} s, got {t:g}")


def _write_png(path: Path, frame: NDArray[np.uint8]) -> Path:
    import imageio.v2 as iio

    atomic_write_with(path, lambda tmp: iio.imwrite(tmp, frame, format="PNG"), suffix=".tmp.png")
    return path


def write_frame(
    log: EpisodeLog,
    path: str | Path,
    at: float,
    selected: int = 0,
    options: ViewerOptions | None = None,
) -> Path:
    """Write the frame of the last row at or before time ``at`` (s) as a PNG, atomically."""
    _check_time(log, at, "--at")
    frame = Replayer(log, options=options).frame(log.step_at(at), selected)
    return _write_png(Path(path), frame)


def record_replay(
    log: EpisodeLog,
    path: str | Path,
    fps: float | None = None,
    start: float = 0.0,
    end: float | None = None,
    selected: int = 0,
    options: ViewerOptions | None = None,
) -> Path:
    """Record the rows from ``start`` to ``end`` (s; default the last) as a GIF or MP4
    (by the suffix), atomically. fps: frames per second of simulated time (default
    1 / dt: one frame per row); frame k shows the last row at or before start + k / fps."""
    end = float(log.time[-1]) if end is None else end
    _check_time(log, start, "--from")
    _check_time(log, end, "--to")
    if end < start:
        raise ValueError(f"--to: expected a time >= --from ({start:g} s), got {end:g}")
    rate = 1.0 / log.dt if fps is None else float(fps)
    replayer = Replayer(log, options=options)
    with Recorder(path, rate) as rec:
        k, frame, shown = 0, None, -1
        while start + k / rate <= end + 1e-9:
            step = log.step_at(start + k / rate)
            if step != shown:
                frame = replayer.frame(step, selected)
                shown = step
            assert frame is not None
            rec.add(frame)
            k += 1
    return Path(path)


def _contact_rows(log: EpisodeLog) -> list[int]:
    return [int(s) for s in log.contact_steps]


def play(
    log: EpisodeLog,
    selected: int = 0,
    start: float = 0.0,
    options: ViewerOptions | None = None,
    explain: Callable[[int], tuple[str, NDArray[np.uint8]]] | None = None,
    max_frames: int | None = None,
    out: TextIO = sys.stdout,
) -> int:
    """Show the log in a window (see :data:`KEYS`) until it is closed; returns the row
    shown last. explain(K) -> (text, picture) of contact K (1-based) for the ``e`` key.
    max_frames: stop after that many frames (None: when the window closes)."""
    import pygame

    _check_time(log, start, "--at")
    viewer = Viewer(options, human=True)
    replayer = Replayer(log, viewer=viewer)
    n_robots = max(len(log.robots), 1)
    step = log.step_at(start)
    last = log.n_steps - 1
    playing, speed, ahead, typed = True, 1.0, 0.0, ""
    overlay: Any = None
    jump = int(round(10.0 / log.dt))
    contacts = _contact_rows(log)
    clock = pygame.time.Clock()
    frames = 0
    print(KEYS, file=out)
    try:
        while max_frames is None or frames < max_frames:
            quit_now = False
            for event in pygame.event.get():
                if event.type == pygame.QUIT:
                    quit_now = True
                if event.type != pygame.KEYDOWN:
                    continue
                if overlay is not None:
                    overlay = None
                    continue
                key = event.key
                if key in (pygame.K_q,) or (key == pygame.K_ESCAPE and not typed):
                    quit_now = True
                elif key == pygame.K_ESCAPE:
                    typed = ""
                elif key == pygame.K_SPACE:
                    playing = not playing
                elif key in (pygame.K_RIGHT, pygame.K_LEFT):
                    playing = False
                    step += 1 if key == pygame.K_RIGHT else -1
                elif key == pygame.K_UP:
                    speed = min(speed * 2.0, 64.0)
                elif key == pygame.K_DOWN:
                    speed = max(speed / 2.0, 1.0 / 16.0)
                elif key in (pygame.K_PAGEUP, pygame.K_PAGEDOWN):
                    step += jump if key == pygame.K_PAGEUP else -jump
                elif key == pygame.K_HOME:
                    step = 0
                elif key == pygame.K_END:
                    step = last
                elif key in (pygame.K_n, pygame.K_p):
                    after = (
                        [c for c in contacts if c > step]
                        if key == pygame.K_n
                        else [c for c in contacts if c < step]
                    )
                    if after:
                        step = after[0] if key == pygame.K_n else after[-1]
                        playing = False
                elif key == pygame.K_e and explain is not None and contacts:
                    number = next(
                        (i + 1 for i, c in enumerate(contacts) if c >= step), len(contacts)
                    )
                    text, picture = explain(number)
                    print(text, file=out, flush=True)
                    overlay = picture
                    step = max(contacts[number - 1] - 1, 0)
                    playing = False
                elif key == pygame.K_TAB:
                    selected = (selected + 1) % n_robots
                elif key == pygame.K_RETURN and typed:
                    try:
                        step = log.step_at(float(typed))
                    except ValueError:
                        pass
                    typed = ""
                    playing = False
                elif key == pygame.K_BACKSPACE:
                    typed = typed[:-1]
                elif event.unicode and event.unicode in "0123456789.":
                    typed += event.unicode
            if quit_now:
                break
            step = int(np.clip(step, 0, last))
            if overlay is not None:
                _show_picture(overlay)
            else:
                replayer.frame(step, selected)
                state = "playing" if playing else "paused"
                pygame.display.set_caption(
                    f"nao_arena replay: t = {log.time[step]:.1f} s, step {step}/{last}, {state}"
                    f", x{speed:g}" + (f", go to {typed} s" if typed else "")
                )
                if playing:
                    ahead += speed
                    move = int(ahead)
                    ahead -= move
                    step = min(step + move, last)
                    if step == last:
                        playing = False
            frames += 1
            clock.tick(1.0 / log.dt)
    finally:
        viewer.close()
    return step


def _show_picture(picture: NDArray[np.uint8]) -> None:
    """Show an RGB picture (H, W, 3) in the window, scaled to fit."""
    import pygame

    window = pygame.display.get_surface()
    if window is None:
        return
    surf = pygame.surfarray.make_surface(np.ascontiguousarray(picture.transpose(1, 0, 2)))
    w, h = window.get_size()
    scale = min(w / surf.get_width(), h / surf.get_height())
    size = (int(surf.get_width() * scale), int(surf.get_height() * scale))
    window.fill((255, 255, 255))
    window.blit(pygame.transform.smoothscale(surf, size), ((w - size[0]) // 2, (h - size[1]) // 2))
    pygame.display.flip()
